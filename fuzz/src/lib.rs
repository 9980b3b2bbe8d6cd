//! Fuzzing of cdrf's parsers on the stable toolchain: one [`Target`] per file format the tools
//! read, a seeded mutation loop over small seed files ([`seeds`], [`Mutator`]), and [`run`],
//! which feeds one input to the library function the tools call.
//!
//! ```
//! use cdrf_fuzz::{Target, run};
//!
//! let work = tempfile::tempdir()?;
//! // Garbage is an error, never a panic.
//! assert!(run(Target::Gaussian, b"sigma_mm = [", work.path()).is_err());
//! # Ok::<(), std::io::Error>(())
//! ```
//!
//! Most entry points take a path (the tools read files), so [`run`] writes the input into a
//! work folder first; that file is also what `scripts/fuzz.sh` keeps when an input aborts the
//! process, exhausts its memory limit or hangs. `cdrf-fuzz replay` runs one saved input and
//! exits 0 when the parser returned (`Ok` or `Err`); `tests/regressions.rs` replays every file
//! under `fuzz/regressions/` that way, each in a child process under a memory and time limit.

use std::fmt;
use std::path::{Path, PathBuf};

use cdrf_core::glam::Vec3;
use cdrf_core::mesh::glb_bytes_with_curvature;
use cdrf_core::{CdrfLut, CurvatureAxis, Mesh, RgbaImage, Scene};

/// A parser under test: the function the tools call for one file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// `cdrf-dataset.toml`: [`cdrf_fit::dataset::Dataset::load`].
    Manifest,
    /// Scene TOML: [`Scene::from_toml_str`], then [`Scene::load_assets`] (relative paths resolve
    /// against the repository's `data/scenes/`).
    Scene,
    /// `gaussian.toml`: [`cdrf_core::read_gaussian`], then `model()`.
    Gaussian,
    /// A LUT EXR: [`cdrf_core::read_lut`].
    LutExr,
    /// A reference / rendered EXR: [`RgbaImage::read_exr`] (`compare` references).
    ReferenceExr,
    /// A photograph (EXR, PNG, JPEG, TIFF): [`cdrf_fit::image_io::load_linear_image`].
    Photo,
    /// A camera RAW / DNG photograph: [`cdrf_fit::image_io::load_linear_image`] on a `.dng`.
    CameraRaw,
    /// Wavefront OBJ: [`Mesh::load`].
    Obj,
    /// glTF (JSON `.gltf` or binary `.glb`): [`Mesh::load`] and [`Mesh::load_with_surfaces`].
    Gltf,
}

impl Target {
    /// Every target, in the order `scripts/fuzz.sh` runs them.
    pub const ALL: [Target; 9] = [
        Target::Manifest,
        Target::Scene,
        Target::Gaussian,
        Target::LutExr,
        Target::ReferenceExr,
        Target::Photo,
        Target::CameraRaw,
        Target::Obj,
        Target::Gltf,
    ];

    /// The name used on the command line and as the folder under `fuzz/regressions/`.
    pub fn name(self) -> &'static str {
        match self {
            Target::Manifest => "manifest",
            Target::Scene => "scene",
            Target::Gaussian => "gaussian",
            Target::LutExr => "lut_exr",
            Target::ReferenceExr => "reference_exr",
            Target::Photo => "photo",
            Target::CameraRaw => "camera_raw",
            Target::Obj => "obj",
            Target::Gltf => "gltf",
        }
    }

    /// The target called `name`, if any.
    pub fn from_name(name: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Whether the format is text (mutations then also insert tokens and numbers).
    pub fn is_text(self) -> bool {
        matches!(
            self,
            Target::Manifest | Target::Scene | Target::Gaussian | Target::Obj
        )
    }

    /// The file name the input is written to in the work folder.
    fn file_name(self, input: &[u8]) -> &'static str {
        match self {
            Target::Manifest => "cdrf-dataset.toml",
            Target::Scene => "scene.toml",
            Target::Gaussian => "gaussian.toml",
            Target::LutExr | Target::ReferenceExr => "input.exr",
            // The loader detects the format from the bytes, not the name.
            Target::Photo => "input.img",
            // RAW files are recognised by their extension.
            Target::CameraRaw => "input.dng",
            Target::Obj => "input.obj",
            Target::Gltf if input.starts_with(b"glTF") => "input.glb",
            Target::Gltf => "input.gltf",
        }
    }
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The repository root (this crate lives in `fuzz/`).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("fuzz/ has a parent")
        .to_path_buf()
}

