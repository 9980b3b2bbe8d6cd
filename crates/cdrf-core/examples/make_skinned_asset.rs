//! Writes the skinned test asset `tests/fixtures/skinned_tube.glb`: no third-party model, every
//! byte made here.
//!
//! ```text
//! cargo run -p cdrf-core --example make_skinned_asset -- tests/fixtures/skinned_tube.glb
//! ```
//!
//! Units are **metres** (glTF's). A finger-like tube along x — an ellipsoid of semi-axes
//! 40 × 7 × 7 mm from an icosphere of 4 subdivisions (2562 vertices), exact normals — skinned to
//! two joints at the origin: node `root` and its child `bend`, both at rest with identity
//! inverse bind matrices. The left half follows `root`, the right half `bend`, blended by a
//! smoothstep over the middle 20 mm. Material `white`: base colour 1, roughness 0.5,
//! metallic 0. Turn `bend` to bend the tube.

use std::collections::BTreeMap;
use std::process::ExitCode;

use cdrf_core::Mesh;
use cdrf_core::glam::{Mat4, Vec3};
use gltf::json;
use gltf_fixture::{Builder, floats};
use json::accessor::{ComponentType, Type};
use json::validation::Checked::Valid;

mod gltf_fixture;

const SEMI_AXES_M: Vec3 = Vec3::new(0.04, 0.007, 0.007);
/// The half width of the blend between the joints, m.
const BLEND_HALF_M: f32 = 0.01;

fn glb() -> Result<Vec<u8>, String> {
    let mut tube = Mesh::icosphere(1.0, 4);
    for (p, n) in tube.positions.iter_mut().zip(&mut tube.normals) {
        let u = *p;
        *p = u * SEMI_AXES_M;
        *n = (u / SEMI_AXES_M).normalize();
    }
    let count = tube.positions.len();
    let mut builder = Builder::new("cdrf-core example make_skinned_asset");
    let positions = builder.vec3s(&tube.positions, true);
    let normals = builder.vec3s(&tube.normals, false);
    let right: Vec<f32> = tube
        .positions
        .iter()
        .map(|p| {
            let t = ((p.x + BLEND_HALF_M) / (2.0 * BLEND_HALF_M)).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        })
        .collect();
    let bytes: Vec<u8> = (0..count)
        .flat_map(|_| [0u16, 1, 0, 0])
        .flat_map(u16::to_le_bytes)
        .collect();
    let joints = builder.accessor(&bytes, count, ComponentType::U16, Type::Vec4, None);
    let bytes = floats(right.iter().flat_map(|&r| [1.0 - r, r, 0.0, 0.0]));
    let weights = builder.accessor(&bytes, count, ComponentType::F32, Type::Vec4, None);
    let indices = builder.triangles(&tube.triangles);
    let bytes = floats((0..2).flat_map(|_| Mat4::IDENTITY.to_cols_array()));
    let inverse_binds = builder.accessor(&bytes, 2, ComponentType::F32, Type::Mat4, None);

    let root = &mut builder.root;
    let material = root.push(json::Material {
        name: Some("white".to_owned()),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(0.5),
            ..Default::default()
        },
        ..Default::default()
    });
    let mut attributes = BTreeMap::new();
    attributes.insert(Valid(json::mesh::Semantic::Positions), positions);
    attributes.insert(Valid(json::mesh::Semantic::Normals), normals);
    attributes.insert(Valid(json::mesh::Semantic::Joints(0)), joints);
    attributes.insert(Valid(json::mesh::Semantic::Weights(0)), weights);
    let mesh = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: Some("tube".to_owned()),
        primitives: vec![json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: Some(material),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        }],
        weights: None,
    });
    let bend = root.push(json::Node {
        name: Some("bend".to_owned()),
        ..Default::default()
    });
    let joint_root = root.push(json::Node {
        name: Some("root".to_owned()),
        children: Some(vec![bend]),
        ..Default::default()
    });
    let skin = root.push(json::Skin {
        extensions: None,
        extras: Default::default(),
        inverse_bind_matrices: Some(inverse_binds),
        joints: vec![joint_root, bend],
        name: Some("tube".to_owned()),
        skeleton: Some(joint_root),
    });
    let tube_node = root.push(json::Node {
        mesh: Some(mesh),
        skin: Some(skin),
        name: Some("tube".to_owned()),
        ..Default::default()
    });
    let scene = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: None,
        nodes: vec![joint_root, tube_node],
    });
    root.scene = Some(scene);
    builder.glb()
}

fn main() -> ExitCode {
    gltf_fixture::write_out("make_skinned_asset", glb())
}
