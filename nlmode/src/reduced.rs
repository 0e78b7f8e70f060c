//! The single nonlinear modal oscillator with linear attachments (`eq:NM`),
//! paper Section 3: slow flow along a sweep, steady state, linear variants,
//! imposed force, post-processing.
//!
//! # Model
//!
//! The structure's response is `q(t) = Re( a sum_n phi_n(a) e^{i n (Phi + theta)} )`
//! (`eq:ansatz`, `Phi = int Omega dt`). With the attachments condensed by
//! `eq:fc1`, the modal amplitude `a` and phase lag `theta` obey `eq:NM`:
//!
//! ```text
//! 2 i Omega (a' + i a theta') + (-Omega^2 + 2 i D(a) omega(a) Omega + omega(a)^2 + Z_A(a, Omega)) a
//!     = phi(a)^H f_ex(Omega) e^{-i theta}
//! ```
//!
//! with the modal impedance and the imposed modal force computed from the
//! generic attachment model at the attachments' interface points
//! (`u_G = E^T q`, the table's fundamental shape `phi_G = E^T phi` there):
//!
//! ```text
//! Z_A(a, Omega)      = phi^H Z_q phi   = sum_att phi_G^H Z_G(Omega) phi_G,
//! phi^H f_ex(Omega)  = sum_att phi_G^H T_G(Omega) u_hat  (+ sum_j conj(phi_j) F_j(Omega) over the imposed forces),
//! ```
//!
//! where `Z_G`, `T_G` are the interface impedance and input-force map of
//! `eq:fc1` (the force of an attachment on the structure is
//! `F_G = -Z_G u_G + T_G u_hat`, positive along positive displacement).
//!
//! # Regular form used for integration
//!
//! Split into `a` and `theta`, `eq:NM` gives `theta' = ... / a`, singular at
//! `a = 0` where every sweep starts (from rest). Multiplying `eq:NM` by
//! `e^{i theta}` and writing the complex amplitude `A = a e^{i theta}`
//! (`A' = (a' + i a theta') e^{i theta}`) gives the equivalent
//!
//! ```text
//! 2 i Omega A' + K(a, Omega) A = phi(a)^H f_ex(Omega),
//! K(a, Omega) = -Omega^2 + 2 i D(a) omega(a) Omega + omega(a)^2 + Z_A(a, Omega),   a = |A|,
//! ```
//!
//! which is regular at `A = 0`; its real and imaginary parts are the two real
//! states integrated (adaptive Dormand-Prince 5(4), [`dopri`]). `a = |A|` and
//! `theta = arg A` are recovered for output; for `a > 0` the two forms are the
//! same equation.
//!
//! # Steady state
//!
//! With `a' = theta' = 0`, taking magnitudes eliminates `theta`:
//! `a |K(a, Omega)| = |phi^H f_ex|` ([`ReducedModel::steady_state`]).
//!
//! # Usage
//!
//! ```text
//! let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3")?;
//! let nm = ReducedModel::new(&table, "tip", "2l3")?.with_linear_attachment(&shaker, &[1.0.into()])?;
//! let sweep = LinearSweep::per_pseudo_period(omega0, 0.8, 1.8, 0.02, 10.0)?;
//! let r = nm.simulate_sweep(&sweep, &SlowFlowOptions::default())?;        // nlmode
//! let l = nm.linear()?.simulate_sweep(&sweep, &SlowFlowOptions::default())?; // linear-slowflow
//! let s = nm.linear_steady(&omegas, 10.0)?;                              // linear-steady, force_drop
//! let frf = nm.steady_state(&omegas, 10.0)?;                             // all branches, stability
//! let imp = ReducedModel::imposed_force(&table, "tip", "2l3", ForceEnvelope::from_result(&r)?)?
//!     .with_frequency_error(FrequencyError { eps: 0.0, offset_rad_s: 0.05 * omega0 })?; // imposed-force
//! ```
//!
//! # Performance
//!
//! The hot loop is allocation-free: the attachment quantities `Z_G`,
//! `T_G u_hat` are tabulated once per sweep over its frequency range (cubic
//! Hermite in `Omega`, refined until the interpolation error is below
//! `channel_tol`, default 1e-9 relative), and the modal table's PCHIP
//! interpolant is evaluated in power form with one segment search for all
//! quantities (`fast`). Measured times against the reference: the README's
//! performance table (`cargo bench -p nlmode --bench reduced`). The output
//! phases (`theta`, force phase) are computed on demand
//! ([`SlowFlowSample::theta_rad`]).
//!
//! # Range policy
//!
//! The modal properties are only defined over the table's amplitude range
//! (held constant below it). A sweep whose amplitude leaves the range, or
//! grows without bound as with an imposed force and a frequency error (paper
//! Section 5.3), stops there and is flagged ([`SweepStatus::LeftTableRange`]),
//! keeping everything computed up to that point.
use crate::nma::ModalTable;
use crate::table::{ModalProperties, TableError, TableInterpolator};
use nalgebra::DMatrix;
use num_complex::Complex64;
use std::fmt::Debug;
use std::sync::Arc;

