//! Options of the nonlinear modal analysis and of backbone continuations, and
//! the defaults that depend on the model (AFT samples, minimum step).
use super::continuation::ContinuationOptions;
use super::epmc::Normalisation;
use super::errors::NmaError;
use super::hb::default_samples;
use crate::structure::StructuralModel;

/// Amplitude range of the continuation (serialised externally tagged,
/// e.g. TOML `amplitude = { modal = { log10_start = -6.0, log10_end = -1.0 } }`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum AmplitudeRange {
    /// Modal amplitude `a = sqrt(q1^H M q1)` [sqrt(kg) m], as `log10 a` bounds.
    Modal { log10_start: f64, log10_end: f64 },
    /// Magnitude of the fundamental harmonic at a named point [m]: the start is
    /// converted with the linear mode; the analysis stops once the point's
    /// amplitude reaches `end_m` (modal amplitude capped at 1000x the linear
    /// estimate of `end_m`).
    Point {
        name: String,
        start_m: f64,
        end_m: f64,
    },
}

/// Options of [`nonlinear_modal_analysis`]. Serialisable; missing keys take
/// the defaults (`Default`: H = 13, mode 0, `a` from 1e-6 to 1e-1, damped,
/// `ds = 0.1`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NmaOptions {
    /// Harmonic truncation order `H` (`eq:fourier`); the paper uses 13.
    pub harmonics: usize,
    /// AFT time samples per period; default `4H+1` (exact for cubic laws), at
    /// least [`HYSTERETIC_DEFAULT_SAMPLES`] for a model with a hysteretic element
    /// (for a Jenkins element they only set the grid on which the reversals
    /// are searched: its loop is integrated exactly), and enough to resolve
    /// a `tanh` friction's transition (`saturation_samples`, capped at
    /// [`max_aft_samples`]).
    pub samples: Option<usize>,
    /// Which linear mode to continue, 0-based in ascending frequency (0 = the
    /// paper's "mode 1").
    pub mode_index: usize,
    pub amplitude: AmplitudeRange,
    /// Drop the linear damping `C` (the underlying conservative system; `D`
    /// then comes out zero).
    pub conservative: bool,
    pub continuation: ContinuationOptions,
    /// Named points whose shape harmonics are stored; empty = all named points.
    pub points: Vec<String>,
    /// Store the shape harmonics of all generalized coordinates at every point.
    pub store_coordinates: bool,
    /// Stop (with a warning) once the fundamental harmonic's share of the
    /// kinetic energy ([`BranchPoint::fundamental_energy_share`]) falls below
    /// this: the branch has turned into another mode's internal-resonance
    /// branch, where `a -> 0` (default 0.005). Only with
    /// [`Normalisation::Fundamental`]; the harmonic-energy normalisation
    /// passes such loops.
    pub min_fundamental_share: f64,
    /// Normalisation and continuation parameter of the EPMC unknowns (default
    /// [`Normalisation::Fundamental`], continuation in `log10 a`; use
    /// [`Normalisation::HarmonicEnergy`] to pass internal-resonance loops: the
    /// amplitude range then bounds the harmonic-energy amplitude `A >= a`).
    pub normalisation: Normalisation,
    /// End the branch once `omega / omega0` reaches this (default `None`: no
    /// frequency end; the amplitude range ends the branch). A branch ending
    /// before it is reported with [`NmaWarning::EndFrequencyNotReached`].
    pub end_omega_over_omega0: Option<f64>,
    /// End the branch at the first point whose `a` falls below an earlier
    /// one (the first fold of the primary branch, [`NmaResult::table_indices`]):
    /// all that a [`TablePolicy::PrimaryBranch`] table uses, so the table is
    /// the same as from the whole branch (default `false`: the whole branch,
    /// loops included, for plots and `host nma`).
    pub stop_at_first_fold: bool,
}

/// Harmonic order `H` of the modal table the single-nonlinear-mode methods use
/// by default (the default `[nma] harmonics` of `host`): the smallest `H` whose
/// refined table ([`NmaResult::refined_table`], [`RefineOptions`] defaults)
/// agrees with the `H = 13` table within the refinement targets (omega 1e-5,
/// D and point shapes 1e-4, relative) for modal amplitudes up to
/// [`SWEEP_TABLE_MAX_AMPLITUDE`] on the paper beam (measured: omega 1.8e-9,
/// D 1.2e-6, shapes 4.2e-5; `H = 5` misses the shapes with 1.7e-4, `H = 3`
/// misses D with 3.5e-3 and the shapes with 6.5e-3 already below
/// a = 1.22e-3). Cubic stiffness excites only odd harmonics, so `H = 6` would
/// equal `H = 5`. The test `sweep_table_harmonics_agree_with_h13_within_the_refined_accuracy`
/// checks it.
pub const SWEEP_TABLE_HARMONICS: usize = 7;