/// Writes `input` into `work` (an existing folder) and runs `target`'s parser on it.
///
/// Returns the parser's verdict: `Ok` or its error message. A panic is *not* caught here
/// (the fuzz loop and the replay catch it).
///
/// # Errors
/// The parser's error, or the I/O error writing the input.
pub fn run(target: Target, input: &[u8], work: &Path) -> Result<(), String> {
    let path = work.join(target.file_name(input));
    std::fs::write(&path, input).map_err(|e| format!("{}: {e}", path.display()))?;
    let shown = |e: &dyn std::error::Error| e.to_string();
    match target {
        Target::Manifest => {
            prepare_manifest_folder(work)?;
            cdrf_fit::dataset::Dataset::load(work)
                .map(drop)
                .map_err(|e| shown(&e))
        }
        Target::Scene => {
            let text = String::from_utf8(input.to_vec()).map_err(|e| e.to_string())?;
            let scene = Scene::from_toml_str(&text, &repo_root().join("data/scenes"), &path)
                .map_err(|e| shown(&e))?;
            scene.load_assets().map(drop).map_err(|e| shown(&e))
        }
        Target::Gaussian => {
            let parameters = cdrf_core::read_gaussian(&path).map_err(|e| shown(&e))?;
            parameters.model().map(drop).map_err(|e| shown(&e))
        }
        Target::LutExr => cdrf_core::read_lut(&path).map(drop).map_err(|e| shown(&e)),
        Target::ReferenceExr => RgbaImage::read_exr(&path).map(drop).map_err(|e| shown(&e)),
        // As it is, then as a raw-like file with sensor levels.
        Target::Photo => {
            cdrf_fit::image_io::load_linear_image(&path, None, 1.0).map_err(|e| shown(&e))?;
            let levels = cdrf_fit::image_io::Decoding {
                levels: Some(cdrf_fit::image_io::SensorLevels {
                    black: 16,
                    white: 240,
                }),
                ..Default::default()
            };
            cdrf_fit::image_io::load_linear_image_with(&path, &levels)
                .map(drop)
                .map_err(|e| shown(&e))
        }
        Target::CameraRaw => cdrf_fit::image_io::load_linear_image(&path, None, 1.0)
            .map(drop)
            .map_err(|e| shown(&e)),
        Target::Obj => Mesh::load(&path).map(drop).map_err(|e| shown(&e)),
        // Geometry alone, then with materials, decoded textures and tangents.
        Target::Gltf => {
            Mesh::load(&path).map(drop).map_err(|e| shown(&e))?;
            Mesh::load_with_surfaces(&path)
                .map(drop)
                .map_err(|e| shown(&e))
        }
    }
}

/// The image files the seed manifest (`data/wax-spheres`) names, as empty files: the manifest
/// check only asks that they exist.
fn prepare_manifest_folder(work: &Path) -> Result<(), String> {
    for radius in [15, 20, 25, 30, 35, 40, 45, 50] {
        for extension in ["exr", "png", "json"] {
            let path = work.join(format!("sphere_r{radius}.{extension}"));
            if !path.exists() {
                std::fs::write(&path, b"").map_err(|e| format!("{}: {e}", path.display()))?;
            }
        }
    }
    Ok(())
}

