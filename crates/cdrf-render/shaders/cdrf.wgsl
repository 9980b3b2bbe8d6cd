// cdrf: shading of curvature-tagged meshes with a curvature-dependent reflectance function.
//
// Output is linear radiance: L = Σ_lights E/π · f(κ, θ) · g(θ, φ), where f is the table value in
// the LUT convention π·L/E (a white Lambertian surface gives max(cos θ, 0)), κ the mean curvature
// in mm⁻¹, θ the angle between the normal and the direction to the light, φ the angle between the
// normal and the direction to the camera. See crates/cdrf-core/src/lut.rs for the conventions.
// An environment light adds its SH sum with the material's zonal coefficients a_l(κ), times
// g(0, φ); a specular layer (cdrf-core's specular module) scales all of that by the share t its
// boundary lets through and adds Σ_lights E · f_spec · cos θ (dimmed by the shadows' V).
// A draw's surface (cdrf-render's surface module) tints the subsurface light by its base
// colour, bends the per-pixel normal by its normal map and sets the specular roughness.
//
// Bind groups (all owned by cdrf-render's Renderer):
//   0: frame    camera, lights
//   1: material LUT, view correction, model parameters
//   2: draw     model transform and surface factors (dynamic offset), the surface's base
//               colour, normal and roughness textures and their samplers; in the compute
//               passes the mesh's vertices, patches, the terms and the frame's emitters
//   3: shadows  per-light light-space transforms, shadow maps (first-surface depth) and the
//               subsurface pyramids (the light entering the lit surface)
//
// The shading model, the LUT filtering and the non-local terms are pipeline-overridable
// constants, so each pipeline compiles to one straight-line shader.
//
// Non-local terms (SHADOWS, TRANSMISSION; see crates/cdrf-core/src/translucency.rs), for the first
// MAX_SHADOW_LIGHTS lights: a directional light's map is orthographic (columns along z), a point
// or spot light's perspective (one face, or a cube of six; columns are the rays from the light
// and depths the distance from it), so the test below runs along each light's own rays
// (light_frame_point, light_ray, light_depth). The CDRF answers as if
// the point lay on its osculating sphere (radius 1/κ, centre p − n/κ). For each shadow-map texel
// around the point we compare the first surface the light meets with the one that sphere (or,
// for flat and concave points, the tangent plane) predicts in that column:
//   - nearer the light than predicted: the column is occluded by something the CDRF does not
//     know (a cast shadow). Visibility V is the Gaussian-weighted share of unoccluded columns,
//     σ = the material's scattering length per channel, so the shadow edge is soft;
//   - transmission: light of occluded columns arrives through d mm of the occluder (light-space
//     depth difference) as T(d, μ), μ the cosine at which it entered the occluder (from the
//     shadow map's depth slope); where the point's own column is thinner than the sphere
//     predicts (a fin, a slab lit from behind) T(d, μ) − T(d_sphere, μ) is added.
// Per light: f → V·f (shadows) + T_occluded + T_thin (transmission), all times g(θ, φ). The
// terms are evaluated per vertex and interpolated (they vary over σ); Lambert's, per pixel.
//
// The subsurface gather below reads maps rendered from each face of each shadowed light
// (vs_light_view): a texel's "light area" A (texel_light_area) is what the light sees of it per
// unit of the light's irradiance_or_intensity — the texel's side² for an orthographic map, its
// solid angle (times a spot's falloff) for a perspective one, since the flux through a solid
// angle ω is intensity · ω — so the flux entering the surface in the texel is that light value
// times A, and the gather returns its sum per unit of it (fs_main multiplies).
//
// Inter-reflection (INTERREFLECTION): light that left one part of the object — its lit side or
// the glow past its terminator — and enters another through the air, bounce after bounce (a
// radiosity between surface patches; cdrf-core's patches module cuts each mesh into them once).
// Four compute passes, after the light maps: cs_vertex_terms also writes each vertex's exitance
// M (Σ over the lights of what fs_main's light_share gives, before the view correction: the
// light leaving the point, as if evenly); cs_patch_emitters averages M over each patch into the
// frame's emitters (world mm: centroid, normal, area, sagitta); cs_emitter_bounce adds to each
// emitter what the others send it, Options::interreflection_bounces − 1 times; and
// cs_vertex_interreflection gathers the emitters at every vertex. An emitter e lights a point as
// a Lambertian disc of its area A and exitance M (exact on its axis, 1/d² far away, the disc's
// area as the point sees it saturating the 1/d² near it), E⊥ = M · A cos θ_e / (π d² + A cos θ_e),
// cos θ_e measured above e's plane less its sagitta (a convex patch does not light its own
// surface), with no visibility test; the point answers with its CDRF as to a small light in
// e's direction, E⊥/π · f(κ, θ_ω), θ_ω past 90° included (light entering the point's part
// beside it), f from its zonal expansion at the point's mean curvature (zonal_value: no texture
// read per emitter), and the sum times the view correction of light along the normal, g(0, φ),
// as the environment light's. On a convex object no emitter lies in front of another's
// surface: the term is zero there.
//
// Subsurface gather (SUBSURFACE; see cdrf-core's diffusion::FarField). The light that entered
// the lit surface near a point — beside it, behind it — and reached it through the medium
// leaves it by the material's diffusion profile R(d). The table f(κ, θ) already holds what
// enters the point's osculating sphere, so only the difference is added, and only the
// profile's far field R_far (the terms longer than a cut ℓ_c, finite at d = 0), which a
// sampled surface resolves:
//   f → V·(f − F_sphere(κ, θ)) + (V + (1 − V)·s(κ, θ))·G,   G = Σ_q w_q · Φ_q · R_far(|p − q|),
// F_sphere the same far field integrated over the osculating sphere (tabulated per material on
// the LUT's axes; the shader reads f − F_sphere as one table), s = f / F_sphere on the
// sphere's shadow side (θ ≥ 100°, held at its 100° value toward the light; applied per vertex,
// where V < 1): what the point receives in shadow is scaled as the measured sphere's shadow
// side is over the profile's, so a sphere keeps f exactly for any V, and Φ_q = μ_q^(p−1) · A_q
// the light entering texel q (μ^p the entry factor, 1/μ the surface a texel covers). V is the
// near field's visibility: with the gather, its penumbra is ℓ_c wide (the table keeps only
// what reaches that far; G brings the rest from the lit surface that is there), not σ. w_q
// (through_medium) leaves out the light that entered in front of the point's local shape along
// the light — an occluder above a cast shadow: its light crosses the air to get here, and the
// inter-reflection carries it. G multiplies the light's irradiance_or_intensity, the rest this
// point's irradiance (under a point light the light entered where the irradiance is not this
// point's). The subsurface map pass (fs_subsurface_map) renders each face's first surface
// into level 0 of a pyramid (Φ·position, Φ), fine enough that ℓ_c spans 1.5 texels; each
// level sums 2 × 2 of the one below. Each vertex reads 12 × 12 texels of every level around
// its own position on the face, weighted by a partition of unity in distance (level L covers
// 1.5–6 of its texels, fading in and out smoothly), and the coarsest level whole: ~800 reads
// per face whatever the map's size, and a continuous function of the point (no texel switches
// on or off at a step), so interpolating it between vertices cannot blotch. A cube's six faces
// are each read around the point's projection on them (their fine levels only where that
// window reaches the face), so the sum is continuous across their edges too. On a sphere
// G = F_sphere up to sampling. With a profile, G replaces TRANSMISSION's T(d, μ); materials
// without one keep T.

const PI: f32 = 3.14159265358979;
const FRAC_1_PI: f32 = 0.318309886183791;
const FRAC_2_PI: f32 = 0.636619772367581;
const FRAC_PI_2: f32 = 1.5707963267949;
const FRAC_1_SQRT_TAU: f32 = 0.398942280401433;
// MAX_LIGHTS, MAX_SHADOW_LIGHTS, PENUMBRA_TAPS (columns read per point and shadowed light when
// the penumbra is wider than a texel: the centre and a Vogel spiral out to 2σ) and the shading
// models MODEL_* are generated by cdrf-render from its Rust constants (see common.wgsl).
const GOLDEN_ANGLE: f32 = 2.39996322972865;
// Principal curvatures may differ from the mean curvature the mesh carries (saddles, cylinders):
// an occluder counts only if it is nearer the light than this much extra curvature explains.
const CURVATURE_ALLOWANCE_PER_MM: f32 = 0.05;
// T(d, μ) was measured on the spheres' shadow side, θ ≥ 110°; nearer the terminator sideways
// diffusion (the CDRF) dominates. The thin-part term fades in as the normal turns away from
// the light, from θ = 90° (light-space n.z = 0) to θ = 110° (n.z = −cos 110°).
const THIN_PART_FADE_END: f32 = 0.342020143325669;

override MODEL: u32 = 0u;
// true: bilinear filtering by hand (four texel loads, f32 weights); false: the sampler's.
override MANUAL_FILTERING: bool = false;
// true when the target is an 8-bit UNORM format that is not sRGB: encode in the shader.
override ENCODE_SRGB: bool = false;
// The non-local terms (both false: the poster's local model): translucent visibility from the
// shadow maps, and transmission.
override SHADOWS: bool = false;
override TRANSMISSION: bool = false;
override INTERREFLECTION: bool = false;
override SUBSURFACE: bool = false;

struct Light {
    // LIGHT_DIRECTIONAL: unit vector toward the light, world space; LIGHT_POINT, LIGHT_SPOT:
    // the light's position, world units.
    to_light_or_position: vec3<f32>,
    kind: u32,
    // Directional: irradiance on a surface facing the light; point, spot: intensity, the
    // irradiance facing the light at d mm times d² (linear RGB).
    irradiance_or_intensity: vec3<f32>,
    // Spot: cosines of the outer and inner cone angles, and the unit vector it shines along.
    spot_cos_outer: f32,
    spot_direction: vec3<f32>,
    spot_cos_inner: f32,
}

