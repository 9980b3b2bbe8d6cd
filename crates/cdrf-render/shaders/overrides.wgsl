// The pipeline-overridable constants: each pipeline of the shading, vertex-terms and
// inter-reflection passes compiles to one straight-line shader (docs/shading.md).

// MODEL_MEASURED, MODEL_GAUSSIAN_LUT, MODEL_GAUSSIAN_ANALYTIC, MODEL_LAMBERT, MODEL_CURVATURE
// (generated from src/constants.rs).
override MODEL: u32 = 0u;
// true: bilinear filtering by hand (four texel loads, f32 weights); false: the sampler's.
override MANUAL_FILTERING: bool = false;
// true when the target is an 8-bit UNORM format that is not sRGB: encode in the shader.
override ENCODE_SRGB: bool = false;
// The non-local terms (all false: the poster's local model).
override SHADOWS: bool = false;
override TRANSMISSION: bool = false;
override INTERREFLECTION: bool = false;
override SUBSURFACE: bool = false;
// Whether the frame renders light maps (shadow maps and subsurface pyramids) that the terms
// read: cdrf_core::light::NonLocal::light_maps on the Rust side. Not set by the pipelines.
override LIGHT_MAPS: bool = SHADOWS || TRANSMISSION || SUBSURFACE;
