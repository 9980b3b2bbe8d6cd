//! Loading images as linear radiance: every format round-trips through a temp file, plus the
//! bundled path-traced EXRs.

use std::path::{Path, PathBuf};
use std::time::Instant;

use cdrf_fit::image_io::{
    CodeStep, ColorSpace, Decoding, ImageError, LinearImage, SampleFormat, SensorLevels,
    load_linear_image, load_linear_image_with, srgb_to_linear,
};
use glam::Vec3;
use image::{ImageBuffer, Luma, Rgb, Rgba};

#[track_caller]
fn assert_close(actual: f32, expected: f32, eps: f32, what: &str) {
    let diff = (actual - expected).abs();
    assert!(
        diff <= eps,
        "{what}: got {actual}, expected {expected} (|diff| = {diff:e} > eps = {eps:e})"
    );
}

#[track_caller]
fn assert_vec3_close(actual: Vec3, expected: Vec3, eps: f32, what: &str) {
    let diff = (actual - expected).abs().max_element();
    assert!(
        diff <= eps,
        "{what}: got {actual}, expected {expected} (max |diff| = {diff:e} > eps = {eps:e})"
    );
}

fn data_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/wax-spheres");
    assert!(
        dir.join("sphere_r35.exr").is_file(),
        "bundled data missing: {} (it is part of the repository)",
        dir.display()
    );
    dir
}

fn load(path: &Path) -> LinearImage {
    load_linear_image(path, None, 1.0)
        .unwrap_or_else(|e| panic!("loading {} failed: {e}", path.display()))
}

/// 4 × 2 RGB test pattern of 8-bit codes; pixel (3, 1) is clipped in one channel.
fn pattern_u8() -> ImageBuffer<Rgb<u8>, Vec<u8>> {
    let codes: [[u8; 3]; 8] = [
        [0, 0, 0],
        [10, 11, 12],
        [128, 64, 32],
        [200, 100, 50],
        [1, 2, 3],
        [254, 254, 254],
        [90, 180, 45],
        [255, 7, 7],
    ];
    ImageBuffer::from_fn(4, 2, |x, y| Rgb(codes[(y * 4 + x) as usize]))
}

#[test]
fn srgb_curve_exact_values() {
    assert_eq!(srgb_to_linear(0.0), 0.0);
    assert_close(srgb_to_linear(1.0), 1.0, 1e-6, "sRGB(1)");
    // At the boundary both pieces give 0.04045 / 12.92 = 0.0031308.
    assert_close(
        srgb_to_linear(0.04045),
        0.04045 / 12.92,
        1e-9,
        "sRGB(0.04045)",
    );
    let above = ((0.04045_f32 + 1e-4 + 0.055) / 1.055).powf(2.4);
    assert_close(
        srgb_to_linear(0.04045 + 1e-4),
        above,
        1e-9,
        "sRGB just above",
    );
    assert_close(srgb_to_linear(0.5), 0.214_041_14, 1e-6, "sRGB(0.5)");
    // Negative float values are decoded sign-symmetrically.
    assert_close(srgb_to_linear(-0.5), -0.214_041_14, 1e-6, "sRGB(-0.5)");
}

#[test]
fn png_8bit_defaults_to_srgb_and_flags_255() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p8.png");
    let source = pattern_u8();
    source.save(&path).unwrap();

    let image = load(&path);
    assert_eq!((image.width, image.height), (4, 2));
    assert_eq!(image.sample_format, SampleFormat::U8);
    assert_eq!(image.color_space, ColorSpace::Srgb);
    for (x, y, px) in source.enumerate_pixels() {
        let expected = Vec3::from_array(px.0.map(|c| srgb_to_linear(f32::from(c) / 255.0)));
        assert_vec3_close(
            image.pixel(x, y),
            expected,
            1e-7,
            &format!("pixel ({x}, {y})"),
        );
        let clipped = px.0.contains(&255);
        assert_eq!(
            image.saturated[(y * 4 + x) as usize],
            clipped,
            "saturation of ({x}, {y})"
        );
    }
    // Codes 10 and 11 straddle the sRGB curve's linear segment (0.04045 × 255 = 10.3).
    assert_close(image.pixel(1, 0).x, 10.0 / 255.0 / 12.92, 1e-8, "code 10");
    assert_close(
        image.pixel(1, 0).y,
        ((11.0 / 255.0 + 0.055) / 1.055f32).powf(2.4),
        1e-8,
        "code 11",
    );
    assert_eq!(image.pixel(0, 0), Vec3::ZERO);
    assert_close(image.pixel(3, 1).x, 1.0, 1e-6, "code 255");
    assert_eq!(image.saturated_count(), 1);

    let linear = load_linear_image(&path, Some(ColorSpace::Linear), 1.0).unwrap();
    assert_eq!(linear.color_space, ColorSpace::Linear);
    assert_close(linear.pixel(2, 0).x, 128.0 / 255.0, 1e-7, "linear 128");
}

