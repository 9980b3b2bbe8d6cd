//! Materials on the GPU: the shading model, its tables as textures and its parameters.

use cdrf_core::diffusion::FarField;
use cdrf_core::environment::ZonalTable;
use cdrf_core::gaussian::GaussianCdrf;
use cdrf_core::glam::Vec3;
use cdrf_core::specular::SpecularLayer;
use cdrf_core::subsurface::SubsurfaceTables;
use cdrf_core::translucency::penumbra_tap_weights;
use cdrf_core::{CdrfLut, CurvatureAxis, ShadingModel, ViewCorrection};
use wgpu::util::DeviceExt;

use crate::constants::{
    ENVIRONMENT_SH_BANDS, ENVIRONMENT_SH_ORDER, ENVIRONMENT_ZONAL_ROWS, Model,
    PENUMBRA_DISC_PER_WIDTH, PENUMBRA_TAPS, SUBSURFACE_KERNEL_SAMPLES,
};
use crate::error::MaterialError;
use crate::gpu_data::rgba16f_texels;
use crate::gpu_types::{GpuMaterial, GpuPenumbraTap, SHADING_STAGES, uniform_layout_entry};
use crate::target::{GaussianEvaluation, Options};

/// How a material shades: the shading model and its data.
#[derive(Clone, Copy, Debug)]
pub enum MaterialDesc<'a> {
    /// The measured CDRF: `LUT(κ, θ) · g(θ, φ)` from a table (cdrf-fit's `measured.exr`).
    Measured {
        /// The table with its view correction.
        lut: &'a CdrfLut,
    },
    /// Kubo's Gaussian CDRF with a view correction (evaluated as [`Options::gaussian`] says).
    Gaussian {
        /// σ and scale per channel.
        model: &'a GaussianCdrf,
        /// g(θ, φ), usually the one of the measured table fitted from the same photographs.
        view_correction: &'a ViewCorrection,
    },
    /// Lambert: `π·L/E = albedo · max(cos θ, 0)`, no view dependence.
    Lambert {
        /// Albedo per RGB channel.
        albedo: [f32; 3],
    },
    /// Debug view: the curvature colour-mapped (cool–warm) from `range_per_mm[0]` (blue) to
    /// `range_per_mm[1]` (red); not radiance.
    Curvature {
        /// κ at the colour map's ends, mm⁻¹.
        range_per_mm: [f32; 2],
    },
}

impl MaterialDesc<'static> {
    /// A material built into the crates ([`cdrf_core::presets`]: `wax`, `skin1`, `marble`,
    /// `wholemilk`; case-insensitive): the measured model with a table fitted to simulated
    /// spheres of the medium, decoded once on first use.
    ///
    /// # Errors
    /// [`cdrf_core::presets::PresetError::Unknown`] listing the built-in names.
    pub fn preset(name: &str) -> Result<Self, cdrf_core::presets::PresetError> {
        Ok(MaterialDesc::Measured {
            lut: cdrf_core::presets::lut(name)?,
        })
    }
}

impl MaterialDesc<'_> {
    /// The model this is.
    pub fn model(&self) -> ShadingModel {
        match self {
            MaterialDesc::Measured { .. } => ShadingModel::Measured,
            MaterialDesc::Gaussian { .. } => ShadingModel::Gaussian,
            MaterialDesc::Lambert { .. } => ShadingModel::Lambert,
            MaterialDesc::Curvature { .. } => ShadingModel::Curvature,
        }
    }
}

/// The material's zonal coefficients a_l(κ) of the environment light (`None`: the curvature
/// view), [`ENVIRONMENT_ZONAL_ROWS`] rows over its table's curvature axis (Lambert: one row),
/// integrated from the table the shader reads: the measured one, or for the Gaussian CDRF its
/// tabulation `table` (cheaper to integrate than the analytic model, which only
/// [`GaussianEvaluation::Analytic`] materials integrate).
fn environment_zonal_table(
    desc: &MaterialDesc<'_>,
    table: Option<&CdrfLut>,
    options: &Options,
) -> Option<ZonalTable> {
    let rows = |min_per_mm: f32, max_per_mm: f32| CurvatureAxis {
        min_per_mm,
        max_per_mm,
        count: ENVIRONMENT_ZONAL_ROWS,
    };
    let from_table = |lut: &CdrfLut| {
        let axis = lut.curvature_axis();
        ZonalTable::tabulate(
            lut,
            rows(axis.min_per_mm, axis.max_per_mm),
            ENVIRONMENT_SH_ORDER,
        )
    };
    Some(match *desc {
        MaterialDesc::Curvature { .. } => return None,
        MaterialDesc::Lambert { albedo } => ZonalTable::lambert(albedo, ENVIRONMENT_SH_ORDER),
        MaterialDesc::Measured { lut } => from_table(lut),
        MaterialDesc::Gaussian { model, .. } => match table {
            Some(tabulated) => from_table(tabulated),
            None => ZonalTable::tabulate(
                model,
                rows(0.0, options.gaussian_lut_max_curvature_per_mm),
                ENVIRONMENT_SH_ORDER,
            ),
        },
    })
}

