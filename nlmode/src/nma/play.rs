//! Exact AFT of a play-type hysteretic element (Jenkins, [`PlayOperator`]):
//! the periodic force of `u(tau)` (the truncated Fourier series of
//! `eq:fourier`, layout of [`super::hb::cos_index`]) integrated in closed form
//! between the located transition instants, instead of sampled.
//!
//! `u` is monotone between consecutive extrema (the roots of `du/dtau`, found
//! by a sign scan on the AFT's sample grid and refined by safeguarded Newton).
//! On a monotone piece from state `w` (slider position [m]) the element sticks,
//! `f = k_t (u - w)`, until `u` reaches `w +- F_s / k_t` (slip onset, a root
//! located the same way), then slips with `f = +-F_s`; the slider ends at
//! `w = u(tau_end) -+ F_s / k_t`. The march starts at `tau = 0` in the
//! law's [`crate::structure::Hysteresis::initial_state`] and repeats the
//! period until its state is periodic (two periods for a play operator); the
//! last period is projected exactly:
//!
//! ```text
//! F_h = p_h [ sum_stick k_t int (u - w) phi_h dtau + sum_slip (+-F_s) int phi_h dtau ],
//! ```
//!
//! `p_0 = 1/(2 pi)`, `p_h = 1/pi`. The force is continuous at every transition
//! (`+-F_s` on both sides), so the boundary terms of the derivative vanish and
//! the Jacobian is exact: `dF_h/dU_j = p_h k_t sum_stick int (phi_j - dw/dU_j)
//! phi_h dtau`, with `dw/dU = phi(tau_end)` after a slip (the end is an extremum
//! or the period boundary) and the initial state's derivative before any slip.
//! The harmonics are therefore smooth (C^1) in `U` through slip onset, with no
//! sampling error (the sampled march has a corner per sample switching between
//! stick and slip, and a reversal displaced to the nearest sample).
use crate::structure::PlayOperator;
use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;

/// Most iterations of a safeguarded root search (bisection alone halves the
/// bracket 60 times, below the resolution of `tau`).
const MAX_ROOT_ITERATIONS: usize = 100;

/// Most periods marched (a play operator is periodic after the first).
const MAX_PERIODS: usize = 4;

/// One piece of the recorded period.
enum Piece {
    /// `f = k_t (u - w)` on `[a, b]`, with `dw/dU`.
    Stick {
        a: f64,
        b: f64,
        w: f64,
        dw: Vec<f64>,
    },
    /// `f = sign F_s` on `[a, b]`.
    Slip { a: f64, b: f64, sign: f64 },
}

/// `(cos k tau, sin k tau)` for `k = 1..=kmax` into `c[k]`, `s[k]` by the
/// angle-addition recurrence from one `sin_cos` (rounding grows like `k eps`).
fn trig_table(tau: f64, kmax: usize, c: &mut [f64], s: &mut [f64]) {
    let (s1, c1) = tau.sin_cos();
    c[0] = 1.0;
    s[0] = 0.0;
    for k in 1..=kmax {
        c[k] = c[k - 1] * c1 - s[k - 1] * s1;
        s[k] = s[k - 1] * c1 + c[k - 1] * s1;
    }
}

/// The displacement `u(tau) = sum_j U_j phi_j(tau)` and its derivatives.
struct Signal<'a> {
    u: &'a [f64],
    harmonics: usize,
}

impl Signal<'_> {
    /// `phi_j(tau)`, `j = 0..2H+1`.
    fn row(&self, tau: f64) -> Vec<f64> {
        let h = self.harmonics;
        let (mut c, mut s) = (vec![0.0; h + 1], vec![0.0; h + 1]);
        trig_table(tau, h, &mut c, &mut s);
        let mut r = vec![0.0; self.u.len()];
        r[0] = 1.0;
        for n in 1..=h {
            r[2 * n - 1] = c[n];
            r[2 * n] = s[n];
        }
        r
    }
    /// `(u, du/dtau, d2u/dtau2)` at `tau`.
    fn eval(&self, tau: f64) -> (f64, f64, f64) {
        let u = self.u;
        let (mut v, mut d1, mut d2) = (u[0], 0.0, 0.0);
        let (s1, c1) = tau.sin_cos();
        let (mut c, mut s) = (1.0, 0.0);
        for n in 1..=self.harmonics {
            let nf = n as f64;
            (c, s) = (c * c1 - s * s1, s * c1 + c * s1);
            let (a, b) = (u[2 * n - 1], u[2 * n]);
            v += a * c + b * s;
            d1 += nf * (b * c - a * s);
            d2 -= nf * nf * (a * c + b * s);
        }
        (v, d1, d2)
    }
}

