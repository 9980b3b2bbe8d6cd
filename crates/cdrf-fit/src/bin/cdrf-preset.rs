//! `cdrf-preset NAME --out DIR` or `cdrf-preset --sigma-s R,G,B --sigma-a R,G,B [--g G] [--eta E]
//! --out DIR`: a CDRF table and a Gaussian CDRF from a named medium or scattering coefficients,
//! without photographs. By default the spheres are simulated (Monte Carlo) and fitted as
//! photographs are; `--model dipole` pre-integrates the dipole instead (instant, for
//! comparison). Writes `measured.exr` and `gaussian.toml` into DIR, the two files `cdrf-fit`
//! writes and the renderer reads (see `cdrf_fit::preset`). `cdrf-preset --list` prints the media.
//!
//! A binary of its own rather than a `cdrf-fit` flag: `cdrf-fit DIR --out OUT` takes the
//! photo folder as its positional argument, and a preset has none.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use cdrf_fit::media::MEDIA;
use cdrf_fit::preset::cache::PresetCache;
use cdrf_fit::preset::simulated::{SimulatedSettings, total_photons};
use cdrf_fit::preset::{DEON_SKIN, Preset, PresetModel, PresetSettings, write_preset};
use cdrf_fit::simulation::ScatteringMedium;
use clap::{ArgGroup, Parser, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};

/// The most θ columns accepted (0.05° apart), as cdrf-fit.
const MAX_THETA_COUNT: u32 = 3601;
/// The most curvature rows accepted, as cdrf-fit.
const MAX_CURVATURE_COUNT: u32 = 1024;
/// The most simulated spheres.
const MAX_RADII: usize = 32;

/// Which model makes the table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Model {
    /// Simulate spheres of the medium (Monte Carlo) and fit them as photographs: a full table
    /// with view correction, transmission and diffusion profile.
    Simulated,
    /// Pre-integrate Jensen's dipole over the ring (instant; no view correction, no non-local
    /// data; for comparison).
    Dipole,
}

/// Write a CDRF look-up table (measured.exr) and Kubo's Gaussian CDRF (gaussian.toml) for a
/// material without photographs: spheres of the medium simulated by Monte Carlo light
/// transport and fitted as cdrf-fit fits photographs (default), or the dipole pre-integrated
/// over curvature (--model dipole).
#[derive(Debug, Parser)]
#[command(name = "cdrf-preset", version)]
#[command(group(ArgGroup::new("medium").required(true).args(["name", "sigma_s", "list"])))]
struct Args {
    /// A medium from --list (case-insensitive), with its own eta unless --eta is given.
    name: Option<String>,
    /// Scattering coefficient sigma_s per RGB channel, mm⁻¹ (not reduced: the dipole uses
    /// sigma_s·(1 − g)), for a medium of your own. Needs --sigma-a.
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb, allow_hyphen_values = true,
          requires = "sigma_a")]
    sigma_s: Option<[f64; 3]>,
    /// Absorption coefficient sigma_a per RGB channel, mm⁻¹ (≥ 0). Needs --sigma-s.
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb, allow_hyphen_values = true,
          requires = "sigma_s")]
    sigma_a: Option<[f64; 3]>,
    /// Henyey–Greenstein asymmetry g of a --sigma-s/--sigma-a medium, in (−0.99, 0.99).
    #[arg(
        long,
        value_name = "G",
        default_value_t = 0.0,
        allow_hyphen_values = true,
        requires = "sigma_s"
    )]
    g: f64,
    /// Relative index of refraction (medium over outside) of the smooth boundary; 1 for an
    /// index-matched one. Default for simulated spheres: 1 (the diffuse term as cross-polarised
    /// photographs see it; the renderer's specular layer adds the surface). Default for
    /// --model dipole: the named medium's (Jensen's 1.3), 1.3 for --sigma-s/--sigma-a.
    #[arg(long, value_name = "E", allow_hyphen_values = true)]
    eta: Option<f64>,
    /// Output folder (created if missing; measured.exr and gaussian.toml in it are replaced).
    #[arg(long, value_name = "DIR", required_unless_present = "list")]
    out: Option<PathBuf>,
    /// List the named media and exit.
    #[arg(long)]
    list: bool,
    /// How the table is made.
    #[arg(long, value_enum, default_value_t = Model::Simulated)]
    model: Model,
    /// Photons per simulated sphere (shared by the three channels' walks when sigma_t differs
    /// between channels); noise falls as 1/√photons.
    #[arg(long, value_name = "N", default_value_t = SimulatedSettings::default().simulation.photons,
          value_parser = clap::value_parser!(u64).range(1000..=1_000_000_000))]
    photons: u64,
    /// Radii of the simulated spheres, mm (2…32 different values in (0, 1000]).
    #[arg(long, value_name = "R,R,…", value_delimiter = ',', num_args = 1..)]
    radii: Option<Vec<f32>>,
    /// Seed of the simulation (the same seed and settings give the same table).
    #[arg(long, default_value_t = SimulatedSettings::default().simulation.seed)]
    seed: u64,
    /// Cache folder for simulated presets (default: $CDRF_CACHE_DIR, else ~/.cache/cdrf/presets).
    #[arg(long, value_name = "DIR", conflicts_with = "no_cache")]
    cache: Option<PathBuf>,
    /// Neither read nor write the cache.
    #[arg(long)]
    no_cache: bool,
    /// Dipole model: curvature of the table's last row, mm⁻¹ (row 0 is flat).
    #[arg(long, value_name = "K", default_value_t = PresetSettings::default().max_curvature_per_mm)]
    max_curvature_per_mm: f32,
    /// Dipole model: rows of the table, uniform in curvature, 2…1024.
    #[arg(long, default_value_t = PresetSettings::default().curvature_count as u32,
          value_parser = clap::value_parser!(u32).range(2..=i64::from(MAX_CURVATURE_COUNT)))]
    curvature_count: u32,
    /// Dipole model: columns of the table over θ ∈ [0°, 180°], 19…3601.
    #[arg(long, default_value_t = PresetSettings::default().theta_count as u32,
          value_parser = clap::value_parser!(u32).range(19..=i64::from(MAX_THETA_COUNT)))]
    theta_count: u32,
    /// Print nothing but errors.
    #[arg(long, short)]
    quiet: bool,
}

