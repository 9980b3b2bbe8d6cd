//! Makes the wax preset at the default quality (every sphere simulated, then fitted) and prints
//! where the time goes and the noise the simulation reached, per sphere; then one chromatic
//! medium (Skin1, three walks sharing the photons), both index-matched as `cdrf-preset` makes
//! them by default.
//!
//! `cargo bench -p cdrf-fit --bench preset`
//!
//! Goal (issue "presets from simulated spheres"): a full preset in ≤ 60 s on two cores, with
//! ≤ 1 % noise on the lit side and ≤ 5 % at θ = 150° on the r = 15 mm sphere.

use std::time::Instant;

use cdrf_fit::preset::Preset;
use cdrf_fit::preset::simulated::SimulatedSettings;

fn main() {
    println!(
        "{} threads; default settings: {} photons per sphere, radii {:?} mm",
        rayon::current_num_threads(),
        SimulatedSettings::default().simulation.photons,
        SimulatedSettings::default().radii_mm
    );
    for name in ["wax", "skin1"] {
        let preset = Preset::named(name)
            .and_then(|p| p.with_eta(1.0))
            .expect("named medium");
        let settings = SimulatedSettings::default();
        let started = Instant::now();
        let tables = preset.simulate(&settings, None, &|_| {}).expect("preset");
        let total = started.elapsed().as_secs_f64();
        let simulated: f64 = tables.spheres.iter().map(|s| s.seconds).sum();
        println!(
            "\n{name}: {total:.1} s in all ({simulated:.1} s simulating, {:.1} s fitting)",
            total - simulated
        );
        for s in &tables.spheres {
            println!("{:>5} mm, {:5.1} s: {}", s.radius_mm, s.seconds, s.noise);
        }
        let at_15 = tables.spheres.iter().find(|s| s.radius_mm == 15.0);
        if let Some(s) = at_15 {
            let [lit, _, _, theta_150] = s.noise.worst_percent();
            println!(
                "goal at r = 15 mm: lit ≤ 1 % ({lit:.2} %), θ = 150° ≤ 5 % ({theta_150:.2} %); total ≤ 60 s ({total:.1} s)"
            );
        }
    }
}
