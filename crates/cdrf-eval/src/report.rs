//! The results as text and files: Markdown tables, the results page, and the files of a run.

use std::path::{Path, PathBuf};

use cdrf_core::block_error::{BLOCK_PX, TERMINATOR_COS};

use crate::error::CompareError;
use crate::figure::figure;
use crate::result::{CaseResult, Metrics};
use crate::run::ERODE_PX;
use crate::theta_bins;

/// One case's Markdown table: per region, each model's relative RMSE, mean relative error and
/// FLIP; the best model of each region and metric in bold.
fn case_table(result: &CaseResult) -> String {
    let mut text = String::new();
    text.push_str("| region | blocks | mean reference radiance |");
    for model in &result.models {
        text.push_str(&format!(" {model} |"));
    }
    text.push_str("\n|---|---|---|");
    text.push_str(&"---|".repeat(result.models.len()));
    text.push('\n');
    for row in &result.regions {
        let best = |metric: fn(&Metrics) -> f64| {
            row.models
                .iter()
                .map(|entry| metric(&entry.metrics))
                .filter(|v| v.is_finite())
                .fold(f64::INFINITY, f64::min)
        };
        let best_rmse = best(|m| m.relative_rmse);
        let best_mre = best(|m| m.mean_relative_error);
        let best_flip = best(|m| m.flip);
        let cell = |value: f64, best: f64, percent: bool| {
            let text = if !value.is_finite() {
                "—".to_owned()
            } else if percent {
                format!("{:.1} %", value * 100.0)
            } else {
                format!("{value:.3}")
            };
            if value == best {
                format!("**{text}**")
            } else {
                text
            }
        };
        let radiance = if row.reference_mean_radiance.is_finite() {
            format!("{:.4}", row.reference_mean_radiance)
        } else {
            "—".to_owned()
        };
        text.push_str(&format!("| {} | {} | {radiance} |", row.region, row.blocks));
        for entry in &row.models {
            let m = &entry.metrics;
            text.push_str(&format!(
                " {} / {} / {} |",
                cell(m.relative_rmse, best_rmse, true),
                cell(m.mean_relative_error, best_mre, true),
                cell(m.flip, best_flip, false)
            ));
        }
        text.push('\n');
    }
    text
}

/// What a case is: its name, size and Lambert albedo (a table's caption).
fn case_caption(result: &CaseResult) -> String {
    let fit = result
        .fit
        .as_ref()
        .map_or_else(String::new, |fit| format!("; models of its own fit, {fit}"));
    format!(
        "{} × {} px; Lambert albedo {:.3} {:.3} {:.3}{fit}",
        result.width,
        result.height,
        result.lambert_albedo[0],
        result.lambert_albedo[1],
        result.lambert_albedo[2]
    )
}

const TABLE_KEY: &str = "Each cell: relative RMSE / mean relative error (8 × 8-pixel blocks, linear \
                         radiance) / mean FLIP (tone-mapped). Lower is better; the best of each \
                         region in bold.\n";

const THETA_KEY: &str = "Render / reference by θ: Σ render / Σ reference (mean of R, G, B) over the \
                         compared pixels of each θ bin outside cast shadows, and over the \
                         cast-shadow pixels; 1 is right, 0.5 means half the light is missing.\n";

/// A case's two tables (regions, then θ bins), each followed by a blank line.
fn case_tables(result: &CaseResult) -> String {
    format!(
        "{}\n{}\n",
        case_table(result),
        theta_bins::markdown(&result.theta)
    )
}

/// The results as Markdown tables: per case and region, each model's relative RMSE, mean
/// relative error and FLIP; the best model of each region and metric in bold.
pub fn markdown(results: &[CaseResult]) -> String {
    let mut text = String::new();
    for result in results {
        text.push_str(&format!(
            "**{}** ({})\n\n",
            result.name,
            case_caption(result)
        ));
        text.push_str(&case_tables(result));
    }
    text.push_str(TABLE_KEY);
    text.push('\n');
    text.push_str(THETA_KEY);
    text
}

/// How a results page was made: the command line, the adapter, the fit.
#[derive(Clone, Debug, Default)]
pub struct Provenance {
    /// The command line that wrote the page (`cdrf-viewer compare …`).
    pub command: String,
    /// The GPU adapter the renders ran on (the numbers depend on it slightly).
    pub adapter: String,
    /// The fit folder whose models were compared.
    pub fit: String,
}