// What a light gives a surface point (cdrf-core's light::Incidence).
struct Incidence {
    to_light: vec3<f32>,
    irradiance: vec3<f32>,
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

// The Gaussian weight per channel of one penumbra tap.
struct PenumbraTap {
    weight: vec3<f32>,
}

struct Material {
    // Lambert: albedo; Gaussian (analytic): scale per channel.
    albedo_or_scale: vec3<f32>,
    // Gaussian (analytic): σ per channel, mm.
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
    // Tap k lies at radius 2σ_max·√(k / PENUMBRA_TAPS).
    penumbra_taps: array<PenumbraTap, PENUMBRA_TAPS>,
    // The subsurface gather's R_far(d) per channel (mm⁻², xyz) at
    // d = reach · (i / (SUBSURFACE_KERNEL_SAMPLES − 1))²: a uniform array, which the gather reads
    // at every texel (as a texture it cost lavapipe 40 of the gather's 69 ms on the bunny).
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

@group(0) @binding(0) var<uniform> frame: Frame;
@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var lut: texture_2d<f32>;
@group(1) @binding(2) var view_correction: texture_2d<f32>;
@group(1) @binding(3) var lut_sampler: sampler;
// The LUT's rows, then the rows of its near field f(κ, θ) − F_sphere(κ, θ) — the table without
// R_far over the osculating sphere (the LUT again where the material has no diffusion
// profile): pipelines that may gather read it in the LUT's place (table_value).
@group(1) @binding(4) var lut_and_near_field: texture_2d<f32>;
// s(κ, θ): the measured table over F_sphere on the sphere's shadow side (see the header).
@group(1) @binding(5) var subsurface_gain: texture_2d<f32>;
@group(2) @binding(0) var<uniform> draw: Draw;
// sRGB base colour (decoded by the format), tangent-space normals, roughness in G.
@group(2) @binding(1) var base_color_texture: texture_2d<f32>;
@group(2) @binding(2) var normal_texture: texture_2d<f32>;
@group(2) @binding(3) var roughness_texture: texture_2d<f32>;
@group(2) @binding(4) var base_color_sampler: sampler;
@group(2) @binding(5) var normal_sampler: sampler;
@group(2) @binding(6) var roughness_sampler: sampler;
@group(3) @binding(0) var<uniform> shadows: Shadows;
@group(3) @binding(1) var shadow_maps: texture_depth_2d_array;
// The subsurface pyramid: per texel Φ·(position in the light's frame, mm) and Φ (per unit of
// the light's irradiance_or_intensity), summed over the level-0 texels it covers; one layer
// per face of each shadowed light.
@group(3) @binding(2) var subsurface_pyramid: texture_2d_array<f32>;

// The vertex terms pass (cs_vertex_terms): the draw's mesh vertices as the vertex buffer holds
// them (VERTEX_FLOATS f32s each: position at VERTEX_POSITION, normal at VERTEX_NORMAL,
// curvature at VERTEX_CURVATURE) and the terms it writes for each of them.
@group(2) @binding(7) var<storage, read> terms_mesh_vertices: array<f32>;
@group(2) @binding(8) var<storage, read_write> terms_out: array<VertexTerms>;
// The inter-reflection's passes (see the header): the draw's mesh's patches and their
// vertices, and the frame's emitters (every emitting draw's patches), read and written.
@group(2) @binding(9) var<storage, read> patches: array<Patch>;
@group(2) @binding(10) var<storage, read> patch_members: array<PatchMember>;
@group(2) @binding(11) var<storage, read> emitters: array<Emitter>;
@group(2) @binding(12) var<storage, read_write> emitters_out: array<Emitter>;

// One patch of a mesh (cdrf-core's patches::SurfacePatch), model units.
struct Patch {
    centroid: vec3<f32>,
    area: f32,
    normal: vec3<f32>,
    sagitta: f32,
    curvature_per_mm: f32,
    first_member: u32,
    member_count: u32,
}

// One vertex of a patch and its share of the patch's area.
struct PatchMember {
    vertex: u32,
    weight: f32,
}

// One patch of an emitting draw as the frame places it: world position and sizes in mm, unit
// world normal, the mean curvature (mm⁻¹) it receives light with, its own exitance M (π·L,
// per unit of irradiance: the light's) and M with the bounces gathered so far.
struct Emitter {
    position_mm: vec3<f32>,
    area_mm2: f32,
    normal: vec3<f32>,
    sagitta_mm: f32,
    direct: vec3<f32>,
    curvature_per_mm: f32,
    exitance: vec3<f32>,
}

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) curvature_per_mm: f32,
    @location(3) uv: vec2<f32>,
    // xyz along +u, w the bitangent's sign (zero: no tangents).
    @location(4) tangent: vec4<f32>,
    // The curvature's anisotropy (cdrf-core's curvature::Curvature), model frame, mm⁻¹.
    @location(14) curvature_anisotropy_per_mm: vec3<f32>,
}

// A vertex's non-local terms (see vs_main_terms), written by cs_vertex_terms once per vertex
// and frame: visibility (xyz) and transmission or gather (xyz, π·L/E) of the shadowed lights
// 0–3, the inter-reflected radiance (xyz; cs_vertex_interreflection) and the vertex's exitance
// (xyz, the inter-reflection's source; not read by the shading pass). w unused.
struct VertexTerms {
    visibility_0: vec4<f32>,
    transmission_0: vec4<f32>,
    visibility_1: vec4<f32>,
    transmission_1: vec4<f32>,
    visibility_2: vec4<f32>,
    transmission_2: vec4<f32>,
    visibility_3: vec4<f32>,
    transmission_3: vec4<f32>,
    radiance: vec4<f32>,
    exitance: vec4<f32>,
}

// The same, read back as a second vertex buffer by the shading pass (locations 5–13).
struct VertexTermsIn {
    @location(5) visibility_0: vec4<f32>,
    @location(6) transmission_0: vec4<f32>,
    @location(7) visibility_1: vec4<f32>,
    @location(8) transmission_1: vec4<f32>,
    @location(9) visibility_2: vec4<f32>,
    @location(10) transmission_2: vec4<f32>,
    @location(11) visibility_3: vec4<f32>,
    @location(12) transmission_3: vec4<f32>,
    @location(13) radiance: vec4<f32>,
}

// Centroid interpolation: with MSAA, a silhouette pixel whose centre lies outside the triangle
// is shaded inside it instead of at an extrapolated normal.
struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(perspective, centroid) world_position: vec3<f32>,
    @location(1) @interpolate(perspective, centroid) world_normal: vec3<f32>,
    @location(2) @interpolate(perspective, centroid) curvature_per_mm: f32,
    // Non-local terms of the shadowed lights 0–3, evaluated per vertex (see vs_main):
    // visibility (xyz) and transmission (xyz, π·L/E) each; in visibility_i.w the curvature
    // along the direction to light i (light_curvature_per_mm), for lights 0–3 whether
    // shadowed or not.
    @location(3) @interpolate(perspective, centroid) visibility_0: vec4<f32>,
    @location(4) @interpolate(perspective, centroid) transmission_0: vec3<f32>,
    @location(5) @interpolate(perspective, centroid) visibility_1: vec4<f32>,
    @location(6) @interpolate(perspective, centroid) transmission_1: vec3<f32>,
    @location(7) @interpolate(perspective, centroid) visibility_2: vec4<f32>,
    @location(8) @interpolate(perspective, centroid) transmission_2: vec3<f32>,
    @location(9) @interpolate(perspective, centroid) visibility_3: vec4<f32>,
    @location(10) @interpolate(perspective, centroid) transmission_3: vec3<f32>,
    // Radiance evaluated per vertex (before exposure): the inter-reflected light of all
    // shadowed lights and the environment light, both smooth over the surface.
    @location(11) @interpolate(perspective, centroid) vertex_radiance: vec3<f32>,
    @location(12) @interpolate(perspective, centroid) uv: vec2<f32>,
    @location(13) @interpolate(perspective, centroid) world_tangent: vec4<f32>,
}

// The non-local terms of a translucent material vary over the scattering length σ (light
// diffuses under a shadow's edge over about σ), so they are evaluated per vertex and
// interpolated: meshes whose edges are well below σ (millimetres for wax) resolve them, at a
// cost per vertex instead of per pixel. Lambert (opaque, hard edges) is evaluated per pixel.
// They are evaluated once per vertex and frame by the vertex terms pass (cs_vertex_terms) and
// read here as a second vertex buffer (vs_main_terms): a rasteriser shades a vertex once per
// triangle corner or batch that uses it (lavapipe about six times), the pass exactly once.
@vertex
fn vs_main(vertex: VertexIn) -> VertexOut {
    return vertex_out(vertex);
}

// vs_main, with the vertex's non-local terms from the vertex terms pass.
@vertex
fn vs_main_terms(vertex: VertexIn, terms: VertexTermsIn) -> VertexOut {
    var out = vertex_out(vertex);
    out.visibility_0 = vec4<f32>(terms.visibility_0.xyz, out.visibility_0.w);
    out.transmission_0 = terms.transmission_0.xyz;
    out.visibility_1 = vec4<f32>(terms.visibility_1.xyz, out.visibility_1.w);
    out.transmission_1 = terms.transmission_1.xyz;
    out.visibility_2 = vec4<f32>(terms.visibility_2.xyz, out.visibility_2.w);
    out.transmission_2 = terms.transmission_2.xyz;
    out.visibility_3 = vec4<f32>(terms.visibility_3.xyz, out.visibility_3.w);
    out.transmission_3 = terms.transmission_3.xyz;
    out.vertex_radiance += terms.radiance.xyz;
    return out;
}

// The shading pass's vertex without non-local terms (visibility 1, no transmission or
// inter-reflection), with the environment light's radiance.
fn vertex_out(vertex: VertexIn) -> VertexOut {
    let world = draw.world_from_model * vec4<f32>(vertex.position, 1.0);
    var out: VertexOut;
    out.clip = frame.clip_from_world * world;
    out.world_position = world.xyz / world.w;
    out.world_normal = world_normal_of(vertex.normal);
    out.curvature_per_mm = vertex.curvature_per_mm * draw.curvature_scale;
    out.uv = vertex.uv;
    out.world_tangent = vec4<f32>(
        (draw.world_from_model * vec4<f32>(vertex.tangent.xyz, 0.0)).xyz,
        vertex.tangent.w,
    );
    let curvatures = light_curvatures_per_mm(
        out.world_position,
        normalize(out.world_normal),
        out.curvature_per_mm,
        world_anisotropy_of(vertex.curvature_anisotropy_per_mm),
    );
    out.visibility_0 = vec4<f32>(1.0, 1.0, 1.0, curvatures.x);
    out.visibility_1 = vec4<f32>(1.0, 1.0, 1.0, curvatures.y);
    out.visibility_2 = vec4<f32>(1.0, 1.0, 1.0, curvatures.z);
    out.visibility_3 = vec4<f32>(1.0, 1.0, 1.0, curvatures.w);
    out.transmission_0 = vec3<f32>(0.0);
    out.transmission_1 = vec3<f32>(0.0);
    out.transmission_2 = vec3<f32>(0.0);
    out.transmission_3 = vec3<f32>(0.0);
    out.vertex_radiance = vec3<f32>(0.0);
    // The environment light: its order-4 SH sum varies as slowly as the normal does, so per
    // vertex.
    if frame.environment_bands != 0u && MODEL != MODEL_CURVATURE {
        let normal = normalize(out.world_normal);
        var environment = environment_radiance(normal, out.curvature_per_mm);
        if MODEL != MODEL_LAMBERT {
            // Light from everywhere: the view correction of light along the normal.
            let phi = angle(dot(normal, to_camera_from(out.world_position)));
            environment *= view_value(out.curvature_per_mm, 0.0, phi);
        }
        out.vertex_radiance = environment;
    }
    return out;
}

// A model-space normal in world space (not normalised).
fn world_normal_of(normal: vec3<f32>) -> vec3<f32> {
    return (draw.normal_from_model * vec4<f32>(normal, 0.0)).xyz;
}

// A vertex's curvature anisotropy (mm⁻¹, model frame) in world space: turned with the model
// transform, rescaled as the curvature is.
fn world_anisotropy_of(anisotropy: vec3<f32>) -> vec3<f32> {
    let turned = (draw.world_from_model * vec4<f32>(anisotropy, 0.0)).xyz;
    let length_turned = length(turned);
    if length_turned <= 0.0 {
        return vec3<f32>(0.0);
    }
    return turned * (length(anisotropy) * draw.curvature_scale / length_turned);
}