pub mod dynamic;
mod fast;
mod harmonic;
mod imposed;
mod omega_cache;
mod output;
mod post;
pub mod problems;
mod rate;
mod residual;
mod single;
mod steady;
mod sweep;

pub use crate::dopri::IntegratorStats;
pub use dynamic::AttachmentStates;
pub use imposed::ForceEnvelope;
pub use output::SampleFields;
pub use post::TimeSignals;
pub use residual::ResidualModes;
pub use steady::{LinearSteady, SteadyFrequency, SteadyPoint};
pub use sweep::{
    Envelope, EnvelopeBatch, EnvelopeFold, SlowFlowOptions, SlowFlowResult, SlowFlowSample,
    SweepRun, SweepSink, SweepStatus, SweepSummary, SWEEP_BATCH,
};

/// Boxed error of an attachment model.
pub type AttachmentModelError = Box<dyn std::error::Error + Send + Sync>;

/// `(Z_G, T_G)` of an attachment (or their derivatives), see [`InterfaceModel`].
pub type Condensed = (DMatrix<Complex64>, DMatrix<Complex64>);

/// Errors of the reduced model; each names the offending input and its value.
#[derive(Debug, thiserror::Error)]
pub enum ReducedError {
    #[error(transparent)]
    Table(#[from] TableError),
    #[error("attachment '{attachment}' at Omega = {omega_rad_s} rad/s: {source}")]
    Attachment {
        attachment: String,
        omega_rad_s: f64,
        #[source]
        source: AttachmentModelError,
    },
    #[error("attachment '{attachment}': {what} has size {found}, expected {expected}")]
    AttachmentSize {
        attachment: String,
        what: &'static str,
        found: usize,
        expected: usize,
    },
    #[error("attachment '{attachment}': {found} input amplitudes given, the attachment has {expected} inputs")]
    InputCount {
        attachment: String,
        expected: usize,
        found: usize,
    },
    #[error("option '{name}' = {value} is invalid: {why}")]
    BadOption {
        name: &'static str,
        value: f64,
        why: &'static str,
    },
    #[error("excitation frequency Omega = {0} rad/s must be positive and finite")]
    BadOmega(f64),
    #[error("force envelope: {0}")]
    Envelope(String),
    #[error(
        "force envelope covers Omega in [{min}, {max}] rad/s, but {omega_rad_s} rad/s is needed"
    )]
    EnvelopeRange {
        omega_rad_s: f64,
        min: f64,
        max: f64,
    },
    #[error("frequency error: omega(a) = {omega_rad_s} rad/s at a = {a} is not positive after (1 + {eps}) omega + {offset_rad_s}")]
    FrequencyError {
        a: f64,
        omega_rad_s: f64,
        eps: f64,
        offset_rad_s: f64,
    },
    #[error("attachment '{attachment}': its states cannot be carried in the slow flow (attachments = \"dynamic\"): {why}")]
    AttachmentStates { attachment: String, why: String },
    #[error("residual_modes = {requested}: {why}")]
    ResidualModes { requested: usize, why: String },
    #[error("rate_terms: at Omega = {omega_rad_s} rad/s and a = {a} the modal mass with the attachments' rate terms, |2 i Omega + 2 D omega + z_s| / (2 Omega) = {modal_mass}, is below 0.5: the attachments dominate the modulation there and the first-order terms are no correction; use rate_terms = false")]
    RateTerms {
        omega_rad_s: f64,
        a: f64,
        modal_mass: f64,
    },
    #[error("the slow-flow result has no samples")]
    EmptyResult,
    #[error("imposed force at '{point}': {found} imposed forces, at most {max} are supported")]
    ImposedCount {
        point: String,
        found: usize,
        max: usize,
    },
}

/// A linear attachment as seen by the reduced model: its condensed interface
/// quantities of `eq:fc1` at any frequency. Implemented for
/// [`crate::attachment::LinearAttachment`]; any other frequency-domain
/// description (e.g. measured) can implement it too (paper Section 3,
/// "use of experimental data").
pub trait InterfaceModel: Debug + Send + Sync {
    /// Name used in messages.
    fn name(&self) -> &str;
    /// Names of the structure points of the `ncon` interface constraints (the
    /// modal table must hold the shape at each of them).
    fn interface_points(&self) -> Vec<String>;
    /// Number of inputs `u` (e.g. 1: the voltage).
    fn ninput(&self) -> usize;
    /// `(Z_G, T_G)` at `Omega` \[rad/s\]: interface impedance (`ncon x ncon`) and
    /// input-force map (`ncon x ninput`), such that the force on the structure
    /// at the interface points is `F_G = -Z_G u_G + T_G u_hat`.
    fn condense(&self, omega_rad_s: f64) -> Result<Condensed, AttachmentModelError>;

