//! Deforming meshes (`Renderer::update_mesh`) on a software adapter (lavapipe): a tube bent as
//! a finger bends, its vertices moved each frame as skinning would move them.
//!
//! - New vertices render as a mesh created in that shape, every non-local term on.
//! - What the rest pose's curvature (FaceWorks' choice, the `None` of `MeshVertices`) loses
//!   against the bent shape's own, printed and bounded.
//! - Bad updates are refused with the mesh kept as it was.

use cdrf_core::glam::{self, Mat4, Quat, Vec3};
use cdrf_core::image_file::RgbaImage;
use cdrf_core::light::NonLocal;
use cdrf_core::{CurvatureOptions, Mesh, curvature_per_mm, read_lut};
use cdrf_render::offscreen::OffscreenTarget;
use cdrf_render::{
    DirectionalLight, Draw, FrameDesc, MaterialDesc, MaterialId, MeshDesc, MeshId, MeshUploadError,
    MeshVertices, Options, Renderer, ToCamera, View,
};
use cdrf_tests::{data_dir, draw_and_read, headless_target, software_device};

const SIZE: u32 = 256;
/// The tube's half length and radius, mm.
const HALF_LENGTH_MM: f32 = 40.0;
const RADIUS_MM: f32 = 7.0;
/// The bend's radius along the tube's axis, mm: 80 mm of tube turn through 2 rad (115°).
const BEND_RADIUS_MM: f32 = 40.0;

/// A finger-like tube along x (an ellipsoid 80 × 14 × 14 mm, 10 242 vertices).
fn tube() -> Mesh {
    let mut mesh = Mesh::icosphere(1.0, 5);
    let semi = Vec3::new(HALF_LENGTH_MM, RADIUS_MM, RADIUS_MM);
    for (p, n) in mesh.positions.iter_mut().zip(&mut mesh.normals) {
        let u = *p;
        *p = u * semi;
        *n = (u / semi).normalize();
    }
    mesh
}

/// The bend at a point of the rest pose: where it goes and the rotation of its frame (the
/// tube's axis turns by x / R about z around the centre (0, R, 0)).
fn bend_at(p: Vec3) -> (Vec3, Quat) {
    let theta = p.x / BEND_RADIUS_MM;
    let (sin, cos) = theta.sin_cos();
    let out = Vec3::new(
        (BEND_RADIUS_MM - p.y) * sin,
        BEND_RADIUS_MM - (BEND_RADIUS_MM - p.y) * cos,
        p.z,
    );
    (out, Quat::from_rotation_z(theta))
}

/// The tube bent: positions, and normals and curvature anisotropy carried as skinning carries
/// them (normals by the map's inverse transpose: its frame turned, stretched along the axis by
/// (R − y) / R; anisotropy, a tangent direction, turned with the frame).
struct Pose {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    rest_anisotropy_turned: Vec<Vec3>,
}

fn bent(rest: &Mesh, rest_anisotropy: &[Vec3]) -> Pose {
    let mut pose = Pose {
        positions: Vec::new(),
        normals: Vec::new(),
        rest_anisotropy_turned: Vec::new(),
    };
    for ((&p, &n), &a) in rest
        .positions
        .iter()
        .zip(&rest.normals)
        .zip(rest_anisotropy)
    {
        let (position, turn) = bend_at(p);
        let stretch = (BEND_RADIUS_MM - p.y) / BEND_RADIUS_MM;
        pose.positions.push(position);
        pose.normals
            .push((turn * Vec3::new(n.x / stretch, n.y, n.z)).normalize());
        pose.rest_anisotropy_turned.push(turn * a);
    }
    pose
}

/// The tube at rest and bent, each with its own curvature.
struct BentTube {
    rest: Mesh,
    rest_curvature: cdrf_core::Curvature,
    pose: Pose,
    bent: Mesh,
    bent_curvature: cdrf_core::Curvature,
}

