//! The output quantities of the single-mode model at given states, in batch
//! form: modal frequency, fundamental tip and drive-point amplitudes
//! (`eq:ansatz`, fundamental) and the fundamental force at the drive point
//! (`eq:fc1`: `F = -Z_G u_G + T_G u_hat`, plus an imposed force acting there).
//!
//! A sweep evaluates these at a few thousand states after the integration
//! (the envelope output). Walking the generic attachment structure (ports,
//! interface points, channel offsets) for every sample cost more than the
//! arithmetic (~580 instructions per sample, callgrind; half of a sweep). Here
//! the structure is compiled once per batch into flat term lists
//! ([`ForcePlan`]), and each quantity is one short loop over all samples.
use super::fast::cubic;
use super::sweep::OmegaCache;
use super::{ReducedError, ReducedModel, SlowFlowSample};
use num_complex::Complex64;

/// The states and excitation of a batch of output samples.
#[derive(Debug, Clone, Copy)]
pub(crate) struct OutputStates<'a> {
    /// Time of each sample \[s\] (`NaN` for steady states).
    pub t_s: &'a [f64],
    /// Excitation frequency `Omega` of each sample \[rad/s\].
    pub omega_rad_s: &'a [f64],
    /// Complex modal amplitude `A` of each sample \[sqrt(kg) m\].
    pub amplitude: &'a [Complex64],
    /// Attachment channels of the samples (`nch` per sample: per port
    /// `Z_G` row major, then `T_G u_hat`).
    pub channels: Channels<'a>,
    /// Imposed force of each sample at the drive point \[N\] (the imposed
    /// forces there summed); empty without one there.
    pub imposed_n: &'a [Complex64],
}

/// The attachment channels of a batch of output samples.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Channels<'a> {
    /// Each sample's row in turn.
    Rows(&'a [Complex64]),
    /// Interpolated at each sample's `Omega` from the sweep's tabulation
    /// (the numbers of its [`OmegaCache::eval`], without a row stored per
    /// sample).
    Tabulated(&'a OmegaCache),
}

impl OutputStates<'_> {
    fn len(&self) -> usize {
        self.t_s.len()
    }
}

/// Which quantities of a [`SlowFlowSample`] are computed (a sink's
/// [`super::SweepSink::fields`]): the others are `NaN`. Each computed one is
/// the same number either way (the same expressions, element-wise).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SampleFields {
    /// Every quantity.
    #[default]
    All,
    /// The envelope only: `t_s`, `omega_rad_s`, `a`, `amplitude`,
    /// `tip_amplitude_m`, `force_amplitude_n`, `force_n`; no
    /// `modal_frequency_rad_s`, no `drive_amplitude_m` (figures of merit of a
    /// sweep read the tip and force amplitudes only).
    Envelope,
}

/// `eq:fc1` at the drive point as flat term lists: `F = sum_t ch[t] - A sum_z
/// ch[z] phi[p]` over the rows of all attachments acting at the drive point.
#[derive(Debug)]
struct ForcePlan {
    /// Table points whose fundamental shapes are needed: tip, drive, then the
    /// interface points of the attachments acting at the drive point.
    points: Vec<usize>,
    /// Channels `T_G u_hat` of the rows at the drive point.
    t_channels: Vec<usize>,
    /// `(channel of Z_G[r, c], index in points of interface point c)`.
    z_terms: Vec<(usize, usize)>,
}

impl ReducedModel {
    fn force_plan(&self) -> ForcePlan {
        let mut points = vec![self.tip, self.drive];
        let mut index = |pt: usize| match points.iter().position(|&p| p == pt) {
            Some(j) => j,
            None => {
                points.push(pt);
                points.len() - 1
            }
        };
        let (mut t_channels, mut z_terms) = (Vec::new(), Vec::new());
        for port in &self.ports {
            let nc = port.ncon();
            for (r, &pt) in port.points.iter().enumerate() {
                if pt != self.drive {
                    continue;
                }
                t_channels.push(port.offset + nc * nc + r);
                for (c, &pc) in port.points.iter().enumerate() {
                    z_terms.push((port.offset + r * nc + c, index(pc)));
                }
            }
        }
        ForcePlan {
            points,
            t_channels,
            z_terms,
        }
    }

    /// The output samples at the states of `s` (every quantity).
    pub(crate) fn output_samples(
        &self,
        s: &OutputStates,
    ) -> Result<Vec<SlowFlowSample>, ReducedError> {
        self.output_fields(s, SampleFields::All)
    }