    /// `((Z_G, T_G), (dZ_G/dOmega, dT_G/dOmega))` at `Omega`. The default takes
    /// central differences of [`Self::condense`] with the step `1e-5 Omega`
    /// (the quantities are rational in `Omega`; relative error below 1e-7 for
    /// the paper's shaker, largest near its suspension resonance); models that
    /// know the derivative override it.
    /// The attachment's state model in interface and internal coordinates,
    /// needed to carry its states in the slow flow
    /// ([`AttachmentStates::Dynamic`]); `None` (the default) for a model known
    /// only by its frequency response.
    fn condenser(&self) -> Option<&crate::attachment::Condenser> {
        None
    }

    fn condense_with_derivative(
        &self,
        omega_rad_s: f64,
    ) -> Result<(Condensed, Condensed), AttachmentModelError> {
        let d = 1e-5 * omega_rad_s;
        let (zp, tp) = self.condense(omega_rad_s + d)?;
        let (zm, tm) = self.condense(omega_rad_s - d)?;
        let s = Complex64::new(0.5 / d, 0.0);
        Ok((self.condense(omega_rad_s)?, ((zp - zm) * s, (tp - tm) * s)))
    }
}

/// A natural-frequency error applied to the table (paper Section 5.3):
/// `omega(a) -> (1 + eps) omega(a) + offset_rad_s`. The damping ratio `D(a)` is
/// kept, so the modal damping term `2 D omega` follows the modified frequency.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct FrequencyError {
    /// Relative error `eps` \[-\].
    pub eps: f64,
    /// Additive offset \[rad/s\] (the paper's "+5 %" is `0.05 omega0` here).
    pub offset_rad_s: f64,
}

/// One attachment connected to the table's points.
#[derive(Debug, Clone)]
pub(crate) struct Port {
    pub model: Arc<dyn InterfaceModel>,
    /// Table point index of each interface constraint.
    pub points: Vec<usize>,
    /// Complex input amplitudes per unit of the sweep amplitude (`u_hat = amplitude * input`).
    pub input: Vec<Complex64>,
    /// Offset of this port's channels in the channel vector.
    pub offset: usize,
}

impl Port {
    fn ncon(&self) -> usize {
        self.points.len()
    }

    fn error(&self, omega_rad_s: f64, source: AttachmentModelError) -> ReducedError {
        ReducedError::Attachment {
            attachment: self.model.name().into(),
            omega_rad_s,
            source,
        }
    }

    /// Writes this port's channels (`Z_G` row major, then `T_G u_hat` with
    /// `u_hat = amplitude * input`) into `out` after checking the sizes.
    fn write_channels(
        &self,
        zg: &DMatrix<Complex64>,
        tg: &DMatrix<Complex64>,
        amplitude: f64,
        out: &mut [Complex64],
    ) -> Result<(), ReducedError> {
        let name = self.model.name();
        let nc = self.ncon();
        if zg.nrows() != nc || zg.ncols() != nc {
            return Err(ReducedError::AttachmentSize {
                attachment: name.into(),
                what: "Z_G rows/cols",
                found: zg.nrows().max(zg.ncols()),
                expected: nc,
            });
        }
        if tg.nrows() != nc || tg.ncols() != self.input.len() {
            return Err(ReducedError::AttachmentSize {
                attachment: name.into(),
                what: "T_G columns",
                found: tg.ncols(),
                expected: self.input.len(),
            });
        }
        let o = self.offset;
        for r in 0..nc {
            for c in 0..nc {
                out[o + r * nc + c] = zg[(r, c)];
            }
            let mut f = Complex64::new(0.0, 0.0);
            for (j, u) in self.input.iter().enumerate() {
                f += tg[(r, j)] * u * amplitude;
            }
            out[o + nc * nc + r] = f;
        }
        Ok(())
    }
    /// `ncon^2` entries of `Z_G` (row major) followed by `ncon` entries of `T_G u_hat`.
    fn nchannels(&self) -> usize {
        self.ncon() * self.ncon() + self.ncon()
    }
}

/// An imposed force `F_j(Omega)` at a table point (a term of `f_ex^(1)` of
/// `eq:NM`: the modal force is `sum_j conj(phi_j(a)) F_j(Omega)`).
#[derive(Debug, Clone)]
pub(crate) struct Imposed {
    pub point: usize,
    pub envelope: ForceEnvelope,
}

/// Most imposed forces of one model (fixed-size buffer of the hot loop).
pub const MAX_IMPOSED: usize = 8;

/// The imposed forces of a model at one `Omega` \[N\], in the order they were
/// added ([`ReducedModel::imposed_at`]; a stack buffer, no allocation).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ImposedForces {
    f: [Complex64; MAX_IMPOSED],
    n: usize,
}

impl ImposedForces {
    /// No imposed force.
    pub(crate) const NONE: Self = Self {
        f: [Complex64::new(0.0, 0.0); MAX_IMPOSED],
        n: 0,
    };

