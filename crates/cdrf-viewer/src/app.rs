//! The viewer's state and its UI: controls on the left, the 3D view in the middle, the
//! inspector on the right.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Instant;

use cdrf_core::environment::{Environment, EnvironmentRadiance, ShCoefficients};
use cdrf_core::gaussian_file::GaussianParameters;
use cdrf_core::glam::{Mat3, Mat4, Vec2, Vec3};
use cdrf_core::light::{DirectionalLight, Light, NonLocal, PointLight, SpotLight};
use cdrf_core::specular::{DEFAULT_IOR, DEFAULT_ROUGHNESS_ALPHA, SpecularLayer};
use cdrf_core::{Cdrf, Filter, ShadingModel};
use cdrf_render::{
    ENVIRONMENT_SH_ORDER, MaterialDesc, MaterialId, MeshDesc, MeshId, SurfaceDesc, SurfaceId,
};
use egui::{Color32, RichText};

use crate::assets::{
    Asset, FIT_LUT_FILE, LoadedEnvironment, LoadedGaussian, LoadedLut, LoadedMesh, StartupFiles,
    bundled_data_dir, load_fit_folder,
};
use crate::camera::OrbitCamera;
use crate::gpu::{Layout, ViewCallback, ViewerGpu, slot_size_pixels};
use crate::panels;

/// The models a slot's menu offers, in menu order (the curvature view has its own switch).
/// Lambert's albedo is the one fitted to the measured table
/// ([`cdrf_core::CdrfLut::lambert_albedo`]; the Gaussian's scale when no LUT is loaded).
pub const SLOT_MODELS: [ShadingModel; 3] = [
    ShadingModel::Measured,
    ShadingModel::Gaussian,
    ShadingModel::Lambert,
];

/// The kind of light the light controls place (at the direction they set).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightKind {
    /// From infinitely far: the photographs' light.
    Directional,
    /// A lamp at [`Settings::light_distance_mm`] from the origin, as bright there as the
    /// directional light (intensity = E · d²).
    Point,
    /// That lamp with a cone aimed at the origin (inner 15°, outer 25°).
    Spot,
}

impl LightKind {
    /// All kinds, in menu order.
    pub const ALL: [LightKind; 3] = [LightKind::Directional, LightKind::Point, LightKind::Spot];

    /// The name shown in the UI.
    pub fn label(self) -> &'static str {
        match self {
            LightKind::Directional => "directional",
            LightKind::Point => "point",
            LightKind::Spot => "spot",
        }
    }
}

/// How the models share the 3D view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compare {
    /// The left model (A) alone, filling the view.
    Single,
    /// Two halves, the same camera.
    SideBySide,
    /// One view, a draggable line between the models.
    Split,
    /// The luminance difference left − right.
    Difference,
}

/// Everything the user sets.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// How the models share the view.
    pub compare: Compare,
    /// The left (A) and right (B) models.
    pub models: [ShadingModel; 2],
    /// Show per-vertex curvature instead of shading.
    pub curvature_view: bool,
    /// Rounds of curvature smoothing for meshes loaded from now on.
    pub curvature_smoothing: u32,
    /// Split line position, fraction of the view width.
    pub split: f32,
    /// Radiance difference shown at full colour.
    pub difference_range: f32,
    /// Millimetres per mesh unit.
    pub mm_per_unit: f32,
    /// Light azimuth, degrees: 0 from the left (the photographs), 90 from the camera side
    /// (+Z), 180 from the right, −90 from behind.
    pub light_azimuth_deg: f32,
    /// Light elevation, degrees (+ from above).
    pub light_elevation_deg: f32,
    /// Irradiance E of the light (the radiance unit is E's per steradian).
    pub irradiance: f32,
    /// Display exposure multiplier.
    pub exposure: f32,
    /// The Gaussian CDRF's σ per RGB channel, mm.
    pub sigma_mm: [f32; 3],
    /// Curvature of the radiance plot, mm⁻¹.
    pub plot_curvature_per_mm: f32,
    /// The plot follows the curvature under the pointer.
    pub plot_follows_pointer: bool,
    /// Repaint continuously (for frame timing).
    pub continuous: bool,
    /// Show wall-clock timings (frame interval, Gaussian table build). Snapshot tests turn
    /// them off: they differ from run to run.
    pub show_timings: bool,
    /// The non-local terms (both models): [`NonLocal::ALL`] is the renderer at its best,
    /// [`NonLocal::OFF`] the poster's model.
    pub non_local: NonLocal,
    /// What kind of light the light controls place.
    pub light_kind: LightKind,
    /// Point and spot lights: distance from the origin, mm.
    pub light_distance_mm: f32,
    /// Draw a textured mesh with its glTF materials (base colour, normal map, roughness);
    /// off: every primitive the bare measured material.
    pub textures: bool,
    /// The first-surface reflection on every model (a rough dielectric boundary).
    pub specular: bool,
    /// Its Beckmann α.
    pub specular_roughness: f32,
    /// Its relative index of refraction.
    pub ior: f32,
    /// A uniform sky's radiance (0: none), used when no environment map is loaded.
    pub sky_radiance: f32,
    /// The environment map's intensity (0: off).
    pub environment_intensity: f32,
    /// The environment map's rotation about +y, degrees.
    pub environment_rotate_deg: f32,
}

impl Settings {
    /// World direction towards the light.
    pub fn to_light(&self) -> Vec3 {
        let (sin_az, cos_az) = self.light_azimuth_deg.to_radians().sin_cos();
        let (sin_el, cos_el) = self.light_elevation_deg.to_radians().sin_cos();
        Vec3::new(-cos_az * cos_el, sin_el, sin_az * cos_el)
    }

    /// The light the controls describe, in world mm (the object about the origin).
    pub fn light(&self) -> Light {
        let to_light = self.to_light();
        let irradiance = [self.irradiance; 3];
        // World units are mm here.
        let lamp = || {
            PointLight::facing(
                Vec3::ZERO,
                to_light,
                self.light_distance_mm,
                1.0,
                irradiance,
            )
        };
        match self.light_kind {
            LightKind::Directional => DirectionalLight {
                to_light,
                irradiance,
            }
            .into(),
            LightKind::Point => lamp().into(),
            LightKind::Spot => {
                SpotLight::aimed_at(lamp(), Vec3::ZERO, 15f32.to_radians(), 25f32.to_radians())
                    .into()
            }
        }
    }

    /// The specular layer the controls describe (`None`: off or out of range).
    pub fn specular_layer(&self) -> Option<SpecularLayer> {
        self.specular
            .then(|| SpecularLayer::new(self.specular_roughness, self.ior).ok())
            .flatten()
    }

