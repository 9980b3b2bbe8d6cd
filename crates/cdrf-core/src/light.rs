//! Lights and the non-local shading terms: the types a renderer takes per frame. Scene files
//! ([`crate::scene`]) parse into them; `cdrf-render` re-exports them.

use glam::Vec3;

/// A directional light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionalLight {
    /// Unit vector toward the light, world space.
    pub to_light: Vec3,
    /// Irradiance on a surface facing the light, linear, per RGB channel.
    pub irradiance: [f32; 3],
}

/// A point light: the same intensity in every direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    /// Where it is, world units.
    pub position: Vec3,
    /// Linear, per RGB channel: the irradiance on a surface facing the light at d **mm** is
    /// `intensity / d²` (so with the scene in mm, intensity is in irradiance · mm²).
    pub intensity: [f32; 3],
}

/// A spot light: a point light whose intensity fades from its axis to a cone's edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotLight {
    /// Where it is, world units.
    pub position: Vec3,
    /// Unit vector, world space: the way the light shines (its cone's axis).
    pub direction: Vec3,
    /// As [`PointLight::intensity`], on the axis.
    pub intensity: [f32; 3],
    /// Full intensity out to this angle from the axis (radians) …
    pub inner_angle_rad: f32,
    /// … and none beyond this one (radians, > inner, ≤ π/2); between, a smoothstep in the cosine.
    pub outer_angle_rad: f32,
}

impl PointLight {
    /// A lamp `distance` world units from `target` toward the unit vector `to_light`, as
    /// bright at `target` as a directional light of `irradiance` there: intensity
    /// `irradiance · (distance · mm_per_world_unit)²`.
    pub fn facing(
        target: Vec3,
        to_light: Vec3,
        distance: f32,
        mm_per_world_unit: f32,
        irradiance: [f32; 3],
    ) -> Self {
        let distance_mm = distance * mm_per_world_unit;
        Self {
            position: target + to_light * distance,
            intensity: irradiance.map(|e| e * distance_mm * distance_mm),
        }
    }
}

impl SpotLight {
    /// `lamp` turned into a spot aimed at `target`, full within `inner_angle_rad` of its axis
    /// and dark beyond `outer_angle_rad`.
    pub fn aimed_at(
        lamp: PointLight,
        target: Vec3,
        inner_angle_rad: f32,
        outer_angle_rad: f32,
    ) -> Self {
        Self {
            position: lamp.position,
            direction: (target - lamp.position).normalize_or_zero(),
            intensity: lamp.intensity,
            inner_angle_rad,
            outer_angle_rad,
        }
    }

    /// The cone's factor (0..=1) for light leaving along the unit vector `from_light`:
    /// `smoothstep(cos outer, cos inner, from_light · direction)`.
    pub fn cone_factor(&self, from_light: Vec3) -> f32 {
        let (cos_outer, cos_inner) = (self.outer_angle_rad.cos(), self.inner_angle_rad.cos());
        let t = ((from_light.dot(self.direction) - cos_outer) / (cos_inner - cos_outer).max(1e-6))
            .clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    }
}

/// A light of any kind (what a frame and a scene file hold).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Parallel light from a direction.
    Directional(DirectionalLight),
    /// Light from a point, falling off as 1/d².
    Point(PointLight),
    /// A point light limited to a cone.
    Spot(SpotLight),
}

/// What a light gives one surface point: the unit vector toward it and the irradiance on a
/// surface there facing it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incidence {
    /// Unit vector toward the light, world space (zero where the point is at the light).
    pub to_light: Vec3,
    /// Irradiance on a surface facing the light, linear, per RGB channel.
    pub irradiance: [f32; 3],
}

impl Light {
    /// The directional light, if this is one.
    pub fn as_directional(&self) -> Option<&DirectionalLight> {
        match self {
            Self::Directional(light) => Some(light),
            _ => None,
        }
    }

    /// The light arriving at `world_position` (world units; `mm_per_world_unit` turns the
    /// distance to a point or spot light into mm for its 1/d²). The shader does the same per
    /// pixel; this is its reference.
    pub fn incidence(&self, world_position: Vec3, mm_per_world_unit: f32) -> Incidence {
        let from_point = |position: Vec3, intensity: [f32; 3]| {
            let offset = position - world_position;
            let d_mm = offset.length() * mm_per_world_unit;
            let falloff = 1.0 / (d_mm * d_mm).max(1e-12);
            Incidence {
                to_light: offset.normalize_or_zero(),
                irradiance: intensity.map(|i| i * falloff),
            }
        };
        match *self {
            Self::Directional(light) => Incidence {
                to_light: light.to_light,
                irradiance: light.irradiance,
            },
            Self::Point(light) => from_point(light.position, light.intensity),
            Self::Spot(light) => {
                let mut incidence = from_point(light.position, light.intensity);
                let cone = light.cone_factor(-incidence.to_light);
                incidence.irradiance = incidence.irradiance.map(|e| e * cone);
                incidence
            }
        }
    }
}

impl From<DirectionalLight> for Light {
    fn from(light: DirectionalLight) -> Self {
        Self::Directional(light)
    }
}

impl From<PointLight> for Light {
    fn from(light: PointLight) -> Self {
        Self::Point(light)
    }
}