/// Seed inputs for `target`: small files from the repository's `data/` and `tests/fixtures/`,
/// and small valid files written by cdrf itself (a tiny LUT, 8 × 8 images, an icosphere as
/// OBJ, GLB and glTF with a `data:` buffer). Each is `(name, bytes)`.
///
/// # Panics
/// If a seed cannot be written or read (the repository is incomplete).
pub fn seeds(target: Target) -> Vec<(String, Vec<u8>)> {
    let root = repo_root();
    let file = |relative: &str| -> (String, Vec<u8>) {
        let path = root.join(relative);
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("seed {}: {e}", path.display()));
        (relative.to_owned(), bytes)
    };
    let generated = tempfile::tempdir().expect("a temporary folder for the seeds");
    let dir = generated.path();
    let written = |name: &str| -> (String, Vec<u8>) {
        let bytes = std::fs::read(dir.join(name)).expect("a generated seed");
        (format!("generated/{name}"), bytes)
    };
    match target {
        Target::Manifest => vec![
            file("data/wax-spheres/cdrf-dataset.toml"),
            (
                "generated/capture.toml".to_owned(),
                b"[camera]\nprojection = \"perspective\"\nvertical_fov_deg = 12.5\n\
                  [light]\nposition_mm = [-900.0, 150.0, -850.0]\n\
                  [calibration]\nimage = \"sphere_r50.png\"\nradius_mm = 25.0\n\
                  albedo = [0.5, 0.5, 0.5]\nblack_level = 512\nwhite_level = 16383\n\
                  [[sphere]]\nimage = \"sphere_r50.png\"\nradius_mm = 15.0\n\
                  black_level = 512\nwhite_level = 16383\nmask = \"sphere_r15.png\"\n"
                    .to_vec(),
            ),
        ],
        Target::Scene => vec![
            file("data/scenes/bunny.toml"),
            file("data/scenes/sphere_r35.toml"),
            file("data/scenes/torus.toml"),
        ],
        Target::Gaussian => vec![file("data/wax-fit/gaussian.toml")],
        Target::LutExr | Target::ReferenceExr => {
            write_tiny_lut(&dir.join("lut.exr"));
            RgbaImage::new(8, 8)
                .write_exr(dir.join("image.exr"))
                .expect("write a seed EXR");
            vec![
                written("lut.exr"),
                written("image.exr"),
                file("tests/fixtures/not-a-lut.exr"),
            ]
        }
        Target::Photo => {
            let mut image = RgbaImage::new(8, 8);
            for (i, pixel) in image.pixels.iter_mut().enumerate() {
                let v = i as f32 / 64.0;
                *pixel = [v, 0.5 * v, 0.25, 1.0];
            }
            image.write_exr(dir.join("photo.exr")).expect("seed EXR");
            image
                .write_png_srgb(dir.join("photo.png"))
                .expect("seed PNG");
            vec![
                written("photo.exr"),
                written("photo.png"),
                file("data/lambert-control/sphere_r35.png"),
            ]
        }
        Target::CameraRaw => vec![file("crates/cdrf-fit/tests/fixtures/bayer.dng")],
        Target::Obj => vec![
            ("generated/icosphere.obj".to_owned(), icosphere_obj()),
            (
                "generated/quads.obj".to_owned(),
                b"# quads, negative indices, vt/vn\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                  vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\ng plane\nusemtl m\n\
                  f -4/-4/-1 -3/-3/-1 -2/-2/-1 -1/-1/-1\n"
                    .to_vec(),
            ),
            file("data/bunny/bunny.obj"),
        ],
        Target::Gltf => {
            let glb = icosphere_glb();
            let gltf = glb_to_gltf_with_data_uri(&glb);
            vec![
                ("generated/icosphere.glb".to_owned(), glb),
                ("generated/icosphere.gltf".to_owned(), gltf),
                file("tests/fixtures/textured.glb"),
            ]
        }
    }
}

fn write_tiny_lut(path: &Path) {
    let axis = CurvatureAxis::from_radii_mm(50.0, 15.0, 4);
    let theta_count = 8;
    let radiance = (0..axis.count * theta_count)
        .map(|i| Vec3::splat(0.1 + i as f32 / 64.0))
        .collect();
    let lut = CdrfLut::new(axis, theta_count, radiance).expect("a valid tiny LUT");
    cdrf_core::write_lut(&lut, path).expect("write the tiny LUT");
}

fn icosphere_obj() -> Vec<u8> {
    let mesh = Mesh::icosphere(1.0, 1);
    let mut text = String::from("# icosphere, 1 subdivision\n");
    for p in &mesh.positions {
        text += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for n in &mesh.normals {
        text += &format!("vn {} {} {}\n", n.x, n.y, n.z);
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| i + 1);
        text += &format!("f {a}//{a} {b}//{b} {c}//{c}\n");
    }
    text.into_bytes()
}

