//! The LUT file: round trip, and clear errors for files that are not (valid) cdrf LUTs.

use cdrf_core::lut::{Cdrf, CdrfLut, CurvatureAxis, TexelCoverage, ViewCorrection};
use cdrf_core::lut_file::{LutFileError, read_lut, write_lut};
use glam::Vec3;

struct Ramp;

impl Cdrf for Ramp {
    fn reflectance(&self, curvature_per_mm: f32, theta_rad: f32) -> [f32; 3] {
        let value = (1.0 + theta_rad.cos()) * (1.0 + 10.0 * curvature_per_mm);
        [value, 0.5 * value, 0.25 * value + curvature_per_mm]
    }
}

fn fitted_like_table() -> CdrfLut {
    let axis = CurvatureAxis::from_radii_mm(50.0, 15.0, 8);
    let lut = CdrfLut::tabulate(&Ramp, axis, 64).unwrap();
    let coverage = (0..lut.radiance().len())
        .map(|i| TexelCoverage {
            sample_count: (i % 7) as f32 * 100.0,
            relative_spread: (i % 5) as f32 * 0.01,
        })
        .collect();
    let view: Vec<Vec3> = (0..12)
        .map(|i| Vec3::new(1.0, 1.0 + i as f32 * 0.05, 0.9))
        .collect();
    lut.with_coverage(coverage)
        .unwrap()
        .with_view_correction(ViewCorrection::new(4, 3, view).unwrap())
        .with_provenance("tool", "cdrf-core tests")
        .with_provenance("input", "wax spheres r = 15…50 mm (UTF-8: κ, θ, φ)")
}

#[test]
fn round_trip_keeps_everything() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("measured.exr");
    let lut = fitted_like_table();
    write_lut(&lut, &path).unwrap();
    let back = read_lut(&path).unwrap();
    assert_eq!(
        back, lut,
        "the table read back differs from the one written"
    );
    // No temporary file is left next to it.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("measured.exr")]);

    // A view correction with curvature layers (format version 5) too.
    let layers = CurvatureAxis::from_radii_mm(50.0, 15.0, 3);
    let layered: Vec<Vec3> = (0..36)
        .map(|i| Vec3::new(1.0, 0.8 + i as f32 * 0.02, 0.9))
        .collect();
    let lut_layered = fitted_like_table().with_view_correction(
        ViewCorrection::with_curvature_layers(4, 3, layers, layered).unwrap(),
    );
    write_lut(&lut_layered, &path).unwrap();
    assert_eq!(read_lut(&path).unwrap(), lut_layered);

    // Without coverage and with the default view correction too.
    let plain = CdrfLut::tabulate(&Ramp, CurvatureAxis::from_radii_mm(40.0, 20.0, 3), 5).unwrap();
    write_lut(&plain, &path).unwrap();
    assert_eq!(read_lut(&path).unwrap(), plain);
}

#[test]
fn an_image_tool_sees_the_table_as_rgb() {
    // Any OpenEXR reader finds the radiance as R, G, B of the `cdrf.lut` layer, θ across.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lut.exr");
    let lut = fitted_like_table();
    write_lut(&lut, &path).unwrap();
    let image = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    let layer = image
        .layer_data
        .iter()
        .find(|l| {
            l.attributes
                .layer_name
                .as_ref()
                .is_some_and(|n| n == "cdrf.lut")
        })
        .expect("a cdrf.lut layer");
    assert_eq!((layer.size.width(), layer.size.height()), (64, 8));
    let red = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name == *"R")
        .unwrap();
    let values: Vec<f32> = red.sample_data.values_as_f32().collect();
    assert_eq!(values[3 * 64 + 10], lut.row(3)[10].x);
}

fn write_bytes(name: &str, bytes: &[u8]) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    (dir, path)
}

#[test]
fn missing_file_names_the_path() {
    let error = read_lut("/nonexistent/measured.exr").unwrap_err();
    assert!(matches!(error, LutFileError::Io { .. }), "{error:?}");
    assert!(
        error.to_string().contains("/nonexistent/measured.exr"),
        "{error}"
    );
}

