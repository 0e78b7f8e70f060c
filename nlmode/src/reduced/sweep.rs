//! Slow-flow integration of `eq:NM` along a sine sweep (`nlmode`,
//! `linear-slowflow`, `imposed-force`).
use super::dynamic::AttachmentStates;
pub(crate) use super::omega_cache::OmegaCache;
use super::output::{Channels, FoldOut, OutputScratch, OutputStates, SampleFields};
use super::{ImposedForces, ReducedError, ReducedModel, MAX_PHI};
use crate::dopri::{
    integrate, Controller, DensePoly, ErrorScale, IntegratorStats, Stop, Tolerances,
};
use crate::excitation::LinearSweep;
use crate::table::TableError;
use num_complex::Complex64;
use serde::Serialize;

/// Options of the slow-flow integration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct SlowFlowOptions {
    /// Relative tolerance of the Dormand-Prince error control. The default
    /// 1e-4 keeps the envelopes of case (a) within 2e-5 of their peaks of the
    /// converged solution (rtol 1e-9; 3.7e-4 at Matlab's default 1e-3, 8e-7 at
    /// 1e-5), far below the model's own error against the reference (~1 %).
    /// The imposed-force model near a force minimum is more sensitive: use
    /// 1e-5 or less there.
    pub rtol: f64,
    /// Absolute tolerance on `Re A`, `Im A` relative to the table's largest
    /// amplitude (`atol = atol_rel * a_max`).
    pub atol_rel: f64,
    /// Largest step as a fraction of the sweep duration.
    pub max_step_fraction: f64,
    /// Number of output samples, uniform in time (and so in `Omega`), including
    /// both ends.
    pub output_samples: usize,
    /// Relative accuracy of the attachment quantities `Z_G`, `T_G u_hat`
    /// tabulated along the sweep's frequency range (see [`SlowFlowResult`]).
    pub channel_tol: f64,
    /// How the attachments enter the slow flow: in quasi-steady state
    /// (`eq:NM`, the paper's model, default) or with their states carried as
    /// slowly varying amplitudes ([`super::dynamic`]).
    #[serde(default)]
    pub attachments: AttachmentStates,
    /// With [`AttachmentStates::Dynamic`]: an attachment mode whose pole lies
    /// farther than `fast_pole_factor * Omega_max` from the swept band is
    /// kept in quasi-steady state ([`super::dynamic`], "fast and slow
    /// parts"); `f64::INFINITY` carries every state.
    #[serde(default = "default_fast_pole_factor")]
    pub fast_pole_factor: f64,
    /// Keep the modulation terms `eq:NM` drops, to first order in the slow
    /// derivatives: the attachments' rate terms `dZ_A/d(i Omega) A'`, the
    /// modal damping's `2 D omega A'` and the sweep's `i Omega' A`
    /// ([`super::rate`]). Steady states are unchanged. Default `false`: the
    /// paper's `eq:NM`.
    #[serde(default)]
    pub rate_terms: bool,
}

fn default_fast_pole_factor() -> f64 {
    super::dynamic::FAST_POLE_FACTOR
}

impl Default for SlowFlowOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-4,
            atol_rel: 1e-9,
            max_step_fraction: 0.02,
            output_samples: 2001,
            channel_tol: 1e-9,
            attachments: AttachmentStates::QuasiSteady,
            fast_pole_factor: super::dynamic::FAST_POLE_FACTOR,
            rate_terms: false,
        }
    }
}

impl SlowFlowOptions {
    pub(crate) fn check(&self) -> Result<(), ReducedError> {
        let bad = |name, value: f64, why| Err(ReducedError::BadOption { name, value, why });
        if !(self.rtol > 0.0 && self.rtol < 1.0) {
            return bad("rtol", self.rtol, "must lie in (0, 1)");
        }
        if !(self.atol_rel > 0.0 && self.atol_rel.is_finite()) {
            return bad("atol_rel", self.atol_rel, "must be positive");
        }
        if !(self.max_step_fraction > 0.0 && self.max_step_fraction <= 1.0) {
            return bad(
                "max_step_fraction",
                self.max_step_fraction,
                "must lie in (0, 1]",
            );
        }
        if self.output_samples < 2 {
            return bad(
                "output_samples",
                self.output_samples as f64,
                "need at least 2",
            );
        }
        if !(self.channel_tol > 0.0 && self.channel_tol < 1e-2) {
            return bad("channel_tol", self.channel_tol, "must lie in (0, 1e-2)");
        }
        if self.fast_pole_factor.is_nan() || self.fast_pole_factor <= 0.0 {
            return bad(
                "fast_pole_factor",
                self.fast_pole_factor,
                "must be positive (infinity: every attachment state carried)",
            );
        }
        Ok(())
    }
}

