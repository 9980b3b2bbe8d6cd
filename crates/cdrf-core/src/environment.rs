//! Environment light — a uniform sky or an equirectangular map — as real spherical harmonics,
//! and any CDRF's zonal coefficients, so that shading under an environment costs a few SH terms
//! per pixel.
//!
//! # Why zonal coefficients
//! Under an environment of radiance `L_env(ω)` a point with normal `n` and curvature κ has the
//! radiance
//!
//! ```text
//! L_out(n) = ∫ f(κ, θ(n, ω))/π · L_env(ω) dω,    cos θ = n·ω,
//! ```
//!
//! because a table in π·L/E turns the irradiance `dE = L_env(ω) dω` arriving from ω into the
//! radiance `f/π · dE` (view correction g left out: the renderer applies it). The kernel
//! `k(t) = f(κ, acos t)/π` depends on `n·ω` only, so by the Funk–Hecke theorem it acts on each
//! band of the environment's spherical harmonics by a number:
//!
//! ```text
//! L_out(n) = Σ_l a_l(κ) Σ_m L_lm Y_lm(n),    a_l(κ) = 2π ∫₀^π f(κ, θ)/π · P_l(cos θ) sin θ dθ
//!                                                    = 2 ∫₀^π f(κ, θ) P_l(cos θ) sin θ dθ,
//! ```
//!
//! with `L_lm = ∫ L_env(ω) Y_lm(ω) dω` and `P_l` the Legendre polynomials. A white Lambertian
//! surface (`f = cos⁺θ`) has `a_0 = 1`, `a_1 = 2/3`, `a_2 = 1/4`, `a_3 = 0`, `a_4 = −1/24`
//! ([`lambert_zonal_coefficient`]; Ramamoorthi and Hanrahan's `Â_l` divided by π), so under a
//! uniform sky of radiance `L` it has radiance `albedo · L`, as it must.
//!
//! [`ZonalTable`] tabulates `a_l(κ)` once per material (from a [`CdrfLut`]'s own rows, or any
//! [`Cdrf`] on a [`CurvatureAxis`]); [`Environment::project_sh`] projects the environment once;
//! [`radiance_sh`] is the per-pixel sum the shader does, and [`radiance_brute_force`] the
//! reference that integrates `f` over the map's texels directly.
//!
//! # Spherical harmonics
//! Real, orthonormal on the unit sphere (`∫ Y_lm Y_l'm' dω = δ`), **without** the Condon–Shortley
//! phase, polar axis world **+z**, in world coordinates (x, y, z) of a unit direction:
//!
//! ```text
//! Y_l0  = K_l0 · P_l(z)
//! Y_lm  = √2 K_lm · P̃_l^m(z) · Re (x + i y)^m     (m > 0)
//! Y_l−m = √2 K_lm · P̃_l^m(z) · Im (x + i y)^m     (m > 0)
//! K_lm  = √((2l + 1)/(4π) · (l − m)!/(l + m)!)
//! ```
//!
//! where `P̃_l^m(z) = P_l^m(z) / sin^m θ` is a polynomial (`P̃_m^m = (2m − 1)!!`,
//! `P̃_{m+1}^m = (2m + 1) z P̃_m^m`, then the usual three-term recurrence in l). So
//! `Y_00 = 0.282095`, `(Y_1−1, Y_10, Y_11) = 0.488603 (y, z, x)`, `Y_2−2 = 1.092548 xy`,
//! `Y_20 = 0.315392 (3z² − 1)`, `Y_22 = 0.546274 (x² − y²)`. Coefficient `(l, m)` is at index
//! `l² + l + m` ([`sh_index`]); order L holds bands `0..=L`, `(L + 1)²` coefficients. The polar
//! axis does not matter for the result (the kernels are zonal); the basis is polynomial in
//! x, y, z, with no trigonometry, so the shader evaluates it from the normal directly.
//!
//! # Equirectangular maps
//! A map is `width × height` texels of linear radiance, row 0 at the top; texel (i, j) covers
//! `u ∈ [i/W, (i+1)/W)`, `v ∈ [j/H, (j+1)/H)`. The world is right-handed with **+y up**
//! ([`crate::scene`]'s convention); a direction `d` maps to
//!
//! ```text
//! u = atan2(d.x, −d.z) / 2π  (wrapped into [0, 1)),     v = acos(d.y) / π,
//! d = (sin πv · sin 2πu,  cos πv,  −sin πv · cos 2πu),
//! ```
//!
//! so row 0 is the zenith (+y), the bottom row the nadir, the left edge (u = 0) looks along −z
//! (the way the default camera, at +z, looks), u = ¼ along +x, the **centre column (u = ½)
//! along +z** (behind that camera) and u = ¾ along −x: u runs −z → +x → +z → −x, clockwise
//! seen from above. This is the convention of Mitsuba 3's `envmap` emitter with an identity
//! `to_world` (the renderer of the bundled data), so a path-traced reference can use the same
//! file. A texel's solid angle is exact: `2π/W · (cos(πj/H) − cos(π(j + 1)/H))`; they sum to 4π.
//!
//! `rotate_deg = α` turns the whole environment by α about world +y by the right-hand rule
//! (+z toward +x): the radiance arriving from `R_y(α)·d` is the map's at `d`, so what the map
//! holds at azimuth u then lights from the direction of `u − α/360`. Shading a normal `n` under
//! the rotated environment equals shading `R_y(−α)·n` under the unrotated one. `intensity`
//! multiplies every texel (or the uniform radiance).
//!
//! # Bad maps
//! Maps are read with [`RgbaImage::read_exr`] and its limits ([`crate::input_file`]); its alpha
//! is ignored. A texel that is NaN, infinite or negative is an **error** naming the file and
//! the texel (not clamped): radiance is never negative, and a map with such values is broken —
//! clamping would silently change its light.

