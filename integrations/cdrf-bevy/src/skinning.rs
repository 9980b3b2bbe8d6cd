//! Skinned CDRF meshes. Bevy skins in its own vertex shader, which cdrf's pass does not run,
//! so the plugin skins on the CPU each frame — linear blend of four joints, as bevy_pbr's
//! `skinning.wesl` — and hands the vertices to cdrf-render's deforming meshes
//! (`Renderer::update_mesh`). The curvature stays the rest pose's (docs/deforming.md measures
//! what that loses); its anisotropy, a direction on the surface, turns with the skin.

use bevy::mesh::VertexAttributeValues;
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::prelude::*;
use cdrf_core::glam;

/// A mesh's joint indices and weights, one entry per cdrf vertex.
#[derive(Clone, Debug)]
pub(crate) struct SkinWeights {
    joints: Vec<[u16; 4]>,
    weights: Vec<[f32; 4]>,
}

impl SkinWeights {
    /// The weights of a Bevy mesh with `ATTRIBUTE_JOINT_INDEX` and `ATTRIBUTE_JOINT_WEIGHT`;
    /// `None` for a mesh without them.
    pub(crate) fn of(mesh: &Mesh) -> Option<Self> {
        let joints = match mesh.try_attribute_option(Mesh::ATTRIBUTE_JOINT_INDEX) {
            Ok(Some(VertexAttributeValues::Uint16x4(joints))) => joints.clone(),
            _ => return None,
        };
        let weights = match mesh.try_attribute_option(Mesh::ATTRIBUTE_JOINT_WEIGHT) {
            Ok(Some(VertexAttributeValues::Float32x4(weights))) => weights.clone(),
            _ => return None,
        };
        (joints.len() == weights.len()).then_some(Self { joints, weights })
    }

    pub(crate) fn len(&self) -> usize {
        self.joints.len()
    }

    /// The largest joint index any vertex names with a non-zero weight.
    fn max_joint(&self) -> Option<u16> {
        self.joints
            .iter()
            .zip(&self.weights)
            .flat_map(|(j, w)| (0..4).filter(|&i| w[i] != 0.0).map(|i| j[i]))
            .max()
    }
}

/// A skinned mesh's vertices this frame: world positions divided by the skin's `scale`, so
/// that a draw scaled by it gives the rest pose's curvature its world size (an armature
/// exported at 0.01 shrinks its mesh's curvature radii too).
#[derive(Debug)]
pub struct Pose {
    /// The skin's uniform scale: the cube root of the first joint matrix's determinant.
    pub scale: f32,
    /// Positions, world units / `scale`.
    pub positions: Vec<glam::Vec3>,
    /// Unit normals (the skin matrix's inverse transpose, as Bevy's `skin_normals`).
    pub normals: Vec<glam::Vec3>,
    /// Tangents turned with the skin (w kept), where the mesh has them.
    pub tangents: Option<Vec<glam::Vec4>>,
    /// The rest pose's curvature anisotropy turned with the skin, mm⁻¹.
    pub anisotropy_per_mm: Vec<glam::Vec3>,
}

/// Why a skinned CDRF mesh is drawn unskinned.
#[derive(Debug, thiserror::Error)]
pub(crate) enum SkinError {
    #[error(
        "its mesh has no Uint16x4 joint indices and Float32x4 weights, one per vertex, or \
         lost vertices to cdrf's repair"
    )]
    Weights,
    #[error("its joint weights name joint {joint}, but the skin has {joints} joints")]
    Joint { joint: u16, joints: usize },
    #[error("its inverse bind poses are not loaded")]
    Bindposes,
    #[error("a joint entity has no GlobalTransform")]
    JointEntity,
}

/// The skin matrices of this frame: each joint's world transform times its inverse bind pose
/// (bevy_pbr's joint matrices).
pub(crate) fn joint_matrices(
    skin: &SkinnedMesh,
    bindposes: &Assets<SkinnedMeshInverseBindposes>,
    transforms: &Query<&GlobalTransform>,
) -> Result<Vec<glam::Mat4>, SkinError> {
    let bindposes = bindposes
        .get(&skin.inverse_bindposes)
        .ok_or(SkinError::Bindposes)?;
    skin.joints
        .iter()
        .zip(bindposes.iter())
        .map(|(&joint, inverse_bindpose)| {
            let world = transforms.get(joint).map_err(|_| SkinError::JointEntity)?;
            Ok(glam::Mat4::from_cols_array(
                &(world.to_matrix() * *inverse_bindpose).to_cols_array(),
            ))
        })
        .collect()
}

/// The rest pose a skin moves: positions and normals, and where the mesh has them tangents, and
/// the curvature's anisotropy.
pub(crate) struct RestPose<'a> {
    pub positions: &'a [glam::Vec3],
    pub normals: &'a [glam::Vec3],
    pub tangents: Option<&'a [glam::Vec4]>,
    pub anisotropy_per_mm: &'a [glam::Vec3],
}