// The curvature along a direction (cdrf-core's curvature::directional_curvature_per_mm):
// H + 2 (d·a)²/|a| − |a|·(1 − (d·n)²), the normal curvature along d's tangent part, moving to
// H as d turns to the normal.
fn directional_curvature(
    mean_per_mm: f32,
    anisotropy: vec3<f32>,
    normal: vec3<f32>,
    direction: vec3<f32>,
) -> f32 {
    let length_a = length(anisotropy);
    if length_a <= 0.0 {
        return mean_per_mm;
    }
    let along = dot(direction, anisotropy);
    let facing = dot(direction, normal);
    return mean_per_mm + 2.0 * along * along / length_a
        - length_a * max(1.0 - facing * facing, 0.0);
}

// The curvature each of lights 0–3 sees at a vertex: along the direction to the light, across
// which its angle θ changes (a tube lit across its axis falls off like a sphere of the tube's
// radius, lit along it like a flat strip), where the table is read for that light. Lights from
// 4 on use the mean curvature.
fn light_curvatures_per_mm(
    world_position: vec3<f32>,
    normal: vec3<f32>,
    mean_per_mm: f32,
    anisotropy: vec3<f32>,
) -> vec4<f32> {
    var curvatures = vec4<f32>(mean_per_mm);
    let count = min(frame.light_count, 4u);
    for (var i = 0u; i < count; i++) {
        let to_light = light_incidence(frame.lights[i], world_position).to_light;
        curvatures[i] = directional_curvature(mean_per_mm, anisotropy, normal, to_light);
    }
    return curvatures;
}

// The curvature light `index` sees at a fragment (light_curvatures_per_mm, interpolated).
fn light_curvature_per_mm(in: VertexOut, index: u32) -> f32 {
    switch index {
        case 0u: {
            return in.visibility_0.w;
        }
        case 1u: {
            return in.visibility_1.w;
        }
        case 2u: {
            return in.visibility_2.w;
        }
        case 3u: {
            return in.visibility_3.w;
        }
        default: {
            return in.curvature_per_mm;
        }
    }
}

// The compute passes' invocation index: a 2D grid of 64-wide groups (a dimension holds at
// most 65 535 groups), the index running along the grid's rows.
fn invocation_index(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * 64u;
}

// A vertex of the draw's mesh, as the compute passes read it: world position, unit world
// normal, curvature and its anisotropy (mm⁻¹, world frame).
struct MeshVertex {
    world_position: vec3<f32>,
    normal: vec3<f32>,
    curvature_per_mm: f32,
    anisotropy: vec3<f32>,
}

fn mesh_vertex(i: u32) -> MeshVertex {
    let base = i * VERTEX_FLOATS;
    var v: MeshVertex;
    let position = vec3<f32>(
        terms_mesh_vertices[base + VERTEX_POSITION],
        terms_mesh_vertices[base + VERTEX_POSITION + 1u],
        terms_mesh_vertices[base + VERTEX_POSITION + 2u],
    );
    let world = draw.world_from_model * vec4<f32>(position, 1.0);
    v.world_position = world.xyz / world.w;
    v.normal = normalize(world_normal_of(vec3<f32>(
        terms_mesh_vertices[base + VERTEX_NORMAL],
        terms_mesh_vertices[base + VERTEX_NORMAL + 1u],
        terms_mesh_vertices[base + VERTEX_NORMAL + 2u],
    )));
    v.curvature_per_mm = terms_mesh_vertices[base + VERTEX_CURVATURE] * draw.curvature_scale;
    v.anisotropy = world_anisotropy_of(vec3<f32>(
        terms_mesh_vertices[base + VERTEX_ANISOTROPY],
        terms_mesh_vertices[base + VERTEX_ANISOTROPY + 1u],
        terms_mesh_vertices[base + VERTEX_ANISOTROPY + 2u],
    ));
    return v;
}

// The vertex terms pass: the non-local terms of every vertex of the draw's mesh, once, and
// with the inter-reflection its exitance (see the header).
@compute @workgroup_size(64)
fn cs_vertex_terms(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = invocation_index(id, groups);
    if i >= arrayLength(&terms_out) {
        return;
    }
    let v = mesh_vertex(i);
    // (The shadow test's local shape keeps the mean curvature: read at the curvature along
    // the light, a saddle's switch between sphere and tangent plane painted jagged lines of
    // visibility along the torus's shadow side.)
    var lights: array<NonLocalTerms, MAX_SHADOW_LIGHTS>;
    for (var k = 0u; k < MAX_SHADOW_LIGHTS; k++) {
        lights[k].visibility = vec3<f32>(1.0);
        lights[k].transmission = vec3<f32>(0.0);
    }
    let count = min(shadows.light_count, frame.light_count);
    let curvatures = light_curvatures_per_mm(
        v.world_position,
        v.normal,
        v.curvature_per_mm,
        v.anisotropy,
    );
    if (SHADOWS || TRANSMISSION || SUBSURFACE) && MODEL != MODEL_CURVATURE {
        for (var k = 0u; k < count; k++) {
            if MODEL == MODEL_LAMBERT {
                // Lambert's terms are the shading pass's, per pixel; the exitance needs them here.
                if INTERREFLECTION && SHADOWS {
                    lights[k] = non_local_terms(k, v.world_position, v.normal, v.curvature_per_mm);
                }
            } else {
                lights[k] = vertex_non_local(
                    k,
                    v.world_position,
                    v.normal,
                    v.curvature_per_mm,
                    curvatures[k],
                );
            }
        }
    }
    var terms: VertexTerms;
    terms.visibility_0 = vec4<f32>(lights[0].visibility, 1.0);
    terms.transmission_0 = vec4<f32>(lights[0].transmission, 0.0);
    terms.visibility_1 = vec4<f32>(lights[1].visibility, 1.0);
    terms.transmission_1 = vec4<f32>(lights[1].transmission, 0.0);
    terms.visibility_2 = vec4<f32>(lights[2].visibility, 1.0);
    terms.transmission_2 = vec4<f32>(lights[2].transmission, 0.0);
    terms.visibility_3 = vec4<f32>(lights[3].visibility, 1.0);
    terms.transmission_3 = vec4<f32>(lights[3].transmission, 0.0);
    if INTERREFLECTION && MODEL != MODEL_CURVATURE {
        var exitance = vec3<f32>(0.0);
        for (var k = 0u; k < min(frame.light_count, MAX_LIGHTS); k++) {
            let incidence = light_incidence(frame.lights[k], v.world_position);
            let cos_theta = dot(v.normal, incidence.to_light);
            var curvature_per_mm = v.curvature_per_mm;
            var light_terms: NonLocalTerms;
            light_terms.visibility = vec3<f32>(1.0);
            light_terms.transmission = vec3<f32>(0.0);
            if k < 4u {
                curvature_per_mm = curvatures[k];
            }
            if k < MAX_SHADOW_LIGHTS {
                light_terms = lights[k];
            }
            exitance += light_share(
                k,
                incidence,
                cos_theta,
                angle(cos_theta),
                curvature_per_mm,
                light_terms,
            ).reflected;
        }
        terms.exitance = vec4<f32>(exitance, 0.0);
    }
    terms_out[i] = terms;
}

// Each patch of the draw's mesh as an emitter of the frame (at draw.emitter_first + patch):
// placed by the draw's transform, its exitance its vertices' area-weighted mean.
@compute @workgroup_size(64)
fn cs_patch_emitters(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = invocation_index(id, groups);
    if i >= arrayLength(&patches) {
        return;
    }
    let surface_patch = patches[i];
    var direct = vec3<f32>(0.0);
    for (var m = 0u; m < surface_patch.member_count; m++) {
        let member = patch_members[surface_patch.first_member + m];
        direct += member.weight * terms_out[member.vertex].exitance.xyz;
    }
    // Model units → mm: the transform's scale (1 / curvature_scale), then the frame's unit.
    let mm_per_model_unit = frame.mm_per_world_unit / draw.curvature_scale;
    let world = draw.world_from_model * vec4<f32>(surface_patch.centroid, 1.0);
    var e: Emitter;
    e.position_mm = world.xyz / world.w * frame.mm_per_world_unit;
    e.normal = normalize(world_normal_of(surface_patch.normal));
    e.area_mm2 = surface_patch.area * mm_per_model_unit * mm_per_model_unit;
    e.sagitta_mm = surface_patch.sagitta * mm_per_model_unit;
    e.curvature_per_mm = surface_patch.curvature_per_mm * draw.curvature_scale;
    e.direct = direct;
    e.exitance = direct;
    emitters_out[draw.emitter_first + i] = e;
}

// One bounce: each emitter of the draw's patches gathers what every other emitter sends it
// and sends out its own light plus that (its receiving part answers as at its mean curvature).
@compute @workgroup_size(64)
fn cs_emitter_bounce(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = invocation_index(id, groups);
    if i >= arrayLength(&patches) {
        return;
    }
    let k = draw.emitter_first + i;
    var e = emitters[k];
    let receiver = Receiver(e.position_mm, e.normal, e.curvature_per_mm);
    e.exitance = e.direct + gathered_light(receiver, k);
    emitters_out[k] = e;
}

// The inter-reflected radiance at every vertex of the draw's mesh, gathered from the frame's
// emitters after their bounces (added to what cs_vertex_terms wrote).
@compute @workgroup_size(64)
fn cs_vertex_interreflection(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = invocation_index(id, groups);
    if i >= arrayLength(&terms_out) {
        return;
    }
    let v = mesh_vertex(i);
    let receiver = Receiver(
        v.world_position * frame.mm_per_world_unit,
        v.normal,
        v.curvature_per_mm,
    );
    var light = gathered_light(receiver, arrayLength(&emitters));
    if MODEL != MODEL_LAMBERT {
        // Light from everywhere: the view correction of light along the normal (as the
        // environment light's).
        let phi = angle(dot(v.normal, to_camera_from(v.world_position)));
        light *= view_value(v.curvature_per_mm, 0.0, phi);
    }
    terms_out[i].radiance += vec4<f32>(FRAC_1_PI * light, 0.0);
}

// A point receiving the inter-reflection: position (mm), unit normal and mean curvature
// (mm⁻¹).
struct Receiver {
    position_mm: vec3<f32>,
    normal: vec3<f32>,
    curvature_per_mm: f32,
}

// Σ over the frame's emitters but `skip` of the light each gives the receiver (see the header),
// π·L/E times the irradiance facing the emitter: f(κ, θ_ω) · E⊥ (the CDRF's zonal expansion at
// the receiver's mean curvature: zonal_value).
fn gathered_light(receiver: Receiver, skip: u32) -> vec3<f32> {
    let response = zonal_response(receiver.curvature_per_mm);
    var sum = vec3<f32>(0.0);
    let count = arrayLength(&emitters);
    for (var k = 0u; k < count; k++) {
        // Only the fields the sum needs, each read on its own: lavapipe reads a storage buffer
        // at a loop's index invocation by invocation, and the whole emitter's 15 floats cost
        // about 2 ms more per frame on the bunny than these 11.
        let e = &emitters[k];
        let from_emitter = receiver.position_mm - (*e).position_mm;
        let height = dot((*e).normal, from_emitter) - (*e).sagitta_mm;
        let area_mm2 = (*e).area_mm2;
        if k == skip || height <= 0.0 || !(area_mm2 > 0.0) {
            continue;
        }
        let d2 = dot(from_emitter, from_emitter);
        let d = sqrt(d2);
        // The disc's area seen from the point, A cos θ_e, saturates its 1/d² near it.
        let seen_mm2 = area_mm2 * height / d;
        let facing = (*e).exitance * (seen_mm2 / (PI * d2 + seen_mm2));
        sum += facing * zonal_value(response, -dot(receiver.normal, from_emitter) / d);
    }
    return sum;
}