#[test]
fn each_file_knows_the_width_of_its_codes() {
    let dir = tempfile::tempdir().unwrap();
    // 8-bit sRGB: the step above a code is the distance to the next code's value.
    let png = dir.path().join("p8.png");
    pattern_u8().save(&png).unwrap();
    let image = load_linear_image(&png, None, 2.0).unwrap();
    assert!(!image.code_step.lossy());
    for code in [0.0_f32, 1.0, 10.0, 11.0, 128.0] {
        let value = 2.0 * srgb_to_linear(code / 255.0);
        let next = 2.0 * srgb_to_linear((code + 1.0) / 255.0);
        assert_close(image.code_step.at(value), next - value, 1e-7, "sRGB step");
    }
    // JPEG: the same codes, compressed.
    let jpg = dir.path().join("p8.jpg");
    pattern_u8().save(&jpg).unwrap();
    assert!(load(&jpg).code_step.lossy());
    // 16-bit linear: 1/65535 everywhere; sensor levels: 1/(white − black), times the exposure.
    let png16 = dir.path().join("p16.png");
    ImageBuffer::<Rgb<u16>, _>::from_fn(2, 1, |x, _| Rgb([x as u16 * 600; 3]))
        .save(&png16)
        .unwrap();
    assert_eq!(
        load(&png16).code_step,
        CodeStep::Linear {
            step: 1.0 / 65535.0,
            lossy: false
        }
    );
    let decoding = Decoding {
        levels: Some(SensorLevels {
            black: 512,
            white: 16383,
        }),
        exposure: 2.0,
        ..Decoding::default()
    };
    let raw = load_linear_image_with(&png16, &decoding).unwrap();
    assert_close(raw.code_step.at(0.3), 2.0 / 15871.0, 1e-9, "levels step");
    // Float files have none.
    let exr = data_dir().join("sphere_r35.exr");
    assert_eq!(load(&exr).code_step, CodeStep::Float);
}

#[test]
fn exposure_scales_and_must_be_positive() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p8.png");
    pattern_u8().save(&path).unwrap();
    let one = load(&path);
    let four = load_linear_image(&path, None, 4.0).unwrap();
    for (a, b) in one.pixels.iter().zip(&four.pixels) {
        assert_vec3_close(*b, *a * 4.0, 1e-6, "exposure 4");
    }
    assert_eq!(
        one.saturated, four.saturated,
        "saturation is judged before the exposure"
    );
    for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let err = load_linear_image(&path, None, bad).unwrap_err();
        assert!(matches!(err, ImageError::InvalidExposure { .. }), "{err}");
        assert!(err.to_string().contains("p8.png"), "{err}");
    }
}

