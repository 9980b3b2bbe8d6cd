//! Finding a sphere in a photograph and turning its pixels into (θ, φ, radiance) samples.
//!
//! # Detection
//! The shadow side of a large translucent sphere is nearly black, so its silhouette is only
//! visible on the lit side. Detection therefore fits a circle to the *visible* boundary:
//! 1. threshold the luminance at 2 % of its 99th percentile and take the mask's boundary pixels
//!    (this includes a false boundary where the shadow side fades out);
//! 2. RANSAC: circles through three boundary pixels, keeping the one most boundary pixels lie on
//!    (the false boundary is not a circle of the same centre, so it loses);
//! 3. refine to sub-pixel: along the radius through every inlier, find where the bilinearly
//!    interpolated luminance crosses half the level just inside the edge (with a box pixel
//!    filter that is where the true edge is, if the radiance is flat near the edge) and fit a
//!    circle to those points by geometric least squares. Where the radiance falls toward the
//!    limb (a sphere lit from the camera's direction) the crossing lies up to ~1 px inside; a
//!    side-lit sphere, the measurement setup, is found to within a few hundredths of a pixel;
//! 4. off black (a wall or a table around the sphere: the ring just outside is not dark) the
//!    threshold keeps only part of the ring and the background is not 0, so the circle is
//!    refitted to the whole ring ([`crate::circles`]'s silhouette crossings).
//!
//! # Geometry
//! Pixel `(i, j)` (row 0 at the top) has its centre at continuous coordinates
//! `(i + 0.5, j + 0.5)`; camera space is +x right, +y up, +z toward the camera.
//! - **Orthographic**: the normal at a pixel is `((u − cx)/R, −(v − cy)/R, √(1 − …))` and the
//!   view vector is `(0, 0, 1)`.
//! - **Perspective** (vertical field of view, principal point at the image centre): the rays
//!   through the detected silhouette points form a circular cone around the sphere's direction
//!   (exact also off the optical axis, where the silhouette is an ellipse); its axis and
//!   half-angle place the sphere, each pixel's ray is intersected with it, and the view vector
//!   is the reversed ray.

use cdrf_core::linear::solve_3x3;
use glam::{DVec2, Vec2, Vec3};

use crate::dataset::{LightSource, Projection};
use crate::image_io::LinearImage;

/// A circle in continuous pixel coordinates (`(0, 0)` is the top-left corner of the image).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle {
    /// Centre, pixels.
    pub center_px: Vec2,
    /// Radius, pixels.
    pub radius_px: f32,
}

/// A sphere's silhouette as detected in an image.
#[derive(Clone, Debug, PartialEq)]
pub struct Detection {
    /// The fitted circle.
    pub circle: Circle,
    /// The (sub-pixel) boundary points the circle was fitted to, pixels.
    pub edge_points: Vec<Vec2>,
    /// RMS distance of those points from the circle, pixels.
    pub rms_residual_px: f32,
}

/// Why no sphere could be found.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum DetectionError {
    /// Everything is black (or the image is empty).
    #[error("the image is black: no sphere to detect")]
    Black,
    /// Too little of a circular boundary is visible.
    #[error(
        "no circular silhouette found ({inliers} of {boundary} boundary pixels on the best circle)"
    )]
    NoCircle {
        /// Boundary pixels on the best circle.
        inliers: usize,
        /// Boundary pixels in all.
        boundary: usize,
    },
    /// A photograph shows more spheres than the manifest names in it, so size cannot say which
    /// is which.
    #[error(
        "the photograph shows more spheres than the {named} the manifest names in it: give center_px for each entry of this image to say which is which"
    )]
    TooManySpheres {
        /// Entries naming the photograph.
        named: usize,
    },
    /// A photograph of several spheres shows fewer circles than the manifest names.
    #[error(
        "the manifest names {wanted} spheres in this photograph but fewer were found ({error})"
    )]
    TooFewSpheres {
        /// Entries naming the photograph.
        wanted: usize,
        /// What the detector said.
        error: Box<DetectionError>,
    },
}

