//! Material presets (`cdrf_fit::preset`, the `cdrf-preset` binary): every named medium gives a
//! valid table carrying its albedo, coefficients given by hand equal the named medium, the CLI
//! writes the two files cdrf-core reads back and refuses bad input cleanly, and the wax preset
//! is held against the bundled measured fit and the wax sphere photographs.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cdrf_core::lut::{CdrfLut, Filter};
use cdrf_core::{Cdrf, read_gaussian, read_lut};
use cdrf_fit::curves::SphereSamples;
use cdrf_fit::dataset::Dataset;
use cdrf_fit::evaluate::{SphereError, sphere_error};
use cdrf_fit::image_io::load_linear_image;
use cdrf_fit::media::{self, MEDIA, NamedMedium, Source};
use cdrf_fit::preset::{DEON_SKIN, Preset, PresetProfile, PresetSettings, preset_names};
use cdrf_fit::sphere::{SphereView, detect_sphere, sample_sphere};
use glam::Vec3;

/// Small axes so that every preset tabulates quickly in a debug build.
const SMALL: PresetSettings = PresetSettings {
    max_curvature_per_mm: 1.0,
    curvature_count: 17,
    theta_count: 91,
};

/// Jensen et al. 2001's total diffuse reflectance, written out here from the paper (not taken
/// from the library): `R_d = α'/2 · (1 + e^(−4/3·A·√(3(1 − α')))) · e^(−√(3(1 − α')))`.
fn jensen_r_d(sigma_s_prime: f32, sigma_a: f32, eta: f32) -> f64 {
    let (s, a, n) = (f64::from(sigma_s_prime), f64::from(sigma_a), f64::from(eta));
    let alpha = s / (s + a);
    let f_dr = -1.440 / (n * n) + 0.710 / n + 0.668 + 0.0636 * n;
    let big_a = (1.0 + f_dr) / (1.0 - f_dr);
    let root = (3.0 * (1.0 - alpha)).sqrt();
    0.5 * alpha * (1.0 + (-4.0 / 3.0 * big_a * root).exp()) * (-root).exp()
}

/// What a preset's flat, head-on value must be: the dipole's R_d for Jensen's media, and 1 for
/// d'Eon & Luebke's skin (their weights sum to white in every channel).
fn expected_albedo(name: &str) -> [f64; 3] {
    if name == DEON_SKIN {
        return [1.0; 3];
    }
    let medium = media::find(name).unwrap();
    std::array::from_fn(|c| {
        jensen_r_d(
            (medium.sigma_s_per_mm[c] * (1.0 - medium.g)) as f32,
            medium.sigma_a_per_mm[c] as f32,
            medium.eta as f32,
        )
    })
}

/// Jensen et al. 2001's media (their σs is σs′: g = 0).
fn jensen() -> impl Iterator<Item = &'static NamedMedium> {
    MEDIA.iter().filter(|m| m.source == Source::Jensen2001)
}

#[track_caller]
fn assert_close(actual: f64, expected: f64, relative: f64, what: &str) {
    let difference = (actual - expected).abs();
    assert!(
        difference <= relative * expected.abs(),
        "{what}: {actual} vs {expected} (difference {difference}, allowed {relative} relative)"
    );
}

