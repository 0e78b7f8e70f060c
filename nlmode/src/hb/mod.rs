//! The exact periodic steady state of the coupled system: harmonic balance of
//! the assembled model (structure + every linear attachment + imposed
//! forces), Hill stability and bifurcations (issue 24, DESIGN item 7).
//!
//! # Harmonic balance with the attachments condensed at each harmonic
//!
//! Every attachment is linear (`eq:component2`), so at harmonic `n` it acts on
//! the structure exactly as its condensed impedance `Z_G(n Omega)` at its
//! interface points, and its input (the shaker voltage `u_hat e^{i phase}`)
//! only at `n = 1`: `eq:fc1` at `n Omega` ([`crate::attachment`]). With the
//! structure's dynamic stiffness
//!
//! ```text
//! D_n(Omega) = K - (n Omega)^2 M + i n Omega C + sum_a E_a Z_G,a(n Omega) E_a^T,
//! b_1(Omega) = sum_a E_a T_G,a(Omega) u_a + sum_p e_p f_p,
//! ```
//!
//! the HB equations of the structure (`q_n` its complex harmonics, `W` the
//! nonlinear elements' directions, `f_n(U)` their force harmonics by the
//! AFT of [`crate::nma::hb`]) read `D_n q_n + W f_n = alpha b_1 delta_{n1}`.
//! They are condensed exactly (Schur complement per harmonic) onto the
//! element displacements `u_n = W^T q_n`:
//!
//! ```text
//! u_n - alpha a_n(Omega) + R_n(Omega) f_n(u) = 0,
//! R_n = W^T D_n^{-1} W  (receptance at the elements),   a_1 = W^T D_1^{-1} b_1,
//! ```
//!
//! so the Newton systems have `E (2H+1)` rows for `E` nonlinear elements,
//! independent of the model size (one dense `ndof`-sized inverse per harmonic
//! and evaluation: reduce large models first, e.g. Craig-Bampton). The
//! structure's harmonics are recovered as `q_n = D_n^{-1} (alpha b_1
//! delta_{n1} - W f_n)`, the interface forces as `F_G = -Z_G E^T q_1 +
//! alpha T_G u`. All Jacobian entries are analytic (`dZ_G/dOmega` from
//! [`crate::attachment::Condenser::condense_with_derivative`]). Unknowns
//! `X = [U / x_ref; (alpha); Omega]` with `x_ref` the peak linear response
//! amplitude at the elements over the frequency range.
//!
//! # Control
//!
//! - [`Control::Voltage`]: every input at its given amplitude (`alpha = 1`).
//! - [`Control::Force`]: the fundamental force amplitude of one force column
//!   (an attachment's interface force or an imposed force) held at
//!   `amplitude_n`. The extra unknown is the common scale `alpha >= 0` of all
//!   inputs (every exciter's voltage, the imposed forces), their phases kept:
//!   for one shaker, `alpha u_hat` is the voltage a force-controlled
//!   stepped-sine test applies. Extra equation `(|F_1|^2 - F*^2)/F*^2 = 0`.
//!
//! # Continuation, stability, bifurcations
//!
//! Pseudo-arc-length continuation in `Omega` ([`crate::nma::continuation`])
//! from `omega_start` to `omega_end` through folds. Each point's stability
//! comes from Hill's method ([`hill`]). Between consecutive points the branch
//! is tested for
//! - a **fold** (`fold`): the tangent's `Omega` component changes sign,
//! - a **branch point** (`branch-point`): the determinant of the augmented
//!   Jacobian `[dR/dX; t^T]` changes sign (it does not at a fold),
//! - a **Neimark-Sacker** point (`neimark-sacker`): the largest real part of
//!   the kept complex Floquet exponents changes sign,
//!
//! and each one found is refined by regula falsi (Illinois) on the chord
//! between the two points, the corrector solving `R = 0` on the hyperplane
//! normal to the chord, until the chord parameter is known to `1e-10`; the
//! refined point is inserted into the branch with its label.
//!
//! # Isolated branches
//!
//! [`frequency_response`] continues the main branch and then, from each
//! [`Seed`] (e.g. every point of the single-mode steady state's branches,
//! [`crate::reduced`], or the folds of another computation) not already on a
//! found branch, solves at the seed's `Omega` from the seed's response
//! amplitude and phase and continues both ways; a branch that returns to its
//! start is an isola (closed).
use crate::attachment::AttachmentError;
use crate::nma::continuation::ContinuationOptions;
use serde::{Deserialize, Serialize};