use std::f64::consts::PI as PI_F64;
use std::path::{Path, PathBuf};

use glam::{Mat3, Vec3};
use rayon::prelude::*;
use thiserror::Error;

use crate::gaussian::quadrature::{GAUSS_LEGENDRE_8, for_each_node};
use crate::image_file::{ImageFileError, RgbaImage};
use crate::lut::{Cdrf, CdrfLut, CurvatureAxis};

/// The highest SH order (band index L) this module evaluates: 81 coefficients.
pub const MAX_SH_ORDER: usize = 8;

/// The order the renderer should use: bands 0..=4, 25 coefficients per RGB channel and 5 zonal
/// coefficients per curvature. Measured against [`radiance_brute_force`] on a 256 × 128 map
/// (`tests/environment.rs`, which prints the table), mean / max relative error over normals:
/// a smooth sky, order 2 ≤ 0.74 % / 5.0 %, order 4 ≤ 0.07 % / 1.0 %; a sky with a 4° sun
/// 300× brighter than the zenith, order 2 up to 18 % / 80 % (the measured table 17 % / 67 %, and
/// 20 % of the brightest normal's radiance: its rows are flatter than cos θ near θ = 0), order 4
/// up to 8.5 % / 44 % (3.6 % of the brightest). Order 3 adds nothing to Lambert and the Gaussian
/// (odd a_l ≈ 0) and makes the measured table's mean error worse. A strong sun is better taken
/// out of the map as a directional light.
pub const RECOMMENDED_SH_ORDER: usize = 4;

/// Panels of the θ quadrature of [`zonal_coefficients`] over `[0, π]` (8 Gauss–Legendre nodes
/// each; π/2, the terminator of `cos⁺`, is a panel boundary).
const ZONAL_PANELS: usize = 360;

/// Coefficients of an SH expansion of order `order`: `(order + 1)²`.
pub const fn sh_coefficient_count(order: usize) -> usize {
    (order + 1) * (order + 1)
}

/// Index of coefficient `(l, m)`, `−l ≤ m ≤ l`: `l² + l + m`.
///
/// # Panics
/// If `|m| > l`.
pub fn sh_index(l: usize, m: i32) -> usize {
    assert!(
        m.unsigned_abs() as usize <= l,
        "SH index m = {m} with l = {l}"
    );
    (l * l + l).wrapping_add_signed(m as isize)
}

/// The normalisation constants `K_lm` (m ≥ 0) up to [`MAX_SH_ORDER`], at
/// `l·(l + 1)/2 + m`: what the shader holds as a constant array.
fn sh_normalisation() -> [f32; (MAX_SH_ORDER + 1) * (MAX_SH_ORDER + 2) / 2] {
    let mut k = [0.0; (MAX_SH_ORDER + 1) * (MAX_SH_ORDER + 2) / 2];
    for l in 0..=MAX_SH_ORDER {
        for m in 0..=l {
            // (l − m)!/(l + m)! as a product, in f64.
            let ratio: f64 = ((l - m + 1)..=(l + m)).map(|i| 1.0 / i as f64).product();
            k[l * (l + 1) / 2 + m] = ((2 * l + 1) as f64 / (4.0 * PI_F64) * ratio).sqrt() as f32;
        }
    }
    k
}

/// Evaluates the real SH basis up to `order` at the unit `direction` into
/// `out[..sh_coefficient_count(order)]` (conventions in the [module docs](self)). `k` is
/// [`sh_normalisation`]. Written as the shader writes it: loops, no trigonometry.
fn sh_basis_into(k: &[f32], direction: Vec3, order: usize, out: &mut [f32]) {
    let (x, y, z) = (direction.x, direction.y, direction.z);
    // Re and Im of (x + i y)^m, and P̃_m^m = (2m − 1)!!.
    let (mut re, mut im, mut p_mm) = (1.0f32, 0.0f32, 1.0f32);
    for m in 0..=order {
        if m > 0 {
            (re, im) = (re * x - im * y, re * y + im * x);
            p_mm *= (2 * m - 1) as f32;
        }
        let (mut p_previous, mut p) = (0.0f32, p_mm);
        for l in m..=order {
            if l == m + 1 {
                (p_previous, p) = (p, (2 * m + 1) as f32 * z * p_mm);
            } else if l > m + 1 {
                let next =
                    ((2 * l - 1) as f32 * z * p - (l + m - 1) as f32 * p_previous) / (l - m) as f32;
                (p_previous, p) = (p, next);
            }
            let kp = k[l * (l + 1) / 2 + m] * p;
            let centre = l * l + l;
            if m == 0 {
                out[centre] = kp;
            } else {
                out[centre + m] = std::f32::consts::SQRT_2 * kp * re;
                out[centre - m] = std::f32::consts::SQRT_2 * kp * im;
            }
        }
    }
}

