//! Golden-image comparison with NVIDIA FLIP.
//!
//! A golden test renders an image and calls [`assert_golden`] with a name. The reference is
//! `tests/golden/NAME.png`; the two are compared with [FLIP] (the `nv-flip` crate) on their RGB
//! channels and the test fails when the mean FLIP error or the fraction of clearly visible
//! differences (FLIP > 0.1) is over the [`Tolerance`].
//!
//! * On failure the new image is written to `NAME.new.png` and the FLIP error map (magma colour
//!   map: black = identical, yellow-white = very different) to `NAME.diff.png`, both next to the
//!   reference and git-ignored; the panic message gives the measured numbers, the thresholds and
//!   the paths.
//! * A **missing reference is a failure** (the image is written to `NAME.new.png` so it can be
//!   inspected), never a silent pass.
//! * With `UPDATE_SNAPSHOTS=1` a missing or failing reference is (re)written from the new image
//!   and the test passes, printing what it wrote; a reference that passes is left untouched, so
//!   re-running with `UPDATE_SNAPSHOTS=1` does not churn files on small differences.
//! * On success stale `NAME.new.png` / `NAME.diff.png` from an earlier failure are removed.
//! * Every comparison prints its FLIP numbers (visible with `cargo test -- --show-output`).
//!
//! PNG files are written atomically (a temporary file in the same folder, then a rename), so an
//! interrupted run never leaves a truncated reference.
//!
//! [FLIP]: https://github.com/NVlabs/flip

use std::fmt;
use std::io::{self, BufWriter, Write as _};
use std::panic::Location;
use std::path::{Path, PathBuf};

use image::ImageEncoder as _;

/// A FLIP error above this value is a clearly visible difference at the viewing distance FLIP
/// assumes ([`nv_flip::DEFAULT_PIXELS_PER_DEGREE`]: 67 pixels per degree, a 0.7 m distance from
/// a 24" 4K screen). [`FlipStats::fraction_above_0_1`] counts pixels over it.
pub const VISIBLE_FLIP: f32 = 0.1;

/// The environment variable that turns on reference updates (`UPDATE_SNAPSHOTS=1`), the same
/// name wgpu's and egui_kittest's snapshot tests use.
pub const UPDATE_ENV: &str = "UPDATE_SNAPSHOTS";

/// An 8-bit sRGB RGBA image, row 0 at the top, pixels in row-major order.
///
/// Colour is sRGB-encoded and, when the image has transparency, already composited over black
/// (premultiplied): the comparison drops alpha and looks only at RGB.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Srgb8Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixels, row-major from the top-left, each `[r, g, b, a]`.
    pub pixels: Vec<[u8; 4]>,
}

impl Srgb8Image {
    /// An image from its pixels.
    ///
    /// # Panics
    /// If `pixels.len() != width * height`.
    pub fn new(width: u32, height: u32, pixels: Vec<[u8; 4]>) -> Self {
        assert_eq!(
            pixels.len(),
            width as usize * height as usize,
            "Srgb8Image::new: {width}×{height} needs {} pixels, got {}",
            width as usize * height as usize,
            pixels.len()
        );
        Self {
            width,
            height,
            pixels,
        }
    }

    /// An image whose pixel at column `x`, row `y` (0 = top) is `f(x, y)`.
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> [u8; 4]) -> Self {
        let pixels = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| f(x, y))
            .collect();
        Self::new(width, height, pixels)
    }

    /// Reads a PNG (any bit depth and colour type; converted to 8-bit RGBA).
    ///
    /// # Errors
    /// If the file cannot be read or is not a valid image.
    pub fn from_png(path: impl AsRef<Path>) -> Result<Self, image::ImageError> {
        let rgba = image::ImageReader::open(path.as_ref())?
            .with_guessed_format()?
            .decode()?
            .into_rgba8();
        let (width, height) = rgba.dimensions();
        let pixels = rgba.pixels().map(|p| p.0).collect();
        Ok(Self::new(width, height, pixels))
    }

    /// Writes the image as an 8-bit RGBA PNG, atomically: the data goes to a temporary file in the
    /// same folder, which is then renamed over `path`. The folder must exist.
    ///
    /// # Errors
    /// If the temporary file cannot be created, written or renamed.
    pub fn write_png(&self, path: impl AsRef<Path>) -> Result<(), image::ImageError> {
        let path = path.as_ref();
        let dir = match path.parent() {
            Some(parent) if !parent.as_os_str().is_empty() => parent,
            _ => Path::new("."),
        };
        let temp = tempfile::Builder::new()
            .prefix(".golden-")
            .suffix(".png.tmp")
            .tempfile_in(dir)?;
        {
            let mut writer = BufWriter::new(temp.as_file());
            image::codecs::png::PngEncoder::new(&mut writer).write_image(
                self.pixels.as_flattened(),
                self.width,
                self.height,
                image::ExtendedColorType::Rgba8,
            )?;
            writer.flush()?;
        }
        temp.persist(path).map_err(io::Error::from)?;
        Ok(())
    }

    /// The RGB channels, tightly packed (alpha dropped), as FLIP takes them.
    fn rgb_bytes(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|&[r, g, b, _]| [r, g, b])
            .collect()
    }
}

