//! Figures of merit of one sweep, folded sample by sample.
//!
//! The one definition of the figures of merit: `summary.json`
//! ([`MethodResult::new`]) and the study use them. The
//! peak is the first largest finite tip amplitude and the excitation
//! frequency there; the force extremes are over the finite force amplitudes;
//! the jump-down ([`jump_down`]) is the steepest drop of the
//! tip envelope over `w = max(n / 400, 1)` samples at or after the last
//! largest finite tip amplitude, at the midpoint of that window, none for
//! fewer than 8 samples. [`Figures::fold`] (by [`Fold`], which a sweep feeds
//! as it integrates) evaluates the same expressions in
//! the same order on the same samples, keeping only the last `w + 1` of them
//! (a ring), so the study's numbers are bit-identical to `host run`'s without
//! an envelope being stored: when a new maximum arrives the steepest-drop
//! search restarts there, which is exactly the batch search from the final
//! maximum.
//!
//! [`MethodResult::new`]: crate::results::MethodResult::new
use serde::Serialize;

/// Excitation frequency of the jump-down of the tip envelope `y(x)`
/// ([`Figures::jump_down_omega_rad_s`] of a sweep), `None` for fewer than 8 samples.
pub fn jump_down(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len().min(y.len());
    Figures::fold((0..n).map(|i| (x[i], y[i], f64::NAN)), n, true).jump_down_omega_rad_s
}

/// The figures of merit of one sweep (the `results.csv` columns).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Figures {
    pub peak_tip_amplitude_m: Option<f64>,
    pub peak_omega_rad_s: Option<f64>,
    pub jump_down_omega_rad_s: Option<f64>,
    pub min_force_amplitude_n: Option<f64>,
    pub max_force_amplitude_n: Option<f64>,
}

impl Figures {
    /// `1 - min/max` of the force envelope (the force drop over the sweep).
    pub fn force_drop(&self) -> Option<f64> {
        match (self.min_force_amplitude_n, self.max_force_amplitude_n) {
            (Some(a), Some(b)) if b > 0.0 => Some(1.0 - a / b),
            _ => None,
        }
    }

    /// Fold `n` samples `(omega [rad/s], tip amplitude [m], force amplitude
    /// [N])` in sweep order; `is_sweep`: a transient sweep (it has a jump-down).
    pub fn fold(
        samples: impl IntoIterator<Item = (f64, f64, f64)>,
        n: usize,
        is_sweep: bool,
    ) -> Self {
        let mut fold = Fold::new(n);
        for (x, y, f) in samples {
            fold.push(x, y, f);
        }
        debug_assert_eq!(fold.count(), n, "Figures::fold: n must be the sample count");
        fold.finish(is_sweep)
    }

    /// The figures of a slow-flow sweep (its output samples in order).
    pub fn of_slow_flow(res: &nlmode::reduced::SlowFlowResult) -> Self {
        let s = &res.samples;
        Self::fold(
            s.iter()
                .map(|x| (x.omega_rad_s, x.tip_amplitude_m, x.force_amplitude_n)),
            s.len(),
            true,
        )
    }

    /// The figures of an envelope (e.g. the reference's windowed one).
    pub fn of_envelope(e: &nlmode::envelope::Envelope, is_sweep: bool) -> Self {
        let n = e.omega_rad_s.len();
        Self::fold(
            (0..n).map(|i| {
                (
                    e.omega_rad_s[i],
                    e.tip_amplitude_m[i],
                    e.force_amplitude_n[i],
                )
            }),
            n,
            is_sweep,
        )
    }
}

/// [`Figures::fold`] one sample at a time: the figures of a sweep of `n`
/// samples without the samples stored. The jump-down window `w = max(n /
/// 400, 1)` is fixed by the count announced to [`Fold::new`]; a sweep that
/// ends with another count (it stopped early) is folded exactly only if its
/// window is the same ([`Fold::is_exact`]).
#[derive(Debug, Clone)]
pub struct Fold {
    /// The last `w + 1` samples (omega, tip); sample `j` in slot `j % (w + 1)`.
    ring: Vec<(f64, f64)>,
    state: FoldState,
}

/// The figures so far of a [`Fold`] (all but its ring): a copy lives in
/// registers while a batch is folded ([`Fold`]'s `EnvelopeFold::fold`).
#[derive(Debug, Clone, Copy)]
struct FoldState {
    w: usize,
    /// Slot of the next sample.
    slot: usize,
    peak: (f64, f64),
    fmin: f64,
    fmax: f64,
    /// Last largest finite tip amplitude (index, value) and the steepest drop after it.
    top: Option<(usize, f64)>,
    best: Option<(f64, f64)>,
    count: usize,
}