/// The factor of each basis function over its bare polynomial, at [`sh_index`] for bands
/// `0..=order`: `K_l0` for m = 0, `√2 K_l|m|` otherwise, so that
/// `Y_lm = factor · P̃_l^|m|(z) · (Re or Im)(x + i y)^|m|`. A renderer that multiplies the
/// environment's coefficients by these evaluates only the polynomials per pixel.
///
/// # Panics
/// If `order` > [`MAX_SH_ORDER`].
pub fn sh_basis_factors(order: usize) -> Vec<f32> {
    assert!(order <= MAX_SH_ORDER, "SH order {order} > {MAX_SH_ORDER}");
    let k = sh_normalisation();
    let mut out = vec![0.0; sh_coefficient_count(order)];
    for l in 0..=order {
        for m in 0..=l {
            let centre = l * l + l;
            let kp = k[l * (l + 1) / 2 + m];
            if m == 0 {
                out[centre] = kp;
            } else {
                out[centre + m] = std::f32::consts::SQRT_2 * kp;
                out[centre - m] = std::f32::consts::SQRT_2 * kp;
            }
        }
    }
    out
}

/// The real SH basis `Y_lm(direction)` for bands `0..=order`, at [`sh_index`] (conventions in
/// the [module docs](self)). `direction` should be a unit vector.
///
/// # Panics
/// If `order` > [`MAX_SH_ORDER`].
pub fn sh_basis(direction: Vec3, order: usize) -> Vec<f32> {
    assert!(order <= MAX_SH_ORDER, "SH order {order} > {MAX_SH_ORDER}");
    let mut out = vec![0.0; sh_coefficient_count(order)];
    sh_basis_into(&sh_normalisation(), direction, order, &mut out);
    out
}

/// An environment's radiance as real SH coefficients per RGB channel, `coefficients[l² + l + m]`
/// = `L_lm = ∫ L_env(ω) Y_lm(ω) dω` (conventions in the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct ShCoefficients {
    /// `(order + 1)²` coefficients, [`sh_index`] order, linear radiance × steradian^½.
    pub coefficients: Vec<[f32; 3]>,
}

impl ShCoefficients {
    /// The highest complete band held: `⌊√len⌋ − 1` (0 for an empty set reads as band 0).
    pub fn order(&self) -> usize {
        let mut bands = 0;
        while (bands + 1) * (bands + 1) <= self.coefficients.len() {
            bands += 1;
        }
        bands.saturating_sub(1)
    }
}

/// A white Lambertian surface's zonal coefficient `a_l = 2 ∫₀^{π/2} cos θ P_l(cos θ) sin θ dθ`
/// (multiply by the albedo): 1, 2/3, then 0 for odd l and
/// `2 (−1)^(l/2+1) l! / (2^l ((l/2)!)² (l + 2)(l − 1))` for even l.
pub fn lambert_zonal_coefficient(l: usize) -> f64 {
    match l {
        0 => 1.0,
        1 => 2.0 / 3.0,
        _ if l % 2 == 1 => 0.0,
        _ => {
            // l! / (2^l ((l/2)!)²) = C(l, l/2) / 2^l.
            let half = l / 2;
            let binomial: f64 = (1..=half).map(|i| (half + i) as f64 / i as f64).product();
            let sign = if half % 2 == 1 { 1.0 } else { -1.0 };
            sign * 2.0 * binomial / 2f64.powi(l as i32) / ((l + 2) * (l - 1)) as f64
        }
    }
}

/// Legendre polynomials `P_0(t) … P_order(t)` into `out`.
fn legendre(t: f64, out: &mut [f64]) {
    for l in 0..out.len() {
        out[l] = match l {
            0 => 1.0,
            1 => t,
            _ => ((2 * l - 1) as f64 * t * out[l - 1] - (l - 1) as f64 * out[l - 2]) / l as f64,
        };
    }
}

/// `a_l = 2 ∫₀^π f(θ) P_l(cos θ) sin θ dθ` for l = 0..=order by 8-point Gauss–Legendre on
/// `panels` equal panels of [0, π]. `f` is evaluated once per node.
fn zonal_by_quadrature(
    order: usize,
    panels: usize,
    mut f: impl FnMut(f64) -> [f32; 3],
) -> Vec<[f32; 3]> {
    let mut sums = vec![[0.0f64; 3]; order + 1];
    let mut p = vec![0.0f64; order + 1];
    let width = PI_F64 / panels as f64;
    for panel in 0..panels {
        let (a, b) = (panel as f64 * width, (panel + 1) as f64 * width);
        for_each_node(&GAUSS_LEGENDRE_8, a, b, |theta, w| {
            let value = f(theta);
            legendre(theta.cos(), &mut p);
            let weight = 2.0 * w * theta.sin();
            for (sum, &pl) in sums.iter_mut().zip(&p) {
                for c in 0..3 {
                    sum[c] += weight * pl * f64::from(value[c]);
                }
            }
        });
    }
    sums.into_iter().map(|s| s.map(|v| v as f32)).collect()
}

/// The zonal coefficients `a_0 … a_order` of `cdrf` at `curvature_per_mm`, per RGB channel:
/// `a_l = 2 ∫₀^π f(κ, θ) P_l(cos θ) sin θ dθ` (see the [module docs](self)), by 8-point
/// Gauss–Legendre on 360 panels of 0.5° (exact to ~1e-7 for `cos⁺`, whose kink at 90° is a
/// panel boundary). The Lambertian model ([`crate::lut::Lambert`]) goes through here too and
/// gives [`lambert_zonal_coefficient`] × albedo.
///
/// # Panics
/// If `order` > [`MAX_SH_ORDER`].
pub fn zonal_coefficients(cdrf: &impl Cdrf, curvature_per_mm: f32, order: usize) -> Vec<[f32; 3]> {
    assert!(order <= MAX_SH_ORDER, "SH order {order} > {MAX_SH_ORDER}");
    zonal_by_quadrature(order, ZONAL_PANELS, |theta| {
        cdrf.reflectance(curvature_per_mm, theta as f32)
    })
}

