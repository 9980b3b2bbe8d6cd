//! What a deforming mesh costs per frame, in one run: `Renderer::update_mesh` (interleave the
//! new positions and normals, upload, refit the bounds) against recomputing the curvature on
//! the CPU (what keeping the rest pose's saves) and against a frame of the same mesh with every
//! non-local term at 1024 × 1024 (4× MSAA). Spheres of 10 242 and 163 842 vertices.
//!
//! ```text
//! cargo bench -p cdrf-render --bench deforming            # software adapter (lavapipe)
//! cargo bench -p cdrf-render --bench deforming -- --gpu   # whatever adapter wgpu prefers
//! ```

use std::error::Error;
use std::time::Instant;

use cdrf_core::glam::{Mat4, Vec3};
use cdrf_core::{CurvatureOptions, Mesh, curvature_per_mm};
use cdrf_render::headless::{
    AdapterPreference, HEADLESS_COLOR_FORMAT, HEADLESS_DEPTH_FORMAT, HeadlessDevice,
};
use cdrf_render::offscreen::OffscreenTarget;
use cdrf_render::{
    DirectionalLight, Draw, FrameDesc, MaterialDesc, MeshDesc, MeshVertices, NonLocal, Options,
    Renderer, TargetDesc, ToCamera, View, wgpu,
};

const SIZE: u32 = 1024;
const FRAMES: u32 = 10;

fn main() -> Result<(), Box<dyn Error>> {
    let mut preference = AdapterPreference::Software;
    for arg in std::env::args().skip(1) {
        match arg.as_str() {
            "--gpu" => preference = AdapterPreference::Any,
            "--bench" => {}
            other => return Err(format!("unknown argument {other}").into()),
        }
    }
    let host = HeadlessDevice::new(preference)?;
    let (device, queue) = (&host.device, &host.queue);
    println!("adapter: {}", host.adapter_description());
    let wait = || device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ());
    let target_desc = TargetDesc::new(HEADLESS_COLOR_FORMAT)
        .with_sample_count(4)
        .with_depth(HEADLESS_DEPTH_FORMAT);
    let target = OffscreenTarget::new(device, &target_desc, SIZE, SIZE);
    println!(
        "{:>9} | {:>12} | {:>14} | {:>16} | update / frame",
        "vertices", "update ms", "curvature ms", "frame ms (all)"
    );
    for level in [5, 7] {
        let mut renderer = Renderer::new(device, &target_desc, Options::default());
        let material =
            renderer.create_material(device, queue, &MaterialDesc::Lambert { albedo: [0.8; 3] })?;
        let rest = Mesh::icosphere(20.0, level);
        let start = Instant::now();
        let curvature = curvature_per_mm(&rest, &CurvatureOptions::new(1.0))?;
        let curvature_ms = start.elapsed().as_secs_f64() * 1e3;
        let mesh = renderer.create_mesh(
            device,
            &MeshDesc::from_mesh(&rest, &curvature.mean_per_mm).deforming(),
        )?;
        // A breathing sphere: each frame's vertices differ.
        let poses: Vec<Vec<Vec3>> = (0..FRAMES)
            .map(|f| {
                let scale = 1.0 + 0.01 * f as f32;
                rest.positions.iter().map(|p| *p * scale).collect()
            })
            .collect();

        let start = Instant::now();
        for pose in &poses {
            renderer.update_mesh(queue, mesh, &MeshVertices::new(pose, &rest.normals))?;
            queue.submit([]);
        }
        wait()?;
        let update_ms = start.elapsed().as_secs_f64() * 1e3 / f64::from(FRAMES);

        let draws = [Draw::new(mesh, material, Mat4::IDENTITY)];
        let frame = FrameDesc {
            view: View {
                clip_from_world: cdrf_core::glam::camera::rh::proj::directx::orthographic(
                    -25.0, 25.0, -25.0, 25.0, 0.0, 100.0,
                ) * cdrf_core::glam::camera::rh::view::look_at_mat4(
                    Vec3::new(0.0, 0.0, 50.0),
                    Vec3::ZERO,
                    Vec3::Y,
                ),
                to_camera: ToCamera::Direction(Vec3::Z),
            },
            lights: &[DirectionalLight {
                to_light: Vec3::new(1.0, 1.0, 0.5).normalize(),
                irradiance: [1.0; 3],
            }
            .into()],
            exposure: 1.0,
            draws: &draws,
            non_local: NonLocal::ALL,
            mm_per_world_unit: 1.0,
            environment: None,
        };
        let render = |renderer: &mut Renderer| -> Result<(), Box<dyn Error>> {
            let mut commands = renderer.prepare(device, queue, &frame)?;
            let mut encoder = device.create_command_encoder(&Default::default());
            renderer.render(&mut target.begin_pass(&mut encoder, wgpu::Color::TRANSPARENT));
            commands.push(encoder.finish());
            queue.submit(commands);
            Ok(())
        };
        render(&mut renderer)?; // builds the pipelines
        wait()?;
        let start = Instant::now();
        for _ in 0..FRAMES {
            render(&mut renderer)?;
        }
        wait()?;
        let frame_ms = start.elapsed().as_secs_f64() * 1e3 / f64::from(FRAMES);
        println!(
            "{:>9} | {update_ms:>12.3} | {curvature_ms:>14.1} | {frame_ms:>16.1} | {:.3}",
            rest.positions.len(),
            update_ms / frame_ms
        );
    }
    Ok(())
}