    /// The output samples at the states of `s`, the quantities of `fields`
    /// computed (the others `NaN`).
    pub(crate) fn output_fields(
        &self,
        s: &OutputStates,
        fields: SampleFields,
    ) -> Result<Vec<SlowFlowSample>, ReducedError> {
        let mut out = Vec::with_capacity(s.len());
        self.output_fields_into(s, fields, &mut OutputScratch::default(), &mut out)?;
        Ok(out)
    }

    /// [`Self::output_fields`] handed to `out` in sample order (appended to a
    /// `Vec`, or folded as they are computed: [`SampleOut`]), with the work
    /// space of `scratch` (a sweep keeps both across its batches: no
    /// allocation per batch). On an error a `Vec` is left as it was.
    ///
    /// One pass over the samples: table location, channels (from the
    /// sweep's tabulation if [`Channels::Tabulated`]), `eq:fc1`, the
    /// amplitudes. The error is the one of checking all samples' table
    /// locations first (in sample order), then their detuned frequencies,
    /// then the residual displacements ([`Self::first_output_error`]). Each
    /// quantity is the same expression as before, element by element (the
    /// same operations in the same order): the numbers do not change by a
    /// bit.
    // (inlined, and the pass too: a fold's state stays in registers over
    // the samples of a batch)
    #[inline(always)]
    pub(crate) fn output_fields_into<O: SampleOut>(
        &self,
        s: &OutputStates,
        fields: SampleFields,
        scratch: &mut OutputScratch,
        out: &mut O,
    ) -> Result<(), ReducedError> {
        let nch = self.nch;
        debug_assert!(
            s.omega_rad_s.len() == s.len()
                && s.amplitude.len() == s.len()
                && match s.channels {
                    Channels::Rows(r) => r.len() == nch * s.len(),
                    Channels::Tabulated(c) => c.nch() == nch,
                }
                && (s.imposed_n.is_empty() || s.imposed_n.len() == s.len())
        );
        // one pass per kind of channel source (each compiled for its own),
        // and for one interface point at the drive point without residual
        // modes or imposed force (`eq:fc1` with one term: no term lists)
        let one = match self.single_point() {
            Some(sp) if sp.pt == self.drive && self.residual.is_none() => Some(sp.z),
            _ => None,
        };
        match s.channels {
            Channels::Rows(rows) => {
                let ch = FromRows(rows, nch);
                match one {
                    Some(z) => self.output_pass::<_, _, true>(s, fields, z, scratch, out, ch),
                    None => self.output_pass::<_, _, false>(s, fields, 0, scratch, out, ch),
                }
            }
            Channels::Tabulated(cache) => {
                let ch = FromCache(cache);
                match one {
                    Some(z) => self.output_pass::<_, _, true>(s, fields, z, scratch, out, ch),
                    None => self.output_pass::<_, _, false>(s, fields, 0, scratch, out, ch),
                }
            }
        }
    }

