//! Finding several spheres in a cluttered photograph: a grey wall behind them, a table, stands.
//!
//! [`crate::sphere::detect_sphere`] thresholds the image against a black background; a real
//! capture has none, and its background is often brighter than the spheres' shadow sides. Here
//! the silhouette is found as an *edge of either polarity*:
//! 1. edges: the Sobel gradient of the log of the (blurred) luminance, so a lit side against a
//!    darker wall and a shadow side against a brighter one count alike; thinned to the gradient's
//!    local maxima;
//! 2. centres: every edge pixel votes along its gradient, both ways, for the centres of circles
//!    of every radius it could lie on (a gradient Hough transform);
//! 3. radii: around each strong centre, the radius whose ring has the largest share of its
//!    circumference on radially pointing edges; a circle needs at least a quarter of its ring;
//! 4. the best non-overlapping circles are refined to sub-pixel: in each direction around the
//!    circle, the steepest step of the luminance within ±4 px, then the halfway crossing between
//!    the levels 2.5–3 px either side of it (`crossings`); a geometric least-squares circle
//!    through the crossings on the detected ring edges, then through those in every direction
//!    that lie within 2, 1, ½ px of it (`around_circle`), so that a stand, a cup's rim or a
//!    terminator near the limb drops out.
//!
//! Straight edges (a table's, a post's) vote along lines and make no strong centre; the
//! terminator inside a sphere is a soft gradient that the threshold does not keep.

use glam::{DVec2, Vec2, Vec3};

use crate::sphere::{Circle, Detection, DetectionError, box_blur_3x3};

/// Smallest circle radius looked for, pixels.
const MIN_RADIUS_PX: usize = 8;
/// Share of a ring's circumference that must lie on edges.
const MIN_COVERAGE: f64 = 0.25;

/// Finds `count` spheres in a linear RGB image (row-major, row 0 at the top), best covered
/// first, plus one more if the photograph clearly shows another (half its ring on edges): the
/// caller cannot then tell by size alone which circle is which entry.
///
/// # Errors
/// When the image is black, or fewer than `count` circular silhouettes are found.
pub fn detect_spheres(
    width: usize,
    height: usize,
    pixels: &[Vec3],
    count: usize,
) -> Result<Vec<Detection>, DetectionError> {
    let luma: Vec<f32> = pixels
        .iter()
        .map(|p| (p.x + p.y + p.z) / 3.0)
        .map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 })
        .collect();
    let mut positive: Vec<f32> = luma.iter().copied().filter(|v| *v > 0.0).collect();
    if positive.is_empty() || width < 3 || height < 3 {
        return Err(DetectionError::Black);
    }
    let rank = ((positive.len() - 1) as f64 * 0.99) as usize;
    let (_, &mut p99, _) = positive.select_nth_unstable_by(rank, f32::total_cmp);
    // Below half a percent of the bright level, noise would dominate the log.
    let floor = 0.005 * p99;
    let blurred = box_blur_3x3(&box_blur_3x3(&luma, width, height), width, height);
    let log: Vec<f32> = blurred.iter().map(|v| (v + floor).ln()).collect();
    let edges = edges(&log, width, height);
    let max_radius = width.min(height) / 2;
    if edges.len() < 12 || max_radius <= MIN_RADIUS_PX {
        return Err(DetectionError::NoCircle {
            inliers: 0,
            boundary: edges.len(),
        });
    }
    let centres = vote(&edges, width, height, max_radius);
    let mut circles: Vec<(DVec2, f64, f64)> = Vec::new();
    for centre in centres {
        if circles
            .iter()
            .any(|(c, r, _)| (centre - *c).length() < *r + MIN_RADIUS_PX as f64)
        {
            continue;
        }
        if let Some((radius, coverage)) = best_radius(&edges, centre, max_radius) {
            circles.push((centre, radius, coverage));
        }
    }
    circles.sort_by(|a, b| b.2.total_cmp(&a.2));
    let mut chosen: Vec<(DVec2, f64)> = Vec::new();
    for (centre, radius, coverage) in circles {
        let overlaps = chosen
            .iter()
            .any(|(c, r)| (centre - *c).length() < radius + r - 2.0);
        if overlaps || (chosen.len() == count && coverage < 0.5) {
            continue;
        }
        chosen.push((centre, radius));
        if chosen.len() > count {
            break;
        }
    }
    if chosen.len() < count {
        return Err(DetectionError::NoCircle {
            inliers: chosen.len(),
            boundary: edges.len(),
        });
    }
    Ok(chosen
        .into_iter()
        .map(|(centre, radius)| refine(&edges, &blurred, width, height, centre, radius))
        .collect())
}

