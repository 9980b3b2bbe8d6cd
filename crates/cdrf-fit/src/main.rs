//! `cdrf-fit DIR --out OUTDIR`: a measured CDRF from a folder of sphere photographs.
//!
//! Reads `DIR/cdrf-dataset.toml`, fits, and writes `measured.exr` (with the material's
//! translucency when the shadow sides allow a transmission fit, and the diffusion profile),
//! `gaussian.toml`,
//! `report.json` and plots into `OUTDIR` (see `cdrf_fit::outputs`). The input folder is never
//! written to.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use cdrf_fit::curves::ViewModel;
use cdrf_fit::dataset::Dataset;
use cdrf_fit::fit::Progress;
use cdrf_fit::outputs::{check_output_dir, view_model_name, write_outputs};
use cdrf_fit::{FitOptions, fit_dataset};
use clap::{Parser, ValueEnum};

/// The most θ columns accepted (0.05° apart).
const MAX_THETA_COUNT: u32 = 3601;
/// The most curvature rows accepted.
const MAX_CURVATURE_COUNT: u32 = 1024;
use indicatif::{ProgressBar, ProgressStyle};

/// Fit a measured curvature-dependent reflectance function (CDRF) look-up table to
/// photographs of spheres of several radii lit by one directional light.
///
/// DIR must hold a manifest, cdrf-dataset.toml, naming the images, their sphere radii (mm),
/// the camera and the light (see the README). OUTDIR receives measured.exr (the LUT),
/// gaussian.toml (Kubo's Gaussian CDRF fitted to the same photos), report.json and plots.
#[derive(Debug, Parser)]
#[command(name = "cdrf-fit", version)]
struct Args {
    /// Data set folder containing cdrf-dataset.toml.
    dir: PathBuf,
    /// Output folder (created if missing; files in it are replaced atomically).
    #[arg(long, value_name = "OUTDIR")]
    out: PathBuf,
    /// View correction: the poster's g(φ) shared by all radii, or g(φ) times a smooth
    /// θ-dependent correction (lower residual on translucent materials; taken only where the
    /// lamp is within about 15° of 90° to the camera, else g(φ) alone).
    #[arg(long, value_enum, default_value_t = ViewModelArg::ThetaPhi)]
    view_model: ViewModelArg,
    /// Columns of the table over θ ∈ [0°, 180°] (361 = 0.5° apart), 19…3601.
    #[arg(long, default_value_t = FitOptions::default().curves.theta_count as u32,
          value_parser = clap::value_parser!(u32).range(19..=i64::from(MAX_THETA_COUNT)))]
    theta_count: u32,
    /// Rows of the table over the measured curvature range, 2…1024.
    #[arg(long, default_value_t = FitOptions::default().curvature_count as u32,
          value_parser = clap::value_parser!(u32).range(2..=i64::from(MAX_CURVATURE_COUNT)))]
    curvature_count: u32,
    /// Print nothing but errors (and the --json summary).
    #[arg(long, short)]
    quiet: bool,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum ViewModelArg {
    /// g(φ) only (the poster).
    Phi,
    /// g(φ)·c(θ, φ).
    ThetaPhi,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            // The error and its causes, joined with ": ".
            eprintln!("error: {error:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> anyhow::Result<()> {
    let mut options = FitOptions::default();
    options.curves.theta_count = args.theta_count as usize;
    options.curves.view_model = match args.view_model {
        ViewModelArg::Phi => ViewModel::Phi,
        ViewModelArg::ThetaPhi => ViewModel::ThetaPhi,
    };
    options.curvature_count = args.curvature_count as usize;

    let dataset = Dataset::load(&args.dir)?;
    check_output_dir(&dataset.dir, &args.out)?;
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        let bar = ProgressBar::new(dataset.spheres.len() as u64);
        bar.set_style(
            ProgressStyle::with_template("{bar:30} {pos}/{len} spheres {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    };
    if dataset.spheres.len() == 1 && !args.quiet {
        eprintln!(
            "note: one sphere: the table can only be that sphere's curve at every curvature (no curvature dependence); use several radii for a CDRF"
        );
    }
    let fit = fit_dataset(&dataset, &options, |progress| match progress {
        Progress::SphereSampled { index, .. } => {
            bar.set_position(index as u64 + 1);
            bar.set_message(dataset.spheres[index].image_name.clone());
        }
        Progress::Fitting => bar.set_message("fitting"),
    })
    .with_context(|| format!("fitting {}", dataset.manifest.display()))?;
    bar.finish_and_clear();

    let (written, report) = write_outputs(&fit, &dataset.dir, &args.out)
        .with_context(|| format!("writing outputs to {}", args.out.display()))?;

    if !args.quiet {
        let sigma = fit.gaussian.model.sigma_mm();
        eprintln!(
            "fitted {} spheres (r = {}) in {:.2} s ({:.2} s decoding); view model {}",
            fit.spheres.len(),
            fit.spheres
                .iter()
                .map(|s| format!("{}", s.radius_mm))
                .collect::<Vec<_>>()
                .join(", "),
            fit.timings.total_s,
            fit.timings.decode_s,
            view_model_name(fit.curves.chosen.settings.view_model),
        );
        eprintln!(
            "radius  measured error  Gaussian error   (mean relative, lit + terminator, 8×8 px blocks)"
        );
        for (sphere, errors) in fit.spheres.iter().zip(&fit.errors) {
            eprintln!(
                "{:>4} mm  {:>12.2} %  {:>12.2} %",
                sphere.radius_mm,
                100.0 * errors.measured.lit_and_terminator.mean_relative_error,
                100.0 * errors.gaussian.lit_and_terminator.mean_relative_error,
            );
        }
        if let Some(light) = &fit.light {
            match light.strength_from {
                "relative" => eprintln!(
                    "warning: the light's strength is unknown (no irradiance / intensity and no [calibration] sphere): the table is relative, its scale arbitrary"
                ),
                "calibrated" => {
                    let s = light.strength;
                    eprintln!(
                        "light calibrated from the reference sphere: {} = [{:.4e}, {:.4e}, {:.4e}]",
                        if light.source == "lamp" {
                            "intensity"
                        } else {
                            "irradiance"
                        },
                        s[0],
                        s[1],
                        s[2]
                    );
                }
                _ => {}
            }
        }
        for sphere in &fit.spheres {
            if sphere.dropped.highlight > 0 {
                eprintln!(
                    "{}: {} pixels of a residual highlight left out (imperfect cross-polarisation)",
                    sphere.image, sphere.dropped.highlight
                );
            }
        }
        for (sphere, entry) in report.spheres.iter().zip(&fit.spheres) {
            if !sphere.room_dominated_theta_deg.is_empty() {
                eprintln!(
                    "warning: r = {} mm: at theta {} deg the flagged frame carried more than {:.0} times the lamp's light; a flag leaves part of the room's (and lit neighbours') light, a bias there the band does not count (darken the room: docs/captures.md)",
                    entry.radius_mm,
                    degree_ranges(&sphere.room_dominated_theta_deg),
                    cdrf_fit::fit::ROOM_DOMINATED
                );
            }
            // The last 10° before the anti-light pole are silhouette pixels on every photograph.
            if let Some(from) = sphere.continued_from_theta_deg
                && from < 170.0
            {
                eprintln!(
                    "note: r = {} mm: from theta {from:.1} deg on, the table holds the diffusion profile's fall-off, matched to the {:.0} deg before (the photograph's 95 % band was wider than ±{:.0} % there, or nothing was measured)",
                    entry.radius_mm,
                    cdrf_fit::tails::MATCH_DEG,
                    100.0 * cdrf_fit::tails::CONTINUE_BAND
                );
            }
            if !sphere.noisy_theta_deg.is_empty() {
                eprintln!(
                    "warning: r = {} mm: too uncertain to trust at theta {} deg (95 % band, noise and file codes, wider than ±{:.0} %; see report.json confidence_95)",
                    entry.radius_mm,
                    degree_ranges(&sphere.noisy_theta_deg),
                    100.0 * cdrf_fit::fit::NOISY_BAND
                );
            }
        }
        let deep_deg = report.diffusion.measured_deep_shadow_deg;
        if deep_deg < cdrf_fit::fit::DEEP_SHADOW_MIN_DEG {
            eprintln!(
                "warning: no sphere's shadow side is measured past theta {:.0} deg ({deep_deg:.1} deg at most, free of the room's light and inside the band): how far light travels in the material (the diffusion profile's long terms, which the renderer's subsurface terms read) is a guess; photograph the spheres one at a time, in a dark room for the largest (docs/captures.md; an opaque material has none to measure)",
                cdrf_fit::fit::DEEP_SHADOW_FROM_DEG
            );
        }
        eprintln!(
            "Gaussian CDRF: sigma_mm = [{:.2}, {:.2}, {:.2}]",
            sigma[0], sigma[1], sigma[2]
        );
        match &fit.transmission {
            Ok(transmission) => {
                let (a, l) = (
                    transmission.profile.amplitude,
                    transmission.profile.length_mm,
                );
                eprintln!(
                    "transmission T(d, mu) = A·mu·exp(-d/l): A = [{:.4}, {:.4}, {:.4}], l = [{:.2}, {:.2}, {:.2}] mm (shadow side, theta >= {} deg)",
                    a[0], a[1], a[2], l[0], l[1], l[2], transmission.settings.min_theta_deg
                );
            }
            Err(error) => eprintln!(
                "warning: no transmission profile ({error}); {} has no translucency",
                cdrf_fit::outputs::MEASURED_LUT
            ),
        }
        match &fit.diffusion {
            Ok(diffusion) => {
                let (rms, albedo) = (diffusion.relative_rms, diffusion.profile.albedo());
                eprintln!(
                    "diffusion profile R(d): {} terms, entry factor mu^{:.2}, albedo [{:.3}, {:.3}, {:.3}]; alone it reproduces the spheres to [{:.1}, {:.1}, {:.1}] % RMS",
                    diffusion.profile.terms().len(),
                    diffusion.profile.entry_cosine_power(),
                    albedo[0],
                    albedo[1],
                    albedo[2],
                    100.0 * rms[0],
                    100.0 * rms[1],
                    100.0 * rms[2],
                );
                eprintln!("radius  profile alone: rel. RMS (G)  lit side (G)  shadow side (G)");
                for sphere in &diffusion.spheres {
                    eprintln!(
                        "{:>4} mm  {:>20.1} %  {:>11.2} x  {:>14.2} x",
                        // The radius is 1/κ here: rounded to 0.01 mm, 7.5 prints as 7.5.
                        (sphere.radius_mm * 100.0).round() / 100.0,
                        100.0 * sphere.relative_rms[1],
                        sphere.lit_ratio[1],
                        sphere.shadow_ratio[1],
                    );
                }
            }
            Err(error) => eprintln!(
                "warning: no diffusion profile ({error}); {} has none",
                cdrf_fit::outputs::MEASURED_LUT
            ),
        }
        for path in &written {
            eprintln!("wrote {}", path.display());
        }
    }
    if args.json {
        let summary = serde_json::json!({
            "outputs": written,
            "spheres": fit.spheres.len(),
            "view_model": report.view_model,
            "gaussian": report.gaussian,
            "transmission": report.transmission,
            "diffusion": report.diffusion,
            "measured_error_lit_and_terminator": fit.errors.iter().map(|e| e.measured.lit_and_terminator.mean_relative_error).collect::<Vec<_>>(),
            "gaussian_error_lit_and_terminator": fit.errors.iter().map(|e| e.gaussian.lit_and_terminator.mean_relative_error).collect::<Vec<_>>(),
            "timings": report.timings,
        });
        println!("{}", serde_json::to_string_pretty(&summary)?);
    }
    Ok(())
}

/// θ ranges as the warnings print them: "110–135, 140–150".
fn degree_ranges(ranges: &[[f32; 2]]) -> String {
    ranges
        .iter()
        .map(|[from, to]| {
            if to > from {
                format!("{from:.0}–{to:.0}")
            } else {
                format!("{from:.0}")
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}
