//! The assets a Bevy app loads: measured tables (`.exr` from cdrf-fit or cdrf-preset) and the
//! materials that use them.

use std::path::Path;
use std::sync::Arc;

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext};
use bevy::prelude::*;
use cdrf_core::CdrfLut;
use cdrf_core::lut_file::LutFileError;
use cdrf_core::presets::PresetError;
use cdrf_core::specular::SpecularLayer;

/// A measured table f(κ, θ) with its view correction and material terms: cdrf-fit's
/// `measured.exr` or a `cdrf-preset` output, loaded by the asset server (hot reload included).
#[derive(Asset, TypePath, Clone, Debug)]
pub struct CdrfTable(pub Arc<CdrfLut>);

/// Reads tables (`.exr`) for `AssetServer::load::<CdrfTable>`.
#[derive(Default, TypePath)]
pub struct CdrfTableLoader;

/// Why a table file could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum CdrfTableLoadError {
    /// The asset source could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The asset path.
        path: String,
        /// The reader's error.
        source: std::io::Error,
    },
    /// The file is not a valid table (the message names the file and the problem).
    #[error(transparent)]
    Table(#[from] LutFileError),
}

impl AssetLoader for CdrfTableLoader {
    type Asset = CdrfTable;
    type Settings = ();
    type Error = CdrfTableLoadError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        load_context: &mut LoadContext<'_>,
    ) -> Result<CdrfTable, CdrfTableLoadError> {
        let path = load_context.path().to_string();
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .await
            .map_err(|source| CdrfTableLoadError::Io {
                path: path.clone(),
                source,
            })?;
        let lut = cdrf_core::lut_file::read_lut_bytes(&bytes, Path::new(&path))?;
        Ok(CdrfTable(Arc::new(lut)))
    }

    fn extensions(&self) -> &[&str] {
        &["exr"]
    }
}

/// How a CDRF mesh is shaded: a measured table, loaded as an asset or built in, and
/// optionally a first-surface reflection on top.
#[derive(Asset, TypePath, Clone, Debug)]
pub struct CdrfMaterial {
    /// The table.
    pub model: CdrfModel,
    /// A rough dielectric boundary's specular reflection (`None`: the subsurface light only).
    /// A surface's roughness ([`CdrfOverride`](crate::CdrfOverride)'s `StandardMaterial`)
    /// replaces its roughness per pixel.
    pub specular: Option<SpecularLayer>,
}

/// Where a material's table comes from.
#[derive(Clone, Debug)]
pub enum CdrfModel {
    /// A table file loaded by the asset server.
    Table(Handle<CdrfTable>),
    /// A table in memory: a built-in one ([`CdrfMaterial::preset`]) or one the app made.
    Lut(Arc<CdrfLut>),
    /// Lambert's opaque diffuse surface (`π·L/E = albedo · cos θ`), for comparison.
    Lambert {
        /// Albedo per linear RGB channel.
        albedo: [f32; 3],
    },
}

/// A material ready to draw: its table loaded.
#[derive(Debug)]
pub(crate) struct ResolvedMaterial {
    pub(crate) model: ResolvedModel,
    pub(crate) specular: Option<SpecularLayer>,
}

#[derive(Debug)]
pub(crate) enum ResolvedModel {
    Measured(Arc<CdrfLut>),
    Lambert([f32; 3]),
}

impl ResolvedMaterial {
    /// How far light travels under the surface, mm (the curvature filter's length).
    pub(crate) fn diffusion_length_mm(&self) -> Option<f32> {
        match &self.model {
            ResolvedModel::Measured(lut) => lut.diffusion_length_mm(),
            ResolvedModel::Lambert(_) => None,
        }
    }
}

impl CdrfMaterial {
    /// A material whose table is a loaded `.exr` (`assets.load("wax/measured.exr")`).
    pub fn from_lut(table: Handle<CdrfTable>) -> Self {
        Self {
            model: CdrfModel::Table(table),
            specular: None,
        }
    }

    /// A built-in material by name ([`cdrf_core::presets::names`], case-insensitive).
    ///
    /// # Errors
    /// [`PresetError`] for an unknown name.
    pub fn preset(name: &str) -> Result<Self, PresetError> {
        Ok(Self {
            model: CdrfModel::Lut(Arc::new(cdrf_core::presets::lut(name)?.clone())),
            specular: None,
        })
    }

    /// A material of a table in memory (e.g. read with [`cdrf_core::read_lut`]).
    pub fn from_table(lut: CdrfLut) -> Self {
        Self {
            model: CdrfModel::Lut(Arc::new(lut)),
            specular: None,
        }
    }

    /// Lambert's diffuse surface of `albedo` (linear RGB).
    pub fn lambert(albedo: [f32; 3]) -> Self {
        Self {
            model: CdrfModel::Lambert { albedo },
            specular: None,
        }
    }

    /// With a specular layer on top (e.g. [`SpecularLayer::new`]).
    pub fn with_specular(self, layer: SpecularLayer) -> Self {
        Self {
            specular: Some(layer),
            ..self
        }
    }

    /// The material ready to draw (`None` while its table loads).
    pub(crate) fn resolve(&self, tables: &Assets<CdrfTable>) -> Option<ResolvedMaterial> {
        let model = match &self.model {
            CdrfModel::Table(handle) => ResolvedModel::Measured(tables.get(handle)?.0.clone()),
            CdrfModel::Lut(lut) => ResolvedModel::Measured(lut.clone()),
            CdrfModel::Lambert { albedo } => ResolvedModel::Lambert(*albedo),
        };
        Some(ResolvedMaterial {
            model,
            specular: self.specular,
        })
    }
}

/// Shades the entity's `Mesh3d` with cdrf-render's pass instead of Bevy's PBR (the entity needs
/// no `MeshMaterial3d`).
#[derive(Component, Clone, Debug, Default, Deref, DerefMut)]
#[require(Transform, Visibility)]
pub struct CdrfMaterial3d(pub Handle<CdrfMaterial>);