/// Luminance used for detection (the mean of R, G, B: no colour preference).
fn luminance(pixel: Vec3) -> f32 {
    (pixel.x + pixel.y + pixel.z) / 3.0
}

/// Detects the sphere's silhouette in a linear RGB image (row-major, row 0 at the top).
///
/// # Errors
/// When the image is black or shows no circular silhouette.
pub fn detect_sphere(
    width: usize,
    height: usize,
    pixels: &[Vec3],
) -> Result<Detection, DetectionError> {
    // A non-finite pixel (a half-float overflow, say) must not poison the edge search.
    let luma: Vec<f32> = pixels
        .iter()
        .map(|&p| luminance(p))
        .map(|v| if v.is_finite() { v } else { 0.0 })
        .collect();
    let mut finite: Vec<f32> = luma
        .iter()
        .copied()
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if finite.is_empty() {
        return Err(DetectionError::Black);
    }
    let rank = ((finite.len() - 1) as f64 * 0.99) as usize;
    let (_, &mut p99, _) = finite.select_nth_unstable_by(rank, f32::total_cmp);
    let threshold = 0.02 * p99;
    // Threshold a lightly blurred copy (single-pixel noise would riddle the mask), then keep
    // only the boundary against the background connected to the image border, so holes inside
    // the sphere make no false edges.
    let blurred = box_blur_3x3(&luma, width, height);
    let inside = |x: usize, y: usize| blurred[y * width + x] > threshold;
    let mut outside = vec![false; width * height];
    let mut stack: Vec<(usize, usize)> = Vec::new();
    for x in 0..width {
        stack.push((x, 0));
        stack.push((x, height - 1));
    }
    for y in 0..height {
        stack.push((0, y));
        stack.push((width - 1, y));
    }
    while let Some((x, y)) = stack.pop() {
        let index = y * width + x;
        if outside[index] || inside(x, y) {
            continue;
        }
        outside[index] = true;
        if x > 0 {
            stack.push((x - 1, y));
        }
        if x + 1 < width {
            stack.push((x + 1, y));
        }
        if y > 0 {
            stack.push((x, y - 1));
        }
        if y + 1 < height {
            stack.push((x, y + 1));
        }
    }
    let is_outside = |x: usize, y: usize| outside[y * width + x];
    let mut boundary = Vec::new();
    for y in 0..height {
        for x in 0..width {
            if !inside(x, y) {
                continue;
            }
            let at_edge = (x > 0 && is_outside(x - 1, y))
                || (x + 1 < width && is_outside(x + 1, y))
                || (y > 0 && is_outside(x, y - 1))
                || (y + 1 < height && is_outside(x, y + 1));
            if at_edge {
                boundary.push(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
            }
        }
    }
    if boundary.len() < 12 {
        return Err(DetectionError::NoCircle {
            inliers: 0,
            boundary: boundary.len(),
        });
    }

    let (circle, inliers) = ransac_circle(&boundary, width.max(height) as f64);
    // At least a quarter of the circle must be visible.
    let min_inliers = ((circle.1 * std::f64::consts::FRAC_PI_2) as usize).max(12);
    if inliers.len() < min_inliers {
        return Err(DetectionError::NoCircle {
            inliers: inliers.len(),
            boundary: boundary.len(),
        });
    }
    let circle = fit_circle(&inliers, circle);

    // Sub-pixel edge along the radius through each inlier.
    let sample = |p: DVec2| bilinear(&luma, width, height, p);
    let edges: Vec<DVec2> = inliers
        .iter()
        .filter_map(|&p| {
            let direction = (p - circle.0).normalize_or_zero();
            if direction == DVec2::ZERO {
                return None;
            }
            let inner_level = (3..=5)
                .map(|k| sample(circle.0 + direction * (circle.1 - k as f64)))
                .sum::<f64>()
                / 3.0;
            if inner_level.is_nan() || inner_level <= threshold as f64 {
                return None;
            }
            let half = inner_level / 2.0;
            crate::circles::crossing(
                |s| sample(circle.0 + direction * s),
                (circle.1 - 3.0, circle.1 + 3.0),
                half,
                |before, after| before >= half && after < half,
            )
            .map(|s| circle.0 + direction * s)
        })
        .collect();
    let (circle, points) = if edges.len() >= min_inliers {
        (fit_circle(&edges, circle), edges)
    } else {
        (circle, inliers)
    };
    if !(circle.0.is_finite() && circle.1.is_finite() && circle.1 > 0.0) {
        return Err(DetectionError::NoCircle {
            inliers: 0,
            boundary: boundary.len(),
        });
    }
    // On black the halfway crossing above is exact. Against a lit wall or a table the threshold
    // keeps only part of the ring (a noisy shadow side falls below it) and the background is
    // not 0: refit to the whole ring where it stands out from its surround.
    let (circle, points) = match on_black(&blurred, width, height, circle, p99) {
        true => (circle, points),
        false => match crate::circles::around_circle(&blurred, width, height, circle) {
            Some((c, r, all)) => ((c, r), all),
            None => (circle, points),
        },
    };
    let rms = rms_residual_px(&points, circle);
    Ok(Detection {
        circle: Circle {
            center_px: circle.0.as_vec2(),
            radius_px: circle.1 as f32,
        },
        edge_points: points.iter().map(|p| p.as_vec2()).collect(),
        rms_residual_px: rms as f32,
    })
}

/// The root mean square of the points' distances from the circle, pixels (0 for no points).
pub(crate) fn rms_residual_px(points: &[DVec2], (centre, radius): (DVec2, f64)) -> f64 {
    (points
        .iter()
        .map(|p| ((*p - centre).length() - radius).powi(2))
        .sum::<f64>()
        / points.len().max(1) as f64)
        .sqrt()
}

/// Whether the ring 5–8 px outside `circle` is black: its median below 10⁻³ of the bright level.
fn on_black(luma: &[f32], width: usize, height: usize, circle: (DVec2, f64), bright: f32) -> bool {
    let mut ring: Vec<f32> = (0..256)
        .flat_map(|i| {
            let direction = DVec2::from_angle(std::f64::consts::TAU * f64::from(i) / 256.0);
            [5.0, 6.5, 8.0].map(|d| {
                bilinear(luma, width, height, circle.0 + direction * (circle.1 + d)) as f32
            })
        })
        .filter(|v| v.is_finite())
        .collect();
    crate::curves::median(&mut ring).is_none_or(|median| median <= 1e-3 * bright)
}

/// Mean over each pixel's 3 × 3 neighbourhood (clipped at the image border).
pub(crate) fn box_blur_3x3(values: &[f32], width: usize, height: usize) -> Vec<f32> {
    let mut out = vec![0.0; values.len()];
    for y in 0..height {
        for x in 0..width {
            let (mut sum, mut count) = (0.0, 0.0);
            for yy in y.saturating_sub(1)..(y + 2).min(height) {
                for xx in x.saturating_sub(1)..(x + 2).min(width) {
                    sum += values[yy * width + xx];
                    count += 1.0;
                }
            }
            out[y * width + x] = sum / count;
        }
    }
    out
}

pub(crate) fn bilinear(values: &[f32], width: usize, height: usize, p: DVec2) -> f64 {
    let x = (p.x - 0.5).clamp(0.0, (width - 1) as f64);
    let y = (p.y - 0.5).clamp(0.0, (height - 1) as f64);
    let (x0, y0) = (x as usize, y as usize);
    let (x1, y1) = ((x0 + 1).min(width - 1), (y0 + 1).min(height - 1));
    let (tx, ty) = (x - x0 as f64, y - y0 as f64);
    let at = |x: usize, y: usize| values[y * width + x] as f64;
    let top = at(x0, y0) * (1.0 - tx) + at(x1, y0) * tx;
    let bottom = at(x0, y1) * (1.0 - tx) + at(x1, y1) * tx;
    top * (1.0 - ty) + bottom * ty
}

/// RANSAC over circles through three boundary points (deterministic: a fixed-seed generator).
fn ransac_circle(points: &[DVec2], max_radius: f64) -> ((DVec2, f64), Vec<DVec2>) {
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut next = |n: usize| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % n as u64) as usize
    };
    let tolerance = 1.5;
    let mut best = ((DVec2::ZERO, 0.0), 0usize);
    for _ in 0..400 {
        let (a, b, c) = (
            points[next(points.len())],
            points[next(points.len())],
            points[next(points.len())],
        );
        let Some((center, radius)) = circle_through(a, b, c) else {
            continue;
        };
        if !(4.0..=max_radius).contains(&radius) {
            continue;
        }
        let count = points
            .iter()
            .filter(|p| ((**p - center).length() - radius).abs() < tolerance)
            .count();
        if count > best.1 {
            best = ((center, radius), count);
        }
    }
    let (center, radius) = best.0;
    let inliers = points
        .iter()
        .copied()
        .filter(|p| ((*p - center).length() - radius).abs() < tolerance)
        .collect();
    (best.0, inliers)
}

