//! cdrf in Bevy: meshes shaded with a measured curvature-dependent reflectance function —
//! translucent wax, skin and marble that glow past the terminator — inside a Bevy 0.20 app,
//! lit by Bevy's lights, seen by Bevy's cameras, depth-tested against Bevy's meshes.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use cdrf_bevy::{CdrfMaterial, CdrfMaterial3d, CdrfPlugin};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, CdrfPlugin::default()))
//!     .add_systems(Startup, |mut commands: Commands, assets: Res<AssetServer>,
//!                            mut materials: ResMut<Assets<CdrfMaterial>>| {
//!         commands.spawn((
//!             Mesh3d(assets.load("bunny.glb#Mesh0/Primitive0")),
//!             CdrfMaterial3d(materials.add(CdrfMaterial::from_lut(assets.load("wax/measured.exr")))),
//!         ));
//!     })
//!     .run();
//! ```
//!
//! # How it works
//! The plugin drives cdrf-render's [`Renderer`](cdrf_render::Renderer) on Bevy's device: one
//! renderer per kind of target (format, MSAA) the 3D cameras render into, prepared once a frame
//! in `RenderSystems::Prepare` and recorded in each camera's `Core3d` schedule right after
//! Bevy's opaque pass, from that camera's view, into its main (HDR) texture with its MSAA and
//! its reversed-Z depth buffer. So CDRF meshes and Bevy's meshes hide each other, and Bevy's
//! transparent pass, tonemapping, exposure and bloom apply to them as to any mesh. The pixels
//! are the ones cdrf's own viewer renders, non-local terms included; CDRF meshes are not
//! shadowed by Bevy's shadow maps (their own cast shadows are translucent, with a penumbra as
//! wide as the material's scattering length) and do not cast shadows onto Bevy's meshes.
//!
//! - Lights: Bevy's directional, point and spot lights, its `GlobalAmbientLight` and a camera's
//!   `EnvironmentMapLight` (its diffuse map as the sky's spherical harmonics); units in
//!   [`units`].
//! - Meshes: curvature is computed once per mesh asset (and material diffusion length) when it
//!   is first drawn, in model units × [`CdrfSettings::mm_per_unit`]. Skinned meshes
//!   (`SkinnedMesh`, e.g. a glTF character) are skinned on the CPU each frame with the rest
//!   pose's curvature.
//! - glTF scenes: [`CdrfOverride`] draws a scene's meshes in a CDRF material painted with their
//!   `StandardMaterial`'s base colour, normal map and roughness ([`CdrfSurface`]).

mod assets;
mod environment;
mod frame;
mod render;
mod skinning;
mod surface;
pub mod units;

use bevy::asset::AssetApp;
use bevy::core_pipeline::core_3d::{main_opaque_pass_3d, main_transparent_pass_3d};
use bevy::core_pipeline::{Core3d, Core3dSystems};
use bevy::prelude::*;
use bevy::render::{ExtractSchedule, Render, RenderApp, RenderSystems};
use cdrf_core::light::NonLocal;

pub use assets::{
    CdrfMaterial, CdrfMaterial3d, CdrfModel, CdrfTable, CdrfTableLoadError, CdrfTableLoader,
};
pub use frame::{MeshConversionError, PreparedMesh, mesh_from_cdrf, prepare_mesh};
pub use surface::{CdrfOverride, CdrfSurface};

/// What the plugin renders with; a resource, so it can change at run time (e.g. a toggle of
/// the non-local terms).
#[derive(Resource, Clone, Debug)]
pub struct CdrfSettings {
    /// Millimetres per Bevy world unit (1000: Bevy's units are metres). The tables are
    /// measured in mm: a 1-unit sphere is a 1 m sphere, nearly opaque.
    pub mm_per_unit: f32,
    /// The non-local terms: shadows, transmission, the subsurface gather, inter-reflection.
    pub non_local: NonLocal,
    /// cdrf-render's options (shadow-map size, patches, …). The depth test is always Bevy's
    /// reversed Z, whatever `depth_compare` says.
    pub options: cdrf_render::Options,
}

impl Default for CdrfSettings {
    fn default() -> Self {
        Self {
            mm_per_unit: 1000.0,
            non_local: NonLocal::ALL,
            options: cdrf_render::Options::default(),
        }
    }
}

/// Adds the CDRF assets (tables, materials) and the pass to every 3D camera.
#[derive(Default)]
pub struct CdrfPlugin {
    /// The initial [`CdrfSettings`].
    pub settings: CdrfSettings,
}

impl Plugin for CdrfPlugin {
    fn build(&self, app: &mut App) {
        app.init_asset::<CdrfTable>()
            .init_asset::<CdrfMaterial>()
            .init_asset_loader::<CdrfTableLoader>()
            .insert_resource(self.settings.clone())
            .init_resource::<frame::CdrfFrame>()
            .init_resource::<frame::CdrfCaches>()
            .add_systems(
                PostUpdate,
                (
                    surface::apply_overrides,
                    frame::invalidate_caches,
                    frame::gather_frame,
                )
                    .chain()
                    .after(TransformSystems::Propagate)
                    .after(bevy::camera::visibility::VisibilitySystems::VisibilityPropagate),
            );
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .init_resource::<frame::CdrfFrame>()
            .init_resource::<render::CdrfViews>()
            .add_systems(ExtractSchedule, render::extract_frame)
            .add_systems(Render, render::prepare_views.in_set(RenderSystems::Prepare))
            .add_systems(
                Core3d,
                render::cdrf_main_pass_3d
                    .after(main_opaque_pass_3d)
                    .before(main_transparent_pass_3d)
                    .in_set(Core3dSystems::MainPass),
            );
    }
}
