//! What is compared: the models of one fit, and each rendered with a set of non-local terms.

use std::fmt;
use std::path::Path;

use cdrf_core::gaussian::GaussianCdrf;
use cdrf_core::light::NonLocal;
use cdrf_core::{CdrfLut, ShadingModel, ViewCorrection, read_gaussian, read_lut};
use serde::{Serialize, Serializer};

use crate::error::CompareError;

/// The three models of one fit.
#[derive(Clone, Debug)]
pub struct Models {
    /// The measured table (with its view correction).
    pub measured: CdrfLut,
    /// Kubo's Gaussian CDRF fitted to the same photographs.
    pub gaussian: GaussianCdrf,
    /// The view correction the Gaussian shares with the table.
    pub view_correction: ViewCorrection,
    /// Lambert's albedo per channel ([`CdrfLut::lambert_albedo`]).
    pub lambert_albedo: [f32; 3],
}

impl Models {
    /// The models of a fit: its measured table (cdrf-fit's `measured.exr`) and its Gaussian
    /// parameters (`gaussian.toml`, with the view correction it names).
    ///
    /// # Errors
    /// [`CompareError::Lut`] or [`CompareError::Gaussian`], naming the file.
    pub fn from_files(lut: &Path, gaussian: &Path) -> Result<Self, CompareError> {
        let lut = read_lut(lut)?;
        let (model, view_correction) = read_gaussian(gaussian)?.load_model(gaussian)?;
        Ok(Self {
            lambert_albedo: lut.lambert_albedo(),
            measured: lut,
            gaussian: model,
            view_correction,
        })
    }
}

/// A model compared with a reference. Its [`name`](Self::name) is its key in `compare.json`
/// and its [`label`](Self::label) its column heading in the tables and figures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ComparedModel {
    /// A model of the fit with non-local terms added to it.
    Shaded {
        /// The measured CDRF, the Gaussian CDRF or Lambert (with the fitted albedo).
        model: ShadingModel,
        /// The terms added.
        non_local: NonLocal,
    },
    /// The scene's specular layer over a black medium: the model of a
    /// [`ReferenceLayer::Specular`](crate::ReferenceLayer::Specular) case.
    SpecularLayer {
        /// The terms added.
        non_local: NonLocal,
    },
}

/// Cast shadows.
const SHADOWS: NonLocal = NonLocal {
    shadows: true,
    ..NonLocal::OFF
};
/// Transmission by T(d, μ).
const TRANSMISSION: NonLocal = NonLocal {
    transmission: true,
    ..NonLocal::OFF
};
/// Cast shadows and T(d, μ).
const SHADOWS_TRANSMISSION: NonLocal = NonLocal {
    shadows: true,
    transmission: true,
    ..NonLocal::OFF
};
/// Cast shadows and the subsurface gather (in place of T(d, μ)).
const SHADOWS_SUBSURFACE: NonLocal = NonLocal {
    shadows: true,
    transmission: true,
    subsurface: true,
    ..NonLocal::OFF
};

impl ComparedModel {
    /// A model of the fit with `non_local`.
    pub const fn shaded(model: ShadingModel, non_local: NonLocal) -> Self {
        Self::Shaded { model, non_local }
    }

    /// Every model a whole-material case is compared with, in table order: the measured CDRF
    /// alone and with each step of non-local terms, the Gaussian CDRF alone and with cast
    /// shadows (penumbra = its σ), Lambert.
    pub const ALL: [ComparedModel; 9] = [
        Self::shaded(ShadingModel::Measured, NonLocal::OFF),
        Self::shaded(ShadingModel::Measured, SHADOWS),
        Self::shaded(ShadingModel::Measured, TRANSMISSION),
        Self::shaded(ShadingModel::Measured, SHADOWS_TRANSMISSION),
        Self::shaded(ShadingModel::Measured, SHADOWS_SUBSURFACE),
        Self::shaded(ShadingModel::Measured, NonLocal::ALL),
        Self::shaded(ShadingModel::Gaussian, NonLocal::OFF),
        Self::shaded(ShadingModel::Gaussian, SHADOWS),
        Self::shaded(ShadingModel::Lambert, NonLocal::OFF),
    ];