/// A material's model and bind group (group 1).
pub(crate) struct GpuMaterialEntry {
    pub(crate) model: Model,
    pub(crate) bind_group: wgpu::BindGroup,
    /// The parameters as uploaded (the specular layer rewrites them).
    uniforms: GpuMaterial,
    buffer: wgpu::Buffer,
    /// The model's total diffuse reflectance facing the light on its flattest surface, per
    /// channel: what the specular layer's boundary loss is computed from.
    matched_albedo: [f32; 3],
}

impl GpuMaterialEntry {
    /// Turns the first-surface reflection on (`Some`) or off, in the uniforms at once.
    pub(crate) fn set_specular(
        &mut self,
        queue: &wgpu::Queue,
        layer: Option<SpecularLayer>,
    ) -> Result<(), MaterialError> {
        if layer.is_some() && self.model == Model::Curvature {
            return Err(MaterialError::Parameter {
                what: "specular layer",
                value: Vec::new(),
                requirement: "the curvature view is not radiance",
            });
        }
        let u = &mut self.uniforms;
        match layer {
            Some(layer) => {
                u.specular_on = 1;
                u.specular_roughness_alpha = layer.roughness_alpha();
                u.specular_ior = layer.ior();
                u.subsurface_transmission =
                    Vec3::from_array(layer.subsurface_transmission(self.matched_albedo));
            }
            None => {
                u.specular_on = 0;
                u.subsurface_transmission = Vec3::ONE;
            }
        }
        queue.write_buffer(&self.buffer, 0, bytemuck::bytes_of(&self.uniforms));
        Ok(())
    }
}

/// What every material's bind group is made with.
pub(crate) struct MaterialFactory {
    pub(crate) layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    max_texture_side: u32,
}