/// How far an image may be from its reference before a golden test fails. Both limits must hold.
///
/// Choose them per test and comment the adapter that set the reference and the numbers it
/// measured (every comparison prints them). Renders on the same software adapter (lavapipe) are
/// deterministic, so a tolerance only needs to absorb small driver or compiler changes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    /// Largest accepted mean FLIP error over all pixels (0 = identical, 1 = black vs white).
    pub mean_flip: f32,
    /// Largest accepted fraction (0..=1, not a percentage) of pixels whose FLIP error is above
    /// [`VISIBLE_FLIP`] (0.1).
    pub max_flip_fraction_above_0_1: f32,
}

impl Tolerance {
    /// Only FLIP-identical images pass (mean 0, no pixel over 0.1).
    pub const EXACT: Self = Self {
        mean_flip: 0.0,
        max_flip_fraction_above_0_1: 0.0,
    };

    /// Whether `stats` is within this tolerance.
    pub fn accepts(&self, stats: &FlipStats) -> bool {
        stats.mean <= self.mean_flip && stats.fraction_above_0_1 <= self.max_flip_fraction_above_0_1
    }

    fn check(&self) {
        assert!(
            self.mean_flip.is_finite()
                && self.mean_flip >= 0.0
                && self.max_flip_fraction_above_0_1.is_finite()
                && (0.0..=1.0).contains(&self.max_flip_fraction_above_0_1),
            "invalid golden-image tolerance {self:?}: mean_flip must be ≥ 0 and \
             max_flip_fraction_above_0_1 in 0..=1"
        );
    }
}

impl fmt::Display for Tolerance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "mean FLIP ≤ {:.6}, fraction of pixels with FLIP > {VISIBLE_FLIP} ≤ {:.6}",
            self.mean_flip, self.max_flip_fraction_above_0_1
        )
    }
}

/// Summary of a FLIP error map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlipStats {
    /// Mean FLIP error over all pixels (what the FLIP authors recommend as a single number).
    pub mean: f32,
    /// Fraction (0..=1) of pixels whose FLIP error is above [`VISIBLE_FLIP`] (0.1).
    pub fraction_above_0_1: f32,
    /// Largest per-pixel FLIP error.
    pub max: f32,
}

impl fmt::Display for FlipStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "mean FLIP {:.6}, fraction of pixels with FLIP > {VISIBLE_FLIP} {:.6} ({:.3}%), max FLIP {:.6}",
            self.mean,
            self.fraction_above_0_1,
            100.0 * self.fraction_above_0_1,
            self.max
        )
    }
}

/// FLIP statistics of `test` against `reference` (RGB only: alpha is dropped), at FLIP's default
/// 67 pixels per degree.
///
/// # Panics
/// If the images differ in size.
pub fn flip_stats(reference: &Srgb8Image, test: &Srgb8Image) -> FlipStats {
    flip_compare(reference, test).0
}