impl BentTube {
    fn new() -> Self {
        let rest = tube();
        let rest_curvature = curvature(&rest);
        let pose = bent(&rest, &rest_curvature.anisotropy_per_mm);
        let bent = Mesh {
            positions: pose.positions.clone(),
            normals: pose.normals.clone(),
            ..rest.clone()
        };
        let bent_curvature = curvature(&bent);
        Self {
            rest,
            rest_curvature,
            pose,
            bent,
            bent_curvature,
        }
    }

    /// A mesh created bent, with the bent shape's curvature.
    fn create_bent(&self, bench: &mut Bench) -> MeshId {
        bench.create(
            &MeshDesc::from_mesh(&self.bent, &self.bent_curvature.mean_per_mm)
                .with_curvature_anisotropy(&self.bent_curvature.anisotropy_per_mm),
        )
    }

    /// A deforming mesh created at rest, with the rest pose's curvature.
    fn create_rest_deforming(&self, bench: &mut Bench) -> MeshId {
        bench.create(
            &MeshDesc::from_mesh(&self.rest, &self.rest_curvature.mean_per_mm)
                .with_curvature_anisotropy(&self.rest_curvature.anisotropy_per_mm)
                .deforming(),
        )
    }
}

/// One renderer, its offscreen target and the bundled wax: an orthographic view along −z of
/// the bent tube, mm world units, a light from above and in front.
struct Bench {
    renderer: Renderer,
    target: OffscreenTarget,
    wax: MaterialId,
}

impl Bench {
    fn new() -> Self {
        let device = software_device();
        let target_desc = headless_target();
        let mut renderer = Renderer::new(&device.device, &target_desc, Options::PREDICTABLE);
        let lut = read_lut(data_dir().join("wax-fit/measured.exr"))
            .unwrap_or_else(|error| panic!("{error}"));
        let wax = renderer
            .create_material(
                &device.device,
                &device.queue,
                &MaterialDesc::Measured { lut: &lut },
            )
            .unwrap_or_else(|error| panic!("{error}"));
        Self {
            renderer,
            target: OffscreenTarget::new(&device.device, &target_desc, SIZE, SIZE),
            wax,
        }
    }

    fn create(&mut self, desc: &MeshDesc<'_>) -> MeshId {
        self.renderer
            .create_mesh(&software_device().device, desc)
            .unwrap_or_else(|error| panic!("{error}"))
    }

    fn render(&mut self, mesh: MeshId, non_local: NonLocal) -> RgbaImage {
        let device = software_device();
        let half = 1.2 * HALF_LENGTH_MM;
        let centre = Vec3::new(0.0, 0.45 * HALF_LENGTH_MM, 0.0);
        let eye = centre + Vec3::new(0.0, 0.0, 200.0);
        let draws = [Draw::new(mesh, self.wax, Mat4::IDENTITY)];
        let frame = FrameDesc {
            view: View {
                clip_from_world: glam::camera::rh::proj::directx::orthographic(
                    -half, half, -half, half, 100.0, 300.0,
                ) * glam::camera::rh::view::look_at_mat4(eye, centre, Vec3::Y),
                to_camera: ToCamera::Direction(Vec3::Z),
            },
            lights: &[DirectionalLight {
                to_light: Vec3::new(0.2, 1.0, -0.2).normalize(),
                irradiance: [1.0; 3],
            }
            .into()],
            exposure: 1.0,
            draws: &draws,
            non_local,
            mm_per_world_unit: 1.0,
            environment: None,
        };
        let commands = self
            .renderer
            .prepare(&device.device, &device.queue, &frame)
            .unwrap_or_else(|error| panic!("{error}"));
        draw_and_read(&self.target, commands, |pass| self.renderer.render(pass))
    }
}

