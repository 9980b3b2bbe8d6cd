//! Which pixels lie in a cast shadow, on the CPU: a rasteriser, the camera's depth map and the
//! light's (a shadow map), independent of the renderer whose shadows are being measured.

use cdrf_core::glam::{Mat3, Vec3};
use cdrf_core::light::{Light, PointLight, SpotLight};
use cdrf_core::scene::{Projection, Scene};

/// Per pixel of the scene camera's `width` × `height` image: 1 where the visible surface point
/// is hidden from `light` by another part of `mesh` (model units, placed by the scene's
/// transform), else 0; and the cosine between that point's normal and its direction to the light
/// (0 where no surface). Two CPU depth maps: the camera's (which surface point each pixel sees)
/// and the light's (2048 cells across the object, keeping the point nearest the light:
/// orthographic along a directional light, a perspective map about a point or spot light's
/// position); a point is occluded when the light's map holds a point nearer the light than it
/// by more than a slope-scaled bias (2 + 2 tan θ cells).
pub fn cast_shadow(
    scene: &Scene,
    mesh: &cdrf_core::Mesh,
    light: &Light,
    width: u32,
    height: u32,
) -> (Vec<f32>, Vec<f32>) {
    let world_from_model = scene.mesh.transform.world_from_model();
    let positions: Vec<Vec3> = mesh
        .positions
        .iter()
        .map(|&p| world_from_model.transform_point3(p))
        .collect();
    let camera = &scene.camera;
    let forward = (camera.target - camera.eye).normalize();
    let depths = positions.iter().map(|p| (*p - camera.eye).dot(forward));
    let (near, far) = depths.fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), d| {
        (a.min(d), b.max(d))
    });
    let margin = 0.01 * (far - near).abs() + 1e-3;
    let near = match camera.projection {
        Projection::Orthographic { .. } => near - margin,
        Projection::Perspective { .. } => (near - margin).max(1e-3),
    };
    let clip_from_world = camera.clip_from_view(near, far + margin) * camera.view_from_world();

    // The camera's depth map: the nearest surface point per pixel centre.
    let screen: Vec<(Vec3, f32)> = positions
        .iter()
        .map(|&p| {
            let clip = clip_from_world * p.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            let x = (ndc.x + 1.0) * 0.5 * width as f32;
            let y = (1.0 - ndc.y) * 0.5 * height as f32;
            (Vec3::new(x, y, ndc.z), clip.w)
        })
        .collect();
    let normal_from_model = Mat3::from_mat4(world_from_model).inverse().transpose();
    let normals: Vec<Vec3> = mesh
        .normals
        .iter()
        .map(|&n| (normal_from_model * n).normalize_or_zero())
        .collect();
    // Per pixel: depth, surface point, normal.
    let mut seen: Vec<Option<(f32, Vec3, Vec3)>> = vec![None; (width * height) as usize];
    for triangle in &mesh.triangles {
        let [a, b, c] = triangle.map(|i| i as usize);
        rasterize(
            [screen[a].0, screen[b].0, screen[c].0],
            width,
            height,
            |x, y, weights| {
                // Perspective-correct interpolation of the world position.
                let w =
                    Vec3::new(1.0 / screen[a].1, 1.0 / screen[b].1, 1.0 / screen[c].1) * weights;
                let w = w / w.element_sum();
                let depth = screen[a].0.z * weights.x
                    + screen[b].0.z * weights.y
                    + screen[c].0.z * weights.z;
                let point = positions[a] * w.x + positions[b] * w.y + positions[c] * w.z;
                let normal = normals[a] * w.x + normals[b] * w.y + normals[c] * w.z;
                let slot = &mut seen[(y * width + x) as usize];
                if slot.is_none_or(|(d, _, _)| depth < d) {
                    *slot = Some((depth, point, normal.normalize_or_zero()));
                }
            },
        );
    }

    // The light's depth map: (x, y, toward) per point, keeping the largest `toward` (nearest the
    // light) per cell. Directional: x, y across the light, toward = along it. Point and spot:
    // x, y the tangents about an axis from the light to the object, toward = −distance; a cell
    // there covers `cell · distance` of world.
    let source = match *light {
        Light::Directional(_) => None,
        Light::Point(PointLight { position, .. }) | Light::Spot(SpotLight { position, .. }) => {
            Some(position)
        }
    };
    let directional_light = match light {
        Light::Directional(light) => light.to_light.normalize(),
        _ => Vec3::Z,
    };
    let axis = match source {
        Some(position) => {
            let centre = positions.iter().copied().sum::<Vec3>() / positions.len().max(1) as f32;
            (centre - position).normalize_or(Vec3::NEG_Z)
        }
        None => directional_light,
    };
    let u = axis.any_orthonormal_vector();
    let v = axis.cross(u);
    let project = |p: Vec3| match source {
        None => Vec3::new(p.dot(u), p.dot(v), p.dot(directional_light)),
        Some(position) => {
            let r = p - position;
            let z = r.dot(axis).max(1e-6);
            Vec3::new(r.dot(u) / z, r.dot(v) / z, -r.length())
        }
    };
    let to_light_at = |p: Vec3| match source {
        None => directional_light,
        Some(position) => (position - p).normalize_or_zero(),
    };
    let world_per_unit = |p: Vec3| match source {
        None => 1.0,
        Some(position) => (p - position).length(),
    };
    let light_space: Vec<Vec3> = positions.iter().map(|&p| project(p)).collect();
    let (min, max) = light_space.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    const CELLS: u32 = 2048;
    let cell = ((max.x - min.x).max(max.y - min.y) / (CELLS - 2) as f32).max(1e-9);
    let to_cell = |p: Vec3| Vec3::new((p.x - min.x) / cell + 1.0, (p.y - min.y) / cell + 1.0, p.z);
    let mut nearest = vec![f32::NEG_INFINITY; (CELLS * CELLS) as usize];
    for triangle in &mesh.triangles {
        let corners = triangle.map(|i| to_cell(light_space[i as usize]));
        rasterize(corners, CELLS, CELLS, |x, y, weights| {
            let toward =
                corners[0].z * weights.x + corners[1].z * weights.y + corners[2].z * weights.z;
            let slot = &mut nearest[(y * CELLS + x) as usize];
            *slot = slot.max(toward);
        });
    }
    let mut cos_thetas = vec![0.0; seen.len()];
    let occluded = seen
        .iter()
        .zip(&mut cos_thetas)
        .map(|(hit, cos_out)| {
            let Some((_, point, normal)) = hit else {
                return 0.0;
            };
            // Slope-scaled: a surface at grazing light changes its distance to the light by
            // tan θ per unit across, so a cell holds points up to that much nearer.
            let cos_theta = normal.dot(to_light_at(*point)).clamp(-1.0, 1.0);
            *cos_out = cos_theta;
            let tan_theta = (1.0 - cos_theta * cos_theta).sqrt() / cos_theta.abs().max(0.02);
            let bias = cell * world_per_unit(*point) * (2.0 + 2.0 * tan_theta);
            let p = to_cell(project(*point));
            let (x, y) = (p.x.floor() as i64, p.y.floor() as i64);
            if x < 0 || y < 0 || x >= i64::from(CELLS) || y >= i64::from(CELLS) {
                return 0.0;
            }
            let occluder = nearest[(y as u32 * CELLS + x as u32) as usize];
            if occluder > p.z + bias { 1.0 } else { 0.0 }
        })
        .collect();
    (occluded, cos_thetas)
}

