//! Reading a texture back to the CPU: the one implementation the headless renders, the viewer's
//! screenshots and the tests share.

use cdrf_core::RgbaImage;
use thiserror::Error;

/// Why a read-back failed.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ReadbackError {
    /// The format has no fixed texel size (compressed, or depth/stencil).
    #[error("cannot read back {format:?} textures")]
    Format {
        /// The texture's format.
        format: wgpu::TextureFormat,
    },
    /// Mapping the buffer failed (e.g. out of memory for a large image).
    #[error("mapping the {width} × {height} read-back buffer: {message}")]
    Map {
        /// Texels per row.
        width: u32,
        /// Rows.
        height: u32,
        /// What wgpu said.
        message: String,
    },
    /// The read-back buffer would exceed the device's largest buffer.
    #[error(
        "reading back {width} × {height} texels needs a {bytes}-byte buffer; \
         the device allows {max_bytes} bytes"
    )]
    TooLarge {
        /// Texels per row.
        width: u32,
        /// Rows.
        height: u32,
        /// The buffer's size (rows padded to 256 bytes).
        bytes: u64,
        /// The device's `max_buffer_size`.
        max_bytes: u64,
    },
    /// The device could not create the read-back buffer (out of memory or refused).
    #[error("creating the {width} × {height} read-back buffer ({bytes} bytes): {message}")]
    Allocate {
        /// Texels per row.
        width: u32,
        /// Rows.
        height: u32,
        /// The buffer's size.
        bytes: u64,
        /// What wgpu said.
        message: String,
    },
    /// Waiting for the GPU failed.
    #[error("waiting for the GPU: {0}")]
    Poll(wgpu::PollError),
}

// The message holds the cause's, which `source()` therefore does not repeat.
impl From<wgpu::PollError> for ReadbackError {
    fn from(error: wgpu::PollError) -> Self {
        Self::Poll(error)
    }
}

/// Bytes of the buffer that reads back a `width` × `height` texture of `texel_bytes` bytes a
/// texel (rows padded to [`wgpu::COPY_BYTES_PER_ROW_ALIGNMENT`]).
pub fn readback_bytes(width: u32, height: u32, texel_bytes: u32) -> u64 {
    (u64::from(width) * u64::from(texel_bytes))
        .next_multiple_of(u64::from(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT))
        * u64::from(height)
}

/// A copy of a texture's first mip level and layer on its way into a mappable buffer: record it
/// with [`TextureReadback::record`], submit the encoder, then [`TextureReadback::read`].
pub struct TextureReadback {
    buffer: wgpu::Buffer,
    padded_bytes_per_row: u32,
    bytes_per_row: u32,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
}

impl TextureReadback {
    /// Records the copy of `texture` (usage `COPY_SRC`) into `encoder`.
    ///
    /// # Errors
    /// [`ReadbackError::Format`] for a format without a fixed texel size,
    /// [`ReadbackError::TooLarge`] beyond the device's `max_buffer_size`,
    /// [`ReadbackError::Allocate`] when the device cannot create the buffer.
    pub fn record(
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        texture: &wgpu::Texture,
    ) -> Result<Self, ReadbackError> {
        let format = texture.format();
        let texel_bytes = format
            .block_copy_size(None)
            .filter(|_| format.block_dimensions() == (1, 1))
            .ok_or(ReadbackError::Format { format })?;
        let (width, height) = (texture.width(), texture.height());
        let bytes_per_row = width * texel_bytes;
        let padded_bytes_per_row =
            bytes_per_row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let bytes = readback_bytes(width, height, texel_bytes);
        let max_bytes = device.limits().max_buffer_size;
        if bytes > max_bytes {
            return Err(ReadbackError::TooLarge {
                width,
                height,
                bytes,
                max_bytes,
            });
        }
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf readback"),
            size: bytes,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let memory = pollster::block_on(memory.pop());
        let validation = pollster::block_on(validation.pop());
        if let Some(error) = memory.or(validation) {
            return Err(ReadbackError::Allocate {
                width,
                height,
                bytes,
                message: error.to_string(),
            });
        }
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_bytes_per_row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
        );
        Ok(Self {
            buffer,
            padded_bytes_per_row,
            bytes_per_row,
            width,
            height,
            format,
        })
    }

    /// Texels per row and rows.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Waits for the GPU (the encoder holding the copy must have been submitted) and returns
    /// the texels row by row, top row first, without row padding, in the texture's own byte
    /// layout.
    ///
    /// # Errors
    /// [`ReadbackError::Map`] or [`ReadbackError::Poll`].
    pub fn read(self, device: &wgpu::Device) -> Result<Vec<u8>, ReadbackError> {
        let (sender, receiver) = std::sync::mpsc::channel();
        self.buffer
            .map_async(wgpu::MapMode::Read, .., move |result| {
                let _ = sender.send(result);
            });
        device.poll(wgpu::PollType::wait_indefinitely())?;
        let map_error = |message: String| ReadbackError::Map {
            width: self.width,
            height: self.height,
            message,
        };
        receiver
            .recv()
            .map_err(|_| map_error("the mapping never completed".into()))?
            .map_err(|error| map_error(error.to_string()))?;
        let data = self
            .buffer
            .get_mapped_range(..)
            .map_err(|error| map_error(error.to_string()))?;
        let mut texels = Vec::with_capacity((self.bytes_per_row * self.height) as usize);
        for row in data.chunks_exact(self.padded_bytes_per_row as usize) {
            texels.extend_from_slice(&row[..self.bytes_per_row as usize]);
        }
        drop(data);
        self.buffer.unmap();
        Ok(texels)
    }

    /// [`TextureReadback::read`] of an `Rgba16Float` texture (the headless renders' target) as
    /// linear RGBA, row 0 at the top.
    ///
    /// # Errors
    /// [`ReadbackError::Format`] for another format; as [`TextureReadback::read`].
    pub fn read_rgba16f(self, device: &wgpu::Device) -> Result<RgbaImage, ReadbackError> {
        if self.format != wgpu::TextureFormat::Rgba16Float {
            return Err(ReadbackError::Format {
                format: self.format,
            });
        }
        let (width, height) = self.size();
        let texels = self.read(device)?;
        Ok(RgbaImage {
            width,
            height,
            pixels: texels
                .chunks_exact(8)
                .map(|texel| {
                    std::array::from_fn(|i| {
                        half::f16::from_ne_bytes([texel[2 * i], texel[2 * i + 1]]).to_f32()
                    })
                })
                .collect(),
        })
    }
}
