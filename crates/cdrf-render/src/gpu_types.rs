//! The data the shaders read, as `#[repr(C)]` structs of the same names and fields as the WGSL
//! declarations (`shaders/common.wgsl`, `shaders/types.wgsl`, `shaders/interreflection.wgsl`,
//! `shaders/shadow_pass.wgsl`). The unit test at the bottom holds every struct's size and field
//! offsets against naga's reflection of every composed shader that declares it, so a field
//! moved on one side only fails `cargo test`. Fields named `_pad*` are
//! explicit padding to WGSL's alignment rules (vec3 and structs: 16 bytes).

use std::mem::offset_of;

use bytemuck::{Pod, Zeroable};
use cdrf_core::glam::{Mat4, Vec2, Vec3, Vec4};

use crate::constants::{
    ENVIRONMENT_SH_BANDS, ENVIRONMENT_SH_COEFFICIENTS, ENVIRONMENT_ZONAL_ROWS, MAX_LIGHTS,
    MAX_SHADOW_FACES, MAX_SHADOW_LIGHTS, PENUMBRA_TAPS, SUBSURFACE_KERNEL_SAMPLES,
};

/// Name, size and named field offsets of a struct, for the layout test.
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) struct StructLayout {
    pub(crate) wgsl_name: &'static str,
    pub(crate) size: usize,
    pub(crate) fields: &'static [(&'static str, usize)],
}

