// The compute passes' view of the draw's mesh: the invocation index, and a vertex read from
// the mesh's vertex buffer as f32s (VERTEX_* offsets, generated from src/gpu_types.rs) in
// world space. Reads `terms_mesh_vertices` (group 2 of the compute passes). See
// docs/shading.md.

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
