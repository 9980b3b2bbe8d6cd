//! Several views of one prepared frame (`Renderer::add_view` / `render_view`) on a software
//! adapter (lavapipe): split screen, several cameras or a probe's faces without a second
//! renderer. Each view gives the pixels a frame prepared for that camera alone gives, every
//! non-local term on, on two wax bodies that light each other; views past the buffer's first room, a bad view and a view before any
//! frame are handled.

use cdrf_core::glam::{self, Mat4, Vec3};
use cdrf_core::image_file::RgbaImage;
use cdrf_core::light::NonLocal;
use cdrf_core::{Mesh, read_lut};
use cdrf_render::offscreen::OffscreenTarget;
use cdrf_render::{
    DirectionalLight, Draw, FrameDesc, MaterialDesc, MeshDesc, Options, PrepareError, Renderer,
    ToCamera, View,
};
use cdrf_tests::{data_dir, draw_and_read, headless_target, merged, software_device};

const SIZE: u32 = 128;

/// A perspective camera 120 mm from the origin along `direction`, looking at it.
fn camera(direction: Vec3) -> View {
    let eye = 120.0 * direction.normalize();
    let up = if direction.normalize().y.abs() > 0.9 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    View {
        clip_from_world: glam::camera::rh::proj::directx::perspective(0.6, 1.0, 40.0, 200.0)
            * glam::camera::rh::view::look_at_mat4(eye, Vec3::ZERO, up),
        to_camera: ToCamera::Point(eye),
    }
}

/// Cameras around the two bodies: front, side, above, behind, below, and front again with
/// twice the exposure.
fn cameras() -> Vec<(View, f32)> {
    [
        (Vec3::Z, 1.0),
        (Vec3::X, 1.0),
        (Vec3::new(0.2, 1.0, 0.3), 1.0),
        (Vec3::NEG_Z, 1.0),
        (Vec3::new(0.1, -1.0, 0.2), 1.0),
        (Vec3::Z, 2.0),
    ]
    .into_iter()
    .map(|(direction, exposure)| (camera(direction), exposure))
    .collect()
}

#[test]
fn every_view_of_one_frame_renders_as_a_frame_of_its_own() {
    let device = software_device();
    let (gpu, queue) = (&device.device, &device.queue);
    // Two bodies facing each other, so the inter-reflection (whose view correction is the
    // view's) is not zero.
    let ellipsoid = |semi: Vec3| {
        let mut mesh = Mesh::icosphere(1.0, 4);
        for p in &mut mesh.positions {
            *p *= semi;
        }
        mesh.compute_normals();
        mesh
    };
    let (mesh, curvature) = merged(&[
        (
            ellipsoid(Vec3::new(20.0, 20.0, 18.0)),
            Vec3::new(-12.0, 0.0, 0.0),
        ),
        (
            ellipsoid(Vec3::new(8.0, 14.0, 14.0)),
            Vec3::new(22.0, 0.0, 0.0),
        ),
    ]);
    let lut =
        read_lut(data_dir().join("wax-fit/measured.exr")).unwrap_or_else(|error| panic!("{error}"));
    let target_desc = headless_target();
    let target = OffscreenTarget::new(gpu, &target_desc, SIZE, SIZE);
    let mut renderer = Renderer::new(gpu, &target_desc, Options::PREDICTABLE);

    let wax = renderer
        .create_material(gpu, queue, &MaterialDesc::Measured { lut: &lut })
        .unwrap_or_else(|error| panic!("{error}"));
    let mesh_id = renderer
        .create_mesh(
            gpu,
            &MeshDesc::from_mesh(&mesh, &curvature.mean_per_mm)
                .with_curvature_anisotropy(&curvature.anisotropy_per_mm),
        )
        .unwrap_or_else(|error| panic!("{error}"));
    let draws = [Draw::new(mesh_id, wax, Mat4::IDENTITY)];
    let lights = [DirectionalLight {
        to_light: Vec3::new(-0.6, 0.7, -0.4).normalize(),
        irradiance: [1.0; 3],
    }
    .into()];
    let frame = |view: View, exposure: f32| FrameDesc {
        view,
        lights: &lights,
        exposure,
        draws: &draws,
        non_local: NonLocal::ALL,
        mm_per_world_unit: 1.0,
        environment: None,
    };

    // Before any frame: no view to add, nothing drawn.
    let error = renderer
        .add_view(gpu, queue, &cameras()[1].0, 1.0)
        .expect_err("no frame yet");
    assert!(matches!(error, PrepareError::NotPrepared), "{error}");

    // Each camera alone.
    let mut alone: Vec<RgbaImage> = Vec::new();
    for (view, exposure) in cameras() {
        let commands = renderer
            .prepare(gpu, queue, &frame(view, exposure))
            .unwrap_or_else(|error| panic!("{error}"));
        alone.push(draw_and_read(&target, commands, |pass| {
            renderer.render(pass)
        }));
    }

    // One frame, the first camera's, and the others added: past the buffer's first room.
    let views = cameras();
    let commands = renderer
        .prepare(gpu, queue, &frame(views[0].0, views[0].1))
        .unwrap_or_else(|error| panic!("{error}"));
    let mut indices = vec![0];
    for (view, exposure) in &views[1..] {
        indices.push(
            renderer
                .add_view(gpu, queue, view, *exposure)
                .unwrap_or_else(|error| panic!("{error}")),
        );
    }
    assert_eq!(indices, (0..views.len()).collect::<Vec<_>>());
    let bad = View {
        clip_from_world: Mat4::NAN,
        ..views[1].0
    };
    let error = renderer
        .add_view(gpu, queue, &bad, 1.0)
        .expect_err("a NaN view");
    assert!(matches!(error, PrepareError::BadView), "{error}");
    let error = renderer
        .add_view(gpu, queue, &views[1].0, -1.0)
        .expect_err("a negative exposure");
    assert!(matches!(error, PrepareError::BadExposure { .. }), "{error}");

    let mut commands = Some(commands);
    for (index, expected) in indices.iter().zip(&alone) {
        let image = draw_and_read(&target, commands.take().unwrap_or_default(), |pass| {
            renderer.render_view(pass, *index)
        });
        let covered = image.pixels.iter().filter(|p| p[3] > 0.5).count();
        let differing = image
            .pixels
            .iter()
            .zip(&expected.pixels)
            .filter(|(a, b)| a != b)
            .count();
        println!("view {index}: {covered} px covered, {differing} differ from its own frame");
        assert!(covered > 1000, "view {index} shows the body ({covered} px)");
        assert_eq!(differing, 0, "view {index}");
    }
    // An unknown view draws nothing.
    let empty = draw_and_read(&target, Vec::new(), |pass| {
        renderer.render_view(pass, views.len())
    });
    assert!(empty.pixels.iter().all(|p| p[3] == 0.0));
    // Twice the exposure, twice the radiance.
    let (front, bright) = (&alone[0], &alone[5]);
    let ratio: f32 = bright.pixels.iter().map(|p| p[1]).sum::<f32>()
        / front.pixels.iter().map(|p| p[1]).sum::<f32>();
    assert!((ratio - 2.0).abs() < 0.01, "{ratio}");
}
