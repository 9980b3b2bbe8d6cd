//! An offscreen target for [`crate::Renderer`]: multisampled colour (when the target asks for
//! samples), a single-sampled resolved colour texture the host can sample or copy, and depth.
//!
//! Headless rendering reads the resolved texture back; an embedding UI (the viewer) renders
//! into it and samples it in its own pass.

use crate::error::TargetError;
use crate::target::TargetDesc;

/// The depth format used when the [`TargetDesc`] names none.
pub const DEFAULT_DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Colour (resolved, and multisampled when `sample_count > 1`) and depth textures of one size.
///
/// The resolved texture can be a render attachment, bound for sampling and copied from.
#[derive(Debug)]
pub struct OffscreenTarget {
    multisampled: Option<wgpu::TextureView>,
    resolved: wgpu::Texture,
    resolved_view: wgpu::TextureView,
    depth: wgpu::TextureView,
    width: u32,
    height: u32,
}

impl OffscreenTarget {
    /// Textures for `target` of `width` × `height` pixels, with the size checked against the
    /// device's limits and wgpu's validation and out-of-memory errors captured.
    ///
    /// # Errors
    /// [`TargetError::Size`] for a zero or oversized side, [`TargetError::Create`] when the
    /// device refuses the textures or runs out of memory.
    pub fn try_new(
        device: &wgpu::Device,
        target: &TargetDesc,
        width: u32,
        height: u32,
    ) -> Result<Self, TargetError> {
        let max = device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(TargetError::Size { width, height, max });
        }
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let created = Self::new(device, target, width, height);
        let memory = pollster::block_on(memory.pop());
        let validation = pollster::block_on(validation.pop());
        match memory.or(validation) {
            None => Ok(created),
            Some(error) => Err(TargetError::Create {
                width,
                height,
                samples: target.sample_count,
                message: error.to_string(),
            }),
        }
    }

    /// Textures for `target` of `width` × `height` pixels (each at least 1: callers check
    /// sizes against the device's limits; wgpu rejects a zero or oversized texture, which
    /// without an error scope reaches the device's uncaptured-error handler —
    /// [`OffscreenTarget::try_new`] checks and captures).
    pub fn new(device: &wgpu::Device, target: &TargetDesc, width: u32, height: u32) -> Self {
        let texture = |label, format, samples, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let attachment = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let resolved = texture(
            "cdrf offscreen colour",
            target.color_format,
            1,
            attachment | wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let multisampled = (target.sample_count > 1).then(|| {
            texture(
                "cdrf offscreen colour (multisampled)",
                target.color_format,
                target.sample_count,
                attachment,
            )
            .create_view(&Default::default())
        });
        let depth = texture(
            "cdrf offscreen depth",
            target.depth_format.unwrap_or(DEFAULT_DEPTH_FORMAT),
            target.sample_count,
            attachment,
        )
        .create_view(&Default::default());
        Self {
            multisampled,
            resolved_view: resolved.create_view(&Default::default()),
            resolved,
            depth,
            width,
            height,
        }
    }

    /// Width and height in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The single-sampled colour texture (the resolve target when multisampled).
    pub fn resolved(&self) -> &wgpu::Texture {
        &self.resolved
    }

    /// A view of [`OffscreenTarget::resolved`].
    pub fn resolved_view(&self) -> &wgpu::TextureView {
        &self.resolved_view
    }

    /// Begins a pass: colour cleared to `clear` (resolved into the single-sampled texture when
    /// multisampled), depth cleared to 1 (the far plane of a `Less` test). Record with
    /// [`crate::Renderer::render`]; the renderer's [`TargetDesc`] must be the one given to
    /// [`OffscreenTarget::new`], with a depth format.
    pub fn begin_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        clear: wgpu::Color,
    ) -> wgpu::RenderPass<'e> {
        let (view, resolve_target) = match &self.multisampled {
            Some(multisampled) => (multisampled, Some(&self.resolved_view)),
            None => (&self.resolved_view, None),
        };
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("cdrf offscreen pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(clear),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }
}