/// Declares a GPU struct: `#[repr(C)]`, `Pod`, and its [`StructLayout`] as `LAYOUT`.
macro_rules! gpu_struct {
    ($(#[$meta:meta])* $name:ident as $wgsl:literal {
        $($(#[$field_meta:meta])* $field:ident: $ty:ty,)*
    }) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Pod, Zeroable)]
        pub(crate) struct $name {
            $($(#[$field_meta])* pub(crate) $field: $ty,)*
        }

        impl $name {
            #[cfg_attr(not(test), allow(dead_code))]
            pub(crate) const LAYOUT: StructLayout = StructLayout {
                wgsl_name: $wgsl,
                size: size_of::<$name>(),
                fields: &[$((stringify!($field), std::mem::offset_of!($name, $field)),)*],
            };
        }
    };
}

gpu_struct! {
    /// One light of any kind (`Light`): `kind` says which fields it uses, the others are zero.
    GpuLight as "Light" {
        /// Directional: unit vector toward the light, world space.
        to_light: Vec3,
        kind: u32,
        /// Point, spot: position, world units.
        position: Vec3,
        spot_cos_outer: f32,
        /// Directional: irradiance facing the light.
        irradiance: Vec3,
        spot_cos_inner: f32,
        /// Point, spot: intensity (irradiance facing the light at d mm, times d²).
        intensity: Vec3,
        _pad0: f32,
        spot_direction: Vec3,
        _pad1: f32,
    }
}

gpu_struct! {
    /// Camera and lights: bind group 0 (`Frame`).
    GpuFrame as "Frame" {
        clip_from_world: Mat4,
        to_camera: Vec3,
        camera_is_point: u32,
        exposure: f32,
        light_count: u32,
        mm_per_world_unit: f32,
        environment_bands: u32,
        lights: [GpuLight; MAX_LIGHTS],
        environment_sh: [[f32; 4]; ENVIRONMENT_SH_COEFFICIENTS],
    }
}

gpu_struct! {
    /// The weight per channel of one penumbra tap (`PenumbraTap`).
    GpuPenumbraTap as "PenumbraTap" {
        weight: Vec3,
        _pad0: f32,
    }
}

gpu_struct! {
    /// A material's parameters: bind group 1, binding 0 (`Material`).
    GpuMaterial as "Material" {
        /// Lambert: the albedo.
        lambert_albedo: Vec3,
        _pad0: f32,
        /// Gaussian (analytic): the scale, and σ.
        gaussian_scale: Vec3,
        _pad1: f32,
        sigma_mm: Vec3,
        _pad2: f32,
        lut_curvature_per_mm: [f32; 2],
        lut_size: [f32; 2],
        view_size: [f32; 2],
        curvature_range_per_mm: [f32; 2],
        scattering_length_mm: Vec3,
        transmission_entry_cosine_power: f32,
        transmission_amplitude: Vec3,
        subsurface_reach_mm: f32,
        transmission_length_mm: Vec3,
        subsurface_entry_cosine_power: f32,
        subsurface_transmission: Vec3,
        specular_on: u32,
        specular_roughness_alpha: f32,
        specular_ior: f32,
        environment_curvature_per_mm: [f32; 2],
        view_curvature_per_mm: [f32; 2],
        view_layers: f32,
        subsurface_cut_mm: f32,
        penumbra_taps: [GpuPenumbraTap; PENUMBRA_TAPS],
        near_field_taps: [GpuPenumbraTap; PENUMBRA_TAPS],
        subsurface_kernel: [[f32; 4]; SUBSURFACE_KERNEL_SAMPLES],
        environment_zonal: [[f32; 4]; ENVIRONMENT_ZONAL_ROWS * ENVIRONMENT_SH_BANDS],
    }
}

gpu_struct! {
    /// One draw's transforms and its surface's factors: bind group 2 of the shading pass, 1
    /// of the shadow pass (`Draw`).
    GpuDraw as "Draw" {
        world_from_model: Mat4,
        normal_from_model: Mat4,
        base_color_factor: Vec3,
        curvature_scale: f32,
        normal_scale: f32,
        roughness_factor: f32,
        surface_flags: u32,
        emitter_first: u32,
    }
}

gpu_struct! {
    /// One light's camera of the shadow maps (`ShadowLight`).
    GpuShadowLight as "ShadowLight" {
        light_from_world: [Mat4; MAX_SHADOW_FACES],
        position: Vec3,
        half_extent: f32,
        depth_range: f32,
        projection: u32,
        face_count: u32,
        first_layer: u32,
    }
}

gpu_struct! {
    /// The shadow maps' cameras and parameters: bind group 3, binding 0 (`Shadows`).
    GpuShadows as "Shadows" {
        lights: [GpuShadowLight; MAX_SHADOW_LIGHTS],
        mm_per_world_unit: f32,
        depth_bias_mm: f32,
        resolution: u32,
        light_count: u32,
        subsurface_resolution: u32,
        subsurface_levels: u32,
        _pad0: u32,
        _pad1: u32,
    }
}

gpu_struct! {
    /// The shadow pass's per-light transform: its bind group 0 (`ShadowPass`).
    GpuShadowPass as "ShadowPass" {
        clip_from_world: Mat4,
        light_position: Vec3,
        inverse_depth_range: f32,
    }
}

gpu_struct! {
    /// One vertex of a mesh (`VertexIn` in `shaders/mesh.wgsl`: locations 0–4 and 14).
    GpuVertex as "VertexIn" {
        position: Vec3,
        normal: Vec3,
        curvature_per_mm: f32,
        uv: Vec2,
        // ([f32; 4], not Vec4: glam's Vec4 is 16-byte aligned, which would pad the vertex.)
        tangent: [f32; 4],
        curvature_anisotropy_per_mm: Vec3,
    }
}

impl GpuVertex {
    /// The vertex buffer's attributes, from the struct's offsets.
    pub(crate) const ATTRIBUTES: [wgpu::VertexAttribute; 6] = [
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x3,
            offset: std::mem::offset_of!(GpuVertex, position) as u64,
            shader_location: 0,
        },
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x3,
            offset: std::mem::offset_of!(GpuVertex, normal) as u64,
            shader_location: 1,
        },
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32,
            offset: std::mem::offset_of!(GpuVertex, curvature_per_mm) as u64,
            shader_location: 2,
        },
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x2,
            offset: std::mem::offset_of!(GpuVertex, uv) as u64,
            shader_location: 3,
        },
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x4,
            offset: std::mem::offset_of!(GpuVertex, tangent) as u64,
            shader_location: 4,
        },
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x3,
            offset: std::mem::offset_of!(GpuVertex, curvature_anisotropy_per_mm) as u64,
            shader_location: 14,
        },
    ];

    /// Bytes per vertex.
    pub(crate) const STRIDE: u64 = size_of::<GpuVertex>() as u64;
}