    /// [`Self::output_fields_into`] with the channels of sample `i` at
    /// `Omega` given by `channels.at(i, Omega)`; `ONE`: the model has one
    /// interface point, at the drive point, its `Z_G` channel `z_one` (the
    /// force plan's one term of each list), no residual modes, no imposed
    /// force.
    #[inline(always)]
    fn output_pass<S: ChannelSource, O: SampleOut, const ONE: bool>(
        &self,
        s: &OutputStates,
        fields: SampleFields,
        z_one: usize,
        scratch: &mut OutputScratch,
        out: &mut O,
        channels: S,
    ) -> Result<(), ReducedError> {
        let all = !O::ENVELOPE_ONLY && fields == SampleFields::All;
        let OutputScratch { plan, phi, row } = scratch;
        let plan = &*plan.get_or_insert_with(|| self.force_plan());
        phi.clear();
        phi.resize(plan.points.len(), Complex64::new(0.0, 0.0));
        row.clear();
        row.resize(self.nch, Complex64::new(0.0, 0.0));
        let base = out.mark(s.len());
        let zero = Complex64::new(0.0, 0.0);
        let detuned = self.frequency_error.eps != 0.0 || self.frequency_error.offset_rad_s != 0.0;
        // (iterators rather than indices: no bounds check per sample)
        let states = s.t_s.iter().zip(s.omega_rad_s).zip(s.amplitude);
        for (i, ((&t_s, &omega_rad_s), &amp)) in states.enumerate() {
            let a = modulus(&amp);
            let fail = |out: &mut O, stage, e| {
                out.reset(base);
                Err(self.first_output_error(s, all, i, stage, e))
            };
            let loc = match self.fast.locate(a) {
                Ok(loc) => loc,
                Err(e) => return fail(out, 0, e.into()),
            };
            let mut omega = f64::NAN;
            if all {
                omega = self.fast.value(loc, 0);
                if detuned {
                    omega = match self.detuned_omega(omega, a) {
                        Ok(w) => w,
                        Err(e) => return fail(out, 1, e),
                    };
                }
            }
            // the shapes at the plan's points: tip, drive, then the others
            let (tip, drive) = (
                self.fast.shape(loc, self.tip),
                self.fast.shape(loc, self.drive),
            );
            let ch = channels.at(i, omega_rad_s);
            // eq:fc1, term by term
            let mut f = zero;
            let mut z = zero;
            if ONE {
                // the plan's terms: T_G u_hat, then Z_G at the drive point
                f += ch.channel(z_one + 1);
                z += ch.channel(z_one) * drive;
            } else {
                if let [p0, p1, others @ ..] = &mut phi[..] {
                    (*p0, *p1) = (tip, drive);
                    let shapes = self.fast.shapes(loc.k);
                    for (p, &pt) in others.iter_mut().zip(&plan.points[2..]) {
                        *p = cubic(&shapes[pt], loc.t);
                    }
                }
                f = s.imposed_n.get(i).copied().unwrap_or(zero);
                for &t in &plan.t_channels {
                    f += ch.channel(t);
                }
                for &(c, p) in &plan.z_terms {
                    z += ch.channel(c) * phi[p];
                }
            }
            f -= z * amp;
            let (tip_m, drive_m) = if !ONE && self.residual.is_some() {
                // the residual modes' displacement G F added (super::residual)
                let row = ch.row(row);
                let [dt, dd] = match self.residual_at(omega_rad_s, row, loc, amp) {
                    Ok(d) => d,
                    Err(e) => return fail(out, 2, e),
                };
                ((amp * tip + dt).norm(), (amp * drive + dd).norm())
            } else if all {
                (a * modulus(&tip), a * modulus(&drive))
            } else {
                (a * modulus(&tip), f64::NAN)
            };
            out.put(&SlowFlowSample {
                t_s,
                omega_rad_s,
                a,
                amplitude: amp,
                modal_frequency_rad_s: omega,
                tip_amplitude_m: tip_m,
                drive_amplitude_m: if all { drive_m } else { f64::NAN },
                force_amplitude_n: modulus(&f),
                force_n: f,
            });
        }
        Ok(())
    }

    /// The error of the output samples of `s` when sample `i` is the first
    /// to fail check `stage` (0: table location, 1: detuned frequency, 2:
    /// residual displacement) with `error`: the checks run over all samples
    /// one after the other (every location, then every detuned frequency,
    /// then the samples), so a later sample's failure of an earlier check
    /// comes first.
    #[cold]
    #[inline(never)]
    fn first_output_error(
        &self,
        s: &OutputStates,
        all: bool,
        i: usize,
        stage: u8,
        error: ReducedError,
    ) -> ReducedError {
        let later = || s.amplitude[i + 1..].iter().map(modulus);
        if stage >= 1 {
            for a in later() {
                if let Err(e) = self.fast.locate(a) {
                    return e.into();
                }
            }
        }
        let detuned = self.frequency_error.eps != 0.0 || self.frequency_error.offset_rad_s != 0.0;
        if stage >= 2 && all && detuned {
            for a in later() {
                // located above
                let Ok(loc) = self.fast.locate(a) else {
                    continue;
                };
                if let Err(e) = self.detuned_omega(self.fast.value(loc, 0), a) {
                    return e;
                }
            }
        }
        error
    }
}

/// Where the output pass hands each sample (called once per sample, in
/// order, and inlined: a sink that reads a few of the quantities leaves the
/// others uncomputed and unstored).
pub(crate) trait SampleOut {
    /// Reads the envelope's quantities only ([`SampleFields::Envelope`]
    /// whatever the pass is asked for: known when the pass is compiled).
    const ENVELOPE_ONLY: bool = false;
    /// Before a pass of `n` samples: the mark to [`Self::reset`] to.
    fn mark(&mut self, n: usize) -> usize;
    /// After an error of the pass: back to `mark` where possible.
    fn reset(&mut self, mark: usize);
    /// The next sample.
    fn put(&mut self, s: &SlowFlowSample);
}