/// Mean |a − b| / mean b over the pixels both cover (RGB summed), and that count.
fn relative_difference(a: &RgbaImage, b: &RgbaImage) -> (f64, usize) {
    let (mut difference, mut total, mut count) = (0.0f64, 0.0f64, 0usize);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        if p[3] > 0.99 && q[3] > 0.99 {
            for c in 0..3 {
                difference += f64::from((p[c] - q[c]).abs());
                total += f64::from(q[c]);
            }
            count += 1;
        }
    }
    (difference / total.max(1e-12), count)
}

fn coverage_differs(a: &RgbaImage, b: &RgbaImage) -> usize {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| (p[3] > 0.5) != (q[3] > 0.5))
        .count()
}

fn curvature(mesh: &Mesh) -> cdrf_core::Curvature {
    curvature_per_mm(mesh, &CurvatureOptions::new(1.0)).unwrap_or_else(|error| panic!("{error}"))
}

/// A deforming mesh given the bent tube's vertices and curvature renders as the bent tube
/// created as it is: the same pixels without the inter-reflection (the shading, shadow map,
/// transmission and gather read only the vertices), and with it within 0.5 % (measured 0.11 %:
/// its patches stay the rest pose's cut, placed where their vertices now are).
#[test]
fn an_updated_mesh_renders_as_one_created_in_that_shape() {
    let tube = BentTube::new();
    let pose = &tube.pose;

    let mut bench = Bench::new();
    let created = tube.create_bent(&mut bench);
    let deforming = tube.create_rest_deforming(&mut bench);
    let before_update = bench.render(deforming, NonLocal::OFF);
    bench
        .renderer
        .update_mesh(
            &software_device().queue,
            deforming,
            &MeshVertices {
                curvature_per_mm: Some(&tube.bent_curvature.mean_per_mm),
                curvature_anisotropy_per_mm: Some(&tube.bent_curvature.anisotropy_per_mm),
                ..MeshVertices::new(&pose.positions, &pose.normals)
            },
        )
        .unwrap_or_else(|error| panic!("{error}"));

    let no_interreflection = NonLocal {
        interreflection: false,
        ..NonLocal::ALL
    };
    let expected = bench.render(created, no_interreflection);
    let updated = bench.render(deforming, no_interreflection);
    let moved = coverage_differs(&before_update, &expected);
    println!("{moved} px of coverage moved by the bend");
    assert!(
        moved > 3000,
        "the bend must move the silhouette ({moved} px)"
    );
    let differing = expected
        .pixels
        .iter()
        .zip(&updated.pixels)
        .filter(|(p, q)| p != q)
        .count();
    assert_eq!(differing, 0, "updated vs created, without inter-reflection");

    let expected = bench.render(created, NonLocal::ALL);
    let updated = bench.render(deforming, NonLocal::ALL);
    let (difference, count) = relative_difference(&updated, &expected);
    println!(
        "every term: updated vs created {:.3} % over {count} px",
        100.0 * difference
    );
    assert_eq!(coverage_differs(&updated, &expected), 0);
    assert!(difference < 0.005, "{:.3} %", 100.0 * difference);
}

