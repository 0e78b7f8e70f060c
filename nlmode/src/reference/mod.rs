//! Full-order reference: primal assembly of structure and attachments
//! (`eq:finalassembly1`-`eq:finalassembly2`, see [`assembly`]) and its time
//! integration over a sine sweep, from rest.
//!
//! Every input of every attachment receives `u(t) = u_hat cos Phi(t)` of the
//! [`LinearSweep`], or, with complex input factors `c` (an exciter's voltage
//! ratio and phase, [`simulate_phased_sweep_with_progress`]), `Re(c e^{i Phi})
//! u_hat = Re(c) u_hat cos Phi - Im(c) u_hat sin Phi`: the in-phase and the
//! quadrature sweep as two input signals of the assembly ([`assembly`]). Two integrators are available ([`Integrator`]):
//!
//! - [`Integrator::Exponential`] (default): exponential collocation, exact for
//!   the stiff linear time-invariant part, implicit in the few scalar nonlinear
//!   forces ([`expo`] explains the method and why it was chosen over BDF/ESDIRK);
//! - [`Integrator::DormandPrince`]: explicit adaptive Dormand-Prince 5(4) (the
//!   Matlab `ode45` of the paper's reference), for comparison; its step is bound
//!   by the stiff modes, so it is slow on the Craig-Bampton model and unusable on
//!   the unreduced one.
//!
//! # Choice of the default, measured on the paper's case (a)
//!
//! Case (a) (exciter at 2l/3, 10 V, 2 % per pseudo period, 0.8 -> 1.8 omega0,
//! 0.88 s), Craig-Bampton model (25 states, eigenvalues up to 2.4e5 rad/s),
//! release build, CPU time on one core when the choice was made (the times of
//! today's build are in the README's performance table, `cargo bench -p nlmode
//! --bench reference`):
//!
//! | method | CPU time | steps | tip deviation from a tight run |
//! |---|---|---|---|
//! | exponential, 8 nodes, rtol 1e-6 (default) | 6.6 ms | 3 627 | 3e-11 |
//! | Dormand-Prince 5(4), rtol 1e-6 | 133 ms | 87 110 | 5e-10 |
//! | diffsol 0.18 BDF, rtol 1e-6, atol 1e-9 | 56 ms | 28 439 | 1.3e-5 |
//! | diffsol 0.18 ESDIRK34, rtol 1e-6, atol 1e-6 | 58 ms | 8 029 | 1.6e-4 |
//! | diffsol 0.18 TR-BDF2, rtol 1e-6, atol 1e-6 | 52 ms | 12 077 | 1.0e-3 |
//!
//! (deviations relative to the peak tip displacement; diffsol with analytic
//! Jacobian-vector products and its dense nalgebra LU; with atol 1e-12 its BDF,
//! and with atol 1e-9 its ESDIRK34 and TR-BDF2, stopped with
//! `TooManyNonlinearSolverFailures` at t = 0.15-0.25 s). The unreduced 100-node
//! model (399 states, eigenvalues up to 8e10 rad/s) takes 0.3 s with the
//! exponential method and gives the same envelopes as the Craig-Bampton model
//! to 2e-4; no explicit method can integrate it. diffsol was therefore not
//! added: besides being slower here it pulls in faer 0.24 and a second nalgebra
//! (0.35) next to the workspace's 0.33 (a 13-minute build on this machine).
//!
//! Both integrators sample on a uniform grid of `samples_per_period` points per
//! excitation period at the highest sweep frequency; the envelopes
//! ([`envelope`]) are computed from these samples, and the time series are
//! decimated to `output_interval_s`.
//!
//! Error control for both: weighted RMS norm of the local error estimate with
//! weights `atol + rtol max(|z_i|_max so far, |z_i|)`, i.e. relative to the
//! largest value each state has reached (states mix units: m, m/s, A).
pub mod assembly;
mod dopri;
pub mod envelope;
pub mod expo;

pub use assembly::{
    AssembledSystem, AttachmentLocalization, AttachmentObservation, FirstOrderSystem,
};

