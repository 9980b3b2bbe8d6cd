//! cdrf-core: curvature-dependent reflectance functions (CDRF) without a GPU.
//!
//! A CDRF f(κ, θ) says how bright a translucent surface point is given its mean curvature κ
//! (mm⁻¹) and the angle θ between its normal and the light. This crate holds what every cdrf
//! tool shares: the table [`CdrfLut`] and its OpenEXR file, non-uniform Catmull-Rom splines,
//! the analytic models (Kubo's Gaussian CDRF, ring pre-integration of diffusion profiles),
//! meshes and per-vertex curvature. Tables store **π·L/E**: a white Lambertian surface is
//! `max(cos θ, 0)`, and radiance is `L = E/π · f(κ, θ) · g(θ, φ)`.
//!
//! ```
//! use cdrf_core::gaussian::GaussianCdrf;
//! use cdrf_core::{CdrfLut, CurvatureAxis, Filter, read_lut, write_lut};
//!
//! // Kubo's Gaussian CDRF (σ per RGB channel, mm) tabulated for spheres of radius 50…15 mm.
//! let model = GaussianCdrf::new([10.5, 6.9, 4.7])?;
//! let lut = CdrfLut::tabulate(&model, CurvatureAxis::from_radii_mm(50.0, 15.0, 32), 256)?
//!     .with_provenance("model", "Gaussian CDRF, sigma_mm = [10.5, 6.9, 4.7]");
//!
//! // Past the terminator (θ = 100°) a 15 mm sphere still glows, red most.
//! let f = lut.sample(1.0 / 15.0, 100_f32.to_radians(), Filter::CatmullRom);
//! assert!(f.x > f.z && f.z > 0.0);
//!
//! // The table is an OpenEXR file any image tool opens.
//! let path = std::env::temp_dir().join(format!("cdrf-doc-{}.exr", std::process::id()));
//! write_lut(&lut, &path)?;
//! assert_eq!(read_lut(&path)?, lut);
//! # std::fs::remove_file(&path)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod atomic;
pub mod azimuth;
pub mod block_error;
pub mod catmull_rom;
pub mod curvature;
pub mod diffusion;
pub mod environment;
pub mod gaussian;
pub mod gaussian_file;
pub mod image_file;
pub mod input_file;
pub mod light;
pub mod linear;
pub mod lut;
pub mod lut_file;
pub mod mesh;
pub mod patches;
pub mod presets;
pub mod scene;
pub mod shading;
pub mod specular;
pub mod subsurface;
pub mod translucency;

/// The math types of the public API (positions, normals, matrices).
pub use glam;

pub use curvature::{
    Curvature, CurvatureError, CurvatureOptions, curvature_per_mm, directional_curvature_per_mm,
    mean_curvature_per_mm,
};
pub use gaussian_file::{GaussianParameters, read_gaussian, write_gaussian};
pub use image_file::RgbaImage;
pub use lut::{Cdrf, CdrfLut, CurvatureAxis, Filter, ViewCorrection};
pub use lut_file::{read_lut, write_lut};
pub use mesh::{LoadError, Mesh, RepairReport};
pub use scene::{Scene, SceneAssets};
pub use shading::ShadingModel;
pub use translucency::{Translucency, TransmissionProfile};