/// Root of `g` in `[a, b]` with `g(a)`, `g(b)` of opposite signs (or zero),
/// `g` returning `(value, derivative)`: Newton kept inside the bracket,
/// bisection where it leaves it; at most [`MAX_ROOT_ITERATIONS`] steps.
fn bracketed_root(mut a: f64, mut b: f64, g: impl Fn(f64) -> (f64, f64)) -> f64 {
    let (ga, _) = g(a);
    let (gb, _) = g(b);
    if ga == 0.0 {
        return a;
    }
    if gb == 0.0 {
        return b;
    }
    let up = gb > ga;
    let mut x = 0.5 * (a + b);
    for _ in 0..MAX_ROOT_ITERATIONS {
        let (gx, dg) = g(x);
        if gx == 0.0 {
            return x;
        }
        if (gx > 0.0) == up {
            b = x;
        } else {
            a = x;
        }
        let newton = x - gx / dg;
        let next = if newton.is_finite() && newton > a && newton < b {
            newton
        } else {
            0.5 * (a + b)
        };
        if (next - x).abs() <= 4.0 * f64::EPSILON * (1.0 + x.abs()) || b - a <= 1e-15 {
            return next;
        }
        x = next;
    }
    x
}

/// Force harmonics and, if `jacobian`, `dF/dU` of the play operator `p` for the
/// displacement harmonics `u` (`2H+1` real coefficients); `grid` holds
/// `du/dtau` at `N` equidistant instants (the sign scan for the extrema), and
/// `(s0, ds0)` the initial state at `U[0]` and its derivative.
pub(super) fn play_aft(
    p: PlayOperator,
    harmonics: usize,
    u: &DVector<f64>,
    du_grid: &DVector<f64>,
    (s0, ds0): (f64, f64),
    jacobian: bool,
) -> (DVector<f64>, DMatrix<f64>) {
    let nh = 2 * harmonics + 1;
    let fs = p.slip_force_n;
    let mut force = DVector::zeros(nh);
    let mut jac = DMatrix::zeros(nh, if jacobian { nh } else { 0 });
    if fs == 0.0 {
        return (force, jac);
    }
    let sig = Signal {
        u: u.as_slice(),
        harmonics,
    };
    let ext = extrema(&sig, du_grid);
    let segs = monotone_segments(&sig, &ext);
    let pieces = periodic_pieces(&sig, &segs, p, (s0, ds0));
    project_pieces(
        &pieces,
        p,
        harmonics,
        u,
        &mut force,
        jacobian.then_some(&mut jac),
    );
    (force, jac)
}

/// The extrema of `u(tau)` in one period, sorted: the roots of `du/dtau`
/// between grid points where its sign changes (`du_grid`: `du/dtau` at `N`
/// equidistant instants, periodic).
fn extrema(sig: &Signal, du_grid: &DVector<f64>) -> Vec<f64> {
    // extrema: sign changes of du/dtau between grid points (periodic)
    let n = du_grid.len();
    let two_pi = 2.0 * PI;
    let mut ext: Vec<f64> = Vec::new();
    for t in 0..n {
        let (g0, g1) = (du_grid[t], du_grid[(t + 1) % n]);
        if (g0 > 0.0) != (g1 > 0.0) {
            let a = two_pi * t as f64 / n as f64;
            let b = two_pi * (t + 1) as f64 / n as f64;
            let r = bracketed_root(a, b, |x| {
                let (_, d1, d2) = sig.eval(x);
                (d1, d2)
            });
            ext.push(if r >= two_pi { r - two_pi } else { r });
        }
    }
    ext.sort_by(f64::total_cmp);
    ext
}