fn icosphere_glb() -> Vec<u8> {
    let mesh = Mesh::icosphere(1.0, 1);
    let curvature = vec![1.0; mesh.positions.len()];
    glb_bytes_with_curvature(&mesh, &curvature).expect("the icosphere exports")
}

/// The same asset as a `.gltf`: the GLB's JSON with its binary chunk as a base64 `data:` URI.
fn glb_to_gltf_with_data_uri(glb: &[u8]) -> Vec<u8> {
    let u32_at = |i: usize| u32::from_le_bytes(glb[i..i + 4].try_into().expect("4 bytes")) as usize;
    let json_len = u32_at(12);
    let json = &glb[20..20 + json_len];
    let bin_start = 20 + json_len;
    let bin_len = u32_at(bin_start);
    let bin = &glb[bin_start + 8..bin_start + 8 + bin_len];
    let mut document: serde_json::Value = serde_json::from_slice(json).expect("GLB JSON");
    document["buffers"][0]["uri"] = serde_json::Value::String(format!(
        "data:application/octet-stream;base64,{}",
        base64(bin)
    ));
    serde_json::to_vec_pretty(&document).expect("JSON")
}

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Tokens that parsers of cdrf's text formats (TOML, OBJ, glTF JSON) treat specially.
const TOKENS: &[&str] = &[
    "=",
    "\"",
    "'",
    "[",
    "]",
    "{",
    "}",
    ",",
    ":",
    "\n",
    "#",
    "-",
    ".",
    "/",
    "\\",
    "[[",
    "]]",
    "\"\"\"",
    "\u{0}",
    "\u{feff}",
    "\u{fffd}",
    "ü",
    "v ",
    "vn ",
    "vt ",
    "f ",
    "o ",
    "g ",
    "s 1",
    "mtllib x.mtl",
    "usemtl",
    "\"uri\"",
    "\"byteLength\"",
    "\"byteOffset\"",
    "\"count\"",
    "\"children\"",
    "\"nodes\"",
    "\"mesh\"",
    "\"accessors\"",
    "\"bufferView\"",
    "\"scale\"",
    "\"matrix\"",
    "data:",
    "/dev/zero",
    "../",
    "/etc/passwd",
    "true",
    "false",
];

/// Numbers at the edges of what parsers and the maths after them handle.
const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "0.0",
    "1e38",
    "-1e38",
    "3.5e38",
    "1e-45",
    "1e-40",
    "nan",
    "inf",
    "-inf",
    "255",
    "256",
    "65535",
    "65536",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "99999999999999999999",
    "1e308",
    "0x10",
    "1_0",
];

/// A small, fast, seeded random source (xorshift64*): the same seed gives the same inputs.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator started from `seed` (any value; 0 is remapped).
    pub fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// A value in `0..n` (`n` > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// Mutates seed inputs: bit flips, random and "interesting" bytes and integers, inserts,
/// deletes, duplicated ranges, splices with another seed, truncation, and for text formats
/// tokens and edge-case numbers. 1 to 8 mutations are stacked per input.
#[derive(Debug)]
pub struct Mutator {
    rng: Rng,
    text: bool,
    max_len: usize,
}

impl Mutator {
    /// A mutator for `target`, seeded with `seed`; outputs are capped at `max_len` bytes.
    pub fn new(target: Target, seed: u64, max_len: usize) -> Self {
        Self {
            rng: Rng::new(seed),
            text: target.is_text(),
            max_len,
        }
    }

    /// A mutated copy of one of `seeds` (chosen at random; others serve as splice donors).
    pub fn mutate(&mut self, seeds: &[Vec<u8>]) -> Vec<u8> {
        let mut data = seeds[self.rng.below(seeds.len())].clone();
        let rounds = 1 << self.rng.below(4);
        for _ in 0..rounds {
            self.mutate_once(&mut data, seeds);
        }
        data.truncate(self.max_len);
        data
    }