    /// Sets azimuth and elevation from a direction towards the light.
    pub fn set_to_light(&mut self, to_light: Vec3) {
        let d = to_light.normalize_or(Vec3::NEG_X);
        self.light_elevation_deg = d.y.clamp(-1.0, 1.0).asin().to_degrees();
        self.light_azimuth_deg = d.z.atan2(-d.x).to_degrees();
    }
}

/// The surface point under the pointer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hover {
    /// Which slot (0 left/A, 1 right/B) the pointer is over.
    pub slot: usize,
    /// Mean curvature, mm⁻¹.
    pub curvature_per_mm: f32,
    /// Angle between normal and light, radians.
    pub theta_rad: f32,
    /// Angle between normal and view, radians.
    pub phi_rad: f32,
}

#[derive(Default)]
struct GpuIds {
    mesh: Option<MeshId>,
    /// The mesh's materials' surfaces, in the order of its `MeshSurfaces::materials`.
    surfaces: Vec<SurfaceId>,
    measured: Option<MaterialId>,
    gaussian: Option<MaterialId>,
    lambert: Option<MaterialId>,
    curvature: Option<MaterialId>,
}

/// Recent frame intervals.
#[derive(Default)]
struct FrameTimes {
    seconds: std::collections::VecDeque<f32>,
}

impl FrameTimes {
    const WINDOW: usize = 60;

    fn push(&mut self, dt: f32) {
        if dt.is_finite() && dt > 0.0 {
            self.seconds.push_back(dt);
            if self.seconds.len() > Self::WINDOW {
                self.seconds.pop_front();
            }
        }
    }

    fn mean_ms(&self) -> Option<f32> {
        (!self.seconds.is_empty())
            .then(|| 1e3 * self.seconds.iter().sum::<f32>() / self.seconds.len() as f32)
    }
}

/// The viewer. Create it with [`ViewerApp::new`] and draw it with [`ViewerApp::show`] every
/// frame (eframe does both through [`eframe::App`]; tests and the offscreen screenshot call
/// them directly).
pub struct ViewerApp {
    render_state: egui_wgpu::RenderState,
    settings: Settings,
    camera: OrbitCamera,
    mesh: Option<LoadedMesh>,
    lut: Option<LoadedLut>,
    gaussian: Option<LoadedGaussian>,
    environment: Option<LoadedEnvironment>,
    ids: GpuIds,
    hover: Option<Hover>,
    error: Option<String>,
    status: Option<String>,
    lut_image: Option<egui::TextureHandle>,
    /// The material picker's name of the loaded table (set with it).
    material: String,
    frame_times: FrameTimes,
    gaussian_table_ms: Option<f64>,
    dragging_split: bool,
    frame_on_next_view: bool,
    /// The settings the GPU state was last built for.
    applied: Applied,
}

/// Settings whose change needs GPU work.
#[derive(Default)]
struct Applied {
    sigma_mm: [f32; 3],
    mm_per_unit: f32,
    /// The specular layer put on which materials (measured, Gaussian, Lambert).
    specular: Option<(Option<SpecularLayer>, [Option<MaterialId>; 3])>,
    /// The environment's SH and what it was projected from (intensity, rotation, sky, map).
    environment: Option<(EnvironmentKey, Option<ShCoefficients>)>,
}

/// What the environment's SH depend on.
#[derive(Clone, Debug, PartialEq)]
struct EnvironmentKey {
    intensity: f32,
    rotate_deg: f32,
    sky_radiance: f32,
    map: Option<PathBuf>,
}

/// Background of the 3D view, linear RGB.
pub const BACKGROUND: [f32; 3] = [0.012, 0.012, 0.015];

impl ViewerApp {
    /// A viewer drawing with `render_state` (its [`ViewerGpu`] is installed there), opened on
    /// `files`. A file that fails to load leaves its part empty and shows the error.
    pub fn new(render_state: &egui_wgpu::RenderState, files: &StartupFiles) -> Self {
        ViewerGpu::install(render_state);
        let mut settings = Settings {
            compare: Compare::Single,
            models: [ShadingModel::Measured, ShadingModel::Gaussian],
            curvature_view: false,
            curvature_smoothing: files.curvature_smoothing,
            split: 0.5,
            difference_range: 0.2,
            mm_per_unit: files.mm_per_unit,
            light_azimuth_deg: 0.0,
            light_elevation_deg: 0.0,
            irradiance: files.irradiance,
            exposure: 3.0,
            sigma_mm: [1.0; 3],
            plot_curvature_per_mm: 1.0 / 35.0,
            plot_follows_pointer: true,
            continuous: false,
            show_timings: true,
            non_local: files.non_local,
            light_kind: LightKind::Directional,
            light_distance_mm: 150.0,
            textures: true,
            specular: files.specular.is_some(),
            specular_roughness: files
                .specular
                .map_or(DEFAULT_ROUGHNESS_ALPHA, |layer| layer.roughness_alpha()),
            ior: files.specular.map_or(DEFAULT_IOR, |layer| layer.ior()),
            sky_radiance: files.sky_radiance,
            environment_intensity: 1.0,
            environment_rotate_deg: 0.0,
        };
        settings.set_to_light(files.to_light);
        let mut app = Self {
            render_state: render_state.clone(),
            settings,
            camera: OrbitCamera::framing(Vec3::ZERO, 50.0, 1.0),
            mesh: None,
            lut: None,
            gaussian: None,
            environment: None,
            ids: GpuIds::default(),
            hover: None,
            error: None,
            status: None,
            lut_image: None,
            material: "—".to_owned(),
            frame_times: FrameTimes::default(),
            gaussian_table_ms: None,
            dragging_split: false,
            frame_on_next_view: true,
            applied: Applied::default(),
        };
        let mut errors = Vec::new();
        match LoadedMesh::load(&files.mesh, files.curvature_smoothing) {
            Ok(mesh) => app.set_mesh(mesh, Some(files.mm_per_unit)),
            Err(error) => errors.push(error.to_string()),
        }
        match load_fit_folder(&files.fit_folder) {
            Ok(asset) => app.apply(asset),
            Err(error) => errors.push(error.to_string()),
        }
        if !errors.is_empty() {
            app.error = Some(errors.join("\n"));
        }
        app.status = None;
        app
    }

    /// The current settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Changes settings; GPU state follows on the next [`ViewerApp::show`].
    pub fn settings_mut(&mut self) -> &mut Settings {
        &mut self.settings
    }

    /// The error shown in the UI, if any.
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// What is under the pointer, if it is over the mesh.
    pub fn hover(&self) -> Option<Hover> {
        self.hover
    }