    /// The forces \[N\], one per imposed force of the model.
    #[inline(always)]
    pub(crate) fn forces(&self) -> &[Complex64] {
        &self.f[..self.n]
    }
}

/// The single-nonlinear-mode model with attachments (`eq:NM`).
#[derive(Debug, Clone)]
pub struct ReducedModel {
    pub(crate) table: TableInterpolator,
    /// The same interpolant in power form for the hot loop.
    pub(crate) fast: fast::FastTable,
    /// The table's amplitude grid (root scan of the steady state).
    pub(crate) grid: Vec<f64>,
    /// The table's point names in index order.
    pub(crate) point_names: Vec<String>,
    pub(crate) ports: Vec<Port>,
    /// The imposed forces (`imposed-force`), empty for the shaker-driven model.
    pub(crate) imposed: Vec<Imposed>,
    pub(crate) tip: usize,
    pub(crate) drive: usize,
    pub(crate) tip_name: String,
    pub(crate) drive_name: String,
    pub(crate) frequency_error: FrequencyError,
    /// Amplitude scale for absolute tolerances: the (original) table's maximum.
    pub(crate) a_scale: f64,
    /// Size of the channel vector (all ports).
    pub(crate) nch: usize,
    /// Residual modes ([`Self::with_residual_modes`]); `None`: `eq:NM`.
    pub(crate) residual: Option<residual::Residual>,
}

/// Maximum number of interface points over all attachments handled without
/// heap allocation in the hot loop.
pub(crate) const MAX_INTERFACE: usize = 8;
/// Maximum number of interface points over all attachments plus the imposed
/// force points (fixed-size buffers of the hot loop).
pub(crate) const MAX_PHI: usize = 32;
/// Most interface points of all linear attachments of one [`ReducedModel`]
/// together (one slot of [`MAX_PHI`] is kept for an imposed force).
pub const MAX_INTERFACE_POINTS: usize = MAX_PHI - 1;

impl ReducedModel {
    /// A model of the mode in `table` without attachments or forces yet.
    /// `tip` and `drive` name the table points reported as tip displacement
    /// and as drive point (where the force is measured).
    pub fn new(table: &ModalTable, tip: &str, drive: &str) -> Result<Self, ReducedError> {
        let interp = table.interpolator()?;
        let fast = fast::FastTable::new(&interp);
        Ok(Self {
            fast,
            tip: interp.point_index(tip)?,
            drive: interp.point_index(drive)?,
            table: interp,
            grid: table.amplitude.clone(),
            point_names: table.points.iter().map(|p| p.name.clone()).collect(),
            ports: Vec::new(),
            imposed: Vec::new(),
            tip_name: tip.into(),
            drive_name: drive.into(),
            frequency_error: FrequencyError::default(),
            nch: 0,
            a_scale: *table.amplitude.last().unwrap(),
            residual: None,
        })
    }

    /// Adds an attachment driven by the sweep: its input amplitudes are
    /// `u_hat = amplitude * input_per_unit` (for the shaker: `[1]`, so the
    /// sweep amplitude is the voltage amplitude).
    pub fn with_attachment(
        mut self,
        model: Arc<dyn InterfaceModel>,
        input_per_unit: &[Complex64],
    ) -> Result<Self, ReducedError> {
        if self.residual.is_some() {
            return Err(ReducedError::ResidualModes {
                requested: self.residual_modes().map_or(0, |r| r.len()),
                why: format!(
                    "attachment '{}' added after the residual modes (they merge every attachment: add them last)",
                    model.name()
                ),
            });
        }
        if input_per_unit.len() != model.ninput() {
            return Err(ReducedError::InputCount {
                attachment: model.name().into(),
                expected: model.ninput(),
                found: input_per_unit.len(),
            });
        }
        let points = model
            .interface_points()
            .iter()
            .map(|p| self.table.point_index(p))
            .collect::<Result<Vec<_>, _>>()?;
        if points.is_empty() || points.len() > MAX_INTERFACE {
            return Err(ReducedError::AttachmentSize {
                attachment: model.name().into(),
                what: "interface point list (1..=8 supported)",
                found: points.len(),
                expected: 1,
            });
        }
        // one slot is kept for an imposed force added later
        let total: usize = self.ports.iter().map(|p| p.points.len()).sum::<usize>()
            + points.len()
            + self.imposed.len().max(1);
        if total > MAX_PHI {
            return Err(ReducedError::AttachmentSize {
                attachment: model.name().into(),
                what: "total number of interface points of all attachments (at most 31)",
                found: total - 1,
                expected: MAX_PHI - 1,
            });
        }
        let port = Port {
            model,
            points,
            input: input_per_unit.to_vec(),
            offset: self.nch,
        };
        self.nch += port.nchannels();
        self.ports.push(port);
        Ok(self)
    }

