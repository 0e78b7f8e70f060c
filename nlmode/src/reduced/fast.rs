//! The modal table's PCHIP interpolant in power form for the hot loop.
//!
//! [`crate::table::TableInterpolator`] evaluates each quantity separately
//! (one segment search per call, value and derivative each time). The slow
//! flow needs `omega`, `D` and the fundamental shape at a few points at the same
//! amplitude thousands of times per sweep, so the same piecewise cubics are
//! taken once in power form per segment
//! ([`TableInterpolator::fundamental_power_form`], from the table's PCHIP
//! slopes), and one segment search serves all quantities. The range policy is the table's:
//! held below the first amplitude, [`TableError::AboveRange`] above the last.
use crate::table::{TableError, TableInterpolator};
use num_complex::Complex64;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Segment and local coordinate `t in [0, 1]` of an abscissa.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Loc {
    pub k: usize,
    pub t: f64,
}

/// Breakpoints of a piecewise polynomial with a search hint: along a sweep
/// the abscissa (amplitude, frequency) changes smoothly, so the next lookup
/// is usually in the same segment or a neighbour.
#[derive(Debug)]
pub(crate) struct Breaks {
    x: Vec<f64>,
    /// `x[0]` and the last breakpoint (read without an index).
    first: f64,
    last: f64,
    /// Per segment `k`: `[x[k], x[k+1], 1 / (x[k+1] - x[k])]` (the hinted
    /// lookup reads one entry).
    seg: Vec<[f64; 3]>,
    /// Segment of the previous lookup (relaxed atomic: only a hint, any value
    /// is safe, and the model stays `Sync`). Threads sweeping one shared
    /// model at once overwrite it for each other at every lookup (and move
    /// its cache line between cores): give each thread its own clone (a clone
    /// starts with its own hint), as `host study` does.
    hint: AtomicUsize,
}

impl Clone for Breaks {
    fn clone(&self) -> Self {
        Self {
            x: self.x.clone(),
            first: self.first,
            last: self.last,
            seg: self.seg.clone(),
            hint: AtomicUsize::new(0),
        }
    }
}

impl Breaks {
    /// `x` strictly increasing, at least two points.
    pub fn new(x: &[f64]) -> Self {
        debug_assert!(x.len() >= 2 && x.windows(2).all(|w| w[0] < w[1]));
        Self {
            x: x.to_vec(),
            first: x[0],
            last: x[x.len() - 1],
            seg: x
                .windows(2)
                .map(|w| [w[0], w[1], 1.0 / (w[1] - w[0])])
                .collect(),
            hint: AtomicUsize::new(0),
        }
    }

    #[inline(always)]
    pub fn first(&self) -> f64 {
        self.first
    }

    #[inline(always)]
    pub fn last(&self) -> f64 {
        self.last
    }

    /// Number of breakpoints.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Segment `k` with `x[k] <= a < x[k+1]` (a breakpoint starts its segment:
    /// `t = 0`; the last breakpoint belongs to the last segment) for `a` in
    /// `[first, last]`. The segment of the previous lookup is tried first
    /// (one entry, one comparison pair); the neighbours and the search are
    /// [`Self::locate_near`].
    #[inline(always)]
    pub fn locate(&self, a: f64) -> Loc {
        let h = self.hint.load(Ordering::Relaxed);
        if let Some(&[x0, x1, inv_h]) = self.seg.get(h) {
            if x0 <= a && (a < x1 || h + 1 == self.seg.len()) {
                return Loc {
                    k: h,
                    t: (a - x0) * inv_h,
                };
            }
        }
        self.locate_near(a)
    }

    /// [`Self::locate`] outside the hinted segment: its neighbours, else a
    /// binary search.
    #[inline(never)]
    fn locate_near(&self, a: f64) -> Loc {
        let n = self.x.len();
        let inside = |k: usize| self.x[k] <= a && (a < self.x[k + 1] || k + 2 == n);
        let h = self.hint.load(Ordering::Relaxed).min(n - 2);
        let k = if inside(h) {
            h
        } else if h + 1 < n - 1 && inside(h + 1) {
            h + 1
        } else if h > 0 && inside(h - 1) {
            h - 1
        } else {
            self.x.partition_point(|&v| v <= a).clamp(1, n - 1) - 1
        };
        self.hint.store(k, Ordering::Relaxed);
        let [xk, _, inv_h] = self.seg[k];
        Loc {
            k,
            t: (a - xk) * inv_h,
        }
    }

