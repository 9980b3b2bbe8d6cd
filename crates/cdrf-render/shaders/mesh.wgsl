// A mesh's vertex and the draw's transforms of it: the vertex buffer's attributes, normals and
// curvature anisotropy in world space, and the curvature along a direction. Reads `draw`
// (group 2, binding 0 of every pass). See docs/shading.md.

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