// Whether this material's subsurface gather is on (a diffusion profile, and the pipeline's).
fn gathers_subsurface() -> bool {
    return SUBSURFACE && material.subsurface_reach_mm > 0.0 && MODEL != MODEL_LAMBERT;
}

// The per-vertex terms of shadowed light `index`: visibility and T(d, μ) from the shadow map
// (π·L/E), and with the subsurface gather G in T's place (per unit of the light's
// irradiance_or_intensity: see fs_main).
fn vertex_non_local(
    index: u32,
    world_position: vec3<f32>,
    normal: vec3<f32>,
    curvature_per_mm: f32,
    light_curvature_per_mm: f32,
) -> NonLocalTerms {
    var terms: NonLocalTerms;
    terms.visibility = vec3<f32>(1.0);
    terms.transmission = vec3<f32>(0.0);
    if SHADOWS || TRANSMISSION {
        terms = non_local_terms(index, world_position, normal, curvature_per_mm);
    }
    if gathers_subsurface() {
        let shape = local_shape(
            light_frame_point(index, world_position),
            light_frame_vector(index, normal),
            curvature_per_mm,
        );
        terms.transmission = subsurface_gather(index, shape);
        let v = terms.visibility;
        if SHADOWS && any(v < vec3<f32>(1.0)) {
            let to_light = light_incidence(frame.lights[index], world_position).to_light;
            let gain = subsurface_gain_value(light_curvature_per_mm, angle(dot(normal, to_light)));
            terms.transmission *= v + (vec3<f32>(1.0) - v) * gain;
        }
    }
    return terms;
}

// The per-vertex terms of shadowed light `index`, interpolated.
fn vertex_terms(in: VertexOut, index: u32) -> NonLocalTerms {
    var terms: NonLocalTerms;
    switch index {
        case 0u: {
            terms.visibility = in.visibility_0.xyz;
            terms.transmission = in.transmission_0;
        }
        case 1u: {
            terms.visibility = in.visibility_1.xyz;
            terms.transmission = in.transmission_1;
        }
        case 2u: {
            terms.visibility = in.visibility_2.xyz;
            terms.transmission = in.transmission_2;
        }
        default: {
            terms.visibility = in.visibility_3.xyz;
            terms.transmission = in.transmission_3;
        }
    }
    return terms;
}

// Texture coordinate of a value on a uniform axis over [0, extent] with `count` texels whose
// centres sit on the axis nodes (node 0 at 0, the last at `extent`); clamped to the end nodes.
fn node_coordinate(value: f32, extent: f32, count: f32) -> f32 {
    return clamp(value / extent, 0.0, 1.0) * (count - 1.0);
}

// Bilinear read of `texture` at continuous node coordinates (column, row).
fn read_bilinear(texture: texture_2d<f32>, column: f32, row: f32, size: vec2<f32>) -> vec3<f32> {
    if MANUAL_FILTERING {
        let last = vec2<i32>(size) - vec2<i32>(1);
        let base = vec2<i32>(floor(vec2<f32>(column, row)));
        let t = vec2<f32>(column, row) - vec2<f32>(base);
        let p00 = clamp(base, vec2<i32>(0), last);
        let p11 = clamp(base + vec2<i32>(1), vec2<i32>(0), last);
        let a = textureLoad(texture, p00, 0).rgb;
        let b = textureLoad(texture, vec2<i32>(p11.x, p00.y), 0).rgb;
        let c = textureLoad(texture, vec2<i32>(p00.x, p11.y), 0).rgb;
        let d = textureLoad(texture, p11, 0).rgb;
        return mix(mix(a, b, t.x), mix(c, d, t.x), t.y);
    }
    let uv = (vec2<f32>(column, row) + 0.5) / size;
    return textureSampleLevel(texture, lut_sampler, uv, 0.0).rgb;
}

// f(κ, θ) from the LUT: θ across (columns over [0, π]), κ down (rows over the curvature axis,
// clamped to its ends).
fn lut_value(curvature_per_mm: f32, theta: f32) -> vec3<f32> {
    let at = lut_coordinates(curvature_per_mm, theta);
    return read_bilinear(lut, at.x, at.y, material.lut_size);
}

// Node coordinates (column, row) of (κ, θ) on the LUT's axes, as lut_value reads them.
fn lut_coordinates(curvature_per_mm: f32, theta: f32) -> vec2<f32> {
    let kappa = material.lut_curvature_per_mm;
    let size = material.lut_size;
    var row = 0.0;
    if size.y > 1.0 && kappa.y > kappa.x {
        row = clamp((curvature_per_mm - kappa.x) / (kappa.y - kappa.x), 0.0, 1.0) * (size.y - 1.0);
    }
    return vec2<f32>(node_coordinate(theta, PI, size.x), row);
}

// g(κ, θ, φ): φ across (columns over [0, π/2]), θ down (rows over [0, π]) in each curvature
// layer, the layers stacked down the texture; bilinear within the two layers around κ, linear
// between them.
fn view_value(curvature_per_mm: f32, theta: f32, phi: f32) -> vec3<f32> {
    let size = material.view_size;
    let layers = material.view_layers;
    let texture_size = vec2<f32>(size.x, size.y * layers);
    let column = node_coordinate(phi, FRAC_PI_2, size.x);
    let row = node_coordinate(theta, PI, size.y);
    let kappa = material.view_curvature_per_mm;
    var layer = 0.0;
    if layers > 1.0 && kappa.y > kappa.x {
        layer = clamp((curvature_per_mm - kappa.x) / (kappa.y - kappa.x), 0.0, 1.0)
            * (layers - 1.0);
    }
    let below = floor(layer);
    let above = min(below + 1.0, layers - 1.0);
    let a = read_bilinear(view_correction, column, below * size.y + row, texture_size);
    let b = read_bilinear(view_correction, column, above * size.y + row, texture_size);
    return mix(a, b, layer - below);
}

// (cos⁺ ⊛ g_s)(θ) for θ ∈ [0, π]: the clamped cosine blurred by a wrapped Gaussian of angular
// standard deviation s. The same two forms as cdrf-core's `convolved_clamped_cosine` (Fourier
// series for s ≥ 0.25, terminator correction with 16-point Gauss–Legendre below), in f32.
fn convolved_clamped_cosine(theta: f32, s: f32) -> f32 {
    if s <= 0.0 {
        return max(cos(theta), 0.0);
    }
    if s >= 0.25 {
        let q = s * s;
        let cos_2theta = cos(2.0 * theta);
        var cos_prev = 1.0;
        var cos_k = cos_2theta;
        let step = exp(-4.0 * q);
        var ratio = exp(-6.0 * q);
        var damping = exp(-2.0 * q);
        var series = 0.0;
        var sign = 1.0;
        for (var k = 1; k < 32; k++) {
            let kf = f32(k);
            let magnitude = damping / (4.0 * kf * kf - 1.0);
            if magnitude < 1e-8 {
                break;
            }
            series += sign * magnitude * cos_k;
            sign = -sign;
            let next = 2.0 * cos_2theta * cos_k - cos_prev;
            cos_prev = cos_k;
            cos_k = next;
            damping *= ratio;
            ratio *= step;
        }
        return FRAC_1_PI + 0.5 * exp(-0.5 * q) * cos(theta) + FRAC_2_PI * series;
    }
    // Local form: the kernel offset t = s·u is lit iff t > θ − π/2; the Gaussian is cut at 6s.
    let u_terminator = (theta - FRAC_PI_2) / s;
    if u_terminator >= 6.0 {
        return 0.0;
    }
    let full = exp(-0.5 * s * s) * cos(theta);
    if u_terminator <= -6.0 {
        return full;
    }
    let lit_side = u_terminator <= 0.0;
    var a = u_terminator;
    var sign = 1.0;
    if lit_side {
        a = -u_terminator;
        sign = -1.0;
    }
    let tail = half_gaussian_tail(theta, s, a, sign);
    if lit_side {
        return full - tail;
    }
    return tail;
}

// ∫_a^6 cos(θ ∓ s·u)·φ(u) du (φ the standard normal density), 16-point Gauss–Legendre.
fn half_gaussian_tail(theta: f32, s: f32, a: f32, sign: f32) -> f32 {
    var nodes = array<vec2<f32>, 8>(
        vec2<f32>(0.0950125098376374, 0.189450610455068),
        vec2<f32>(0.281603550779259, 0.182603415044924),
        vec2<f32>(0.458016777657227, 0.169156519395003),
        vec2<f32>(0.617876244402644, 0.149595988816577),
        vec2<f32>(0.755404408355003, 0.124628971255534),
        vec2<f32>(0.865631202387832, 0.0951585116824929),
        vec2<f32>(0.944575023073233, 0.0622535239386478),
        vec2<f32>(0.98940093499165, 0.0271524594117541),
    );
    let mid = 0.5 * (a + 6.0);
    let half_width = 0.5 * (6.0 - a);
    let sin_theta = sin(theta);
    let cos_theta = cos(theta);
    var sum = 0.0;
    for (var i = 0; i < 8; i++) {
        let node = nodes[i];
        for (var side = -1.0; side <= 1.0; side += 2.0) {
            let u = mid + side * half_width * node.x;
            let su = s * u;
            let value = (cos_theta * cos(su) + sign * sin_theta * sin(su)) * exp(-0.5 * u * u);
            sum += node.y * half_width * value;
        }
    }
    return sum * FRAC_1_SQRT_TAU;
}

fn gaussian_analytic(curvature_per_mm: f32, theta: f32) -> vec3<f32> {
    let kappa = max(curvature_per_mm, 0.0);
    let s = material.sigma_mm * kappa;
    let f = vec3<f32>(
        convolved_clamped_cosine(theta, s.x),
        convolved_clamped_cosine(theta, s.y),
        convolved_clamped_cosine(theta, s.z),
    );
    return material.albedo_or_scale * f;
}

// A diverging colour map (Moreland's cool–warm ends) over [0, 1], in linear RGB.
fn cool_warm(t: f32) -> vec3<f32> {
    let cool = vec3<f32>(0.230, 0.299, 0.754);
    let middle = vec3<f32>(0.865, 0.865, 0.865);
    let warm = vec3<f32>(0.706, 0.016, 0.150);
    let x = clamp(t, 0.0, 1.0);
    var srgb: vec3<f32>;
    if x < 0.5 {
        srgb = mix(cool, middle, x * 2.0);
    } else {
        srgb = mix(middle, warm, x * 2.0 - 1.0);
    }
    return srgb_to_linear(srgb);
}

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let low = c / 12.92;
    let high = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(high, low, c <= vec3<f32>(0.04045));
}

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let x = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    let low = x * 12.92;
    let high = 1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(high, low, x <= vec3<f32>(0.0031308));
}

