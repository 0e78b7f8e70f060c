//! Slow-flow integration of `eq:NM` along a sine sweep (`nlmode`,
//! `linear-slowflow`, `imposed-force`).
use super::dopri::{integrate, IntegratorStats, Stop, Tolerances};
use super::{ReducedError, ReducedModel, MAX_PHI};
use crate::excitation::LinearSweep;
use crate::table::TableError;
use num_complex::Complex64;
use serde::Serialize;

/// Options of the slow-flow integration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct SlowFlowOptions {
    /// Relative tolerance of the Dormand-Prince error control.
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
}

impl Default for SlowFlowOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-5,
            atol_rel: 1e-9,
            max_step_fraction: 0.02,
            output_samples: 2001,
            channel_tol: 1e-9,
        }
    }
}

impl SlowFlowOptions {
    fn check(&self) -> Result<(), ReducedError> {
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
    /// Modal amplitude `a` \[sqrt(kg) m\].
    pub a: f64,
    /// Phase lag `theta` \[rad\] (`q = Re(a phi e^{i(Phi + theta)})`).
    pub theta_rad: f64,
    /// Modal frequency `omega(a)` in force (frequency error applied) \[rad/s\].
    pub modal_frequency_rad_s: f64,
    /// Fundamental tip amplitude `|q_tip,1| = a |phi_tip,1(a)|` \[m\].
    pub tip_amplitude_m: f64,
    /// Fundamental drive-point amplitude `a |phi_drive,1(a)|` \[m\].
    pub drive_amplitude_m: f64,
    /// Fundamental force amplitude at the drive point `|F|` \[N\] (`eq:fc1`).
    pub force_amplitude_n: f64,
    /// Phase of the force relative to the excitation phase `Phi` \[rad\]
    /// (`F(t) = Re(|F| e^{i(Phi + phase)})`).
    pub force_phase_rad: f64,
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
            return Some(Complex64::from_polar(s[0].a, s[0].theta_rad));
        }
        let (p, q) = (&s[j - 1], &s[j]);
        let w = if q.t_s > p.t_s {
            (t_s - p.t_s) / (q.t_s - p.t_s)
        } else {
            0.0
        };
        let ap = Complex64::from_polar(p.a, p.theta_rad);
        let aq = Complex64::from_polar(q.a, q.theta_rad);
        Some(ap + (aq - ap) * w)
    }
}

/// `Z_G`, `T_G u_hat` of all attachments tabulated over `[lo, hi]` with cubic
/// Hermite interpolation: the attachment models (matrix algebra with heap
/// allocation) are evaluated once per node, not in the integrator's hot loop.
/// Nodes are bisected until the interpolation error at every interval
/// midpoint is below `tol` times the channel's magnitude.
#[derive(Debug, Clone)]
pub(crate) struct OmegaCache {
    nodes: Vec<f64>,
    val: Vec<Complex64>,
    der: Vec<Complex64>,
    nch: usize,
}

