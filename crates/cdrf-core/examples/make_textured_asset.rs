//! Writes the textured test asset `tests/fixtures/textured.glb`: no third-party model, every
//! byte made here.
//!
//! ```text
//! cargo run -p cdrf-core --example make_textured_asset -- tests/fixtures/textured.glb
//! ```
//!
//! Units are **millimetres** (`mm_per_unit = 1`). One mesh, one node, two primitives:
//!
//! 0. A UV sphere of radius 30 mm at the origin (64 segments around +y, 32 rings), material
//!    `checker`: a 64 × 64 px sRGB PNG base-colour texture of 8 × 8 px squares, white
//!    (255, 255, 255: the measured material itself) and light orange (255, 200, 150), the
//!    top-left square white; a 128 × 128 px tangent-space normal map (linear PNG) of the bumps
//!    `h(u, v) = sin(16πu) · sin(8πv)`; roughness 0.6.
//! 1. A UV sphere of radius 15 mm centred at (55, 0, 0) mm (32 × 16), material `tinted`: base
//!    colour factor (0.8, 0.9, 1.0, 1), roughness 0.3, no texture.
//!
//! Both have exact normals and `TEXCOORD_0` (`u = φ / 2π` around +y from +z towards +x,
//! `v = θ / π` from the north pole, glTF's `v` down) and no `TANGENT`, so loaders compute
//! MikkTSpace tangents. Seam and pole vertices repeat their positions bit for bit (the welded
//! mesh is closed). Metallic factors are 0 (cdrf materials are dielectric).

use std::collections::BTreeMap;
use std::f32::consts::{PI, TAU};
use std::io::Cursor;
use std::process::ExitCode;

use cdrf_core::glam::{Vec2, Vec3};
use gltf::json;
use gltf_fixture::{Builder, floats};
use json::validation::Checked::Valid;

mod gltf_fixture;

/// The checker texture's side and its squares' side, in pixels.
const CHECKER_PX: u32 = 64;
const SQUARE_PX: u32 = 8;
/// The normal map's side in pixels.
const NORMAL_PX: u32 = 128;
/// Bump height in texels of the normal map (its strength).
const BUMP_TEXELS: f32 = 2.0;

struct Sphere {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    triangles: Vec<[u32; 3]>,
}

/// A UV sphere: `rings − 1` rows of `segments + 1` vertices, the last column repeating the
/// first's positions, and two pole rows at exactly `±radius` on y with one vertex per segment
/// (`u` at the segment's middle).
fn uv_sphere(centre: Vec3, radius: f32, segments: u32, rings: u32) -> Sphere {
    let mut sphere = Sphere {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        triangles: Vec::new(),
    };
    for i in 0..=rings {
        let theta = PI * i as f32 / rings as f32;
        let columns = if i == 0 || i == rings {
            segments
        } else {
            segments + 1
        };
        for j in 0..columns {
            let phi = TAU * (j % segments) as f32 / segments as f32;
            let normal = if i == 0 {
                Vec3::Y
            } else if i == rings {
                Vec3::NEG_Y
            } else {
                Vec3::new(
                    theta.sin() * phi.sin(),
                    theta.cos(),
                    theta.sin() * phi.cos(),
                )
            };
            let u = if i == 0 || i == rings {
                (j as f32 + 0.5) / segments as f32
            } else {
                j as f32 / segments as f32
            };
            sphere.positions.push(centre + radius * normal);
            sphere.normals.push(normal);
            sphere.uvs.push(Vec2::new(u, i as f32 / rings as f32));
        }
    }
    let index = |i: u32, j: u32| {
        if i == 0 {
            j
        } else {
            segments + (i - 1) * (segments + 1) + j
        }
    };
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            );
            // Counter-clockwise from outside; the pole rows have one triangle per segment.
            if i == 0 {
                sphere.triangles.push([a, b, c]);
            } else if i + 1 == rings {
                sphere.triangles.push([a, b, d]);
            } else {
                sphere.triangles.push([a, b, c]);
                sphere.triangles.push([a, c, d]);
            }
        }
    }
    sphere
}

/// The checker: white and light orange 8 × 8 px squares, sRGB.
fn checker() -> Vec<u8> {
    let mut pixels = Vec::with_capacity((CHECKER_PX * CHECKER_PX * 3) as usize);
    for y in 0..CHECKER_PX {
        for x in 0..CHECKER_PX {
            let white = (x / SQUARE_PX + y / SQUARE_PX).is_multiple_of(2);
            pixels.extend_from_slice(if white {
                &[255, 255, 255]
            } else {
                &[255, 200, 150]
            });
        }
    }
    png(CHECKER_PX, &pixels)
}

