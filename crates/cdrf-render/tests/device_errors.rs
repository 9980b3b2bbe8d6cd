//! wgpu errors become typed errors that name the size, never wgpu's default panic: the
//! offscreen target's creation is checked and scoped, a read-back beyond the device's largest
//! buffer is refused, and errors outside any scope are recorded by the headless device.

use cdrf_render::headless::{AdapterPreference, HeadlessDevice, HeadlessError};
use cdrf_render::readback::{ReadbackError, TextureReadback};
use cdrf_render::{OffscreenTarget, TargetDesc, TargetError, wgpu};

fn device() -> HeadlessDevice {
    HeadlessDevice::new(AdapterPreference::Software).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn offscreen_target_errors_name_the_size() {
    let device = device();
    let max = device.device.limits().max_texture_dimension_2d;
    let target = TargetDesc::new(wgpu::TextureFormat::Rgba16Float);
    let error = OffscreenTarget::try_new(&device.device, &target, max + 1, 4).unwrap_err();
    println!("{error}");
    assert!(matches!(error, TargetError::Size { .. }), "{error}");
    assert!(error.to_string().contains(&format!("{} × 4", max + 1)));
    // A sample count the format does not support: wgpu's validation error, captured.
    let odd = target.with_sample_count(3);
    let error = OffscreenTarget::try_new(&device.device, &odd, 64, 32).unwrap_err();
    println!("{error}");
    assert!(matches!(error, TargetError::Create { .. }), "{error}");
    assert!(error.to_string().contains("64 × 32"), "{error}");
    assert!(device.take_uncaptured_errors().is_empty());
}

#[test]
fn readback_beyond_the_largest_buffer_is_refused() {
    let device = device();
    let side = 6000;
    let texture = device.device.create_texture(&wgpu::TextureDescriptor {
        label: None,
        size: wgpu::Extent3d {
            width: side,
            height: side,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba16Float,
        usage: wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let mut encoder = device.device.create_command_encoder(&Default::default());
    let Err(error) = TextureReadback::record(&device.device, &mut encoder, &texture) else {
        panic!("a {side}² Rgba16Float read-back fits a 256 MiB buffer?");
    };
    println!("{error}");
    assert!(matches!(error, ReadbackError::TooLarge { .. }), "{error}");
    assert!(error.to_string().contains("6000 × 6000"), "{error}");
}

#[test]
fn errors_outside_a_scope_are_recorded_not_panicked() {
    let device = device();
    let error = device.check_image_size(16384, 16384).unwrap_err();
    assert!(matches!(error, HeadlessError::Size { .. }), "{error}");
    // An invalid texture (zero width) outside any error scope: wgpu's default handler panics.
    let _ = device.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("invalid"),
        size: wgpu::Extent3d {
            width: 0,
            height: 4,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let errors = device.take_uncaptured_errors();
    println!("{errors:?}");
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert!(device.take_uncaptured_errors().is_empty());
}
