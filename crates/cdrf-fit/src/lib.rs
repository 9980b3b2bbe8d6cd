//! `cdrf-fit`: turns photographs of spheres lit by one directional light into a measured
//! curvature-dependent reflectance function (CDRF) look-up table.
//!
//! The pipeline ([`fit`]): [`dataset`] (the manifest), [`image_io`] (linear radiance),
//! [`sphere`] (silhouette, θ and φ per pixel), [`curves`] (f(θ; κ) and the view correction),
//! [`table`] (the `CdrfLut`; [`tails`] continues a shadow side past what the photographs
//! measured with the diffusion profile's fall-off), [`gaussian_fit`] (Kubo's Gaussian CDRF,
//! whose σ is also the scattering length of the table's translucency), [`transmission`] (the
//! light through the material, `T(d, μ) = A·μ·exp(−d/ℓ)`, from the spheres' shadow sides),
//! [`evaluate`] (errors) and
//! [`outputs`] / [`plot`] (the files).
//!
//! Without photographs, [`preset`] makes the same two files the renderer reads (`measured.exr`,
//! `gaussian.toml`) from a named medium or scattering coefficients (the `cdrf-preset` binary).
//! [`simulation`] makes virtual photographs of spheres of a scattering medium, such as the named
//! ones of [`media`], which the preset fits as photographs.
//!
//! ```
//! use cdrf_fit::dataset::Dataset;
//! use cdrf_fit::image_io::load_linear_image;
//!
//! let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/wax-spheres");
//! let dataset = Dataset::load(&dir)?;
//! let sphere = &dataset.spheres[0];
//! let image = load_linear_image(&sphere.image, sphere.color_space, sphere.exposure)?;
//! println!("{} mm: {} × {} px", sphere.radius_mm, image.width, image.height);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#[cfg(feature = "raw")]
mod camera_raw;
pub mod circles;
pub mod curves;
pub mod dataset;
pub mod diffusion;
pub mod evaluate;
pub mod fit;
pub mod gaussian_fit;
pub mod highlight;
pub mod image_io;
pub mod media;
pub mod outputs;
pub mod photographs;
pub mod plot;
pub mod preset;
pub mod simulation;
pub mod sphere;
pub mod table;
pub mod tails;
pub mod transmission;

pub use fit::{Fit, FitError, FitOptions, fit_dataset};