    /// Opens a file or fit folder (as the file dialog and drag-and-drop do). Failures are
    /// shown in the UI; the previous data stays.
    pub fn open(&mut self, path: &Path) {
        match Asset::load(path, self.settings.curvature_smoothing) {
            Ok(asset) => {
                self.error = None;
                self.apply(asset);
            }
            Err(error) => self.error = Some(error.to_string()),
        }
    }

    fn apply(&mut self, asset: Asset) {
        match asset {
            Asset::Mesh(mesh) => self.set_mesh(mesh, None),
            Asset::Lut(lut) => self.set_lut(lut),
            Asset::Gaussian(gaussian) => self.set_gaussian(gaussian),
            Asset::Environment(environment) => {
                self.status = Some(format!(
                    "{}: environment map, {} × {}",
                    file_name(&environment.path),
                    environment.map.width(),
                    environment.map.height()
                ));
                self.environment = Some(environment);
            }
            Asset::Fit { lut, gaussian } => {
                if let Some(lut) = lut {
                    self.set_lut(lut);
                }
                if let Some(gaussian) = gaussian {
                    self.set_gaussian(gaussian);
                }
            }
        }
    }

    fn with_gpu<R>(&self, f: impl FnOnce(&mut ViewerGpu) -> R) -> Option<R> {
        let mut renderer = self.render_state.renderer.write();
        renderer.callback_resources.get_mut::<ViewerGpu>().map(f)
    }

    fn set_mesh(&mut self, mesh: LoadedMesh, mm_per_unit: Option<f32>) {
        self.settings.mm_per_unit = match mm_per_unit {
            Some(scale) => scale,
            None => {
                let scale = mesh.suggested_mm_per_unit();
                self.status = Some(format!(
                    "{}: {scale} mm per unit ({:.0} mm across); change it under Mesh",
                    file_name(&mesh.path),
                    mesh.extent.max_element() * scale
                ));
                scale
            }
        };
        self.applied.mm_per_unit = self.settings.mm_per_unit;
        self.mesh = Some(mesh);
        self.filter_curvature(true);
        self.frame_on_next_view = true;
        self.hover = None;
        self.refresh_curvature_material();
    }

    /// Filters the mesh's curvature at the measured material's scale at the current mm per unit
    /// (cdrf-core's `material_filter_length_mm`, as a scene file's default) and uploads the
    /// mesh when that changed its curvature or `upload` asks.
    fn filter_curvature(&mut self, upload: bool) {
        let length_mm = self
            .lut
            .as_ref()
            .and_then(|loaded| loaded.lut.diffusion_length_mm());
        let scale = self.settings.mm_per_unit;
        let Some(mesh) = self.mesh.as_mut() else {
            return;
        };
        let units =
            cdrf_core::curvature::material_filter_length_mm(length_mm, &mesh.mesh, 1.0, scale);
        let changed = units != mesh.curvature_filter_units;
        if changed && let Err(error) = mesh.filter_curvature(units) {
            self.error = Some(error.to_string());
            return;
        }
        if changed || upload {
            self.upload_mesh();
        }
    }

    /// Replaces the renderer's copy of the mesh (and its surfaces) with `self.mesh`.
    fn upload_mesh(&mut self) {
        let (device, queue) = (
            self.render_state.device.clone(),
            self.render_state.queue.clone(),
        );
        let old = self.ids.mesh.take();
        let old_surfaces = std::mem::take(&mut self.ids.surfaces);
        let Some(mesh) = self.mesh.take() else {
            return;
        };
        let uploaded = self.with_gpu(|gpu| {
            if let Some(old) = old {
                gpu.renderer.remove_mesh(old);
            }
            for surface in old_surfaces {
                gpu.renderer.remove_surface(surface);
            }
            let surfaces = mesh
                .surfaces
                .materials
                .iter()
                .map(|material| {
                    gpu.renderer
                        .create_surface(&device, &queue, &SurfaceDesc::from_material(material))
                        .map_err(|error| {
                            let name = material.name.as_deref().unwrap_or("(unnamed)");
                            format!("material {name}: {error}")
                        })
                })
                .collect::<Result<Vec<_>, _>>()?;
            let desc = MeshDesc::from_mesh(&mesh.mesh, &mesh.curvature_per_unit)
                .with_curvature_anisotropy(&mesh.curvature_anisotropy_per_unit)
                .with_tangents(mesh.surfaces.tangents.as_deref());
            let id = gpu
                .renderer
                .create_mesh(&device, &desc)
                .map_err(|error| error.to_string())?;
            Ok::<_, String>((id, surfaces))
        });
        match uploaded {
            Some(Ok((id, surfaces))) => {
                self.ids.mesh = Some(id);
                self.ids.surfaces = surfaces;
                self.mesh = Some(mesh);
            }
            Some(Err(error)) => {
                self.error = Some(format!("{}: {error}", mesh.path.display()));
            }
            None => self.mesh = Some(mesh),
        }
    }

    /// Whether the mesh has glTF materials of its own (else every primitive is the default).
    fn mesh_is_textured(&self) -> bool {
        self.mesh.as_ref().is_some_and(|mesh| {
            mesh.surfaces
                .materials
                .iter()
                .any(|material| material.source_index.is_some())
        })
    }

    /// The mesh's draws: each primitive with its material's surface (none with textures off).
    fn primitives(&self) -> Vec<(Range<u32>, Option<SurfaceId>)> {
        let Some(mesh) = &self.mesh else {
            return Vec::new();
        };
        mesh.surfaces
            .primitives
            .iter()
            .map(|primitive| {
                let surface = self
                    .settings
                    .textures
                    .then(|| self.ids.surfaces.get(primitive.material).copied())
                    .flatten();
                (primitive.triangles.clone(), surface)
            })
            .collect()
    }

    fn set_lut(&mut self, lut: LoadedLut) {
        let (device, queue) = (
            self.render_state.device.clone(),
            self.render_state.queue.clone(),
        );
        let old = self.ids.measured.take();
        let created = self.with_gpu(|gpu| {
            if let Some(old) = old {
                gpu.renderer.remove_material(old);
            }
            gpu.renderer
                .create_material(&device, &queue, &MaterialDesc::Measured { lut: &lut.lut })
        });
        match created {
            Some(Ok(id)) => self.ids.measured = Some(id),
            Some(Err(error)) => {
                self.error = Some(format!("{}: {error}", lut.path.display()));
                return;
            }
            None => {}
        }
        self.lut_image = None;
        self.material = material_name(&lut.path);
        self.lut = Some(lut);
        self.filter_curvature(false);
        self.refresh_lambert_material();
    }

    fn set_gaussian(&mut self, gaussian: LoadedGaussian) {
        self.settings.sigma_mm = gaussian.parameters.sigma_mm;
        self.gaussian = Some(gaussian);
        self.refresh_gaussian_materials();
        self.refresh_lambert_material();
    }

