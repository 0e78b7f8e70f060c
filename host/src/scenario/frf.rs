//! `[frf]`: which model `host frf` computes the steady state of.
use super::*;

/// The model of `host frf` (`[frf] model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrfModel {
    /// The single nonlinear modal oscillator with the attachments (`eq:NM`),
    /// all roots at `[run] frf_points` frequencies (`frf.csv`).
    #[default]
    Nlmode,
    /// The harmonic balance of the full model (method `hb`, options `[hb]`;
    /// `hb_frc.csv`).
    Hb,
}

#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct FrfSpec {
    pub model: FrfModel,
}