use crate::attachment::LinearAttachment;
use crate::excitation::LinearSweep;
use crate::structure::StructuralModel;
use nalgebra::DVector;
use num_complex::Complex64;

/// Errors of the reference integration; each names the input or the time.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReferenceError {
    #[error(
        "the sweep needs {samples:.3e} output samples (duration {duration_s:.4e} s at \
         {samples_per_period} samples per period of the highest frequency); at most \
         {MAX_SWEEP_SAMPLES} are recorded: sweep faster or over a shorter band"
    )]
    TooManySamples {
        samples: f64,
        duration_s: f64,
        samples_per_period: usize,
    },
    #[error("{owner}: point '{point}' is not a named point of the structure (known: {known:?})")]
    UnknownPoint {
        owner: String,
        point: String,
        known: Vec<String>,
    },
    #[error("attachment '{attachment}' has no coefficient matrices A_k")]
    EmptyAttachment { attachment: String },
    #[error(
        "attachment '{attachment}': B2 has rank {rank} but {constraints} constraints; \
         eq:L1L2 needs full row rank"
    )]
    CompatibilityRank {
        attachment: String,
        rank: usize,
        constraints: usize,
    },
    #[error(
        "the leading-coefficient matrix of the assembled system is singular (reciprocal condition \
         {rcond:.3e}); the assembly is a DAE of index > 1 in the variables {variables:?} (e.g. an \
         algebraic constraint between states, or a variable that enters no equation); index \
         reduction is not supported: reformulate the attachment with those variables eliminated"
    )]
    SingularLeadingMatrix { rcond: f64, variables: Vec<String> },
    #[error(
        "attachment '{attachment}': its interface force needs derivative {order} of '{variable}', \
         which has differential order {available} in the assembly"
    )]
    InterfaceForceOrder {
        attachment: String,
        variable: String,
        order: usize,
        available: usize,
    },
    #[error("step size collapsed to {step_s:.3e} s at t = {time_s} s")]
    StepSizeCollapse { time_s: f64, step_s: f64 },
    #[error("non-finite state at t = {time_s} s")]
    NonFinite { time_s: f64 },
    #[error("state norm {norm:.3e} exceeds divergence_limit = {limit:.3e} at t = {time_s} s")]
    BlowUp { time_s: f64, norm: f64, limit: f64 },
    #[error("step limit max_steps = {steps} reached at t = {time_s} s")]
    TooManySteps { time_s: f64, steps: usize },
    #[error("option {name} = {value}: expected {expected}")]
    BadOption {
        name: &'static str,
        value: String,
        expected: &'static str,
    },
}

/// Time integration method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Integrator {
    /// Exponential collocation, exact for the linear part ([`expo`]).
    #[default]
    Exponential,
    /// Explicit adaptive Dormand-Prince 5(4).
    DormandPrince,
}

/// Options of [`simulate_sweep`]; `Default` gives the documented defaults.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReferenceOptions {
    /// Integrator (default exponential).
    pub method: Integrator,
    /// Relative tolerance of the local error (default 1e-6).
    pub rtol: f64,
    /// Absolute tolerance, in the states' units (default 1e-12).
    pub atol: f64,
    /// Analysis samples per excitation period at the highest sweep frequency
    /// (default 40): the envelope resolution and, for the exponential method,
    /// the largest step.
    pub samples_per_period: usize,
    /// Interval of the returned time series and envelope points \[s\]; rounded to a
    /// multiple of the analysis interval; `None` = every analysis sample.
    pub output_interval_s: Option<f64>,
    /// Envelope window length in excitation periods (default 1).
    pub envelope_periods: f64,
    /// Collocation nodes of the exponential method, `s >= 2` (polynomial degree
    /// `s - 1` of the forcing over a step; default 8).
    pub collocation_nodes: usize,
    /// Name of the structure point reported as the tip (default `tip`).
    pub tip_point: String,
    /// Step limit (accepted + rejected; default 5e6).
    pub max_steps: usize,
    /// Largest allowed state magnitude before the run counts as diverged (default 1e12).
    pub divergence_limit: f64,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        Self {
            method: Integrator::Exponential,
            rtol: 1e-6,
            atol: 1e-12,
            samples_per_period: 40,
            output_interval_s: None,
            envelope_periods: 1.0,
            collocation_nodes: 8,
            tip_point: "tip".to_string(),
            max_steps: 5_000_000,
            divergence_limit: 1e12,
        }
    }
}