#[test]
fn every_named_preset_is_valid_and_flat_head_on_gives_its_albedo() {
    assert_eq!(preset_names().len(), MEDIA.len() + 1);
    let names: Vec<&str> = jensen().map(|m| m.name).chain([DEON_SKIN]).collect();
    assert_eq!(names.len(), 12, "{names:?}");
    for name in names {
        let preset = Preset::named(name).unwrap();
        let lut = preset.build_lut(&SMALL).unwrap();
        let dipole = preset.dipole_cdrf().unwrap();
        assert!(
            lut.radiance()
                .iter()
                .all(|v| v.is_finite() && v.min_element() >= 0.0),
            "{name}: a negative or non-finite value"
        );
        let r_d = expected_albedo(name);
        println!("{name}: R_d = {r_d:.4?}");
        for c in 0..3 {
            assert!(r_d[c] > 0.0 && r_d[c] <= 1.0, "{name}: R_d {r_d:?}");
            assert_close(dipole.albedo()[c], r_d[c], 1e-4, &format!("{name} albedo"));
            // Row 0 is flat: R_d · cos⁺θ (a white Lambertian surface would be cos⁺θ).
            for (column, value) in lut.row(0).iter().enumerate() {
                let theta = PI * column as f64 / (SMALL.theta_count - 1) as f64;
                let expected = r_d[c] * theta.cos().max(0.0);
                assert!(
                    (f64::from(value[c]) - expected).abs() < 1e-5,
                    "{name}: flat row at θ = {theta}: {} vs {expected}",
                    value[c]
                );
            }
            // Low curvature (r = 1 m): still R_d at θ = 0, to 1 %.
            let low = dipole.reflectance(1e-3, 0.0);
            assert_close(
                f64::from(low[c]),
                r_d[c],
                0.01,
                &format!("{name} at κ = 1e-3"),
            );
        }
        // Curvature blurs light past the terminator (a 15 mm sphere at θ = 100°) and takes
        // some from the lit pole.
        let shadow = dipole.reflectance(1.0 / 15.0, 100_f32.to_radians());
        let pole = dipole.reflectance(1.0 / 15.0, 0.0);
        for c in 0..3 {
            assert!(
                shadow[c] > 0.0,
                "{name}: no light past the terminator: {shadow:?}"
            );
            assert!(
                f64::from(pole[c]) < r_d[c],
                "{name}: pole {pole:?} vs R_d {r_d:?}"
            );
        }
        assert_eq!(
            lut.provenance().get("preset").map(String::as_str),
            Some(name)
        );
        assert_eq!(lut.view_correction().sample(0.05, 0.3, 1.2), Vec3::ONE);
    }
}

#[test]
fn names_are_case_insensitive_and_unknown_names_list_the_valid_ones() {
    let reference = Preset::named("Skimmilk").unwrap();
    for spelling in ["skimmilk", "SKIMMILK", "sKiMmIlK"] {
        assert_eq!(Preset::named(spelling).unwrap(), reference, "{spelling}");
    }
    assert_eq!(Preset::named("DEONSKIN").unwrap().name(), DEON_SKIN);
    let message = Preset::named("Plutonium").unwrap_err().to_string();
    for name in preset_names() {
        assert!(message.contains(name), "{message} lacks {name}");
    }
    assert!(message.contains("Plutonium"), "{message}");
}

#[test]
fn custom_coefficients_equal_the_named_medium() {
    for medium in jensen() {
        let named = Preset::named(medium.name).unwrap();
        let custom = Preset::dipole(
            medium.sigma_s_per_mm.map(|v| v as f32),
            medium.sigma_a_per_mm.map(|v| v as f32),
            medium.eta as f32,
        )
        .unwrap();
        let (a, b) = (named.dipole_cdrf().unwrap(), custom.dipole_cdrf().unwrap());
        assert_eq!(a.profile(), b.profile(), "{}", medium.name);
        assert!(matches!(a.profile(), PresetProfile::Dipole(_)));
        let (a, b) = (
            named.build_lut(&SMALL).unwrap(),
            custom.build_lut(&SMALL).unwrap(),
        );
        assert_eq!(a.radiance(), b.radiance(), "{}", medium.name);
    }
    // A different η is a different medium.
    let skin = Preset::named("Skin1").unwrap();
    let matched = skin.with_eta(1.0).unwrap();
    assert_ne!(
        matched.dipole_cdrf().unwrap().albedo(),
        skin.dipole_cdrf().unwrap().albedo(),
        "eta must matter"
    );
    assert_eq!(matched.medium().unwrap().eta, 1.0);
}

#[test]
fn bad_coefficients_are_typed_errors() {
    let ok = [1.0, 1.0, 1.0];
    for (sigma_s, sigma_a, eta, needle) in [
        ([-1.0, 1.0, 1.0], ok, 1.3, "sigma_s_prime_per_mm[0]"),
        ([1.0, 0.0, 1.0], ok, 1.3, "sigma_s_prime_per_mm[1]"),
        (ok, [0.1, f32::NAN, 0.1], 1.3, "sigma_a_per_mm[1]"),
        (ok, [0.1, 0.1, -0.1], 1.3, "sigma_a_per_mm[2]"),
        (ok, [0.1; 3], 0.5, "eta"),
        (ok, [0.1; 3], 100.0, "eta"),
        (ok, [0.1; 3], f32::INFINITY, "eta"),
    ] {
        let message = Preset::dipole(sigma_s, sigma_a, eta)
            .unwrap_err()
            .to_string();
        println!("{message}");
        assert!(message.contains(needle), "{message} lacks {needle}");
    }
}