impl Fold {
    /// A fold of a sweep of `n` output samples.
    pub fn new(n: usize) -> Self {
        let w = (n / 400).max(1);
        Self {
            ring: vec![(0.0, 0.0); w + 1],
            state: FoldState {
                w,
                slot: 0,
                peak: (f64::NAN, f64::NAN),
                fmin: f64::INFINITY,
                fmax: f64::NEG_INFINITY,
                top: None,
                best: None,
                count: 0,
            },
        }
    }

    /// The next sample `(omega [rad/s], tip amplitude [m], force amplitude [N])`.
    #[inline]
    pub fn push(&mut self, x: f64, y: f64, f: f64) {
        self.state.push(&mut self.ring, x, y, f);
    }

    /// Samples folded.
    pub fn count(&self) -> usize {
        self.state.count
    }

    /// Whether the samples folded so far give the figures of [`Figures::fold`]
    /// of exactly these samples (the window of their count is the one used).
    pub fn is_exact(&self) -> bool {
        (self.state.count / 400).max(1) == self.state.w
    }

    /// The figures of the samples folded; `is_sweep`: a transient sweep.
    pub fn finish(&self, is_sweep: bool) -> Figures {
        let st = &self.state;
        let finite = |v: f64| v.is_finite().then_some(v);
        Figures {
            peak_tip_amplitude_m: finite(st.peak.0),
            peak_omega_rad_s: finite(st.peak.1),
            jump_down_omega_rad_s: if is_sweep && st.count >= 8 {
                st.best.map(|(_, x)| x)
            } else {
                None
            },
            min_force_amplitude_n: finite(st.fmin),
            max_force_amplitude_n: finite(st.fmax),
        }
    }
}

impl FoldState {
    /// [`Fold::push`] with the fold's ring (`w + 1` slots).
    #[inline(always)]
    // `!(a <= b)` on purpose: true where a comparison involves NaN
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn push(&mut self, ring: &mut [(f64, f64)], x: f64, y: f64, f: f64) {
        let (j, w) = (self.count, self.w);
        self.count += 1;
        if y.is_finite() && !(y <= self.peak.0) {
            self.peak = (y, x);
        }
        // (`fmin.min(f)`, `fmax.max(f)` as compiled: the extremes are never
        // NaN, and a tie keeps the one held)
        if f.is_finite() {
            if f < self.fmin {
                self.fmin = f;
            }
            if f > self.fmax {
                self.fmax = f;
            }
        }
        // slot of sample j - w (= (j + 1) % (w + 1)), read after j is written
        let slot = self.slot;
        let older = if slot == w { 0 } else { slot + 1 };
        ring[slot] = (x, y);
        self.slot = older;
        // `y >= v` in the total order: decided by `>` unless the two are
        // equal as numbers (then by `total_cmp`: -0 < +0)
        if y.is_finite()
            && self
                .top
                .is_none_or(|(_, v)| y > v || (y == v && y.total_cmp(&v).is_ge()))
        {
            self.top = Some((j, y));
            self.best = None;
        }
        // the window (i, i + w) = (j - w, j), for i at or after the maximum
        if let Some((ipk, _)) = self.top {
            if j >= w && j - w >= ipk {
                let (xi, yi) = ring[older];
                let dx = x - xi;
                if dx != 0.0 {
                    let slope = (y - yi) / dx.abs();
                    if self.best.is_none_or(|(s, _)| slope < s) {
                        self.best = Some((slope, 0.5 * (xi + x)));
                    }
                }
            }
        }
    }
}