    /// Adds an imposed force with complex amplitude `F(Omega)` \[N\] at table
    /// point `point` (a term of `f_ex^(1)`, independent of the sweep
    /// amplitude); each call adds one more (at most [`MAX_IMPOSED`]), the modal
    /// force of `eq:NM` being the sum of `conj(phi_j) F_j(Omega)` over them.
    pub fn with_imposed_force(
        mut self,
        point: &str,
        envelope: ForceEnvelope,
    ) -> Result<Self, ReducedError> {
        let name = point;
        let point = self.table.point_index(point)?;
        let ports: usize = self.ports.iter().map(|p| p.points.len()).sum();
        let max = MAX_IMPOSED.min(MAX_PHI - ports);
        if self.imposed.len() + 1 > max {
            return Err(ReducedError::ImposedCount {
                point: name.into(),
                found: self.imposed.len() + 1,
                max,
            });
        }
        self.imposed.push(Imposed { point, envelope });
        Ok(self)
    }

    /// The paper's `imposed-force` model: only the prescribed force at the
    /// drive point, no exciter model.
    pub fn imposed_force(
        table: &ModalTable,
        tip: &str,
        drive: &str,
        envelope: ForceEnvelope,
    ) -> Result<Self, ReducedError> {
        Self::new(table, tip, drive)?.with_imposed_force(drive, envelope)
    }

    /// The `imposed-force` model with several exciters: the prescribed force
    /// `F_j(Omega)` of each at its table point (`(point, envelope)` in order;
    /// one entry is [`Self::imposed_force`]), no exciter model; `drive` names
    /// the point whose force is reported (the imposed forces there summed).
    pub fn imposed_forces(
        table: &ModalTable,
        tip: &str,
        drive: &str,
        forces: Vec<(&str, ForceEnvelope)>,
    ) -> Result<Self, ReducedError> {
        let mut m = Self::new(table, tip, drive)?;
        for (point, envelope) in forces {
            m = m.with_imposed_force(point, envelope)?;
        }
        Ok(m)
    }

    /// Applies a natural-frequency error (see [`FrequencyError`]).
    pub fn with_frequency_error(mut self, error: FrequencyError) -> Result<Self, ReducedError> {
        if !error.eps.is_finite() || error.eps <= -1.0 {
            return Err(ReducedError::BadOption {
                name: "eps",
                value: error.eps,
                why: "must be finite and > -1",
            });
        }
        if !error.offset_rad_s.is_finite() {
            return Err(ReducedError::BadOption {
                name: "offset_rad_s",
                value: error.offset_rad_s,
                why: "must be finite",
            });
        }
        self.frequency_error = error;
        Ok(self)
    }

    /// The frequency error in force.
    pub fn frequency_error(&self) -> FrequencyError {
        self.frequency_error
    }

    /// The modal table interpolator.
    pub fn table(&self) -> &TableInterpolator {
        &self.table
    }

    /// Names of the tip and drive points.
    pub fn tip_name(&self) -> &str {
        &self.tip_name
    }
    /// Name of the drive point.
    pub fn drive_name(&self) -> &str {
        &self.drive_name
    }

    /// Linear modal properties `(omega0, D0)` at the table's first point
    /// (frequency error applied).
    pub fn linear_properties(&self) -> Result<(f64, f64), ReducedError> {
        let p = self.modal_properties(0.0)?;
        Ok((p.omega_rad_s, p.damping_ratio))
    }

    /// The linear variant (`linear-slowflow`, `linear-steady`): the same model
    /// with constant `omega0`, `D0` and fundamental shapes `phi0` taken at the
    /// table's first point, valid for any amplitude (the range is extended to
    /// `1e12` times the table's maximum; higher harmonics are dropped).
    pub fn linear(&self) -> Result<ReducedModel, ReducedError> {
        let (amin, amax) = self.table.amplitude_range();
        let p0 = self.table.eval(0.0)?;
        let names = &self.point_names;
        let shapes = names
            .iter()
            .enumerate()
            .map(|(j, n)| Ok((n.as_str(), self.table.shape(j, 1, 0.0)?)))
            .collect::<Result<Vec<_>, TableError>>()?;
        let table =
            ModalTable::linear(p0.omega_rad_s, p0.damping_ratio, &shapes, amin, 1e12 * amax);
        let mut m = ReducedModel::new(&table, &self.tip_name, &self.drive_name)?;
        m.ports = self.ports.clone();
        m.nch = self.nch;
        m.imposed = self.imposed.clone();
        m.frequency_error = self.frequency_error;
        m.a_scale = self.a_scale;
        m.residual = self.residual.clone();
        Ok(m)
    }

    /// `omega(a)` (with the frequency error), `D(a)`, `d omega/d a`.
    #[inline(always)]
    pub fn modal_properties(&self, a: f64) -> Result<ModalProperties, ReducedError> {
        let loc = self.fast.locate(a)?;
        self.properties_at(loc, a)
    }