// ---- the binary ----------------------------------------------------------------------------

/// A temporary folder to run `cdrf-preset` in; `out()` is not created here.
struct TestCommand {
    root: tempfile::TempDir,
}

impl TestCommand {
    fn new() -> Self {
        Self {
            root: tempfile::tempdir().expect("temporary directory"),
        }
    }

    fn out(&self) -> PathBuf {
        self.root.path().join("out")
    }

    fn run(&self, args: &[&str]) -> Output {
        Command::new(env!("CARGO_BIN_EXE_cdrf-preset"))
            .current_dir(self.root.path())
            .args(args)
            .output()
            .expect("run cdrf-preset")
    }

    /// Runs `args --out OUT` (the dipole model, small axes) and expects success.
    #[track_caller]
    fn ok(&self, args: &[&str]) -> String {
        let out = self.out();
        let mut all = args.to_vec();
        all.extend([
            "--out",
            out.to_str().unwrap(),
            "--model",
            "dipole",
            "--curvature-count",
            "17",
            "--theta-count",
            "91",
        ]);
        let output = self.run(&all);
        let stderr = String::from_utf8(output.stderr).unwrap();
        assert!(output.status.success(), "{all:?} failed:\n{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        stderr
    }

    /// Runs and expects a non-zero exit, an error message holding every needle, no panic, and
    /// nothing at OUT.
    #[track_caller]
    fn fails(&self, args: &[&str], needles: &[&str]) -> String {
        let output = self.run(args);
        let stderr = String::from_utf8(output.stderr).unwrap();
        println!("{args:?} → {:?}\n{stderr}", output.status.code());
        assert!(
            matches!(output.status.code(), Some(code) if code != 0),
            "{args:?} should have failed:\n{stderr}"
        );
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(stderr.starts_with("error"), "{stderr}");
        for needle in needles {
            assert!(
                stderr.contains(needle),
                "stderr lacks {needle:?}:\n{stderr}"
            );
        }
        assert!(
            !self.out().exists(),
            "a failed run left {}",
            self.out().display()
        );
        stderr
    }
}

fn file_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn cli_writes_both_files_that_cdrf_core_reads_back() {
    let cmd = TestCommand::new();
    let stderr = cmd.ok(&["marble"]);
    assert!(stderr.contains("wrote"), "{stderr}");
    assert_eq!(file_names(&cmd.out()), ["gaussian.toml", "measured.exr"]);

    let lut = read_lut(cmd.out().join("measured.exr")).unwrap();
    let axis = lut.curvature_axis();
    assert_eq!(
        (axis.min_per_mm, axis.max_per_mm, axis.count),
        (0.0, 1.0, 17)
    );
    assert_eq!(lut.theta_count(), 91);
    assert_eq!(
        lut,
        Preset::named("Marble").unwrap().build_lut(&SMALL).unwrap()
    );
    assert_eq!(lut.provenance()["preset"], "Marble");
    assert!(lut.provenance()["medium"].contains("Jensen"));

    let toml_path = cmd.out().join("gaussian.toml");
    let parameters = read_gaussian(&toml_path).unwrap();
    let (gaussian, g) = parameters.load_model(&toml_path).unwrap();
    assert_eq!(g, *lut.view_correction());
    // The Gaussian is fitted to the table: over the rows up to κ = 1/8 mm⁻¹ it follows it to
    // a few per cent of the table's energy.
    let (mut residual, mut energy) = (0.0, 0.0);
    for row in 0..=2 {
        let kappa = axis.curvature_per_mm(row);
        for (column, value) in lut.row(row).iter().enumerate() {
            let theta = std::f32::consts::PI * column as f32 / 90.0;
            let model = Vec3::from_array(gaussian.reflectance(kappa, theta));
            residual += (model - *value).length_squared();
            energy += value.length_squared();
        }
    }
    let relative = (residual / energy).sqrt();
    println!(
        "Gaussian vs marble table, κ ≤ 1/8 mm⁻¹: {:.2} % RMS",
        100.0 * relative
    );
    assert!(relative < 0.05, "{relative}");

    // Running again replaces the files and leaves nothing else.
    cmd.ok(&["Skin1"]);
    assert_eq!(file_names(&cmd.out()), ["gaussian.toml", "measured.exr"]);
    assert_eq!(
        read_lut(cmd.out().join("measured.exr"))
            .unwrap()
            .provenance()["preset"],
        "Skin1"
    );
}

#[test]
fn cli_custom_coefficients_equal_the_named_medium() {
    let (named, custom) = (TestCommand::new(), TestCommand::new());
    named.ok(&["Skin2"]);
    custom.ok(&[
        "--sigma-s",
        "1.09,1.59,1.79",
        "--sigma-a",
        "0.013, 0.070, 0.145",
    ]);
    let a = read_lut(named.out().join("measured.exr")).unwrap();
    let b = read_lut(custom.out().join("measured.exr")).unwrap();
    assert_eq!(a.radiance(), b.radiance());
    let (ga, gb) = (
        read_gaussian(named.out().join("gaussian.toml")).unwrap(),
        read_gaussian(custom.out().join("gaussian.toml")).unwrap(),
    );
    assert_eq!((ga.sigma_mm, ga.scale), (gb.sigma_mm, gb.scale));
}

#[test]
fn cli_lists_every_medium() {
    let output = TestCommand::new().run(&["--list"]);
    assert!(output.status.success());
    let stdout = String::from_utf8(output.stdout).unwrap();
    for name in preset_names() {
        assert!(stdout.contains(name), "{stdout} lacks {name}");
    }
}

/// The default model: simulated spheres through the fit (few photons, small radii: quick in a
/// debug build). The table is a full one, the same seed gives the same table, and the cache
/// answers the second call.
#[test]
fn cli_simulates_spheres_and_caches_them() {
    let cmd = TestCommand::new();
    let cache = cmd.root.path().join("cache");
    let out = cmd.out();
    let args = |out: &Path| {
        vec![
            "wax".to_owned(),
            "--photons".into(),
            "4000".into(),
            "--radii".into(),
            "4,6".into(),
            "--cache".into(),
            cache.to_str().unwrap().into(),
            "--out".into(),
            out.to_str().unwrap().into(),
        ]
    };
    let first = cmd.run(&args(&out).iter().map(String::as_str).collect::<Vec<_>>());
    let stderr = String::from_utf8(first.stderr).unwrap();
    assert!(first.status.success(), "{stderr}");
    assert!(
        stderr.contains("simulated spheres") && stderr.contains("θ = 150°"),
        "{stderr}"
    );
    let lut = read_lut(out.join("measured.exr")).unwrap();
    assert!(
        lut.translucency().is_some() || lut.diffusion_profile().is_some(),
        "{:?}",
        lut.provenance()
    );
    assert!(lut.provenance()["source"].contains("simulated"));
    assert!(lut.provenance()["simulation"].contains("photons = 4000"));
    assert!(lut.provenance()["simulation_noise"].contains("r = 4 mm"));
    let axis = lut.curvature_axis();
    assert!((axis.min_per_mm - 1.0 / 6.0).abs() < 1e-6 && (axis.max_per_mm - 0.25).abs() < 1e-6);

    let again = cmd.root.path().join("again");
    let second = cmd.run(&args(&again).iter().map(String::as_str).collect::<Vec<_>>());
    let stderr = String::from_utf8(second.stderr).unwrap();
    assert!(second.status.success(), "{stderr}");
    assert!(stderr.contains("from the cache"), "{stderr}");
    assert_eq!(
        read_lut(again.join("measured.exr")).unwrap().radiance(),
        lut.radiance()
    );

    // Without the cache the same seed simulates the same table again.
    let fresh = cmd.root.path().join("fresh");
    let mut uncached = args(&fresh);
    uncached.retain(|a| a != "--cache" && !a.ends_with("cache"));
    uncached.push("--no-cache".into());
    let third = cmd.run(&uncached.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(
        third.status.success(),
        "{}",
        String::from_utf8_lossy(&third.stderr)
    );
    assert_eq!(
        read_lut(fresh.join("measured.exr")).unwrap().radiance(),
        lut.radiance()
    );
}

#[test]
fn cli_bad_inputs_fail_cleanly_without_output() {
    let cmd = TestCommand::new();
    let out = cmd.out();
    let out = out.to_str().unwrap();
    cmd.fails(
        &["Plutonium", "--out", out],
        &[
            "unknown medium",
            "Plutonium",
            "Skin1",
            "LowfatMilk",
            "Wax",
            "dEonSkin",
        ],
    );
    let custom = |s: &'static str, a: &'static str| ["--sigma-s", s, "--sigma-a", a, "--out", out];
    let coefficients = "sigma_s and sigma_a must be finite and ≥ 0";
    cmd.fails(&custom("-1,1,1", "0.1,0.1,0.1"), &[coefficients, "-1.0"]);
    cmd.fails(&custom("1,1,1", "0.1,NaN,0.1"), &[coefficients, "NaN"]);
    cmd.fails(&custom("1,1,1", "0.1,0.1,-2"), &[coefficients, "-2.0"]);
    cmd.fails(
        &custom("1,1", "0.1,0.1,0.1"),
        &["--sigma-s", "3 comma-separated", "2"],
    );
    cmd.fails(
        &custom("1,1,1", "0.1,0.1,0.1,0.1"),
        &["--sigma-a", "3 comma-separated", "4"],
    );
    cmd.fails(&custom("1,x,1", "0.1,0.1,0.1"), &["not a number"]);
    for eta in ["0.5", "100", "-1", "nan"] {
        let mut args = custom("1,1,1", "0.1,0.1,0.1").to_vec();
        args.extend(["--eta", eta]);
        cmd.fails(&args, &["eta", "[1, 3]"]);
    }
    let mut args = custom("1,1,1", "0.1,0.1,0.1").to_vec();
    args.extend(["--g", "1.5"]);
    cmd.fails(&args, &["g must be in (−0.99, 0.99)"]);
    // A medium the simulator takes but the dipole cannot (red does not scatter).
    cmd.fails(
        &[
            "--sigma-s",
            "0,1,1",
            "--sigma-a",
            "0.1,0.1,0.1",
            "--model",
            "dipole",
            "--out",
            out,
        ],
        &["sigma_s_prime_per_mm[0]"],
    );
    cmd.fails(
        &["dEonSkin", "--out", out],
        &["not a scattering medium", "--model dipole"],
    );
    cmd.fails(
        &["Marble", "--out", out, "--radii", "20"],
        &["--radii", "2"],
    );
    cmd.fails(
        &["Marble", "--out", out, "--radii", "20,20"],
        &["two different radii"],
    );
    cmd.fails(&["Marble", "--out", out, "--photons", "10"], &["--photons"]);
    cmd.fails(
        &[
            "Marble",
            "--out",
            out,
            "--model",
            "dipole",
            "--max-curvature-per-mm",
            "0",
        ],
        &["curvature axis"],
    );
    cmd.fails(
        &[
            "Marble",
            "--sigma-s",
            "1,1,1",
            "--sigma-a",
            "1,1,1",
            "--out",
            out,
        ],
        &["cannot be used"],
    );
    cmd.fails(&["--sigma-s", "1,1,1", "--out", out], &["--sigma-a"]);
    cmd.fails(&["--g", "0.5", "Marble", "--out", out], &["--sigma-s"]);
    cmd.fails(&["--out", out], &["required"]);
    cmd.fails(&["Marble"], &["--out"]);

    // --out naming an existing file: refused, and the file is left as it was.
    let file = cmd.root.path().join("not-a-folder");
    std::fs::write(&file, "keep me").unwrap();
    cmd.fails(
        &["Marble", "--out", file.to_str().unwrap()],
        &["not-a-folder", "not a folder"],
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep me");
}

// ---- the wax spheres -----------------------------------------------------------------------

/// The wax of the bundled photographs (`data/README.md`): σ_t = 1 mm⁻¹, single-scattering
/// albedo (0.997, 0.993, 0.985), isotropic phase (so σs′ = σs), index-matched boundary (η = 1).
fn wax_preset() -> Preset {
    let albedo = [0.997_f32, 0.993, 0.985];
    let sigma_t = 1.0_f32;
    Preset::dipole(
        albedo.map(|a| a * sigma_t),
        albedo.map(|a| (1.0 - a) * sigma_t),
        1.0,
    )
    .unwrap()
}

fn data_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(name);
    assert!(dir.is_dir(), "bundled data missing at {}", dir.display());
    dir
}

/// Every usable pixel of every bundled wax sphere, as `cdrf-fit` samples them (detected
/// silhouette, 2 px edge margin), with its radius.
fn wax_samples() -> Vec<(f32, SphereSamples)> {
    let dataset = Dataset::load(&data_dir("wax-spheres")).unwrap();
    dataset
        .spheres
        .iter()
        .map(|entry| {
            let image = load_linear_image(&entry.image, entry.color_space, entry.exposure).unwrap();
            let (w, h) = (image.width as usize, image.height as usize);
            let detection = detect_sphere(w, h, &image.pixels).unwrap();
            let view = SphereView::with_silhouette(
                detection.circle,
                dataset.camera.projection,
                w,
                h,
                &detection.edge_points,
            );
            let (samples, _) = sample_sphere(
                &view,
                &image,
                &(&dataset.light).into(),
                2.0,
                None,
                false,
                None,
            );
            let samples = SphereSamples {
                curvature_per_mm: 1.0 / entry.radius_mm,
                image_width: image.width,
                samples,
            };
            (entry.radius_mm, samples)
        })
        .collect()
}

/// The numbers of docs/presets.md: the wax presets against the eight path-traced photographs
/// (the `cdrf_core::block_error` regions, 8 × 8 px blocks), per radius: the measured fit
/// (`data/wax-fit/measured.exr`, fitted to these very photographs), the built-in preset
/// (`cdrf_core::presets`, simulated spheres fitted as photographs) and the dipole preset.
#[test]
fn wax_presets_against_the_photographs() {
    let simulated = cdrf_core::presets::lut("wax").unwrap();
    let dipole = wax_preset().build_lut(&PresetSettings::default()).unwrap();
    let measured = read_lut(data_dir("wax-fit").join("measured.exr")).unwrap();
    println!(
        "mean relative error (Σ|model − data| / Σ data) on the photographs, lit | terminator | shadow"
    );
    println!("radius | measured fit | simulated preset | dipole preset (g = 1)");
    let percent = |e: &SphereError| {
        format!(
            "{:5.2} | {:5.2} | {:5.2}",
            100.0 * e.lit.mean_relative_error,
            100.0 * e.terminator.mean_relative_error,
            100.0 * e.shadow.mean_relative_error
        )
    };
    for (radius_mm, sphere) in wax_samples() {
        let kappa = sphere.curvature_per_mm;
        let error = |lut: &CdrfLut| {
            sphere_error(&sphere, |theta, phi| {
                lut.evaluate(kappa, theta, phi, Filter::Bilinear)
            })
        };
        let (fit, preset, old) = (error(&measured), error(simulated), error(&dipole));
        println!(
            "{radius_mm:>4} mm | {} | {} | {}",
            percent(&fit),
            percent(&preset),
            percent(&old)
        );
        assert!(preset.lit.blocks > 0 && preset.shadow.blocks > 0);
        // The bounds of the issue that asked for simulated presets: lit 2 %, terminator 3 %,
        // shadow 15 % (the fit to these very photographs reaches 15.5 % on the 50 mm sphere,
        // whose shadow side the photographs' own noise dominates).
        assert!(preset.lit.mean_relative_error < 0.02, "{radius_mm} mm lit");
        assert!(
            preset.terminator.mean_relative_error < 0.03,
            "{radius_mm} mm terminator"
        );
        assert!(
            preset.shadow.mean_relative_error < 0.15,
            "{radius_mm} mm shadow"
        );
        // The dipole is what the simulated spheres replace: it is far off past the terminator.
        assert!(old.shadow.mean_relative_error > 3.0 * preset.shadow.mean_relative_error);
    }
}