/// One output sample of a slow-flow sweep.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SlowFlowSample {
    /// Time since the start of the sweep \[s\].
    pub t_s: f64,
    /// Excitation frequency `Omega(t)` \[rad/s\].
    pub omega_rad_s: f64,
    /// Modal amplitude `a = |A|` \[sqrt(kg) m\].
    pub a: f64,
    /// Complex modal amplitude `A = a e^{i theta}` \[sqrt(kg) m\]
    /// (`q = Re(a phi e^{i(Phi + theta)})`; phase lag: [`Self::theta_rad`]).
    pub amplitude: Complex64,
    /// Modal frequency `omega(a)` in force (frequency error applied) \[rad/s\].
    pub modal_frequency_rad_s: f64,
    /// Fundamental tip amplitude `|q_tip,1| = a |phi_tip,1(a)|` \[m\].
    pub tip_amplitude_m: f64,
    /// Fundamental drive-point amplitude `a |phi_drive,1(a)|` \[m\].
    pub drive_amplitude_m: f64,
    /// Fundamental force amplitude at the drive point `|F|` \[N\] (`eq:fc1`).
    pub force_amplitude_n: f64,
    /// Complex fundamental force at the drive point relative to the excitation
    /// phase `Phi` \[N\] (`F(t) = Re(F e^{i Phi})`; phase: [`Self::force_phase_rad`]).
    pub force_n: Complex64,
}

// The phases are derived on demand: two `atan2` per sample were a third of
// a sweep's cost, and parameter studies mostly read only the amplitudes.
impl SlowFlowSample {
    /// Phase lag `theta = arg A` \[rad\] (`q = Re(a phi e^{i(Phi + theta)})`).
    pub fn theta_rad(&self) -> f64 {
        self.amplitude.arg()
    }

    /// Phase of the force relative to the excitation phase `Phi` \[rad\]
    /// (`F(t) = Re(|F| e^{i(Phi + phase)})`).
    pub fn force_phase_rad(&self) -> f64 {
        self.force_n.arg()
    }
}

/// How a sweep ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum SweepStatus {
    /// The whole sweep was integrated.
    Completed,
    /// The modal amplitude reached the top of the table's range at `t_s` (the
    /// model is not defined above it; with an imposed force and a frequency
    /// error this is the paper's unbounded growth). Samples stop there.
    LeftTableRange {
        t_s: f64,
        omega_rad_s: f64,
        a: f64,
        a_max: f64,
    },
    /// The error controller asked for a step below the minimum.
    StepSizeTooSmall {
        t_s: f64,
        omega_rad_s: f64,
        h_s: f64,
    },
    /// The step limit was reached.
    MaxSteps { t_s: f64, omega_rad_s: f64 },
    /// The state became non-finite.
    NotFinite { t_s: f64, omega_rad_s: f64 },
}

/// The fundamental-harmonic envelopes against the excitation frequency (the
/// host's `<name>_envelope.csv`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Envelope {
    pub omega_rad_s: Vec<f64>,
    pub force_amplitude_n: Vec<f64>,
    pub tip_amplitude_m: Vec<f64>,
}

/// Summary numbers of a sweep.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SweepSummary {
    pub peak_tip_amplitude_m: f64,
    /// Excitation frequency at the peak \[rad/s\].
    pub peak_omega_rad_s: f64,
    /// Excitation frequency of the steepest drop of the tip envelope after the
    /// peak (the jump-down of a hardening resonance) \[rad/s\]; `None` if the
    /// peak is the last sample.
    pub jump_down_omega_rad_s: Option<f64>,
    pub min_force_amplitude_n: f64,
    pub max_force_amplitude_n: f64,
}

/// The result of [`ReducedModel::simulate_sweep`].
#[derive(Debug, Clone, Serialize)]
pub struct SlowFlowResult {
    pub sweep: LinearSweep,
    pub samples: Vec<SlowFlowSample>,
    pub status: SweepStatus,
    pub stats: IntegratorStats,
    /// Frequencies at which the attachment models were evaluated exactly to
    /// tabulate `Z_G`, `T_G u_hat` over the sweep (cubic Hermite in `Omega`,
    /// refined until the midpoint error is below `channel_tol`).
    pub channel_nodes: usize,
}