fn circle_through(a: DVec2, b: DVec2, c: DVec2) -> Option<(DVec2, f64)> {
    let d = 2.0 * (a.x * (b.y - c.y) + b.x * (c.y - a.y) + c.x * (a.y - b.y));
    if d.abs() < 1e-9 {
        return None;
    }
    let (a2, b2, c2) = (a.length_squared(), b.length_squared(), c.length_squared());
    let center = DVec2::new(
        (a2 * (b.y - c.y) + b2 * (c.y - a.y) + c2 * (a.y - b.y)) / d,
        (a2 * (c.x - b.x) + b2 * (a.x - c.x) + c2 * (b.x - a.x)) / d,
    );
    Some((center, (a - center).length()))
}

/// Geometric least-squares circle (Gauss–Newton from `start`).
pub(crate) fn fit_circle(points: &[DVec2], start: (DVec2, f64)) -> (DVec2, f64) {
    let (mut center, mut radius) = start;
    for _ in 0..20 {
        // Residual rᵢ = |pᵢ − c| − R; Jacobian row (−uᵢ, −1) with uᵢ the unit vector c → pᵢ.
        let mut normal = [[0.0_f64; 3]; 3];
        let mut rhs = [0.0_f64; 3];
        for p in points {
            let offset = *p - center;
            let distance = offset.length();
            if distance < 1e-12 {
                continue;
            }
            let u = offset / distance;
            let row = [-u.x, -u.y, -1.0];
            let residual = distance - radius;
            for i in 0..3 {
                for j in 0..3 {
                    normal[i][j] += row[i] * row[j];
                }
                rhs[i] -= row[i] * residual;
            }
        }
        let Some(step) = solve_3x3(normal, rhs) else {
            break;
        };
        center += DVec2::new(step[0], step[1]);
        radius += step[2];
        if step.iter().map(|s| s.abs()).fold(0.0, f64::max) < 1e-7 {
            break;
        }
    }
    (center, radius)
}