/// The monotone pieces `[a, b]` of one period between the extrema `ext`,
/// with their direction `+-1` (0: constant displacement).
fn monotone_segments(sig: &Signal, ext: &[f64]) -> Vec<(f64, f64, f64)> {
    let two_pi = 2.0 * PI;
    // monotone pieces [a, b] of one period with direction +-1 (0: constant)
    let mut bounds = vec![0.0];
    bounds.extend(ext.iter().copied().filter(|&x| x > 0.0 && x < two_pi));
    bounds.push(two_pi);
    bounds
        .windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| {
            let (ua, ub) = (sig.eval(w[0]).0, sig.eval(w[1]).0);
            let d = if ext.is_empty() || ub == ua {
                0.0
            } else if ub > ua {
                1.0
            } else {
                -1.0
            };
            (w[0], w[1], d)
        })
        .collect()
}

/// The stick and slip pieces of the play operator over one period of the
/// monotone segments `segs`, marched from the state `(s0, ds0)` (`w` and
/// `dw/dU[0]`) period after period (at most [`MAX_PERIODS`]) until the state
/// at the period's end repeats: the pieces of the last period.
fn periodic_pieces(
    sig: &Signal,
    segs: &[(f64, f64, f64)],
    p: PlayOperator,
    (s0, ds0): (f64, f64),
) -> Vec<Piece> {
    let nh = 2 * sig.harmonics + 1;
    let (kt, fs) = (p.stiffness_n_per_m, p.slip_force_n);
    let xs = fs / kt;
    let mut w = s0;
    let mut dw = vec![0.0; nh];
    dw[0] = ds0;
    let mut pieces: Vec<Piece> = Vec::new();
    for period in 0..MAX_PERIODS {
        let w_start = w;
        pieces.clear();
        for &(a, b, d) in segs {
            let ub = sig.eval(b).0;
            if d == 0.0 {
                // constant displacement: stick or a constant slip force
                let f = kt * (ub - w);
                if f.abs() <= fs {
                    pieces.push(Piece::Stick {
                        a,
                        b,
                        w,
                        dw: dw.clone(),
                    });
                } else {
                    pieces.push(Piece::Slip {
                        a,
                        b,
                        sign: f.signum(),
                    });
                }
                continue;
            }
            let threshold = w + d * xs;
            if d * (ub - threshold) <= 0.0 {
                pieces.push(Piece::Stick {
                    a,
                    b,
                    w,
                    dw: dw.clone(),
                });
                continue;
            }
            let ua = sig.eval(a).0;
            let onset = if d * (ua - threshold) >= 0.0 {
                a
            } else {
                bracketed_root(a, b, |x| {
                    let (v, d1, _) = sig.eval(x);
                    (v - threshold, d1)
                })
            };
            if onset > a {
                pieces.push(Piece::Stick {
                    a,
                    b: onset,
                    w,
                    dw: dw.clone(),
                });
            }
            pieces.push(Piece::Slip {
                a: onset,
                b,
                sign: d,
            });
            w = ub - d * xs;
            dw = sig.row(b);
        }
        let tol = 1e-13 * (w.abs() + xs + sig.u.iter().map(|v| v.abs()).sum::<f64>());
        if period > 0 && (w - w_start).abs() <= tol {
            break;
        }
    }
    pieces
}