/// Step-control settings shared by the integrators.
#[derive(Debug, Clone)]
pub(crate) struct StepControl {
    pub rtol: f64,
    pub atol: f64,
    pub nodes: usize,
    pub max_steps: usize,
    pub divergence_limit: f64,
}

impl StepControl {
    /// After an accepted step to `time_s`: every state finite, `zmax` (running
    /// maximum of `|z_i|`, the error scale) updated, `max |z_i|` below the
    /// divergence limit.
    pub(crate) fn check_state(
        &self,
        z: &DVector<f64>,
        zmax: &mut [f64],
        time_s: f64,
    ) -> Result<(), ReferenceError> {
        let mut zinf: f64 = 0.0;
        for (zi, mi) in z.iter().zip(zmax.iter_mut()) {
            let a = zi.abs();
            if !a.is_finite() {
                return Err(ReferenceError::NonFinite { time_s });
            }
            *mi = mi.max(a);
            zinf = zinf.max(a);
        }
        if zinf > self.divergence_limit {
            return Err(ReferenceError::BlowUp {
                time_s,
                norm: zinf,
                limit: self.divergence_limit,
            });
        }
        Ok(())
    }
}

impl ReferenceOptions {
    fn validate(&self) -> Result<StepControl, ReferenceError> {
        let bad = |name, value: String, expected| {
            Err(ReferenceError::BadOption {
                name,
                value,
                expected,
            })
        };
        if !(self.rtol.is_finite() && self.rtol > 0.0 && self.rtol < 1.0) {
            return bad("rtol", self.rtol.to_string(), "a number in (0, 1)");
        }
        if !(self.atol.is_finite() && self.atol > 0.0) {
            return bad("atol", self.atol.to_string(), "a positive number");
        }
        if self.samples_per_period < 4 {
            return bad(
                "samples_per_period",
                self.samples_per_period.to_string(),
                "an integer >= 4",
            );
        }
        if let Some(dt) = self.output_interval_s {
            if !(dt.is_finite() && dt > 0.0) {
                return bad(
                    "output_interval_s",
                    dt.to_string(),
                    "a positive interval in seconds",
                );
            }
        }
        if !(self.envelope_periods.is_finite() && self.envelope_periods > 0.0) {
            return bad(
                "envelope_periods",
                self.envelope_periods.to_string(),
                "a positive number of periods",
            );
        }
        if !(2..=12).contains(&self.collocation_nodes) {
            return bad(
                "collocation_nodes",
                self.collocation_nodes.to_string(),
                "an integer in 2..=12",
            );
        }
        if self.max_steps == 0 {
            return bad("max_steps", "0".into(), "a positive integer");
        }
        if !(self.divergence_limit.is_finite() && self.divergence_limit > 0.0) {
            return bad(
                "divergence_limit",
                self.divergence_limit.to_string(),
                "a positive number",
            );
        }
        Ok(StepControl {
            rtol: self.rtol,
            atol: self.atol,
            nodes: self.collocation_nodes,
            max_steps: self.max_steps,
            divergence_limit: self.divergence_limit,
        })
    }
}

/// Work counters of an integration.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct IntegrationStats {
    /// Accepted steps.
    pub steps: usize,
    /// Rejected steps.
    pub rejected: usize,
    /// Right-hand-side evaluations (Dormand-Prince).
    pub rhs_evals: usize,
    /// Scalar nonlinear-law evaluations (exponential method).
    pub law_evals: usize,
    /// Newton iterations for the collocation forces (exponential method).
    pub newton_iterations: usize,
    /// Propagator sets (matrix exponentials) built (exponential method).
    pub propagators: usize,
}