mod branch;
pub mod hill;
mod hill_band;
mod residual;
mod system;

pub use branch::{add_seeded_branches, frequency_response};
pub use hill::Floquet;
pub use system::{HbSystem, MAX_DOFS};

/// Largest harmonic order `H` accepted.
pub const MAX_HARMONICS: usize = 64;
/// Largest number of AFT samples per period accepted.
pub const MAX_SAMPLES: usize = 1 << 14;
/// Largest number of points per branch accepted.
pub const MAX_POINTS: usize = 1_000_000;
/// Largest number of seeds accepted.
pub const MAX_SEEDS: usize = 10_000;

/// Errors of the harmonic balance; each names the option or input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HbError {
    #[error("hb option `{name}` = {value}: expected {expected}")]
    BadOption {
        name: &'static str,
        value: f64,
        expected: &'static str,
    },
    #[error(transparent)]
    Attachment(#[from] AttachmentError),
    #[error("{found} input vectors given for {expected} attachments")]
    InputCount { expected: usize, found: usize },
    #[error("excitation `{name}` is not finite (|value| = {value})")]
    NonFiniteExcitation { name: String, value: f64 },
    #[error("structure point `{point}` does not exist (available: {available:?})")]
    UnknownPoint {
        point: String,
        available: Vec<String>,
    },
    #[error("the structure has {ndof} DOFs; hb accepts 1 to {max} (reduce it first, e.g. Craig-Bampton)")]
    ModelSize { ndof: usize, max: usize },
    #[error(
        "the dynamic stiffness of harmonic {harmonic} is singular at Omega = {omega_rad_s} rad/s"
    )]
    SingularDynamicStiffness { omega_rad_s: f64, harmonic: usize },
    #[error("force control: force column {column} does not exist ({available:?})")]
    UnknownForceColumn {
        column: usize,
        available: Vec<String>,
    },
    #[error("stability needs the assembly's first-order form: {reason}")]
    NoFirstOrderForm { reason: String },
    #[error("the start point at Omega = {omega_rad_s} rad/s did not converge (residual {residual_norm:e}{reason})")]
    StartNotConverged {
        omega_rad_s: f64,
        residual_norm: f64,
        reason: String,
    },
}

/// Which excitation is held along the curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Control {
    /// Every input at its given amplitude and phase.
    #[default]
    Voltage,
    /// The fundamental force amplitude of force column `column` (index into
    /// [`HbSystem::force_names`]) held at `amplitude_n` \[N\] by scaling all
    /// inputs by one factor (module docs).
    Force { column: usize, amplitude_n: f64 },
}

/// Options of [`frequency_response`]. Missing keys take the defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HbOptions {
    /// Harmonic order `H` (1..=[`MAX_HARMONICS`], default 7).
    pub harmonics: usize,
    /// AFT samples per period (`2H+1..=`[`MAX_SAMPLES`]; default `4H+1`,
    /// exact for cubic laws).
    pub samples: Option<usize>,
    /// Start and end of the continuation in `Omega` \[rad/s\] (positive, distinct).
    pub omega_start_rad_s: f64,
    pub omega_end_rad_s: f64,
    /// Initial arc-length step (scaled unknowns: element amplitudes over the
    /// peak linear amplitude, `Omega` over the range), in `(0, 1]`; default 0.02.
    pub ds: f64,
    /// Smallest and largest step; defaults `ds / 50` and `5 ds`.
    pub dsmin: Option<f64>,
    pub dsmax: Option<f64>,
    /// Largest number of points per branch (default 5000, at most [`MAX_POINTS`]).
    pub max_points: usize,
    /// Newton tolerance on the scaled residual (in `(0, 1e-3]`, default 1e-10).
    pub tolerance: f64,
    /// Newton iterations per corrector (1..=100, default 12).
    pub max_iterations: usize,
    /// Floquet exponents by Hill's method at every point (default true).
    pub stability: bool,
    /// Harmonics of the Hill matrix (`1..=harmonics`; default `harmonics`):
    /// the principal block of harmonics `0..=H_s` of the full Hill matrix.
    pub stability_harmonics: Option<usize>,
    /// How the Floquet exponents are computed (default
    /// [`HillMethod::Condensed`]).
    pub hill: HillMethod,
    /// Look for and refine folds, branch points and Neimark-Sacker points
    /// (default true; Neimark-Sacker needs `stability`).
    pub bifurcations: bool,
    pub control: Control,
}