/// Where a pixel sees the sphere: its normal and the direction to the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Unit outward normal, camera space.
    pub normal: Vec3,
    /// Unit vector from the point toward the camera.
    pub to_camera: Vec3,
    /// Distance of the pixel centre from the silhouette, pixels (positive inside).
    pub inside_by_px: f32,
    /// The point in camera space, mm (the pinhole at the origin); perspective views only (an
    /// orthographic photograph does not say how far the sphere is).
    pub position_mm: Option<Vec3>,
}

/// A light as the sampler uses it: where it is and how strong, in the image's units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Illumination {
    /// Where the light comes from.
    pub source: LightSource,
    /// Irradiance on a surface facing a directional light, or a lamp's intensity (a surface
    /// facing it at d mm receives `strength / d²`), per channel.
    pub strength: Vec3,
}

impl From<&crate::dataset::Light> for Illumination {
    /// The manifest's light, of strength 1 where the manifest does not give it.
    fn from(light: &crate::dataset::Light) -> Self {
        Self {
            source: light.source,
            strength: light.given_strength().unwrap_or(Vec3::ONE),
        }
    }
}

impl Illumination {
    /// A directional light toward unit vector `to_light` with `irradiance`.
    pub fn directional(to_light: Vec3, irradiance: Vec3) -> Self {
        Self {
            source: LightSource::Directional { to_light },
            strength: irradiance,
        }
    }