/// Calls `shade(x, y, barycentric weights)` for every pixel centre (x + 0.5, y + 0.5) of a
/// `width` × `height` grid inside the triangle `corners` (x, y in pixels; either winding).
fn rasterize(corners: [Vec3; 3], width: u32, height: u32, mut shade: impl FnMut(u32, u32, Vec3)) {
    let [a, b, c] = corners;
    let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if area.abs() < 1e-12 || !area.is_finite() {
        return;
    }
    let lo_x = a.x.min(b.x).min(c.x).floor().max(0.0) as u32;
    let hi_x = (a.x.max(b.x).max(c.x).ceil().max(0.0) as u32).min(width);
    let lo_y = a.y.min(b.y).min(c.y).floor().max(0.0) as u32;
    let hi_y = (a.y.max(b.y).max(c.y).ceil().max(0.0) as u32).min(height);
    for y in lo_y..hi_y {
        for x in lo_x..hi_x {
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            let w0 = ((b.x - px) * (c.y - py) - (b.y - py) * (c.x - px)) / area;
            let w1 = ((c.x - px) * (a.y - py) - (c.y - py) * (a.x - px)) / area;
            let w2 = 1.0 - w0 - w1;
            if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 {
                shade(x, y, Vec3::new(w0, w1, w2));
            }
        }
    }
}