impl Default for HbOptions {
    fn default() -> Self {
        Self {
            harmonics: 7,
            samples: None,
            omega_start_rad_s: 0.0,
            omega_end_rad_s: 0.0,
            ds: 0.02,
            dsmin: None,
            dsmax: None,
            max_points: 5000,
            tolerance: 1e-10,
            max_iterations: 12,
            stability: true,
            stability_harmonics: None,
            hill: HillMethod::Condensed,
            bifurcations: true,
            control: Control::Voltage,
        }
    }
}

fn check(ok: bool, name: &'static str, value: f64, expected: &'static str) -> Result<(), HbError> {
    if ok {
        Ok(())
    } else {
        Err(HbError::BadOption {
            name,
            value,
            expected,
        })
    }
}

impl HbOptions {
    /// The AFT samples (the default resolved).
    pub fn samples(&self) -> usize {
        self.samples.unwrap_or(4 * self.harmonics + 1)
    }

    /// The Hill matrix's harmonics (the default resolved).
    pub fn hill_harmonics(&self) -> usize {
        self.stability_harmonics.unwrap_or(self.harmonics)
    }

    /// Checks every option against its bounds.
    pub fn validate(&self) -> Result<(), HbError> {
        let h = self.harmonics;
        check(
            (1..=MAX_HARMONICS).contains(&h),
            "harmonics",
            h as f64,
            "an integer in 1..=64",
        )?;
        let hs = self.hill_harmonics();
        check(
            (1..=h).contains(&hs),
            "stability_harmonics",
            hs as f64,
            "an integer in 1..=harmonics",
        )?;
        let s = self.samples();
        check(
            s > 2 * h && s <= MAX_SAMPLES,
            "samples",
            s as f64,
            "an integer in 2*harmonics+1..=16384",
        )?;
        for (name, v) in [
            ("omega_start_rad_s", self.omega_start_rad_s),
            ("omega_end_rad_s", self.omega_end_rad_s),
        ] {
            check(v.is_finite() && v > 0.0, name, v, "a positive frequency")?;
        }
        check(
            self.omega_end_rad_s != self.omega_start_rad_s,
            "omega_end_rad_s",
            self.omega_end_rad_s,
            "a frequency different from omega_start_rad_s",
        )?;
        check(
            self.ds.is_finite() && self.ds > 0.0 && self.ds <= 1.0,
            "ds",
            self.ds,
            "a step in (0, 1]",
        )?;
        let (dsmin, dsmax) = (self.dsmin(), self.dsmax());
        check(
            dsmin.is_finite() && dsmin > 0.0 && dsmin <= self.ds,
            "dsmin",
            dsmin,
            "a step in (0, ds]",
        )?;
        check(
            dsmax.is_finite() && dsmax >= self.ds && dsmax <= 10.0,
            "dsmax",
            dsmax,
            "a step in [ds, 10]",
        )?;
        check(
            (2..=MAX_POINTS).contains(&self.max_points),
            "max_points",
            self.max_points as f64,
            "an integer in 2..=1000000",
        )?;
        check(
            self.tolerance > 0.0 && self.tolerance <= 1e-3,
            "tolerance",
            self.tolerance,
            "a tolerance in (0, 1e-3]",
        )?;
        check(
            (1..=100).contains(&self.max_iterations),
            "max_iterations",
            self.max_iterations as f64,
            "an integer in 1..=100",
        )?;
        if let Control::Force { amplitude_n, .. } = self.control {
            check(
                amplitude_n.is_finite() && amplitude_n > 0.0,
                "force_amplitude_n",
                amplitude_n,
                "a positive force amplitude",
            )?;
        }
        Ok(())
    }

    pub fn dsmin(&self) -> f64 {
        self.dsmin.unwrap_or(self.ds / 50.0)
    }

    pub fn dsmax(&self) -> f64 {
        self.dsmax.unwrap_or(5.0 * self.ds)
    }

    pub(crate) fn continuation(&self) -> ContinuationOptions {
        ContinuationOptions {
            ds: self.ds,
            dsmin: Some(self.dsmin()),
            dsmax: Some(self.dsmax()),
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
            max_points: self.max_points,
            max_tangent_angle_deg: Some(20.0),
            ..ContinuationOptions::default()
        }
    }
}

/// A start point for an extra branch: the response point's fundamental
/// `amplitude_m e^{i phase_rad}` at `omega_rad_s` (phase relative to the
/// excitation `cos(Omega t)`, the convention of `f = Re(f_hat e^{i Omega t})`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Seed {
    pub omega_rad_s: f64,
    pub amplitude_m: f64,
    pub phase_rad: f64,
}

