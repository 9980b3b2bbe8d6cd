//! cdrf-core: curvature-dependent reflectance functions (CDRF) without a GPU.
//!
//! (Crate docs with a runnable example are written once the modules settle.)

pub mod atomic;
pub mod catmull_rom;
pub mod curvature;
pub mod gaussian;
pub mod lut;
pub mod lut_file;
pub mod mesh;

pub use lut::{Cdrf, CdrfLut, CurvatureAxis, Filter, ViewCorrection};
pub use lut_file::{read_lut, write_lut};