/// Fundamental-harmonic envelopes against the instantaneous excitation frequency.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Envelope {
    /// `Omega` at the window centre \[rad/s\].
    pub omega_rad_s: Vec<f64>,
    /// Fundamental amplitude of the first attachment's first interface force \[N\].
    pub force_amplitude_n: Vec<f64>,
    /// Phase of that force's fundamental relative to the excitation phase `Phi`
    /// \[rad\] (`F ~ |F| cos(Phi + phase)`; the convention of the slow flow's
    /// `force_phase_rad`, so the envelope can be imposed on the modal model).
    pub force_phase_rad: Vec<f64>,
    /// Fundamental amplitude of the tip displacement \[m\].
    pub tip_amplitude_m: Vec<f64>,
}

/// Time series of one attachment (decimated).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AttachmentSeries {
    pub name: String,
    pub interface_points: Vec<String>,
    /// `drive_m[c][i]`: displacement of interface point `c` \[m\].
    pub drive_m: Vec<Vec<f64>>,
    /// `force_n[c][i]`: interface force on the structure at point `c` \[N\],
    /// positive along the point's positive displacement.
    pub force_n: Vec<Vec<f64>>,
    pub state_names: Vec<String>,
    /// `states[k][i]`: attachment state `x_k` (SI units of that state).
    pub states: Vec<Vec<f64>>,
    /// `state_amplitudes[k][j]`: fundamental-harmonic amplitude of state `x_k` at
    /// the envelope point `j` (the points of [`SweepResult::envelope`], same
    /// windows), e.g. a piezo shunt's electrode voltage amplitude \[V\].
    pub state_amplitudes: Vec<Vec<f64>>,
    /// `force_envelopes[c][j]`: complex fundamental harmonic of the interface
    /// force at point `c` at the envelope point `j` (same windows; `F ~ |F|
    /// cos(Phi + arg F)`, the convention of [`Envelope::force_phase_rad`]) \[N\],
    /// e.g. each exciter's force for `imposed-force`.
    #[serde(default)]
    pub force_envelopes: Vec<Vec<Complex64>>,
}

/// Result of [`simulate_sweep`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SweepResult {
    /// Sample times \[s\] (decimated).
    pub time_s: Vec<f64>,
    /// Instantaneous excitation frequency \[rad/s\].
    pub omega_rad_s: Vec<f64>,
    /// Excitation signal `u(t)` (V for a shaker).
    pub input: Vec<f64>,
    /// Tip displacement \[m\].
    pub tip_m: Vec<f64>,
    /// Displacement of the first attachment's first interface point \[m\] (empty
    /// without attachments).
    pub drive_m: Vec<f64>,
    /// Force of the first attachment on the structure at its first interface
    /// point \[N\] (empty without attachments).
    pub force_n: Vec<f64>,
    /// Per-attachment series.
    pub attachments: Vec<AttachmentSeries>,
    /// Envelopes at the output times whose window lies inside the sweep.
    pub envelope: Envelope,
    /// Analysis sample interval \[s\].
    pub sample_interval_s: f64,
    pub stats: IntegrationStats,
}

/// Most input signals of an assembled system: the in-phase sweep `u_hat cos Phi`
/// and the quadrature sweep `u_hat sin Phi`.
pub const MAX_INPUT_SIGNALS: usize = 2;

/// The input signals at time `t` (in-phase, quadrature); a system uses the
/// first [`FirstOrderSystem::n_inputs`] of them.
pub(crate) type InputSignals<'a> = dyn Fn(f64) -> [f64; MAX_INPUT_SIGNALS] + 'a;

/// The integrators' sample callback `(i, z, element_states)`: the hysteretic
/// elements' states at the sample are needed for their forces.
pub(crate) type SampleWithStates<'a> = dyn FnMut(usize, &DVector<f64>, &[f64]) + 'a;