    #[inline(always)]
    fn properties_at(&self, loc: fast::Loc, a: f64) -> Result<ModalProperties, ReducedError> {
        let mut p = ModalProperties {
            omega_rad_s: self.fast.value(loc, 0),
            damping_ratio: self.fast.value(loc, 1),
            domega_da: self.fast.derivative(loc, a, 0),
        };
        let fe = self.frequency_error;
        if fe.eps != 0.0 || fe.offset_rad_s != 0.0 {
            p.omega_rad_s = self.detuned_omega(p.omega_rad_s, a)?;
            p.domega_da *= 1.0 + fe.eps;
        }
        Ok(p)
    }

    /// The table's `omega(a)` with the frequency error applied.
    #[inline(always)]
    pub(crate) fn detuned_omega(&self, omega_rad_s: f64, a: f64) -> Result<f64, ReducedError> {
        let fe = self.frequency_error;
        let w = (1.0 + fe.eps) * omega_rad_s + fe.offset_rad_s;
        if w.is_nan() || w <= 0.0 {
            return Err(ReducedError::FrequencyError {
                a,
                omega_rad_s: w,
                eps: fe.eps,
                offset_rad_s: fe.offset_rad_s,
            });
        }
        Ok(w)
    }

    /// Fundamental shape at table point `pt` (fast path).
    #[inline(always)]
    pub(crate) fn phi1(&self, loc: fast::Loc, pt: usize) -> Complex64 {
        self.fast.shape(loc, pt)
    }

    /// Fills the channel vector at `Omega` exactly from the attachment models:
    /// per port `Z_G` (row major) then `T_G u_hat` with `u_hat = amplitude * input`.
    pub(crate) fn fill_channels(
        &self,
        omega: f64,
        amplitude: f64,
        out: &mut [Complex64],
    ) -> Result<(), ReducedError> {
        if !(omega.is_finite() && omega > 0.0) {
            return Err(ReducedError::BadOmega(omega));
        }
        self.fill_channels_at(omega, amplitude, out)
    }

    /// As [`Self::fill_channels`] but allows any real `Omega` (harmonics `n = 0`).
    pub(crate) fn fill_channels_at(
        &self,
        omega: f64,
        amplitude: f64,
        out: &mut [Complex64],
    ) -> Result<(), ReducedError> {
        assert_eq!(out.len(), self.nch);
        for port in &self.ports {
            let (zg, tg) = port
                .model
                .condense(omega)
                .map_err(|source| port.error(omega, source))?;
            port.write_channels(&zg, &tg, amplitude, out)?;
        }
        Ok(())
    }

    /// [`Self::fill_channels`] and the channels' derivatives with respect to
    /// `Omega` (from [`InterfaceModel::condense_with_derivative`]).
    pub(crate) fn fill_channels_with_derivative(
        &self,
        omega: f64,
        amplitude: f64,
        out: &mut [Complex64],
        derivative: &mut [Complex64],
    ) -> Result<(), ReducedError> {
        if !(omega.is_finite() && omega > 0.0) {
            return Err(ReducedError::BadOmega(omega));
        }
        assert!(out.len() == self.nch && derivative.len() == self.nch);
        for port in &self.ports {
            let ((zg, tg), (dzg, dtg)) = port
                .model
                .condense_with_derivative(omega)
                .map_err(|source| port.error(omega, source))?;
            port.write_channels(&zg, &tg, amplitude, out)?;
            port.write_channels(&dzg, &dtg, amplitude, derivative)?;
        }
        Ok(())
    }

    /// The complex terms of `eq:NM` at amplitude `a` for given channels:
    /// `(K(a, Omega), phi^H f_ex, modal properties)`, with `Z_A` inside `K`.
    /// `f_imposed` are the imposed forces at their points ([`Self::imposed_at`]).
    #[inline(always)]
    pub(crate) fn nm_terms(
        &self,
        a: f64,
        omega: f64,
        ch: &[Complex64],
        f_imposed: ImposedForces,
    ) -> Result<(Complex64, Complex64, Complex64, ModalProperties), ReducedError> {
        self.nm_terms_in(
            a,
            omega,
            ch,
            &f_imposed,
            &mut [Complex64::new(0.0, 0.0); MAX_PHI],
        )
    }

    /// [`Self::nm_terms`] with a caller-provided scratch buffer for the shapes
    /// (the hot loop reuses one instead of zeroing a new one per call).
    #[inline(always)]
    pub(crate) fn nm_terms_in(
        &self,
        a: f64,
        omega: f64,
        ch: &[Complex64],
        f_imposed: &ImposedForces,
        phi: &mut [Complex64; MAX_PHI],
    ) -> Result<(Complex64, Complex64, Complex64, ModalProperties), ReducedError> {
        let p = self.gather(a, phi)?;
        let (k, fm, za) = self.terms_with(&p, phi, omega, ch, f_imposed);
        Ok((k, fm, za, p))
    }

    /// Modal properties at `a` and the fundamental shapes at all attachment
    /// interface points (ports in order) followed by the imposed-force points.
    #[inline(always)]
    pub(crate) fn gather(
        &self,
        a: f64,
        phi: &mut [Complex64; MAX_PHI],
    ) -> Result<ModalProperties, ReducedError> {
        Ok(self.gather_loc(a, phi)?.1)
    }