gpu_struct! {
    /// One shadowed light's terms at a vertex (`LightTerms`; w unused): the visibility, and the
    /// light through the material (T, or the gather G where the material gathers).
    GpuLightTerms as "LightTerms" {
        visibility: Vec4,
        through: Vec4,
    }
}

gpu_struct! {
    /// One vertex's non-local terms, written by the vertex terms pass and read by the shading
    /// pass as its second vertex buffer (`VertexTerms`; `VertexTermsIn` in
    /// `shaders/shading_pass.wgsl`).
    GpuVertexTerms as "VertexTerms" {
        lights: [GpuLightTerms; MAX_SHADOW_LIGHTS],
        radiance: Vec4,
        exitance: Vec4,
    }
}

/// The per-vertex light slots `shaders/shading_pass.wgsl` writes out by hand (stage inputs and
/// outputs hold no arrays: `VertexTermsIn`, `VertexOut`, `slot_terms`) and
/// `light_curvatures_per_mm`'s `vec4` holds. `tests/shaders.rs` counts them in the WGSL.
const WGSL_LIGHT_SLOTS: usize = 4;
const _: () = assert!(
    MAX_SHADOW_LIGHTS == WGSL_LIGHT_SLOTS,
    "MAX_SHADOW_LIGHTS changed: write out as many slots in shaders/shading_pass.wgsl"
);

impl GpuVertexTerms {
    /// The first shader location of the terms (`VertexTermsIn`).
    const FIRST_LOCATION: u32 = 5;

    /// The second vertex buffer's attributes: each light's visibility and `through`, then the
    /// radiance (the exitance, the inter-reflection's source, is not shaded).
    pub(crate) const ATTRIBUTES: [wgpu::VertexAttribute; 2 * MAX_SHADOW_LIGHTS + 1] = {
        let mut attributes = [wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x4,
            offset: 0,
            shader_location: 0,
        }; 2 * MAX_SHADOW_LIGHTS + 1];
        let mut k = 0;
        while k < MAX_SHADOW_LIGHTS {
            let light = offset_of!(GpuVertexTerms, lights) + k * size_of::<GpuLightTerms>();
            attributes[2 * k].offset = (light + offset_of!(GpuLightTerms, visibility)) as u64;
            attributes[2 * k + 1].offset = (light + offset_of!(GpuLightTerms, through)) as u64;
            k += 1;
        }
        attributes[2 * MAX_SHADOW_LIGHTS].offset = offset_of!(GpuVertexTerms, radiance) as u64;
        let mut i = 0;
        while i < attributes.len() {
            attributes[i].shader_location = Self::FIRST_LOCATION + i as u32;
            i += 1;
        }
        attributes
    };

    /// Bytes per vertex.
    pub(crate) const STRIDE: u64 = size_of::<GpuVertexTerms>() as u64;
}

/// The shading pass's vertex attributes (the mesh's and the terms') fit WebGPU's default limit
/// of 16.
const _: () = assert!(GpuVertex::ATTRIBUTES.len() + GpuVertexTerms::ATTRIBUTES.len() <= 16);

gpu_struct! {
    /// One patch of a mesh (cdrf-core's `patches::SurfacePatch`): the inter-reflection's
    /// compute passes read them (`Patch`) and place them where their vertices are.
    GpuPatch as "Patch" {
        area: f32,
        curvature_per_mm: f32,
        first_member: u32,
        member_count: u32,
    }
}

gpu_struct! {
    /// One vertex of a patch and its share of the patch's area (`PatchMember`).
    GpuPatchMember as "PatchMember" {
        vertex: u32,
        weight: f32,
    }
}

gpu_struct! {
    /// One patch as the frame places it, written and read by the inter-reflection's compute
    /// passes only (`Emitter`).
    GpuEmitter as "Emitter" {
        position_mm: Vec3,
        area_mm2: f32,
        normal: Vec3,
        sagitta_mm: f32,
        direct: Vec3,
        curvature_per_mm: f32,
        exitance: Vec3,
        _pad0: f32,
    }
}