impl SlowFlowResult {
    /// Fundamental-harmonic envelopes.
    pub fn envelope(&self) -> Envelope {
        Envelope {
            omega_rad_s: self.samples.iter().map(|s| s.omega_rad_s).collect(),
            force_amplitude_n: self.samples.iter().map(|s| s.force_amplitude_n).collect(),
            tip_amplitude_m: self.samples.iter().map(|s| s.tip_amplitude_m).collect(),
        }
    }

    /// Peak, jump-down and force extremes.
    pub fn summary(&self) -> Result<SweepSummary, ReducedError> {
        let s = &self.samples;
        if s.is_empty() {
            return Err(ReducedError::EmptyResult);
        }
        let (ip, peak) = s
            .iter()
            .enumerate()
            .fold((0, f64::NEG_INFINITY), |b, (i, x)| {
                if x.tip_amplitude_m > b.1 {
                    (i, x.tip_amplitude_m)
                } else {
                    b
                }
            });
        let jump = (ip..s.len().saturating_sub(1))
            .map(|i| (i, s[i + 1].tip_amplitude_m - s[i].tip_amplitude_m))
            .fold(None, |b: Option<(usize, f64)>, (i, d)| match b {
                Some((_, bd)) if bd <= d => b,
                _ => Some((i, d)),
            })
            .map(|(i, _)| 0.5 * (s[i].omega_rad_s + s[i + 1].omega_rad_s));
        Ok(SweepSummary {
            peak_tip_amplitude_m: peak,
            peak_omega_rad_s: s[ip].omega_rad_s,
            jump_down_omega_rad_s: jump,
            min_force_amplitude_n: s
                .iter()
                .map(|x| x.force_amplitude_n)
                .fold(f64::INFINITY, f64::min),
            max_force_amplitude_n: s
                .iter()
                .map(|x| x.force_amplitude_n)
                .fold(f64::NEG_INFINITY, f64::max),
        })
    }

    /// Complex modal amplitude `A = a e^{i theta}` at time `t` by linear
    /// interpolation between samples (slow variables), `None` outside.
    pub fn amplitude_at(&self, t_s: f64) -> Option<Complex64> {
        let s = &self.samples;
        if s.is_empty() || t_s < s[0].t_s || t_s > s[s.len() - 1].t_s {
            return None;
        }
        let j = s
            .partition_point(|x| x.t_s <= t_s)
            .clamp(1, s.len().max(2) - 1);
        if s.len() == 1 {
            return Some(s[0].amplitude);
        }
        let (p, q) = (&s[j - 1], &s[j]);
        let w = if q.t_s > p.t_s {
            (t_s - p.t_s) / (q.t_s - p.t_s)
        } else {
            0.0
        };
        let (ap, aq) = (p.amplitude, q.amplitude);
        Some(ap + (aq - ap) * w)
    }
}

impl ReducedModel {
    /// Integrates the slow flow of `eq:NM` (regular complex form, module docs)
    /// along `sweep` from rest (`A = 0`), with the sweep amplitude as `u_hat`
    /// of the attachments.
    pub fn simulate_sweep(
        &self,
        sweep: &LinearSweep,
        opts: &SlowFlowOptions,
    ) -> Result<SlowFlowResult, ReducedError> {
        self.simulate_sweep_from(sweep, opts, Complex64::new(0.0, 0.0))
    }

    /// As [`Self::simulate_sweep`] from the complex modal amplitude `A0`.
    pub fn simulate_sweep_from(
        &self,
        sweep: &LinearSweep,
        opts: &SlowFlowOptions,
        a0: Complex64,
    ) -> Result<SlowFlowResult, ReducedError> {
        let mut samples: Vec<SlowFlowSample> = Vec::with_capacity(opts.output_samples + 1);
        let run = self.simulate_sweep_into(sweep, opts, a0, &mut samples)?;
        Ok(SlowFlowResult {
            sweep: *sweep,
            samples,
            status: run.status,
            stats: run.stats,
            channel_nodes: run.channel_nodes,
        })
    }