/// The exact projection of the period's `pieces` onto the harmonics, added
/// to `force` and, if given, `jac` (`dF/dU`): a slip piece contributes `+-f_s`,
/// a stick piece `k_t (u - w)`.
fn project_pieces(
    pieces: &[Piece],
    p: PlayOperator,
    harmonics: usize,
    u: &DVector<f64>,
    force: &mut DVector<f64>,
    mut jac: Option<&mut DMatrix<f64>>,
) {
    let nh = 2 * harmonics + 1;
    let (kt, fs) = (p.stiffness_n_per_m, p.slip_force_n);
    // exact projection of the recorded period
    let weight = |h: usize| if h == 0 { 0.5 / PI } else { 1.0 / PI };
    let mut cs = vec![0.0; 2 * harmonics + 1];
    let mut sn = vec![0.0; 2 * harmonics + 1];
    let mut ih = vec![0.0; nh];
    let (mut ta_c, mut ta_s) = (vec![0.0; nh], vec![0.0; nh]);
    let (mut tb_c, mut tb_s) = (vec![0.0; nh], vec![0.0; nh]);
    let mut ihj = DMatrix::zeros(nh, nh);
    for piece in pieces {
        let (a, b) = match *piece {
            Piece::Stick { a, b, .. } | Piece::Slip { a, b, .. } => (a, b),
        };
        // C_k = int_a^b cos(k tau), S_k = int_a^b sin(k tau), k = 0..2H
        trig_table(a, 2 * harmonics, &mut ta_c, &mut ta_s);
        trig_table(b, 2 * harmonics, &mut tb_c, &mut tb_s);
        cs[0] = b - a;
        sn[0] = 0.0;
        for k in 1..=2 * harmonics {
            let kf = k as f64;
            cs[k] = (tb_s[k] - ta_s[k]) / kf;
            sn[k] = -(tb_c[k] - ta_c[k]) / kf;
        }
        ih[0] = cs[0];
        for m in 1..=harmonics {
            ih[2 * m - 1] = cs[m];
            ih[2 * m] = sn[m];
        }
        match piece {
            Piece::Slip { sign, .. } => {
                for h in 0..nh {
                    force[h] += weight(h) * sign * fs * ih[h];
                }
            }
            Piece::Stick { w, dw, .. } => {
                fill_products(harmonics, &cs, &sn, &ih, &mut ihj);
                for h in 0..nh {
                    let c = weight(h) * kt;
                    let row_u: f64 = (0..nh).map(|j| ihj[(h, j)] * u[j]).sum();
                    force[h] += c * (row_u - w * ih[h]);
                    if let Some(jac) = jac.as_deref_mut() {
                        for j in 0..nh {
                            jac[(h, j)] += c * (ihj[(h, j)] - ih[h] * dw[j]);
                        }
                    }
                }
            }
        }
    }
}

/// `I[h, j] = int_a^b phi_h phi_j dtau` from `C_k`, `S_k` (`k = 0..2H`) and
/// `I_h = int phi_h` by the product-to-sum identities.
fn fill_products(harmonics: usize, cs: &[f64], sn: &[f64], ih: &[f64], out: &mut DMatrix<f64>) {
    let nh = 2 * harmonics + 1;
    // S_{k} for signed k
    let s = |k: isize| -> f64 {
        if k >= 0 {
            sn[k as usize]
        } else {
            -sn[(-k) as usize]
        }
    };
    for j in 0..nh {
        out[(0, j)] = ih[j];
        out[(j, 0)] = ih[j];
    }
    for n in 1..=harmonics {
        for m in n..=harmonics {
            let (d, p) = (n.abs_diff(m), n + m);
            let cc = 0.5 * (cs[d] + cs[p]);
            let ss = 0.5 * (cs[d] - cs[p]);
            let nm = n as isize - m as isize;
            // cos n sin m = (sin(n+m) - sin(n-m))/2, sin n cos m = (sin(n+m) + sin(n-m))/2
            let csm = 0.5 * (sn[p] - s(nm));
            let scm = 0.5 * (sn[p] + s(nm));
            let (cn, sn_, cm, sm) = (2 * n - 1, 2 * n, 2 * m - 1, 2 * m);
            out[(cn, cm)] = cc;
            out[(cm, cn)] = cc;
            out[(sn_, sm)] = ss;
            out[(sm, sn_)] = ss;
            out[(cn, sm)] = csm;
            out[(sm, cn)] = csm;
            out[(sn_, cm)] = scm;
            out[(cm, sn_)] = scm;
        }
    }
}