/// A material's zonal coefficients over curvature, ready for upload: row `r` holds
/// `a_0 … a_order` at `curvatures_per_mm[r]` per RGB channel. Rows built by
/// [`ZonalTable::tabulate`] and [`ZonalTable::from_lut`] are uniformly spaced, so a GPU maps κ
/// to the row coordinate `(κ − first)/(last − first)·(rows − 1)` and filters linearly with
/// clamp-to-edge — which is [`ZonalTable::sample`]. Since `a_l` is linear in f, interpolating
/// rows linearly in κ gives exactly the coefficients of the table interpolated linearly in κ
/// (what [`CdrfLut`]'s bilinear filter does).
#[derive(Clone, Debug, PartialEq)]
pub struct ZonalTable {
    /// The highest band l; each row has `order + 1` coefficients.
    pub order: usize,
    /// Curvature of each row, mm⁻¹, increasing.
    pub curvatures_per_mm: Vec<f32>,
    /// `coefficients[row · (order + 1) + l]` = `a_l(κ_row)` per RGB channel (radiance per
    /// radiance: an environment of uniform radiance L gives `a_0 · L`).
    pub coefficients: Vec<[f32; 3]>,
}

impl ZonalTable {
    /// `cdrf`'s zonal coefficients on the rows of `axis` ([`zonal_coefficients`], in parallel).
    ///
    /// # Panics
    /// If `order` > [`MAX_SH_ORDER`].
    pub fn tabulate(cdrf: &(impl Cdrf + Sync), axis: CurvatureAxis, order: usize) -> Self {
        let curvatures_per_mm: Vec<f32> = (0..axis.count)
            .map(|row| axis.curvature_per_mm(row))
            .collect();
        let coefficients = curvatures_per_mm
            .par_iter()
            .flat_map_iter(|&curvature| zonal_coefficients(cdrf, curvature, order))
            .collect();
        Self {
            order,
            curvatures_per_mm,
            coefficients,
        }
    }

    /// The zonal coefficients of a measured table's own rows, with its θ filtering (linear
    /// between columns, as [`crate::Filter::Bilinear`]) integrated per column interval — exact
    /// for the piecewise-linear row to the quadrature's ~1e-9. The view correction is not
    /// included.
    ///
    /// # Panics
    /// If `order` > [`MAX_SH_ORDER`].
    pub fn from_lut(lut: &CdrfLut, order: usize) -> Self {
        assert!(order <= MAX_SH_ORDER, "SH order {order} > {MAX_SH_ORDER}");
        let axis = lut.curvature_axis();
        let columns = lut.theta_count();
        let intervals = columns - 1;
        // Panels that end on every column and number at least ZONAL_PANELS.
        let panels = intervals * ZONAL_PANELS.div_ceil(intervals);
        let curvatures_per_mm: Vec<f32> = (0..axis.count)
            .map(|row| axis.curvature_per_mm(row))
            .collect();
        let coefficients = (0..axis.count)
            .into_par_iter()
            .flat_map_iter(|row| {
                let values = lut.row(row);
                zonal_by_quadrature(order, panels, move |theta| {
                    let u = (theta / PI_F64 * intervals as f64).clamp(0.0, intervals as f64);
                    let column = (u as usize).min(intervals - 1);
                    let t = (u - column as f64) as f32;
                    values[column].lerp(values[column + 1], t).to_array()
                })
            })
            .collect();
        Self {
            order,
            curvatures_per_mm,
            coefficients,
        }
    }

    /// A Lambertian material: one row (κ = 0, the same at every curvature) of
    /// `albedo · `[`lambert_zonal_coefficient`].
    pub fn lambert(albedo: [f32; 3], order: usize) -> Self {
        Self {
            order,
            curvatures_per_mm: vec![0.0],
            coefficients: (0..=order)
                .map(|l| albedo.map(|a| (f64::from(a) * lambert_zonal_coefficient(l)) as f32))
                .collect(),
        }
    }

    /// Number of rows.
    pub fn row_count(&self) -> usize {
        self.curvatures_per_mm.len()
    }

    /// Row `row`: `a_0 … a_order`.
    ///
    /// # Panics
    /// If `row` ≥ [`ZonalTable::row_count`].
    pub fn row(&self, row: usize) -> &[[f32; 3]] {
        let bands = self.order + 1;
        &self.coefficients[row * bands..(row + 1) * bands]
    }

    /// `a_0 … a_order` at `curvature_per_mm`: linear between rows, clamped to the first and
    /// last row outside them (as the LUT; a NaN reads the first row). All zeros for a table
    /// without rows.
    pub fn sample(&self, curvature_per_mm: f32) -> Vec<[f32; 3]> {
        let rows = self.row_count();
        if rows == 0 || self.coefficients.len() < rows * (self.order + 1) {
            return vec![[0.0; 3]; self.order + 1];
        }
        let curvatures = &self.curvatures_per_mm;
        let above = curvatures.partition_point(|&c| c <= curvature_per_mm);
        if above == 0 || curvature_per_mm.is_nan() {
            return self.row(0).to_vec();
        }
        if above == rows {
            return self.row(rows - 1).to_vec();
        }
        let (c0, c1) = (curvatures[above - 1], curvatures[above]);
        let t = ((curvature_per_mm - c0) / (c1 - c0)).clamp(0.0, 1.0);
        self.row(above - 1)
            .iter()
            .zip(self.row(above))
            .map(|(a, b)| std::array::from_fn(|c| a[c] + t * (b[c] - a[c])))
            .collect()
    }
}

