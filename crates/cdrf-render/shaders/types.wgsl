// The uniform and storage structs of the shading-side passes (groups 0, 1 and 3, and the
// vertex terms). Each is `#[repr(C)]` in src/gpu_types.rs under the same field names; a test
// there holds sizes and offsets against naga's reflection. See docs/shading.md.

// One light. `kind` says which fields it uses: LIGHT_DIRECTIONAL `to_light` and `irradiance`;
// LIGHT_POINT `position` and `intensity`; LIGHT_SPOT those and the `spot_*` fields. Unused
// fields are zero.
struct Light {
    // Unit vector toward a directional light, world space.
    to_light: vec3<f32>,
    kind: u32,
    // A point or spot light's position, world units.
    position: vec3<f32>,
    // Spot: cosines of the outer and inner cone angles, and the unit vector it shines along.
    spot_cos_outer: f32,
    // Irradiance of a directional light on a surface facing it (linear RGB).
    irradiance: vec3<f32>,
    spot_cos_inner: f32,
    // A point or spot light's intensity: the irradiance facing the light at d mm times d²
    // (linear RGB).
    intensity: vec3<f32>,
    spot_direction: vec3<f32>,
}

struct Frame {
    clip_from_world: mat4x4<f32>,
    // The eye position (camera_is_point = 1, perspective) or the unit vector toward the camera
    // (camera_is_point = 0, orthographic).
    to_camera: vec3<f32>,
    camera_is_point: u32,
    // Multiplies the radiance.
    exposure: f32,
    light_count: u32,
    // World units → mm, for the 1/d² of point and spot lights.
    mm_per_world_unit: f32,
    // SH bands of the environment light (0: none).
    environment_bands: u32,
    // Directional lights first: shadowed light i (i < shadows.light_count) is lights[i].
    lights: array<Light, MAX_LIGHTS>,
    // The environment's SH coefficients L_lm at l² + l + m (rgb), each times its basis
    // function's normalisation (cdrf-core's environment::sh_basis_factors), so the shader
    // evaluates the bare polynomials.
    environment_sh: array<vec4<f32>, ENVIRONMENT_SH_COEFFICIENTS>,
}

// The weight per channel of one penumbra tap.
struct PenumbraTap {
    weight: vec3<f32>,
}

struct Material {
    // Lambert: the albedo per channel.
    lambert_albedo: vec3<f32>,
    // Gaussian (analytic): the scale per channel, and σ per channel, mm.
    gaussian_scale: vec3<f32>,
    sigma_mm: vec3<f32>,
    // κ of the LUT's first and last row, mm⁻¹.
    lut_curvature_per_mm: vec2<f32>,
    // LUT texels: θ columns, κ rows.
    lut_size: vec2<f32>,
    // View correction texels: φ columns, θ rows.
    view_size: vec2<f32>,
    // Curvature view: κ at the colour map's ends, mm⁻¹.
    curvature_range_per_mm: vec2<f32>,
    // Penumbra width σ per channel, mm (0: opaque, a hard shadow edge).
    scattering_length_mm: vec3<f32>,
    // T(d, μ) = amplitude · μ^p · exp(−d / length), π·L/E and mm per channel (amplitude 0:
    // none); p is the entry cosine power.
    transmission_entry_cosine_power: f32,
    transmission_amplitude: vec3<f32>,
    // The subsurface gather: the reach of R_far's table (mm; 0: no diffusion profile, no
    // gather) and the profile's entry cosine power p.
    subsurface_reach_mm: f32,
    transmission_length_mm: vec3<f32>,
    subsurface_entry_cosine_power: f32,
    // The specular layer (cdrf-core's specular module): the share of the subsurface light its
    // boundary lets through (1 when off), on (1) or off (0), Beckmann α and relative index η.
    subsurface_transmission: vec3<f32>,
    specular_on: u32,
    specular_roughness_alpha: f32,
    specular_ior: f32,
    // κ of the zonal table's first and last row, mm⁻¹ (equal: one row).
    environment_curvature_per_mm: vec2<f32>,
    // κ of the view correction's first and last layer, mm⁻¹, and its layers (view_size.y rows
    // each, stacked down the texture; one layer: the same at every curvature).
    view_curvature_per_mm: vec2<f32>,
    view_layers: f32,
    // The subsurface gather's cut ℓ_c, mm: the reach of the table's near field it leaves to
    // the table (and the penumbra's width with the gather).
    subsurface_cut_mm: f32,
    // Without the gather: tap k lies at radius PENUMBRA_DISC_PER_WIDTH·σ_max·√(k /
    // PENUMBRA_TAPS), weighted by a Gaussian of each channel's σ.
    penumbra_taps: array<PenumbraTap, PENUMBRA_TAPS>,
    // With the gather: the same spiral over PENUMBRA_DISC_PER_WIDTH·ℓ_c, each tap weighted by the
    // share of the table's near field that lands at its ring (cdrf-core's
    // near_field_ring_shares).
    near_field_taps: array<PenumbraTap, PENUMBRA_TAPS>,
    // The subsurface gather's R_far(d) per channel (mm⁻², xyz) at
    // d = reach · (i / (SUBSURFACE_KERNEL_SAMPLES − 1))²: a uniform array, not a texture, as
    // the gather reads it at every texel.
    subsurface_kernel: array<vec4<f32>, SUBSURFACE_KERNEL_SAMPLES>,
    // The environment light's zonal coefficients a_l(κ) (rgb) at row · ENVIRONMENT_SH_BANDS + l,
    // rows uniform in κ.
    environment_zonal: array<vec4<f32>, ENVIRONMENT_ZONAL_ROWS * ENVIRONMENT_SH_BANDS>,
}