impl OmegaCache {
    pub fn build(
        model: &ReducedModel,
        lo: f64,
        hi: f64,
        amplitude: f64,
        tol: f64,
    ) -> Result<Self, ReducedError> {
        let nch = model.nch;
        if nch == 0 {
            return Ok(Self {
                nodes: vec![lo, hi],
                val: vec![],
                der: vec![],
                nch,
            });
        }
        let node = |w: f64| -> Result<(Vec<Complex64>, Vec<Complex64>), ReducedError> {
            let mut v = vec![Complex64::new(0.0, 0.0); nch];
            let mut p = v.clone();
            let mut m = v.clone();
            model.fill_channels(w, amplitude, &mut v)?;
            // central difference for the slope; the attachment quantities are
            // rational in Omega and smooth on the scale of Omega itself
            let d = 1e-5 * w;
            model.fill_channels(w + d, amplitude, &mut p)?;
            model.fill_channels(w - d, amplitude, &mut m)?;
            let der = p.iter().zip(&m).map(|(p, m)| (p - m) / (2.0 * d)).collect();
            Ok((v, der))
        };
        let n0 = 9;
        let mut pts: Vec<(f64, Vec<Complex64>, Vec<Complex64>)> = Vec::new();
        for j in 0..n0 {
            let w = lo + (hi - lo) * j as f64 / (n0 - 1) as f64;
            let (v, d) = node(w)?;
            pts.push((w, v, d));
        }
        let mut scale = vec![0.0f64; nch];
        for (_, v, _) in &pts {
            for (s, x) in scale.iter_mut().zip(v) {
                *s = s.max(x.norm());
            }
        }
        loop {
            let mut out = Vec::with_capacity(2 * pts.len());
            let mut refined = false;
            for k in 0..pts.len() - 1 {
                let (w0, v0, d0) = &pts[k];
                let (w1, v1, d1) = &pts[k + 1];
                out.push(pts[k].clone());
                let wm = 0.5 * (w0 + w1);
                let h = w1 - w0;
                let mut exact = vec![Complex64::new(0.0, 0.0); nch];
                model.fill_channels(wm, amplitude, &mut exact)?;
                let bad = (0..nch).any(|c| {
                    let herm = 0.5 * (v0[c] + v1[c]) + 0.125 * h * (d0[c] - d1[c]);
                    (herm - exact[c]).norm() > tol * scale[c]
                });
                if bad {
                    if pts.len() + out.len() > 200_000 || h < 1e-9 * wm {
                        return Err(ReducedError::BadOption {
                            name: "channel_tol",
                            value: tol,
                            why: "attachment quantities too rough to tabulate to this accuracy",
                        });
                    }
                    let (v, d) = node(wm)?;
                    out.push((wm, v, d));
                    refined = true;
                }
            }
            out.push(pts[pts.len() - 1].clone());
            pts = out;
            if !refined {
                break;
            }
        }
        let mut c = Self {
            nodes: Vec::new(),
            val: Vec::new(),
            der: Vec::new(),
            nch,
        };
        for (w, v, d) in pts {
            c.nodes.push(w);
            c.val.extend(v);
            c.der.extend(d);
        }
        Ok(c)
    }

    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Interpolated channels at `w` (clamped to the tabulated range).
    #[inline]
    pub fn eval(&self, w: f64, out: &mut [Complex64]) {
        if self.nch == 0 {
            return;
        }
        let n = self.nodes.len();
        let w = w.clamp(self.nodes[0], self.nodes[n - 1]);
        let k = self.nodes.partition_point(|&x| x <= w).clamp(1, n - 1) - 1;
        let h = self.nodes[k + 1] - self.nodes[k];
        let t = (w - self.nodes[k]) / h;
        let t2 = t * t;
        let t3 = t2 * t;
        let h00 = 2.0 * t3 - 3.0 * t2 + 1.0;
        let h10 = (t3 - 2.0 * t2 + t) * h;
        let h01 = -2.0 * t3 + 3.0 * t2;
        let h11 = (t3 - t2) * h;
        let (o0, o1) = (k * self.nch, (k + 1) * self.nch);
        for c in 0..self.nch {
            out[c] = self.val[o0 + c] * h00
                + self.der[o0 + c] * h10
                + self.val[o1 + c] * h01
                + self.der[o1 + c] * h11;
        }
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
        opts.check()?;
        let (lo, hi) = {
            let (s, e) = (sweep.omega_start_rad_s, sweep.omega_end_rad_s);
            (s.min(e), s.max(e))
        };
        if let Some(imp) = &self.imposed {
            imp.envelope.check_covers(lo, hi)?;
        }
        let cache = OmegaCache::build(self, lo, hi, sweep.amplitude, opts.channel_tol)?;
        let duration = sweep.duration_s();
        let atol = opts.atol_rel * self.a_scale;
        let tol = Tolerances {
            rtol: opts.rtol,
            atol: [atol; 2],
            h_max: opts.max_step_fraction * duration,
            h_min: 1e-12 * duration,
            max_steps: 10_000_000,
            h0: None,
        };
        let mut ch = vec![Complex64::new(0.0, 0.0); self.nch];
        let rhs = |t: f64, y: &[f64; 2]| -> Result<[f64; 2], ReducedError> {
            let w = sweep.omega_rad_s(t);
            cache.eval(w, &mut ch);
            let fi = self.imposed_at(w)?;
            self.rhs(y, w, &ch, fi)
        };
        let n = opts.output_samples;
        let mut raw: Vec<(f64, [f64; 2])> = Vec::with_capacity(n + 1);
        let mut next = 0usize;
        let sample_t = |j: usize| duration * j as f64 / (n - 1) as f64;
        let mut last_state = (0.0, [a0.re, a0.im]);
        let (stats, stop) = integrate(rhs, 0.0, [a0.re, a0.im], duration, &tol, |d| {
            let t1 = d.t0 + d.h;
            while next < n && sample_t(next) <= t1 * (1.0 + 1e-14) {
                let t = sample_t(next).max(d.t0);
                raw.push((t, d.eval(t)));
                next += 1;
            }
            last_state = (t1, d.eval(t1));
        });
        if raw.is_empty() {
            raw.push((0.0, [a0.re, a0.im]));
        }
        let status = match stop {
            None => SweepStatus::Completed,
            Some(stop) => {
                let t_stop = last_state.0;
                if raw.last().map(|r| r.0 < t_stop).unwrap_or(true) {
                    raw.push(last_state);
                }
                let w = sweep.omega_rad_s(t_stop);
                match stop {
                    Stop::Rhs {
                        error: ReducedError::Table(TableError::AboveRange { max, .. }),
                        ..
                    } => SweepStatus::LeftTableRange {
                        t_s: t_stop,
                        omega_rad_s: w,
                        a: Complex64::new(last_state.1[0], last_state.1[1]).norm(),
                        a_max: max,
                    },
                    Stop::Rhs { error, .. } => return Err(error),
                    Stop::StepTooSmall { h, .. } => SweepStatus::StepSizeTooSmall {
                        t_s: t_stop,
                        omega_rad_s: w,
                        h_s: h,
                    },
                    Stop::MaxSteps { .. } => SweepStatus::MaxSteps {
                        t_s: t_stop,
                        omega_rad_s: w,
                    },
                    Stop::NotFinite { .. } => SweepStatus::NotFinite {
                        t_s: t_stop,
                        omega_rad_s: w,
                    },
                }
            }
        };
        let mut ch = vec![Complex64::new(0.0, 0.0); self.nch];
        let mut samples = Vec::with_capacity(raw.len());
        for (t, y) in raw {
            let w = sweep.omega_rad_s(t);
            cache.eval(w, &mut ch);
            let fi = self.imposed_at(w)?;
            samples.push(self.sample(t, w, Complex64::new(y[0], y[1]), &ch, fi)?);
        }
        Ok(SlowFlowResult {
            sweep: *sweep,
            samples,
            status,
            stats,
            channel_nodes: cache.len(),
        })
    }

    /// Output quantities at one state.
    pub(crate) fn sample(
        &self,
        t: f64,
        w: f64,
        amp: Complex64,
        ch: &[Complex64],
        fi: Complex64,
    ) -> Result<SlowFlowSample, ReducedError> {
        // plain sqrt instead of hypot: no overflow risk at these magnitudes
        let abs = |z: Complex64| z.norm_sqr().sqrt();
        let a = abs(amp);
        let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
        let (loc, p) = self.gather_loc(a, &mut phi)?;
        let f = self.drive_force_with(amp, &phi, ch, fi);
        Ok(SlowFlowSample {
            t_s: t,
            omega_rad_s: w,
            a,
            theta_rad: amp.arg(),
            modal_frequency_rad_s: p.omega_rad_s,
            tip_amplitude_m: a * abs(self.phi1(loc, self.tip)),
            drive_amplitude_m: a * abs(self.phi1(loc, self.drive)),
            force_amplitude_n: abs(f),
            force_phase_rad: f.arg(),
        })
    }
}