    /// The unit vector toward the light and the irradiance on a surface facing it, at a point
    /// (camera space, mm; a lamp seen in an orthographic view is taken from the pinhole).
    pub fn at(&self, position_mm: Option<Vec3>) -> (Vec3, Vec3) {
        match self.source {
            LightSource::Directional { to_light } => (to_light, self.strength),
            LightSource::Lamp { position_mm: lamp } => {
                let offset = lamp - position_mm.unwrap_or(Vec3::ZERO);
                let distance2 = offset.length_squared().max(1e-12);
                (offset / distance2.sqrt(), self.strength / distance2)
            }
        }
    }
}

/// Maps pixels to points on a sphere seen through a camera.
#[derive(Clone, Copy, Debug)]
pub struct SphereView {
    circle: Circle,
    perspective: Option<PerspectiveSphere>,
    radius_mm: f32,
}

#[derive(Clone, Copy, Debug)]
struct PerspectiveSphere {
    principal_px: Vec2,
    focal_px: f32,
    /// Sphere centre in units of its radius, camera at the origin.
    center: Vec3,
}

impl SphereView {
    /// The sphere with silhouette `circle` in a `width × height` image taken with `projection`.
    pub fn new(circle: Circle, projection: Projection, width: usize, height: usize) -> Self {
        Self::with_silhouette(circle, projection, width, height, &[])
    }

    /// Like [`SphereView::new`], with the detected silhouette points (pixels): a perspective
    /// camera then places the sphere from those points rather than from the circle, which is
    /// exact also for a sphere off the optical axis (whose silhouette is an ellipse).
    pub fn with_silhouette(
        circle: Circle,
        projection: Projection,
        width: usize,
        height: usize,
        silhouette_px: &[Vec2],
    ) -> Self {
        let perspective = match projection {
            Projection::Orthographic => None,
            Projection::Perspective { vertical_fov_deg } => {
                let principal_px = Vec2::new(width as f32, height as f32) / 2.0;
                let focal_px = (height as f32 / 2.0) / (vertical_fov_deg.to_radians() / 2.0).tan();
                let ray = |p: Vec2| {
                    Vec3::new(p.x - principal_px.x, principal_px.y - p.y, -focal_px).normalize()
                };
                // The silhouette rays r form a circular cone around the sphere's direction a,
                // a·r = cos α. With w = a / cos α that is w·r = 1: a linear least-squares fit.
                let mut rays: Vec<Vec3> = silhouette_px.iter().map(|&p| ray(p)).collect();
                if rays.len() < 3 {
                    rays = (0..64)
                        .map(|k| {
                            let t = k as f32 / 64.0 * std::f32::consts::TAU;
                            ray(circle.center_px + circle.radius_px * Vec2::new(t.cos(), t.sin()))
                        })
                        .collect();
                }
                let (mut normal, mut rhs) = (glam::DMat3::ZERO, glam::DVec3::ZERO);
                for r in &rays {
                    let r = r.as_dvec3();
                    normal += glam::DMat3::from_cols(r * r.x, r * r.y, r * r.z);
                    rhs += r;
                }
                let w = if normal.determinant().abs() > 1e-12 {
                    normal.inverse() * rhs
                } else {
                    // Degenerate (all rays alike): the mean direction, a tiny cone.
                    rhs.normalize() / (1.0 - 1e-6)
                };
                let axis = w.normalize().as_vec3();
                let cos_angle = (1.0 / w.length()).clamp(-1.0, 1.0) as f32;
                let angle = cos_angle.acos().max(1e-6);
                Some(PerspectiveSphere {
                    principal_px,
                    focal_px,
                    center: axis / angle.sin(),
                })
            }
        };
        Self {
            circle,
            perspective,
            radius_mm: 1.0,
        }
    }