/// The outgoing radiance (no view correction) of a point with unit `normal` whose material has
/// the zonal coefficients `zonal_row` (a [`ZonalTable`] row or [`ZonalTable::sample`]) under
/// the environment `sh`: `max(Σ_l a_l Σ_m L_lm Y_lm(n), 0)` per RGB channel, over the bands both
/// hold (at most [`MAX_SH_ORDER`]). Negative ringing of the truncated series is clamped to 0.
/// This is the shader's sum, written to be ported line by line.
pub fn radiance_sh(sh: &ShCoefficients, zonal_row: &[[f32; 3]], normal: Vec3) -> [f32; 3] {
    let bands = (sh.order() + 1).min(zonal_row.len()).min(MAX_SH_ORDER + 1);
    if bands == 0 || sh.coefficients.is_empty() {
        return [0.0; 3];
    }
    let order = bands - 1;
    let mut y = [0.0f32; sh_coefficient_count(MAX_SH_ORDER)];
    sh_basis_into(&sh_normalisation(), normal, order, &mut y);
    let mut radiance = [0.0f32; 3];
    for l in 0..=order {
        let mut band = [0.0f32; 3];
        for i in l * l..(l + 1) * (l + 1) {
            for c in 0..3 {
                band[c] += sh.coefficients[i][c] * y[i];
            }
        }
        for c in 0..3 {
            radiance[c] += zonal_row[l][c] * band[c];
        }
    }
    radiance.map(|v| v.max(0.0))
}

/// The reference for [`radiance_sh`]: the radiance (no view correction) of a point with unit
/// `normal` and curvature `curvature_per_mm` under `environment`, integrating `f/π · L_env`
/// directly. For a map, the sum over every texel of `f(κ, θ)/π · L · ΔΩ` with θ the angle
/// between the normal and the texel's centre direction (the same discrete map the projection
/// sees, so the difference to [`radiance_sh`] is the SH truncation alone). For a uniform sky,
/// the integral in the normal's own frame, `L · 2 ∫₀^π f(κ, θ) sin θ dθ` (the azimuth gives 2π),
/// by 8-point Gauss–Legendre on 360 panels.
pub fn radiance_brute_force(
    cdrf: &(impl Cdrf + Sync),
    curvature_per_mm: f32,
    normal: Vec3,
    environment: &Environment,
) -> [f32; 3] {
    let intensity = f64::from(environment.intensity);
    match &environment.radiance {
        EnvironmentRadiance::Uniform(radiance) => {
            let mut sum = [0.0f64; 3];
            let width = PI_F64 / ZONAL_PANELS as f64;
            for panel in 0..ZONAL_PANELS {
                let (a, b) = (panel as f64 * width, (panel + 1) as f64 * width);
                for_each_node(&GAUSS_LEGENDRE_8, a, b, |theta, w| {
                    let f = cdrf.reflectance(curvature_per_mm, theta as f32);
                    for c in 0..3 {
                        sum[c] += 2.0 * w * theta.sin() * f64::from(f[c]);
                    }
                });
            }
            std::array::from_fn(|c| (sum[c] * f64::from(radiance[c]) * intensity) as f32)
        }
        EnvironmentRadiance::Map(map) => {
            // The normal in the map's frame: rotating the environment by α is shading R_y(−α)·n.
            let local = Mat3::from_rotation_y(-environment.rotate_rad) * normal;
            let sum = (0..map.height)
                .into_par_iter()
                .map(|row| {
                    let solid_angle = map.texel_solid_angle(row);
                    let mut sum = [0.0f64; 3];
                    for column in 0..map.width {
                        let cos = local.dot(map.texel_direction(column, row)).clamp(-1.0, 1.0);
                        let f = cdrf.reflectance(curvature_per_mm, cos.acos());
                        let texel = map.texels[row * map.width + column];
                        for c in 0..3 {
                            sum[c] += f64::from(f[c]) * f64::from(texel[c]);
                        }
                    }
                    sum.map(|v| v * solid_angle)
                })
                .reduce(|| [0.0; 3], |a, b| std::array::from_fn(|c| a[c] + b[c]));
            sum.map(|v| (v / PI_F64 * intensity) as f32)
        }
    }
}

/// An equirectangular map of linear radiance (conventions in the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct EquirectMap {
    width: usize,
    height: usize,
    texels: Vec<[f32; 3]>,
}