    /// `1 / (x[k+1] - x[k])`.
    #[inline(always)]
    pub fn inv_h(&self, k: usize) -> f64 {
        self.seg[k][2]
    }

    /// `d/dx` of a cubic in `t` with coefficients `c` on segment `loc.k`.
    #[inline(always)]
    pub fn slope(&self, loc: Loc, c: &[f64; 4]) -> f64 {
        (c[1] + loc.t * (2.0 * c[2] + 3.0 * loc.t * c[3])) * self.seg[loc.k][2]
    }
}

#[derive(Debug, Clone)]
pub(crate) struct FastTable {
    x: Breaks,
    /// `a` in `(lo, hi]` is inside the table (the fast path of
    /// [`Self::locate`]): `lo = max(first amplitude, 0)`, `hi` the last.
    lo: f64,
    hi: f64,
    /// `modal[k]`: `omega` and `D`, cubics in `t in [0, 1]` on segment `k`.
    modal: Vec<[[f64; 4]; 2]>,
    /// `shape[k * np + p]`: the fundamental shape at table point `p` on
    /// segment `k`, a cubic in `t` with complex coefficients (the real and
    /// imaginary parts' cubics side by side: one evaluation gives both, the
    /// same numbers as evaluating each part).
    shape: Vec<[Complex64; 4]>,
    /// Table points.
    np: usize,
}

impl FastTable {
    /// The table's fundamental-harmonic interpolants in power form.
    pub fn new(table: &TableInterpolator) -> Self {
        let np = table.point_count();
        // per segment: omega, D, then Re, Im of each point's shape
        let c = table.fundamental_power_form();
        let seg = c.chunks_exact(2 + 2 * np);
        let modal = seg.clone().map(|s| [s[0], s[1]]).collect();
        let shape = seg
            .flat_map(|s| {
                s[2..]
                    .chunks_exact(2)
                    .map(|ri| std::array::from_fn(|j| Complex64::new(ri[0][j], ri[1][j])))
            })
            .collect();
        let x = Breaks::new(table.amplitudes());
        Self {
            lo: x.first().max(0.0),
            hi: x.last(),
            x,
            modal,
            shape,
            np,
        }
    }

    /// The location of `a`; below the table it is held (segment 0, `t = 0`),
    /// above it [`TableError::AboveRange`], not finite or negative
    /// [`TableError::BadAmplitude`]. Inside the table (the hot path) two
    /// comparisons decide; the edges are [`Self::locate_edge`].
    #[inline(always)]
    pub fn locate(&self, a: f64) -> Result<Loc, TableError> {
        if a > self.lo && a <= self.hi {
            Ok(self.x.locate(a))
        } else {
            self.locate_edge(a)
        }
    }

    /// [`Self::locate`] for every `a` (the checks in their order).
    #[cold]
    #[inline(never)]
    fn locate_edge(&self, a: f64) -> Result<Loc, TableError> {
        if !(a.is_finite() && a >= 0.0) {
            return Err(TableError::BadAmplitude(a));
        }
        if a <= self.x.first() {
            return Ok(Loc { k: 0, t: 0.0 });
        }
        if a > self.x.last() {
            return Err(TableError::AboveRange {
                a,
                max: self.x.last(),
            });
        }
        Ok(self.x.locate(a))
    }

    /// Value of `omega` (`q = 0`) or `D` (`q = 1`) at `loc`.
    #[inline(always)]
    pub fn value(&self, loc: Loc, q: usize) -> f64 {
        let c = &self.modal[loc.k][q];
        c[0] + loc.t * (c[1] + loc.t * (c[2] + loc.t * c[3]))
    }

    /// The fundamental shape at table point `pt` at `loc` (its real and
    /// imaginary parts each `c0 + t (c1 + t (c2 + t c3))`, as [`Self::value`]).
    #[inline(always)]
    pub fn shape(&self, loc: Loc, pt: usize) -> Complex64 {
        cubic(&self.shape[loc.k * self.np + pt], loc.t)
    }

