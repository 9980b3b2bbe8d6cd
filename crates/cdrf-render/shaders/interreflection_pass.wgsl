// The inter-reflection's compute passes, after the vertex terms pass: cs_patch_emitters
// places each patch of the draw's mesh as an emitter, cs_emitter_bounce adds one bounce
// between the frame's emitters (Options::interreflection_bounces − 1 times), and
// cs_vertex_interreflection gathers them at every vertex. The passes' bind groups: 0–1 and 3
// in bindings.wgsl, their group 2 here. See docs/shading.md, "Inter-reflection".

// Group 2: the draw's transforms (dynamic offset), the mesh's vertex buffer as f32s
// (compute_mesh.wgsl), the terms of its vertices, its patches and their vertices, and the
// frame's emitters (every emitting draw's patches), read and written.
@group(2) @binding(0) var<uniform> draw: Draw;
@group(2) @binding(7) var<storage, read> terms_mesh_vertices: array<f32>;
@group(2) @binding(8) var<storage, read_write> terms_out: array<VertexTerms>;
@group(2) @binding(9) var<storage, read> patches: array<Patch>;
@group(2) @binding(10) var<storage, read> patch_members: array<PatchMember>;
@group(2) @binding(11) var<storage, read> emitters: array<Emitter>;
@group(2) @binding(12) var<storage, read_write> emitters_out: array<Emitter>;

// Each patch of the draw's mesh as an emitter of the frame (at draw.emitter_first + patch):
// placed where its vertices are this frame (area-weighted centroid and normal, the sagitta its
// farthest vertex rises above them), its exitance its vertices' area-weighted mean.
@compute @workgroup_size(COMPUTE_WORKGROUP_SIZE)
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
    var centroid = vec3<f32>(0.0);
    var summed_normal = vec3<f32>(0.0);
    for (var m = 0u; m < surface_patch.member_count; m++) {
        let member = patch_members[surface_patch.first_member + m];
        let v = mesh_vertex(member.vertex);
        direct += member.weight * terms_out[member.vertex].exitance.xyz;
        centroid += member.weight * v.world_position;
        summed_normal += member.weight * v.normal;
    }
    // A patch whose normals cancel (a deformed mesh folded onto itself) sends out nothing.
    let normal_length = length(summed_normal);
    let placed = normal_length > 1e-12;
    let normal = select(vec3<f32>(0.0, 0.0, 1.0), summed_normal / normal_length, placed);
    var sagitta = 0.0;
    for (var m = 0u; m < surface_patch.member_count; m++) {
        let member = patch_members[surface_patch.first_member + m];
        sagitta = max(sagitta, dot(normal, mesh_vertex(member.vertex).world_position - centroid));
    }
    // Model units → mm: the transform's scale (1 / curvature_scale), then the frame's unit.
    let mm_per_model_unit = frame.mm_per_world_unit / draw.curvature_scale;
    var e: Emitter;
    e.position_mm = centroid * frame.mm_per_world_unit;
    e.normal = normal;
    e.area_mm2 = select(0.0, surface_patch.area * mm_per_model_unit * mm_per_model_unit, placed);
    e.sagitta_mm = sagitta * frame.mm_per_world_unit;
    e.curvature_per_mm = surface_patch.curvature_per_mm * draw.curvature_scale;
    e.direct = direct;
    e.exitance = direct;
    emitters_out[draw.emitter_first + i] = e;
}

// One bounce: each emitter of the draw's patches gathers what every other emitter sends it
// and sends out its own light plus that (its receiving part answers as at its mean curvature).
@compute @workgroup_size(COMPUTE_WORKGROUP_SIZE)
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
    e.exitance = e.direct + gathered_light(receiver, k).light;
    emitters_out[k] = e;
}

// The inter-reflected radiance at every vertex of the draw's mesh, gathered from the frame's
// emitters after their bounces (added to what cs_vertex_terms wrote).
@compute @workgroup_size(COMPUTE_WORKGROUP_SIZE)
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
    // Before the view correction, which the shading pass applies per view.
    let gathered = gathered_light(receiver, arrayLength(&emitters));
    let radiance = terms_out[i].radiance.xyz + FRAC_1_PI * gathered.light;
    terms_out[i].radiance = vec4<f32>(radiance, gathered.arrival_angle);
}