    /// [`Self::gather`], also returning the table location of `a`.
    #[inline(always)]
    pub(crate) fn gather_loc(
        &self,
        a: f64,
        phi: &mut [Complex64; MAX_PHI],
    ) -> Result<(fast::Loc, ModalProperties), ReducedError> {
        let loc = self.fast.locate(a)?;
        Ok((loc, self.gather_at(loc, a, phi)?))
    }

    /// [`Self::gather`] at the table location `loc` of `a`.
    #[inline(always)]
    pub(crate) fn gather_at(
        &self,
        loc: fast::Loc,
        a: f64,
        phi: &mut [Complex64; MAX_PHI],
    ) -> Result<ModalProperties, ReducedError> {
        let p = self.properties_at(loc, a)?;
        // the shapes of the segment once, each point's cubic from them
        let shapes = self.fast.shapes(loc.k);
        let points = self.ports.iter().flat_map(|port| &port.points);
        let points = points.chain(self.imposed.iter().map(|imp| &imp.point));
        for (phi, &pt) in phi.iter_mut().zip(points) {
            *phi = fast::cubic(&shapes[pt], loc.t);
        }
        Ok(p)
    }

    /// `(K, phi^H f_ex, Z_A)` of `eq:NM` from gathered properties and shapes.
    #[inline(always)]
    pub(crate) fn terms_with(
        &self,
        p: &ModalProperties,
        phi: &[Complex64; MAX_PHI],
        omega: f64,
        ch: &[Complex64],
        f_imposed: &ImposedForces,
    ) -> (Complex64, Complex64, Complex64) {
        let mut za = Complex64::new(0.0, 0.0);
        let mut fm = Complex64::new(0.0, 0.0);
        let mut j = 0;
        for port in &self.ports {
            let nc = port.ncon();
            if nc == 0 {
                continue;
            }
            let ph = &phi[j..j + nc];
            // the port's channels: Z_G row major, then T_G u_hat (slices:
            // one bounds check per port instead of one per term)
            let (z_g, t_g) = ch[port.offset..port.offset + nc * nc + nc].split_at(nc * nc);
            for ((z_row, t_r), ph_r) in z_g.chunks_exact(nc).zip(t_g).zip(ph) {
                let mut zr = Complex64::new(0.0, 0.0);
                for (z_rc, ph_c) in z_row.iter().zip(ph) {
                    zr += z_rc * ph_c;
                }
                za += ph_r.conj() * zr;
                fm += ph_r.conj() * t_r;
            }
            j += nc;
        }
        for (k, f) in f_imposed.forces().iter().enumerate() {
            fm += phi[j + k].conj() * f;
        }
        let w = p.omega_rad_s;
        let k = Complex64::new(w * w - omega * omega, 2.0 * p.damping_ratio * w * omega) + za;
        (k, fm, za)
    }

    /// Modal impedance `Z_A(a, Omega) = sum_att phi_G^H Z_G phi_G` [1/s^2 per
    /// unit modal mass] and imposed modal force `phi^H f_ex(Omega)` for the
    /// sweep amplitude `amplitude` (`eq:NM`), evaluated exactly.
    pub fn modal_impedance_and_force(
        &self,
        a: f64,
        omega_rad_s: f64,
        amplitude: f64,
    ) -> Result<(Complex64, Complex64), ReducedError> {
        let mut ch = vec![Complex64::new(0.0, 0.0); self.nch];
        self.fill_channels(omega_rad_s, amplitude, &mut ch)?;
        let fi = self.imposed_at(omega_rad_s)?;
        let (_, fm, za, _) = self.nm_terms(a, omega_rad_s, &ch, fi)?;
        Ok((za, fm))
    }

    /// The imposed forces at `Omega` (none without one; no allocation).
    #[inline(always)]
    pub(crate) fn imposed_at(&self, omega: f64) -> Result<ImposedForces, ReducedError> {
        let mut out = ImposedForces {
            f: [Complex64::new(0.0, 0.0); MAX_IMPOSED],
            n: self.imposed.len(),
        };
        for (f, imp) in out.f.iter_mut().zip(&self.imposed) {
            *f = imp.envelope.eval(omega)?;
        }
        Ok(out)
    }

    /// Whether an imposed force acts at the drive point (the reported force
    /// then includes it).
    pub(crate) fn imposed_at_drive(&self) -> bool {
        self.imposed.iter().any(|imp| imp.point == self.drive)
    }

    /// The imposed forces acting at the drive point, summed \[N\] (zero
    /// without one there; one force there is returned as it is).
    pub(crate) fn drive_imposed(&self, fi: &ImposedForces) -> Complex64 {
        let mut sum: Option<Complex64> = None;
        for (imp, f) in self.imposed.iter().zip(fi.forces()) {
            if imp.point == self.drive {
                sum = Some(sum.map_or(*f, |s| s + f));
            }
        }
        sum.unwrap_or_default()
    }