/// How Hill's problem is solved (docs/hb.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum HillMethod {
    /// The problem condensed onto the nonlinear elements, its roots near the
    /// fundamental band refined on the exact condensed determinant
    /// ([`hill_band`]); the full matrix where that does not apply.
    #[default]
    Condensed,
    /// Every eigenvalue of the full Hill matrix, sorted ([`hill`]).
    Full,
}

/// Bifurcation label of a branch point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Bifurcation {
    #[default]
    None,
    Fold,
    BranchPoint,
    NeimarkSacker,
}

impl Bifurcation {
    /// The `bifurcation` column of `hb_frc.csv`: empty, `fold`,
    /// `branch-point`, `neimark-sacker`.
    pub fn label(self) -> &'static str {
        match self {
            Bifurcation::None => "",
            Bifurcation::Fold => "fold",
            Bifurcation::BranchPoint => "branch-point",
            Bifurcation::NeimarkSacker => "neimark-sacker",
        }
    }
}

/// One periodic solution.
#[derive(Debug, Clone, PartialEq)]
pub struct HbPoint {
    pub omega_rad_s: f64,
    /// Complex harmonics `0..=H` of the response point's displacement \[m\]
    /// (`u(t) = Re sum_n u_n e^{i n Omega t}`).
    pub response_m: Vec<num_complex::Complex64>,
    /// Complex fundamental force per force column ([`HbSystem::force_names`]) \[N\].
    pub forces_n: Vec<num_complex::Complex64>,
    /// Input scale `alpha` (1 under voltage control).
    pub input_scale: f64,
    /// Floquet exponents (if stability was computed).
    pub floquet: Option<Floquet>,
    pub bifurcation: Bifurcation,
    /// The HB unknowns (to seed further computations).
    pub unknowns: Vec<f64>,
}

impl HbPoint {
    /// Fundamental amplitude at the response point \[m\] (`tip_amplitude_m`).
    pub fn tip_amplitude_m(&self) -> f64 {
        self.response_m.get(1).map_or(0.0, |v| v.norm())
    }
    /// Amplitude of each harmonic `0..=H` at the response point \[m\]
    /// (`tip_h<n>_amplitude_m`; `n = 0` is the absolute mean).
    pub fn harmonic_amplitudes_m(&self) -> Vec<f64> {
        self.response_m.iter().map(|v| v.norm()).collect()
    }
    /// Force amplitude per force column \[N\] (`<name>_force_amplitude_N`;
    /// the first is `force_amplitude_N`).
    pub fn force_amplitudes_n(&self) -> Vec<f64> {
        self.forces_n.iter().map(|v| v.norm()).collect()
    }
    /// `Some(true)` if stable by Hill's method, `None` if not computed.
    pub fn stable(&self) -> Option<bool> {
        self.floquet.as_ref().map(|f| f.stable)
    }
}

/// How a branch ended.
#[derive(Debug, Clone, PartialEq)]
pub enum BranchStatus {
    /// Reached the end of the frequency range (or left it at the start).
    Complete,
    /// An isola: the branch returned to its start point.
    Closed,
    /// `max_points` reached.
    MaxPoints,
    /// The continuation could not pass `omega_rad_s`.
    Stopped { omega_rad_s: f64, reason: String },
}

/// One branch of periodic solutions.
#[derive(Debug, Clone, PartialEq)]
pub struct HbBranch {
    pub points: Vec<HbPoint>,
    pub status: BranchStatus,
    /// Started from a [`Seed`] (not the main branch from `omega_start`).
    pub from_seed: Option<Seed>,
}

/// All branches found by [`frequency_response`].
#[derive(Debug, Clone, PartialEq)]
pub struct HbResult {
    /// The main branch first, then one per seed that led off the found ones.
    pub branches: Vec<HbBranch>,
    /// Names of the force columns.
    pub force_names: Vec<String>,
    pub harmonics: usize,
}

impl HbResult {
    /// Every labelled point `(branch, point)`.
    pub fn bifurcations(&self) -> Vec<(usize, &HbPoint)> {
        self.branches
            .iter()
            .enumerate()
            .flat_map(|(b, br)| {
                br.points
                    .iter()
                    .filter(|p| p.bifurcation != Bifurcation::None)
                    .map(move |p| (b, p))
            })
            .collect()
    }
}