    /// The same view of a sphere of `radius_mm` (what places its points in mm, for a lamp).
    pub fn with_radius_mm(self, radius_mm: f32) -> Self {
        Self { radius_mm, ..self }
    }

    /// The sphere's centre in camera space, mm (perspective views only).
    pub fn center_mm(&self) -> Option<Vec3> {
        self.perspective.map(|p| p.center * self.radius_mm)
    }

    /// The surface point seen through the centre of pixel `(column, row)`, if any.
    pub fn point(&self, column: usize, row: usize) -> Option<SurfacePoint> {
        let pixel = Vec2::new(column as f32 + 0.5, row as f32 + 0.5);
        match self.perspective {
            None => {
                let offset = (pixel - self.circle.center_px) / self.circle.radius_px;
                let (x, y) = (offset.x, -offset.y);
                let rho2 = x * x + y * y;
                if rho2.is_nan() || rho2 >= 1.0 {
                    return None;
                }
                Some(SurfacePoint {
                    normal: Vec3::new(x, y, (1.0 - rho2).sqrt()),
                    to_camera: Vec3::Z,
                    inside_by_px: self.circle.radius_px - (pixel - self.circle.center_px).length(),
                    position_mm: None,
                })
            }
            Some(sphere) => {
                let ray = Vec3::new(
                    pixel.x - sphere.principal_px.x,
                    sphere.principal_px.y - pixel.y,
                    -sphere.focal_px,
                )
                .normalize();
                let along = ray.dot(sphere.center);
                let discriminant = along * along - (sphere.center.length_squared() - 1.0);
                if discriminant <= 0.0 {
                    return None;
                }
                let hit = ray * (along - discriminant.sqrt());
                Some(SurfacePoint {
                    normal: (hit - sphere.center).normalize(),
                    to_camera: -ray,
                    inside_by_px: self.circle.radius_px - (pixel - self.circle.center_px).length(),
                    position_mm: Some(hit * self.radius_mm),
                })
            }
        }
    }
}

/// One pixel of a sphere photograph, reduced to what the fit needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Angle between normal and light, radians.
    pub theta_rad: f32,
    /// Angle between normal and view, radians.
    pub phi_rad: f32,
    /// π·L/E per channel.
    pub radiance: Vec3,
    /// Cosine between the view and the light at this point (0 with the camera at 90° to the
    /// light, as in the bundled photographs): the view's azimuth the fit divides out.
    pub view_dot_light: f32,
    /// Pixel index (row-major) in its image.
    pub pixel: u32,
    /// The width of the file's code step at this value, π·L/E per channel (the photograph's
    /// and its flagged frame's added): rounding can have moved `radiance` by half of it
    /// ([`crate::image_io::CodeStep`]).
    pub code_step: Vec3,
    /// Whether a file behind this sample was compressed lossily (JPEG).
    pub lossy: bool,
    /// The flagged frame's light at this pixel (what was subtracted), π·L/E per channel; zero
    /// without one.
    pub ambient: Vec3,
}

impl Sample {
    /// Divides every π·L/E quantity of the sample (radiance, code step, ambient light) by
    /// `factor`: a light's strength, or the view's azimuth factor.
    pub fn divide(&mut self, factor: Vec3) {
        self.radiance /= factor;
        self.code_step /= factor;
        self.ambient /= factor;
    }
}