    fn mutate_once(&mut self, data: &mut Vec<u8>, seeds: &[Vec<u8>]) {
        let kinds = if self.text { 11 } else { 9 };
        let len = data.len();
        let at = |rng: &mut Rng, extra: usize| rng.below(len + extra);
        match self.rng.below(kinds) {
            0 if len > 0 => {
                let i = at(&mut self.rng, 0);
                data[i] ^= 1 << self.rng.below(8);
            }
            1 if len > 0 => {
                let i = at(&mut self.rng, 0);
                data[i] = self.rng.next_u64() as u8;
            }
            2 if len > 0 => {
                // An interesting integer, little endian, 1, 2, 4 or 8 bytes wide.
                const VALUES: [u64; 10] = [
                    0,
                    1,
                    0x7f,
                    0x80,
                    0xff,
                    0x7fff,
                    0xffff,
                    0x7fff_ffff,
                    0xffff_ffff,
                    u64::MAX,
                ];
                let value = VALUES[self.rng.below(VALUES.len())];
                let value = if self.rng.below(2) == 0 {
                    value
                } else {
                    value.wrapping_neg()
                };
                let width = 1 << self.rng.below(4);
                let i = at(&mut self.rng, 0);
                let bytes = value.to_le_bytes();
                let n = width.min(len - i);
                data[i..i + n].copy_from_slice(&bytes[..n]);
            }
            3 => {
                let i = at(&mut self.rng, 1);
                let count = 1 + self.rng.below(8);
                let bytes: Vec<u8> = (0..count).map(|_| self.rng.next_u64() as u8).collect();
                data.splice(i..i, bytes);
            }
            4 if len > 0 => {
                let i = at(&mut self.rng, 0);
                let count = 1 + self.rng.below((len - i).min(64));
                data.drain(i..i + count);
            }
            5 if len > 0 => {
                let from = at(&mut self.rng, 0);
                let count = 1 + self.rng.below((len - from).min(256));
                let chunk = data[from..from + count].to_vec();
                let to = at(&mut self.rng, 1);
                data.splice(to..to, chunk);
            }
            6 => {
                // Splice: our head, another seed's tail (from roughly the same place).
                let donor = &seeds[self.rng.below(seeds.len())];
                if !donor.is_empty() {
                    let cut = at(&mut self.rng, 1);
                    let from = self.rng.below(donor.len());
                    data.truncate(cut);
                    data.extend_from_slice(&donor[from..]);
                }
            }
            7 if len > 0 => {
                let keep = self.rng.below(len);
                data.truncate(keep);
            }
            8 if len > 0 => {
                // Overwrite a range with copies of one byte.
                let i = at(&mut self.rng, 0);
                let count = 1 + self.rng.below((len - i).min(32));
                let byte = self.rng.next_u64() as u8;
                data[i..i + count].fill(byte);
            }
            9 => {
                let token = TOKENS[self.rng.below(TOKENS.len())];
                let i = at(&mut self.rng, 1);
                data.splice(i..i, token.bytes());
            }
            10 => self.replace_number(data),
            _ => {}
        }
    }

    /// Replaces one run of ASCII digits (with sign, point, exponent) by an edge-case number.
    fn replace_number(&mut self, data: &mut Vec<u8>) {
        let number = NUMBERS[self.rng.below(NUMBERS.len())];
        let starts: Vec<usize> = (0..data.len())
            .filter(|&i| {
                data[i].is_ascii_digit() && (i == 0 || !data[i - 1].is_ascii_alphanumeric())
            })
            .collect();
        if starts.is_empty() {
            let i = self.rng.below(data.len() + 1);
            data.splice(i..i, number.bytes());
            return;
        }
        let mut start = starts[self.rng.below(starts.len())];
        if start > 0 && data[start - 1] == b'-' {
            start -= 1;
        }
        let mut end = start + 1;
        while end < data.len()
            && matches!(data[end], b'0'..=b'9' | b'.' | b'e' | b'E' | b'-' | b'+')
        {
            end += 1;
        }
        data.splice(start..end, number.bytes());
    }
}

/// A short, stable name for an input: FNV-1a of its bytes, in hex.
pub fn content_hash(bytes: &[u8]) -> String {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        hash ^= u64::from(b);
        hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{hash:016x}")
}