/// Skins the rest pose: each vertex by the weighted sum of its joints' matrices.
pub(crate) fn skin(
    rest: &RestPose<'_>,
    weights: &SkinWeights,
    joint_matrices: &[glam::Mat4],
) -> Result<Pose, SkinError> {
    if let Some(joint) = weights
        .max_joint()
        .filter(|&j| usize::from(j) >= joint_matrices.len())
    {
        return Err(SkinError::Joint {
            joint,
            joints: joint_matrices.len(),
        });
    }
    let count = rest.positions.len();
    let scale = joint_matrices
        .first()
        .map(|m| glam::Mat3::from_mat4(*m).determinant().abs().cbrt())
        .filter(|s| s.is_finite() && *s > 0.0)
        .unwrap_or(1.0);
    let mut pose = Pose {
        scale,
        positions: Vec::with_capacity(count),
        normals: Vec::with_capacity(count),
        tangents: rest.tangents.map(|_| Vec::with_capacity(count)),
        anisotropy_per_mm: Vec::with_capacity(count),
    };
    for i in 0..count {
        let (joints, w) = (weights.joints[i], weights.weights[i]);
        let mut matrix = glam::Mat4::ZERO;
        for k in 0..4 {
            if w[k] != 0.0 {
                matrix += joint_matrices[usize::from(joints[k])] * w[k];
            }
        }
        let linear = glam::Mat3::from_mat4(matrix);
        pose.positions
            .push(matrix.transform_point3(rest.positions[i]) / scale);
        pose.normals.push(
            (linear.inverse().transpose() * rest.normals[i])
                .try_normalize()
                .unwrap_or(rest.normals[i]),
        );
        if let (Some(out), Some(tangents)) = (&mut pose.tangents, rest.tangents) {
            let t = tangents[i];
            let turned = (linear * t.truncate())
                .try_normalize()
                .unwrap_or(t.truncate());
            out.push(turned.extend(t.w));
        }
        let a = rest.anisotropy_per_mm.get(i).copied().unwrap_or_default();
        pose.anisotropy_per_mm
            .push((linear * a).normalize_or_zero() * a.length());
    }
    Ok(pose)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_vertex(joints: [u16; 4], weights: [f32; 4]) -> SkinWeights {
        SkinWeights {
            joints: vec![joints],
            weights: vec![weights],
        }
    }

    #[test]
    fn a_half_weight_blends_two_joints_and_turns_the_frame() {
        let turn = glam::Mat4::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let matrices = [glam::Mat4::IDENTITY, turn];
        let rest = RestPose {
            positions: &[glam::Vec3::X],
            normals: &[glam::Vec3::X],
            tangents: Some(&[glam::Vec4::new(0.0, 1.0, 0.0, -1.0)]),
            anisotropy_per_mm: &[glam::Vec3::X * 0.1],
        };
        let pose = skin(
            &rest,
            &one_vertex([0, 1, 0, 0], [0.5, 0.5, 0.0, 0.0]),
            &matrices,
        )
        .expect("skins");
        // Linear blend: halfway between (1, 0) and (0, 1), normal along the blend.
        assert!(pose.positions[0].abs_diff_eq(glam::Vec3::new(0.5, 0.5, 0.0), 1e-6));
        let diagonal = glam::Vec3::new(1.0, 1.0, 0.0).normalize();
        assert!(pose.normals[0].abs_diff_eq(diagonal, 1e-6));
        assert!(pose.anisotropy_per_mm[0].abs_diff_eq(diagonal * 0.1, 1e-6));
        let tangent = pose.tangents.expect("tangents")[0];
        let turned = glam::Vec3::new(-1.0, 1.0, 0.0).normalize();
        assert!(tangent.abs_diff_eq(turned.extend(-1.0), 1e-6), "{tangent}");
        assert_eq!(pose.scale, 1.0);
    }

    #[test]
    fn a_scaled_armature_scales_the_draw_not_the_positions() {
        let matrices = [glam::Mat4::from_scale(glam::Vec3::splat(0.01))];
        let rest = RestPose {
            positions: &[glam::Vec3::new(30.0, 0.0, 0.0)],
            normals: &[glam::Vec3::X],
            tangents: None,
            anisotropy_per_mm: &[],
        };
        let pose =
            skin(&rest, &one_vertex([0; 4], [1.0, 0.0, 0.0, 0.0]), &matrices).expect("skins");
        assert!((pose.scale - 0.01).abs() < 1e-7);
        // World position 0.3 = scale × 30: the rest pose's units, drawn scaled by 0.01.
        assert!(pose.positions[0].abs_diff_eq(glam::Vec3::new(30.0, 0.0, 0.0), 1e-4));
    }

    #[test]
    fn a_joint_the_skin_lacks_is_refused() {
        let rest = RestPose {
            positions: &[glam::Vec3::X],
            normals: &[glam::Vec3::X],
            tangents: None,
            anisotropy_per_mm: &[],
        };
        let error = skin(
            &rest,
            &one_vertex([0, 3, 0, 0], [0.5, 0.5, 0.0, 0.0]),
            &[glam::Mat4::IDENTITY; 2],
        )
        .expect_err("joint 3 of 2");
        assert_eq!(
            error.to_string(),
            "its joint weights name joint 3, but the skin has 2 joints"
        );
    }
}