/// What the rest pose's curvature loses on the bent tube: rendered with the rest pose's mean
/// curvature (its anisotropy turned with the pose, as the Bevy plugin's skinning turns it)
/// against the bent shape's own curvature, every term on. Uniform bending leaves the mean
/// curvature of a thin tube nearly as it was (its cross-section does not change); what moves
/// is the inside and outside of the bend, whose curvature along the axis gains or loses 1/R.
#[test]
fn the_rest_poses_curvature_on_a_bent_tube() {
    let tube = BentTube::new();
    let pose = &tube.pose;
    let change: Vec<f32> = tube
        .bent_curvature
        .mean_per_mm
        .iter()
        .zip(&tube.rest_curvature.mean_per_mm)
        .map(|(b, r)| (b - r).abs())
        .collect();
    let mean_change = change.iter().sum::<f32>() / change.len() as f32;
    let rest_mean = tube.rest_curvature.mean_per_mm.iter().sum::<f32>()
        / tube.rest_curvature.mean_per_mm.len() as f32;
    println!(
        "mean |H_bent − H_rest| = {mean_change:.4} /mm (rest mean H {rest_mean:.4} /mm, 1/(2R) = {:.4} /mm)",
        0.5 / BEND_RADIUS_MM
    );

    let mut bench = Bench::new();
    let own = tube.create_bent(&mut bench);
    let deforming = tube.create_rest_deforming(&mut bench);
    bench
        .renderer
        .update_mesh(
            &software_device().queue,
            deforming,
            &MeshVertices {
                curvature_anisotropy_per_mm: Some(&pose.rest_anisotropy_turned),
                ..MeshVertices::new(&pose.positions, &pose.normals)
            },
        )
        .unwrap_or_else(|error| panic!("{error}"));
    let mut figures = Vec::new();
    for (name, non_local) in [("local", NonLocal::OFF), ("every term", NonLocal::ALL)] {
        let truth = bench.render(own, non_local);
        let rest_pose = bench.render(deforming, non_local);
        let (difference, count) = relative_difference(&rest_pose, &truth);
        println!(
            "{name}: rest-pose curvature vs the bent shape's {:.2} % over {count} px",
            100.0 * difference
        );
        figures.push(difference);
    }
    // Measured on lavapipe: 0.95 % local, 0.49 % with every term (docs/deforming.md). Twice
    // that fails: the rest pose would then cost more than the docs say.
    assert!(figures.iter().all(|&d| d < 0.02), "{figures:?}");
}

/// Updates that cannot apply are refused, and the mesh keeps its last vertices.
#[test]
fn bad_updates_are_refused_and_leave_the_mesh_as_it_was() {
    let rest = tube();
    let rest_curvature = curvature(&rest);
    let mut bench = Bench::new();
    let queue = &software_device().queue;
    let fixed = bench.create(&MeshDesc::from_mesh(&rest, &rest_curvature.mean_per_mm));
    let deforming =
        bench.create(&MeshDesc::from_mesh(&rest, &rest_curvature.mean_per_mm).deforming());
    let before = bench.render(deforming, NonLocal::OFF);

    let moved: Vec<Vec3> = rest.positions.iter().map(|p| *p * 0.5).collect();
    let error = bench
        .renderer
        .update_mesh(queue, fixed, &MeshVertices::new(&moved, &rest.normals))
        .expect_err("a mesh not made deforming");
    assert!(matches!(error, MeshUploadError::NotDeforming), "{error}");
    assert!(error.to_string().contains("not created as deforming"));

    let short = &moved[1..];
    let error = bench
        .renderer
        .update_mesh(queue, deforming, &MeshVertices::new(short, &rest.normals))
        .expect_err("one position short");
    assert_eq!(
        error.to_string(),
        format!(
            "{} positions for {} vertices",
            short.len(),
            rest.positions.len()
        )
    );

    let mut broken = moved.clone();
    broken[7].y = f32::NAN;
    let error = bench
        .renderer
        .update_mesh(queue, deforming, &MeshVertices::new(&broken, &rest.normals))
        .expect_err("a NaN position");
    assert_eq!(error.to_string(), "a position is not finite");

    let curvature = vec![f32::INFINITY; rest.positions.len()];
    let error = bench
        .renderer
        .update_mesh(
            queue,
            deforming,
            &MeshVertices {
                curvature_per_mm: Some(&curvature),
                ..MeshVertices::new(&moved, &rest.normals)
            },
        )
        .expect_err("infinite curvature");
    assert_eq!(error.to_string(), "a curvature value is not finite");

    assert!(before.pixels == bench.render(deforming, NonLocal::OFF).pixels);

    bench.renderer.remove_mesh(deforming);
    let error = bench
        .renderer
        .update_mesh(queue, deforming, &MeshVertices::new(&moved, &rest.normals))
        .expect_err("a removed mesh");
    assert!(matches!(error, MeshUploadError::Unknown), "{error}");
}
