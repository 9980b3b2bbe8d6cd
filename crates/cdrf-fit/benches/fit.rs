//! Fits the bundled 8-sphere wax data set and prints where the wall time goes: decoding the
//! images against everything else, for both view models, best of a few runs.
//!
//! `cargo bench -p cdrf-fit --bench fit`
//!
//! Goal (issue "cdrf-fit"): the whole fit under 1 s on a 2-core machine, and the non-decode part
//! below the decode part.

use std::path::PathBuf;

use cdrf_fit::curves::ViewModel;
use cdrf_fit::dataset::Dataset;
use cdrf_fit::fit::Timings;
use cdrf_fit::{FitOptions, fit_dataset};

fn main() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/wax-spheres");
    let dataset = Dataset::load(&dir).expect("bundled data set");
    let runs = 5;
    println!(
        "fitting {} spheres ({} threads), best of {runs} runs",
        dataset.spheres.len(),
        rayon::current_num_threads()
    );
    println!(
        "view model   total    decode   rest     (curves  sampling  Gaussian  evaluation)  rest/decode"
    );
    for model in [ViewModel::Phi, ViewModel::ThetaPhi] {
        let mut options = FitOptions::default();
        options.curves.view_model = model;
        let best: Timings = (0..runs)
            .map(|_| {
                fit_dataset(&dataset, &options, |_| {})
                    .expect("fit")
                    .timings
            })
            .min_by(|a, b| a.total_s.total_cmp(&b.total_s))
            .expect("at least one run");
        let rest = best.total_s - best.decode_s;
        println!(
            "{:<11} {:>6.3} s {:>6.3} s {:>6.3} s ({:.3}   {:.3}     {:.3}     {:.3})        {:.2}",
            format!("{model:?}"),
            best.total_s,
            best.decode_s,
            rest,
            best.curves_s,
            best.sampling_s,
            best.gaussian_s,
            best.evaluation_s,
            rest / best.decode_s
        );
    }
}
