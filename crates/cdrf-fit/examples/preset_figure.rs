//! The figure of docs/presets.md: f(θ) of the bundled measured wax table, the built-in wax
//! preset (simulated spheres) and the dipole preset at three radii, red channel, log scale.
//!
//! `cargo run --release -p cdrf-fit --example preset_figure -- docs/images/preset-vs-measured.svg`

use cdrf_core::lut::{CdrfLut, Filter};
use cdrf_core::lut_file::read_lut;
use cdrf_fit::plot::{LinePlot, LineStyle, Series};
use cdrf_fit::preset::{Preset, PresetSettings};

fn main() -> anyhow::Result<()> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "preset-vs-measured.svg".into());
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data");
    let measured = read_lut(data.join("wax-fit/measured.exr"))?;
    let simulated = cdrf_core::presets::lut("wax")?;
    let wax = Preset::named("wax")?;
    let dipole = wax.build_lut(&PresetSettings::default())?;
    let curve = |lut: &CdrfLut, radius_mm: f32| -> Vec<(f32, f32)> {
        (0..=180)
            .map(|degrees| {
                let theta = (degrees as f32).to_radians();
                (
                    degrees as f32,
                    lut.sample(1.0 / radius_mm, theta, Filter::Bilinear).x,
                )
            })
            .collect()
    };
    let mut plot = LinePlot::new(
        "wax, red channel: measured table vs presets",
        "θ between normal and light (degrees)",
        "f(θ; κ) = π·L/E",
    );
    plot.log_y = true;
    plot.y_range = Some((1e-4, 1.0));
    for (radius_mm, color) in [
        (5.0, [200, 40, 40]),
        (15.0, [40, 120, 200]),
        (50.0, [40, 160, 60]),
    ] {
        plot.series.push(Series::new(
            format!("measured, r = {radius_mm} mm"),
            color,
            curve(&measured, radius_mm),
        ));
        plot.series.push(
            Series::new(
                format!("simulated preset, r = {radius_mm} mm"),
                color,
                curve(simulated, radius_mm),
            )
            .with_style(LineStyle::Dashed),
        );
        plot.series.push(
            Series::new(
                format!("dipole preset, r = {radius_mm} mm"),
                color,
                curve(&dipole, radius_mm),
            )
            .with_style(LineStyle::Markers),
        );
    }
    std::fs::write(&out, plot.to_svg())?;
    println!("wrote {out}");
    Ok(())
}