// Angle in [0, π] from its cosine: Abramowitz & Stegun 4.4.45, |error| ≤ 6.8e-5 rad (0.004°,
// a hundredth of a LUT column), cheaper than acos on software rasterisers.
fn angle(cosine: f32) -> f32 {
    let x = clamp(cosine, -1.0, 1.0);
    let a = abs(x);
    let r = sqrt(1.0 - a) * (1.5707288 + a * (-0.2121144 + a * (0.0742610 - 0.0187293 * a)));
    return select(r, PI - r, x < 0.0);
}

struct NonLocalTerms {
    // Share of the light the CDRF term keeps, per channel.
    visibility: vec3<f32>,
    // Light through material the CDRF does not see, π·L/E.
    transmission: vec3<f32>,
}

// T(d, μ): light through `thickness_mm` of material that entered it at the cosine
// `entry_cosine` to the surface.
fn transmission_profile(thickness_mm: f32, entry_cosine: f32) -> vec3<f32> {
    return material.transmission_amplitude * entry_factor(entry_cosine)
        * exp(-max(thickness_mm, 0.0) / material.transmission_length_mm);
}

// μ^p of T(d, μ) (p = 0: 1).
fn entry_factor(entry_cosine: f32) -> f32 {
    if material.transmission_entry_cosine_power > 0.0 {
        return pow(clamp(entry_cosine, 1e-6, 1.0), material.transmission_entry_cosine_power);
    }
    return 1.0;
}

// Depth (0–1) of map layer `layer` at `texel + step`, clamped to the map.
fn neighbour_depth(layer: u32, texel: vec2<i32>, step: vec2<i32>) -> f32 {
    let last = vec2<i32>(i32(shadows.resolution) - 1);
    return textureLoad(shadow_maps, clamp(texel + step, vec2<i32>(0), last), i32(layer), 0);
}

// Cosine between the light and the first surface it meets in column `texel` of map layer
// `layer`, from the map's depth slope (the gentler one-sided difference per axis, so a depth
// jump at a silhouette does not count as slope); `texel_mm` the texel's width there.
fn entry_cosine(layer: u32, texel: vec2<i32>, texel_mm: f32, depth_range_mm: f32) -> f32 {
    let here = textureLoad(shadow_maps, texel, i32(layer), 0);
    let left = neighbour_depth(layer, texel, vec2<i32>(-1, 0));
    let right = neighbour_depth(layer, texel, vec2<i32>(1, 0));
    let down = neighbour_depth(layer, texel, vec2<i32>(0, -1));
    let up = neighbour_depth(layer, texel, vec2<i32>(0, 1));
    var dx = right - here;
    if abs(here - left) < abs(dx) {
        dx = here - left;
    }
    var dy = up - here;
    if abs(here - down) < abs(dy) {
        dy = here - down;
    }
    let slope = vec2<f32>(dx, dy) * depth_range_mm / texel_mm;
    return inverseSqrt(1.0 + dot(slope, slope));
}

// The point and its local shape in light space (mm): the osculating sphere of radius 1/κ
// (or, for flat and concave points, the tangent plane).
struct LocalShape {
    point: vec3<f32>,
    normal: vec3<f32>,
    curved: bool,
    radius_mm: f32,
    centre: vec3<f32>,
    // The tangent plane's axes (the tap footprint lies on the surface, not across the light:
    // at grazing light a step along the surface moves little across the light).
    tangent: vec3<f32>,
    bitangent: vec3<f32>,
}

fn local_shape(point: vec3<f32>, normal: vec3<f32>, curvature_per_mm: f32) -> LocalShape {
    var shape: LocalShape;
    shape.point = point;
    shape.normal = normal;
    shape.curved = curvature_per_mm > 1e-3;
    shape.radius_mm = 1.0 / max(curvature_per_mm, 1e-3);
    shape.centre = point - normal * shape.radius_mm;
    var helper = vec3<f32>(0.0, 0.0, 1.0);
    if abs(normal.z) > 0.9 {
        helper = vec3<f32>(1.0, 0.0, 0.0);
    }
    shape.tangent = normalize(cross(helper, normal));
    shape.bitangent = cross(normal, shape.tangent);
    return shape;
}

// A tap of the spiral moved onto the local shape: where it lies and which way it faces.
struct Tap {
    surface: vec3<f32>,
    facing: vec3<f32>,
    // Distance from the point on the tangent plane, mm.
    radius_mm: f32,
}

// Tap k of a Vogel spiral over the disc of radius `disc_mm` on the tangent plane (tap 0 at the
// centre), moved onto the local shape.
fn spiral_tap(shape: LocalShape, k: u32, disc_mm: f32) -> Tap {
    var tap: Tap;
    tap.radius_mm = disc_mm * sqrt(f32(k) / f32(PENUMBRA_TAPS));
    let angle = f32(k) * GOLDEN_ANGLE;
    tap.surface = shape.point
        + tap.radius_mm * (cos(angle) * shape.tangent + sin(angle) * shape.bitangent);
    tap.facing = shape.normal;
    if shape.curved {
        tap.facing = normalize(tap.surface - shape.centre);
        tap.surface = shape.centre + shape.radius_mm * tap.facing;
    }
    return tap;
}

// The frame the non-local terms of shadowed light `index` work in (mm): an orthographic light's
// light space (x, y across the light, z along it), or world axes about a point or spot light.
fn light_frame_point(index: u32, world_position: vec3<f32>) -> vec3<f32> {
    let light = &shadows.lights[index];
    if (*light).projection == SHADOW_ORTHOGRAPHIC {
        return ((*light).light_from_world[0] * vec4<f32>(world_position, 1.0)).xyz
            * shadows.mm_per_world_unit;
    }
    return (world_position - (*light).position) * shadows.mm_per_world_unit;
}

fn light_frame_vector(index: u32, v: vec3<f32>) -> vec3<f32> {
    if shadows.lights[index].projection == SHADOW_ORTHOGRAPHIC {
        return (shadows.lights[index].light_from_world[0] * vec4<f32>(v, 0.0)).xyz;
    }
    return v;
}

// The unit vector along light `index`'s rays at frame point q, away from the light.
fn light_ray(index: u32, q: vec3<f32>) -> vec3<f32> {
    if shadows.lights[index].projection == SHADOW_ORTHOGRAPHIC {
        return vec3<f32>(0.0, 0.0, 1.0);
    }
    return q / max(length(q), 1e-6);
}

// Depth of frame point q as light `index`'s map stores it (mm): along z (orthographic) or
// from the light (perspective).
fn light_depth(index: u32, q: vec3<f32>) -> f32 {
    if shadows.lights[index].projection == SHADOW_ORTHOGRAPHIC {
        return q.z;
    }
    return length(q);
}

// The width of one shadow map texel across the light at frame point q (mm).
fn texel_width_mm(index: u32, q: vec3<f32>) -> f32 {
    return texel_width_of(index, q, shadows.resolution);
}

// The same for a map of `resolution` texels per side.
fn texel_width_of(index: u32, q: vec3<f32>, resolution: u32) -> f32 {
    let light = &shadows.lights[index];
    var half_width_mm = (*light).half_extent * shadows.mm_per_world_unit;
    if (*light).projection != SHADOW_ORTHOGRAPHIC {
        half_width_mm = (*light).half_extent * light_depth(index, q);
    }
    return 2.0 * half_width_mm / f32(resolution);
}

// Frame point q (mm) in face `face` of light `index`: x, y across it, z along its axis (an
// orthographic light's frame is its face already).
fn light_face_point(index: u32, face: u32, q: vec3<f32>) -> vec3<f32> {
    if shadows.lights[index].projection == SHADOW_ORTHOGRAPHIC {
        return q;
    }
    return (shadows.lights[index].light_from_world[face] * vec4<f32>(q, 0.0)).xyz;
}

// The map coordinates (0–1 across the map, v down) of face point `local` of light `index`;
// a perspective face's only for local.z > 0 (in front of the light).
fn face_uv(index: u32, local: vec3<f32>) -> vec2<f32> {
    let light = &shadows.lights[index];
    var across = local.xy / ((*light).half_extent * shadows.mm_per_world_unit);
    if (*light).projection != SHADOW_ORTHOGRAPHIC {
        across = local.xy / (local.z * (*light).half_extent);
    }
    return vec2<f32>(0.5, 0.5) + vec2<f32>(0.5, -0.5) * across;
}

// The area the light sees of one texel of a `resolution`-texel map of light `index` at frame
// point q on face `face`, per unit of the light's irradiance_or_intensity, so that
// times it is the flux entering the first surface in that texel: orthographic, the texel's
// side squared (mm²); perspective, its solid angle (sr) times a spot's falloff (the flux
// through a solid angle ω is intensity · ω whatever the distance).
fn texel_light_area(index: u32, face: u32, q: vec3<f32>, resolution: u32) -> f32 {
    let light = &shadows.lights[index];
    if (*light).projection == SHADOW_ORTHOGRAPHIC {
        let side_mm = 2.0 * (*light).half_extent * shadows.mm_per_world_unit / f32(resolution);
        return side_mm * side_mm;
    }
    let local = light_face_point(index, face, q);
    let distance_mm = max(length(q), 1e-6);
    // A texel of side a on the plane z = 1 at angle γ off the axis: ω = a² cos³ γ.
    let side = 2.0 * (*light).half_extent / f32(resolution);
    let cosine = max(local.z, 0.0) / distance_mm;
    return side * side * cosine * cosine * cosine
        * spot_falloff(frame.lights[index], -q / distance_mm);
}

// The depth (mm) of the first surface the local shape puts in the tap's column: the tap itself
// where it faces the light, else the near end of the shape's chord through it; −∞ (−1e30) for
// a plane facing away (no surface in front of it). `along`: the cosine between the tap's
// facing and the light's ray there.
fn expected_first_surface(shape: LocalShape, tap: Tap, depth_mm: f32, along: f32) -> f32 {
    if along > 0.0 {
        if shape.curved {
            return depth_mm - 2.0 * shape.radius_mm * along;
        }
        return -1e30;
    }
    return depth_mm;
}

// Allowed mismatch between the map and the local shape (mm): the bias, plus (half a texel across
// the light, and the shape's sag if its principal curvatures differ from the mean by up to
// CURVATURE_ALLOWANCE) turned into depth by the surface's slope — at most σ + 4 texels, so
// grazing light still sees occluders farther away than the penumbra is wide.
fn column_tolerance(
    tap: Tap,
    ray: vec3<f32>,
    curvature_per_mm: f32,
    texel_mm: f32,
    sigma_max_mm: f32,
) -> f32 {
    let sag = 0.5 * tap.radius_mm * tap.radius_mm
        * (abs(curvature_per_mm) + CURVATURE_ALLOWANCE_PER_MM);
    let along = dot(tap.facing, ray);
    let across = 0.5 * texel_mm * length(tap.facing - along * ray) + sag;
    return shadows.depth_bias_mm
        + min(across / max(abs(along), 1e-3), sigma_max_mm + 4.0 * texel_mm);
}

