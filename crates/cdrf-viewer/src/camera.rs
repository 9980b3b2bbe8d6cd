//! The orbit camera of the 3D view: yaw and pitch around a target, distance, pan.

use cdrf_core::glam::{Mat4, Vec2, Vec3};
use cdrf_core::scene::{Camera, Projection};
use cdrf_render::{ToCamera, View};

/// Vertical field of view of the 3D view, degrees.
pub const VERTICAL_FOV_DEG: f32 = 30.0;

/// A perspective camera orbiting `target`, world units mm. Y is up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// The point orbited, mm.
    pub target: Vec3,
    /// Distance from the eye to the target, mm.
    pub distance_mm: f32,
    /// Rotation about +Y, radians (0: the eye on +Z looking down −Z).
    pub yaw_rad: f32,
    /// Elevation of the eye, radians, within ±89°.
    pub pitch_rad: f32,
}

const PITCH_LIMIT_RAD: f32 = 89.0 * std::f32::consts::PI / 180.0;

impl OrbitCamera {
    /// A camera on +Z that frames a sphere of `radius_mm` around `center` in a view of
    /// `aspect` (width / height) — the photographs' view: light from the left is
    /// `to_light = −X`.
    pub fn framing(center: Vec3, radius_mm: f32, aspect: f32) -> Self {
        let tan_half_vertical = (VERTICAL_FOV_DEG * 0.5).to_radians().tan();
        let aspect = if aspect.is_finite() && aspect > 0.0 {
            aspect
        } else {
            1.0
        };
        // The narrower of the two half-angles must hold the sphere.
        let half_fov = (tan_half_vertical * aspect.min(1.0)).atan();
        Self {
            target: center,
            distance_mm: radius_mm.max(1e-3) * 1.1 / half_fov.sin(),
            yaw_rad: 0.0,
            pitch_rad: 0.0,
        }
    }

    /// Eye position, mm.
    pub fn eye(&self) -> Vec3 {
        let (sin_yaw, cos_yaw) = self.yaw_rad.sin_cos();
        let (sin_pitch, cos_pitch) = self.pitch_rad.sin_cos();
        self.target
            + self.distance_mm * Vec3::new(sin_yaw * cos_pitch, sin_pitch, cos_yaw * cos_pitch)
    }

    /// Rotates by a pointer drag of `delta` (fraction of the view height per unit).
    pub fn orbit(&mut self, delta: Vec2) {
        self.yaw_rad -= delta.x * std::f32::consts::PI;
        self.pitch_rad = (self.pitch_rad + delta.y * std::f32::consts::PI)
            .clamp(-PITCH_LIMIT_RAD, PITCH_LIMIT_RAD);
    }

    /// Moves the target in the view plane by a drag of `delta` (fraction of the view height),
    /// so the point under the pointer follows it at the target's depth.
    pub fn pan(&mut self, delta: Vec2) {
        let forward = (self.target - self.eye()).normalize();
        let right = forward.cross(Vec3::Y).normalize();
        let up = right.cross(forward);
        let height_mm = 2.0 * self.distance_mm * (VERTICAL_FOV_DEG * 0.5).to_radians().tan();
        self.target += (-delta.x * right + delta.y * up) * height_mm;
    }

    /// Zooms by `factor` (> 1 moves closer).
    pub fn zoom(&mut self, factor: f32) {
        if factor.is_finite() && factor > 0.0 {
            self.distance_mm = (self.distance_mm / factor).max(1e-3);
        }
    }

    /// The scene camera for a view of `width` × `height` pixels.
    pub fn scene_camera(&self, width: u32, height: u32) -> Camera {
        Camera {
            projection: Projection::Perspective {
                vertical_fov_deg: VERTICAL_FOV_DEG,
            },
            eye: self.eye(),
            target: self.target,
            up: Vec3::Y,
            width: width.max(1),
            height: height.max(1),
            msaa_samples: crate::gpu::SLOT_SAMPLES,
            exposure: 1.0,
        }
    }

    /// Near and far planes around a bounding sphere (`center`, `radius_mm`).
    pub fn depth_range(&self, center: Vec3, radius_mm: f32) -> (f32, f32) {
        let distance = (center - self.eye()).dot((self.target - self.eye()).normalize());
        let margin = radius_mm * 1.05 + 1e-3;
        let far = (distance + margin).max(1e-2);
        ((distance - margin).max(far * 1e-4), far)
    }

    /// The renderer's view and its `clip_from_world` for a view of `width` × `height` pixels
    /// showing a bounding sphere (`center`, `radius_mm`).
    pub fn view(&self, width: u32, height: u32, center: Vec3, radius_mm: f32) -> View {
        let (near, far) = self.depth_range(center, radius_mm);
        let view = View::from_camera(&self.scene_camera(width, height), near, far);
        debug_assert!(matches!(view.to_camera, ToCamera::Point(_)));
        view
    }

    /// The world-space ray (origin, unit direction) through `ndc` (−1..1, y up) of `view`.
    pub fn ray(clip_from_world: Mat4, ndc: Vec2) -> Option<(Vec3, Vec3)> {
        let world_from_clip = clip_from_world.inverse();
        let near = world_from_clip.project_point3(ndc.extend(0.0));
        let far = world_from_clip.project_point3(ndc.extend(1.0));
        let direction = (far - near).normalize_or_zero();
        (near.is_finite() && direction != Vec3::ZERO).then_some((near, direction))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_puts_the_whole_sphere_in_view_and_the_centre_ray_through_it() {
        let camera = OrbitCamera::framing(Vec3::new(1.0, 2.0, 3.0), 50.0, 0.5);
        let view = camera.view(200, 400, Vec3::new(1.0, 2.0, 3.0), 50.0);
        // The sphere's top and side points project inside the view.
        for offset in [Vec3::Y * 50.0, Vec3::X * 50.0, -Vec3::Y * 50.0] {
            let clip = view
                .clip_from_world
                .project_point3(Vec3::new(1.0, 2.0, 3.0) + offset);
            assert!(
                clip.x.abs() < 1.0 && clip.y.abs() < 1.0,
                "{offset} -> {clip}"
            );
            assert!((0.0..=1.0).contains(&clip.z), "depth {clip}");
        }
        let (origin, direction) = OrbitCamera::ray(view.clip_from_world, Vec2::ZERO).unwrap();
        let to_centre = (Vec3::new(1.0, 2.0, 3.0) - origin).normalize();
        assert!(direction.dot(to_centre) > 0.999_99);
    }

    #[test]
    fn orbit_keeps_the_distance_and_clamps_the_pitch() {
        let mut camera = OrbitCamera::framing(Vec3::ZERO, 10.0, 1.0);
        let distance = camera.eye().length();
        camera.orbit(Vec2::new(0.3, 5.0));
        assert!((camera.eye().length() - distance).abs() < 1e-3 * distance);
        assert!(camera.pitch_rad <= PITCH_LIMIT_RAD);
        camera.zoom(2.0);
        assert!((camera.eye().length() - distance / 2.0).abs() < 1e-3 * distance);
    }
}