    /// Rebuilds the Lambert material: the albedo fitted to the measured table, or the
    /// Gaussian's scale (its κ → 0 limit) without a table.
    fn refresh_lambert_material(&mut self) {
        let albedo = match (&self.lut, &self.gaussian) {
            (Some(lut), _) => lut.lut.lambert_albedo(),
            (None, Some(gaussian)) => gaussian.parameters.scale,
            (None, None) => return,
        };
        let (device, queue) = (
            self.render_state.device.clone(),
            self.render_state.queue.clone(),
        );
        let old = self.ids.lambert.take();
        let created = self.with_gpu(|gpu| {
            if let Some(old) = old {
                gpu.renderer.remove_material(old);
            }
            gpu.renderer
                .create_material(&device, &queue, &MaterialDesc::Lambert { albedo })
        });
        match created {
            Some(Ok(id)) => self.ids.lambert = Some(id),
            Some(Err(error)) => self.error = Some(format!("Lambert: {error}")),
            None => {}
        }
    }

    /// Rebuilds the Gaussian table for the current σ.
    fn refresh_gaussian_materials(&mut self) {
        let Some(gaussian) = &self.gaussian else {
            return;
        };
        let model = match gaussian.model_with_sigma(self.settings.sigma_mm) {
            Ok(model) => model,
            Err(error) => {
                self.error = Some(format!("Gaussian CDRF: {error}"));
                return;
            }
        };
        let view_correction = gaussian.view_correction.clone();
        let (device, queue) = (
            self.render_state.device.clone(),
            self.render_state.queue.clone(),
        );
        let old = self.ids.gaussian.take();
        self.applied.sigma_mm = self.settings.sigma_mm;
        let start = Instant::now();
        let created = self.with_gpu(|gpu| {
            if let Some(old) = old {
                gpu.renderer.remove_material(old);
            }
            gpu.renderer.create_material(
                &device,
                &queue,
                &MaterialDesc::Gaussian {
                    model: &model,
                    view_correction: &view_correction,
                },
            )
        });
        self.gaussian_table_ms = Some(start.elapsed().as_secs_f64() * 1e3);
        match created {
            Some(Ok(id)) => self.ids.gaussian = Some(id),
            Some(Err(error)) => self.error = Some(format!("Gaussian CDRF: {error}")),
            None => {}
        }
    }

    fn refresh_curvature_material(&mut self) {
        let Some(mesh) = &self.mesh else {
            return;
        };
        let range_per_mm = mesh.curvature_view_range_per_mm(self.settings.mm_per_unit);
        let (device, queue) = (
            self.render_state.device.clone(),
            self.render_state.queue.clone(),
        );
        let old = self.ids.curvature.take();
        let created = self.with_gpu(|gpu| {
            if let Some(old) = old {
                gpu.renderer.remove_material(old);
            }
            gpu.renderer
                .create_material(&device, &queue, &MaterialDesc::Curvature { range_per_mm })
        });
        if let Some(Ok(id)) = created {
            self.ids.curvature = Some(id);
        }
    }

    fn material(&self, model: ShadingModel) -> Option<MaterialId> {
        match model {
            ShadingModel::Measured => self.ids.measured,
            ShadingModel::Gaussian => self.ids.gaussian,
            ShadingModel::Lambert => self.ids.lambert,
            ShadingModel::Curvature => self.ids.curvature,
        }
    }

    fn layout(&self) -> Layout {
        if self.settings.curvature_view {
            return Layout::Single;
        }
        match self.settings.compare {
            Compare::Single => Layout::Single,
            Compare::SideBySide => Layout::SideBySide,
            Compare::Split => Layout::Split,
            Compare::Difference => Layout::Difference,
        }
    }

    fn world_from_model(&self) -> Mat4 {
        Mat4::from_scale(Vec3::splat(self.settings.mm_per_unit))
    }