/// The bump map's tangent-space normals: `+X` along `+u`, `+Y` up the image (along `−v`).
fn bump_normals() -> Vec<u8> {
    let n = NORMAL_PX as f32;
    let mut pixels = Vec::with_capacity((NORMAL_PX * NORMAL_PX * 3) as usize);
    for y in 0..NORMAL_PX {
        for x in 0..NORMAL_PX {
            let (u, v) = ((x as f32 + 0.5) / n, (y as f32 + 0.5) / n);
            // h(u, v) = sin(16πu) sin(8πv), in texels of height: derivatives per texel.
            let dh_du = 16.0 * PI * (16.0 * PI * u).cos() * (8.0 * PI * v).sin() / n;
            let dh_dv = 8.0 * PI * (16.0 * PI * u).sin() * (8.0 * PI * v).cos() / n;
            let normal = Vec3::new(-BUMP_TEXELS * dh_du, BUMP_TEXELS * dh_dv, 1.0).normalize();
            pixels.extend(
                normal
                    .to_array()
                    .map(|c| ((c * 0.5 + 0.5) * 255.0).round() as u8),
            );
        }
    }
    png(NORMAL_PX, &pixels)
}

fn png(side: u32, rgb: &[u8]) -> Vec<u8> {
    let mut bytes = Vec::new();
    image::write_buffer_with_format(
        &mut Cursor::new(&mut bytes),
        rgb,
        side,
        side,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .expect("encoding a PNG in memory cannot fail");
    bytes
}

impl Builder {
    fn primitive(
        &mut self,
        sphere: &Sphere,
        material: json::Index<json::Material>,
    ) -> json::mesh::Primitive {
        use json::accessor::{ComponentType, Type};
        let count = sphere.positions.len();
        let mut attributes = BTreeMap::new();
        let positions = self.vec3s(&sphere.positions, true);
        attributes.insert(Valid(json::mesh::Semantic::Positions), positions);
        let normals = self.vec3s(&sphere.normals, false);
        attributes.insert(Valid(json::mesh::Semantic::Normals), normals);
        let bytes = floats(sphere.uvs.iter().flat_map(|t| t.to_array()));
        let uvs = self.accessor(&bytes, count, ComponentType::F32, Type::Vec2, None);
        attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), uvs);
        let indices = self.triangles(&sphere.triangles);
        json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: Some(material),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        }
    }

    fn png_texture(&mut self, png: &[u8], name: &str) -> json::Index<json::Texture> {
        let view = self.view(png, None);
        let image = self.root.push(json::Image {
            buffer_view: Some(view),
            mime_type: Some(json::image::MimeType("image/png".to_owned())),
            name: Some(name.to_owned()),
            uri: None,
            extensions: None,
            extras: Default::default(),
        });
        self.root.push(json::Texture {
            name: Some(name.to_owned()),
            sampler: Some(json::Index::new(0)),
            source: image,
            extensions: None,
            extras: Default::default(),
        })
    }
}

fn material(
    name: &str,
    base_color_factor: [f32; 4],
    roughness: f32,
    base_color_texture: Option<json::Index<json::Texture>>,
    normal_texture: Option<json::Index<json::Texture>>,
) -> json::Material {
    json::Material {
        name: Some(name.to_owned()),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor(base_color_factor),
            base_color_texture: base_color_texture.map(|index| json::texture::Info {
                index,
                tex_coord: 0,
                extensions: None,
                extras: Default::default(),
            }),
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(roughness),
            ..Default::default()
        },
        normal_texture: normal_texture.map(|index| json::material::NormalTexture {
            index,
            scale: 1.0,
            tex_coord: 0,
            extensions: None,
            extras: Default::default(),
        }),
        ..Default::default()
    }
}

fn glb() -> Result<Vec<u8>, String> {
    let mut builder = Builder::new("cdrf-core example make_textured_asset");
    builder.root.push(json::texture::Sampler {
        mag_filter: Some(Valid(json::texture::MagFilter::Linear)),
        min_filter: Some(Valid(json::texture::MinFilter::LinearMipmapLinear)),
        wrap_s: Valid(json::texture::WrappingMode::Repeat),
        wrap_t: Valid(json::texture::WrappingMode::ClampToEdge),
        ..Default::default()
    });
    let checker = builder.png_texture(&checker(), "checker");
    let bumps = builder.png_texture(&bump_normals(), "bumps");
    let checker_material = builder.root.push(material(
        "checker",
        [1.0; 4],
        0.6,
        Some(checker),
        Some(bumps),
    ));
    let tinted_material =
        builder
            .root
            .push(material("tinted", [0.8, 0.9, 1.0, 1.0], 0.3, None, None));
    let big = builder.primitive(&uv_sphere(Vec3::ZERO, 30.0, 64, 32), checker_material);
    let small = builder.primitive(
        &uv_sphere(Vec3::new(55.0, 0.0, 0.0), 15.0, 32, 16),
        tinted_material,
    );
    let root = &mut builder.root;
    let mesh = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: Some("textured".to_owned()),
        primitives: vec![big, small],
        weights: None,
    });
    let node = root.push(json::Node {
        mesh: Some(mesh),
        name: Some("textured".to_owned()),
        ..Default::default()
    });
    let scene = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: None,
        nodes: vec![node],
    });
    root.scene = Some(scene);
    builder.glb()
}

fn main() -> ExitCode {
    gltf_fixture::write_out("make_textured_asset", glb())
}