    /// [`Self::drive_imposed`] at each `Omega` of `omega`: the output's
    /// imposed force column (empty without an imposed force at the drive point).
    pub(crate) fn drive_imposed_n(&self, omega: &[f64]) -> Result<Vec<Complex64>, ReducedError> {
        if !self.imposed_at_drive() {
            return Ok(Vec::new());
        }
        omega
            .iter()
            .map(|&w| Ok(self.drive_imposed(&self.imposed_at(w)?)))
            .collect()
    }

    /// The slow-flow right-hand side: `A' = (phi^H f_ex - K A) / (2 i Omega)`;
    /// `phi` is scratch space.
    #[inline(always)]
    pub(crate) fn rhs(
        &self,
        y: &[f64; 2],
        omega: f64,
        ch: &[Complex64],
        f_imposed: &ImposedForces,
        phi: &mut [Complex64; MAX_PHI],
    ) -> Result<[f64; 2], ReducedError> {
        let amp = Complex64::new(y[0], y[1]);
        // plain sqrt: hypot's overflow guard is not needed at modal amplitudes
        let a = (y[0] * y[0] + y[1] * y[1]).sqrt();
        let (k, fm, _, _) = self.nm_terms_in(a, omega, ch, f_imposed, phi)?;
        // z / (2 i Omega) = -i z / (2 Omega)
        let z = fm - k * amp;
        let s = 0.5 / omega;
        Ok([z.im * s, -z.re * s])
    }

    /// The blocked force at the drive point, `F0 = sum T_G u_hat` \[N\] (the force
    /// with the structure held at rest).
    pub fn blocked_force(
        &self,
        omega_rad_s: f64,
        amplitude: f64,
    ) -> Result<Complex64, ReducedError> {
        let mut ch = vec![Complex64::new(0.0, 0.0); self.nch];
        self.fill_channels(omega_rad_s, amplitude, &mut ch)?;
        let fi = self.drive_imposed_n(&[omega_rad_s])?;
        let s = self.output_samples(&output::OutputStates {
            t_s: &[f64::NAN],
            omega_rad_s: &[omega_rad_s],
            amplitude: &[Complex64::new(0.0, 0.0)],
            channels: output::Channels::Rows(&ch),
            imposed_n: &fi,
        })?;
        Ok(s[0].force_n)
    }
}

/// A [`crate::attachment::LinearAttachment`] prepared for many frequencies
/// (its [`crate::attachment::Condenser`] built once).
#[derive(Debug, Clone)]
pub struct PreparedAttachment {
    attachment: crate::attachment::LinearAttachment,
    condenser: crate::attachment::Condenser,
}

impl PreparedAttachment {
    /// Validates and localizes the attachment.
    pub fn new(
        attachment: crate::attachment::LinearAttachment,
    ) -> Result<Self, crate::attachment::AttachmentError> {
        attachment.validate()?;
        let condenser = crate::attachment::Condenser::new(&attachment)?;
        Ok(Self {
            attachment,
            condenser,
        })
    }

    /// The underlying attachment.
    pub fn attachment(&self) -> &crate::attachment::LinearAttachment {
        &self.attachment
    }
}

impl InterfaceModel for PreparedAttachment {
    fn name(&self) -> &str {
        &self.attachment.name
    }
    fn interface_points(&self) -> Vec<String> {
        self.attachment.interface_points.clone()
    }
    fn ninput(&self) -> usize {
        self.attachment.ninput()
    }
    fn condenser(&self) -> Option<&crate::attachment::Condenser> {
        Some(&self.condenser)
    }
    fn condense(&self, omega_rad_s: f64) -> Result<Condensed, AttachmentModelError> {
        let c = self.condenser.condense(omega_rad_s)?;
        Ok((c.z_g, c.t_g))
    }
    fn condense_with_derivative(
        &self,
        omega_rad_s: f64,
    ) -> Result<(Condensed, Condensed), AttachmentModelError> {
        let (c, d) = self.condenser.condense_with_derivative(omega_rad_s)?;
        Ok(((c.z_g, c.t_g), (d.z_g, d.t_g)))
    }
}

impl ReducedModel {
    /// Adds a generic linear attachment (`eq:component2`) driven by the sweep,
    /// `u_hat = amplitude * input_per_unit` (see [`Self::with_attachment`]).
    pub fn with_linear_attachment(
        self,
        attachment: &crate::attachment::LinearAttachment,
        input_per_unit: &[Complex64],
    ) -> Result<Self, ReducedError> {
        let prepared =
            PreparedAttachment::new(attachment.clone()).map_err(|e| ReducedError::Attachment {
                attachment: attachment.name.clone(),
                omega_rad_s: f64::NAN,
                source: Box::new(e),
            })?;
        self.with_attachment(Arc::new(prepared), input_per_unit)
    }
}