impl From<SpotLight> for Light {
    fn from(light: SpotLight) -> Self {
        Self::Spot(light)
    }
}

/// Which non-local terms a render adds to the CDRF (see [`crate::translucency`]). The default,
/// all off, is the poster's local model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct NonLocal {
    /// Translucent visibility: cast shadows from shadow maps, with a penumbra as wide as the
    /// material's scattering length.
    pub shadows: bool,
    /// Transmission: light through parts thinner than the CDRF assumes, and (with `shadows`)
    /// through occluders, by the material's T(d, μ).
    pub transmission: bool,
    /// Inter-reflection: light that left one part of the object (or another draw) — its lit
    /// side or its glow — and enters another through the air, bounce after bounce, as between
    /// the strands of a knot (a radiosity between surface patches: [`crate::patches`]). Zero
    /// on convex objects, where no two points of the surface face each other.
    pub interreflection: bool,
    /// Subsurface gather: light that entered the lit surface near the point — beside it, behind
    /// it — and reached it through the medium, weighted by the material's diffusion profile
    /// ([`crate::diffusion`]) beyond what the point's osculating sphere already lets the CDRF
    /// see. For materials with a profile it replaces `transmission`'s T(d, μ) (the gather holds
    /// the light through thin parts too); without one, T(d, μ) stays.
    pub subsurface: bool,
}

impl NonLocal {
    /// No term: the poster's local model.
    pub const OFF: Self = Self {
        shadows: false,
        transmission: false,
        interreflection: false,
        subsurface: false,
    };

    /// Every term.
    pub const ALL: Self = Self {
        shadows: true,
        transmission: true,
        interreflection: true,
        subsurface: true,
    };

    /// Whether any term is on.
    pub fn any(self) -> bool {
        self.shadows || self.transmission || self.interreflection || self.subsurface
    }

    /// Whether the terms read light maps (each shadowed light's shadow map and subsurface
    /// pyramid): the shader's `LIGHT_MAPS`.
    pub fn light_maps(self) -> bool {
        self.shadows || self.transmission || self.subsurface
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lamp_facing_a_target_gives_it_the_irradiance_asked_for() {
        let target = Vec3::new(1.0, 2.0, 3.0);
        let to_light = Vec3::new(-0.6, 0.0, 0.8);
        // 40 world units of 2.5 mm: 100 mm away.
        let lamp = PointLight::facing(target, to_light, 40.0, 2.5, [0.5, 1.0, 2.0]);
        assert!((lamp.position - (target + 40.0 * to_light)).length() < 1e-4);
        let at = Light::Point(lamp).incidence(target, 2.5);
        for (e, want) in at.irradiance.iter().zip([0.5, 1.0, 2.0]) {
            assert!((e - want).abs() < 1e-5 * want, "{e} vs {want}");
        }
        assert!((at.to_light - to_light).length() < 1e-5);
        // Aimed at the target, the spot's axis passes through it at full strength.
        let spot = SpotLight::aimed_at(lamp, target, 0.2, 0.4);
        assert!((spot.direction + to_light).length() < 1e-5);
        let at_spot = Light::Spot(spot).incidence(target, 2.5);
        assert_eq!(at_spot.irradiance, at.irradiance);
    }

    #[test]
    fn point_light_falls_off_with_the_square_of_the_distance_in_mm() {
        let light = Light::Point(PointLight {
            position: Vec3::new(0.0, 0.0, 10.0), // world units of 2 mm: 20 mm away
            intensity: [400.0, 800.0, 0.0],
        });
        let at = light.incidence(Vec3::ZERO, 2.0);
        assert_eq!(at.to_light, Vec3::Z);
        assert_eq!(at.irradiance, [1.0, 2.0, 0.0]);
    }

    #[test]
    fn spot_light_is_full_inside_its_inner_cone_and_dark_outside_its_outer() {
        let spot = SpotLight {
            position: Vec3::ZERO,
            direction: Vec3::NEG_Z,
            intensity: [1.0; 3],
            inner_angle_rad: 20f32.to_radians(),
            outer_angle_rad: 30f32.to_radians(),
        };
        let along = |deg: f32| {
            let r = deg.to_radians();
            Vec3::new(r.sin(), 0.0, -r.cos())
        };
        assert_eq!(spot.cone_factor(along(0.0)), 1.0);
        assert_eq!(spot.cone_factor(along(19.9)), 1.0);
        assert_eq!(spot.cone_factor(along(30.1)), 0.0);
        let middle = spot.cone_factor(along(25.0));
        assert!(middle > 0.3 && middle < 0.7, "{middle}");
        // Monotonic between the edges.
        let mut last = 1.0;
        for tenth in 200..=300 {
            let f = spot.cone_factor(along(tenth as f32 / 10.0));
            assert!(f <= last + 1e-6, "{tenth}: {f} > {last}");
            last = f;
        }
        // A point 10 mm away on the axis: intensity / 100, the cone's factor 1.
        let at = Light::Spot(spot).incidence(Vec3::new(0.0, 0.0, -10.0), 1.0);
        assert!(
            (at.irradiance[0] - 0.01).abs() < 1e-7,
            "{:?}",
            at.irradiance
        );
    }
}