/// The samples stored (the envelope, the sink's batch).
impl SampleOut for Vec<SlowFlowSample> {
    #[inline(always)]
    fn mark(&mut self, n: usize) -> usize {
        self.reserve(n);
        self.len()
    }
    fn reset(&mut self, mark: usize) {
        self.truncate(mark);
    }
    #[inline(always)]
    fn put(&mut self, s: &SlowFlowSample) {
        self.push(*s);
    }
}

/// The figures' quantities `(Omega, tip amplitude, force amplitude)` of
/// each sample to a fold (`f`), nothing stored; a sample handed over is
/// not taken back on an error.
pub(crate) struct FoldOut<F>(pub F);

impl<F: FnMut(f64, f64, f64)> SampleOut for FoldOut<F> {
    const ENVELOPE_ONLY: bool = true;
    #[inline(always)]
    fn mark(&mut self, _: usize) -> usize {
        0
    }
    fn reset(&mut self, _: usize) {}
    #[inline(always)]
    fn put(&mut self, s: &SlowFlowSample) {
        (self.0)(s.omega_rad_s, s.tip_amplitude_m, s.force_amplitude_n)
    }
}

/// The attachment channels of one output sample.
trait SampleChannels {
    /// Channel `c`.
    fn channel(&self, c: usize) -> Complex64;
    /// All channels, in `buf` if they are not stored (`nch` long).
    fn row<'b>(&'b self, buf: &'b mut [Complex64]) -> &'b [Complex64];
}

/// Where the channels of the output samples come from.
trait ChannelSource {
    /// The channels of one sample.
    type C: SampleChannels;
    /// The channels of sample `i` at `Omega`.
    fn at(&self, i: usize, omega: f64) -> Self::C;
}

/// Each sample's stored row (`nch` channels) in turn.
#[derive(Clone, Copy)]
struct FromRows<'a>(&'a [Complex64], usize);

impl<'a> ChannelSource for FromRows<'a> {
    type C = RowValues<'a>;
    #[inline(always)]
    fn at(&self, i: usize, _: f64) -> RowValues<'a> {
        RowValues(&self.0[i * self.1..(i + 1) * self.1])
    }
}

/// Interpolated at each sample's `Omega` from the sweep's tabulation.
#[derive(Clone, Copy)]
struct FromCache<'a>(&'a OmegaCache);

impl<'a> ChannelSource for FromCache<'a> {
    type C = RowCubics<'a>;
    #[inline(always)]
    fn at(&self, _: usize, omega: f64) -> RowCubics<'a> {
        let (c, t) = self.0.segment(omega);
        RowCubics(c, t)
    }
}

/// A stored row of channels.
struct RowValues<'a>(&'a [Complex64]);

impl SampleChannels for RowValues<'_> {
    #[inline(always)]
    fn channel(&self, c: usize) -> Complex64 {
        self.0[c]
    }
    fn row<'b>(&'b self, _: &'b mut [Complex64]) -> &'b [Complex64] {
        self.0
    }
}

/// The channels' cubics on a segment of the sweep's tabulation and the
/// local coordinate: each channel evaluated where it is needed (the numbers
/// of [`OmegaCache::eval`]).
struct RowCubics<'a>(&'a [[Complex64; 4]], f64);

impl SampleChannels for RowCubics<'_> {
    #[inline(always)]
    fn channel(&self, c: usize) -> Complex64 {
        cubic(&self.0[c], self.1)
    }
    fn row<'b>(&'b self, buf: &'b mut [Complex64]) -> &'b [Complex64] {
        for (o, c) in buf.iter_mut().zip(self.0) {
            *o = cubic(c, self.1);
        }
        buf
    }
}

/// `|z|` by a plain sqrt (vectorizes; hypot's overflow guard is not needed).
#[inline(always)]
fn modulus(z: &Complex64) -> f64 {
    (z.re * z.re + z.im * z.im).sqrt()
}

