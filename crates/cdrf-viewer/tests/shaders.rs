//! The viewer's composite shader validates with naga, and the workspace's `shaders/` folder
//! (links for browsing) points at exactly the WGSL files the crates compile.

use std::path::{Path, PathBuf};

use naga::valid::{Capabilities, ValidationFlags, Validator};

#[test]
fn the_composite_shader_parses_and_validates() {
    let name = "crates/cdrf-viewer/shaders/viewer_composite.wgsl";
    let source = cdrf_viewer::gpu::COMPOSITE_SHADER;
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string_with_path(source, name)));
    Validator::new(ValidationFlags::all(), Capabilities::default())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string_with_path(source, name)));
    assert!(!module.entry_points.is_empty(), "{name}: no entry point");
}

fn wgsl_in(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.expect("folder entry").path())
        .filter(|path| path.extension().is_some_and(|ext| ext == "wgsl"))
        .collect();
    files.sort();
    files
}

#[test]
fn the_workspace_shader_folder_links_every_crate_shader() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut crate_files: Vec<PathBuf> =
        ["crates/cdrf-render/shaders", "crates/cdrf-viewer/shaders"]
            .iter()
            .flat_map(|dir| wgsl_in(&root.join(dir)))
            .map(|path| path.canonicalize().expect("crate shader"))
            .collect();
    crate_files.sort();
    let mut linked: Vec<PathBuf> = wgsl_in(&root.join("shaders"))
        .into_iter()
        .map(|path| {
            path.canonicalize()
                .unwrap_or_else(|e| panic!("{}: a broken link ({e})", path.display()))
        })
        .collect();
    linked.sort();
    assert_eq!(
        linked, crate_files,
        "shaders/ must link each crate's WGSL once"
    );
}