/// Uniform sample times `t_i = i interval_s`, `i = 0..=count`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleGrid {
    /// Sample interval \[s\].
    pub interval_s: f64,
    /// Number of intervals (the integration ends at `count interval_s`).
    pub count: usize,
}

/// Integrate the assembled system (first-order state `z`, see
/// [`AssembledSystem::state_from_structure`]) from `z0` at `t = 0` with the
/// input signal `input(t)` on every attachment input, calling `on_sample(i, z)` at
/// every grid time and `progress(fraction)` now and then. For a system with the
/// one input signal ([`AssembledSystem::new`]).
pub fn integrate(
    system: &AssembledSystem,
    z0: &DVector<f64>,
    grid: SampleGrid,
    input: &dyn Fn(f64) -> f64,
    options: &ReferenceOptions,
    on_sample: &mut dyn FnMut(usize, &DVector<f64>),
    progress: &mut dyn FnMut(f64),
) -> Result<IntegrationStats, ReferenceError> {
    assert_eq!(z0.len(), system.first_order.nz(), "initial state length");
    assert_eq!(
        system.first_order.n_inputs(),
        1,
        "integrate: the system has a quadrature input signal"
    );
    integrate_with_states(
        system,
        z0,
        grid,
        &|t| [input(t), 0.0],
        options,
        &mut |i, z, _states| on_sample(i, z),
        progress,
    )
}

/// [`integrate`] with the hysteretic elements' states handed to
/// `on_sample(i, z, element_states)` (the forces at a sample need them).
fn integrate_with_states(
    system: &AssembledSystem,
    z0: &DVector<f64>,
    grid: SampleGrid,
    input: &InputSignals,
    options: &ReferenceOptions,
    on_sample: &mut SampleWithStates,
    progress: &mut dyn FnMut(f64),
) -> Result<IntegrationStats, ReferenceError> {
    let ctl = options.validate()?;
    let integrate = match options.method {
        Integrator::Exponential => expo::integrate,
        Integrator::DormandPrince => dopri::integrate,
    };
    integrate(
        &system.first_order,
        z0,
        grid,
        input,
        &ctl,
        on_sample,
        progress,
    )
}

/// The exponential integration of an assembled system continued over a
/// sequence of sample grids (a controller's excitation periods, each with its
/// own interval): the state, the hysteretic elements' states, the step level,
/// the error scale and the propagators carry over from one grid to the next.
/// New step sizes are built from the eigenvectors of `A` where they reproduce
/// the augmented exponential (see [`expo`]), so a grid interval that changes
/// every period costs scalar functions per eigenvalue rather than a matrix
/// exponential.
pub struct ContinuedIntegration {
    ctl: StepControl,
    cache: expo::Propagators,
    z: DVector<f64>,
    states: Vec<f64>,
}

impl std::fmt::Debug for ContinuedIntegration {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ContinuedIntegration")
            .field("z", &self.z)
            .field("states", &self.states)
            .finish_non_exhaustive()
    }
}

impl ContinuedIntegration {
    /// From `z0` (element states relaxed at `z0`); `options.method` must be
    /// the exponential one.
    pub fn new(
        system: &AssembledSystem,
        z0: DVector<f64>,
        options: &ReferenceOptions,
    ) -> Result<Self, ReferenceError> {
        assert_eq!(z0.len(), system.first_order.nz(), "initial state length");
        let ctl = options.validate()?;
        if options.method != Integrator::Exponential {
            return Err(ReferenceError::BadOption {
                name: "method",
                value: format!("{:?}", options.method),
                expected: "the exponential method for a continued integration",
            });
        }
        Ok(Self {
            ctl,
            cache: expo::Propagators::new(&system.first_order, true),
            states: system.first_order.initial_element_states(&z0),
            z: z0,
        })
    }