#[test]
fn a_file_that_is_not_exr_is_refused() {
    let (_dir, path) = write_bytes("notes.exr", b"this is not an image");
    let error = read_lut(&path).unwrap_err();
    assert!(matches!(error, LutFileError::Exr { .. }), "{error:?}");
    assert!(error.to_string().contains("notes.exr"), "{error}");
}

#[test]
fn a_truncated_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("whole.exr");
    write_lut(&fitted_like_table(), &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let (_dir, truncated) = write_bytes("truncated.exr", &bytes[..bytes.len() / 2]);
    let error = read_lut(&truncated).unwrap_err();
    assert!(matches!(error, LutFileError::Exr { .. }), "{error:?}");
}

#[test]
fn an_ordinary_exr_image_is_not_a_lut() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("photo.exr");
    exr::prelude::write_rgb_file(&path, 4, 3, |x, y| (x as f32, y as f32, 0.0)).unwrap();
    let error = read_lut(&path).unwrap_err();
    assert!(
        matches!(error, LutFileError::NotACdrfLut { .. }),
        "{error:?}"
    );
    assert!(
        error.to_string().contains("photo.exr: not a cdrf LUT"),
        "{error}"
    );
}

/// Rewrites one attribute of a valid LUT file's `cdrf.lut` layer.
fn tampered(
    edit: impl FnOnce(&mut exr::prelude::LayerAttributes),
) -> (tempfile::TempDir, std::path::PathBuf) {
    use exr::prelude::WritableImage;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tampered.exr");
    write_lut(&fitted_like_table(), &path).unwrap();
    let mut image = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    let layer = image
        .layer_data
        .iter_mut()
        .find(|l| {
            l.attributes
                .layer_name
                .as_ref()
                .is_some_and(|n| n == "cdrf.lut")
        })
        .unwrap();
    edit(&mut layer.attributes);
    image.write().to_file(&path).unwrap();
    (dir, path)
}

#[test]
fn a_newer_format_version_is_refused_clearly() {
    use exr::prelude::{AttributeValue, Text};
    let (_dir, path) = tampered(|a| {
        a.other
            .insert(Text::from("cdrf.version"), AttributeValue::I32(7));
    });
    let error = read_lut(&path).unwrap_err();
    assert!(
        matches!(error, LutFileError::UnsupportedVersion { found: 7, .. }),
        "{error:?}"
    );
    assert!(error.to_string().contains("version 7"), "{error}");
}

#[test]
fn another_axis_convention_is_refused() {
    use exr::prelude::{AttributeValue, Text};
    let (_dir, path) = tampered(|a| {
        a.other.insert(
            Text::from("cdrf.theta_axis"),
            AttributeValue::Text(Text::from("uniform cos theta [-1, 1]")),
        );
    });
    let error = read_lut(&path).unwrap_err();
    assert!(error.to_string().contains("cdrf.theta_axis"), "{error}");
}

#[test]
fn a_wrong_curvature_range_is_refused() {
    use exr::prelude::{AttributeValue, Text};
    let (_dir, path) = tampered(|a| {
        a.other.insert(
            Text::from("cdrf.curvature_min_per_mm"),
            AttributeValue::F32(1.0),
        );
    });
    let error = read_lut(&path).unwrap_err();
    assert!(
        matches!(error, LutFileError::InvalidTable { .. }),
        "{error:?}"
    );
    assert!(error.to_string().contains("curvature axis"), "{error}");
}

#[test]
fn writing_into_a_missing_directory_fails_cleanly() {
    let error = write_lut(&fitted_like_table(), "/nonexistent/dir/measured.exr").unwrap_err();
    assert!(
        error.to_string().contains("/nonexistent/dir/measured.exr"),
        "{error}"
    );
}

#[test]
fn a_failed_write_leaves_the_old_file_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("measured.exr");
    std::fs::write(&path, b"previous contents").unwrap();
    let result = cdrf_core::atomic::write_file(&path, |file| {
        use std::io::Write;
        file.write_all(b"half a tab")?;
        Err(std::io::Error::other("encoder gave up"))
    });
    assert!(result.is_err());
    assert_eq!(std::fs::read(&path).unwrap(), b"previous contents");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "temporary file left behind"
    );
}