    /// The sweep integration of [`Self::simulate_sweep_from`] (the one
    /// kernel: the envelope-storing path is this with a `Vec` as the sink),
    /// handing the output samples to `sink` in sweep order, in batches of at
    /// most [`SWEEP_BATCH`] as the integration passes them, instead of
    /// storing them: e.g. to fold figures of merit without an envelope. Each
    /// sample is computed by the same expressions as in the stored result
    /// (the output quantities are element-wise, so the batching does not
    /// change a bit). An error of the sink stops the sweep and is returned.
    pub fn simulate_sweep_into(
        &self,
        sweep: &LinearSweep,
        opts: &SlowFlowOptions,
        a0: Complex64,
        sink: &mut dyn SweepSink,
    ) -> Result<SweepRun, ReducedError> {
        self.sweep_with(sweep, opts, a0, &mut ToSink(sink))
    }

    /// [`Self::simulate_sweep_into`] folded by `fold` (the figures of merit
    /// of a sweep read `Omega`, the tip and the force amplitudes only): each
    /// sample's three quantities are computed as the fold takes them, by the
    /// same expressions as in the stored result, and no sample is stored.
    /// On an error the fold may have taken a part of the last batch (the
    /// sweep's result is then the error).
    pub fn simulate_sweep_folded<K: EnvelopeFold>(
        &self,
        sweep: &LinearSweep,
        opts: &SlowFlowOptions,
        a0: Complex64,
        fold: &mut K,
    ) -> Result<SweepRun, ReducedError> {
        self.sweep_with(sweep, opts, a0, &mut ToFold(fold))
    }

    /// The sweep kernel of [`Self::simulate_sweep_into`] and
    /// [`Self::simulate_sweep_folded`], its output batches to `out`.
    fn sweep_with<E: Emit>(
        &self,
        sweep: &LinearSweep,
        opts: &SlowFlowOptions,
        a0: Complex64,
        out: &mut E,
    ) -> Result<SweepRun, ReducedError> {
        opts.check()?;
        let (lo, hi) = {
            let (s, e) = (sweep.omega_start_rad_s, sweep.omega_end_rad_s);
            (s.min(e), s.max(e))
        };
        for imp in &self.imposed {
            imp.envelope.check_covers(lo, hi)?;
        }
        if opts.attachments == AttachmentStates::Dynamic {
            let ports = super::dynamic::StatePort::select(self, lo, hi, opts.fast_pole_factor)?;
            // without a slow attachment state the model is `eq:NM` itself
            if !ports.is_empty() {
                return out.dynamic(self, &ports, (sweep, opts), a0);
            }
        }
        let cache = OmegaCache::build(self, lo, hi, sweep.amplitude, opts.channel_tol)?;
        let duration = sweep.duration_s();
        let atol = opts.atol_rel * self.a_scale;
        let tol = Tolerances {
            rtol: opts.rtol,
            atol: [atol; 2],
            controller: Controller::Pi,
            scale: ErrorScale::Local,
            h_max: opts.max_step_fraction * duration,
            h_min: 1e-12 * duration,
            max_steps: 10_000_000,
            h0: None,
        };
        // one port with one point, no imposed force: straight-line code,
        // the integration compiled for it alone (no tests of the other
        // cases per evaluation)
        if let (Some(sp), false) = (self.single_point(), opts.rate_terms) {
            let ramp = sweep.ramp();
            // (inlined into the integrator's stages: no call per evaluation)
            return self.integrate_sweep(
                #[inline(always)]
                |t: f64, y: &[f64; 2], dy: &mut [f64; 2]| -> Result<(), ReducedError> {
                    let w = ramp.at(t);
                    let (c, tc) = cache.segment(w);
                    *dy = self.rhs_single(sp, y, w, c, tc)?;
                    Ok(())
                },
                (sweep, opts),
                &cache,
                &tol,
                a0,
                out,
            );
        }
        let mut ch = vec![Complex64::new(0.0, 0.0); self.nch];
        let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
        let no_imposed = self.imposed.is_empty();
        // (without imposed forces their empty list, set once: no forces
        // evaluated, copied or summed per evaluation)
        let mut fi = ImposedForces::NONE;
        let mut dch = vec![Complex64::new(0.0, 0.0); if opts.rate_terms { self.nch } else { 0 }];
        let rhs = |t: f64, y: &[f64; 2], dy: &mut [f64; 2]| -> Result<(), ReducedError> {
            let w = sweep.omega_rad_s(t);
            if !no_imposed {
                fi = self.imposed_at(w)?;
            }
            if opts.rate_terms {
                cache.eval_with_derivative(w, &mut ch, &mut dch);
                let wdot = sweep.omega_rate_rad_s2(t);
                let d = self.rhs_first_order(y, w, wdot, &ch, &dch, &fi, &mut phi)?;
                *dy = [d.re, d.im];
            } else {
                cache.eval(w, &mut ch);
                *dy = self.rhs(y, w, &ch, &fi, &mut phi)?;
            }
            Ok(())
        };
        self.integrate_sweep(rhs, (sweep, opts), &cache, &tol, a0, out)
    }