/// FLIP statistics and the per-pixel error map (row-major, one value in 0..=1 per pixel).
fn flip_compare(reference: &Srgb8Image, test: &Srgb8Image) -> (FlipStats, nv_flip::FlipImageFloat) {
    assert_eq!(
        (reference.width, reference.height),
        (test.width, test.height),
        "FLIP needs images of the same size"
    );
    let to_flip = |image: &Srgb8Image| {
        nv_flip::FlipImageRgb8::with_data(image.width, image.height, &image.rgb_bytes())
    };
    let error_map = nv_flip::flip(
        to_flip(reference),
        to_flip(test),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let errors = error_map.to_vec();
    let stats = if errors.is_empty() {
        FlipStats {
            mean: 0.0,
            fraction_above_0_1: 0.0,
            max: 0.0,
        }
    } else {
        let sum: f64 = errors.iter().map(|&e| f64::from(e)).sum();
        let above = errors.iter().filter(|&&e| e > VISIBLE_FLIP).count();
        FlipStats {
            mean: (sum / errors.len() as f64) as f32,
            fraction_above_0_1: (above as f64 / errors.len() as f64) as f32,
            max: errors.iter().copied().fold(0.0, f32::max),
        }
    };
    (stats, error_map)
}

/// The error map coloured with FLIP's magma colour map.
fn error_map_image(error_map: &nv_flip::FlipImageFloat) -> Srgb8Image {
    let rgb = error_map.apply_color_lut(&nv_flip::magma_lut()).to_vec();
    let pixels = rgb
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2], 255])
        .collect();
    Srgb8Image::new(error_map.width(), error_map.height(), pixels)
}

/// The workspace's reference folder, `tests/golden/`.
pub fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("golden")
}

/// Whether `UPDATE_SNAPSHOTS` asks for references to be (re)written: `1`, `true` or `yes` turn it
/// on; unset, empty, `0`, `false` or `no` leave it off.
///
/// # Panics
/// On any other value, so a typo does not silently run the strict comparison.
pub fn update_requested() -> bool {
    let Some(value) = std::env::var_os(UPDATE_ENV) else {
        return false;
    };
    match value.to_string_lossy().trim().to_ascii_lowercase().as_str() {
        "1" | "true" | "yes" => true,
        "" | "0" | "false" | "no" => false,
        other => panic!("{UPDATE_ENV}={other:?} is not understood: use {UPDATE_ENV}=1 or unset it"),
    }
}

/// Compares `image` with the reference `tests/golden/NAME.png` and panics if they differ by more
/// than `tolerance` (FLIP on RGB; a size mismatch or a missing reference is a failure). With
/// `UPDATE_SNAPSHOTS=1` a missing or failing reference is rewritten instead. See the
/// [module documentation](self) for the files written.
///
/// # Panics
/// On a mismatch, a missing or unreadable reference, an invalid name or tolerance, or when a file
/// cannot be written.
#[track_caller]
pub fn assert_golden(name: &str, image: &Srgb8Image, tolerance: Tolerance) {
    assert_golden_in(&golden_dir(), name, image, tolerance, update_requested());
}

/// [`assert_golden`] with an explicit reference folder and update switch (`update` = what
/// `UPDATE_SNAPSHOTS=1` turns on), for testing the helper itself without touching the process
/// environment.
///
/// `name` is a file stem: letters, digits, `-`, `_` and `.`, not starting with `.`.
///
/// # Panics
/// As [`assert_golden`].
#[track_caller]
pub fn assert_golden_in(
    dir: &Path,
    name: &str,
    image: &Srgb8Image,
    tolerance: Tolerance,
    update: bool,
) {
    check_name(name);
    tolerance.check();
    let caller = Location::caller();
    let reference_path = dir.join(format!("{name}.png"));
    let new_path = dir.join(format!("{name}.new.png"));
    let diff_path = dir.join(format!("{name}.diff.png"));
    let write = |what: &Srgb8Image, path: &Path| {
        std::fs::create_dir_all(dir).unwrap_or_else(|e| {
            panic!(
                "golden `{name}`: cannot create folder {}: {e}",
                dir.display()
            )
        });
        what.write_png(path)
            .unwrap_or_else(|e| panic!("golden `{name}`: cannot write {}: {e}", path.display()));
    };
    let accept = |why: &str| {
        write(image, &reference_path);
        remove_stale(&[&new_path, &diff_path]);
        println!(
            "golden `{name}`: {why}; wrote reference {} ({UPDATE_ENV}=1)",
            reference_path.display()
        );
    };

    if !reference_path.exists() {
        if update {
            accept("no reference yet");
            return;
        }
        write(image, &new_path);
        remove_stale(&[&diff_path]);
        panic!(
            "golden `{name}` ({caller}): reference {} is missing (a missing reference is a \
             failure).\n  wrote the rendered image to {}\n  inspect it, then create the reference \
             with `{UPDATE_ENV}=1 cargo test --workspace` (or rename the .new.png to {name}.png) \
             and commit it",
            reference_path.display(),
            new_path.display()
        );
    }

    let reference = match Srgb8Image::from_png(&reference_path) {
        Ok(reference) => reference,
        Err(e) if update => {
            accept(&format!("reference was unreadable ({e})"));
            return;
        }
        Err(e) => {
            write(image, &new_path);
            remove_stale(&[&diff_path]);
            panic!(
                "golden `{name}` ({caller}): cannot read reference {}: {e}\n  wrote the rendered \
                 image to {}\n  run with {UPDATE_ENV}=1 to accept",
                reference_path.display(),
                new_path.display()
            );
        }
    };

    if (reference.width, reference.height) != (image.width, image.height) {
        let sizes = format!(
            "size {}×{} differs from the reference's {}×{}",
            image.width, image.height, reference.width, reference.height
        );
        println!("golden `{name}`: {sizes}");
        if update {
            accept(&sizes);
            return;
        }
        write(image, &new_path);
        remove_stale(&[&diff_path]);
        panic!(
            "golden `{name}` ({caller}): {sizes}\n  reference: {}\n  new image: {}\n  run with \
             {UPDATE_ENV}=1 to accept",
            reference_path.display(),
            new_path.display()
        );
    }

    let (stats, error_map) = flip_compare(&reference, image);
    let passed = tolerance.accepts(&stats);
    println!(
        "golden `{name}`: {stats} ({}; thresholds: {tolerance})",
        if passed { "pass" } else { "FAIL" }
    );
    if passed {
        remove_stale(&[&new_path, &diff_path]);
        return;
    }
    if update {
        accept("comparison failed");
        return;
    }
    write(image, &new_path);
    write(&error_map_image(&error_map), &diff_path);
    panic!(
        "golden `{name}` ({caller}): image differs from the reference\n  measured:   {stats}\n  \
         thresholds: {tolerance}\n  reference:  {}\n  new image:  {}\n  FLIP map:   {} (magma: \
         black = identical, bright = different)\n  run with {UPDATE_ENV}=1 to accept",
        reference_path.display(),
        new_path.display(),
        diff_path.display()
    );
}