/// Largest modal amplitude `a` [sqrt(kg) m] the paper's sweeps reach (with
/// margin) for which [`SWEEP_TABLE_HARMONICS`] is stated: case (a), 2l/3 at
/// 10 V, reaches 1.22e-3 and the 10 V sweep at l/3 2.07e-3; the first fold
/// of the damped primary branch is at 3.96e-3.
pub const SWEEP_TABLE_MAX_AMPLITUDE: f64 = 2.5e-3;

impl Default for NmaOptions {
    fn default() -> Self {
        Self {
            harmonics: 13,
            samples: None,
            mode_index: 0,
            amplitude: AmplitudeRange::Modal {
                log10_start: -6.0,
                log10_end: -1.0,
            },
            conservative: false,
            continuation: ContinuationOptions {
                ds: 0.1,
                ..Default::default()
            },
            points: vec![],
            store_coordinates: true,
            min_fundamental_share: 0.005,
            normalisation: Normalisation::Fundamental,
            end_omega_over_omega0: None,
            stop_at_first_fold: false,
        }
    }
}

/// Options of a backbone continuation through internal-resonance loops (the
/// scenario's `[nma]` backbone settings; serialisable, missing keys take the
/// defaults). [`BackboneOptions::nma_options`] turns them into [`NmaOptions`]
/// with [`Normalisation::HarmonicEnergy`].
///
/// Defaults (chosen on the paper beam, H = 13, where they pass the 1:5, 1:9,
/// 1:3, 1:7 and 1:13 loops up to 2.7 omega0 in about 660 points):
/// `harmonics = 13`, `log10_start = -6` (start at `A = 1e-6`, linear regime),
/// `log10_end = 0` (`A = 1`, in practice never reached), `end_omega_over_omega0
/// = 2.7`, `ds = 0.03`, `dsmin = 1e-5`, `dsmax = 0.03` (scaled arc length:
/// unit-norm shape, `omega / omega0`, `log10 A`; larger steps cut across the
/// narrow 1:5 and 1:9 loops), `max_tangent_angle_deg = 10`,
/// `max_contraction = 0.6`, `tolerance = 1e-8` (scaled residual; inside the
/// 1:13 loop at H = 13 Newton stalls near 1e-7 relative to 1e-10, the
/// conditioning of that branch), `max_points = 5000`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BackboneOptions {
    pub harmonics: usize,
    pub log10_start: f64,
    pub log10_end: f64,
    pub end_omega_over_omega0: Option<f64>,
    pub ds: f64,
    pub dsmin: f64,
    pub dsmax: f64,
    pub max_tangent_angle_deg: f64,
    pub max_contraction: f64,
    pub tolerance: f64,
    pub max_points: usize,
}

impl Default for BackboneOptions {
    fn default() -> Self {
        Self {
            harmonics: 13,
            log10_start: -6.0,
            log10_end: 0.0,
            end_omega_over_omega0: Some(2.7),
            ds: 0.03,
            dsmin: 1e-5,
            dsmax: 0.03,
            max_tangent_angle_deg: 10.0,
            max_contraction: 0.6,
            tolerance: 1e-8,
            max_points: 5000,
        }
    }
}

impl BackboneOptions {
    /// The [`NmaOptions`] of this backbone continuation (mode 0, all named
    /// points, coordinates stored).
    pub fn nma_options(&self, conservative: bool) -> NmaOptions {
        NmaOptions {
            harmonics: self.harmonics,
            amplitude: AmplitudeRange::Modal {
                log10_start: self.log10_start,
                log10_end: self.log10_end,
            },
            conservative,
            normalisation: Normalisation::HarmonicEnergy,
            end_omega_over_omega0: self.end_omega_over_omega0,
            continuation: ContinuationOptions {
                ds: self.ds,
                dsmin: Some(self.dsmin),
                dsmax: Some(self.dsmax),
                max_tangent_angle_deg: Some(self.max_tangent_angle_deg),
                max_contraction: Some(self.max_contraction),
                tolerance: self.tolerance,
                max_points: self.max_points,
                ..Default::default()
            },
            ..Default::default()
        }
    }
}

/// Default AFT samples of a model with a hysteretic element. For a play-type
/// element (Jenkins) they are only the grid on which the reversals of the
/// displacement are searched (its loop is integrated exactly between the
/// located transitions); 256 separate the extrema of displacements with up to
/// ~60 harmonics. For another (sampled) hysteretic law a sample switching
/// between stick and slip is a corner of the branch, and with `4H+1` samples
/// these corners are so large that Newton cycles across them; 256 pass them.
pub const HYSTERETIC_DEFAULT_SAMPLES: usize = 256;