impl EquirectMap {
    /// A map from its texels, row-major, row 0 at the top (the zenith).
    ///
    /// # Errors
    /// [`MapError::Shape`] for a zero side or a texel count that does not match;
    /// [`MapError::Texel`] for a NaN, infinite or negative value.
    pub fn new(width: usize, height: usize, texels: Vec<[f32; 3]>) -> Result<Self, MapError> {
        if width == 0 || height == 0 || width.checked_mul(height) != Some(texels.len()) {
            return Err(MapError::Shape {
                width,
                height,
                texels: texels.len(),
            });
        }
        for (index, texel) in texels.iter().enumerate() {
            if let Some(&value) = texel.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
                return Err(MapError::Texel {
                    column: index % width,
                    row: index / width,
                    value,
                });
            }
        }
        Ok(Self {
            width,
            height,
            texels,
        })
    }

    /// Reads the RGB channels of an OpenEXR file (alpha ignored) within the limits of
    /// [`crate::input_file`].
    ///
    /// # Errors
    /// [`EnvironmentError::Image`] for a missing, unreadable, non-EXR, empty or oversized file;
    /// [`EnvironmentError::Map`] for a NaN, infinite or negative texel. Both name the file.
    pub fn read_exr(path: impl AsRef<Path>) -> Result<Self, EnvironmentError> {
        let path = path.as_ref();
        let image = RgbaImage::read_exr(path)?;
        let texels = image.pixels.iter().map(|&[r, g, b, _]| [r, g, b]).collect();
        Self::new(image.width as usize, image.height as usize, texels).map_err(|error| {
            EnvironmentError::Map {
                path: path.to_owned(),
                error,
            }
        })
    }

    /// Columns.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The texels, `texels[row · width + column]`, linear radiance.
    pub fn texels(&self) -> &[[f32; 3]] {
        &self.texels
    }

    /// The unit direction (map frame, before rotation) of the centre of texel (`column`, `row`).
    pub fn texel_direction(&self, column: usize, row: usize) -> Vec3 {
        let u = (column as f64 + 0.5) / self.width as f64;
        let v = (row as f64 + 0.5) / self.height as f64;
        let (sin_v, cos_v) = (PI_F64 * v).sin_cos();
        let (sin_u, cos_u) = (2.0 * PI_F64 * u).sin_cos();
        Vec3::new(
            (sin_v * sin_u) as f32,
            cos_v as f32,
            (-sin_v * cos_u) as f32,
        )
    }

    /// The solid angle of a texel of `row`, steradians (exact; a row's texels alike).
    pub fn texel_solid_angle(&self, row: usize) -> f64 {
        let top = (PI_F64 * row as f64 / self.height as f64).cos();
        let bottom = (PI_F64 * (row + 1) as f64 / self.height as f64).cos();
        2.0 * PI_F64 / self.width as f64 * (top - bottom)
    }

    /// The texel (column, row) holding the direction `direction` (map frame; need not be
    /// unit length; the zero vector reads the zenith row).
    pub fn texel_at(&self, direction: Vec3) -> (usize, usize) {
        let d = direction.as_dvec3().normalize_or(glam::DVec3::Y);
        let u = (d.x.atan2(-d.z) / (2.0 * PI_F64)).rem_euclid(1.0);
        let v = d.y.clamp(-1.0, 1.0).acos() / PI_F64;
        let column = ((u * self.width as f64) as usize).min(self.width - 1);
        let row = ((v * self.height as f64) as usize).min(self.height - 1);
        (column, row)
    }
}

/// Where an environment's radiance comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum EnvironmentRadiance {
    /// The same linear radiance from every direction, per RGB channel.
    Uniform([f32; 3]),
    /// An equirectangular map.
    Map(EquirectMap),
}

/// What a scene file's `[environment]` says: `uniform = [r, g, b]` radiance or
/// `map = "sky.exr"`, times `intensity` (default 1), turned by `rotate_deg` (default 0) about
/// world +y. [`Environment::load`] reads it.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentDesc {
    /// The radiance source.
    pub source: EnvironmentSource,
    /// Multiplies every radiance (≥ 0).
    pub intensity: f32,
    /// Rotation about world +y, degrees, right-hand rule (see the [module docs](self)).
    pub rotate_deg: f32,
}

/// The source named by an [`EnvironmentDesc`].
#[derive(Clone, Debug, PartialEq)]
pub enum EnvironmentSource {
    /// Uniform linear radiance per RGB channel.
    Uniform([f32; 3]),
    /// An equirectangular linear-radiance OpenEXR file (already resolved against the scene
    /// file's folder).
    Map(PathBuf),
}

impl EnvironmentDesc {
    /// A uniform sky of `radiance`, intensity 1, no rotation.
    pub fn uniform(radiance: [f32; 3]) -> Self {
        Self {
            source: EnvironmentSource::Uniform(radiance),
            intensity: 1.0,
            rotate_deg: 0.0,
        }
    }

    /// The map at `path`, intensity 1, no rotation.
    pub fn map(path: impl Into<PathBuf>) -> Self {
        Self {
            source: EnvironmentSource::Map(path.into()),
            intensity: 1.0,
            rotate_deg: 0.0,
        }
    }

    /// With `intensity`.
    pub fn with_intensity(mut self, intensity: f32) -> Self {
        self.intensity = intensity;
        self
    }

    /// With `rotate_deg`.
    pub fn with_rotation_deg(mut self, rotate_deg: f32) -> Self {
        self.rotate_deg = rotate_deg;
        self
    }
}

/// Environment light: radiance from every direction (conventions in the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    radiance: EnvironmentRadiance,
    intensity: f32,
    rotate_rad: f32,
}