// The texel and layer of light `index`'s map under frame point q and the depth (mm) of the
// first surface stored there (the far plane outside the map).
struct Column {
    texel: vec2<i32>,
    layer: u32,
    first_surface_mm: f32,
}

fn shadow_column(index: u32, q: vec3<f32>) -> Column {
    let light = &shadows.lights[index];
    let resolution = f32(shadows.resolution);
    let depth_range_mm = (*light).depth_range * shadows.mm_per_world_unit;
    var column: Column;
    column.layer = (*light).first_layer;
    column.first_surface_mm = depth_range_mm;
    // A cube's face: the axis the ray is nearest (faces +x, −x, +y, −y, +z, −z).
    var face = 0u;
    if (*light).face_count == 6u {
        let a = abs(q);
        if a.x >= a.y && a.x >= a.z {
            face = select(1u, 0u, q.x >= 0.0);
        } else if a.y >= a.z {
            face = select(3u, 2u, q.y >= 0.0);
        } else {
            face = select(5u, 4u, q.z >= 0.0);
        }
    }
    column.layer += face;
    let local = light_face_point(index, face, q);
    if (*light).projection != SHADOW_ORTHOGRAPHIC && local.z <= 0.0 {
        column.texel = vec2<i32>(-1);
        return column;
    }
    column.texel = vec2<i32>(floor(face_uv(index, local) * resolution));
    if all(column.texel >= vec2<i32>(0)) && all(column.texel < vec2<i32>(i32(resolution))) {
        column.first_surface_mm = textureLoad(shadow_maps, column.texel, i32(column.layer), 0)
            * depth_range_mm;
    }
    return column;
}

// See the header: compare the shadow map of light `index` around the point with the osculating
// sphere (or tangent plane) of the point. Directional lights' maps are orthographic; point and
// spot lights' perspective, their columns the rays from the light and depths the distances
// from it.
fn non_local_terms(
    index: u32,
    world_position: vec3<f32>,
    normal: vec3<f32>,
    curvature_per_mm: f32,
) -> NonLocalTerms {
    let depth_range_mm = shadows.lights[index].depth_range * shadows.mm_per_world_unit;
    let shape = local_shape(
        light_frame_point(index, world_position),
        light_frame_vector(index, normal),
        curvature_per_mm,
    );
    let p = shape.point;
    let n = shape.normal;
    let p_depth = light_depth(index, p);
    let n_along = dot(n, light_ray(index, p));
    let texel_mm = texel_width_mm(index, p);
    let sigma = material.scattering_length_mm;
    let sigma_max = max(sigma.x, max(sigma.y, sigma.z));
    // T(d, μ), unless the subsurface gather brings that light instead (vertex_non_local).
    let gathers = gathers_subsurface();
    let transmits = TRANSMISSION && !gathers;
    // The penumbra's width: the light the CDRF spreads under a shadow's edge reaches about σ;
    // with the subsurface gather the table keeps only its near field, which reaches about the
    // cut ℓ_c (the gather brings the rest from the lit surface that is there).
    var penumbra_mm = sigma_max;
    if gathers {
        penumbra_mm = material.subsurface_cut_mm;
    }
    var taps = 1u;
    if penumbra_mm > texel_mm {
        taps = PENUMBRA_TAPS;
    }
    // The same spiral at every point (no per-point rotation) and every tap read: the result
    // is a continuous function of the point up to the taps' texel steps, so interpolating it
    // between vertices cannot blotch; PENUMBRA_TAPS is large enough that its steps do not band.
    var unoccluded = vec3<f32>(0.0);
    var weights = vec3<f32>(0.0);
    // Occluded columns (counted − lit of them): their weight, and their summed distance through
    // the occluder.
    var through_weight = vec3<f32>(0.0);
    var through_mm = 0.0;
    // The first occluded column (its entry cosine is read after the loop), and whether the
    // centre column shows a part thinner than the local shape (read after the loop too).
    // Nothing that reads the map beyond a tap's own texel stays inside the loop: lavapipe runs
    // a branch's code for every tap even where no invocation takes it (the centre's and the
    // first occluded column's slope reads, inside the loop, were two thirds of every term's
    // tap cost on the bunny).
    var first_occluded = Column(vec2<i32>(-1), 0u, 0.0);
    var centre_column = Column(vec2<i32>(-1), 0u, 0.0);
    var centre_lit = false;
    var centre_expected_mm = 0.0;
    var centre_tolerance_mm = 0.0;
    var counted = 0u;
    var lit = 0u;
    // Every tap is read: skipping the rest where a few probes agree made neighbouring vertices
    // jump between "fully lit / occluded" and the full average (hard, jagged shadow edges).
    for (var k = 0u; k < taps; k++) {
        let tap = spiral_tap(shape, k, 2.0 * penumbra_mm);
        let ray = light_ray(index, tap.surface);
        let tap_depth = light_depth(index, tap.surface);
        let expected = expected_first_surface(shape, tap, tap_depth, dot(tap.facing, ray));
        let column = shadow_column(index, tap.surface);
        let occluder = column.first_surface_mm;
        let tolerance = column_tolerance(tap, ray, curvature_per_mm, texel_mm, sigma_max);
        // No surface where the local shape puts one (the tangent plane reaching over a hole or
        // past an edge): this column says nothing about the light near the point.
        if k > 0u && expected > -1e29 && occluder > expected + tolerance {
            continue;
        }
        // Gaussian weight of the tap per channel (σ per channel), precomputed per material;
        // with the gather, one width for every channel: the taps reach 2ℓ_c, so tap k's weight
        // is exp(−2k / PENUMBRA_TAPS). (64 taps over ℓ_c cost 1–2 ms less on the bunny on
        // lavapipe and moved no compare figure, but painted the torus's grazing-lit rim with
        // brighter blobs.)
        var weight = vec3<f32>(1.0);
        if taps > 1u {
            if gathers {
                weight = vec3<f32>(exp(-2.0 * f32(k) / f32(PENUMBRA_TAPS)));
            } else {
                weight = material.penumbra_taps[k].weight;
            }
        }
        weights += weight;
        counted += 1u;
        if occluder < expected - tolerance {
            through_weight += weight;
            through_mm += tap_depth - occluder;
            if counted == lit + 1u {
                first_occluded = column;
            }
        } else {
            unoccluded += weight;
            lit += 1u;
            if k == 0u {
                centre_lit = true;
                centre_column = column;
                centre_expected_mm = expected;
                centre_tolerance_mm = tolerance;
            }
        }
    }
    var terms: NonLocalTerms;
    terms.visibility = unoccluded / weights;
    terms.transmission = vec3<f32>(0.0);
    if transmits && centre_lit && n_along > 0.0 {
        terms.transmission = smoothstep(0.0, THIN_PART_FADE_END, n_along)
            * thin_part_transmission(
                centre_column.layer,
                centre_column.texel,
                p_depth - centre_column.first_surface_mm,
                p_depth - centre_expected_mm - centre_tolerance_mm,
                texel_mm,
                depth_range_mm,
            );
    }
    if SHADOWS && transmits && counted > lit {
        // Light through the occluders, at their mean thickness and at the entry cosine of the
        // first occluded column (one T per light; read at every occluded column instead, the
        // torus's errors against path tracing moved by ≤ 1.6 points: cast shadow 111.5 %
        // instead of 109.9 %).
        let occluded = f32(counted - lit);
        let entry = entry_cosine(
            first_occluded.layer,
            first_occluded.texel,
            texel_mm,
            depth_range_mm,
        );
        terms.transmission += through_weight / weights
            * transmission_profile(through_mm / occluded, entry);
    }
    return terms;
}

// Light through a part thinner than the local shape by more than the tolerance: T at the
// thickness the map shows minus T at the thickness the shape predicts, both at the entry cosine
// the map shows, so on the sphere itself the difference vanishes whatever the error of the
// slope estimate (read only where it is needed).
fn thin_part_transmission(
    layer: u32,
    texel: vec2<i32>,
    thickness_mm: f32,
    expected_thickness_mm: f32,
    texel_mm: f32,
    depth_range_mm: f32,
) -> vec3<f32> {
    let thin = max(
        transmission_profile(thickness_mm, 1.0) - transmission_profile(expected_thickness_mm, 1.0),
        vec3<f32>(0.0),
    );
    if any(thin > vec3<f32>(0.0)) {
        return thin * entry_factor(entry_cosine(layer, texel, texel_mm, depth_range_mm));
    }
    return thin;
}

// The per-pixel normal: the interpolated one, bent by the surface's normal map (its texel
// `encoded`) where the draw has one and its mesh has tangents (glTF's convention:
// B = cross(N, T) · w).
fn shading_normal(in: VertexOut, encoded: vec3<f32>) -> vec3<f32> {
    let normal = normalize(in.world_normal);
    if (draw.surface_flags & SURFACE_NORMAL_MAP) == 0u || abs(in.world_tangent.w) < 0.5 {
        return normal;
    }
    let t = in.world_tangent.xyz - normal * dot(normal, in.world_tangent.xyz);
    if dot(t, t) < 1e-12 {
        return normal;
    }
    let tangent = normalize(t);
    let bitangent = cross(normal, tangent) * sign(in.world_tangent.w);
    let m = (encoded * 2.0 - 1.0) * vec3<f32>(draw.normal_scale, draw.normal_scale, 1.0);
    return normalize(tangent * m.x + bitangent * m.y + normal * m.z);
}

// The specular layer's Beckmann α at this pixel: the surface's (roughness², `texel` its
// roughness texture's G) or the material's.
fn specular_alpha(texel: f32) -> f32 {
    if (draw.surface_flags & SURFACE_ROUGHNESS) == 0u {
        return material.specular_roughness_alpha;
    }
    let roughness = draw.roughness_factor * texel;
    // (Beckmann's D is singular at α = 0: a mirror is α = 0.01 here.)
    return max(roughness * roughness, 0.01);
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    // (Every texture sampled before any branch: implicit derivatives need uniform control
    // flow.)
    let tint = draw.base_color_factor
        * textureSample(base_color_texture, base_color_sampler, in.uv).rgb;
    let normal = shading_normal(in, textureSample(normal_texture, normal_sampler, in.uv).xyz);
    let alpha = specular_alpha(textureSample(roughness_texture, roughness_sampler, in.uv).g);
    var radiance = vec3<f32>(0.0);
    if MODEL == MODEL_CURVATURE {
        let range = material.curvature_range_per_mm;
        radiance = cool_warm((in.curvature_per_mm - range.x) / max(range.y - range.x, 1e-12));
    } else {
        let to_camera = to_camera_from(in.world_position);
        let phi = angle(dot(normal, to_camera));
        let light_count = min(frame.light_count, MAX_LIGHTS);
        // The first surface's reflection, added after the subsurface light is scaled by what
        // the boundary lets through.
        var specular = vec3<f32>(0.0);
        for (var i = 0u; i < light_count; i++) {
            let incidence = light_incidence(frame.lights[i], in.world_position);
            let cos_theta = dot(normal, incidence.to_light);
            let theta = angle(cos_theta);
            let curvature_per_mm = light_curvature_per_mm(in, i);
            var terms: NonLocalTerms;
            terms.visibility = vec3<f32>(1.0);
            terms.transmission = vec3<f32>(0.0);
            if (SHADOWS || TRANSMISSION || SUBSURFACE) && i < shadows.light_count {
                if MODEL == MODEL_LAMBERT {
                    terms = non_local_terms(i, in.world_position, normal, in.curvature_per_mm);
                } else {
                    terms = vertex_terms(in, i);
                }
            }
            let share = light_share(i, incidence, cos_theta, theta, curvature_per_mm, terms);
            var reflected = share.reflected;
            if MODEL != MODEL_LAMBERT {
                reflected *= view_value(curvature_per_mm, theta, phi);
            }
            radiance += FRAC_1_PI * reflected;
            if material.specular_on != 0u {
                specular += incidence.irradiance * share.visibility
                    * specular_radiance(normal, incidence.to_light, to_camera, alpha);
            }
        }
        radiance += in.vertex_radiance;
        radiance = (radiance * material.subsurface_transmission * tint + specular)
            * frame.exposure;
    }
    if ENCODE_SRGB {
        radiance = linear_to_srgb(radiance);
    }
    return vec4<f32>(radiance, 1.0);
}

