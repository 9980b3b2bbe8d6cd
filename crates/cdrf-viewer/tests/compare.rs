//! The `compare` command end to end: one small case, its JSON, Markdown, figure and results page
//! (the comparison itself is cdrf-eval's, tested there).

use std::process::Command;

use cdrf_eval::{ComparedModel, FigureLayout};

#[test]
fn compare_command_writes_json_markdown_a_figure_and_the_results_page() {
    let dir = tempfile::tempdir().unwrap();
    let runtime = dir.path().join("xdg-runtime");
    std::fs::create_dir_all(&runtime).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_cdrf-viewer"))
        .args([
            "compare",
            "--case",
            "sphere_r35",
            "--size",
            "128",
            "--out",
            "out",
            "--results",
            "docs/results.md",
        ])
        .current_dir(dir.path())
        .env("XDG_RUNTIME_DIR", &runtime)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("| lit side |"), "{stdout}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("out/compare.json")).unwrap())
            .unwrap();
    assert_eq!(json[0]["name"], "sphere_r35");
    assert_eq!(json[0]["regions"][1]["region"], "lit");
    assert_eq!(json[0]["regions"][1]["models"][0]["model"], "measured");
    assert!(
        json[0]["regions"][1]["models"][0]["relative_rmse"]
            .as_f64()
            .is_some()
    );
    let figure = image::open(dir.path().join("out/sphere_r35.png")).unwrap();
    // Reference and one column per model, two rows of panels; the labels (column labels on
    // top, row labels on the left, the colour key at the bottom) add margins around them.
    let columns = 1 + ComparedModel::ALL.len() as u32;
    let layout = FigureLayout::new(128, 128, ComparedModel::ALL.len());
    assert_eq!(
        (
            figure.width() - layout.label_width_px,
            figure.height() - layout.header_height_px - layout.footer_height_px
        ),
        (columns * 128, 2 * 128)
    );
    // The labels are drawn: the header above the reference holds text (bright pixels).
    let figure = figure.to_rgb8();
    let bright = (0..layout.header_height_px)
        .flat_map(|y| (layout.label_width_px..layout.label_width_px + 128).map(move |x| (x, y)))
        .filter(|&(x, y)| figure.get_pixel(x, y)[0] > 128)
        .count();
    assert!(bright > 20, "no column label above the reference");
    assert!(dir.path().join("out/compare.md").is_file());
    // The results page links the figures relative to itself and carries the tables.
    let page = std::fs::read_to_string(dir.path().join("docs/results.md")).unwrap();
    assert!(page.contains("](../out/sphere_r35.png)"), "{page}");
    assert!(page.contains("| lit side |"), "{page}");
    assert!(
        page.contains("cdrf-viewer compare --case sphere_r35 --size 128"),
        "{page}"
    );

    let output = Command::new(env!("CARGO_BIN_EXE_cdrf-viewer"))
        .args(["compare", "--case", "teapot", "--out", "out2"])
        .current_dir(dir.path())
        .env("XDG_RUNTIME_DIR", &runtime)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(stderr.contains("no case named teapot"), "{stderr}");
    assert!(!dir.path().join("out2").exists());
}