/// An edge pixel: its centre and the unit gradient direction (either polarity).
struct Edge {
    at: DVec2,
    direction: DVec2,
}

/// Thinned edges of the log luminance: Sobel magnitude above a threshold and a local maximum
/// along the gradient.
fn edges(log: &[f32], width: usize, height: usize) -> Vec<Edge> {
    let at = |x: usize, y: usize| log[y * width + x];
    let mut gradient = vec![(0.0_f32, 0.0_f32); log.len()];
    for y in 1..height - 1 {
        for x in 1..width - 1 {
            let gx = (at(x + 1, y - 1) + 2.0 * at(x + 1, y) + at(x + 1, y + 1)
                - at(x - 1, y - 1)
                - 2.0 * at(x - 1, y)
                - at(x - 1, y + 1))
                / 8.0;
            let gy = (at(x - 1, y + 1) + 2.0 * at(x, y + 1) + at(x + 1, y + 1)
                - at(x - 1, y - 1)
                - 2.0 * at(x, y - 1)
                - at(x + 1, y - 1))
                / 8.0;
            gradient[y * width + x] = (gx, gy);
        }
    }
    let magnitude = |x: usize, y: usize| {
        let (gx, gy) = gradient[y * width + x];
        (gx * gx + gy * gy).sqrt()
    };
    // A silhouette is a step of a factor of two or more blurred over a few pixels; the
    // terminator's and the noise's gradients are far below.
    let threshold = 0.12;
    let mut out = Vec::new();
    for y in 2..height - 2 {
        for x in 2..width - 2 {
            let m = magnitude(x, y);
            if m < threshold {
                continue;
            }
            let (gx, gy) = gradient[y * width + x];
            let (dx, dy) = ((gx / m).round() as isize, (gy / m).round() as isize);
            let ahead = magnitude((x as isize + dx) as usize, (y as isize + dy) as usize);
            let behind = magnitude((x as isize - dx) as usize, (y as isize - dy) as usize);
            if m >= ahead && m > behind {
                out.push(Edge {
                    at: DVec2::new(x as f64 + 0.5, y as f64 + 0.5),
                    direction: DVec2::new(f64::from(gx), f64::from(gy)) / f64::from(m),
                });
            }
        }
    }
    out
}

/// Centre candidates, strongest first (local maxima of the blurred vote count).
fn vote(edges: &[Edge], width: usize, height: usize, max_radius: usize) -> Vec<DVec2> {
    let mut votes = vec![0.0_f32; width * height];
    for edge in edges {
        for sign in [-1.0, 1.0] {
            for r in MIN_RADIUS_PX..=max_radius {
                let c = edge.at + edge.direction * (sign * r as f64);
                if c.x < 0.0 || c.y < 0.0 || c.x >= width as f64 || c.y >= height as f64 {
                    break;
                }
                votes[c.y as usize * width + c.x as usize] += 1.0;
            }
        }
    }
    let votes = box_blur_3x3(&votes, width, height);
    let mut peaks: Vec<(f32, usize)> = Vec::new();
    for y in 1..height - 1 {
        for x in 1..width - 1 {
            let v = votes[y * width + x];
            if v < 3.0 {
                continue;
            }
            let is_peak =
                (y - 1..=y + 1).all(|yy| (x - 1..=x + 1).all(|xx| votes[yy * width + xx] <= v));
            if is_peak {
                peaks.push((v, y * width + x));
            }
        }
    }
    peaks.sort_by(|a, b| b.0.total_cmp(&a.0));
    peaks.truncate(64);
    peaks
        .into_iter()
        .map(|(_, i)| DVec2::new((i % width) as f64 + 0.5, (i / width) as f64 + 0.5))
        .collect()
}