/// A photograph's flagged frame as [`sample_sphere`] needs it, per pixel (row-major, the
/// photograph's size).
#[derive(Clone, Debug)]
pub struct FlaggedFrame {
    /// The flagged frame's own pixels (already subtracted from the photograph).
    pub light: Vec<Vec3>,
    /// The code steps of both frames at each pixel, added.
    pub code_steps: Vec<Vec3>,
    /// Whether either file is lossy (JPEG).
    pub lossy: bool,
}

/// How many pixels inside the silhouette were not used, and why.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct DroppedPixels {
    /// Closer to the silhouette than the margin (their footprint mixes in background, and their
    /// normals are the least certain).
    pub near_silhouette: usize,
    /// A channel at the format's maximum code value.
    pub saturated: usize,
    /// NaN or infinite, or negative in a file without sensor levels.
    pub invalid: usize,
    /// Zero in the entry's mask image.
    pub masked: usize,
    /// In a residual highlight (imperfect cross-polarisation; see `crate::highlight`).
    pub highlight: usize,
}

/// Turns every usable pixel inside the silhouette into a [`Sample`].
///
/// Radiance is converted to π·L/E with the light's irradiance at the pixel's point. Pixels
/// closer to the silhouette than `edge_margin_px`, pixels a `mask` excludes (`false`; row-major,
/// the image's size), saturated pixels and invalid ones (non-finite; negative unless
/// `allow_negative`, which a raw-like file's noise around its black level needs) are dropped and
/// counted. `image` is the photograph minus its `flagged` frame where there is one, which gives
/// each sample's code steps and ambient light; else they are the image's own and zero.
///
/// # Panics
/// If `flagged`'s vectors are not the image's size.
pub fn sample_sphere(
    view: &SphereView,
    image: &LinearImage,
    light: &Illumination,
    edge_margin_px: f32,
    mask: Option<&[bool]>,
    allow_negative: bool,
    flagged: Option<&FlaggedFrame>,
) -> (Vec<Sample>, DroppedPixels) {
    let (width, height) = (image.width as usize, image.height as usize);
    if let Some(frame) = flagged {
        assert!(
            frame.light.len() == image.pixels.len() && frame.code_steps.len() == image.pixels.len(),
            "flagged frame of {} / {} pixels for a {width} × {height} image",
            frame.light.len(),
            frame.code_steps.len()
        );
    }
    let mut samples = Vec::new();
    let mut dropped = DroppedPixels::default();
    for row in 0..height {
        for column in 0..width {
            let Some(point) = view.point(column, row) else {
                continue;
            };
            let index = row * width + column;
            if point.inside_by_px < edge_margin_px {
                dropped.near_silhouette += 1;
                continue;
            }
            if mask.is_some_and(|mask| !mask.get(index).copied().unwrap_or(false)) {
                dropped.masked += 1;
                continue;
            }
            let value = image.pixels[index];
            if !(value.is_finite() && (allow_negative || value.min_element() >= 0.0)) {
                dropped.invalid += 1;
                continue;
            }
            if image.saturated[index] {
                dropped.saturated += 1;
                continue;
            }
            let (to_light, irradiance) = light.at(point.position_mm);
            let to_reflectance = std::f32::consts::PI / irradiance;
            samples.push(Sample {
                theta_rad: point.normal.dot(to_light).clamp(-1.0, 1.0).acos(),
                phi_rad: point.normal.dot(point.to_camera).clamp(-1.0, 1.0).acos(),
                radiance: value * to_reflectance,
                view_dot_light: point.to_camera.dot(to_light),
                pixel: index as u32,
                code_step: flagged.map_or_else(
                    || image.code_step.at_rgb(value),
                    |frame| frame.code_steps[index],
                ) * to_reflectance,
                lossy: flagged.map_or(image.code_step.lossy(), |frame| frame.lossy),
                ambient: flagged.map_or(Vec3::ZERO, |frame| frame.light[index]) * to_reflectance,
            });
        }
    }
    (samples, dropped)
}
