//! Every WGSL shader in the workspace's `shaders/` folder parses and validates with naga (the
//! shader compiler wgpu uses), without a GPU: shader errors show up in `cargo test` with naga's
//! diagnostics instead of at pipeline creation.

use std::path::{Path, PathBuf};

use naga::valid::{Capabilities, ValidationFlags, Validator};

/// The workspace's shader folder.
const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shaders");

/// The `*.wgsl` files directly in `dir`, sorted.
fn wgsl_files(dir: &Path) -> Vec<PathBuf> {
    let entries = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list shader folder {}: {e}", dir.display()));
    let mut files: Vec<PathBuf> = entries
        .map(|entry| entry.expect("shader folder entry").path())
        .filter(|path| path.is_file() && path.extension().is_some_and(|ext| ext == "wgsl"))
        .collect();
    files.sort();
    files
}

/// `shaders/NAME.wgsl`: how files are named in messages (relative to the workspace root).
fn label(path: &Path) -> String {
    let folder = path.parent().and_then(Path::file_name).unwrap_or_default();
    let file = path.file_name().unwrap_or_default();
    Path::new(folder).join(file).display().to_string()
}

/// Parses and validates one WGSL file; `Err` holds naga's diagnostics, naming the file.
fn validate(path: &Path) -> Result<naga::Module, String> {
    let name = label(path);
    let source = std::fs::read_to_string(path).map_err(|e| format!("{name}: cannot read: {e}"))?;
    let module = naga::front::wgsl::parse_str(&source).map_err(|e| {
        format!(
            "{name}: parse error\n{}",
            e.emit_to_string_with_path(&source, &name)
        )
    })?;
    Validator::new(ValidationFlags::all(), Capabilities::default())
        .validate(&module)
        .map_err(|e| {
            format!(
                "{name}: validation error\n{}",
                e.emit_to_string_with_path(&source, &name)
            )
        })?;
    if module.entry_points.is_empty() {
        return Err(format!(
            "{name}: no entry point (@vertex, @fragment or @compute)"
        ));
    }
    Ok(module)
}

/// Checks every file, reporting all failures at once.
fn validate_all(dir: &Path) {
    let dir = dir
        .canonicalize()
        .unwrap_or_else(|e| panic!("shader folder {} is missing: {e}", dir.display()));
    let files = wgsl_files(&dir);
    assert!(
        !files.is_empty(),
        "no *.wgsl files in {}: the shader folder is missing or empty",
        dir.display()
    );
    let mut failures = Vec::new();
    for path in &files {
        match validate(path) {
            Ok(module) => {
                let entry_points: Vec<String> = module
                    .entry_points
                    .iter()
                    .map(|ep| format!("{:?} {}", ep.stage, ep.name))
                    .collect();
                println!("validated {}: {}", label(path), entry_points.join(", "));
            }
            Err(report) => {
                println!("FAILED {}", label(path));
                failures.push(report);
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} shader(s) failed:\n\n{}",
        failures.len(),
        files.len(),
        failures.join("\n")
    );
}

#[test]
fn every_wgsl_shader_parses_and_validates() {
    validate_all(Path::new(SHADER_DIR));
}
