//! The shading models, without their data: what a scene file's `[shading] model` names, what a
//! viewer's menu offers and what the evaluation compares. The enums that carry a model's data
//! (the scene's [`ShadingSpec`](crate::scene::ShadingSpec) and
//! [`Material`](crate::scene::Material), cdrf-render's `MaterialDesc`) say which one they are
//! with a `model()` method.

use std::fmt;

/// A shading model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShadingModel {
    /// The measured CDRF: a table f(κ, θ) (the poster's model).
    Measured,
    /// Kubo's Gaussian CDRF.
    Gaussian,
    /// Lambert: `albedo · max(cos θ, 0)`.
    Lambert,
    /// The curvature colour-mapped: a debug view, not radiance.
    Curvature,
}

impl ShadingModel {
    /// Every model, in declaration order.
    pub const ALL: [ShadingModel; 4] = [
        ShadingModel::Measured,
        ShadingModel::Gaussian,
        ShadingModel::Lambert,
        ShadingModel::Curvature,
    ];

    /// The name in files: a scene file's `[shading] model`, the evaluation's JSON.
    pub fn name(self) -> &'static str {
        match self {
            ShadingModel::Measured => "measured",
            ShadingModel::Gaussian => "gaussian",
            ShadingModel::Lambert => "lambert",
            ShadingModel::Curvature => "curvature",
        }
    }

    /// The model [`name`](Self::name) names.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|model| model.name() == name)
    }

    /// The name in a user interface (`measured CDRF`).
    pub fn label(self) -> &'static str {
        match self {
            ShadingModel::Measured => "measured CDRF",
            ShadingModel::Gaussian => "Gaussian CDRF",
            ShadingModel::Lambert => "Lambert",
            ShadingModel::Curvature => "curvature",
        }
    }

    /// The name in a table's column heading (`measured`).
    pub fn short_label(self) -> &'static str {
        match self {
            ShadingModel::Measured => "measured",
            ShadingModel::Gaussian => "Gaussian",
            ShadingModel::Lambert => "Lambert",
            ShadingModel::Curvature => "curvature",
        }
    }
}

impl fmt::Display for ShadingModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.label())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_all_is_in_declaration_order() {
        for (index, model) in ShadingModel::ALL.into_iter().enumerate() {
            assert_eq!(ShadingModel::from_name(model.name()), Some(model));
            // Hosts index per-model arrays by `model as usize`.
            assert_eq!(model as usize, index);
        }
        assert_eq!(ShadingModel::from_name("Measured"), None);
    }
}