/// Edges whose gradient points (either way) along the radius from `centre`.
fn radial(edges: &[Edge], centre: DVec2) -> impl Iterator<Item = (&Edge, f64)> {
    edges.iter().filter_map(move |e| {
        let offset = e.at - centre;
        let distance = offset.length();
        (distance > 0.0 && (offset.dot(e.direction) / distance).abs() > 0.9)
            .then_some((e, distance))
    })
}

/// The radius around `centre` whose ring is best covered by radial edges, and that coverage.
fn best_radius(edges: &[Edge], centre: DVec2, max_radius: usize) -> Option<(f64, f64)> {
    let mut histogram = vec![0.0_f64; max_radius + 3];
    for (_, distance) in radial(edges, centre) {
        let bin = distance.round() as usize;
        if bin < histogram.len() {
            histogram[bin] += 1.0;
        }
    }
    (MIN_RADIUS_PX..=max_radius)
        .map(|r| {
            // A ring of thinned edges holds about 2πr·(4/π) pixels (8-connected): count ±1 px.
            let hits = histogram[r - 1] + histogram[r] + histogram[r + 1];
            let coverage = hits / (8.0 * r as f64);
            (r as f64, coverage)
        })
        .filter(|(_, coverage)| *coverage >= MIN_COVERAGE)
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// Sub-pixel circle from the ring's edges (see the module docs).
fn refine(
    edges: &[Edge],
    luma: &[f32],
    width: usize,
    height: usize,
    centre: DVec2,
    radius: f64,
) -> Detection {
    let ring: Vec<DVec2> = radial(edges, centre)
        .filter(|(_, d)| (d - radius).abs() < 2.5)
        .map(|(e, _)| e.at)
        .collect();
    let (centre, radius) = crate::sphere::fit_circle(&ring, (centre, radius));
    let directions: Vec<DVec2> = ring
        .iter()
        .filter_map(|&p| (p - centre).try_normalize())
        .collect();
    let points = crossings(luma, width, height, (centre, radius), &directions);
    let (centre, radius, points) = if points.len() >= 12 {
        let (c, r) = crate::sphere::fit_circle(&points, (centre, radius));
        (c, r, points)
    } else {
        (centre, radius, ring)
    };
    // Then every direction around that circle (see `around_circle`).
    let (centre, radius, points) =
        around_circle(luma, width, height, (centre, radius)).unwrap_or((centre, radius, points));
    let rms = crate::sphere::rms_residual_px(&points, (centre, radius));
    Detection {
        circle: Circle {
            center_px: centre.as_vec2(),
            radius_px: radius as f32,
        },
        edge_points: points.iter().map(|p| p.as_vec2()).collect::<Vec<Vec2>>(),
        rms_residual_px: rms as f32,
    }
}

/// The circle refitted to the crossings (see [`crossings`]) in every direction around it, one
/// per pixel of its circumference: a noisy shadow side keeps few edges, and on a partial arc
/// the centre slides along it (0.5 px on the 14-bit r = 30 mm capture). Crossings off the
/// circle (a stand, a cup's rim, a terminator near the limb) are left out. `None` where fewer
/// than a quarter of the directions (and fewer than 12) keep a crossing, as a detected circle
/// needs a quarter of its ring.
pub(crate) fn around_circle(
    luma: &[f32],
    width: usize,
    height: usize,
    (centre, radius): (DVec2, f64),
) -> Option<(DVec2, f64, Vec<DVec2>)> {
    if !(centre.is_finite() && radius.is_finite() && radius > 0.0)
        || radius > width.max(height) as f64
    {
        return None;
    }
    let count = (std::f64::consts::TAU * radius).ceil().max(12.0) as usize;
    let around: Vec<DVec2> = (0..count)
        .map(|i| DVec2::from_angle(std::f64::consts::TAU * i as f64 / count as f64))
        .collect();
    let all = crossings(luma, width, height, (centre, radius), &around);
    if all.len() < 12 {
        return None;
    }
    // Fitted to the crossings within 2, then 1, then ½ px of the circle so far: an inner
    // terminator or a stand's edge is steeper than a faint silhouette and would pull a plain fit.
    let mut circle = (centre, radius);
    let mut kept = Vec::new();
    for window_px in [2.0, 1.0, 0.5, 0.5] {
        kept = all
            .iter()
            .copied()
            .filter(|p| ((*p - circle.0).length() - circle.1).abs() <= window_px)
            .collect();
        if kept.len() < 12 {
            return None;
        }
        circle = crate::sphere::fit_circle(&kept, circle);
    }
    let (c, r) = circle;
    (kept.len() as f64 >= (MIN_COVERAGE * std::f64::consts::TAU * r).max(12.0))
        .then_some((c, r, kept))
}

/// Along each of `directions` from the circle's centre, the silhouette: the steepest step of the
/// luminance within ±4 px of the circle, where the levels 4–6 px inside and outside differ by
/// at least 30 %, then the halfway crossing between the levels 2.5–3 px either side of that
/// step. Levels read that close barely move where the disk darkens toward its limb (halfway
/// between levels 6 px apart was 1.7 px inside on a 32 px sphere lit from near the camera).
pub(crate) fn crossings(
    luma: &[f32],
    width: usize,
    height: usize,
    (centre, radius): (DVec2, f64),
    directions: &[DVec2],
) -> Vec<DVec2> {
    const REACH_PX: f64 = 4.0;
    if !(centre.is_finite() && radius.is_finite()) || radius > (width + height) as f64 {
        return Vec::new();
    }
    let sample = |p: DVec2| crate::sphere::bilinear(luma, width, height, p);
    directions
        .iter()
        .filter_map(|&direction| {
            let at = |s: f64| sample(centre + direction * s);
            let level = |from: f64| (0..3).map(|k| at(radius + from + k as f64)).sum::<f64>() / 3.0;
            let (inner, outer) = (level(-6.0), level(4.0));
            // (NaN levels fail the comparison too.)
            let contrast = (inner - outer).abs();
            if contrast.is_nan() || contrast < 0.3 * inner.max(outer) {
                return None;
            }
            let falling = (inner - outer).signum();
            // The slope over ±0.5 px, signed so that the expected edge is positive.
            let slope = |s: f64| falling * (at(s - 0.5) - at(s + 0.5));
            let steps = (2.0 * REACH_PX / SCAN_STEP_PX) as usize;
            let (best, peak) = (0..=steps)
                .map(|i| radius - REACH_PX + i as f64 * SCAN_STEP_PX)
                .map(|s| (s, slope(s)))
                .max_by(|a, b| a.1.total_cmp(&b.1))?;
            if peak.is_nan() || peak <= 0.0 {
                return None;
            }
            // Then the halfway crossing between the levels 2.5–3 px either side of that step:
            // close enough that a disk darkening toward its limb barely moves it.
            let side = |sign: f64| {
                [2.5, 2.75, 3.0]
                    .map(|d| at(best + sign * d))
                    .iter()
                    .sum::<f64>()
                    / 3.0
            };
            let (near_in, near_out) = (side(-1.0), side(1.0));
            let half = (near_in + near_out) / 2.0;
            crossing(at, (best - 2.0, best + 2.0), half, |before, after| {
                (before - half) * (after - half) <= 0.0 && before != after
            })
            .map(|s| centre + direction * s)
        })
        .collect()
}

/// The step of the sub-pixel scans along a radius, pixels.
const SCAN_STEP_PX: f64 = 0.125;

/// Along a line read by `at`, from `span.0` to `span.1` in steps of ⅛ px, the first place where
/// two consecutive readings `crosses(before, after)`, placed by linear interpolation where the
/// line meets `level`. `None` when nothing crosses or the span is not finite.
pub(crate) fn crossing(
    at: impl Fn(f64) -> f64,
    span: (f64, f64),
    level: f64,
    crosses: impl Fn(f64, f64) -> bool,
) -> Option<f64> {
    if !(span.0.is_finite() && span.1.is_finite()) {
        return None;
    }
    let steps = ((span.1 - span.0) / SCAN_STEP_PX).floor().clamp(0.0, 1e4) as usize;
    let mut previous = (span.0, at(span.0));
    for i in 1..=steps {
        let s = span.0 + i as f64 * SCAN_STEP_PX;
        let value = at(s);
        if crosses(previous.1, value) {
            let t = (previous.1 - level) / (previous.1 - value);
            return Some(previous.0 + t * SCAN_STEP_PX);
        }
        previous = (s, value);
    }
    None
}