    /// The integration of [`Self::sweep_with`] with the slow flow's
    /// right-hand side `rhs` (the sweep's channels tabulated in `cache`,
    /// the integrator's tolerances `tol`), from `A0`: the output samples
    /// taken from each step's continuous extension, in batches to `out`.
    fn integrate_sweep<E: Emit>(
        &self,
        rhs: impl FnMut(f64, &[f64; 2], &mut [f64; 2]) -> Result<(), ReducedError>,
        (sweep, opts): (&LinearSweep, &SlowFlowOptions),
        cache: &OmegaCache,
        tol: &Tolerances<[f64; 2]>,
        a0: Complex64,
        out: &mut E,
    ) -> Result<SweepRun, ReducedError> {
        let duration = sweep.duration_s();
        let n = opts.output_samples;
        let mut batch = OutputBatch::new(opts.rate_terms);
        let mut next = 0usize;
        let dt = duration / (n - 1) as f64;
        let times = SampleTimes { n, dt, duration };
        let mut last_state = (0.0, [a0.re, a0.im]);
        let (stats, stop) = integrate(rhs, 0.0, [a0.re, a0.im], duration, tol, |d, _| {
            let t1 = d.t0 + d.h;
            // the step's continuous extension, its coefficients once
            let poly = d.polynomial();
            let t_last = t1 * (1.0 + 1e-14);
            while batch.take(&poly, (d.t0, t_last), &times, &mut next) {
                batch.flush(self, sweep, cache, out)?;
            }
            last_state = (t1, poly.eval(t1));
            Ok(())
        });
        if batch.last_t.is_none() {
            batch.push(0.0, a0);
        }
        let status = match stop {
            None => SweepStatus::Completed,
            Some(stop) => {
                let t_stop = last_state.0;
                let a_stop = Complex64::new(last_state.1[0], last_state.1[1]).norm();
                let status = stop_status(stop, t_stop, sweep.omega_rad_s(t_stop), a_stop)?;
                // the state where the sweep stopped ends the output
                if batch.last_t.map(|t| t < t_stop).unwrap_or(true) {
                    if batch.ts.len() == SWEEP_BATCH {
                        batch.flush(self, sweep, cache, out)?;
                    }
                    batch.push(t_stop, Complex64::new(last_state.1[0], last_state.1[1]));
                }
                status
            }
        };
        batch.flush(self, sweep, cache, out)?;
        Ok(SweepRun {
            status,
            stats,
            channel_nodes: cache.len(),
            samples: batch.emitted,
        })
    }
}

/// The status of a sweep whose integration stopped at `t_stop` (excitation
/// frequency `omega_rad_s`, modal amplitude `a_stop` there); an error of the
/// model other than leaving the table's range is returned as it is.
pub(crate) fn stop_status(
    stop: Stop<ReducedError>,
    t_stop: f64,
    omega_rad_s: f64,
    a_stop: f64,
) -> Result<SweepStatus, ReducedError> {
    let (t_s, w) = (t_stop, omega_rad_s);
    Ok(match stop {
        Stop::Rhs {
            error: ReducedError::Table(TableError::AboveRange { max, .. }),
            ..
        } => SweepStatus::LeftTableRange {
            t_s,
            omega_rad_s: w,
            a: a_stop,
            a_max: max,
        },
        Stop::Rhs { error, .. } | Stop::Observer { error, .. } => return Err(error),
        Stop::StepTooSmall { h, .. } => SweepStatus::StepSizeTooSmall {
            t_s,
            omega_rad_s: w,
            h_s: h,
        },
        Stop::MaxSteps { .. } => SweepStatus::MaxSteps {
            t_s,
            omega_rad_s: w,
        },
        Stop::NotFinite { .. } => SweepStatus::NotFinite {
            t_s,
            omega_rad_s: w,
        },
    })
}