/// The continuation options for `model`: as given, but for a model with a
/// hysteretic element `dsmin` defaults to `1e-4 ds` (the stick-slip transition
/// is a corner of the branch, passed at `dsmin`, and `D(a)` turns sharply at its
/// maximum).
pub(super) fn continuation_for(
    model: &StructuralModel,
    c: &ContinuationOptions,
) -> ContinuationOptions {
    let mut c = c.clone();
    if has_hysteresis(model) && c.dsmin.is_none() {
        c.dsmin = Some(1e-4 * c.ds);
    }
    c
}

/// Whether any nonlinear element of `model` is hysteretic.
pub(super) fn has_hysteresis(model: &StructuralModel) -> bool {
    model.nonlinear.iter().any(|e| e.law.hysteresis().is_some())
}

/// AFT samples that resolve the transition of every velocity-saturating
/// element ([`crate::structure::NonlinearLaw::velocity_saturation`], `tanh`
/// friction `F_s tanh(v / v_r)`) in the regime where it shapes the mode: the
/// element saturates at the velocity amplitude `V = F_s / sqrt(k_w m_w)`
/// (its slip force reached by the stiffness `k_w = w^T K w` its direction
/// sees, at the frequency `sqrt(k_w / m_w)`, `m_w = w^T M w`); there the
/// transition `|v| < v_r` lasts `2 v_r / V` rad of the period, and
/// `N = 4 pi V / v_r` puts four samples across it. Beyond, the element acts as
/// a Coulomb force small against the elastic ones, and an under-resolved
/// transition no longer matters (measured on NLvib example 05, H = 21: with
/// `4H+1 = 85` samples Newton fails at the onset of slip, `|q_1| = 0.16 m`;
/// with this rule, 1405 samples, the branch reaches `|q_1| = 14 m`, as with
/// 8192). Zero (no requirement) without such elements or where `k_w` or
/// `m_w` vanish.
pub(super) fn saturation_samples(model: &StructuralModel) -> usize {
    let mut n = 0usize;
    for e in &model.nonlinear {
        let Some((fs, vr)) = e.law.velocity_saturation() else {
            continue;
        };
        let w = &e.direction;
        let kw = w.dot(&(&model.stiffness * w));
        let mw = w.dot(&(&model.mass * w));
        if !(kw > 0.0 && mw > 0.0 && fs > 0.0 && vr > 0.0) {
            continue;
        }
        let v = fs / (kw * mw).sqrt();
        let need = 4.0 * std::f64::consts::PI * v / vr;
        if need.is_finite() {
            n = n.max(need.ceil().min(MAX_AFT_SAMPLES as f64) as usize);
        }
    }
    n
}

/// Largest number of AFT samples per period accepted ([`NmaOptions::samples`]):
/// 65536 resolve a `tanh` transition of 1e-4 of the period, and the
/// describing-function limit of a Jenkins element at H = 1 to 1e-8.
pub const MAX_AFT_SAMPLES: usize = 1 << 16;

/// Largest `N (2H+1)` accepted: the AFT's DFT matrices hold `3 N (2H+1)`
/// numbers, at most 40 MB (16384 samples at H = 50).
pub const MAX_AFT_TABLE_ENTRIES: usize = 16384 * 101;

/// The largest sample count accepted at `harmonics`: [`MAX_AFT_SAMPLES`],
/// lowered so that the DFT tables stay within [`MAX_AFT_TABLE_ENTRIES`].
pub fn max_aft_samples(harmonics: usize) -> usize {
    MAX_AFT_SAMPLES.min(MAX_AFT_TABLE_ENTRIES / (2 * harmonics + 1).max(1))
}

/// The AFT samples: `samples`, by default `4H+1`, and at least
/// [`HYSTERETIC_DEFAULT_SAMPLES`] for a model with a hysteretic element.
pub(super) fn check_harmonics(
    model: &StructuralModel,
    harmonics: usize,
    samples: Option<usize>,
) -> Result<usize, NmaError> {
    if harmonics == 0 {
        return Err(NmaError::NoHarmonics { harmonics });
    }
    let minimum = default_samples(harmonics);
    let maximum = max_aft_samples(harmonics);
    let samples = samples.unwrap_or_else(|| {
        let mut n = minimum;
        if has_hysteresis(model) {
            n = n.max(HYSTERETIC_DEFAULT_SAMPLES);
        }
        n.max(saturation_samples(model).min(maximum))
    });
    if samples > maximum {
        return Err(NmaError::TooManySamples {
            samples,
            harmonics,
            maximum,
        });
    }
    if samples < minimum {
        return Err(NmaError::TooFewSamples {
            samples,
            harmonics,
            minimum,
        });
    }
    Ok(samples)
}