    /// The shapes of segment `k`, one per table point (for several points
    /// at one location: one bounds check per point instead of an index
    /// computation each).
    #[inline(always)]
    pub fn shapes(&self, k: usize) -> &[[Complex64; 4]] {
        &self.shape[k * self.np..(k + 1) * self.np]
    }

    /// `d/da` of `omega` (`q = 0`) or `D` (`q = 1`) at `loc` (zero below the range).
    #[inline(always)]
    pub fn derivative(&self, loc: Loc, a: f64, q: usize) -> f64 {
        if a <= self.x.first() {
            return 0.0;
        }
        self.x.slope(loc, &self.modal[loc.k][q])
    }
}

/// A cubic with complex coefficients in power form at the local coordinate
/// `t` (a shape of [`FastTable::shapes`], a channel of the sweep's
/// tabulation): `c0 + t (c1 + t (c2 + t c3))`, real and imaginary parts
/// each evaluated as a real cubic would be.
#[inline(always)]
pub(crate) fn cubic(c: &[Complex64; 4], t: f64) -> Complex64 {
    c[0] + (c[1] + (c[2] + c[3] * t) * t) * t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nma::{ModalTable, PointShape, MODAL_TABLE_FORMAT, MODAL_TABLE_VERSION};

    #[test]
    fn power_form_reproduces_the_table_interpolant() {
        let a: Vec<f64> = (0..23).map(|j| 1e-5 * 1.4f64.powi(j)).collect();
        let omega: Vec<f64> = a
            .iter()
            .map(|&a| (356.2f64.powi(2) + 5e10 * a * a).sqrt() - 3e4 * a * a)
            .collect();
        let damping: Vec<f64> = a.iter().map(|&a| 0.004 + 2.0 * a).collect();
        let t = ModalTable {
            format: MODAL_TABLE_FORMAT.into(),
            version: MODAL_TABLE_VERSION,
            description: "test".into(),
            harmonics: 1,
            amplitude: a.clone(),
            omega_rad_s: omega,
            damping_ratio: damping,
            points: vec![
                PointShape {
                    name: "p".into(),
                    re: a.iter().map(|&a| vec![0.0, 1.0 + 30.0 * a]).collect(),
                    im: a.iter().map(|&a| vec![0.0, -(a * 1e3).sin()]).collect(),
                },
                PointShape {
                    name: "q".into(),
                    re: a.iter().map(|&a| vec![0.0, 0.3 - 50.0 * a * a]).collect(),
                    im: a.iter().map(|_| vec![0.0, 0.1]).collect(),
                },
            ],
            coordinates: vec![],
            truncated_at_fold: None,
            accuracy: None,
            linear_modes: None,
        };
        let ip = t.interpolator().unwrap();
        let f = FastTable::new(&ip);
        let amax = *a.last().unwrap();
        let mut worst: f64 = 0.0;
        for k in 0..=5000 {
            let x = amax * (k as f64 / 5000.0).powi(3);
            let loc = f.locate(x).unwrap();
            let p = ip.eval(x).unwrap();
            worst = worst.max((f.value(loc, 0) - p.omega_rad_s).abs() / p.omega_rad_s);
            worst = worst.max((f.value(loc, 1) - p.damping_ratio).abs() / p.damping_ratio);
            worst = worst.max(
                (f.derivative(loc, x, 0) - p.domega_da).abs() / (1.0 + p.domega_da.abs()) * 1e-3,
            );
            for pt in 0..2 {
                let s = ip.shape(pt, 1, x).unwrap();
                let g = f.shape(loc, pt);
                let d = (g.re - s.re).abs() + (g.im - s.im).abs();
                worst = worst.max(d / s.norm());
            }
        }
        assert!(worst < 1e-12, "{worst:e}");
        // nodes are exact and the range policy is the table's
        for (j, &x) in a.iter().enumerate().take(a.len() - 1) {
            assert_eq!(f.value(f.locate(x).unwrap(), 0), t.omega_rad_s[j]);
        }
        assert_eq!(f.value(f.locate(0.0).unwrap(), 0), t.omega_rad_s[0]);
        assert!(matches!(
            f.locate(1.001 * amax),
            Err(TableError::AboveRange { .. })
        ));
        assert!(matches!(
            f.locate(f64::NAN),
            Err(TableError::BadAmplitude(_))
        ));
    }
}