/// Output samples a sweep computes and hands to its [`SweepSink`] at a time.
pub const SWEEP_BATCH: usize = 1024;

/// Receives the output samples of a sweep in order
/// ([`ReducedModel::simulate_sweep_into`]).
pub trait SweepSink {
    /// The next samples of the sweep (at most [`SWEEP_BATCH`], at least one).
    fn samples(&mut self, batch: &[SlowFlowSample]) -> Result<(), ReducedError>;

    /// The quantities this sink reads (the sweep computes only those; the
    /// others are `NaN`). Default: all.
    fn fields(&self) -> SampleFields {
        SampleFields::All
    }
}

/// The envelope-storing sink: every sample kept.
impl SweepSink for Vec<SlowFlowSample> {
    fn samples(&mut self, batch: &[SlowFlowSample]) -> Result<(), ReducedError> {
        self.extend_from_slice(batch);
        Ok(())
    }
}

/// A fold of a sweep's envelope ([`ReducedModel::simulate_sweep_folded`]):
/// the figures of merit of a sweep, folded as it integrates without a
/// sample stored.
pub trait EnvelopeFold {
    /// Fold the next samples of the sweep (at most [`SWEEP_BATCH`], at least
    /// one), in order: `batch.each(f)` calls `f(Omega [rad/s], tip amplitude
    /// [m], force amplitude [N])` once per sample (the quantities of
    /// [`SlowFlowSample`]) and returns the error of the sweep's output, if
    /// any (to be returned as it is).
    fn fold<B: EnvelopeBatch>(&mut self, batch: B) -> Result<(), ReducedError>;
}

/// The samples of one output batch of a sweep, for an [`EnvelopeFold`]
/// (computed as they are folded, or stored ones).
pub trait EnvelopeBatch {
    /// Calls `f(Omega, tip amplitude, force amplitude)` per sample, in order.
    fn each<F: FnMut(f64, f64, f64)>(self, f: F) -> Result<(), ReducedError>;
}

/// Stored samples (e.g. of the sweep with carried attachment states).
impl EnvelopeBatch for &[SlowFlowSample] {
    #[inline(always)]
    fn each<F: FnMut(f64, f64, f64)>(self, mut f: F) -> Result<(), ReducedError> {
        for s in self {
            f(s.omega_rad_s, s.tip_amplitude_m, s.force_amplitude_n);
        }
        Ok(())
    }
}

/// One batch of the sweep's output states: the output pass, its samples
/// to the fold as they are computed.
struct PassBatch<'a> {
    model: &'a ReducedModel,
    states: &'a OutputStates<'a>,
    scratch: &'a mut OutputScratch,
}

impl EnvelopeBatch for PassBatch<'_> {
    #[inline(always)]
    fn each<F: FnMut(f64, f64, f64)>(self, f: F) -> Result<(), ReducedError> {
        let (model, fields) = (self.model, SampleFields::Envelope);
        model.output_fields_into(self.states, fields, self.scratch, &mut FoldOut(f))
    }
}

/// An [`EnvelopeFold`] as a [`SweepSink`] (reading the envelope only).
struct FoldSink<'a, K>(&'a mut K);

impl<K: EnvelopeFold> SweepSink for FoldSink<'_, K> {
    fn samples(&mut self, batch: &[SlowFlowSample]) -> Result<(), ReducedError> {
        self.0.fold(batch)
    }
    fn fields(&self) -> SampleFields {
        SampleFields::Envelope
    }
}

/// Where the sweep kernel hands its output batches: a [`SweepSink`]'s
/// samples, or an [`EnvelopeFold`]'s quantities as they are computed.
trait Emit {
    /// The output samples of the states of one batch (`buf`: the sweep's
    /// buffer of samples, kept across batches).
    fn emit(
        &mut self,
        model: &ReducedModel,
        states: &OutputStates,
        scratch: &mut OutputScratch,
        buf: &mut Vec<SlowFlowSample>,
    ) -> Result<(), ReducedError>;

    /// The sweep with carried attachment states ([`super::dynamic`]).
    fn dynamic(
        &mut self,
        model: &ReducedModel,
        ports: &[super::dynamic::StatePort],
        sweep: (&LinearSweep, &SlowFlowOptions),
        a0: Complex64,
    ) -> Result<SweepRun, ReducedError>;
}