impl MaterialFactory {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        // The tables are read per pixel, and per vertex by the vertex terms pass (the
        // inter-reflection's response to the bounced light, the gather's tables).
        let texture = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: SHADING_STAGES,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: true },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf material layout"),
            entries: &[
                uniform_layout_entry::<GpuMaterial>(0, SHADING_STAGES, false),
                texture(1),
                texture(2),
                wgpu::BindGroupLayoutEntry {
                    binding: 3,
                    visibility: SHADING_STAGES,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
                // The subsurface gather's F_sphere(κ, θ) and its gain in shadow s(κ, θ).
                texture(4),
                texture(5),
            ],
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("cdrf lut sampler"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Self {
            layout,
            sampler,
            max_texture_side: device.limits().max_texture_dimension_2d,
        }
    }

    /// Uploads a material: its table(s) as `Rgba16Float` textures and its parameters.
    pub(crate) fn create(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        options: &Options,
        desc: &MaterialDesc<'_>,
    ) -> Result<GpuMaterialEntry, MaterialError> {
        let identity = ViewCorrection::identity();
        let mut uniforms = GpuMaterial {
            lambert_albedo: Vec3::ONE,
            gaussian_scale: Vec3::ONE,
            transmission_length_mm: Vec3::ONE,
            subsurface_transmission: Vec3::ONE,
            ..bytemuck::Zeroable::zeroed()
        };
        let tabulated;
        // R_far(d) and F_sphere(κ, θ) of the subsurface gather (none: zero, no gather).
        let mut subsurface = None;
        let model = Model::new(desc.model(), options.gaussian);
        let (lut, view) = match *desc {
            MaterialDesc::Measured { lut } => {
                if let Some(profile) = lut.diffusion_profile() {
                    let far = FarField::new(profile, f64::from(options.subsurface_cut_mm));
                    if !far.is_empty() {
                        let tables = SubsurfaceTables::new(&far, lut, SUBSURFACE_KERNEL_SAMPLES);
                        uniforms.subsurface_reach_mm = tables.reach_mm;
                        uniforms.subsurface_cut_mm = far.cut_mm() as f32;
                        uniforms.subsurface_entry_cosine_power = far.entry_cosine_power() as f32;
                        for (texel, value) in
                            uniforms.subsurface_kernel.iter_mut().zip(&tables.kernel)
                        {
                            *texel = [value.x, value.y, value.z, 0.0];
                        }
                        // The penumbra's tap weights with the gather, over the disc its
                        // spiral covers (penumbra.wgsl).
                        let shares = profile.near_field_ring_shares(
                            far.cut_mm(),
                            f64::from(PENUMBRA_DISC_PER_WIDTH) * far.cut_mm(),
                            PENUMBRA_TAPS,
                        );
                        for (tap, share) in uniforms.near_field_taps.iter_mut().zip(shares) {
                            tap.weight = Vec3::from_array(share);
                        }
                        subsurface = Some(tables);
                    }
                }
                // Non-local terms: penumbra width and T(d, μ) (none: a hard edge and no
                // transmission).
                if let Some(translucency) = lut.translucency() {
                    uniforms.scattering_length_mm =
                        Vec3::from_array(translucency.scattering_length_mm);
                    let transmission = translucency.transmission;
                    uniforms.transmission_amplitude = Vec3::from_array(transmission.amplitude);
                    uniforms.transmission_entry_cosine_power = transmission.entry_cosine_power;
                    uniforms.transmission_length_mm = Vec3::from_array(transmission.length_mm);
                }
                (Some(lut), lut.view_correction())
            }
            MaterialDesc::Gaussian {
                model,
                view_correction,
            } => {
                // Kubo's σ is the terminator's width in mm: the same sideways spread.
                uniforms.scattering_length_mm = Vec3::from_array(model.sigma_mm());
                match options.gaussian {
                    GaussianEvaluation::Lut => {
                        tabulated = tabulate_gaussian(model, options)?;
                        (Some(&tabulated), view_correction)
                    }
                    GaussianEvaluation::Analytic => {
                        uniforms.sigma_mm = Vec3::from_array(model.sigma_mm());
                        uniforms.gaussian_scale = Vec3::from_array(model.scale());
                        (None, view_correction)
                    }
                }
            }
            MaterialDesc::Lambert { albedo } => {
                check_finite_non_negative("albedo", &albedo)?;
                uniforms.lambert_albedo = Vec3::from_array(albedo);
                (None, &identity)
            }
            MaterialDesc::Curvature { range_per_mm } => {
                let [low, high] = range_per_mm;
                if !(low.is_finite() && high.is_finite() && high > low) {
                    return Err(MaterialError::Parameter {
                        what: "curvature range (mm⁻¹)",
                        value: range_per_mm.to_vec(),
                        requirement: "must be finite with low < high",
                    });
                }
                uniforms.curvature_range_per_mm = range_per_mm;
                (None, &identity)
            }
        };

        uniforms.penumbra_taps = penumbra_taps(uniforms.scattering_length_mm);

        let lut_texture = match lut {
            Some(lut) => {
                let axis = lut.curvature_axis();
                uniforms.lut_curvature_per_mm = [axis.min_per_mm, axis.max_per_mm];
                uniforms.lut_size = [lut.theta_count() as f32, axis.count as f32];
                self.upload_table(
                    device,
                    queue,
                    "cdrf lut",
                    lut.theta_count(),
                    axis.count,
                    lut.radiance(),
                )?
            }
            None => {
                uniforms.lut_size = [1.0, 1.0];
                self.upload_table(device, queue, "cdrf lut (unused)", 1, 1, &[Vec3::ONE])?
            }
        };
        let view_layers = view.curvature_axis();
        let view_texture = self.upload_table(
            device,
            queue,
            "cdrf view correction",
            view.phi_count(),
            view.theta_count() * view_layers.count,
            view.values(),
        )?;
        uniforms.view_size = [view.phi_count() as f32, view.theta_count() as f32];
        uniforms.view_curvature_per_mm = [view_layers.min_per_mm, view_layers.max_per_mm];
        uniforms.view_layers = view_layers.count as f32;
        // The table's blocks of rows (bindings.wgsl's lut_blocks): F_sphere (what the gather
        // replaces; 0 without a diffusion profile), then the flow ℓ·(−∂ ln f/∂θ) of the view's
        // azimuth.
        let blocks_texture = match lut {
            Some(lut) => {
                let mut rows = match &subsurface {
                    Some(tables) => tables.sphere.clone(),
                    None => vec![Vec3::ZERO; lut.radiance().len()],
                };
                rows.extend(lut.flow_mm_per_rad());
                self.upload_table(
                    device,
                    queue,
                    "cdrf table blocks",
                    lut.theta_count(),
                    2 * lut.curvature_axis().count,
                    &rows,
                )?
            }
            None => self.upload_table(
                device,
                queue,
                "cdrf table blocks (unused)",
                1,
                1,
                &[Vec3::ZERO],
            )?,
        };
        let gain_texture = match &subsurface {
            Some(tables) => self.upload_table(
                device,
                queue,
                "cdrf subsurface gain",
                tables.columns,
                tables.rows,
                &tables.gain,
            )?,
            None => self.upload_table(
                device,
                queue,
                "cdrf subsurface gain (unused)",
                1,
                1,
                &[Vec3::ONE],
            )?,
        };

        if let Some(table) = environment_zonal_table(desc, lut, options) {
            let rows = &table.curvatures_per_mm;
            uniforms.environment_curvature_per_mm = [rows[0], rows[rows.len() - 1]];
            for (row, slots) in uniforms
                .environment_zonal
                .chunks_exact_mut(ENVIRONMENT_SH_BANDS)
                .enumerate()
            {
                let source = table.row(row.min(table.row_count() - 1));
                for (slot, a) in slots.iter_mut().zip(source) {
                    *slot = [a[0], a[1], a[2], 0.0];
                }
            }
        }
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cdrf material uniforms"),
            contents: bytemuck::bytes_of(&uniforms),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let lut_view = lut_texture.create_view(&Default::default());
        let view_view = view_texture.create_view(&Default::default());
        let blocks_view = blocks_texture.create_view(&Default::default());
        let gain_view = gain_texture.create_view(&Default::default());
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cdrf material"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&lut_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&view_view),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::Sampler(&self.sampler),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&blocks_view),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(&gain_view),
                },
            ],
        });
        let matched_albedo = match *desc {
            MaterialDesc::Measured { lut } => lut.flat_albedo(),
            MaterialDesc::Gaussian { model, .. } => model.scale(),
            MaterialDesc::Lambert { albedo } => albedo,
            MaterialDesc::Curvature { .. } => [1.0; 3],
        };
        Ok(GpuMaterialEntry {
            model,
            bind_group,
            uniforms,
            buffer,
            matched_albedo,
        })
    }

    fn upload_table(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        label: &'static str,
        width: usize,
        height: usize,
        values: &[Vec3],
    ) -> Result<wgpu::Texture, MaterialError> {
        let max = self.max_texture_side;
        if width > max as usize || height > max as usize {
            return Err(MaterialError::TooLarge {
                what: label,
                width,
                height,
                max,
            });
        }
        Ok(device.create_texture_with_data(
            queue,
            &wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: width as u32,
                    height: height as u32,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba16Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            &rgba16f_texels(values),
        ))
    }
}

