//! `cdrf-preset NAME --out DIR` or `cdrf-preset --sigma-s R,G,B --sigma-a R,G,B [--eta E] --out DIR`:
//! a CDRF table and a Gaussian CDRF from a named medium or scattering coefficients, without
//! photographs. Writes `measured.exr` and `gaussian.toml` into DIR, the two files `cdrf-fit`
//! writes and the renderer reads (see `cdrf_fit::preset`). `cdrf-preset --list` prints the media.
//!
//! A binary of its own rather than a `cdrf-fit` flag: `cdrf-fit DIR --out OUT` takes the
//! photo folder as its positional argument, and a preset has none.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use cdrf_fit::preset::{
    DEON_SKIN, JENSEN_2001, JENSEN_2001_ETA, Preset, PresetSettings, write_preset,
};
use clap::{ArgGroup, Parser};

/// The most θ columns accepted (0.05° apart), as cdrf-fit.
const MAX_THETA_COUNT: u32 = 3601;
/// The most curvature rows accepted, as cdrf-fit.
const MAX_CURVATURE_COUNT: u32 = 1024;

/// Write a CDRF look-up table (measured.exr) and Kubo's Gaussian CDRF (gaussian.toml) for a
/// material without photographs: the radial diffusion profile of a named medium, or of the
/// dipole for given coefficients, pre-integrated over curvature and scaled by the medium's
/// total diffuse reflectance R_d. The view correction is 1 (nothing measured it).
#[derive(Debug, Parser)]
#[command(name = "cdrf-preset", version)]
#[command(group(ArgGroup::new("medium").required(true).args(["name", "sigma_s", "list"])))]
struct Args {
    /// A medium from --list (case-insensitive): Jensen et al. 2001's table (eta = 1.3) or
    /// dEonSkin (d'Eon & Luebke's sum of Gaussians).
    name: Option<String>,
    /// Reduced scattering coefficient sigma_s' = sigma_s·(1 − g) per RGB channel, mm⁻¹
    /// (> 0), for a medium of your own (the dipole). Needs --sigma-a.
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb, allow_hyphen_values = true,
          requires = "sigma_a")]
    sigma_s: Option<[f32; 3]>,
    /// Absorption coefficient sigma_a per RGB channel, mm⁻¹ (≥ 0). Needs --sigma-s.
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb, allow_hyphen_values = true,
          requires = "sigma_s")]
    sigma_a: Option<[f32; 3]>,
    /// Relative index of refraction (medium over outside) of a --sigma-s/--sigma-a medium;
    /// 1 for an index-matched boundary. Default 1.3, as Jensen et al.'s table.
    #[arg(
        long,
        value_name = "E",
        allow_hyphen_values = true,
        requires = "sigma_s"
    )]
    eta: Option<f32>,
    /// Output folder (created if missing; measured.exr and gaussian.toml in it are replaced).
    #[arg(long, value_name = "DIR", required_unless_present = "list")]
    out: Option<PathBuf>,
    /// List the named media and exit.
    #[arg(long)]
    list: bool,
    /// Curvature of the table's last row, mm⁻¹ (row 0 is flat); beyond it the table clamps.
    #[arg(long, value_name = "K", default_value_t = PresetSettings::default().max_curvature_per_mm)]
    max_curvature_per_mm: f32,
    /// Rows of the table, uniform in curvature from 0 to --max-curvature-per-mm, 2…1024.
    #[arg(long, default_value_t = PresetSettings::default().curvature_count as u32,
          value_parser = clap::value_parser!(u32).range(2..=i64::from(MAX_CURVATURE_COUNT)))]
    curvature_count: u32,
    /// Columns of the table over θ ∈ [0°, 180°], 19…3601.
    #[arg(long, default_value_t = PresetSettings::default().theta_count as u32,
          value_parser = clap::value_parser!(u32).range(19..=i64::from(MAX_THETA_COUNT)))]
    theta_count: u32,
    /// Print nothing but errors.
    #[arg(long, short)]
    quiet: bool,
}

/// `R,G,B`: exactly three comma-separated numbers.
fn parse_rgb(text: &str) -> Result<[f32; 3], String> {
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
        print_list()?;
        return Ok(());
    }
    let preset = match (&args.name, args.sigma_s, args.sigma_a) {
        (Some(name), _, _) => Preset::named(name)?,
        (None, Some(sigma_s), Some(sigma_a)) => {
            Preset::dipole(sigma_s, sigma_a, args.eta.unwrap_or(JENSEN_2001_ETA))?
        }
        // clap's group and `requires` rule this out.
        _ => anyhow::bail!("give a medium NAME, or --sigma-s and --sigma-a, or --list"),
    };
    let settings = PresetSettings {
        max_curvature_per_mm: args.max_curvature_per_mm,
        curvature_count: args.curvature_count as usize,
        theta_count: args.theta_count as usize,
    };
    let out = args
        .out
        .context("--out DIR is required (clap should have said so)")?;
    let written = write_preset(&preset, &settings, &out)
        .with_context(|| format!("writing preset {} to {}", preset.name(), out.display()))?;
    if !args.quiet {
        let r_d = preset.albedo();
        let (sigma, scale) = (written.gaussian.sigma_mm(), written.gaussian.scale());
        eprintln!("preset {}: {}", preset.name(), preset.description());
        eprintln!(
            "albedo R_d = [{:.4}, {:.4}, {:.4}] (a flat surface lit head-on, pi·L/E); curvature 0 … {} per mm in {} rows, theta in {} columns; view correction g = 1",
            r_d[0],
            r_d[1],
            r_d[2],
            settings.max_curvature_per_mm,
            settings.curvature_count,
            settings.theta_count
        );
        eprintln!(
            "Gaussian CDRF fitted to the table: sigma_mm = [{:.3}, {:.3}, {:.3}], scale = [{:.4}, {:.4}, {:.4}]",
            sigma[0], sigma[1], sigma[2], scale[0], scale[1], scale[2]
        );
        for path in &written.files {
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(())
}

fn print_list() -> anyhow::Result<()> {
    println!(
        "{:<10} {:<22} {:<25} {:>4}  albedo R_d",
        "name", "sigma_s' (1/mm)", "sigma_a (1/mm)", "eta"
    );
    let rgb = |v: [f32; 3]| format!("{}, {}, {}", v[0], v[1], v[2]);
    for medium in &JENSEN_2001 {
        let preset = Preset::named(medium.name)?;
        let r_d = preset.albedo();
        println!(
            "{:<10} {:<22} {:<25} {:>4}  {:.3}, {:.3}, {:.3}",
            medium.name,
            rgb(medium.sigma_s_prime_per_mm),
            rgb(medium.sigma_a_per_mm),
            JENSEN_2001_ETA,
            r_d[0],
            r_d[1],
            r_d[2]
        );
    }
    let skin = Preset::named(DEON_SKIN)?;
    let r_d = skin.albedo();
    println!(
        "{:<10} {:<53}  {:.3}, {:.3}, {:.3}",
        DEON_SKIN, "six Gaussians, variances 0.0064 … 7.41 mm² (white)", r_d[0], r_d[1], r_d[2]
    );
    println!("(Jensen et al. 2001, table 2; d'Eon & Luebke, GPU Gems 3, ch. 14)");
    Ok(())
}