    /// Draws the whole UI into `ui` (the window's root).
    pub fn show(&mut self, ui: &mut egui::Ui) {
        self.frame_times.push(ui.input(|i| i.unstable_dt));
        self.take_dropped_files(ui);
        self.follow_settings();

        egui::Panel::top("cdrf-messages").show(ui, |ui| self.messages_bar(ui));
        egui::Panel::left("cdrf-controls")
            .resizable(false)
            .exact_size(270.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.controls(ui));
            });
        egui::Panel::right("cdrf-inspector")
            .resizable(false)
            .exact_size(330.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.inspector(ui));
            });
        egui::CentralPanel::default()
            .frame(egui::Frame::NONE)
            .show(ui, |ui| self.view_3d(ui));

        if self.settings.continuous {
            ui.ctx().request_repaint();
        }
    }

    fn take_dropped_files(&mut self, ui: &egui::Ui) {
        let dropped: Vec<PathBuf> = ui.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_owned())
                .collect()
        });
        for path in dropped {
            self.open(&path);
        }
    }

    fn messages_bar(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.heading("cdrf viewer");
            ui.label(
                RichText::new(
                    "translucency from a measured curvature-dependent reflectance function",
                )
                .weak(),
            );
        });
        if let Some(error) = self.error.clone() {
            ui.horizontal(|ui| {
                ui.label(
                    RichText::new(format!("Error: {error}")).color(ui.visuals().error_fg_color),
                );
                if ui.small_button("dismiss").clicked() {
                    self.error = None;
                }
            });
        } else if let Some(status) = &self.status {
            ui.label(RichText::new(status).weak());
        }
        ui.add_space(2.0);
    }

    fn controls(&mut self, ui: &mut egui::Ui) {
        ui.heading("Files");
        self.file_buttons(ui);
        ui.label(RichText::new("…or drop files or a fit folder on the window").weak());
        ui.separator();

        ui.heading("Model");
        self.look_buttons(ui);
        self.material_picker(ui);
        ui.separator();

        ui.heading("Compare");
        ui.horizontal(|ui| {
            let compare = &mut self.settings.compare;
            ui.selectable_value(compare, Compare::Single, "one");
            ui.selectable_value(compare, Compare::SideBySide, "side by side");
            ui.selectable_value(compare, Compare::Split, "split");
            ui.selectable_value(compare, Compare::Difference, "difference");
        });
        let sides = if self.settings.compare == Compare::Single {
            &["shown"][..]
        } else {
            &["left", "right"][..]
        };
        for (index, &side) in sides.iter().enumerate() {
            egui::ComboBox::from_label(side)
                .selected_text(self.settings.models[index].label())
                .show_ui(ui, |ui| {
                    for model in SLOT_MODELS {
                        ui.selectable_value(&mut self.settings.models[index], model, model.label());
                    }
                });
        }
        if self.settings.compare == Compare::Difference {
            ui.add(
                egui::Slider::new(&mut self.settings.difference_range, 0.001..=1.0)
                    .logarithmic(true)
                    .text("range (radiance)"),
            );
        }
        ui.checkbox(&mut self.settings.curvature_view, "curvature view (/mm)");
        ui.checkbox(&mut self.settings.non_local.shadows, "cast shadows")
            .on_hover_text("Translucent visibility from a shadow map: parts hidden from the light by other parts, with a penumbra as wide as the material's scattering length");
        ui.checkbox(&mut self.settings.non_local.transmission, "transmission")
            .on_hover_text("Light through thin parts (and, with cast shadows, through occluders) by the transmission profile T(d, μ) measured with the table");
        ui.checkbox(&mut self.settings.non_local.interreflection, "inter-reflection")
            .on_hover_text("One bounce of light between parts of the object that face each other (as a knot's strands), from the lit surface the light sees");
        ui.checkbox(&mut self.settings.non_local.subsurface, "subsurface gather")
            .on_hover_text("Light that entered the lit surface near each point (beside it, behind it, through an occluder), by the table's diffusion profile; replaces transmission's T(d, μ)");
        ui.separator();

        ui.heading("Light");
        let view_rotation = self.view_rotation();
        let mut to_light = self.settings.to_light();
        if panels::light_gizmo(ui, &mut to_light, view_rotation) {
            self.settings.set_to_light(to_light);
        }
        ui.add(
            egui::Slider::new(&mut self.settings.light_azimuth_deg, -180.0..=180.0)
                .text("azimuth °")
                .suffix("°"),
        )
        .on_hover_text("0° from the left (as photographed), 90° from the camera side, ±180° from the right, −90° from behind");
        ui.add(
            egui::Slider::new(&mut self.settings.light_elevation_deg, -90.0..=90.0)
                .text("elevation")
                .suffix("°"),
        );
        ui.horizontal(|ui| {
            for kind in LightKind::ALL {
                ui.selectable_value(&mut self.settings.light_kind, kind, kind.label());
            }
        });
        ui.add(egui::Slider::new(&mut self.settings.irradiance, 0.0..=10.0).text("irradiance E"))
            .on_hover_text("Directional: on a surface facing it. Point and spot: facing it at the origin (intensity = E · d²)");
        if self.settings.light_kind != LightKind::Directional {
            ui.add(
                egui::Slider::new(&mut self.settings.light_distance_mm, 20.0..=2000.0)
                    .logarithmic(true)
                    .text("distance mm"),
            );
        }
        ui.add(
            egui::Slider::new(&mut self.settings.exposure, 0.1..=20.0)
                .logarithmic(true)
                .text("exposure"),
        );
        ui.separator();

        ui.heading("Surface and sky");
        if self.mesh_is_textured() {
            ui.checkbox(&mut self.settings.textures, "asset textures")
                .on_hover_text("The file's glTF materials on the measured material: base colour as a tint (white = the material itself), normal map, specular roughness. Off: the bare material");
        }
        ui.checkbox(&mut self.settings.specular, "specular layer")
            .on_hover_text("First-surface reflection of a rough dielectric boundary (Beckmann, dielectric Fresnel) on every model; the light under it is scaled by what the boundary lets through. Off: the cross-polarised look the tables were measured in");
        if self.settings.specular {
            ui.add(
                egui::Slider::new(&mut self.settings.specular_roughness, 0.01..=1.0)
                    .text("roughness α"),
            );
            ui.add(egui::Slider::new(&mut self.settings.ior, 1.01..=3.0).text("IOR"));
        }
        match &self.environment {
            Some(environment) => {
                ui.label(format!("environment: {}", file_name(&environment.path)));
                ui.add(
                    egui::Slider::new(&mut self.settings.environment_intensity, 0.0..=10.0)
                        .text("intensity"),
                );
                ui.add(
                    egui::Slider::new(&mut self.settings.environment_rotate_deg, -180.0..=180.0)
                        .text("rotate")
                        .suffix("°"),
                );
                if ui.button("remove environment").clicked() {
                    self.environment = None;
                }
            }
            None => {
                ui.add(
                    egui::Slider::new(&mut self.settings.sky_radiance, 0.0..=1.0)
                        .text("uniform sky L"),
                )
                .on_hover_text("Radiance of a uniform sky; drop an equirectangular OpenEXR for an environment map");
            }
        }
        ui.separator();

        ui.heading("Gaussian CDRF");
        if self.gaussian.is_some() {
            ui.horizontal(|ui| {
                ui.label("σ mm");
                for (value, channel) in self.settings.sigma_mm.iter_mut().zip(["R", "G", "B"]) {
                    ui.add(
                        egui::DragValue::new(value)
                            .speed(0.01)
                            .range(0.0..=50.0)
                            .prefix(format!("{channel} ")),
                    );
                }
            });
            ui.horizontal(|ui| {
                if ui.button("reset to fitted").clicked()
                    && let Some(gaussian) = &self.gaussian
                {
                    self.settings.sigma_mm = gaussian.parameters.sigma_mm;
                }
                if let Some(ms) = self
                    .gaussian_table_ms
                    .filter(|_| self.settings.show_timings)
                {
                    ui.label(RichText::new(format!("table built in {ms:.0} ms")).weak());
                }
            });
        } else {
            ui.label("no gaussian.toml loaded");
        }
        ui.separator();

        ui.heading("Mesh");
        ui.add(
            egui::DragValue::new(&mut self.settings.mm_per_unit)
                .speed(0.05)
                .range(1e-3..=1e6)
                .suffix(" mm per unit"),
        );
        if ui.button("reset view").clicked() {
            self.frame_on_next_view = true;
        }
    }

    /// Rebuilds what depends on settings changed since the last frame (by the UI or through
    /// [`ViewerApp::settings_mut`]).
    fn follow_settings(&mut self) {
        if self.settings.sigma_mm != self.applied.sigma_mm {
            self.refresh_gaussian_materials();
        }
        let (scale, applied_scale) = (self.settings.mm_per_unit, self.applied.mm_per_unit);
        if scale != applied_scale && scale > 0.0 && applied_scale > 0.0 {
            // Keep the framing: the camera follows the scale change about the origin.
            let ratio = scale / applied_scale;
            self.camera.target *= ratio;
            self.camera.distance_mm *= ratio;
            self.filter_curvature(false);
            self.refresh_curvature_material();
        }
        self.applied.mm_per_unit = scale;

        let layer = self.settings.specular_layer();
        let ids = [self.ids.measured, self.ids.gaussian, self.ids.lambert];
        if self.applied.specular != Some((layer, ids)) {
            let queue = self.render_state.queue.clone();
            let failed = self.with_gpu(|gpu| {
                ids.into_iter()
                    .flatten()
                    .find_map(|id| gpu.renderer.set_material_specular(&queue, id, layer).err())
            });
            if let Some(Some(error)) = failed {
                self.error = Some(format!("specular layer: {error}"));
            }
            self.applied.specular = Some((layer, ids));
        }

        let key = EnvironmentKey {
            intensity: self.settings.environment_intensity,
            rotate_deg: self.settings.environment_rotate_deg,
            sky_radiance: self.settings.sky_radiance,
            map: self.environment.as_ref().map(|e| e.path.clone()),
        };
        if self.applied.environment.as_ref().map(|(k, _)| k) != Some(&key) {
            let environment = match &self.environment {
                Some(loaded) if key.intensity > 0.0 => Environment::new(
                    EnvironmentRadiance::Map(loaded.map.clone()),
                    key.intensity,
                    key.rotate_deg,
                )
                .map(Some),
                None if key.sky_radiance > 0.0 => {
                    Environment::uniform([key.sky_radiance; 3]).map(Some)
                }
                _ => Ok(None),
            };
            let sh = match environment {
                Ok(environment) => environment.map(|e| e.project_sh(ENVIRONMENT_SH_ORDER)),
                Err(error) => {
                    self.error = Some(format!("environment: {error}"));
                    None
                }
            };
            self.applied.environment = Some((key, sh));
        }
    }

    /// The two looks one click apart: every non-local term, or the poster's model alone.
    fn look_buttons(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            let non_local = &mut self.settings.non_local;
            ui.selectable_value(non_local, NonLocal::ALL, "every term")
                .on_hover_text("The measured table with cast shadows, transmission, inter-reflection and the subsurface gather");
            ui.selectable_value(non_local, NonLocal::OFF, "poster's model")
                .on_hover_text("The measured table alone: a local CDRF, as in Okamoto et al. 2014");
        });
        let no_profile = self
            .lut
            .as_ref()
            .is_some_and(|lut| lut.lut.diffusion_profile().is_none());
        if self.settings.non_local.subsurface && no_profile {
            ui.label(
                RichText::new("this table has no diffusion profile: no subsurface gather (transmission instead)")
                    .color(ui.visuals().warn_fg_color),
            );
        }
    }

    /// Picks the measured table: the bundled fit, or a preset medium (cdrf-preset's tables,
    /// computed on first use).
    fn material_picker(&mut self, ui: &mut egui::Ui) {
        let current = self.material.clone();
        let mut picked: Option<String> = None;
        egui::ComboBox::from_label("material")
            .selected_text(current.clone())
            .show_ui(ui, |ui| {
                for name in std::iter::once(BUNDLED_MATERIAL).chain(cdrf_core::presets::names()) {
                    if ui.selectable_label(current == name, name).clicked() {
                        picked = Some(name.to_owned());
                    }
                }
            })
            .response
            .on_hover_text("The bundled fit to the wax photographs, or a material built into cdrf-core: a table fitted to simulated spheres of the medium (cdrf-preset makes more)");
        if let Some(name) = picked.filter(|name| *name != current) {
            self.pick_material(&name);
        }
    }

    fn pick_material(&mut self, name: &str) {
        if name == BUNDLED_MATERIAL {
            self.open(&bundled_data_dir().join("wax-fit"));
            return;
        }
        let made = cdrf_core::presets::lut(name)
            .and_then(|lut| Ok((lut.clone(), cdrf_core::presets::gaussian(name)?)));
        match made {
            Ok((lut, gaussian)) => {
                let path = PathBuf::from(format!("{PRESET_PREFIX}{name}"));
                self.error = None;
                self.set_gaussian(LoadedGaussian {
                    path: path.clone(),
                    parameters: GaussianParameters {
                        sigma_mm: gaussian.sigma_mm(),
                        scale: gaussian.scale(),
                        view_correction_from: None,
                    },
                    view_correction: lut.view_correction().clone(),
                });
                self.set_lut(LoadedLut { path, lut });
            }
            Err(error) => self.error = Some(format!("preset {name}: {error}")),
        }
    }

    fn file_buttons(&mut self, ui: &mut egui::Ui) {
        let mut picked: Option<PathBuf> = None;
        ui.horizontal_wrapped(|ui| {
            if ui.button("mesh…").clicked() {
                picked = rfd::FileDialog::new()
                    .add_filter("mesh", &["obj", "gltf", "glb"])
                    .pick_file();
            }
            if ui.button("LUT…").clicked() {
                picked = rfd::FileDialog::new()
                    .add_filter("measured CDRF", &["exr"])
                    .pick_file();
            }
            if ui.button("Gaussian…").clicked() {
                picked = rfd::FileDialog::new()
                    .add_filter("Gaussian CDRF", &["toml"])
                    .pick_file();
            }
            if ui.button("fit folder…").clicked() {
                picked = rfd::FileDialog::new().pick_folder();
            }
            if ui.button("environment…").clicked() {
                picked = rfd::FileDialog::new()
                    .add_filter("equirectangular environment map", &["exr"])
                    .pick_file();
            }
        });
        if let Some(path) = picked {
            self.open(&path);
        }
        let name = |path: Option<&Path>| path.map_or("—".to_owned(), file_name);
        egui::Grid::new("cdrf-files").num_columns(2).show(ui, |ui| {
            ui.label("mesh");
            ui.label(name(self.mesh.as_ref().map(|m| m.path.as_path())));
            ui.end_row();
            ui.label("LUT");
            ui.label(name(self.lut.as_ref().map(|l| l.path.as_path())));
            ui.end_row();
            ui.label("Gaussian");
            ui.label(name(self.gaussian.as_ref().map(|g| g.path.as_path())));
            ui.end_row();
        });
    }

    /// Rotation from world to camera space (for the light gizmo).
    fn view_rotation(&self) -> Mat3 {
        let forward = (self.camera.target - self.camera.eye()).normalize();
        let right = forward.cross(Vec3::Y).normalize();
        let up = right.cross(forward);
        Mat3::from_cols(right, up, -forward).transpose()
    }

    fn inspector(&mut self, ui: &mut egui::Ui) {
        ui.heading("Under the pointer");
        match self.hover {
            Some(hover) => {
                let curvature = hover.curvature_per_mm;
                egui::Grid::new("cdrf-hover").num_columns(2).show(ui, |ui| {
                    ui.label("κ");
                    ui.label(format!("{curvature:.4} /mm"));
                    ui.end_row();
                    ui.label("1/κ");
                    ui.label(if curvature.abs() > 1e-6 {
                        format!("{:.1} mm", 1.0 / curvature)
                    } else {
                        "flat".to_owned()
                    });
                    ui.end_row();
                    ui.label("θ (normal, light)");
                    ui.label(format!("{:.1}°", hover.theta_rad.to_degrees()));
                    ui.end_row();
                    ui.label("φ (normal, view)");
                    ui.label(format!("{:.1}°", hover.phi_rad.to_degrees()));
                    ui.end_row();
                    if let Some(lut) = &self.lut {
                        let f = lut.lut.sample(curvature, hover.theta_rad, Filter::Bilinear);
                        ui.label("f measured");
                        ui.label(format!("{:.3} {:.3} {:.3}", f.x, f.y, f.z));
                        ui.end_row();
                    }
                    if let Some(model) = self.gaussian_model() {
                        let f = model.reflectance(curvature, hover.theta_rad);
                        ui.label("f Gaussian");
                        ui.label(format!("{:.3} {:.3} {:.3}", f[0], f[1], f[2]));
                        ui.end_row();
                    }
                });
            }
            None => {
                ui.label(RichText::new("hover over the mesh").weak());
            }
        }
        if self.settings.plot_follows_pointer
            && let Some(hover) = self.hover
        {
            self.settings.plot_curvature_per_mm = hover.curvature_per_mm;
        }
        ui.separator();

        ui.heading("Measured LUT f(κ, θ)");
        if let Some(lut) = &self.lut {
            let texture = self
                .lut_image
                .get_or_insert_with(|| panels::lut_texture(ui.ctx(), &lut.lut))
                .clone();
            panels::lut_image(ui, &lut.lut, &texture, self.hover);
        } else {
            ui.label("no LUT loaded");
        }
        ui.separator();

        ui.heading("f(θ) at one curvature");
        let range = self
            .lut
            .as_ref()
            .map(|lut| {
                let axis = lut.lut.curvature_axis();
                (
                    axis.curvature_per_mm(0),
                    axis.curvature_per_mm(axis.count - 1),
                )
            })
            .unwrap_or((0.0, 0.2));
        ui.horizontal(|ui| {
            ui.add(
                egui::DragValue::new(&mut self.settings.plot_curvature_per_mm)
                    .speed(0.001)
                    .range(0.0..=range.1.max(range.0) * 2.0)
                    .prefix("κ ")
                    .suffix(" /mm"),
            );
            ui.checkbox(&mut self.settings.plot_follows_pointer, "follow pointer");
        });
        let gaussian = self.gaussian_model();
        panels::radiance_plot(
            ui,
            self.settings.plot_curvature_per_mm,
            self.lut.as_ref().map(|l| &l.lut),
            gaussian.as_ref(),
            self.hover.map(|h| h.theta_rad),
        );
        ui.separator();

        ui.heading("Mesh");
        if let Some(mesh) = &self.mesh {
            let scale = self.settings.mm_per_unit;
            let (min, median, max) = mesh.curvature_summary_per_mm(scale);
            let size = mesh.extent * scale;
            egui::Grid::new("cdrf-mesh").num_columns(2).show(ui, |ui| {
                ui.label("vertices");
                ui.label(mesh.mesh.positions.len().to_string());
                ui.end_row();
                ui.label("triangles");
                ui.label(mesh.mesh.triangles.len().to_string());
                ui.end_row();
                ui.label("size");
                ui.label(format!("{:.1} × {:.1} × {:.1} mm", size.x, size.y, size.z));
                ui.end_row();
                ui.label("κ min / median / max");
                ui.label(format!("{min:.3} / {median:.3} / {max:.3} /mm"));
                ui.end_row();
            });
        } else {
            ui.label("no mesh loaded");
        }
        ui.separator();

        ui.heading("Frame");
        if let Some(ms) = self
            .frame_times
            .mean_ms()
            .filter(|_| self.settings.show_timings)
        {
            ui.label(format!(
                "{ms:.1} ms between frames ({:.0} fps, last {})",
                1e3 / ms,
                self.frame_times.seconds.len()
            ));
        }
        ui.checkbox(&mut self.settings.continuous, "repaint continuously")
            .on_hover_text("frame times mean something only while repainting continuously");
        let info = self.render_state.adapter.get_info();
        ui.label(RichText::new(format!("{} ({:?})", info.name, info.backend)).weak());
    }

    fn gaussian_model(&self) -> Option<cdrf_core::gaussian::GaussianCdrf> {
        self.gaussian
            .as_ref()
            .and_then(|g| g.model_with_sigma(self.settings.sigma_mm).ok())
    }

    fn view_3d(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        let layout = self.layout();
        let pixels_per_point = ui.ctx().pixels_per_point();
        let size_points = Vec2::new(rect.width(), rect.height());
        let slot_pixels = slot_size_pixels(layout, size_points, pixels_per_point);
        let slot_points = Vec2::new(
            slot_pixels[0] as f32 / pixels_per_point,
            slot_pixels[1] as f32 / pixels_per_point,
        );
        self.interact(ui, &response, rect, layout);

        let (center, radius_mm) = self.bounding_sphere_mm();
        if std::mem::take(&mut self.frame_on_next_view) {
            let aspect = slot_pixels[0] as f32 / slot_pixels[1] as f32;
            self.camera = OrbitCamera::framing(center, radius_mm, aspect);
        }
        let view = self
            .camera
            .view(slot_pixels[0], slot_pixels[1], center, radius_mm);
        self.hover = response
            .hover_pos()
            .and_then(|pointer| self.pick(pointer, rect, layout, slot_points, view));

        let materials = if self.settings.curvature_view {
            [self.ids.curvature, None]
        } else {
            self.settings.models.map(|model| self.material(model))
        };
        let callback = ViewCallback {
            view,
            lights: vec![self.settings.light()],
            exposure: self.settings.exposure,
            mesh: self.ids.mesh,
            primitives: self.primitives(),
            world_from_model: self.world_from_model(),
            materials,
            layout,
            split: self.settings.split,
            difference_range: self.settings.difference_range,
            size_points,
            background: BACKGROUND,
            non_local: self.settings.non_local,
            environment: self
                .applied
                .environment
                .as_ref()
                .and_then(|(_, sh)| sh.clone()),
        };
        ui.painter()
            .add(egui_wgpu::Callback::new_paint_callback(rect, callback));
        if let Some(error) = self.with_gpu(|gpu| gpu.last_error.clone()).flatten() {
            self.error = Some(format!("rendering: {error}"));
        }
        panels::view_overlay(
            ui,
            rect,
            layout,
            &self.settings,
            slot_points,
            &self.missing(),
        );
        if self.settings.show_timings {
            self.frame_time_overlay(ui, rect);
        }
        if self.settings.curvature_view
            && let Some(mesh) = &self.mesh
        {
            let range = mesh.curvature_view_range_per_mm(self.settings.mm_per_unit);
            panels::curvature_legend(ui, rect, range);
        }
    }

    /// The frame time in the view's lower right corner; a click starts or stops repainting
    /// continuously (the time between frames means nothing otherwise).
    fn frame_time_overlay(&mut self, ui: &mut egui::Ui, rect: egui::Rect) {
        let text = match self
            .frame_times
            .mean_ms()
            .filter(|_| self.settings.continuous)
        {
            Some(ms) => format!("{ms:.1} ms per frame ({:.0} fps)", 1e3 / ms),
            None => "frame time: click to repaint continuously".to_owned(),
        };
        let size = egui::vec2(300.0, 20.0);
        let area =
            egui::Rect::from_min_size(rect.right_bottom() - size - egui::vec2(8.0, 6.0), size);
        let label = egui::Label::new(RichText::new(text).weak()).sense(egui::Sense::click());
        let response = ui
            .scope_builder(
                egui::UiBuilder::new()
                    .max_rect(area)
                    .layout(egui::Layout::right_to_left(egui::Align::Center)),
                |ui| ui.add(label),
            )
            .inner;
        if response.clicked() {
            self.settings.continuous = !self.settings.continuous;
            self.frame_times = FrameTimes::default();
        }
    }

    /// Names of models shown but not loaded, per slot.
    fn missing(&self) -> [Option<&'static str>; 2] {
        self.settings
            .models
            .map(|model| match self.material(model) {
                Some(_) => None,
                None if self.mesh.is_none() => Some("no mesh loaded"),
                None => Some(match model {
                    ShadingModel::Measured => "no LUT loaded",
                    ShadingModel::Gaussian | ShadingModel::Lambert => "no gaussian.toml loaded",
                    ShadingModel::Curvature => "no curvature view",
                }),
            })
    }

    fn bounding_sphere_mm(&self) -> (Vec3, f32) {
        match &self.mesh {
            Some(mesh) => (
                mesh.center * self.settings.mm_per_unit,
                mesh.radius * self.settings.mm_per_unit,
            ),
            None => (Vec3::ZERO, 50.0),
        }
    }

    fn interact(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        rect: egui::Rect,
        layout: Layout,
    ) {
        let height = rect.height().max(1.0);
        if response.drag_started() {
            let split_x = rect.min.x + self.settings.split * rect.width();
            self.dragging_split = layout == Layout::Split
                && response
                    .interact_pointer_pos()
                    .is_some_and(|p| (p.x - split_x).abs() < 8.0);
        }
        if response.dragged() {
            let delta = response.drag_delta();
            if self.dragging_split {
                if let Some(pointer) = response.interact_pointer_pos() {
                    self.settings.split =
                        ((pointer.x - rect.min.x) / rect.width().max(1.0)).clamp(0.0, 1.0);
                }
            } else if response.dragged_by(egui::PointerButton::Primary)
                && !ui.input(|i| i.modifiers.shift)
            {
                self.camera.orbit(Vec2::new(delta.x, delta.y) / height);
            } else {
                self.camera.pan(Vec2::new(delta.x, delta.y) / height);
            }
        }
        if response.drag_stopped() {
            self.dragging_split = false;
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.camera.zoom((scroll * 0.002).exp());
            }
        }
        if response.double_clicked() {
            self.frame_on_next_view = true;
        }
    }

    fn pick(
        &self,
        pointer: egui::Pos2,
        rect: egui::Rect,
        layout: Layout,
        slot_points: Vec2,
        view: cdrf_render::View,
    ) -> Option<Hover> {
        let mesh = self.mesh.as_ref()?;
        let mut local = Vec2::new(pointer.x - rect.min.x, pointer.y - rect.min.y);
        let mut slot = 0;
        match layout {
            Layout::SideBySide if local.x >= slot_points.x => {
                local.x -= slot_points.x;
                slot = 1;
            }
            Layout::Split if local.x >= self.settings.split * rect.width() => slot = 1,
            _ => {}
        }
        let uv = local / slot_points.max(Vec2::ONE);
        if !(0.0..=1.0).contains(&uv.x) || !(0.0..=1.0).contains(&uv.y) {
            return None;
        }
        let ndc = Vec2::new(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
        let (origin, direction) = OrbitCamera::ray(view.clip_from_world, ndc)?;
        let model_from_world = self.world_from_model().inverse();
        let origin_model = model_from_world.transform_point3(origin);
        let direction_model = model_from_world.transform_vector3(direction).normalize();
        let hit = crate::pick::pick(&mesh.mesh, origin_model, direction_model)?;
        let normal = hit
            .interpolate(&mesh.mesh, &mesh.mesh.normals)
            .normalize_or_zero();
        let curvature_per_unit = hit.interpolate(&mesh.mesh, &mesh.curvature_per_unit);
        let point = self
            .world_from_model()
            .transform_point3(hit.interpolate(&mesh.mesh, &mesh.mesh.positions));
        let to_eye = (self.camera.eye() - point).normalize_or_zero();
        Some(Hover {
            slot,
            curvature_per_mm: curvature_per_unit / self.settings.mm_per_unit,
            theta_rad: normal.dot(self.settings.to_light()).clamp(-1.0, 1.0).acos(),
            phi_rad: normal.dot(to_eye).clamp(-1.0, 1.0).acos(),
        })
    }
}