struct ShadowLight {
    // World → face f's light space, world units, rotation and translation only (faces 0 ..
    // face_count). SHADOW_ORTHOGRAPHIC (face 0 only): x, y across the light, z along it (0 at
    // the map's light-side plane, growing away from the light). SHADOW_PERSPECTIVE: origin at
    // the light, z along the face's axis (one face aimed at the draws, or the six faces of a
    // cube about world ±x, ±y, ±z when the light is among them).
    light_from_world: array<mat4x4<f32>, MAX_SHADOW_FACES>,
    // Perspective: the light's position, world units.
    position: vec3<f32>,
    // Orthographic: half the map's side, world units; perspective: tan of half a face's field
    // of view.
    half_extent: f32,
    // Depth stored as 1, world units: along z (orthographic) or the distance from the light
    // (perspective).
    depth_range: f32,
    projection: u32,
    face_count: u32,
    // The shadow map array's layer of face 0.
    first_layer: u32,
}

struct Shadows {
    lights: array<ShadowLight, MAX_SHADOW_LIGHTS>,
    mm_per_world_unit: f32,
    depth_bias_mm: f32,
    // Texels per side.
    resolution: u32,
    // Lights with a map (the first ones of the frame).
    light_count: u32,
    // The subsurface pyramid's level 0, texels per side (a power of two), and its levels
    // (the last one 8 × 8).
    subsurface_resolution: u32,
    subsurface_levels: u32,
}

// One shadowed light's terms at a vertex (w unused): the visibility V, and the light through
// the material that the table does not see, `through` (pack_through in reflectance.wgsl).
struct LightTerms {
    visibility: vec4<f32>,
    through: vec4<f32>,
}

// A vertex's terms, written by the vertex terms pass once per vertex and frame and read by the
// shading pass as its second vertex buffer (VertexTermsIn): those of each shadowed light, the
// inter-reflected radiance before the view correction (xyz; cs_vertex_interreflection adds it,
// the shading pass corrects it for its view) and the angle at which it arrives (w, rad; the
// view correction's θ), and the vertex's exitance
// (xyz, the inter-reflection's source; not read by the shading pass).
struct VertexTerms {
    lights: array<LightTerms, MAX_SHADOW_LIGHTS>,
    radiance: vec4<f32>,
    exitance: vec4<f32>,
}