    /// Integrates over `grid` (its time origin is the current state's) with
    /// `input(t)` on every attachment input, calling `on_sample(i, z,
    /// element_states)` at every grid time `i = 0..=count`.
    #[allow(clippy::type_complexity)] // the sample callback of `integrate`, with the states
    pub fn advance(
        &mut self,
        system: &AssembledSystem,
        grid: SampleGrid,
        input: &dyn Fn(f64) -> f64,
        on_sample: &mut dyn FnMut(usize, &DVector<f64>, &[f64]),
    ) -> Result<IntegrationStats, ReferenceError> {
        // one input signal (the plant's system has no quadrature input)
        let signals = |t: f64| {
            let mut u = [0.0; MAX_INPUT_SIGNALS];
            u[0] = input(t);
            u
        };
        expo::integrate_continued(
            &system.first_order,
            &mut self.z,
            &mut self.states,
            grid,
            &signals,
            &self.ctl,
            &mut self.cache,
            on_sample,
            &mut |_| {},
        )
    }

    /// Current state.
    pub fn state(&self) -> &DVector<f64> {
        &self.z
    }

    /// Current internal states of the nonlinear elements.
    pub fn element_states(&self) -> &[f64] {
        &self.states
    }
}

/// Most output samples a reference sweep records (each holds every observed
/// quantity: about 100 bytes; 1e7 samples about 1 GB).
pub const MAX_SWEEP_SAMPLES: usize = 10_000_000;

/// Sweep the assembled structure + attachments from rest (see the module docs).
pub fn simulate_sweep(
    model: &StructuralModel,
    attachments: &[LinearAttachment],
    sweep: &LinearSweep,
    options: &ReferenceOptions,
) -> Result<SweepResult, ReferenceError> {
    simulate_sweep_with_progress(model, attachments, sweep, options, &mut |_| {})
}