/// A results page (Markdown, meant to be committed as `docs/results.md`): what is compared and
/// how, then per case its figure (`figures`: the folder of the figures, relative to the
/// page) and its table. Everything in it is generated, so no number in it can drift from what
/// `compare` measures.
pub fn results_page(results: &[CaseResult], figures: &str, provenance: &Provenance) -> String {
    let mut text = String::new();
    text.push_str("# Results: measured vs Gaussian vs Lambert against path-traced references\n\n");
    text.push_str(&format!(
        "<!-- Generated by `{}`; do not edit by hand: run it again. -->\n\n",
        provenance.command
    ));
    text.push_str(&format!(
        "Generated by `{}` on {} with the models of `{}`: the measured CDRF (the table), Kubo's \
         Gaussian CDRF fitted to the same photographs (both with the fit's view correction) and \
         Lambert with the albedo fitted to the measured table, each also with the non-local \
         terms (cast shadows, transmission) where they apply.\n\n",
        provenance.command, provenance.adapter, provenance.fit
    ));
    text.push_str(&format!(
        "**How it compares** (`cdrf_eval`; the metric is `cdrf_core::block_error`, \
         the one cdrf-fit and the render tests use too):\n\
         - *Pixels*: those the render covers fully (4× MSAA coverage = 1) with all neighbours \
         within {ERODE_PX} px covered too.\n\
         - *Errors in linear radiance* on {BLOCK_PX} × {BLOCK_PX}-pixel blocks wholly inside \
         those pixels: relative RMSE √(Σ|R − T|²)/√(Σ T²) and mean relative error \
         Σ|R − T|/Σ T over the region's blocks and channels (T reference, R render; ratios of \
         sums). *FLIP* on tone-mapped images (the exposure puts the reference's 99th-percentile \
         luminance at 0.9, sRGB), averaged over the region's pixels.\n\
         - *Regions* by a block's mean cos θ (θ between normal and light): lit side \
         cos θ ≥ {TERMINATOR_COS}, terminator band |cos θ| < {TERMINATOR_COS}, shadow side \
         cos θ ≤ −{TERMINATOR_COS}, and the cast shadow: facing the light but hidden from it \
         by another part of the object, taken out of the lit side and the terminator band.\n\
         - *Render / reference by θ*: per bin of θ, Σ render / Σ reference of the pixels' mean \
         of R, G and B (cast-shadow pixels in their own column): how much of the light a model \
         reproduces at each angle.\n\n"
    ));
    for result in results {
        text.push_str(&format!("## {}\n\n", result.name));
        text.push_str(&format!(
            "![{}: the reference and each model; beneath: the regions and each model's signed \
             error per block]({}/{}.png)\n\n",
            result.name,
            figures.trim_end_matches('/'),
            result.name
        ));
        text.push_str(&format!("{}\n\n", case_caption(result)));
        text.push_str(&case_tables(result));
    }
    text.push_str(TABLE_KEY);
    text.push('\n');
    text.push_str(THETA_KEY);
    text
}

/// The files a run of `cases` writes: `compare.json`, `compare.md` and `<case>.png` in
/// `folder`, then the results page if any.
pub fn output_paths<'a>(
    folder: &Path,
    case_names: impl IntoIterator<Item = &'a str>,
    results_page: Option<&Path>,
) -> Vec<PathBuf> {
    let mut paths = vec![folder.join("compare.json"), folder.join("compare.md")];
    paths.extend(
        case_names
            .into_iter()
            .map(|name| folder.join(format!("{name}.png"))),
    );
    paths.extend(results_page.map(Path::to_owned));
    paths
}

/// The contents of a run's files, in [`output_paths`] order: `compare.json`, `compare.md` and
/// `<case>.png` (the figures) in `folder`, then the results page if `page` names one. The page
/// links the figures relative to its own folder, so `folder` and the page's folder must exist
/// (the caller stages the outputs there first).
///
/// # Errors
/// [`CompareError::File`] naming the file.
pub fn output_files(
    results: &[CaseResult],
    folder: &Path,
    page: Option<(&Path, &Provenance)>,
) -> Result<Vec<(PathBuf, Vec<u8>)>, CompareError> {
    let file_error = |path: &Path, message: String| CompareError::File {
        path: path.to_owned(),
        message,
    };
    let json_path = folder.join("compare.json");
    let json =
        serde_json::to_string_pretty(results).map_err(|e| file_error(&json_path, e.to_string()))?;
    let mut files = vec![
        (json_path, json.into_bytes()),
        (folder.join("compare.md"), markdown(results).into_bytes()),
    ];
    for result in results {
        let path = folder.join(format!("{}.png", result.name));
        let figure = figure(result);
        let mut png = Vec::new();
        {
            use image::ImageEncoder;
            image::codecs::png::PngEncoder::new(&mut png)
                .write_image(
                    figure.as_raw(),
                    figure.width(),
                    figure.height(),
                    image::ExtendedColorType::Rgb8,
                )
                .map_err(|e| file_error(&path, e.to_string()))?;
        }
        files.push((path, png));
    }
    if let Some((page, provenance)) = page {
        let page_folder = page.parent().filter(|p| !p.as_os_str().is_empty());
        let page_folder = page_folder.unwrap_or(Path::new("."));
        let canonical = |path: &Path| {
            path.canonicalize()
                .map_err(|e| file_error(path, e.to_string()))
        };
        let figures = relative_path(&canonical(folder)?, &canonical(page_folder)?);
        files.push((
            page.to_owned(),
            results_page(results, &figures, provenance).into_bytes(),
        ));
    }
    Ok(files)
}

/// `target` relative to the folder `base` (both absolute), with `/` separators.
fn relative_path(target: &Path, base: &Path) -> String {
    let target: Vec<_> = target.components().collect();
    let base: Vec<_> = base.components().collect();
    let common = target.iter().zip(&base).take_while(|(a, b)| a == b).count();
    let mut parts: Vec<String> = vec!["..".to_owned(); base.len() - common];
    parts.extend(
        target[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    if parts.is_empty() {
        ".".to_owned()
    } else {
        parts.join("/")
    }
}