/// The material picker's name of the bundled fit.
const BUNDLED_MATERIAL: &str = "wax (bundled fit)";
/// What a preset's "path" starts with (it has no file).
const PRESET_PREFIX: &str = "preset: ";

/// The material picker's name of a table loaded from `path`: the bundled fit's table (however
/// its path is spelt), a preset, or the file's name.
fn material_name(path: &Path) -> String {
    let text = path.to_string_lossy();
    if let Some(name) = text.strip_prefix(PRESET_PREFIX) {
        return name.to_owned();
    }
    let bundled = bundled_data_dir().join("wax-fit").join(FIT_LUT_FILE);
    match (path.canonicalize(), bundled.canonicalize()) {
        (Ok(path), Ok(bundled)) if path == bundled => BUNDLED_MATERIAL.to_owned(),
        _ => file_name(path),
    }
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .unwrap_or(path.as_os_str())
        .to_string_lossy()
        .into_owned()
}

impl eframe::App for ViewerApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.show(ui);
    }
}

/// Colour of a model's label.
pub(crate) fn model_colour(model: ShadingModel) -> Color32 {
    match model {
        ShadingModel::Measured => Color32::from_rgb(255, 190, 120),
        ShadingModel::Gaussian => Color32::from_rgb(150, 200, 255),
        ShadingModel::Lambert | ShadingModel::Curvature => Color32::from_rgb(200, 200, 200),
    }
}