impl Environment {
    /// `radiance` times `intensity`, turned by `rotate_deg` about world +y.
    ///
    /// # Errors
    /// [`EnvironmentError::Parameter`] for a negative or non-finite intensity or uniform
    /// radiance, or a non-finite rotation.
    pub fn new(
        radiance: EnvironmentRadiance,
        intensity: f32,
        rotate_deg: f32,
    ) -> Result<Self, EnvironmentError> {
        let bad = |what, value| Err(EnvironmentError::Parameter { what, value });
        if !(intensity.is_finite() && intensity >= 0.0) {
            return bad("intensity", intensity);
        }
        if !rotate_deg.is_finite() {
            return bad("rotate_deg", rotate_deg);
        }
        if let EnvironmentRadiance::Uniform(rgb) = &radiance
            && let Some(&value) = rgb.iter().find(|v| !(v.is_finite() && **v >= 0.0))
        {
            return bad("uniform radiance", value);
        }
        Ok(Self {
            radiance,
            intensity,
            rotate_rad: rotate_deg.to_radians(),
        })
    }

    /// A uniform sky of `radiance`.
    ///
    /// # Errors
    /// As [`Environment::new`].
    pub fn uniform(radiance: [f32; 3]) -> Result<Self, EnvironmentError> {
        Self::new(EnvironmentRadiance::Uniform(radiance), 1.0, 0.0)
    }

    /// Reads the map (if any) and checks the parameters.
    ///
    /// # Errors
    /// As [`EquirectMap::read_exr`] and [`Environment::new`].
    pub fn load(desc: &EnvironmentDesc) -> Result<Self, EnvironmentError> {
        let radiance = match &desc.source {
            EnvironmentSource::Uniform(rgb) => EnvironmentRadiance::Uniform(*rgb),
            EnvironmentSource::Map(path) => EnvironmentRadiance::Map(EquirectMap::read_exr(path)?),
        };
        Self::new(radiance, desc.intensity, desc.rotate_deg)
    }

    /// The radiance source (before intensity and rotation).
    pub fn source(&self) -> &EnvironmentRadiance {
        &self.radiance
    }

    /// The intensity factor.
    pub fn intensity(&self) -> f32 {
        self.intensity
    }

    /// The rotation about world +y, radians.
    pub fn rotate_rad(&self) -> f32 {
        self.rotate_rad
    }

    /// The radiance arriving from world direction `direction` (nearest texel), times intensity.
    pub fn radiance(&self, direction: Vec3) -> [f32; 3] {
        let value = match &self.radiance {
            EnvironmentRadiance::Uniform(rgb) => *rgb,
            EnvironmentRadiance::Map(map) => {
                let (column, row) =
                    map.texel_at(Mat3::from_rotation_y(-self.rotate_rad) * direction);
                map.texels[row * map.width + column]
            }
        };
        value.map(|v| v * self.intensity)
    }

    /// The environment's SH coefficients up to `order`: analytic for a uniform sky
    /// (`L_00 = √(4π)·L`, the rest 0), for a map the sum over its texels of
    /// `L · Y_lm(R_y(α)·d) · ΔΩ` (exact texel solid angles, f64 sums, in parallel over rows).
    ///
    /// # Panics
    /// If `order` > [`MAX_SH_ORDER`].
    pub fn project_sh(&self, order: usize) -> ShCoefficients {
        assert!(order <= MAX_SH_ORDER, "SH order {order} > {MAX_SH_ORDER}");
        let count = sh_coefficient_count(order);
        let intensity = f64::from(self.intensity);
        let coefficients = match &self.radiance {
            EnvironmentRadiance::Uniform(rgb) => {
                let mut coefficients = vec![[0.0f32; 3]; count];
                let sqrt_4pi = (4.0 * PI_F64).sqrt();
                coefficients[0] = rgb.map(|v| (f64::from(v) * intensity * sqrt_4pi) as f32);
                coefficients
            }
            EnvironmentRadiance::Map(map) => {
                let k = sh_normalisation();
                let rotation = Mat3::from_rotation_y(self.rotate_rad);
                let sums = (0..map.height)
                    .into_par_iter()
                    .map(|row| {
                        let mut y = [0.0f32; sh_coefficient_count(MAX_SH_ORDER)];
                        let mut sums = vec![[0.0f64; 3]; count];
                        let solid_angle = map.texel_solid_angle(row);
                        for column in 0..map.width {
                            let direction = rotation * map.texel_direction(column, row);
                            sh_basis_into(&k, direction, order, &mut y);
                            let texel = map.texels[row * map.width + column];
                            for (sum, &basis) in sums.iter_mut().zip(&y[..count]) {
                                for c in 0..3 {
                                    sum[c] += f64::from(basis) * f64::from(texel[c]);
                                }
                            }
                        }
                        for sum in &mut sums {
                            *sum = sum.map(|v| v * solid_angle);
                        }
                        sums
                    })
                    .reduce(
                        || vec![[0.0f64; 3]; count],
                        |mut a, b| {
                            for (a, b) in a.iter_mut().zip(&b) {
                                *a = std::array::from_fn(|c| a[c] + b[c]);
                            }
                            a
                        },
                    );
                sums.into_iter()
                    .map(|s| s.map(|v| (v * intensity) as f32))
                    .collect()
            }
        };
        ShCoefficients { coefficients }
    }
}

/// Why an equirectangular map's data is unusable.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum MapError {
    /// A side is zero or the texels do not fill the map.
    #[error("{width} × {height} map with {texels} texels")]
    Shape {
        /// Columns.
        width: usize,
        /// Rows.
        height: usize,
        /// Texels given.
        texels: usize,
    },
    /// A texel is NaN, infinite or negative.
    #[error("texel (column {column}, row {row}) has radiance {value}: must be finite and ≥ 0")]
    Texel {
        /// Column of the texel.
        column: usize,
        /// Row of the texel (0 at the top).
        row: usize,
        /// The offending channel value.
        value: f32,
    },
}