#[test]
fn png_16bit_defaults_to_linear_and_flags_65535() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p16.png");
    let codes: [[u16; 3]; 4] = [
        [0, 1, 2],
        [1000, 30000, 65534],
        [65535, 0, 0],
        [12345, 54321, 777],
    ];
    let source: ImageBuffer<Rgb<u16>, Vec<u16>> =
        ImageBuffer::from_fn(2, 2, |x, y| Rgb(codes[(y * 2 + x) as usize]));
    source.save(&path).unwrap();

    let image = load(&path);
    assert_eq!(image.sample_format, SampleFormat::U16);
    assert_eq!(image.color_space, ColorSpace::Linear);
    for (x, y, px) in source.enumerate_pixels() {
        let expected = Vec3::from_array(px.0.map(|c| f32::from(c) / 65535.0));
        assert_vec3_close(
            image.pixel(x, y),
            expected,
            1e-7,
            &format!("pixel ({x}, {y})"),
        );
    }
    assert_eq!(image.saturated, vec![false, false, true, false]);

    let srgb = load_linear_image(&path, Some(ColorSpace::Srgb), 1.0).unwrap();
    assert_close(
        srgb.pixel(1, 1).x,
        srgb_to_linear(12345.0 / 65535.0),
        1e-7,
        "16-bit sRGB",
    );
}

#[test]
fn grey_and_alpha_become_rgb_and_alpha_is_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let grey_path = dir.path().join("grey16.png");
    let grey: ImageBuffer<Luma<u16>, Vec<u16>> =
        ImageBuffer::from_fn(3, 1, |x, _| Luma([[0, 32768, 65535][x as usize]]));
    grey.save(&grey_path).unwrap();
    let image = load(&grey_path);
    assert_vec3_close(
        image.pixel(1, 0),
        Vec3::splat(32768.0 / 65535.0),
        1e-7,
        "grey",
    );
    assert_eq!(image.saturated, vec![false, false, true]);

    let rgba_path = dir.path().join("rgba.png");
    let rgba: ImageBuffer<Rgba<u8>, Vec<u8>> =
        ImageBuffer::from_fn(2, 1, |x, _| Rgba([200, 100, 50, [0, 255][x as usize]]));
    rgba.save(&rgba_path).unwrap();
    let image = load_linear_image(&rgba_path, Some(ColorSpace::Linear), 1.0).unwrap();
    let expected = Vec3::new(200.0, 100.0, 50.0) / 255.0;
    assert_vec3_close(
        image.pixel(0, 0),
        expected,
        1e-7,
        "alpha 0 keeps its colour",
    );
    assert_vec3_close(image.pixel(1, 0), expected, 1e-7, "alpha 255");
    assert_eq!(
        image.saturated_count(),
        0,
        "an opaque alpha of 255 is not clipping"
    );
}

#[test]
fn jpeg_decodes_close_to_the_source_and_flags_near_white() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("photo.jpg");
    // Left half a mid colour, right half white: flat 8 × 8 blocks survive JPEG almost exactly.
    let source: ImageBuffer<Rgb<u8>, Vec<u8>> = ImageBuffer::from_fn(32, 16, |x, _| {
        if x < 16 {
            Rgb([120, 120, 120])
        } else {
            Rgb([255; 3])
        }
    });
    source.save(&path).unwrap();
    let image = load(&path);
    assert_eq!(
        (image.width, image.height, image.sample_format),
        (32, 16, SampleFormat::U8)
    );
    assert_eq!(image.color_space, ColorSpace::Srgb);
    let expected = srgb_to_linear(120.0 / 255.0);
    let got = image.pixel(4, 8).x;
    println!("JPEG: code 120 decodes to {got:.5} (exact {expected:.5})");
    assert_close(got, expected, 0.01, "JPEG mid grey");
    assert!(
        !image.saturated[8 * 32 + 4],
        "mid grey flagged as saturated"
    );
    assert!(
        image.saturated[8 * 32 + 28],
        "white not flagged as saturated"
    );
}