impl ReducedModel {
    /// The residual modes' displacement `[tip, drive]` of one output sample
    /// (channel row `row` at `Omega`, table location `loc`, amplitude `amp`).
    fn residual_at(
        &self,
        omega_rad_s: f64,
        row: &[Complex64],
        loc: super::fast::Loc,
        amp: Complex64,
    ) -> Result<[Complex64; 2], ReducedError> {
        let mut phi_g = [Complex64::new(0.0, 0.0); super::MAX_PHI];
        let points: &[usize] = self.ports.first().map_or(&[], |p| &p.points);
        for (g, &pt) in phi_g.iter_mut().zip(points) {
            *g = self.phi1(loc, pt);
        }
        let fi = self.imposed_at(omega_rad_s)?;
        Ok(self.residual_displacements(
            omega_rad_s,
            row,
            &phi_g[..points.len()],
            amp,
            fi,
            [self.tip, self.drive],
        ))
    }
}

/// Work space of [`ReducedModel::output_fields_into`], kept by a sweep
/// across its output batches (one model per sweep: the force plan is the
/// model's).
#[derive(Debug, Default)]
pub(crate) struct OutputScratch {
    plan: Option<ForcePlan>,
    /// Fundamental shapes at the plan's points, of the current sample.
    phi: Vec<Complex64>,
    /// The attachment channels of the current sample ([`Channels::Tabulated`]).
    row: Vec<Complex64>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nma::{ModalTable, PointShape, MODAL_TABLE_FORMAT, MODAL_TABLE_VERSION};
    use crate::reduced::{ForceEnvelope, FrequencyError, InterfaceModel};
    use nalgebra::DMatrix;
    use std::sync::Arc;

    fn c(re: f64, im: f64) -> Complex64 {
        Complex64::new(re, im)
    }

    /// A two-point attachment with frequency-independent `Z_G`, `T_G`.
    #[derive(Debug)]
    struct Fixed {
        points: [&'static str; 2],
        z: [[Complex64; 2]; 2],
        t: [Complex64; 2],
    }

    impl InterfaceModel for Fixed {
        fn name(&self) -> &str {
            "fixed"
        }
        fn interface_points(&self) -> Vec<String> {
            self.points.iter().map(|p| p.to_string()).collect()
        }
        fn ninput(&self) -> usize {
            1
        }
        fn condense(
            &self,
            _omega_rad_s: f64,
        ) -> Result<(DMatrix<Complex64>, DMatrix<Complex64>), crate::reduced::AttachmentModelError>
        {
            Ok((
                DMatrix::from_fn(2, 2, |r, k| self.z[r][k]),
                DMatrix::from_fn(2, 1, |r, _| self.t[r]),
            ))
        }
    }

    /// A hardening table with amplitude-dependent complex shapes at three points.
    fn table() -> ModalTable {
        let a: Vec<f64> = (0..20).map(|j| 1e-5 * 1.45f64.powi(j)).collect();
        let shape = |f: &dyn Fn(f64) -> (f64, f64)| PointShape {
            name: String::new(),
            re: a.iter().map(|&a| vec![0.0, f(a).0]).collect(),
            im: a.iter().map(|&a| vec![0.0, f(a).1]).collect(),
        };
        let named = |name: &str, mut p: PointShape| {
            p.name = name.into();
            p
        };
        ModalTable {
            format: MODAL_TABLE_FORMAT.into(),
            version: MODAL_TABLE_VERSION,
            description: "test".into(),
            harmonics: 1,
            amplitude: a.clone(),
            omega_rad_s: a.iter().map(|&a| 356.0 + 4e5 * a).collect(),
            damping_ratio: a.iter().map(|&a| 0.004 + 3.0 * a).collect(),
            points: vec![
                named("tip", shape(&|a| (1.5 + 40.0 * a, -20.0 * a))),
                named(
                    "drive",
                    shape(&|a| (1.0 - 30.0 * a, 0.05 * (a * 1e3).sin())),
                ),
                named("other", shape(&|a| (0.4 + 10.0 * a * a, 0.01))),
            ],
            coordinates: vec![],
            truncated_at_fold: None,
            accuracy: None,
            linear_modes: None,
        }
    }

