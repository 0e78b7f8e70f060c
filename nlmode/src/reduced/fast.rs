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
    /// `1 / (x[k+1] - x[k])`.
    inv_h: Vec<f64>,
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
            inv_h: self.inv_h.clone(),
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
            inv_h: x.windows(2).map(|w| 1.0 / (w[1] - w[0])).collect(),
            hint: AtomicUsize::new(0),
        }
    }

    pub fn first(&self) -> f64 {
        self.x[0]
    }

    pub fn last(&self) -> f64 {
        self.x[self.x.len() - 1]
    }

    /// Number of breakpoints.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Segment `k` with `x[k] <= a < x[k+1]` (a breakpoint starts its segment:
    /// `t = 0`; the last breakpoint belongs to the last segment) for `a` in
    /// `[first, last]`.
    #[inline(always)]
    pub fn locate(&self, a: f64) -> Loc {
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
        Loc {
            k,
            t: (a - self.x[k]) * self.inv_h[k],
        }
    }

    /// `1 / (x[k+1] - x[k])`.
    #[inline(always)]
    pub fn inv_h(&self, k: usize) -> f64 {
        self.inv_h[k]
    }

    /// `d/dx` of a cubic in `t` with coefficients `c` on segment `loc.k`.
    #[inline(always)]
    pub fn slope(&self, loc: Loc, c: &[f64; 4]) -> f64 {
        (c[1] + loc.t * (2.0 * c[2] + 3.0 * loc.t * c[3])) * self.inv_h[loc.k]
    }
}

#[derive(Debug, Clone)]
pub(crate) struct FastTable {
    x: Breaks,
    /// Quantities: 0 = omega, 1 = D, then `2 + 2 p`, `3 + 2 p` = Re, Im of the
    /// fundamental shape at table point `p`.
    nq: usize,
    /// `c[k * nq + q]`: cubic in `t in [0, 1]` on segment `k`.
    c: Vec<[f64; 4]>,
}

impl FastTable {
    /// The table's fundamental-harmonic interpolants in power form.
    pub fn new(table: &TableInterpolator) -> Self {
        Self {
            x: Breaks::new(table.amplitudes()),
            nq: 2 + 2 * table.point_count(),
            c: table.fundamental_power_form(),
        }
    }

    #[inline(always)]
    pub fn locate(&self, a: f64) -> Result<Loc, TableError> {
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

    /// Value of quantity `q` at `loc`.
    #[inline(always)]
    pub fn value(&self, loc: Loc, q: usize) -> f64 {
        let c = &self.c[loc.k * self.nq + q];
        c[0] + loc.t * (c[1] + loc.t * (c[2] + loc.t * c[3]))
    }

    /// `d/da` of quantity `q` at `loc` (zero below the range).
    #[inline(always)]
    pub fn derivative(&self, loc: Loc, a: f64, q: usize) -> f64 {
        if a <= self.x.first() {
            return 0.0;
        }
        self.x.slope(loc, &self.c[loc.k * self.nq + q])
    }
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
                let d = (f.value(loc, 2 + 2 * pt) - s.re).abs()
                    + (f.value(loc, 3 + 2 * pt) - s.im).abs();
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