// What light `index` gives a point, before the view correction: π·L/E times the light (the
// exitance the point would have if the light left it evenly), and the share V of it the
// shadows let through (1 without). `terms`: the light's non-local terms at the point
// (visibility 1 and no transmission where it has none).
struct LightShare {
    reflected: vec3<f32>,
    visibility: vec3<f32>,
}

fn light_share(
    index: u32,
    incidence: Incidence,
    cos_theta: f32,
    theta: f32,
    curvature_per_mm: f32,
    terms: NonLocalTerms,
) -> LightShare {
    let shadowed = (SHADOWS || TRANSMISSION || SUBSURFACE) && index < shadows.light_count;
    var f: vec3<f32>;
    if SUBSURFACE && (MODEL == MODEL_MEASURED || MODEL == MODEL_GAUSSIAN_LUT) {
        // With the gather on this light, without the far field the table holds through the
        // osculating sphere (the gather brings it from the surface that is there). One read
        // either way: in a branch lavapipe paid for both reads (every term 114 → 101 ms on the
        // bunny at 1024²).
        f = table_value(curvature_per_mm, theta, shadowed && gathers_subsurface());
    } else {
        f = local_value(curvature_per_mm, cos_theta, theta);
    }
    var share: LightShare;
    share.visibility = vec3<f32>(1.0);
    // The light through material the table does not see: T(d, μ) in π·L/E (times the
    // irradiance here), or the gather's G (times the light's irradiance or intensity: the
    // light entered elsewhere, where the irradiance is not this point's).
    var through = vec3<f32>(0.0);
    var through_scale = incidence.irradiance;
    if shadowed {
        if gathers_subsurface() {
            through_scale = frame.lights[index].irradiance_or_intensity;
        }
        if SHADOWS {
            f *= terms.visibility;
            share.visibility = terms.visibility;
        }
        through = terms.transmission;
    }
    share.reflected = max(incidence.irradiance * f + through_scale * through, vec3<f32>(0.0));
    return share;
}

// The material's zonal coefficients a_l(κ), l = 0 … ENVIRONMENT_SH_ORDER (its environment
// table, rows uniform in κ, interpolated linearly).
fn zonal_row(curvature_per_mm: f32) -> array<vec3<f32>, ENVIRONMENT_SH_BANDS> {
    let range = material.environment_curvature_per_mm;
    var t = 0.0;
    if range.y > range.x {
        t = clamp((curvature_per_mm - range.x) / (range.y - range.x), 0.0, 1.0)
            * f32(ENVIRONMENT_ZONAL_ROWS - 1u);
    }
    let row0 = min(u32(t), ENVIRONMENT_ZONAL_ROWS - 1u);
    let row1 = min(row0 + 1u, ENVIRONMENT_ZONAL_ROWS - 1u);
    let w = t - f32(row0);
    var a: array<vec3<f32>, ENVIRONMENT_SH_BANDS>;
    for (var l = 0u; l < ENVIRONMENT_SH_BANDS; l++) {
        a[l] = mix(
            material.environment_zonal[row0 * ENVIRONMENT_SH_BANDS + l].xyz,
            material.environment_zonal[row1 * ENVIRONMENT_SH_BANDS + l].xyz,
            w,
        );
    }
    return a;
}

// The CDRF's answer to light from one direction as its zonal expansion: f(κ, θ) =
// π Σ_l (2l + 1)/(4π) · a_l(κ) · P_l(cos θ) (Funk–Hecke: a_l are the coefficients of f/π), up to
// ENVIRONMENT_SH_ORDER. Per receiver its coefficients (zonal_response), per direction a
// Legendre recurrence (zonal_value): no texture read.
fn zonal_response(curvature_per_mm: f32) -> array<vec3<f32>, ENVIRONMENT_SH_BANDS> {
    var b = zonal_row(curvature_per_mm);
    for (var l = 0u; l < ENVIRONMENT_SH_BANDS; l++) {
        b[l] *= 0.25 * f32(2u * l + 1u);
    }
    return b;
}

fn zonal_value(b: array<vec3<f32>, ENVIRONMENT_SH_BANDS>, cos_theta: f32) -> vec3<f32> {
    var p_previous = 1.0;
    var p = cos_theta;
    var value = b[0] + b[1] * cos_theta;
    for (var l = 2u; l < ENVIRONMENT_SH_BANDS; l++) {
        let next = (f32(2u * l - 1u) * cos_theta * p - f32(l - 1u) * p_previous) / f32(l);
        p_previous = p;
        p = next;
        value += b[l] * p;
    }
    return max(value, vec3<f32>(0.0));
}

// The environment light (cdrf-core's environment::radiance_sh): Σ_l a_l(κ) Σ_m L_lm Y_lm(n),
// the real SH basis as polynomials in the normal (P̃_l^m(z) · Re/Im (x + i y)^m; the
// normalisation is in frame.environment_sh), clamped at 0 against ringing. Local: no shadows.
fn environment_radiance(normal: vec3<f32>, curvature_per_mm: f32) -> vec3<f32> {
    let bands = min(frame.environment_bands, ENVIRONMENT_SH_BANDS);
    let a = zonal_row(curvature_per_mm);
    var radiance = vec3<f32>(0.0);
    // Re and Im of (x + i y)^m, and P̃_m^m = (2m − 1)!!.
    var re = 1.0;
    var im = 0.0;
    var p_mm = 1.0;
    for (var m = 0u; m < bands; m++) {
        if m > 0u {
            let re_next = re * normal.x - im * normal.y;
            im = re * normal.y + im * normal.x;
            re = re_next;
            p_mm *= f32(2u * m - 1u);
        }
        var p_previous = 0.0;
        var p = p_mm;
        for (var l = m; l < bands; l++) {
            if l == m + 1u {
                p_previous = p;
                p = f32(2u * m + 1u) * normal.z * p_mm;
            } else if l > m + 1u {
                let next = (f32(2u * l - 1u) * normal.z * p - f32(l + m - 1u) * p_previous)
                    / f32(l - m);
                p_previous = p;
                p = next;
            }
            let centre = l * l + l;
            if m == 0u {
                radiance += a[l] * p * frame.environment_sh[centre].xyz;
            } else {
                radiance += a[l] * p * (frame.environment_sh[centre + m].xyz * re
                    + frame.environment_sh[centre - m].xyz * im);
            }
        }
    }
    return max(radiance, vec3<f32>(0.0));
}

// cdrf-core's SpecularLayer::radiance_per_irradiance: F(v·h) D(h) G₁(l) G₁(v) / (4 cos φ),
// Beckmann D, Smith G₁ in Walter et al.'s rational form, the dielectric's unpolarised Fresnel.
fn specular_radiance(
    normal: vec3<f32>,
    to_light: vec3<f32>,
    to_camera: vec3<f32>,
    alpha: f32,
) -> f32 {
    let cos_theta = dot(normal, to_light);
    let cos_phi = dot(normal, to_camera);
    let half_sum = to_light + to_camera;
    if cos_theta <= 0.0 || cos_phi <= 0.0 || dot(half_sum, half_sum) < 1e-12 {
        return 0.0;
    }
    let half = normalize(half_sum);
    let cos_half = dot(normal, half);
    if cos_half <= 0.0 {
        return 0.0;
    }
    let c2 = cos_half * cos_half;
    let a2 = alpha * alpha;
    let d = exp(-max(1.0 - c2, 0.0) / (c2 * a2)) / (PI * a2 * c2 * c2);
    let g = smith_g1(cos_theta, alpha) * smith_g1(cos_phi, alpha);
    return dielectric_fresnel(dot(to_camera, half), material.specular_ior) * d * g
        / (4.0 * cos_phi);
}

fn smith_g1(cosine: f32, alpha: f32) -> f32 {
    let tangent = sqrt(max(1.0 - cosine * cosine, 0.0)) / cosine;
    if tangent == 0.0 {
        return 1.0;
    }
    let a = 1.0 / (alpha * tangent);
    if a >= 1.6 {
        return 1.0;
    }
    return (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a);
}

fn dielectric_fresnel(cos_incident: f32, eta: f32) -> f32 {
    let c = clamp(cos_incident, 0.0, 1.0);
    let ct = sqrt(max(1.0 - (1.0 - c * c) / (eta * eta), 0.0));
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    return 0.5 * (rs * rs + rp * rp);
}

// The light arriving at a world position: cdrf-core's Light::incidence.
fn light_incidence(light: Light, world_position: vec3<f32>) -> Incidence {
    var incidence: Incidence;
    if light.kind == LIGHT_DIRECTIONAL {
        incidence.to_light = light.to_light_or_position;
        incidence.irradiance = light.irradiance_or_intensity;
        return incidence;
    }
    let offset = light.to_light_or_position - world_position;
    let d_mm = length(offset) * frame.mm_per_world_unit;
    incidence.to_light = offset / max(length(offset), 1e-30);
    incidence.irradiance = light.irradiance_or_intensity / max(d_mm * d_mm, 1e-12)
        * spot_falloff(light, incidence.to_light);
    return incidence;
}

// A spot light's cone (1 inside the inner angle, 0 outside the outer, a smoothstep in the cosine
// between) at the unit vector `to_light`; 1 for other lights.
fn spot_falloff(light: Light, to_light: vec3<f32>) -> f32 {
    if light.kind != LIGHT_SPOT {
        return 1.0;
    }
    let t = clamp(
        (dot(-to_light, light.spot_direction) - light.spot_cos_outer)
            / max(light.spot_cos_inner - light.spot_cos_outer, 1e-6),
        0.0,
        1.0,
    );
    return t * t * (3.0 - 2.0 * t);
}

// The local model's f(κ, θ) (π·L/E; the curvature view has none).
fn local_value(curvature_per_mm: f32, cos_theta: f32, theta: f32) -> vec3<f32> {
    if MODEL == MODEL_LAMBERT {
        return material.albedo_or_scale * max(cos_theta, 0.0);
    } else if MODEL == MODEL_GAUSSIAN_ANALYTIC {
        return gaussian_analytic(curvature_per_mm, theta);
    }
    return lut_value(curvature_per_mm, theta);
}

// The unit vector toward the camera from a world position.
fn to_camera_from(world_position: vec3<f32>) -> vec3<f32> {
    if frame.camera_is_point != 0u {
        return normalize(frame.to_camera - world_position);
    }
    return frame.to_camera;
}