/// The batches to a [`SweepSink`]: each stored, then handed over.
struct ToSink<'a>(&'a mut dyn SweepSink);

impl Emit for ToSink<'_> {
    fn emit(
        &mut self,
        model: &ReducedModel,
        states: &OutputStates,
        scratch: &mut OutputScratch,
        buf: &mut Vec<SlowFlowSample>,
    ) -> Result<(), ReducedError> {
        buf.clear();
        model.output_fields_into(states, self.0.fields(), scratch, buf)?;
        self.0.samples(buf)
    }

    fn dynamic(
        &mut self,
        model: &ReducedModel,
        ports: &[super::dynamic::StatePort],
        (sweep, opts): (&LinearSweep, &SlowFlowOptions),
        a0: Complex64,
    ) -> Result<SweepRun, ReducedError> {
        super::dynamic::simulate(model, ports, sweep, opts, a0, self.0)
    }
}

/// The batches to an [`EnvelopeFold`]: each sample's quantities folded as
/// the output pass computes them.
struct ToFold<'a, K>(&'a mut K);

impl<K: EnvelopeFold> Emit for ToFold<'_, K> {
    #[inline(always)]
    fn emit(
        &mut self,
        model: &ReducedModel,
        states: &OutputStates,
        scratch: &mut OutputScratch,
        _: &mut Vec<SlowFlowSample>,
    ) -> Result<(), ReducedError> {
        self.0.fold(PassBatch {
            model,
            states,
            scratch,
        })
    }

    fn dynamic(
        &mut self,
        model: &ReducedModel,
        ports: &[super::dynamic::StatePort],
        (sweep, opts): (&LinearSweep, &SlowFlowOptions),
        a0: Complex64,
    ) -> Result<SweepRun, ReducedError> {
        let sink = &mut FoldSink(&mut *self.0);
        super::dynamic::simulate(model, ports, sweep, opts, a0, sink)
    }
}

/// How a sweep into a [`SweepSink`] ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SweepRun {
    pub status: SweepStatus,
    pub stats: IntegratorStats,
    /// As [`SlowFlowResult::channel_nodes`].
    pub channel_nodes: usize,
    /// Output samples handed to the sink.
    pub samples: usize,
}

/// The first `j` in `[j0, end)` where `taken(j)` is false (`end` if none)
/// for a `taken` true up to some index and false after it (the sample
/// times are ordered): searched from the estimate `guess` (`taken` true up
/// to about there) down and up, so the result is that of testing `j0, j0 +
/// 1, ...` in turn, at a few tests per step instead of one per sample.
#[inline(always)]
fn first_after(j0: usize, end: usize, guess: usize, taken: impl Fn(usize) -> bool) -> usize {
    let mut j = guess.saturating_add(1).clamp(j0, end.max(j0));
    while j > j0 && !taken(j - 1) {
        j -= 1;
    }
    while j < end && taken(j) {
        j += 1;
    }
    j
}

/// The output times of a sweep: `n` uniform in `[0, duration]`, sample `j`
/// at `j dt`, the last at `duration` exactly.
struct SampleTimes {
    n: usize,
    dt: f64,
    duration: f64,
}

/// The states of the output samples not yet handed to the sink, and the
/// buffers of their output quantities (reused from batch to batch).
struct OutputBatch {
    /// Times and states of the pending samples (at most [`SWEEP_BATCH`]).
    ts: Vec<f64>,
    amps: Vec<Complex64>,
    /// Samples handed to the sink so far.
    emitted: usize,
    /// Time of the last sample taken.
    last_t: Option<f64>,
    /// Excitation frequency of the pending samples.
    w: Vec<f64>,
    /// Attachment channels of the pending samples, with the rate terms only.
    channels: Vec<Complex64>,
    scratch: OutputScratch,
    samples: Vec<SlowFlowSample>,
    /// The slow flow has the rate terms: so has the reported force.
    rate_terms: bool,
}

impl OutputBatch {
    fn new(rate_terms: bool) -> Self {
        Self {
            rate_terms,
            ts: Vec::with_capacity(SWEEP_BATCH),
            amps: Vec::with_capacity(SWEEP_BATCH),
            emitted: 0,
            last_t: None,
            w: Vec::with_capacity(SWEEP_BATCH),
            channels: Vec::new(),
            scratch: OutputScratch::default(),
            // (reserved by the first batch handed to a sink: a fold never
            // stores a sample)
            samples: Vec::new(),
        }
    }

