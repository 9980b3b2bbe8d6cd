//! `cdrf-curvature MESH --mm-per-unit S --out OUT.glb|OUT.csv [--smoothing N]`
//!
//! Bakes the signed per-vertex mean curvature (mm⁻¹) of an OBJ / glTF / GLB mesh:
//! - `OUT.glb`: the mesh with a `_CURVATURE` vertex attribute (scalar float, mm⁻¹), for other
//!   engines;
//! - `OUT.csv`: `x,y,z,curvature_per_mm`, one row per vertex of the **welded** mesh (seam
//!   duplicates merged), positions in the file's units as loaded, curvature before any clamping.
//!
//! Outputs are written atomically: on any error no output file is left behind.

use std::fmt::Write as _;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use cdrf_core::curvature::{
    CurvatureOptions, MAX_SMOOTHING_ITERATIONS, mean_curvature_per_mm, mean_curvature_per_mm_welded,
};
use cdrf_core::mesh::{Mesh, write_glb_with_curvature};
use clap::Parser;
use rayon::prelude::*;

/// Bake per-vertex mean curvature (mm⁻¹) of a mesh into a GLB or a CSV file.
#[derive(Debug, Parser)]
#[command(name = "cdrf-curvature", version)]
struct Args {
    /// Input mesh: .obj, .gltf or .glb.
    mesh: PathBuf,
    /// Millimetres per model unit (1 for a model in mm, 10 in cm, 1000 in m).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    mm_per_unit: f32,
    /// Output file: .glb (mesh with a _CURVATURE attribute) or .csv (x,y,z,curvature_per_mm per
    /// welded vertex).
    #[arg(long, value_name = "OUT")]
    out: PathBuf,
    /// Rounds of area-weighted 1-ring smoothing of the curvature (at most 1000).
    #[arg(long, value_name = "N", default_value_t = 0,
          value_parser = clap::value_parser!(u32).range(0..=i64::from(MAX_SMOOTHING_ITERATIONS)))]
    smoothing: u32,
}

/// What to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum OutputFormat {
    Glb,
    Csv,
}

/// Validated arguments.
#[derive(Debug)]
struct Config {
    mesh: PathBuf,
    out: PathBuf,
    format: OutputFormat,
    options: CurvatureOptions,
}

impl Config {
    fn from_args(args: Args) -> anyhow::Result<Self> {
        let extension = args
            .out
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let format = match extension.as_deref() {
            Some("glb") => OutputFormat::Glb,
            Some("csv") => OutputFormat::Csv,
            _ => bail!(
                "--out {}: unsupported output format (expected a .glb or .csv file)",
                args.out.display()
            ),
        };
        if !(args.mm_per_unit.is_finite() && args.mm_per_unit > 0.0) {
            bail!(
                "--mm-per-unit {}: must be a finite number > 0",
                args.mm_per_unit
            );
        }
        // Never replace the input: compare canonical paths (an existing --out only).
        if let (Ok(input), Ok(output)) = (
            std::fs::canonicalize(&args.mesh),
            std::fs::canonicalize(&args.out),
        ) && input == output
        {
            bail!(
                "--out {}: is the input mesh {}; choose another output file",
                args.out.display(),
                args.mesh.display()
            );
        }
        Ok(Self {
            mesh: args.mesh,
            out: args.out,
            format,
            options: CurvatureOptions::new(args.mm_per_unit)
                .with_smoothing_iterations(args.smoothing),
        })
    }
}

fn run(config: &Config) -> anyhow::Result<()> {
    let loaded = Mesh::load(&config.mesh).context("cannot load the input mesh")?;
    let mesh = &loaded.mesh;
    let (vertices, curvature_per_mm) = match config.format {
        OutputFormat::Glb => {
            let curvature = mean_curvature_per_mm(mesh, &config.options)
                .context("cannot estimate curvature")?;
            write_glb_with_curvature(&config.out, mesh, &curvature)
                .context("cannot write the GLB")?;
            (mesh.positions.len(), curvature)
        }
        OutputFormat::Csv => {
            let welded = mesh.weld();
            let curvature =
                mean_curvature_per_mm_welded(&welded.positions, &welded.triangles, &config.options)
                    .context("cannot estimate curvature")?;
            write_csv(&config.out, &welded.positions, &curvature)?;
            (welded.positions.len(), curvature)
        }
    };
    let (min, max) = curvature_per_mm
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &k| {
            (lo.min(k), hi.max(k))
        });
    println!(
        "{}: {vertices} {}vertices, {} triangles, curvature {min:.5} to {max:.5} mm⁻¹ \
         (mm_per_unit {}, smoothing {}); {} -> {}",
        config.mesh.display(),
        if config.format == OutputFormat::Csv {
            "welded "
        } else {
            ""
        },
        mesh.triangles.len(),
        config.options.mm_per_unit,
        config.options.smoothing_iterations,
        loaded.report,
        config.out.display()
    );
    Ok(())
}

/// Writes `x,y,z,curvature_per_mm` atomically (temporary file in the same directory, renamed).
fn write_csv(path: &Path, positions: &[glam::Vec3], curvature: &[f32]) -> anyhow::Result<()> {
    // Formatting the numbers is most of the work: chunks are formatted in parallel and written
    // in order.
    const CHUNK_ROWS: usize = 1 << 16;
    let chunks: Vec<String> = positions
        .par_chunks(CHUNK_ROWS)
        .zip(curvature.par_chunks(CHUNK_ROWS))
        .map(|(positions, curvature)| {
            let mut text = String::with_capacity(positions.len() * 48);
            for (p, k) in positions.iter().zip(curvature) {
                // Writing into a String cannot fail.
                let _ = writeln!(text, "{},{},{},{}", p.x, p.y, p.z, k);
            }
            text
        })
        .collect();
    cdrf_core::atomic::write_file(path, |file| {
        let mut writer = BufWriter::new(file);
        writeln!(writer, "x,y,z,curvature_per_mm")?;
        for chunk in &chunks {
            writer.write_all(chunk.as_bytes())?;
        }
        writer.flush()
    })
    .with_context(|| format!("{}: cannot write", path.display()))
}

fn main() -> ExitCode {
    let args = match Args::try_parse() {
        Ok(args) => args,
        Err(error) => {
            // Usage errors exit with 2, --help / --version with 0.
            let _ = error.print();
            return if error.use_stderr() {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    match Config::from_args(args).and_then(|config| run(&config)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            // The error and its causes, joined with ": ".
            eprintln!("error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