// f(κ, θ), or its near field f − F_sphere, from lut_and_near_field (as lut_value: the row
// coordinate is clamped to its half, so filtering never mixes the two).
fn table_value(curvature_per_mm: f32, theta: f32, near_field: bool) -> vec3<f32> {
    let at = lut_coordinates(curvature_per_mm, theta);
    let rows = material.lut_size.y;
    return read_bilinear(
        lut_and_near_field,
        at.x,
        at.y + select(0.0, rows, near_field),
        vec2<f32>(material.lut_size.x, 2.0 * rows),
    );
}

// s(κ, θ) on the LUT's axes (as lut_value).
fn subsurface_gain_value(curvature_per_mm: f32, theta: f32) -> vec3<f32> {
    let at = lut_coordinates(curvature_per_mm, theta);
    return read_bilinear(subsurface_gain, at.x, at.y, material.lut_size);
}

// R_far(d) per channel, mm⁻² (0 beyond the table's reach).
fn subsurface_kernel_value(distance_mm: f32) -> vec3<f32> {
    let reach = material.subsurface_reach_mm;
    if distance_mm >= reach {
        return vec3<f32>(0.0);
    }
    let last = f32(SUBSURFACE_KERNEL_SAMPLES - 1u);
    let x = sqrt(max(distance_mm, 0.0) / reach) * last;
    let i = min(u32(x), SUBSURFACE_KERNEL_SAMPLES - 2u);
    let a = material.subsurface_kernel[i].xyz;
    let b = material.subsurface_kernel[i + 1u].xyz;
    return mix(a, b, clamp(x - f32(i), 0.0, 1.0));
}

// The share of the light level L keeps, at ρ of its texels from the point: 1 within
// SUBSURFACE_LEVEL_REACH texels, 0 beyond twice that, smooth between.
const SUBSURFACE_LEVEL_REACH: f32 = 3.0;
fn level_share(rho: f32) -> f32 {
    return 1.0 - smoothstep(SUBSURFACE_LEVEL_REACH, 2.0 * SUBSURFACE_LEVEL_REACH, rho);
}

// G at frame point p (mm) from the pyramids of light `index` (one per face), per unit of the
// light's irradiance_or_intensity (see the header).
fn subsurface_gather(index: u32, shape: LocalShape) -> vec3<f32> {
    let p = shape.point;
    var sum = vec3<f32>(0.0);
    if shadows.subsurface_levels == 0u {
        return sum;
    }
    let light = &shadows.lights[index];
    for (var face = 0u; face < (*light).face_count; face++) {
        let local = light_face_point(index, face, p);
        // Behind a perspective face the point is far from all of it: its coarsest level only.
        let in_front = (*light).projection == SHADOW_ORTHOGRAPHIC || local.z > 0.0;
        var uv = vec2<f32>(0.0);
        if in_front {
            uv = face_uv(index, local);
        }
        sum += subsurface_gather_face(index, face, shape, uv, in_front);
    }
    return sum;
}

// One face's pyramid (face `face` of light `index`), the point (its local shape) at map
// coordinates `uv` (`near`: false when it has none, and all the light counts as far): level L
// weighs its texel at ρ (its texels) from the point by level_share(ρ) − level_share(2ρ)
// (level 0: level_share(ρ); the coarsest: 1 − level_share(2ρ)), which sum to 1 at every
// distance; and each texel by the share of its light that reaches the point through the
// medium (through_medium).
fn subsurface_gather_face(
    index: u32,
    face: u32,
    shape: LocalShape,
    uv: vec2<f32>,
    near: bool,
) -> vec3<f32> {
    let layer = i32(shadows.lights[index].first_layer + face);
    let p = shape.point;
    let levels = shadows.subsurface_levels;
    // The light's projection, read once: per texel, both projections' rays and texel widths
    // are computed and one selected (lavapipe runs both sides of a branch anyway, and each
    // read of the light's fields inside the loop was a gather per invocation).
    let orthographic = shadows.lights[index].projection == SHADOW_ORTHOGRAPHIC;
    let half_extent = shadows.lights[index].half_extent;
    var sum = vec3<f32>(0.0);
    for (var level = 0u; level < levels; level++) {
        let resolution = shadows.subsurface_resolution >> level;
        let size = i32(resolution);
        // texel_width_of at this level: this times the depth (perspective) or the frame's
        // unit (orthographic).
        let texel_width_per_depth = 2.0 * half_extent / f32(resolution);
        let centre = uv * f32(size);
        let coarsest = level + 1u == levels;
        // The texels whose centres lie within 2·SUBSURFACE_LEVEL_REACH of the point along each
        // axis (any other has ρ at least that, and share 0): 4·REACH per side.
        var first = vec2<i32>(floor(centre - 2.0 * SUBSURFACE_LEVEL_REACH - 0.5)) + 1;
        var count = i32(4.0 * SUBSURFACE_LEVEL_REACH);
        if coarsest {
            first = vec2<i32>(0);
            count = size;
        } else if !near || any(first + count <= vec2<i32>(0)) || any(first >= vec2<i32>(size)) {
            // No texel of this level's window lies on the map.
            continue;
        }
        for (var dy = 0; dy < count; dy++) {
            for (var dx = 0; dx < count; dx++) {
                let texel = first + vec2<i32>(dx, dy);
                if any(texel < vec2<i32>(0)) || any(texel >= vec2<i32>(size)) {
                    continue;
                }
                var share = 1.0;
                if near {
                    let rho = length(vec2<f32>(texel) + 0.5 - centre);
                    if level > 0u {
                        share -= level_share(2.0 * rho);
                    }
                    if !coarsest {
                        share -= 1.0 - level_share(rho);
                    }
                }
                if share <= 0.0 {
                    continue;
                }
                let texel_sum = textureLoad(subsurface_pyramid, texel, layer, i32(level));
                if texel_sum.w <= 0.0 {
                    continue;
                }
                // The texel's flux at its mean position.
                let q = texel_sum.xyz / texel_sum.w;
                let distance_from_light = length(q);
                let ray = select(
                    q / max(distance_from_light, 1e-6),
                    vec3<f32>(0.0, 0.0, 1.0),
                    orthographic,
                );
                let texel_mm = texel_width_per_depth
                    * select(distance_from_light, shadows.mm_per_world_unit, orthographic);
                let tolerance = max(SUBSURFACE_AIR_TOLERANCE_MM, texel_mm);
                share *= through_medium(ray, shape, q, tolerance);
                sum += share * texel_sum.w * subsurface_kernel_value(distance(p, q));
            }
        }
    }
    return sum;
}

// How much of the light entering at frame point q reaches the point of `shape` through the
// medium: none where q lies in front of the point's local shape along q's light ray by more
// than twice `tolerance_mm` — another part, an occluder, whose light crosses the air to get
// here (the inter-reflection carries that) — all of it where it lies within `tolerance_mm`
// of the shape's first surface or behind it (the point's own part, whose surface curves
// inside its osculating sphere), smooth between. The shape's surface the light meets first in
// q's column: the sphere's near side (none where the ray misses it), or the tangent plane
// where it faces the light.
const SUBSURFACE_AIR_TOLERANCE_MM: f32 = 1.0;
// `ray`: the unit vector along the light's rays at q (light_ray).
fn through_medium(ray: vec3<f32>, shape: LocalShape, q: vec3<f32>, tolerance_mm: f32) -> f32 {
    var ahead = -1e30;
    if shape.curved {
        let v = q - shape.centre;
        let b = dot(ray, v);
        let discriminant = b * b - (dot(v, v) - shape.radius_mm * shape.radius_mm);
        if discriminant > 0.0 {
            ahead = -b - sqrt(discriminant);
        }
    } else {
        let facing = dot(ray, shape.normal);
        if facing < 0.0 {
            ahead = dot(shape.point - q, shape.normal) / facing;
        }
    }
    return 1.0 - smoothstep(tolerance_mm, 2.0 * tolerance_mm, ahead);
}

struct LightViewOut {
    @builtin(position) clip: vec4<f32>,
    // The light's frame (light_frame_point), mm, and the normal in it.
    @location(0) light_position_mm: vec3<f32>,
    @location(1) light_normal: vec3<f32>,
    @location(2) @interpolate(flat) light: u32,
    // Face of a perspective light (0 for orthographic ones).
    @location(3) @interpolate(flat) face: u32,
}

// The light-view pass (the subsurface map): the draws seen from face `face` of shadowed light
// `light` (the instance index is light · MAX_SHADOW_FACES + face), in the shadow
// map's square or frustum.
@vertex
fn vs_light_view(vertex: VertexIn, @builtin(instance_index) instance: u32) -> LightViewOut {
    let light = instance / MAX_SHADOW_FACES;
    let face = instance % MAX_SHADOW_FACES;
    let camera = shadows.lights[light];
    let world = (draw.world_from_model * vec4<f32>(vertex.position, 1.0)).xyz;
    let local = (camera.light_from_world[face] * vec4<f32>(world, 1.0)).xyz;
    var out: LightViewOut;
    if camera.projection == SHADOW_ORTHOGRAPHIC {
        out.clip = vec4<f32>(
            local.xy / camera.half_extent,
            local.z / camera.depth_range,
            1.0,
        );
    } else {
        // As the shadow pass's perspective faces: depth from 0.1 % to 100 % of the range.
        let far = camera.depth_range;
        let near = 1e-3 * far;
        out.clip = vec4<f32>(
            local.xy / camera.half_extent,
            (local.z - near) * far / (far - near),
            local.z,
        );
    }
    out.light_position_mm = light_frame_point(light, world);
    let normal = world_normal_of(vertex.normal);
    out.light_normal = light_frame_vector(light, normal);
    out.light = light;
    out.face = face;
    return out;
}

// What the light gives the first surface of a light-view pass's fragment: the cosine between
// its normal and the light, and the area the light sees of one texel of a `resolution`-texel
// map there (texel_light_area).
struct LitTexel {
    normal: vec3<f32>,
    cos_theta: f32,
    area: f32,
}

fn lit_texel(in: LightViewOut, resolution: u32) -> LitTexel {
    var texel: LitTexel;
    texel.normal = normalize(in.light_normal);
    texel.cos_theta = -dot(texel.normal, light_ray(in.light, in.light_position_mm));
    texel.area = texel_light_area(in.light, in.face, in.light_position_mm, resolution);
    return texel;
}

// The subsurface map pass: level 0 of the pyramid, Φ·position and Φ per texel (see the header).
// Materials without a diffusion profile (Lambert, the Gaussian CDRF) occlude but let no light in
// (one pipeline for every model: MODEL is not set here).
@fragment
fn fs_subsurface_map(in: LightViewOut) -> @location(0) vec4<f32> {
    if !(material.subsurface_reach_mm > 0.0) {
        return vec4<f32>(0.0);
    }
    let texel = lit_texel(in, shadows.subsurface_resolution);
    // μ at least 0.1 (a silhouette texel's surface is a guess).
    let mu = max(texel.cos_theta, 0.1);
    let flux = texel.area * pow(mu, material.subsurface_entry_cosine_power - 1.0);
    return vec4<f32>(in.light_position_mm * flux, flux);
}
