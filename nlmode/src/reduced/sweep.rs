//! Slow-flow integration of `eq:NM` along a sine sweep (`nlmode`,
//! `linear-slowflow`, `imposed-force`).
use super::dynamic::AttachmentStates;
pub(crate) use super::omega_cache::OmegaCache;
use super::output::{Channels, OutputScratch, OutputStates, SampleFields};
use super::{ImposedForces, ReducedError, ReducedModel, MAX_PHI};
use crate::dopri::{integrate, Controller, ErrorScale, IntegratorStats, Stop, Tolerances};
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
                return super::dynamic::simulate(self, &ports, sweep, opts, a0, sink);
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
        let mut ch = vec![Complex64::new(0.0, 0.0); self.nch];
        let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
        let no_imposed = self.imposed.is_empty();
        // (without imposed forces their empty list, set once: no forces
        // evaluated, copied or summed per evaluation)
        let mut fi = ImposedForces::NONE;
        let mut dch = vec![Complex64::new(0.0, 0.0); if opts.rate_terms { self.nch } else { 0 }];
        // one port with one point, no imposed force: straight-line code
        let single = self.single_point();
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
            } else if let Some(sp) = single {
                let (c, tc) = cache.segment(w);
                *dy = self.rhs_single(sp, y, w, c, tc)?;
            } else {
                cache.eval(w, &mut ch);
                *dy = self.rhs(y, w, &ch, &fi, &mut phi)?;
            }
            Ok(())
        };
        let n = opts.output_samples;
        let mut batch = OutputBatch::new(opts.rate_terms);
        let mut next = 0usize;
        let dt = duration / (n - 1) as f64;
        let sample_t = |j: usize| if j + 1 == n { duration } else { j as f64 * dt };
        let mut last_state = (0.0, [a0.re, a0.im]);
        let (stats, stop) = integrate(rhs, 0.0, [a0.re, a0.im], duration, &tol, |d, _| {
            let t1 = d.t0 + d.h;
            // the step's continuous extension, its coefficients once
            let poly = d.polynomial();
            let t_last = t1 * (1.0 + 1e-14);
            while next < n {
                let ts = sample_t(next);
                if !(ts <= t_last) {
                    break;
                }
                // `ts.max(t0)` (neither is NaN)
                let t = if ts < d.t0 { d.t0 } else { ts };
                let y = poly.eval(t);
                batch.push(t, Complex64::new(y[0], y[1]));
                next += 1;
                if batch.ts.len() == SWEEP_BATCH {
                    batch.flush(self, sweep, &cache, sink)?;
                }
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
                    batch.push(t_stop, Complex64::new(last_state.1[0], last_state.1[1]));
                }
                status
            }
        };
        batch.flush(self, sweep, &cache, sink)?;
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

/// The states of the output samples not yet handed to the sink, and the
/// buffers of their output quantities (reused from batch to batch).
struct OutputBatch {
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
            samples: Vec::with_capacity(SWEEP_BATCH),
        }
    }

    // (inlined: called per output sample; left to itself it was not, with
    // the inlining decided by the codegen units' partition)
    #[inline(always)]
    fn push(&mut self, t: f64, a: Complex64) {
        self.ts.push(t);
        self.amps.push(a);
        self.last_t = Some(t);
    }

    /// The output quantities of the pending states, to the sink.
    fn flush(
        &mut self,
        model: &ReducedModel,
        sweep: &LinearSweep,
        cache: &OmegaCache,
        sink: &mut dyn SweepSink,
    ) -> Result<(), ReducedError> {
        if self.ts.is_empty() {
            return Ok(());
        }
        self.w.clear();
        self.w.extend(self.ts.iter().map(|&t| sweep.omega_rad_s(t)));
        // with the rate terms each sample's row, its rate force subtracted
        // (super::rate); else the channels from the tabulation
        if self.rate_terms {
            self.channels.clear();
            let states = (&self.ts[..], &self.w[..], &self.amps[..]);
            model.rate_rows_into(cache, sweep, states, &mut self.channels)?;
        }
        let imposed_n = model.drive_imposed_n(&self.w)?;
        self.samples.clear();
        model.output_fields_into(
            &OutputStates {
                t_s: &self.ts,
                omega_rad_s: &self.w,
                amplitude: &self.amps,
                channels: if self.rate_terms {
                    Channels::Rows(&self.channels)
                } else {
                    Channels::Tabulated(cache)
                },
                imposed_n: &imposed_n,
            },
            sink.fields(),
            &mut self.scratch,
            &mut self.samples,
        )?;
        sink.samples(&self.samples)?;
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