#[test]
fn tiff_8_16_and_float() {
    let dir = tempfile::tempdir().unwrap();

    let p8 = dir.path().join("t8.tif");
    pattern_u8().save(&p8).unwrap();
    let image = load(&p8);
    assert_eq!(
        (image.sample_format, image.color_space),
        (SampleFormat::U8, ColorSpace::Srgb)
    );
    assert_close(
        image.pixel(2, 0).x,
        srgb_to_linear(128.0 / 255.0),
        1e-7,
        "TIFF 8",
    );
    assert_eq!(image.saturated_count(), 1);

    let p16 = dir.path().join("t16.tiff");
    let source16: ImageBuffer<Rgb<u16>, Vec<u16>> = ImageBuffer::from_fn(2, 1, |x, _| {
        Rgb([[40000, 2, 3], [65535, 65535, 65535]][x as usize])
    });
    source16.save(&p16).unwrap();
    let image = load(&p16);
    assert_eq!(
        (image.sample_format, image.color_space),
        (SampleFormat::U16, ColorSpace::Linear)
    );
    assert_close(image.pixel(0, 0).x, 40000.0 / 65535.0, 1e-7, "TIFF 16");
    assert_eq!(image.saturated, vec![false, true]);

    let pf = dir.path().join("tf.tif");
    let sourcef: ImageBuffer<Rgb<f32>, Vec<f32>> = ImageBuffer::from_fn(2, 1, |x, _| {
        Rgb([[0.125, 3.5, 1e-6], [-0.25, 0.0, 100.0]][x as usize])
    });
    sourcef.save(&pf).unwrap();
    let image = load_linear_image(&pf, None, 2.0).unwrap();
    assert_eq!(
        (image.sample_format, image.color_space),
        (SampleFormat::Float, ColorSpace::Linear)
    );
    assert_vec3_close(
        image.pixel(0, 0),
        Vec3::new(0.25, 7.0, 2e-6),
        0.0,
        "float TIFF × 2",
    );
    assert_vec3_close(
        image.pixel(1, 0),
        Vec3::new(-0.5, 0.0, 200.0),
        0.0,
        "float TIFF × 2",
    );
    assert_eq!(image.saturated_count(), 0, "float images never saturate");
}

fn write_exr(
    path: &Path,
    width: usize,
    height: usize,
    f: impl Sync + Fn(usize, usize) -> (f32, f32, f32),
) {
    exr::prelude::write_rgb_file(path, width, height, f).unwrap();
}

#[test]
fn exr_round_trip_is_exact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("e.exr");
    let value = |x: usize, y: usize| (x as f32 * 0.5, y as f32 * 0.25 + 1e-3, -(x as f32) * 1e-4);
    write_exr(&path, 7, 5, value);
    let image = load_linear_image(&path, None, 3.0).unwrap();
    assert_eq!((image.width, image.height), (7, 5));
    assert_eq!(
        (image.sample_format, image.color_space),
        (SampleFormat::Float, ColorSpace::Linear)
    );
    for y in 0..5 {
        for x in 0..7 {
            let (r, g, b) = value(x, y);
            let expected = Vec3::new(r, g, b) * 3.0;
            assert_vec3_close(
                image.pixel(x as u32, y as u32),
                expected,
                0.0,
                &format!("({x}, {y})"),
            );
        }
    }
    assert_eq!(image.saturated.len(), 35);
    assert_eq!(image.saturated_count(), 0);
}

#[test]
fn exr_with_nan_and_inf_is_an_error_naming_count_and_first_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nan.exr");
    write_exr(&path, 8, 4, |x, y| match (x, y) {
        (3, 1) => (0.5, f32::NAN, 0.5),
        (1, 2) => (f32::INFINITY, 0.0, 0.0),
        (6, 3) => (0.0, 0.0, f32::NEG_INFINITY),
        _ => (0.1, 0.2, 0.3),
    });
    let err = load_linear_image(&path, None, 1.0).unwrap_err();
    println!("{err}");
    match &err {
        ImageError::NonFinite {
            count,
            first_x,
            first_y,
            ..
        } => {
            assert_eq!((*count, *first_x, *first_y), (3, 3, 1));
        }
        other => panic!("expected NonFinite, got {other:?}"),
    }
    let message = err.to_string();
    assert!(
        message.contains("nan.exr") && message.contains("3 pixel"),
        "{message}"
    );
}