    #[test]
    fn batch_output_equals_eq_fc1_written_out() {
        let t = table();
        let two_point = Fixed {
            points: ["drive", "other"],
            z: [[c(2e4, 30.0), c(-5e3, 4.0)], [c(-5e3, 4.0), c(9e3, 1.0)]],
            t: [c(3.0, -1.0), c(0.5, 0.2)],
        };
        let at_drive = Fixed {
            points: ["tip", "drive"],
            z: [[c(1e3, 0.0), c(7e3, 2.0)], [c(6e3, -3.0), c(4e3, 8.0)]],
            t: [c(0.0, 0.0), c(-2.0, 0.5)],
        };
        let away = Fixed {
            points: ["tip", "other"],
            z: [[c(1e5, 0.0), c(1e5, 0.0)], [c(1e5, 0.0), c(1e5, 0.0)]],
            t: [c(9.0, 9.0), c(9.0, 9.0)],
        };
        let imposed = ForceEnvelope::new(&[100.0, 900.0], &[0.7, 0.7], &[0.3, 0.3]).unwrap();
        let u = 1.7;
        let m = ReducedModel::new(&t, "tip", "drive")
            .unwrap()
            .with_attachment(Arc::new(two_point), &[c(1.0, 0.0)])
            .unwrap()
            .with_attachment(Arc::new(away), &[c(1.0, 0.0)])
            .unwrap()
            .with_attachment(Arc::new(at_drive), &[c(0.0, 2.0)])
            .unwrap()
            .with_imposed_force("drive", imposed)
            .unwrap()
            .with_frequency_error(FrequencyError {
                eps: 0.05,
                offset_rad_s: -3.0,
            })
            .unwrap();
        // states scattered over the table (and below it, where it is held)
        let n = 40;
        let amax = *t.amplitude.last().unwrap();
        let amp: Vec<Complex64> = (0..n)
            .map(|i| {
                Complex64::from_polar(amax * ((i * 7 % n) as f64 / n as f64).powi(2), i as f64)
            })
            .collect();
        let w: Vec<f64> = (0..n).map(|i| 300.0 + 5.0 * i as f64).collect();
        let mut channels = Vec::new();
        let mut fi = Vec::new();
        for &w in &w {
            let mut ch = vec![c(0.0, 0.0); m.nch];
            m.fill_channels(w, u, &mut ch).unwrap();
            channels.extend(ch);
            fi.push(m.drive_imposed(&m.imposed_at(w).unwrap()));
        }
        let ts: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let got = m
            .output_samples(&OutputStates {
                t_s: &ts,
                omega_rad_s: &w,
                amplitude: &amp,
                channels: Channels::Rows(&channels),
                imposed_n: &fi,
            })
            .unwrap();
        let ip = t.interpolator().unwrap();
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs().max(1e-300);
        for i in 0..n {
            let (s, a) = (&got[i], amp[i].norm());
            let phi = |pt: usize| ip.shape(pt, 1, a).unwrap();
            // eq:fc1 at the drive point (table point 1): rows at "drive" of
            // the first and third attachments, plus the imposed force
            let (p_tip, p_drive, p_other) = (phi(0), phi(1), phi(2));
            let f = c(3.0, -1.0) * u - (c(2e4, 30.0) * p_drive + c(-5e3, 4.0) * p_other) * amp[i]
                + c(-2.0, 0.5) * c(0.0, 2.0) * u
                - (c(6e3, -3.0) * p_tip + c(4e3, 8.0) * p_drive) * amp[i]
                + Complex64::from_polar(0.7, 0.3);
            assert!(
                (s.force_n - f).norm() < 1e-12 * f.norm(),
                "{i}: {} vs {f}",
                s.force_n
            );
            assert!(close(s.force_amplitude_n, f.norm()));
            assert!(close(s.tip_amplitude_m, a * p_tip.norm()));
            assert!(close(s.drive_amplitude_m, a * p_drive.norm()));
            let w_modal = 1.05 * ip.eval(a).unwrap().omega_rad_s - 3.0;
            assert!(close(s.modal_frequency_rad_s, w_modal));
            assert!(close(s.a, a));
            assert_eq!((s.t_s, s.omega_rad_s, s.amplitude), (ts[i], w[i], amp[i]));
        }
        // above the table: the table's error, not an extrapolation
        let above = [Complex64::new(1.01 * amax, 0.0)];
        let err = m.output_samples(&OutputStates {
            t_s: &ts[..1],
            omega_rad_s: &w[..1],
            amplitude: &above,
            channels: Channels::Rows(&channels[..m.nch]),
            imposed_n: &fi[..1],
        });
        assert!(matches!(
            err,
            Err(ReducedError::Table(
                crate::table::TableError::AboveRange { .. }
            ))
        ));
    }
}