    /// The sample at `t` with state `a`.
    fn push(&mut self, t: f64, a: Complex64) {
        self.ts.push(t);
        self.amps.push(a);
        self.last_t = Some(t);
    }

    /// Takes the output samples from `*next` on whose times lie at or
    /// before `t_last` in the step from `t0` (continuous extension `poly`),
    /// until the batch is full; `true` if it is (flush it, then take on).
    /// A sample's time is `max(j dt, t0)` (the last `duration`), its state
    /// `poly` there.
    // (the count first, from `t_last / dt` corrected by the exact test;
    // then each buffer extended by an exact-size iterator: no capacity test
    // per sample, no buffer zeroed per sweep; `jf` is `j as f64`, exact as
    // an integer count)
    #[inline(always)]
    fn take(
        &mut self,
        poly: &DensePoly<2>,
        (t0, t_last): (f64, f64),
        times: &SampleTimes,
        next: &mut usize,
    ) -> bool {
        let (len, j0) = (self.ts.len(), *next);
        let time = |j: usize, jf: f64| {
            let ts = if j + 1 == times.n {
                times.duration
            } else {
                jf * times.dt
            };
            // `ts.max(t0)` (neither is NaN)
            (ts, if ts < t0 { t0 } else { ts })
        };
        let end = times.n.min(j0 + (SWEEP_BATCH - len));
        let j = first_after(j0, end, (t_last / times.dt) as usize, |j| {
            time(j, j as f64).0 <= t_last
        });
        let mut jf = j0 as f64;
        self.ts.extend((j0..j).map(|j| {
            let t = time(j, jf).1;
            jf += 1.0;
            t
        }));
        self.amps.extend(self.ts[len..].iter().map(|&t| {
            let y = poly.eval(t);
            Complex64::new(y[0], y[1])
        }));
        if let Some(&t) = self.ts[len..].last() {
            self.last_t = Some(t);
        }
        *next = j;
        self.ts.len() == SWEEP_BATCH
    }

    /// The output quantities of the pending states, to the sink.
    fn flush(
        &mut self,
        model: &ReducedModel,
        sweep: &LinearSweep,
        cache: &OmegaCache,
        out: &mut impl Emit,
    ) -> Result<(), ReducedError> {
        if self.ts.is_empty() {
            return Ok(());
        }
        let (ts, amps) = (&self.ts[..], &self.amps[..]);
        self.w.clear();
        let ramp = sweep.ramp();
        self.w.extend(ts.iter().map(|&t| ramp.at(t)));
        // with the rate terms each sample's row, its rate force subtracted
        // (super::rate); else the channels from the tabulation
        if self.rate_terms {
            self.channels.clear();
            let states = (ts, &self.w[..], amps);
            model.rate_rows_into(cache, sweep, states, &mut self.channels)?;
        }
        let imposed_n = model.drive_imposed_n(&self.w)?;
        let states = OutputStates {
            t_s: ts,
            omega_rad_s: &self.w,
            amplitude: amps,
            channels: if self.rate_terms {
                Channels::Rows(&self.channels)
            } else {
                Channels::Tabulated(cache)
            },
            imposed_n: &imposed_n,
        };
        out.emit(model, &states, &mut self.scratch, &mut self.samples)?;
        self.emitted += self.ts.len();
        self.ts.clear();
        self.amps.clear();
        Ok(())
    }
}

/// The output samples at the states `amps` (times `ts`, frequencies `w`,
/// the attachment channels of each sample in turn), to the sink.
pub(crate) fn emit(
    model: &ReducedModel,
    ts: &[f64],
    w: &[f64],
    amps: &[Complex64],
    channels: &[Complex64],
    sink: &mut dyn SweepSink,
) -> Result<(), ReducedError> {
    let imposed_n = model.drive_imposed_n(w)?;
    let samples = model.output_fields(
        &OutputStates {
            t_s: ts,
            omega_rad_s: w,
            amplitude: amps,
            channels: Channels::Rows(channels),
            imposed_n: &imposed_n,
        },
        sink.fields(),
    )?;
    sink.samples(&samples)
}

#[cfg(test)]
#[path = "sweep_tests.rs"]
mod tests;