#[test]
fn corrupt_truncated_missing_and_unsupported_files_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();

    // Truncated PNG.
    let png = dir.path().join("cut.png");
    let noise: ImageBuffer<Rgb<u8>, Vec<u8>> = ImageBuffer::from_fn(64, 64, |x, y| {
        Rgb([(x * 7 + y * 13) as u8, (x * y) as u8, (x ^ y) as u8])
    });
    noise.save(&png).unwrap();
    let bytes = std::fs::read(&png).unwrap();
    std::fs::write(&png, &bytes[..bytes.len() / 2]).unwrap();
    let err = load_linear_image(&png, None, 1.0).unwrap_err();
    println!("truncated PNG: {err}");
    assert!(
        matches!(err, ImageError::Decode { format: "PNG", .. }),
        "{err:?}"
    );
    assert!(err.to_string().contains("cut.png"), "{err}");

    // Truncated EXR.
    let exr_path = dir.path().join("cut.exr");
    write_exr(&exr_path, 64, 64, |x, y| (x as f32, y as f32, 1.0));
    let bytes = std::fs::read(&exr_path).unwrap();
    std::fs::write(&exr_path, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let err = load_linear_image(&exr_path, None, 1.0).unwrap_err();
    println!("truncated EXR: {err}");
    assert!(
        matches!(
            err,
            ImageError::Decode {
                format: "OpenEXR",
                ..
            }
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("cut.exr"), "{err}");

    // Garbage with a supported extension: a decode error; with another: unsupported.
    let garbage: Vec<u8> = (0..1000_u32).map(|i| (i * 31 % 251) as u8).collect();
    for name in ["junk.png", "junk.exr", "junk.JPG", "junk.tiff"] {
        let path = dir.path().join(name);
        std::fs::write(&path, &garbage).unwrap();
        let err = load_linear_image(&path, None, 1.0).unwrap_err();
        println!("{name}: {err}");
        assert!(matches!(err, ImageError::Decode { .. }), "{name}: {err:?}");
        assert!(err.to_string().contains(name), "{err}");
    }
    let path = dir.path().join("junk.raw");
    std::fs::write(&path, &garbage).unwrap();
    let err = load_linear_image(&path, None, 1.0).unwrap_err();
    assert!(matches!(err, ImageError::Unsupported { .. }), "{err:?}");
    assert!(
        err.to_string().contains("junk.raw") && err.to_string().contains(".raw"),
        "{err}"
    );

    // A format we recognise but do not decode.
    let bmp = dir.path().join("image.bmp");
    std::fs::write(&bmp, b"BM\x3e\0\0\0\0\0\0\0\x36\0\0\0").unwrap();
    let err = load_linear_image(&bmp, None, 1.0).unwrap_err();
    println!("BMP: {err}");
    assert!(matches!(err, ImageError::Unsupported { .. }), "{err:?}");
    assert!(err.to_string().contains("Bmp"), "{err}");

    // Empty file, missing file, a folder.
    let empty = dir.path().join("empty.exr");
    std::fs::write(&empty, b"").unwrap();
    let err = load_linear_image(&empty, None, 1.0).unwrap_err();
    assert!(matches!(err, ImageError::Decode { .. }), "{err:?}");
    assert!(err.to_string().contains("0 bytes"), "{err}");

    let missing = dir.path().join("nowhere.exr");
    let err = load_linear_image(&missing, None, 1.0).unwrap_err();
    assert!(matches!(err, ImageError::NotFound { .. }), "{err:?}");
    assert!(err.to_string().contains("nowhere.exr"), "{err}");

    let err = load_linear_image(dir.path(), None, 1.0).unwrap_err();
    println!("folder: {err}");
    assert!(matches!(err, ImageError::Read { .. }), "{err:?}");
}

#[test]
fn bundled_sphere_r35_has_the_lit_side_radiance_of_its_sidecar() {
    let path = data_dir().join("sphere_r35.exr");
    let image = load(&path);
    assert_eq!((image.width, image.height), (512, 512));
    assert_eq!(image.sample_format, SampleFormat::Float);

    // Same region as the sidecar's noise.lit_half: inside 0.95 of the disk (centre (256, 256),
    // radius 230 px) with n_x < -0.1; its mean radiance there is (0.1354, 0.1273, 0.1168).
    let (mut sum, mut count) = (Vec3::ZERO, 0_usize);
    for y in 0..512 {
        for x in 0..512 {
            let nx = (x as f32 + 0.5 - 256.0) / 230.0;
            let ny = (256.0 - y as f32 - 0.5) / 230.0;
            if nx * nx + ny * ny < 0.95 * 0.95 && nx < -0.1 {
                sum += image.pixel(x, y);
                count += 1;
            }
        }
    }
    let mean = sum / count as f32;
    println!(
        "sphere_r35.exr lit half: {count} px, mean radiance {mean} (sidecar: 0.135425, 0.127270, 0.116824, 64930 px)"
    );
    assert_eq!(count, 64930, "pixel count of the sidecar's region");
    assert_close(mean.x, 0.135_425, 2e-5, "lit-half mean R");
    assert_close(mean.y, 0.127_270, 2e-5, "lit-half mean G");
    assert_close(mean.z, 0.116_824, 2e-5, "lit-half mean B");
    // The background is black.
    assert_eq!(image.pixel(2, 2), Vec3::ZERO);
}

#[test]
fn decoding_all_bundled_exrs_one_at_a_time() {
    let dir = data_dir();
    let mut names: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "exr"))
        .collect();
    names.sort();
    assert_eq!(
        names.len(),
        12,
        "expected the 12 wax sphere EXRs in {}",
        dir.display()
    );
    let start = Instant::now();
    let mut total = 0.0_f64;
    for path in &names {
        let image = load(path);
        total += image.pixels.iter().map(|p| f64::from(p.x)).sum::<f64>();
    }
    let elapsed = start.elapsed();
    println!(
        "decoded {} EXRs (512 × 512 × RGB f32) in {:.0} ms ({:.1} ms each; {} build); sum R = {total:.1}",
        names.len(),
        elapsed.as_secs_f64() * 1e3,
        elapsed.as_secs_f64() * 1e3 / names.len() as f64,
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        }
    );
    assert!(total > 0.0);
}