/// The Gaussian CDRF as a table (a few milliseconds), on the axes [`Options`] gives.
fn tabulate_gaussian(model: &GaussianCdrf, options: &Options) -> Result<CdrfLut, MaterialError> {
    let axis = CurvatureAxis {
        min_per_mm: 0.0,
        max_per_mm: options.gaussian_lut_max_curvature_per_mm,
        count: options.gaussian_lut_rows as usize,
    };
    Ok(CdrfLut::tabulate(
        model,
        axis,
        options.gaussian_lut_columns as usize,
    )?)
}

fn check_finite_non_negative(what: &'static str, values: &[f32]) -> Result<(), MaterialError> {
    if values.iter().all(|v| v.is_finite() && *v >= 0.0) {
        Ok(())
    } else {
        Err(MaterialError::Parameter {
            what,
            value: values.to_vec(),
            requirement: "must be finite and ≥ 0",
        })
    }
}

/// Each penumbra tap's Gaussian weight per channel (see
/// [`penumbra_tap_weights`](cdrf_core::translucency::penumbra_tap_weights)).
fn penumbra_taps(scattering_length_mm: Vec3) -> [GpuPenumbraTap; PENUMBRA_TAPS] {
    penumbra_tap_weights::<PENUMBRA_TAPS>(scattering_length_mm)
        .map(|weight| GpuPenumbraTap { weight, _pad0: 0.0 })
}
