//! Every shader of the passes parses and validates with naga (the shader compiler wgpu uses),
//! without a GPU, as the pipelines compile it (composed with the generated constants: see
//! `cdrf_render::shaders`): shader errors show up in `cargo test` with naga's diagnostics
//! instead of at pipeline creation.

use std::path::{Path, PathBuf};

use naga::valid::{Capabilities, ValidationFlags, Validator};

/// This crate's shader folder.
const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// Parses and validates one composed shader; `Err` holds naga's diagnostics, naming it.
fn validate(name: &str, source: &str) -> Result<naga::Module, String> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| {
        format!(
            "{name}: parse error\n{}",
            e.emit_to_string_with_path(source, name)
        )
    })?;
    Validator::new(ValidationFlags::all(), Capabilities::default())
        .validate(&module)
        .map_err(|e| {
            format!(
                "{name}: validation error\n{}",
                e.emit_to_string_with_path(source, name)
            )
        })?;
    if module.entry_points.is_empty() {
        return Err(format!(
            "{name}: no entry point (@vertex, @fragment or @compute)"
        ));
    }
    Ok(module)
}

/// The `*.wgsl` file names directly in `dir`, sorted.
fn wgsl_files(dir: &Path) -> Vec<String> {
    let entries = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list shader folder {}: {e}", dir.display()));
    let mut files: Vec<String> = entries
        .map(|entry| entry.expect("shader folder entry").path())
        .filter(|path: &PathBuf| path.extension().is_some_and(|ext| ext == "wgsl"))
        .map(|path| path.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    files.sort();
    files
}

#[test]
fn every_shader_parses_and_validates() {
    let shaders = [
        (
            "shaders/cdrf.wgsl",
            cdrf_render::shaders::shading_shader_source(),
        ),
        (
            "shaders/shadow.wgsl",
            cdrf_render::shaders::shadow_shader_source(),
        ),
        (
            "shaders/subsurface_reduce.wgsl",
            cdrf_render::shaders::subsurface_reduce_shader_source(),
        ),
    ];
    let mut failures = Vec::new();
    for (name, source) in &shaders {
        match validate(name, source) {
            Ok(module) => {
                let entry_points: Vec<String> = module
                    .entry_points
                    .iter()
                    .map(|ep| format!("{:?} {}", ep.stage, ep.name))
                    .collect();
                println!("validated {name}: {}", entry_points.join(", "));
            }
            Err(report) => failures.push(report),
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} shader(s) failed:\n\n{}",
        failures.len(),
        shaders.len(),
        failures.join("\n")
    );
}

/// Every WGSL file in the crate's folder is one the shaders above are composed of, so none is
/// left out of validation.
#[test]
fn the_shader_folder_holds_exactly_the_composed_files() {
    assert_eq!(
        wgsl_files(Path::new(SHADER_DIR)),
        [
            "cdrf.wgsl",
            "common.wgsl",
            "shadow.wgsl",
            "subsurface_reduce.wgsl"
        ],
        "a WGSL file was added to or removed from {SHADER_DIR}: compose it in src/shaders.rs \
         and validate it here"
    );
}