/// Why an environment could not be loaded.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum EnvironmentError {
    /// The map file could not be read (missing, not an RGB OpenEXR, empty, too large); the
    /// message names the file.
    #[error("environment map {0}")]
    Image(ImageFileError),
    /// The map file holds unusable data.
    #[error("environment map {}: {error}", path.display())]
    Map {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        error: MapError,
    },
    /// A parameter is out of range.
    #[error("environment {what} = {value}: must be finite (and ≥ 0 for radiance and intensity)")]
    Parameter {
        /// Which parameter.
        what: &'static str,
        /// Its value.
        value: f32,
    },
}

// The message holds the cause's, which `source()` therefore does not repeat.
impl From<ImageFileError> for EnvironmentError {
    fn from(error: ImageFileError) -> Self {
        Self::Image(error)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_close(a: f32, b: f32, eps: f32, what: &str) {
        assert!(
            (a - b).abs() <= eps,
            "{what}: {a} vs {b} (difference {}, eps {eps})",
            (a - b).abs()
        );
    }

    #[test]
    fn basis_matches_the_closed_forms() {
        let d = Vec3::new(0.3, -0.5, 0.7).normalize();
        let y = sh_basis(d, 2);
        let expected = [
            0.282_094_8,
            0.488_602_5 * d.y,
            0.488_602_5 * d.z,
            0.488_602_5 * d.x,
            1.092_548_4 * d.x * d.y,
            1.092_548_4 * d.y * d.z,
            0.315_391_57 * (3.0 * d.z * d.z - 1.0),
            1.092_548_4 * d.x * d.z,
            0.546_274_2 * (d.x * d.x - d.y * d.y),
        ];
        for (i, (&a, &b)) in y.iter().zip(&expected).enumerate() {
            assert_close(a, b, 1e-6, &format!("Y[{i}]"));
        }
        assert_eq!(sh_index(2, -2), 4);
        assert_eq!(sh_index(2, 2), 8);
    }

    #[test]
    fn basis_is_orthonormal_and_obeys_the_addition_theorem() {
        let order = MAX_SH_ORDER;
        let count = sh_coefficient_count(order);
        // Gauss–Legendre in z (exact for polynomials of degree ≤ 2·order) × uniform φ.
        let mut gram = vec![0.0f64; count * count];
        let phis = 4 * order + 4;
        for panel in 0..4 {
            let (a, b) = (-1.0 + 0.5 * panel as f64, -0.5 + 0.5 * panel as f64);
            for_each_node(&GAUSS_LEGENDRE_8, a, b, |z, w| {
                for j in 0..phis {
                    let phi = 2.0 * PI_F64 * j as f64 / phis as f64;
                    let s = (1.0 - z * z).sqrt();
                    let d = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, z as f32);
                    let y = sh_basis(d, order);
                    let weight = w * 2.0 * PI_F64 / phis as f64;
                    for p in 0..count {
                        for q in 0..count {
                            gram[p * count + q] += weight * f64::from(y[p]) * f64::from(y[q]);
                        }
                    }
                }
            });
        }
        for p in 0..count {
            for q in 0..count {
                let expected = if p == q { 1.0 } else { 0.0 };
                assert!(
                    (gram[p * count + q] - expected).abs() < 2e-5,
                    "<Y{p}, Y{q}> = {}",
                    gram[p * count + q]
                );
            }
        }
        let (a, b) = (
            Vec3::new(0.2, 0.9, -0.4).normalize(),
            Vec3::new(-0.7, 0.1, 0.6).normalize(),
        );
        let (ya, yb) = (sh_basis(a, order), sh_basis(b, order));
        let mut p = vec![0.0; order + 1];
        legendre(f64::from(a.dot(b)), &mut p);
        for l in 0..=order {
            let sum: f32 = (l * l..(l + 1) * (l + 1)).map(|i| ya[i] * yb[i]).sum();
            let expected = ((2 * l + 1) as f64 / (4.0 * PI_F64) * p[l]) as f32;
            assert_close(sum, expected, 2e-6, &format!("addition theorem, l = {l}"));
        }
    }

    #[test]
    fn texel_directions_round_trip_and_solid_angles_sum_to_4pi() {
        let map = EquirectMap::new(16, 8, vec![[1.0; 3]; 128]).unwrap();
        let mut total = 0.0;
        for row in 0..8 {
            for column in 0..16 {
                assert_eq!(
                    map.texel_at(map.texel_direction(column, row)),
                    (column, row)
                );
                total += map.texel_solid_angle(row);
            }
        }
        assert!((total - 4.0 * PI_F64).abs() < 1e-12, "{total}");
        // The documented landmarks: u = 0 −z, ¼ +x, ½ +z, ¾ −x; row 0 up.
        assert_eq!(map.texel_at(-Vec3::Z), (0, 4));
        assert_eq!(map.texel_at(Vec3::X), (4, 4));
        assert_eq!(map.texel_at(Vec3::Z), (8, 4));
        assert_eq!(map.texel_at(-Vec3::X), (12, 4));
        assert_eq!(map.texel_at(Vec3::Y).1, 0);
        assert_eq!(map.texel_at(-Vec3::Y).1, 7);
    }
}
