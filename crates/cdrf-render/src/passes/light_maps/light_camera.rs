//! A shadowed light's camera: where its map's faces look from and what they cover.

use cdrf_core::glam::{Mat3, Mat4, Vec3, Vec4};
use cdrf_core::light::Light;

/// The largest angle off a perspective face's axis at which it sees the whole bounding sphere;
/// nearer lights get a cube.
const SINGLE_FACE_HALF_ANGLE_DEG: f32 = 60.0;

/// A shadowed light's camera, fitted to the draws' bounding sphere: orthographic along a
/// directional light; for a point or spot light perspective faces about its position — one
/// aimed at the sphere when the light is outside it (the sphere seen within 60° of the axis),
/// else a cube of six (+x, −x, +y, −y, +z, −z, the order the shader picks faces in).
pub(super) struct LightCamera {
    /// World → each face's light space, world units (rotation and translation): x, y across
    /// the light, z along it — from the map's light-side plane (orthographic) or from the light
    /// (perspective).
    pub(super) faces: Vec<Mat4>,
    /// The light's position (perspective), or `None` (orthographic).
    pub(super) position: Option<Vec3>,
    /// Orthographic: half the map's side, world units; perspective: tan of half a face's field
    /// of view.
    pub(super) half_extent: f32,
    /// Depth stored as 1, world units.
    pub(super) depth_range: f32,
}

impl LightCamera {
    pub(super) fn fit(light: &Light, centre: Vec3, radius: f32) -> Self {
        let half_extent = Self::half_extent_for(radius);
        let position = match light {
            Light::Directional(light) => {
                let light_from_world = Mat4::from_translation(Vec3::new(0.0, 0.0, half_extent))
                    * looking_along(-light.to_light.normalize())
                    * Mat4::from_translation(-centre);
                return Self {
                    faces: vec![light_from_world],
                    position: None,
                    half_extent,
                    depth_range: 2.0 * half_extent,
                };
            }
            Light::Point(light) => light.position,
            Light::Spot(light) => light.position,
        };
        let offset = centre - position;
        let distance = offset.length();
        let depth_range = (distance + half_extent).max(1e-6);
        let from_light = Mat4::from_translation(-position);
        if half_extent < distance * SINGLE_FACE_HALF_ANGLE_DEG.to_radians().sin() {
            let forward = offset / distance;
            Self {
                faces: vec![looking_along(forward) * from_light],
                position: Some(position),
                half_extent: half_extent / (distance * distance - half_extent * half_extent).sqrt(),
                depth_range,
            }
        } else {
            let axes = [
                Vec3::X,
                Vec3::NEG_X,
                Vec3::Y,
                Vec3::NEG_Y,
                Vec3::Z,
                Vec3::NEG_Z,
            ];
            Self {
                faces: axes.map(|axis| looking_along(axis) * from_light).to_vec(),
                position: Some(position),
                half_extent: 1.0,
                depth_range,
            }
        }
    }

    /// Half the orthographic map's side for a bounding sphere of `radius` (world units): a
    /// margin so the sphere's rim is not on the map's edge or its far plane.
    pub(super) fn half_extent_for(radius: f32) -> f32 {
        radius * 1.02
    }

    /// Face `face`'s light space → the shadow pass's clip space. Orthographic: depth = z /
    /// depth range; perspective: x / (z·tan), y / (z·tan), clipped to 0.1 % … 100 % of the
    /// depth range (the fragment shader writes the distance from the light as depth).
    pub(super) fn clip_from_world(&self, face: usize) -> Mat4 {
        let light_from_world = self.faces[face];
        if self.position.is_none() {
            return Mat4::from_scale(Vec3::new(
                1.0 / self.half_extent,
                1.0 / self.half_extent,
                1.0 / self.depth_range,
            )) * light_from_world;
        }
        let (far, near) = (self.depth_range, self.depth_range * 1e-3);
        let t = self.half_extent;
        let projection = Mat4::from_cols(
            Vec4::new(1.0 / t, 0.0, 0.0, 0.0),
            Vec4::new(0.0, 1.0 / t, 0.0, 0.0),
            Vec4::new(0.0, 0.0, far / (far - near), 1.0),
            Vec4::new(0.0, 0.0, -near * far / (far - near), 0.0),
        );
        projection * light_from_world
    }
}