/// CRC-32 (IEEE) as PNG chunks use it.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = u32::MAX;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[test]
fn zero_width_png_is_an_error() {
    // Encoders refuse to write one, so build it by hand: IHDR with width 0, then IEND.
    let chunk = |kind: &[u8], data: &[u8]| {
        let mut out = (data.len() as u32).to_be_bytes().to_vec();
        let body: Vec<u8> = kind.iter().chain(data).copied().collect();
        out.extend(&body);
        out.extend(crc32(&body).to_be_bytes());
        out
    };
    let mut ihdr = 0_u32.to_be_bytes().to_vec();
    ihdr.extend(5_u32.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(b"IEND", &[]));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("zero.png");
    std::fs::write(&path, png).unwrap();
    let err = load_linear_image(&path, None, 1.0).unwrap_err();
    println!("{err}");
    assert!(
        matches!(err, ImageError::Decode { format: "PNG", .. }),
        "{err:?}"
    );
    assert!(
        err.to_string().contains("zero.png") && err.to_string().contains("dimensions"),
        "{err}"
    );
}

#[test]
fn raw_like_codes_with_sensor_levels() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("raw14.png");
    // A 14-bit sensor's codes in a 16-bit PNG: black 512, clipping at 16383; noise dips below
    // the black level.
    let codes: [[u16; 3]; 4] = [
        [512, 512, 512],
        [500, 520, 8447],
        [16383, 100, 100],
        [16000, 16000, 16000],
    ];
    ImageBuffer::<Rgb<u16>, _>::from_fn(4, 1, |x, _| Rgb(codes[x as usize]))
        .save(&path)
        .unwrap();
    let levels = SensorLevels {
        black: 512,
        white: 16383,
    };
    let decoding = Decoding {
        levels: Some(levels),
        exposure: 2.0,
        ..Decoding::default()
    };
    let image = load_linear_image_with(&path, &decoding).unwrap();
    let span = 16383.0 - 512.0;
    assert_eq!(image.pixel(0, 0), Vec3::ZERO);
    assert_vec3_close(
        image.pixel(1, 0),
        Vec3::new(-12.0, 8.0, 7935.0) / span * 2.0,
        1e-6,
        "below black stays negative",
    );
    assert_eq!(image.saturated, vec![false, false, true, false]);
    assert_eq!(image.color_space, ColorSpace::Linear);

    // Where levels cannot apply, the error names the file and why.
    let srgb = Decoding {
        color_space: Some(ColorSpace::Srgb),
        ..decoding
    };
    let err = load_linear_image_with(&path, &srgb).unwrap_err();
    assert!(
        matches!(err, ImageError::Levels { .. }) && err.to_string().contains("raw14.png"),
        "{err}"
    );
    let exr = dir.path().join("float.exr");
    write_exr(&exr, 2, 2, |_, _| (0.5, 0.5, 0.5));
    let err = load_linear_image_with(&exr, &decoding).unwrap_err();
    assert!(err.to_string().contains("float"), "{err}");
    let png8 = dir.path().join("p8.png");
    pattern_u8().save(&png8).unwrap();
    let err = load_linear_image_with(&png8, &decoding).unwrap_err();
    assert!(err.to_string().contains("8-bit"), "{err}");
    let in_range = Decoding {
        levels: Some(SensorLevels {
            black: 16,
            white: 240,
        }),
        ..Decoding::default()
    };
    let image = load_linear_image_with(&png8, &in_range).unwrap();
    assert_eq!(image.sample_format, SampleFormat::U8);
}