fn wax_like_translucency() -> cdrf_core::Translucency {
    let transmission =
        cdrf_core::TransmissionProfile::new([0.3, 0.2, 0.1], [12.0, 8.0, 5.5]).unwrap();
    cdrf_core::Translucency::new([5.4, 5.1, 4.9], transmission).unwrap()
}

#[test]
fn translucency_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("measured.exr");
    let lut = fitted_like_table().with_translucency(wax_like_translucency());
    write_lut(&lut, &path).unwrap();
    let back = read_lut(&path).unwrap();
    assert_eq!(back.translucency(), Some(&wax_like_translucency()));
    assert_eq!(back, lut);
}

/// `fixtures/lut-v1.exr` is the bundled wax fit as format version 1 wrote it (before
/// translucency): it must keep loading, without translucency.
#[test]
fn a_version_1_file_still_loads() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/lut-v1.exr");
    let lut = read_lut(&path).unwrap();
    assert_eq!(lut.translucency(), None);
    assert_eq!(lut.curvature_axis().count, 64);
    assert!(lut.coverage().is_some());
    // Lit side of the r = 15 mm row is bright, its far shadow side dim but not black.
    let row = lut.row(lut.curvature_axis().count - 1);
    assert!(row[0].x > 0.5 && row[row.len() - 1].x > 0.0);
}

/// `fixtures/lut-v2.exr` is the bundled wax fit as format version 2 wrote it (T(d) without the
/// entry cosine): it must keep loading, with entry cosine power 0 so it renders as it did.
#[test]
fn a_version_2_file_still_loads() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/lut-v2.exr");
    let lut = read_lut(&path).unwrap();
    let translucency = lut
        .translucency()
        .expect("version 2 file with translucency");
    let t = translucency.transmission;
    assert_eq!(t.entry_cosine_power, 0.0);
    // The version 2 fit of the wax spheres: A ≈ 0.028, ℓ ≈ 12.1 mm (red), σ ≈ 5.4 mm.
    assert!((t.amplitude[0] - 0.028).abs() < 1e-3, "{t:?}");
    assert!((t.length_mm[0] - 12.1).abs() < 0.1, "{t:?}");
    assert!((translucency.scattering_length_mm[0] - 5.4).abs() < 0.1);
    assert_eq!(t.evaluate(10.0, 0.1), t.evaluate(10.0, 1.0));
}

#[test]
fn translucency_attributes_come_together() {
    use exr::prelude::{AttributeValue, Text};
    let (_dir, path) = tampered(|a| {
        a.other.insert(
            Text::from("cdrf.scattering_length_mm"),
            AttributeValue::FloatVec3((5.0, 5.0, 5.0)),
        );
    });
    let error = read_lut(&path).unwrap_err();
    assert!(error.to_string().contains("must come together"), "{error}");

    let (_dir, path) = tampered(|a| {
        for (name, value) in [
            ("cdrf.scattering_length_mm", (5.0, 5.0, 5.0)),
            ("cdrf.transmission.amplitude", (0.1, 0.1, 0.1)),
            ("cdrf.transmission.length_mm", (10.0, -1.0, 10.0)),
        ] {
            a.other
                .insert(Text::from(name), AttributeValue::FloatVec3(value));
        }
        a.other.insert(
            Text::from("cdrf.transmission.entry_cosine_power"),
            AttributeValue::F32(1.0),
        );
    });
    let error = read_lut(&path).unwrap_err();
    assert!(error.to_string().contains("transmission length"), "{error}");

    // Version 3: A, ℓ and σ without the entry cosine power are incomplete.
    let (_dir, path) = tampered(|a| {
        for (name, value) in [
            ("cdrf.scattering_length_mm", (5.0, 5.0, 5.0)),
            ("cdrf.transmission.amplitude", (0.1, 0.1, 0.1)),
            ("cdrf.transmission.length_mm", (10.0, 10.0, 10.0)),
        ] {
            a.other
                .insert(Text::from(name), AttributeValue::FloatVec3(value));
        }
    });
    let error = read_lut(&path).unwrap_err();
    assert!(error.to_string().contains("must come together"), "{error}");
}