/// The rotation whose z axis is `forward` (unit) and x, y span the plane across it.
fn looking_along(forward: Vec3) -> Mat4 {
    let helper = if forward.y.abs() < 0.9 {
        Vec3::Y
    } else {
        Vec3::X
    };
    let x = helper.cross(forward).normalize();
    let y = forward.cross(x);
    Mat4::from_mat3(Mat3::from_cols(x, y, forward).transpose())
}

#[cfg(test)]
mod tests {
    use cdrf_core::light::{DirectionalLight, PointLight};

    use super::*;

    fn clip(camera: &LightCamera, face: usize, point: Vec3) -> Vec3 {
        camera.clip_from_world(face).project_point3(point)
    }

    #[test]
    fn a_directional_light_sees_the_whole_sphere_on_its_map() {
        let (centre, radius) = (Vec3::new(5.0, -2.0, 1.0), 10.0);
        let light = Light::Directional(DirectionalLight {
            to_light: Vec3::new(1.0, 1.0, 0.0),
            irradiance: [1.0; 3],
        });
        let camera = LightCamera::fit(&light, centre, radius);
        assert_eq!((camera.faces.len(), camera.position), (1, None));
        let middle = clip(&camera, 0, centre);
        assert!(middle.truncate().length() < 1e-5 && (middle.z - 0.5).abs() < 1e-5);
        // The sphere's point nearest the light is nearest on the map; every point is inside.
        let to_light = Vec3::new(1.0, 1.0, 0.0).normalize();
        let near = clip(&camera, 0, centre + radius * to_light);
        let far = clip(&camera, 0, centre - radius * to_light);
        assert!(
            0.0 < near.z && near.z < far.z && far.z < 1.0,
            "{near} {far}"
        );
        for axis in [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            Vec3::NEG_X,
            Vec3::NEG_Y,
            Vec3::NEG_Z,
        ] {
            let p = clip(&camera, 0, centre + radius * axis);
            assert!(p.abs().max_element() <= 1.0 && p.z >= 0.0, "{axis}: {p}");
        }
    }

    #[test]
    fn a_lamp_outside_the_draws_gets_one_face_and_one_among_them_a_cube() {
        let lamp = |position| {
            Light::Point(PointLight {
                position,
                intensity: [1.0; 3],
            })
        };
        let far = LightCamera::fit(&lamp(Vec3::new(0.0, 0.0, 100.0)), Vec3::ZERO, 10.0);
        assert_eq!(far.faces.len(), 1);
        // The sphere's centre is on the face's axis, its rim inside the face.
        assert!(clip(&far, 0, Vec3::ZERO).truncate().length() < 1e-5);
        let rim = clip(&far, 0, Vec3::new(10.0, 0.0, 0.0));
        assert!(rim.truncate().length() < 1.0, "{rim}");
        let inside = LightCamera::fit(&lamp(Vec3::new(0.0, 0.0, 5.0)), Vec3::ZERO, 10.0);
        assert_eq!(inside.faces.len(), 6);
        // +x, −x, +y, −y, +z, −z: the point straight along each axis is at its face's centre.
        for (face, axis) in [
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
        ]
        .into_iter()
        .enumerate()
        {
            let p = clip(&inside, face, Vec3::new(0.0, 0.0, 5.0) + 3.0 * axis);
            assert!(
                p.truncate().length() < 1e-5 && (0.0..1.0).contains(&p.z),
                "{face}: {p}"
            );
        }
    }
}