/// `tests/fixtures/bayer.dng` (written by `scripts/captures/dng.py`): a 32 × 24 RGGB sensor
/// whose 2 × 2 block (bx, by) saw linear sRGB (0.05 (bx + 1), (by + 1) / 16, 0.3) through a
/// camera that sees white as (0.5, 1, 0.7); block (3, 2) is clipped.
#[cfg(feature = "raw")]
#[test]
fn dng_is_decoded_linearly_with_levels_white_balance_and_colour() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/bayer.dng");
    let image = load_linear_image(&path, None, 1.0).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        (image.width, image.height),
        (16, 12),
        "one pixel per 2 × 2 block"
    );
    assert_eq!(image.sample_format, SampleFormat::Raw);
    for by in 0..12 {
        for bx in 0..16 {
            let clipped = (bx, by) == (3, 2);
            assert_eq!(
                image.saturated[(by * 16 + bx) as usize],
                clipped,
                "({bx}, {by})"
            );
            if clipped {
                continue;
            }
            let truth = Vec3::new(0.05 * (bx + 1) as f32, (by + 1) as f32 / 16.0, 0.3);
            // 14-bit codes: a quantisation of 1/15871, through the matrix's rounding.
            assert_vec3_close(
                image.pixel(bx, by),
                truth,
                2e-3,
                &format!("block ({bx}, {by})"),
            );
        }
    }
    // Levels belong to the file; a RAW file is linear.
    let levels = Decoding {
        levels: Some(SensorLevels {
            black: 0,
            white: 100,
        }),
        ..Decoding::default()
    };
    let err = load_linear_image_with(&path, &levels).unwrap_err();
    assert!(err.to_string().contains("own levels"), "{err}");
    // A truncated file is an error naming it, not a panic.
    let dir = tempfile::tempdir().unwrap();
    let cut = dir.path().join("cut.dng");
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let err = load_linear_image(&cut, None, 1.0).unwrap_err();
    assert!(err.to_string().contains("cut.dng"), "{err}");
    std::fs::write(&cut, b"not a raw file at all").unwrap();
    let err = load_linear_image(&cut, None, 1.0).unwrap_err();
    assert!(err.to_string().contains("cut.dng"), "{err}");
    // A header that claims a huge image is refused before its pixels are allocated.
    let mut huge = bytes.clone();
    let ifd = u32::from_le_bytes(huge[4..8].try_into().unwrap()) as usize;
    let count = u16::from_le_bytes(huge[ifd..ifd + 2].try_into().unwrap()) as usize;
    for k in 0..count {
        let entry = ifd + 2 + 12 * k;
        if u16::from_le_bytes(huge[entry..entry + 2].try_into().unwrap()) == 256 {
            huge[entry + 2..entry + 4].copy_from_slice(&4u16.to_le_bytes());
            huge[entry + 8..entry + 12].copy_from_slice(&200_000u32.to_le_bytes());
        }
    }
    std::fs::write(&cut, &huge).unwrap();
    let err = load_linear_image(&cut, None, 1.0).unwrap_err();
    assert!(matches!(err, ImageError::TooLarge { .. }), "{err}");
}
