//! Scratch probe (not committed).
use cdrf_fit::image_io::{ColorSpace, load_linear_image};
use cdrf_fit::simulation::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let r: f32 = args[1].parse().unwrap();
    let photons: u64 = args[2].parse().unwrap();
    let est = match args.get(3).map(|s| s.as_str()) {
        Some("band") => Some(Estimator::ExitBand),
        Some("photons") => Some(Estimator::ExitPhotons),
        _ => None,
    };
    let env3 = |k: &str, d: [f64; 3]| {
        std::env::var(k)
            .map(|v| {
                let p: Vec<f64> = v.split(',').map(|x| x.parse().unwrap()).collect();
                [p[0], p[1], p[2]]
            })
            .unwrap_or(d)
    };
    let g: f64 = std::env::var("G")
        .map(|v| v.parse().unwrap())
        .unwrap_or(0.0);
    let eta: f64 = std::env::var("ETA")
        .map(|v| v.parse().unwrap())
        .unwrap_or(1.0);
    let medium = ScatteringMedium::new(
        env3("SS", [0.997, 0.993, 0.985]),
        env3("SA", [0.003, 0.007, 0.015]),
        g,
        eta,
    )
    .unwrap();
    let size: u32 = std::env::var("SIZE")
        .map(|v| v.parse().unwrap())
        .unwrap_or(512);
    let refdir = std::env::var("REF").unwrap_or("/work/shared/data/wax-spheres".into());
    let settings = SimulationSettings {
        photons,
        estimator: est,
        image_size_px: size,
        sphere_radius_px: size as f32 * 230.0 / 512.0,
        ..Default::default()
    };
    let sim = simulate_sphere(&medium, r, &settings, &|_| {}).unwrap();
    println!(
        "r {r} photons {photons} {:.1} s noise lit {:?} term {:?} shadow {:?}",
        sim.seconds, sim.noise.lit, sim.noise.terminator, sim.noise.shadow
    );
    let reference = load_linear_image(
        format!("{refdir}/sphere_r{r}.exr").as_ref(),
        Some(ColorSpace::Linear),
        1.0,
    )
    .unwrap();
    let n = size as usize;
    let b = 8usize;
    let h = n as f64 / 2.0;
    let rp = size as f64 * 230.0 / 512.0;
    let mut err = [[0.0f64; 3]; 3];
    let mut cnt = [0usize; 3];
    let mut sums = [[[0.0f64; 3]; 2]; 3];
    for by in 0..n / b {
        for bx in 0..n / b {
            let mut inside = true;
            let mut s = [0.0f64; 3];
            let mut t = [0.0f64; 3];
            for j in 0..b {
                for i in 0..b {
                    let (c, rw) = (bx * b + i, by * b + j);
                    let x = (c as f64 + 0.5 - h) / rp;
                    let y = (h - rw as f64 - 0.5) / rp;
                    if x * x + y * y > ((rp - 2.0) / rp).powi(2) {
                        inside = false;
                    }
                    let p = sim.image.pixels[rw * n + c];
                    let q = reference.pixels[rw * n + c];
                    for k in 0..3 {
                        s[k] += p[k] as f64;
                        t[k] += q[k] as f64;
                    }
                }
            }
            if !inside {
                continue;
            }
            let x = ((bx * b + b / 2) as f64 - h) / rp;
            let cos = -x;
            let reg = if cos >= 0.26 {
                0
            } else if cos > -0.26 {
                1
            } else {
                2
            };
            cnt[reg] += 1;
            for k in 0..3 {
                err[reg][k] += (s[k] - t[k]).abs();
                sums[reg][0][k] += s[k];
                sums[reg][1][k] += t[k];
            }
        }
    }
    for reg in 0..3 {
        println!(
            "region {reg}: Σ|sim-ref|/Σref {:?}  Σsim/Σref {:?} ({} blocks)",
            (0..3)
                .map(|k| format!("{:.4}", err[reg][k] / sums[reg][1][k]))
                .collect::<Vec<_>>(),
            (0..3)
                .map(|k| format!("{:.4}", sums[reg][0][k] / sums[reg][1][k]))
                .collect::<Vec<_>>(),
            cnt[reg]
        );
    }
}