fn wax_like_diffusion() -> cdrf_core::diffusion::DiffusionProfile {
    use cdrf_core::diffusion::{DiffusionProfile, ProfileTerm};
    DiffusionProfile::new(
        vec![
            ProfileTerm {
                length_mm: 0.5,
                weight: [0.2, 0.3, 0.4],
            },
            ProfileTerm {
                length_mm: 6.0,
                weight: [0.6, 0.4, 0.2],
            },
        ],
        0.8,
    )
    .unwrap()
}

#[test]
fn diffusion_profile_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("measured.exr");
    let lut = fitted_like_table()
        .with_translucency(wax_like_translucency())
        .with_diffusion_profile(wax_like_diffusion());
    write_lut(&lut, &path).unwrap();
    let back = read_lut(&path).unwrap();
    assert_eq!(back.diffusion_profile(), Some(&wax_like_diffusion()));
    assert_eq!(back, lut);
}

/// `fixtures/lut-v3.exr` is the bundled wax fit as format version 3 wrote it (before the
/// diffusion profile): it must keep loading, with its translucency and no profile.
#[test]
fn a_version_3_file_still_loads() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/lut-v3.exr");
    let lut = read_lut(&path).unwrap();
    assert_eq!(lut.diffusion_profile(), None);
    let t = lut
        .translucency()
        .expect("version 3 file with translucency");
    assert_eq!(t.transmission.entry_cosine_power, 1.0);
}

#[test]
fn diffusion_attributes_are_checked() {
    use exr::prelude::{AttributeValue, Text};
    let with_profile = |edit: &dyn Fn(&mut exr::prelude::LayerAttributes)| {
        tampered(|a| {
            a.other
                .insert(Text::from("cdrf.diffusion.terms"), AttributeValue::I32(2));
            for (k, length) in [(0, 0.5), (1, 6.0)] {
                a.other.insert(
                    Text::from(format!("cdrf.diffusion.term_{k}.length_mm").as_str()),
                    AttributeValue::F32(length),
                );
                a.other.insert(
                    Text::from(format!("cdrf.diffusion.term_{k}.weight").as_str()),
                    AttributeValue::FloatVec3((0.3, 0.2, 0.1)),
                );
            }
            a.other.insert(
                Text::from("cdrf.diffusion.entry_cosine_power"),
                AttributeValue::F32(0.8),
            );
            edit(a);
        })
    };
    // Complete: loads.
    let (_dir, path) = with_profile(&|_| {});
    let lut = read_lut(&path).unwrap();
    assert_eq!(lut.diffusion_profile().unwrap().terms().len(), 2);
    // A missing weight, a count out of range, a negative weight, lengths out of order and a
    // power without terms are each refused with the attribute named.
    for (edit, says) in [
        (
            Box::new(|a: &mut exr::prelude::LayerAttributes| {
                a.other.remove(&Text::from("cdrf.diffusion.term_1.weight"));
            }) as Box<dyn Fn(&mut exr::prelude::LayerAttributes)>,
            "cdrf.diffusion.term_1.weight",
        ),
        (
            Box::new(|a: &mut exr::prelude::LayerAttributes| {
                a.other
                    .insert(Text::from("cdrf.diffusion.terms"), AttributeValue::I32(17));
            }),
            "cdrf.diffusion.terms",
        ),
        (
            Box::new(|a: &mut exr::prelude::LayerAttributes| {
                a.other.insert(
                    Text::from("cdrf.diffusion.term_0.weight"),
                    AttributeValue::FloatVec3((0.3, -0.2, 0.1)),
                );
            }),
            "weight",
        ),
        (
            Box::new(|a: &mut exr::prelude::LayerAttributes| {
                a.other.insert(
                    Text::from("cdrf.diffusion.term_1.length_mm"),
                    AttributeValue::F32(0.1),
                );
            }),
            "length",
        ),
        (
            Box::new(|a: &mut exr::prelude::LayerAttributes| {
                a.other.remove(&Text::from("cdrf.diffusion.terms"));
            }),
            "without `cdrf.diffusion.terms`",
        ),
    ] {
        let (_dir, path) = with_profile(&*edit);
        let error = read_lut(&path).unwrap_err();
        assert!(
            matches!(error, LutFileError::NotACdrfLut { .. }) && error.to_string().contains(says),
            "{error}"
        );
        assert!(error.to_string().contains("tampered.exr"), "{error}");
    }
}