    /// The model of a specular-layer case: the layer alone, with cast shadows.
    pub const SPECULAR_LAYER: ComparedModel = ComparedModel::SpecularLayer { non_local: SHADOWS };

    /// The non-local terms this model adds.
    pub fn non_local(self) -> NonLocal {
        match self {
            Self::Shaded { non_local, .. } | Self::SpecularLayer { non_local } => non_local,
        }
    }

    /// The terms a name and a label list, in order (name part, label part). Transmission is
    /// named only without the subsurface gather, which replaces its T(d, μ).
    fn named_terms(non_local: NonLocal) -> impl Iterator<Item = (&'static str, &'static str)> {
        [
            (non_local.shadows, "shadows", "shadows"),
            (
                non_local.transmission && !non_local.subsurface,
                "transmission",
                "transmission",
            ),
            (non_local.subsurface, "subsurface", "subsurface"),
            (
                non_local.interreflection,
                "interreflection",
                "inter-reflection",
            ),
        ]
        .into_iter()
        .filter(|(on, _, _)| *on)
        .map(|(_, name, label)| (name, label))
    }

    /// The key in `compare.json`: the model's name, then its terms (`measured_shadows`);
    /// `_all` for every term; `specular_layer` for the layer alone.
    pub fn name(self) -> String {
        match self {
            Self::SpecularLayer { .. } => "specular_layer".to_owned(),
            Self::Shaded { model, non_local } if non_local == NonLocal::ALL => {
                format!("{}_all", model.name())
            }
            Self::Shaded { model, non_local } => std::iter::once(model.name())
                .chain(Self::named_terms(non_local).map(|(name, _)| name))
                .collect::<Vec<_>>()
                .join("_"),
        }
    }

    /// The column heading: the model, then ` + ` each term (`measured + shadows`).
    pub fn label(self) -> String {
        let (base, non_local) = match self {
            Self::Shaded { model, non_local } => (model.short_label(), non_local),
            Self::SpecularLayer { non_local } => ("specular layer alone", non_local),
        };
        std::iter::once(base)
            .chain(Self::named_terms(non_local).map(|(_, label)| label))
            .collect::<Vec<_>>()
            .join(" + ")
    }
}

impl fmt::Display for ComparedModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.label())
    }
}

/// As its [`name`](ComparedModel::name).
impl Serialize for ComparedModel {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(&self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names and labels are what `compare.json`, `compare.md`, the figures and
    /// `docs/results.md` have always shown: readers of those files key on them.
    #[test]
    fn names_and_labels_are_the_output_contract() {
        let expected = [
            ("measured", "measured"),
            ("measured_shadows", "measured + shadows"),
            ("measured_transmission", "measured + transmission"),
            (
                "measured_shadows_transmission",
                "measured + shadows + transmission",
            ),
            (
                "measured_shadows_subsurface",
                "measured + shadows + subsurface",
            ),
            (
                "measured_all",
                "measured + shadows + subsurface + inter-reflection",
            ),
            ("gaussian", "Gaussian"),
            ("gaussian_shadows", "Gaussian + shadows"),
            ("lambert", "Lambert"),
        ];
        for (model, (name, label)) in ComparedModel::ALL.into_iter().zip(expected) {
            assert_eq!(
                (model.name().as_str(), model.label().as_str()),
                (name, label)
            );
            assert_eq!(
                serde_json::to_string(&model).unwrap(),
                format!("\"{name}\"")
            );
        }
        let specular = ComparedModel::SPECULAR_LAYER;
        assert_eq!(specular.name(), "specular_layer");
        assert_eq!(specular.label(), "specular layer alone + shadows");
        assert_eq!(specular.to_string(), specular.label());
    }

    #[test]
    fn every_term_set_of_the_table_is_what_its_name_says() {
        let non_local = |name: &str| {
            ComparedModel::ALL
                .into_iter()
                .find(|model| model.name() == name)
                .unwrap()
                .non_local()
        };
        assert_eq!(non_local("measured"), NonLocal::OFF);
        assert_eq!(non_local("measured_all"), NonLocal::ALL);
        let gather = non_local("measured_shadows_subsurface");
        assert!(gather.shadows && gather.subsurface && !gather.interreflection);
        assert_eq!(non_local("gaussian_shadows"), SHADOWS);
    }
}