/// A slow-flow sweep folded as it integrates
/// ([`nlmode::reduced::ReducedModel::simulate_sweep_folded`]): each sample's
/// `Omega`, tip and force amplitudes computed as they are folded.
impl nlmode::reduced::EnvelopeFold for Fold {
    #[inline(always)]
    fn fold<B: nlmode::reduced::EnvelopeBatch>(
        &mut self,
        batch: B,
    ) -> Result<(), nlmode::reduced::ReducedError> {
        // the state in a local (registers) over the batch, the ring apart
        let mut st = self.state;
        let ring = &mut self.ring[..];
        let r = batch.each(|x, y, f| st.push(ring, x, y, f));
        self.state = st;
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nlmode::envelope::Envelope;

    /// The figures by their definition, searched over the whole envelope
    /// (the independent check of [`Fold`]'s one-pass search).
    // `!(a <= b)` on purpose: true where a comparison involves NaN
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn batch(e: &Envelope, is_sweep: bool) -> Figures {
        let finite = |v: f64| v.is_finite().then_some(v);
        let (x, y) = (&e.omega_rad_s, &e.tip_amplitude_m);
        let mut peak = (f64::NAN, f64::NAN);
        for (i, &t) in y.iter().enumerate() {
            if t.is_finite() && !(t <= peak.0) {
                peak = (t, x[i]);
            }
        }
        let f = e
            .force_amplitude_n
            .iter()
            .cloned()
            .filter(|v| v.is_finite());
        let fmin = f.clone().fold(f64::INFINITY, f64::min);
        let fmax = f.fold(f64::NEG_INFINITY, f64::max);
        let n = x.len();
        let jump = (|| {
            if !is_sweep || n < 8 {
                return None;
            }
            let ipk = (0..n)
                .filter(|&i| y[i].is_finite())
                .max_by(|&a, &b| y[a].total_cmp(&y[b]))?;
            let w = (n / 400).max(1);
            let mut best: Option<(f64, f64)> = None;
            for i in ipk..n.saturating_sub(w) {
                let dx = x[i + w] - x[i];
                if dx == 0.0 {
                    continue;
                }
                let slope = (y[i + w] - y[i]) / dx.abs();
                if best.is_none_or(|(s, _)| slope < s) {
                    best = Some((slope, 0.5 * (x[i] + x[i + w])));
                }
            }
            best.map(|(_, xm)| xm)
        })();
        Figures {
            peak_tip_amplitude_m: finite(peak.0),
            peak_omega_rad_s: finite(peak.1),
            jump_down_omega_rad_s: jump,
            min_force_amplitude_n: finite(fmin),
            max_force_amplitude_n: finite(fmax),
        }
    }

    /// The fold equals the summary of `host run` on envelopes with ties,
    /// NaN, a peak at the end, short and long lengths.
    #[test]
    fn fold_equals_the_summary_definitions() {
        let mut cases: Vec<Vec<(f64, f64, f64)>> = Vec::new();
        for n in [1usize, 5, 8, 9, 399, 400, 801, 2001, 2345] {
            let mut v: Vec<(f64, f64, f64)> = (0..n)
                .map(|i| {
                    let x = 300.0 + 0.1 * i as f64;
                    let y = (1.0 + (i as f64 * 0.37).sin())
                        * (-(i as f64 - n as f64 * 0.6).powi(2) / (n as f64 + 1.0)).exp();
                    (x, y, 2.0 + (i as f64 * 0.11).cos())
                })
                .collect();
            cases.push(v.clone());
            if n > 10 {
                v[3].1 = f64::NAN;
                v[n / 2].1 = 5.0;
                v[n / 2 + 3].1 = 5.0; // a tie: first for the peak, last for the jump
                v[n - 2].2 = f64::INFINITY;
                v[n - 1].1 = f64::NAN; // a non-finite sample inside the last window
                cases.push(v.clone());
                let mut rising = v.clone();
                rising[n - 1].1 = 9.0;
                cases.push(rising);
            }
        }
        cases.push(vec![(1.0, f64::NAN, f64::NAN); 20]);
        // signed zeros: the last largest tip amplitude in the total order
        // (+0 above -0) starts the jump-down search
        cases.push(
            (0..20)
                .map(|i| {
                    let y = if i % 3 == 0 { -0.0 } else { 0.0 };
                    (300.0 + i as f64, y, 1.0)
                })
                .collect(),
        );
        cases.push(
            (0..20)
                .map(|i| (300.0 + i as f64, if i < 15 { 0.0 } else { -0.0 }, 1.0))
                .collect(),
        );
        for (k, c) in cases.iter().enumerate() {
            let env = Envelope {
                omega_rad_s: c.iter().map(|s| s.0).collect(),
                tip_amplitude_m: c.iter().map(|s| s.1).collect(),
                force_amplitude_n: c.iter().map(|s| s.2).collect(),
                ..Default::default()
            };
            for is_sweep in [true, false] {
                let want = batch(&env, is_sweep);
                let got = Figures::of_envelope(&env, is_sweep);
                let same =
                    |a: Option<f64>, b: Option<f64>| a.map(f64::to_bits) == b.map(f64::to_bits);
                assert!(
                    same(got.peak_tip_amplitude_m, want.peak_tip_amplitude_m)
                        && same(got.peak_omega_rad_s, want.peak_omega_rad_s)
                        && same(got.jump_down_omega_rad_s, want.jump_down_omega_rad_s)
                        && same(got.min_force_amplitude_n, want.min_force_amplitude_n)
                        && same(got.max_force_amplitude_n, want.max_force_amplitude_n),
                    "case {k} (n = {}, sweep {is_sweep}): {got:?} vs {want:?}",
                    c.len()
                );
            }
        }
    }
}