/// `R,G,B`: exactly three comma-separated numbers.
fn parse_rgb(text: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "expected R,G,B (3 comma-separated numbers), found {} component(s)",
            parts.len()
        ));
    }
    let mut rgb = [0.0; 3];
    for (value, part) in rgb.iter_mut().zip(&parts) {
        *value = part
            .parse()
            .map_err(|_| format!("{part:?} is not a number (expected R,G,B)"))?;
    }
    Ok(rgb)
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
    if args.list {
        print_list();
        return Ok(());
    }
    let preset = match (&args.name, args.sigma_s, args.sigma_a) {
        (Some(name), _, _) => {
            let named = Preset::named(name)?;
            match (args.eta, args.model) {
                (Some(eta), _) => named.with_eta(eta)?,
                // Simulated spheres default to the photographs' convention: index-matched.
                (None, Model::Simulated) => named.with_eta(1.0)?,
                (None, Model::Dipole) => named,
            }
        }
        (None, Some(sigma_s), Some(sigma_a)) => {
            let default_eta = if args.model == Model::Simulated {
                1.0
            } else {
                1.3
            };
            let eta = args.eta.unwrap_or(default_eta);
            let medium = ScatteringMedium::new(sigma_s, sigma_a, args.g, eta)?;
            Preset::from_medium(medium)?
        }
        // clap's group and `requires` rule this out.
        _ => anyhow::bail!("give a medium NAME, or --sigma-s and --sigma-a, or --list"),
    };
    let model = match args.model {
        Model::Dipole => PresetModel::Dipole(PresetSettings {
            max_curvature_per_mm: args.max_curvature_per_mm,
            curvature_count: args.curvature_count as usize,
            theta_count: args.theta_count as usize,
        }),
        Model::Simulated => {
            let mut settings = SimulatedSettings::default();
            settings.simulation.photons = args.photons;
            settings.simulation.seed = args.seed;
            if let Some(radii) = args.radii {
                anyhow::ensure!(
                    (2..=MAX_RADII).contains(&radii.len()),
                    "--radii: give 2…{MAX_RADII} radii, got {}",
                    radii.len()
                );
                settings.radii_mm = radii;
            }
            PresetModel::Simulated(settings)
        }
    };
    if let (Model::Simulated, Ok(medium)) = (args.model, preset.medium())
        && medium.eta != 1.0
        && !args.quiet
    {
        eprintln!(
            "note: eta {} simulates a refracting boundary with the boundary-ray estimator, whose images are noisier: the view correction needs about ten times the photons (--photons) to be as smooth as an index-matched preset's",
            medium.eta
        );
    }
    let cache = if args.no_cache || args.model == Model::Dipole {
        None
    } else {
        args.cache
            .map(PresetCache::new)
            .or_else(PresetCache::default_location)
    };
    let out = args
        .out
        .context("--out DIR is required (clap should have said so)")?;

    let bar = match (&model, args.quiet) {
        (PresetModel::Simulated(settings), false) => {
            let bar = ProgressBar::new(total_photons(preset.medium()?, settings));
            bar.set_style(
                ProgressStyle::with_template(
                    "{bar:30} {percent:>3} % photons, {elapsed} (about {eta} left)",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar
        }
        _ => ProgressBar::hidden(),
    };
    let written = write_preset(&preset, &model, cache.as_ref(), &out, &|done| {
        bar.set_position(done);
    })
    .with_context(|| format!("writing preset {} to {}", preset.name(), out.display()))?;
    bar.finish_and_clear();
    if !args.quiet {
        report(&preset, &model, &written, cache.as_ref());
    }
    Ok(())
}

fn report(
    preset: &Preset,
    model: &PresetModel,
    written: &cdrf_fit::preset::WrittenPreset,
    cache: Option<&PresetCache>,
) {
    eprintln!("preset {}: {}", preset.name(), preset.description());
    let tables = &written.tables;
    match model {
        PresetModel::Dipole(settings) => {
            if let Ok(dipole) = preset.dipole_cdrf() {
                let r_d = dipole.albedo();
                eprintln!(
                    "dipole: albedo R_d = [{:.4}, {:.4}, {:.4}] (a flat surface lit head-on, pi·L/E); curvature 0 … {} per mm in {} rows, theta in {} columns; view correction g = 1",
                    r_d[0],
                    r_d[1],
                    r_d[2],
                    settings.max_curvature_per_mm,
                    settings.curvature_count,
                    settings.theta_count
                );
            }
        }
        PresetModel::Simulated(_) if tables.cached => {
            eprintln!(
                "simulated spheres: from the cache {}",
                cache.map_or_else(String::new, |c| c.dir().display().to_string())
            );
        }
        PresetModel::Simulated(_) => {
            eprintln!(
                "simulated spheres (relative standard error of the mean radiance, worst channel):"
            );
            for s in &tables.spheres {
                eprintln!(
                    "{:>5} mm, {} photons, {:.1} s: {}",
                    s.radius_mm, s.photons, s.seconds, s.noise
                );
            }
        }
    }
    let (sigma, scale) = (tables.gaussian.sigma_mm(), tables.gaussian.scale());
    eprintln!(
        "Gaussian CDRF: sigma_mm = [{:.3}, {:.3}, {:.3}], scale = [{:.4}, {:.4}, {:.4}]",
        sigma[0], sigma[1], sigma[2], scale[0], scale[1], scale[2]
    );
    for path in &written.files {
        eprintln!("wrote {}", path.display());
    }
}

fn print_list() {
    println!(
        "{:<18} {:<26} {:<28} {:>5} {:>5}  source",
        "name", "sigma_s (1/mm)", "sigma_a (1/mm)", "g", "eta"
    );
    let rgb = |v: [f64; 3]| format!("{}, {}, {}", v[0], v[1], v[2]);
    for medium in MEDIA {
        println!(
            "{:<18} {:<26} {:<28} {:>5} {:>5}  {}",
            medium.name,
            rgb(medium.sigma_s_per_mm),
            rgb(medium.sigma_a_per_mm),
            medium.g,
            medium.eta,
            medium.source
        );
    }
    println!(
        "{DEON_SKIN:<18} six Gaussians, variances 0.0064 … 7.41 mm² (white; --model dipole only; d'Eon & Luebke, GPU Gems 3, ch. 14)"
    );
}
