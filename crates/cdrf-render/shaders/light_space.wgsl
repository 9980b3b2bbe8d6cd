// Light space: the frame a shadowed light's terms work in (mm), its rays and depths, the faces
// and texels of its maps, the area a texel lets light into, and a point's local shape there.
// Reads `shadows`, `shadow_maps` (group 3) and `frame`. See docs/shading.md.

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
// point q on face `face`, per unit of the light's strength (light_strength), so that times it
// is the flux entering the first surface in that texel: orthographic, the texel's
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