/// [`simulate_sweep`] reporting the completed fraction (0..=1) to `progress`.
pub fn simulate_sweep_with_progress(
    model: &StructuralModel,
    attachments: &[LinearAttachment],
    sweep: &LinearSweep,
    options: &ReferenceOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<SweepResult, ReferenceError> {
    simulate_phased_sweep_with_progress(model, attachments, None, sweep, options, progress)
}

/// [`simulate_sweep_with_progress`] with complex input factors
/// `factors[a][j]` of attachment `a`'s input `j` (its voltage ratio and phase:
/// the input receives `Re(c e^{i Phi}) u_hat`, see
/// [`AssembledSystem::with_input_factors`]); `None`: every factor 1.
pub fn simulate_phased_sweep_with_progress(
    model: &StructuralModel,
    attachments: &[LinearAttachment],
    factors: Option<&[Vec<Complex64>]>,
    sweep: &LinearSweep,
    options: &ReferenceOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<SweepResult, ReferenceError> {
    options.validate()?;
    let system =
        AssembledSystem::with_input_factors(model, attachments, factors, &options.tip_point)?;
    let (n, dt) = sweep_sampling(sweep, options)?;
    let (rec, stats) = record_sweep(&system, sweep, n, dt, options, progress)?;
    progress(1.0);

    let dec = match options.output_interval_s {
        Some(o) => ((o / dt).round() as usize).max(1),
        None => 1,
    };
    let out_idx: Vec<usize> = (0..=n).step_by(dec).collect();
    let series = |k: usize| rec.series(k, &out_idx);
    let time_s: Vec<f64> = out_idx.iter().map(|&i| i as f64 * dt).collect();
    let omega_rad_s: Vec<f64> = time_s.iter().map(|&t| sweep.omega_rad_s(t)).collect();
    let input: Vec<f64> = time_s.iter().map(|&t| sweep.value(t)).collect();
    let mut attachments_out: Vec<AttachmentSeries> = system
        .observations
        .iter()
        .map(|o| {
            let ncon = o.interface_points.len();
            AttachmentSeries {
                name: o.name.clone(),
                interface_points: o.interface_points.clone(),
                drive_m: (0..ncon).map(|c| series(o.drive_index + c)).collect(),
                force_n: (0..ncon).map(|c| series(o.force_index + c)).collect(),
                state_names: o.state_names.clone(),
                states: (0..o.state_names.len())
                    .map(|k| series(o.state_index + k))
                    .collect(),
                state_amplitudes: Vec::new(),
                force_envelopes: Vec::new(),
            }
        })
        .collect();
    let first = system
        .observations
        .iter()
        .find(|o| !o.interface_points.is_empty());
    let (drive_m, force_n) = match first {
        Some(o) => (series(o.drive_index), series(o.force_index)),
        None => (Vec::new(), Vec::new()),
    };

    // envelopes from the full-rate samples
    let phase: Vec<f64> = (0..=n).map(|i| sweep.phase_rad(i as f64 * dt)).collect();
    let (env, kept, force_env) = sweep_envelope(&rec, sweep, dt, first, &phase, &out_idx, options);
    // the attachment states' envelopes on the same windows (same phase and
    // centres: defined exactly where the tip's is)
    for (o, out) in system.observations.iter().zip(attachments_out.iter_mut()) {
        // the first attachment's first force is the envelope's: not computed twice
        let is_first = first.is_some_and(|f| std::ptr::eq(f, o));
        let first_force = is_first.then_some(&force_env);
        let win = Windows {
            phase: &phase,
            out_idx: &out_idx,
            kept: &kept,
            periods: options.envelope_periods,
        };
        attachment_envelopes(&rec, o, out, &win, first_force);
    }
    Ok(SweepResult {
        tip_m: series(0),
        time_s,
        omega_rad_s,
        input,
        drive_m,
        force_n,
        attachments: attachments_out,
        envelope: env,
        sample_interval_s: dt,
        stats,
    })
}

/// The sweep's samples: their number `n` (at least `samples_per_period` per
/// period of the highest frequency, at most [`MAX_SWEEP_SAMPLES`]) and
/// their interval `dt` [s] (`n dt` the sweep's duration).
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(n <= max)` also rejects NaN
fn sweep_sampling(
    sweep: &LinearSweep,
    options: &ReferenceOptions,
) -> Result<(usize, f64), ReferenceError> {
    let duration = sweep.duration_s();
    let omega_max = sweep.omega_start_rad_s.max(sweep.omega_end_rad_s);
    let dt_req = 2.0 * std::f64::consts::PI / omega_max / options.samples_per_period as f64;
    let n_f = (duration / dt_req).ceil().max(1.0);
    if !(n_f <= MAX_SWEEP_SAMPLES as f64) {
        return Err(ReferenceError::TooManySamples {
            samples: n_f,
            duration_s: duration,
            samples_per_period: options.samples_per_period,
        });
    }
    let n = n_f as usize;
    let dt = duration / n as f64;
    Ok((n, dt))
}

/// Every observed quantity at every sample `0..=n` of a sweep, `nobs` per
/// sample.
struct SweepRecord {
    record: Vec<f64>,
    nobs: usize,
    n: usize,
}

impl SweepRecord {
    /// Observed quantity `k` at the samples `idx`.
    fn series(&self, k: usize, idx: &[usize]) -> Vec<f64> {
        idx.iter()
            .map(|&i| self.record[i * self.nobs + k])
            .collect()
    }

    /// Observed quantity `k` at every sample.
    fn full(&self, k: usize) -> Vec<f64> {
        (0..=self.n)
            .map(|i| self.record[i * self.nobs + k])
            .collect()
    }
}

/// Integrates the assembled system from rest over the sweep (input signals:
/// the sweep's value and its quadrature), recording every observed quantity
/// at the `n + 1` samples `i dt`.
fn record_sweep(
    system: &AssembledSystem,
    sweep: &LinearSweep,
    n: usize,
    dt: f64,
    options: &ReferenceOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<(SweepRecord, IntegrationStats), ReferenceError> {
    let signals = |t: f64| -> [f64; MAX_INPUT_SIGNALS] {
        let phi = sweep.phase_rad(t);
        [sweep.value(t), sweep.amplitude * phi.sin()]
    };
    let nobs = system.n_observed();
    let m = system.first_order.m();
    let mut record = vec![0.0; nobs * (n + 1)];
    let mut obs = DVector::zeros(nobs);
    let mut f = vec![0.0; m];
    let z0 = DVector::zeros(system.first_order.nz());
    let stats = {
        let mut on_sample = |i: usize, z: &DVector<f64>, states: &[f64]| {
            let u = signals(i as f64 * dt);
            system.first_order.forces(z, states, &mut f);
            system.observe_inputs(z, &u, &f, &mut obs);
            record[i * nobs..(i + 1) * nobs].copy_from_slice(obs.as_slice());
        };
        let grid = SampleGrid {
            interval_s: dt,
            count: n,
        };
        integrate_with_states(
            system,
            &z0,
            grid,
            &signals,
            options,
            &mut on_sample,
            progress,
        )?
    };
    Ok((SweepRecord { record, nobs, n }, stats))
}

/// The sweep's envelope (tip amplitude [m], the first attachment's first
/// force's amplitude [N] and phase [rad] over `omega` [rad/s]) at the output
/// samples `out_idx` where both are defined (their positions in `out_idx`:
/// the second value), and that force's fundamental harmonics at every output
/// sample (zero without an attachment force).
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
fn sweep_envelope(
    rec: &SweepRecord,
    sweep: &LinearSweep,
    dt: f64,
    first: Option<&AttachmentObservation>,
    phase: &[f64],
    out_idx: &[usize],
    options: &ReferenceOptions,
) -> (Envelope, Vec<usize>, Vec<Option<Complex64>>) {
    let tip_env =
        envelope::fundamental_amplitudes(phase, &rec.full(0), out_idx, options.envelope_periods);
    let force_env = match first {
        Some(o) => envelope::fundamental_harmonics(
            phase,
            &rec.full(o.force_index),
            out_idx,
            options.envelope_periods,
        ),
        None => vec![Some(Complex64::new(0.0, 0.0)); out_idx.len()],
    };
    let mut env = Envelope::default();
    let mut kept = Vec::new();
    for (k, &i) in out_idx.iter().enumerate() {
        if let (Some(a), Some(fa)) = (tip_env[k], force_env[k]) {
            env.omega_rad_s.push(sweep.omega_rad_s(i as f64 * dt));
            env.tip_amplitude_m.push(a);
            env.force_amplitude_n.push(fa.norm());
            env.force_phase_rad.push(fa.arg());
            kept.push(k);
        }
    }
    (env, kept, force_env)
}

/// The envelope windows: the sweep's phase at every sample, the output
/// samples, those kept in the envelope (positions in `out_idx`) and the
/// periods per window.
struct Windows<'a> {
    phase: &'a [f64],
    out_idx: &'a [usize],
    kept: &'a [usize],
    periods: f64,
}

/// One attachment's state amplitudes and interface forces' harmonics on the
/// envelope's windows (NaN where undefined); `first_force`: its first
/// force's harmonics when already computed for the envelope.
fn attachment_envelopes(
    rec: &SweepRecord,
    o: &AttachmentObservation,
    out: &mut AttachmentSeries,
    win: &Windows,
    first_force: Option<&Vec<Option<Complex64>>>,
) {
    let (phase, out_idx, kept) = (win.phase, win.out_idx, win.kept);
    out.state_amplitudes = (0..o.state_names.len())
        .map(|k| {
            let a = envelope::fundamental_amplitudes(
                phase,
                &rec.full(o.state_index + k),
                out_idx,
                win.periods,
            );
            kept.iter().map(|&j| a[j].unwrap_or(f64::NAN)).collect()
        })
        .collect();
    out.force_envelopes = (0..o.interface_points.len())
        .map(|c| {
            let h = match first_force {
                Some(f) if c == 0 => f.clone(),
                _ => envelope::fundamental_harmonics(
                    phase,
                    &rec.full(o.force_index + c),
                    out_idx,
                    win.periods,
                ),
            };
            let nan = Complex64::new(f64::NAN, f64::NAN);
            kept.iter().map(|&j| h[j].unwrap_or(nan)).collect()
        })
        .collect();
}