#[track_caller]
fn check_name(name: &str) {
    assert!(
        !name.is_empty()
            && !name.starts_with('.')
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.')),
        "golden image name {name:?} must be a plain file stem (letters, digits, '-', '_', '.'; \
         not starting with '.')"
    );
}

/// Removes leftovers of an earlier failure; a file that is not there is fine.
fn remove_stale(paths: &[&Path]) {
    for path in paths {
        match std::fs::remove_file(path) {
            Ok(()) => println!("removed stale {}", path.display()),
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(e) => eprintln!("warning: cannot remove stale {}: {e}", path.display()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::panic::{AssertUnwindSafe, catch_unwind};

    /// A smooth colour gradient with some structure, 64×48.
    fn gradient() -> Srgb8Image {
        Srgb8Image::from_fn(64, 48, |x, y| {
            [
                (x * 4) as u8,
                (y * 5) as u8,
                ((x + y) * 2) as u8,
                if (x / 8 + y / 8) % 2 == 0 { 255 } else { 128 },
            ]
        })
    }

    /// `gradient` with a white 16×16 square: a plainly visible change.
    fn gradient_with_square() -> Srgb8Image {
        let mut image = gradient();
        for y in 16..32 {
            for x in 24..40 {
                image.pixels[(y * 64 + x) as usize] = [255, 255, 255, 255];
            }
        }
        image
    }

    thread_local! {
        /// Set while this thread runs a closure that is expected to panic.
        static EXPECTING_PANIC: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    }

    /// Runs `f`, expecting a panic, and returns its message. The expected panic prints nothing
    /// (no message or backtrace in a passing run's log); panics elsewhere print as usual.
    fn panic_message(f: impl FnOnce()) -> String {
        static QUIET_HOOK: std::sync::Once = std::sync::Once::new();
        QUIET_HOOK.call_once(|| {
            let default = std::panic::take_hook();
            std::panic::set_hook(Box::new(move |info| {
                if !EXPECTING_PANIC.with(std::cell::Cell::get) {
                    default(info);
                }
            }));
        });
        EXPECTING_PANIC.with(|expecting| expecting.set(true));
        let outcome = catch_unwind(AssertUnwindSafe(f));
        EXPECTING_PANIC.with(|expecting| expecting.set(false));
        let payload = outcome.expect_err("expected a panic");
        if let Some(s) = payload.downcast_ref::<String>() {
            s.clone()
        } else if let Some(s) = payload.downcast_ref::<&str>() {
            (*s).to_owned()
        } else {
            String::from("<non-string panic payload>")
        }
    }

    fn files_in(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    const LOOSE: Tolerance = Tolerance {
        mean_flip: 0.05,
        max_flip_fraction_above_0_1: 0.05,
    };

    #[test]
    fn golden_png_round_trip_is_lossless_and_leaves_no_temp_files() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        let image = gradient();
        image.write_png(&path).unwrap();
        image.write_png(&path).unwrap(); // overwriting works too
        assert_eq!(Srgb8Image::from_png(&path).unwrap(), image);
        assert_eq!(files_in(dir.path()), ["a.png"]);
    }

    #[test]
    fn golden_flip_stats_of_identical_images_are_zero_and_alpha_is_ignored() {
        let a = gradient();
        let mut b = a.clone();
        for p in &mut b.pixels {
            p[3] = 0;
        }
        let stats = flip_stats(&a, &b);
        println!("{stats}");
        assert_eq!(
            stats,
            FlipStats {
                mean: 0.0,
                fraction_above_0_1: 0.0,
                max: 0.0
            }
        );
    }

    #[test]
    fn golden_flip_stats_of_black_against_white_are_large() {
        let black = Srgb8Image::from_fn(32, 32, |_, _| [0, 0, 0, 255]);
        let white = Srgb8Image::from_fn(32, 32, |_, _| [255, 255, 255, 255]);
        let stats = flip_stats(&black, &white);
        println!("{stats}");
        assert!(stats.mean > 0.5, "{stats}");
        assert_eq!(stats.fraction_above_0_1, 1.0, "{stats}");
        assert!(stats.max <= 1.0, "{stats}");
    }

    #[test]
    fn golden_flip_stats_see_a_small_square() {
        let stats = flip_stats(&gradient(), &gradient_with_square());
        println!("{stats}");
        // 256 of 3072 pixels changed; FLIP's spatial filter spreads the edge a little.
        assert!((0.08..0.2).contains(&stats.fraction_above_0_1), "{stats}");
        assert!(stats.mean > 0.01 && stats.max > 0.5, "{stats}");
    }

    #[test]
    fn golden_flip_stats_reject_size_mismatch() {
        let a = gradient();
        let b = Srgb8Image::from_fn(63, 48, |_, _| [0, 0, 0, 255]);
        let message = panic_message(|| {
            flip_stats(&a, &b);
        });
        assert!(message.contains("same size"), "{message}");
    }

    #[test]
    fn golden_identical_image_passes_and_removes_stale_files() {
        let dir = tempfile::tempdir().unwrap();
        let image = gradient();
        image.write_png(dir.path().join("g.png")).unwrap();
        std::fs::write(dir.path().join("g.new.png"), b"stale").unwrap();
        std::fs::write(dir.path().join("g.diff.png"), b"stale").unwrap();
        assert_golden_in(dir.path(), "g", &image, Tolerance::EXACT, false);
        assert_eq!(files_in(dir.path()), ["g.png"]);
    }

    #[test]
    fn golden_different_image_fails_and_writes_new_and_diff() {
        let dir = tempfile::tempdir().unwrap();
        let reference = gradient();
        reference.write_png(dir.path().join("g.png")).unwrap();
        let changed = gradient_with_square();
        let message = panic_message(|| {
            assert_golden_in(dir.path(), "g", &changed, LOOSE, false);
        });
        println!("panic message:\n{message}");
        for needle in [
            "mean FLIP",
            "FLIP > 0.1",
            "thresholds",
            "g.new.png",
            "g.diff.png",
            "UPDATE_SNAPSHOTS=1 to accept",
        ] {
            assert!(
                message.contains(needle),
                "{needle:?} missing from {message}"
            );
        }
        assert_eq!(files_in(dir.path()), ["g.diff.png", "g.new.png", "g.png"]);
        // The reference is untouched, the new image is what was passed, the map is full size.
        assert_eq!(
            Srgb8Image::from_png(dir.path().join("g.png")).unwrap(),
            reference
        );
        assert_eq!(
            Srgb8Image::from_png(dir.path().join("g.new.png")).unwrap(),
            changed
        );
        let diff = Srgb8Image::from_png(dir.path().join("g.diff.png")).unwrap();
        assert_eq!((diff.width, diff.height), (64, 48));
        assert_ne!(diff.pixels[0], diff.pixels[(24 * 64 + 32) as usize]);

        // Fixing the image makes the next run pass and clean up.
        assert_golden_in(dir.path(), "g", &reference, Tolerance::EXACT, false);
        assert_eq!(files_in(dir.path()), ["g.png"]);
    }

    #[test]
    fn golden_size_mismatch_fails() {
        let dir = tempfile::tempdir().unwrap();
        gradient().write_png(dir.path().join("g.png")).unwrap();
        let smaller = Srgb8Image::from_fn(32, 48, |_, _| [0, 0, 0, 255]);
        let message = panic_message(|| {
            assert_golden_in(dir.path(), "g", &smaller, LOOSE, false);
        });
        assert!(
            message.contains("32×48 differs from the reference's 64×48"),
            "{message}"
        );
        assert_eq!(files_in(dir.path()), ["g.new.png", "g.png"]);
    }

    #[test]
    fn golden_missing_reference_fails_and_says_how_to_create_it() {
        let dir = tempfile::tempdir().unwrap();
        let image = gradient();
        let message = panic_message(|| {
            assert_golden_in(dir.path(), "g", &image, LOOSE, false);
        });
        assert!(message.contains("missing"), "{message}");
        assert!(
            message.contains("UPDATE_SNAPSHOTS=1 cargo test"),
            "{message}"
        );
        assert_eq!(files_in(dir.path()), ["g.new.png"]);
        assert_eq!(
            Srgb8Image::from_png(dir.path().join("g.new.png")).unwrap(),
            image
        );
    }

    #[test]
    fn golden_update_writes_a_missing_reference() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("g.new.png"), b"stale").unwrap();
        let image = gradient();
        assert_golden_in(dir.path(), "g", &image, LOOSE, true);
        assert_eq!(files_in(dir.path()), ["g.png"]);
        assert_eq!(
            Srgb8Image::from_png(dir.path().join("g.png")).unwrap(),
            image
        );
        // … which then passes without the update switch.
        assert_golden_in(dir.path(), "g", &image, Tolerance::EXACT, false);
    }

    #[test]
    fn golden_update_rewrites_a_failing_reference() {
        let dir = tempfile::tempdir().unwrap();
        gradient().write_png(dir.path().join("g.png")).unwrap();
        let changed = gradient_with_square();
        assert_golden_in(dir.path(), "g", &changed, LOOSE, true);
        assert_eq!(files_in(dir.path()), ["g.png"]);
        assert_eq!(
            Srgb8Image::from_png(dir.path().join("g.png")).unwrap(),
            changed
        );
    }

    #[test]
    fn golden_update_rewrites_a_reference_of_another_size() {
        let dir = tempfile::tempdir().unwrap();
        gradient().write_png(dir.path().join("g.png")).unwrap();
        let smaller = Srgb8Image::from_fn(32, 48, |_, _| [0, 0, 0, 255]);
        assert_golden_in(dir.path(), "g", &smaller, LOOSE, true);
        assert_eq!(
            Srgb8Image::from_png(dir.path().join("g.png")).unwrap(),
            smaller
        );
    }

    #[test]
    fn golden_update_leaves_a_passing_reference_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let reference = gradient();
        let path = dir.path().join("g.png");
        reference.write_png(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        // One channel of one pixel off by one: within LOOSE, but not identical.
        let mut nearly = reference.clone();
        nearly.pixels[100][0] ^= 1;
        let stats = flip_stats(&reference, &nearly);
        assert!(stats.mean > 0.0 && LOOSE.accepts(&stats), "{stats}");
        assert_golden_in(dir.path(), "g", &nearly, LOOSE, true);
        assert_eq!(std::fs::read(&path).unwrap(), bytes);
        assert_eq!(files_in(dir.path()), ["g.png"]);
    }

    #[test]
    fn golden_unreadable_reference_fails() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("g.png"), b"not a png").unwrap();
        let message = panic_message(|| {
            assert_golden_in(dir.path(), "g", &gradient(), LOOSE, false);
        });
        assert!(message.contains("cannot read reference"), "{message}");
    }

    #[test]
    fn golden_rejects_names_that_are_not_file_stems() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["", "../escape", "a/b", ".hidden", "sp ace"] {
            let message = panic_message(|| {
                assert_golden_in(dir.path(), name, &gradient(), LOOSE, true);
            });
            assert!(message.contains("plain file stem"), "{name:?}: {message}");
        }
        assert!(files_in(dir.path()).is_empty());
    }

    #[test]
    fn golden_dir_is_tests_golden() {
        assert!(golden_dir().ends_with("tests/golden"));
    }
}
