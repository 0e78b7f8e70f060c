//! `Z_G`, `T_G u_hat` of the attachments tabulated over a sweep's frequency
//! range (the slow flow's channels: [`OmegaCache`]).
use super::fast::{cubic, Breaks};
use super::{ReducedError, ReducedModel};
use num_complex::Complex64;

/// `Z_G`, `T_G u_hat` of all attachments tabulated over `[lo, hi]` with cubic
/// Hermite interpolation: the attachment models (matrix algebra with heap
/// allocation) are evaluated once per node, not in the integrator's hot loop.
/// Nodes are bisected until the interpolation error at every interval
/// midpoint is below `tol` times the channel's magnitude.
///
/// Stored per segment in power form in the local coordinate `t in [0, 1]`,
/// with the segment search of [`Breaks`] (hint from the previous lookup).
#[derive(Debug, Clone)]
pub(crate) struct OmegaCache {
    nodes: Breaks,
    /// `c[k * nch + ch]`: cubic in `t` of channel `ch` on segment `k`.
    c: Vec<[Complex64; 4]>,
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
        Self::tabulate(
            model.nch,
            lo,
            hi,
            tol,
            |w, v| model.fill_channels(w, amplitude, v),
            |w, v, d| model.fill_channels_with_derivative(w, amplitude, v, d),
        )
    }

    /// The tabulation of [`Self::build`] for any `nch` channels: `value(w, v)`
    /// fills the channels at `w`, `value_and_derivative(w, v, d)` also their
    /// derivatives with respect to `w`.
    pub fn tabulate(
        nch: usize,
        lo: f64,
        hi: f64,
        tol: f64,
        value: impl Fn(f64, &mut [Complex64]) -> Result<(), ReducedError>,
        value_and_derivative: impl Fn(
            f64,
            &mut [Complex64],
            &mut [Complex64],
        ) -> Result<(), ReducedError>,
    ) -> Result<Self, ReducedError> {
        if nch == 0 {
            return Ok(Self {
                nodes: Breaks::new(&[lo, hi]),
                c: vec![],
                nch,
            });
        }
        let node = |w: f64| -> Result<(Vec<Complex64>, Vec<Complex64>), ReducedError> {
            let mut v = vec![Complex64::new(0.0, 0.0); nch];
            let mut d = v.clone();
            value_and_derivative(w, &mut v, &mut d)?;
            Ok((v, d))
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
        // `done[k]`: interval k (pts[k]..pts[k+1]) has passed the midpoint
        // test; it is not evaluated again (its endpoints do not change, so
        // it would pass again: the nodes are those of testing every interval
        // in every pass, at a fraction of the evaluations)
        let mut done = vec![false; pts.len() - 1];
        let mut exact = vec![Complex64::new(0.0, 0.0); nch];
        loop {
            let mut out = Vec::with_capacity(2 * pts.len());
            let mut out_done = Vec::with_capacity(2 * done.len());
            let mut refined = false;
            let n = pts.len();
            let mut it = pts.into_iter().peekable();
            let mut k = 0;
            while let Some(p0) = it.next() {
                let Some(p1) = it.peek() else {
                    out.push(p0);
                    break;
                };
                if done[k] {
                    out.push(p0);
                    out_done.push(true);
                    k += 1;
                    continue;
                }
                let ((w0, v0, d0), (w1, v1, d1)) = (&p0, p1);
                let wm = 0.5 * (w0 + w1);
                let h = w1 - w0;
                value(wm, &mut exact)?;
                let bad = (0..nch).any(|c| {
                    let herm = 0.5 * (v0[c] + v1[c]) + 0.125 * h * (d0[c] - d1[c]);
                    (herm - exact[c]).norm() > tol * scale[c]
                });
                out.push(p0);
                if bad {
                    if n + out.len() > 200_000 || h < 1e-9 * wm {
                        return Err(ReducedError::BadOption {
                            name: "channel_tol",
                            value: tol,
                            why: "attachment quantities too rough to tabulate to this accuracy",
                        });
                    }
                    let (v, d) = node(wm)?;
                    out.push((wm, v, d));
                    out_done.extend([false, false]);
                    refined = true;
                } else {
                    out_done.push(true);
                }
                k += 1;
            }
            pts = out;
            done = out_done;
            if !refined {
                break;
            }
        }
        // Hermite data -> power form in t: p(t) = v0 + h d0 t
        //   + (3 (v1 - v0) - h (2 d0 + d1)) t^2 + (2 (v0 - v1) + h (d0 + d1)) t^3
        let mut c = Vec::with_capacity((pts.len() - 1) * nch);
        for w in pts.windows(2) {
            let ((w0, v0, d0), (w1, v1, d1)) = (&w[0], &w[1]);
            let h = w1 - w0;
            for ch in 0..nch {
                let (v0, v1, d0, d1) = (v0[ch], v1[ch], d0[ch], d1[ch]);
                c.push([
                    v0,
                    d0 * h,
                    (v1 - v0) * 3.0 - (d0 * 2.0 + d1) * h,
                    (v0 - v1) * 2.0 + (d0 + d1) * h,
                ]);
            }
        }
        let nodes: Vec<f64> = pts.iter().map(|p| p.0).collect();
        Ok(Self {
            nodes: Breaks::new(&nodes),
            c,
            nch,
        })
    }

    /// Number of channels per frequency.
    pub fn nch(&self) -> usize {
        self.nch
    }

    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Interpolated channels at `w` and their derivatives with respect to
    /// `w` (those of the interpolating cubics; zero outside the tabulated
    /// range, where the channels are held).
    pub fn eval_with_derivative(&self, w: f64, out: &mut [Complex64], d: &mut [Complex64]) {
        if self.nch == 0 {
            return;
        }
        let (lo, hi) = (self.nodes.first(), self.nodes.last());
        let loc = self.nodes.locate(w.clamp(lo, hi));
        let c = &self.c[loc.k * self.nch..(loc.k + 1) * self.nch];
        let (t, inv_h) = (loc.t, self.nodes.inv_h(loc.k));
        let inside = if w >= lo && w <= hi { inv_h } else { 0.0 };
        for ((o, d), c) in out.iter_mut().zip(d.iter_mut()).zip(c) {
            *o = c[0] + (c[1] + (c[2] + c[3] * t) * t) * t;
            *d = (c[1] + (c[2] * 2.0 + c[3] * (3.0 * t)) * t) * inside;
        }
    }

    /// Interpolated channels at `w` (clamped to the tabulated range).
    #[inline(always)]
    pub fn eval(&self, w: f64, out: &mut [Complex64]) {
        if self.nch == 0 {
            return;
        }
        let (c, t) = self.segment(w);
        for (o, c) in out.iter_mut().zip(c) {
            *o = cubic(c, t);
        }
    }

    /// The channels' cubics on the segment of `w` (clamped to the tabulated
    /// range) and the local coordinate there: channel `ch` at `w` is
    /// `cubic(&c[ch], t)` (the numbers of [`Self::eval`]).
    #[inline(always)]
    pub fn segment(&self, w: f64) -> (&[[Complex64; 4]], f64) {
        let loc = self.nodes.locate(self.clamped(w));
        (&self.c[loc.k * self.nch..(loc.k + 1) * self.nch], loc.t)
    }

    /// `w.clamp(first node, last node)`, the same number (the nodes are
    /// ordered: without `clamp`'s check of its bounds, per evaluation).
    #[inline(always)]
    fn clamped(&self, w: f64) -> f64 {
        let (lo, hi) = (self.nodes.first(), self.nodes.last());
        let w = if w < lo { lo } else { w };
        if w > hi {
            hi
        } else {
            w
        }
    }
}