/// The stages that read bind groups 0, 1 and 3 (`shaders/bindings.wgsl`): the shading and
/// light-view passes' and the compute passes'.
pub(crate) const SHADING_STAGES: wgpu::ShaderStages =
    wgpu::ShaderStages::VERTEX_FRAGMENT.union(wgpu::ShaderStages::COMPUTE);

/// Size of a uniform struct, for bind group layouts' `min_binding_size`.
pub(crate) const fn uniform_size<T>() -> std::num::NonZeroU64 {
    match std::num::NonZeroU64::new(size_of::<T>() as u64) {
        Some(size) => size,
        None => panic!("a uniform struct has a size"),
    }
}

/// A bind group layout entry for a uniform buffer holding one `T` (the type's size as the
/// minimum binding size).
pub(crate) const fn uniform_layout_entry<T>(
    binding: u32,
    visibility: wgpu::ShaderStages,
    has_dynamic_offset: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset,
            min_binding_size: Some(uniform_size::<T>()),
        },
        count: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shaders::{SHADERS, SHADING, SHADOW};

    /// The uniform and storage structs, each declared in the shader(s) that read it.
    const LAYOUTS: [StructLayout; 13] = [
        GpuLightTerms::LAYOUT,
        GpuVertexTerms::LAYOUT,
        GpuPatch::LAYOUT,
        GpuPatchMember::LAYOUT,
        GpuEmitter::LAYOUT,
        GpuLight::LAYOUT,
        GpuFrame::LAYOUT,
        GpuPenumbraTap::LAYOUT,
        GpuMaterial::LAYOUT,
        GpuDraw::LAYOUT,
        GpuShadowLight::LAYOUT,
        GpuShadows::LAYOUT,
        GpuShadowPass::LAYOUT,
    ];

    fn parse(source: &str) -> naga::Module {
        naga::front::wgsl::parse_str(source).expect("WGSL parses")
    }

    /// The WGSL struct `name`'s members, if the module declares it.
    fn members<'a>(module: &'a naga::Module, name: &str) -> Option<&'a [naga::StructMember]> {
        module.types.iter().find_map(|(_, ty)| match &ty.inner {
            naga::TypeInner::Struct { members, .. } if ty.name.as_deref() == Some(name) => {
                Some(members.as_slice())
            }
            _ => None,
        })
    }

    /// Differences between the Rust layouts and the WGSL module's structs of the same names
    /// (every Rust layout whose struct the module declares).
    fn mismatches(module: &naga::Module, layouts: &[StructLayout]) -> Vec<String> {
        let mut problems = Vec::new();
        for layout in layouts {
            let Some((_, ty)) = module
                .types
                .iter()
                .find(|(_, ty)| ty.name.as_deref() == Some(layout.wgsl_name))
            else {
                continue;
            };
            let naga::TypeInner::Struct { members, span } = &ty.inner else {
                problems.push(format!("{} is not a struct in the WGSL", layout.wgsl_name));
                continue;
            };
            if *span as usize != layout.size {
                problems.push(format!(
                    "{}: WGSL size {span}, Rust size {}",
                    layout.wgsl_name, layout.size
                ));
            }
            let rust: Vec<(&str, usize)> = layout
                .fields
                .iter()
                .copied()
                .filter(|(name, _)| !name.starts_with("_pad"))
                .collect();
            let wgsl: Vec<(&str, usize)> = members
                .iter()
                .map(|m| (m.name.as_deref().unwrap_or("?"), m.offset as usize))
                .collect();
            if rust != wgsl {
                problems.push(format!(
                    "{}: WGSL fields {wgsl:?}, Rust fields {rust:?}",
                    layout.wgsl_name
                ));
            }
        }
        problems
    }

    /// Every Rust layout matches its struct in every composed shader that declares it, and
    /// some shader declares each.
    #[test]
    fn gpu_structs_match_the_wgsl() {
        let mut problems = Vec::new();
        let mut declared = Vec::new();
        for shader in SHADERS {
            let module = parse(shader.compose().source());
            for problem in mismatches(&module, &LAYOUTS) {
                problems.push(format!("{}: {problem}", shader.label));
            }
            declared.extend(
                LAYOUTS
                    .iter()
                    .filter(|layout| members(&module, layout.wgsl_name).is_some())
                    .map(|layout| layout.wgsl_name),
            );
        }
        for layout in &LAYOUTS {
            if !declared.contains(&layout.wgsl_name) {
                problems.push(format!(
                    "struct {} is declared by no shader",
                    layout.wgsl_name
                ));
            }
        }
        assert!(
            problems.is_empty(),
            "layout mismatches:\n{}",
            problems.join("\n")
        );
    }

    /// The check is not vacuous: a field inserted on the WGSL side only shifts the later ones,
    /// and a field renamed or retyped is caught.
    #[test]
    fn a_shifted_wgsl_field_is_caught() {
        let source = SHADING.compose().source().to_string();
        let shifted = source.replace(
            "    camera_is_point: u32,\n",
            "    camera_is_point: u32,\n    inserted: f32,\n",
        );
        assert_ne!(
            shifted, source,
            "the Frame declaration changed; update this test"
        );
        let problems = mismatches(&parse(&shifted), &LAYOUTS);
        println!("{}", problems.join("\n"));
        assert!(
            problems.iter().any(|p| p.starts_with("Frame:")),
            "{problems:?}"
        );

        let retyped = source.replace(
            "    depth_bias_mm: f32,\n",
            "    depth_bias_mm: vec2<f32>,\n",
        );
        assert_ne!(
            retyped, source,
            "the Shadows declaration changed; update this test"
        );
        let problems = mismatches(&parse(&retyped), &LAYOUTS);
        assert!(
            problems.iter().any(|p| p.starts_with("Shadows:")),
            "{problems:?}"
        );
        assert!(mismatches(&parse(SHADOW.compose().source()), &LAYOUTS).is_empty());
    }

    /// (name, location) of each member of the WGSL struct `name`.
    fn locations_of(module: &naga::Module, name: &str) -> Vec<(String, u32)> {
        members(module, name)
            .unwrap_or_else(|| panic!("{name} declared"))
            .iter()
            .filter_map(|member| match member.binding {
                Some(naga::Binding::Location { location, .. }) => {
                    Some((member.name.clone().unwrap_or_default(), location))
                }
                _ => None,
            })
            .collect()
    }

    /// The vertex attributes the pipelines declare are the shader's `VertexIn` and
    /// `VertexTermsIn` locations.
    #[test]
    fn vertex_attributes_match_the_wgsl() {
        let module = parse(SHADING.compose().source());
        let names = [
            "position",
            "normal",
            "curvature_per_mm",
            "uv",
            "tangent",
            "curvature_anisotropy_per_mm",
        ];
        let expected: Vec<(String, u32)> = GpuVertex::ATTRIBUTES
            .iter()
            .zip(names)
            .map(|(attribute, name)| (name.to_string(), attribute.shader_location))
            .collect();
        assert_eq!(locations_of(&module, "VertexIn"), expected);
        let fields: Vec<usize> = GpuVertex::LAYOUT.fields.iter().map(|f| f.1).collect();
        let offsets: Vec<usize> = GpuVertex::ATTRIBUTES
            .iter()
            .map(|a| a.offset as usize)
            .collect();
        assert_eq!(fields, offsets);

        let names = (0..MAX_SHADOW_LIGHTS)
            .flat_map(|k| [format!("visibility_{k}"), format!("through_{k}")])
            .chain(["radiance".to_string()]);
        let expected: Vec<(String, u32)> = names
            .zip(GpuVertexTerms::ATTRIBUTES)
            .map(|(name, attribute)| (name, attribute.shader_location))
            .collect();
        assert_eq!(locations_of(&module, "VertexTermsIn"), expected);
        // Each slot's attributes are its light's fields, in order.
        let slot = size_of::<GpuLightTerms>() as u64;
        for (k, pair) in GpuVertexTerms::ATTRIBUTES
            .chunks(2)
            .take(MAX_SHADOW_LIGHTS)
            .enumerate()
        {
            assert_eq!(pair[0].offset, k as u64 * slot);
            assert_eq!(pair[1].offset, k as u64 * slot + 16);
        }
    }
}
