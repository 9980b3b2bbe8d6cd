// Inter-reflection: a mesh's patches, the frame's emitters, and the light the emitters give a
// receiving point (docs/shading.md, "Inter-reflection"). Reads `emitters` (group 2 of the
// inter-reflection pass).

// One patch of a mesh (cdrf-core's patches::SurfacePatch): its area (model units) and mean
// curvature as cut; where it lies is read from its vertices each frame, so a deforming mesh's
// patches follow it.
struct Patch {
    area: f32,
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

// A point receiving the inter-reflection: position (mm), unit normal and mean curvature
// (mm⁻¹).
struct Receiver {
    position_mm: vec3<f32>,
    normal: vec3<f32>,
    curvature_per_mm: f32,
}

// What a receiver gathers: π·L/E times the irradiance (before the view correction), and the
// angle θ_ω (rad) at which it arrives, its cosine's mean weighted by the light each emitter
// gives (summed over the channels).
struct Gathered {
    light: vec3<f32>,
    arrival_angle: f32,
}

// Σ over the frame's emitters but `skip` of the light each gives the receiver (a Lambertian
// disc each: docs/shading.md), π·L/E times the irradiance facing the emitter: f(κ, θ_ω) · E⊥
// (the CDRF's zonal expansion at the receiver's mean curvature: zonal_value).
fn gathered_light(receiver: Receiver, skip: u32) -> Gathered {
    let response = zonal_response(receiver.curvature_per_mm);
    var sum = vec3<f32>(0.0);
    var cos_arrival_sum = 0.0;
    var weight_sum = 0.0;
    let count = arrayLength(&emitters);
    for (var k = 0u; k < count; k++) {
        // Only the fields the sum needs, each read on its own: software rasterisers read a
        // storage buffer at a loop's index invocation by invocation.
        let e = &emitters[k];
        let from_emitter = receiver.position_mm - (*e).position_mm;
        let height = dot((*e).normal, from_emitter) - (*e).sagitta_mm;
        let area_mm2 = (*e).area_mm2;
        if k == skip || !(height > 0.0) || !(area_mm2 > 0.0) {
            continue;
        }
        let d2 = dot(from_emitter, from_emitter);
        let d = sqrt(d2);
        // The disc's area seen from the point, A cos θ_e, saturates its 1/d² near it.
        let seen_mm2 = area_mm2 * height / d;
        let facing = (*e).exitance * (seen_mm2 / (PI * d2 + seen_mm2));
        let cos_arrival = -dot(receiver.normal, from_emitter) / d;
        let received = facing * zonal_value(response, cos_arrival);
        sum += received;
        let weight = received.r + received.g + received.b;
        cos_arrival_sum += weight * cos_arrival;
        weight_sum += weight;
    }
    var mean_cos_arrival = 1.0;
    if weight_sum > 0.0 {
        mean_cos_arrival = cos_arrival_sum / weight_sum;
    }
    return Gathered(sum, angle(mean_cos_arrival));
}
