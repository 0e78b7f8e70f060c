//! Exponential collocation integrator (the default method).
//!
//! The assembled system is `z' = A z + F r(t)` with `F = [b, G]` and the forcing
//! `r(t) = [u(t); f(t)]`: the excitation (one or two input signals, the columns
//! of `b`) and the nonlinear element forces, which
//! act through a few fixed vectors. Over a step `[t_n, t_n + h]` the forcing is
//! replaced by its interpolation polynomial through `s` equidistant nodes
//! `t_n + l h/(s-1)`, `l = 0..s-1`, and the linear part is integrated exactly
//! (variation of constants):
//!
//! ```text
//! z(t_n + sigma) = e^{sigma A} z_n + sum_{k=1..s} X_k(sigma) a_k,
//! X_k(sigma) = int_0^sigma e^{(sigma - rho) A} rho^{k-1}/(k-1)! F d rho = sigma^k phi_k(sigma A) F,
//! r(t_n + rho) ~ sum_k a_k rho^{k-1}/(k-1)!.
//! ```
//!
//! The nonlinear forces at the nodes `l >= 1` are unknowns (collocation): they
//! follow from the element displacements/velocities at the nodes, which are
//! projections of the formula above, so the implicit equations have only
//! `m (s-1)` scalar unknowns and are solved by Newton with the laws'
//! derivatives. `e^{sigma A}` and the `X_k` come from one matrix exponential of
//! the augmented matrix `[[A, F, 0..],[0, J (x) I]]` (`J` the nilpotent shift; its
//! top-right blocks are the `X_k`, Al-Mohy & Higham 2011, Thm 2.1) and its powers.
//!
//! Why this method: the linear part is large, stiff (stinger mode ~2.5e4 rad/s,
//! Craig-Bampton modes up to ~1e5 rad/s, unreduced FE modes far beyond) and
//! time-invariant, the nonlinearity is a few scalar springs and the input is a
//! smooth sine. The exponential makes the method exact for the linear part and
//! unconditionally stable, so the step size is set only by how well a polynomial
//! of degree `s-1` follows the forcing over one step; a step costs one
//! `nz x nz` matrix-vector product plus `O(nz s)` work. BDF/ESDIRK methods (e.g.
//! diffsol) would be stable too, but need Newton iterations with `nz x nz` linear
//! solves at every stage and still resolve the fast transients with their error
//! control.
//!
//! Step-size control: the contribution of the highest polynomial coefficient,
//! `X_s(h) a_s`, is the error estimate (an order-`(s-1)` estimate of the
//! order-`s` result, used like an embedded pair with local extrapolation). Step
//! sizes are `dt / 2^level` with `dt` the output sample interval, so every step
//! ends on the sample grid and no interpolation is needed; propagators are built
//! once per level and cached. Time is counted in integer ticks of
//! `dt / 2^MAX_LEVEL`, not summed.
use super::assembly::FirstOrderSystem;
use super::{IntegrationStats, ReferenceError, SampleGrid, StepControl};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// Finest level: the smallest step is `dt / 2^MAX_LEVEL`.
const MAX_LEVEL: u32 = 40;
/// Newton iteration limit for the collocation forces.
const MAX_NEWTON: usize = 25;
/// Newton stops when the force update is below this fraction of the forces.
const NEWTON_RTOL: f64 = 1e-11;

/// Solve the small dense system `a x = b` (`n x n`, row-major) in place by
/// Gaussian elimination with partial pivoting; `b` becomes `x`. Hand-written
/// because it runs in the inner loop for systems of a handful of unknowns,
/// where nalgebra's LU would allocate a matrix per call. `false` if singular.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(|pivot| > 0)` also rejects NaN
fn solve_in_place(a: &mut [f64], b: &mut [f64], n: usize) -> bool {
    for c in 0..n {
        let p = (c..n)
            .max_by(|&i, &j| a[i * n + c].abs().total_cmp(&a[j * n + c].abs()))
            .unwrap();
        if !(a[p * n + c].abs() > 0.0) {
            return false;
        }
        if p != c {
            for k in 0..n {
                a.swap(p * n + k, c * n + k);
            }
            b.swap(p, c);
        }
        let piv = a[c * n + c];
        for i in c + 1..n {
            let f = a[i * n + c] / piv;
            if f != 0.0 {
                for k in c..n {
                    a[i * n + k] -= f * a[c * n + k];
                }
                b[i] -= f * b[c];
            }
        }
    }
    for c in (0..n).rev() {
        let mut acc = b[c];
        for k in c + 1..n {
            acc -= a[c * n + k] * b[k];
        }
        b[c] = acc / a[c * n + c];
    }
    b.iter().all(|x| x.is_finite())
}

/// Propagators for one step size.
struct Level {
    /// `e^{hA}`.
    e: DMatrix<f64>,
    /// Final-state weights of the node values `r_l` (`nz x s mf`).
    zw: DMatrix<f64>,
    /// Error-estimate weights (`nz x s mf`).
    ew: DMatrix<f64>,
    /// Node projections, transposed so that each is a contiguous dot product:
    /// column `(j-1) 2m + k` is row `k` of `P e^{j tau A}` (`nz x (s-1) 2m`).
    pe_t: DMatrix<f64>,
    /// Column `(j-1) 2m + k`: weights of the node values `r` in row `k` of
    /// `P z(t_n + j tau)` (`s mf x (s-1) 2m`).
    pq_t: DMatrix<f64>,
}

fn factorial(k: usize) -> f64 {
    (1..=k).map(|i| i as f64).product()
}

/// Diagonal balancing `D` (powers of 2) of `a` so that `D^-1 a D` has rows and
/// columns of comparable 1-norm (Parlett & Reinsch 1969; LAPACK `dgebal`
/// without permutations). nalgebra offers no balancing. The unreduced beam has
/// `|A|` ~ 1e18 (small rotary inertias) against a spectral radius ~ 8e10: the
/// scaling-and-squaring exponential has a backward error ~ eps |tau A|, which
/// would perturb the slow modes unless `A` is balanced first.
fn balance(a: &DMatrix<f64>) -> DVector<f64> {
    let n = a.nrows();
    let mut b = a.clone();
    let mut d = DVector::from_element(n, 1.0);
    for _sweep in 0..100 {
        let mut changed = false;
        for i in 0..n {
            let c = b.column(i).iter().map(|x| x.abs()).sum::<f64>() - b[(i, i)].abs();
            let r = b.row(i).iter().map(|x| x.abs()).sum::<f64>() - b[(i, i)].abs();
            if !(c > 0.0 && r > 0.0) {
                continue;
            }
            // f = 2^k closest to the minimiser sqrt(r/c) of c f + r / f
            let f = 2f64.powi((0.5 * (r / c).log2()).round() as i32);
            if c * f + r / f < 0.95 * (c + r) {
                d[i] *= f;
                b.column_mut(i).scale_mut(f);
                b.row_mut(i).scale_mut(1.0 / f);
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    d
}

fn build_level(sys: &FirstOrderSystem, d: &DVector<f64>, h: f64, s: usize) -> Level {
    let nz = sys.nz();
    let m = sys.m();
    let p = sys.n_inputs();
    let mf = p + m;
    let tau = h / (s - 1) as f64;
    let na = nz + s * mf;
    // balanced coordinates z_b = D^-1 z: A_b = D^-1 A D, F_b = D^-1 F
    let a_b = DMatrix::from_fn(nz, nz, |i, j| sys.a[(i, j)] * d[j] / d[i]);
    let mut aug = DMatrix::<f64>::zeros(na, na);
    aug.view_mut((0, 0), (nz, nz)).copy_from(&(&a_b * tau));
    for i in 0..nz {
        for c in 0..p {
            aug[(i, nz + c)] = sys.b[(i, c)] / d[i] * tau;
        }
        for e in 0..m {
            aug[(i, nz + p + e)] = sys.g[(i, e)] / d[i] * tau;
        }
    }
    for k in 0..s - 1 {
        for c in 0..mf {
            aug[(nz + k * mf + c, nz + (k + 1) * mf + c)] = tau;
        }
    }
    let e1 = aug.exp();
    // powers[j] = exp(j tau Aug), j = 1..s-1, then back to the original
    // coordinates: e^{sA} = D e^{s A_b} D^-1, X_k = D X_k^b (exact: D holds powers of 2)
    let mut powers = vec![DMatrix::zeros(0, 0), e1.clone()];
    for j in 2..s {
        let next = &powers[j - 1] * &e1;
        powers.push(next);
    }
    for p in powers.iter_mut().skip(1) {
        for i in 0..nz {
            for c in 0..na {
                p[(i, c)] *= d[i];
            }
        }
        for c in 0..nz {
            for i in 0..nz {
                p[(i, c)] /= d[c];
            }
        }
    }
    // interpolation in the basis rho^{k-1}/(k-1)!: with nodes rho_l = l tau,
    // V = Vhat diag(tau^{k-1}), Vhat[l][k-1] = l^{k-1}/(k-1)!.
    let vhat = DMatrix::from_fn(s, s, |l, k| (l as f64).powi(k as i32) / factorial(k));
    let vhat_inv = vhat
        .try_inverse()
        .expect("equidistant Vandermonde is regular");
    // node-value weights at time j tau: sum_k X_k(j tau) tau^{-(k-1)} VhatInv[k-1][l]
    let weights = |j: usize, ks: std::ops::Range<usize>| -> DMatrix<f64> {
        let p = &powers[j];
        let mut w = DMatrix::zeros(nz, s * mf);
        for k in ks {
            let xk = p.view((0, nz + k * mf), (nz, mf));
            let sc = tau.powi(-(k as i32));
            for l in 0..s {
                let c = vhat_inv[(k, l)] * sc;
                if c != 0.0 {
                    let mut dst = w.view_mut((0, l * mf), (nz, mf));
                    dst += xk * c;
                }
            }
        }
        w
    };
    let e = powers[s - 1].view((0, 0), (nz, nz)).into_owned();
    let zw = weights(s - 1, 0..s);
    let ew = weights(s - 1, s - 1..s);
    let np = 2 * m;
    let mut pe_t = DMatrix::zeros(nz, (s - 1) * np);
    let mut pq_t = DMatrix::zeros(s * mf, (s - 1) * np);
    for (j, pw) in powers.iter().enumerate().skip(1) {
        let pe = &sys.proj * pw.view((0, 0), (nz, nz));
        let pq = &sys.proj * weights(j, 0..s);
        pe_t.view_mut((0, (j - 1) * np), (nz, np))
            .copy_from(&pe.transpose());
        pq_t.view_mut((0, (j - 1) * np), (s * mf, np))
            .copy_from(&pq.transpose());
    }
    Level {
        e,
        zw,
        ew,
        pe_t,
        pq_t,
    }
}

/// Integrate `z' = A z + b u(t) + G f(z)` from `z0` at `t = 0` over the sample
/// grid, calling `on_sample(i, z, element_states)` at `t = i dt`.
///
/// Hysteretic elements: within a step their state marches through the
/// collocation nodes in order from the state at the step start (the Newton
/// Jacobian keeps the local `df/du` of each node and drops the `O(h^2)` coupling
/// through the earlier nodes' states); an accepted step stores the state at its
/// end.
// `!(enorm <= 1)` also rejects NaN; `%` kept for the workspace's rust-version 1.80
#[allow(clippy::neg_cmp_op_on_partial_ord, clippy::manual_is_multiple_of)]
pub(crate) fn integrate(
    sys: &FirstOrderSystem,
    z0: &DVector<f64>,
    grid: SampleGrid,
    input: &super::InputSignals,
    ctl: &StepControl,
    on_sample: &mut super::SampleWithStates,
    progress: &mut dyn FnMut(f64),
) -> Result<IntegrationStats, ReferenceError> {
    let mut z = z0.clone();
    let mut states = sys.initial_element_states(&z);
    let mut cache = Propagators::new(sys, false);
    integrate_continued(
        sys,
        &mut z,
        &mut states,
        grid,
        input,
        ctl,
        &mut cache,
        on_sample,
        progress,
    )
}

/// [`integrate`] from the state `z` and element states `states` (both left
/// at the end of the grid), reusing the propagators, the step level and the
/// error scale that `cache` kept from earlier calls (an integration continued
/// over several grids, e.g. one excitation period each).
#[allow(
    clippy::neg_cmp_op_on_partial_ord,
    clippy::manual_is_multiple_of,
    clippy::too_many_arguments
)]
pub(crate) fn integrate_continued(
    sys: &FirstOrderSystem,
    z: &mut DVector<f64>,
    states: &mut [f64],
    grid: SampleGrid,
    input: &super::InputSignals,
    ctl: &StepControl,
    cache: &mut Propagators,
    on_sample: &mut super::SampleWithStates,
    progress: &mut dyn FnMut(f64),
) -> Result<IntegrationStats, ReferenceError> {
    let (dt, n) = (grid.interval_s, grid.count);
    let s = ctl.nodes;
    assert!(s >= 2, "at least two collocation nodes");
    let nz = sys.nz();
    let mut stats = IntegrationStats::default();
    let mut level: u32 = cache.level;
    let one: u64 = 1 << MAX_LEVEL;
    let end: u64 = n as u64 * one;
    let mut pos: u64 = 0;
    let tick = dt / one as f64;
    let mut znew = DVector::zeros(nz);
    let mut err = DVector::zeros(nz);
    if cache.zmax.len() != nz {
        cache.zmax = z.abs().as_slice().to_vec();
    }
    // taken out of the cache while the loop borrows it for the propagators
    let mut zmax = std::mem::take(&mut cache.zmax);
    let mut col = Collocation::new(sys, s, states);
    let mut last_rejected = false;
    let hysteretic = sys.has_hysteresis();
    on_sample(0, z, states);
    let mut next_progress = 0.0;
    while pos < end {
        if stats.steps + stats.rejected >= ctl.max_steps {
            return Err(ReferenceError::TooManySteps {
                time_s: pos as f64 * tick,
                steps: ctl.max_steps,
            });
        }
        let ticks: u64 = 1 << (MAX_LEVEL - level);
        let t = pos as f64 * tick;
        let h = ticks as f64 * tick;
        let lv = cache.level_for(sys, h, s, &mut stats);
        let tau = h / (s - 1) as f64;
        col.start_step(sys, input, z, states, t, tau, &mut stats);
        let mut newton_ok = true;
        if col.m > 0 {
            newton_ok = col.newton(sys, lv, z, states, &mut stats);
        }
        let mut enorm = f64::INFINITY;
        if newton_ok {
            znew.gemv(1.0, &lv.e, z, 0.0);
            znew.gemv(1.0, &lv.zw, &col.r, 1.0);
            err.gemv(1.0, &lv.ew, &col.r, 0.0);
            enorm = error_norm(ctl, &err, &znew, &zmax);
        }
        if !(enorm <= 1.0) {
            stats.rejected += 1;
            if level == MAX_LEVEL {
                return Err(ReferenceError::StepSizeCollapse {
                    time_s: t,
                    step_s: h,
                });
            }
            level += 1;
            last_rejected = true;
            continue;
        }
        if hysteretic {
            col.advance_states(sys, lv, states);
        }
        std::mem::swap(z, &mut znew);
        col.accept(t, tau);
        pos += ticks;
        stats.steps += 1;
        let t_new = pos as f64 * tick;
        ctl.check_state(z, &mut zmax, t_new)?;
        if pos % one == 0 {
            on_sample((pos / one) as usize, z, states);
            let frac = pos as f64 / end as f64;
            if frac >= next_progress {
                progress(frac);
                next_progress = frac + 0.01;
            }
        }
        // try a larger step when the error is small and the grid allows it
        let grow = enorm * 2f64.powi(s as i32) < 0.5;
        if grow && !last_rejected && level > 0 && pos % (2 * ticks) == 0 {
            level -= 1;
        }
        last_rejected = false;
        cache.level = level;
    }
    cache.zmax = zmax;
    Ok(stats)
}

/// The weighted RMS norm of the error estimate `err` of the new state
/// `znew` (scales `atol + rtol max(|z|max, |znew|)`).
fn error_norm(ctl: &StepControl, err: &DVector<f64>, znew: &DVector<f64>, zmax: &[f64]) -> f64 {
    let nz = err.len();
    let mut acc = 0.0;
    for i in 0..nz {
        let sc = ctl.atol + ctl.rtol * zmax[i].max(znew[i].abs());
        acc += (err[i] / sc).powi(2);
    }
    (acc / nz as f64).sqrt()
}

/// The collocation buffers of [`integrate_continued`]: the node values of a
/// step and what the next step's guess needs from the accepted one.
struct Collocation {
    /// Collocation nodes per step.
    s: usize,
    /// Nonlinear elements.
    m: usize,
    /// Input signals.
    p: usize,
    /// Values per node: `p` inputs, then `m` forces.
    mf: usize,
    /// Projections per node (`2m`: displacements, velocities).
    np: usize,
    /// The node values `r` (`s mf`).
    r: DVector<f64>,
    /// The forces at node 0 (from `z_n`).
    f0: Vec<f64>,
    /// Known part of the node projections, `P e^{j tau A} z_n`.
    base: DVector<f64>,
    /// Node projections.
    pall: DVector<f64>,
    /// Extrapolation weights of the previous step's node forces: (step
    /// ratio, `s x s`).
    extrap: (f64, Vec<f64>),
    /// Newton Jacobian and residual (`m (s-1)`).
    jac: Vec<f64>,
    res: Vec<f64>,
    /// The previous accepted step: (start time, node spacing) and its node
    /// forces.
    prev: Option<(f64, f64)>,
    prev_f: Vec<f64>,
    /// Element states marched through the nodes.
    node_states: Vec<f64>,
}

impl Collocation {
    fn new(sys: &FirstOrderSystem, s: usize, states: &[f64]) -> Self {
        let m = sys.m();
        let p = sys.n_inputs();
        let mf = p + m;
        let np = 2 * m;
        let nu = m * (s - 1);
        Self {
            s,
            m,
            p,
            mf,
            np,
            r: DVector::zeros(s * mf),
            f0: vec![0.0; m],
            base: DVector::zeros((s - 1) * np),
            pall: DVector::zeros((s - 1) * np),
            extrap: (f64::NAN, vec![0.0; s * s]),
            jac: vec![0.0; nu * nu],
            res: vec![0.0; nu],
            prev: None,
            prev_f: vec![0.0; s * m],
            node_states: states.to_vec(),
        }
    }

    /// The node values of the step from `t` (node spacing `tau`): the inputs
    /// at every node, the forces at node 0 from `z_n`, and as the initial
    /// guess of the other nodes' forces the previous step's interpolation
    /// polynomial, extrapolated (constant force on the first step).
    #[allow(clippy::too_many_arguments)]
    fn start_step(
        &mut self,
        sys: &FirstOrderSystem,
        input: &super::InputSignals,
        z: &DVector<f64>,
        states: &[f64],
        t: f64,
        tau: f64,
        stats: &mut IntegrationStats,
    ) {
        let (s, m, p, mf) = (self.s, self.m, self.p, self.mf);
        let r = &mut self.r;
        // node values: inputs everywhere, forces at node 0 from z_n
        for l in 0..s {
            let u = input(t + l as f64 * tau);
            r.rows_mut(l * mf, p).copy_from_slice(&u[..p]);
        }
        sys.forces(z, states, &mut self.f0);
        stats.law_evals += m;
        // initial guess of the node forces: the previous step's interpolation
        // polynomial, extrapolated (constant force on the first step)
        let extrap = &mut self.extrap;
        if let Some((tp, taup)) = self.prev {
            // node l of this step sits at x = (s-1) + l tau/taup previous spacings
            let ratio = tau / taup;
            if ratio != extrap.0 {
                for l in 0..s {
                    let x = (t - tp) / taup + l as f64 * ratio;
                    for k in 0..s {
                        extrap.1[l * s + k] = (0..s)
                            .filter(|&i| i != k)
                            .map(|i| (x - i as f64) / (k as f64 - i as f64))
                            .product();
                    }
                }
                extrap.0 = ratio;
            }
        }
        let (f0, prev_f) = (&self.f0, &self.prev_f);
        for e in 0..m {
            r[p + e] = f0[e];
            for l in 1..s {
                r[l * mf + p + e] = match self.prev {
                    Some(_) => (0..s)
                        .map(|k| extrap.1[l * s + k] * prev_f[k * m + e])
                        .sum(),
                    None => f0[e],
                };
            }
        }
    }

    /// Newton on the node forces of nodes `1..s` (`f_l = law(P z(t_n + l
    /// tau))`, the Jacobian with each node's local `df/du`, `df/dv`). Returns
    /// whether it converged (`NEWTON_RTOL` of the largest force).
    fn newton(
        &mut self,
        sys: &FirstOrderSystem,
        lv: &Level,
        z: &DVector<f64>,
        states: &[f64],
        stats: &mut IntegrationStats,
    ) -> bool {
        let (s, m, p, mf, np) = (self.s, self.m, self.p, self.mf, self.np);
        let (r, pall, res, jac) = (&mut self.r, &mut self.pall, &mut self.res, &mut self.jac);
        let node_states = &mut self.node_states;
        // known part of the projections: P e^{j tau A} z_n
        self.base.gemv_tr(1.0, &lv.pe_t, z, 0.0);
        let nu = m * (s - 1);
        let mut converged = false;
        for _ in 0..MAX_NEWTON {
            stats.newton_iterations += 1;
            let mut fscale: f64 = f64::MIN_POSITIVE;
            pall.copy_from(&self.base);
            pall.gemv_tr(1.0, &lv.pq_t, r, 1.0);
            node_states.copy_from_slice(states);
            for j in 1..s {
                let pj = (j - 1) * np;
                for e in 0..m {
                    let (fe, dfu, dfv, se) =
                        sys.element(e, node_states[e], pall[pj + e], pall[pj + m + e]);
                    node_states[e] = se;
                    stats.law_evals += 1;
                    let row = (j - 1) * m + e;
                    let cur = r[j * mf + p + e];
                    fscale = fscale.max(fe.abs()).max(cur.abs());
                    res[row] = cur - fe;
                    for l in 1..s {
                        for e2 in 0..m {
                            let col = (l - 1) * m + e2;
                            let w = l * mf + p + e2;
                            jac[row * nu + col] = if row == col { 1.0 } else { 0.0 }
                                - dfu * lv.pq_t[(w, pj + e)]
                                - dfv * lv.pq_t[(w, pj + m + e)];
                        }
                    }
                }
            }
            if !res.iter().all(|x| x.is_finite()) || !solve_in_place(jac, res, nu) {
                break;
            }
            let mut dmax: f64 = 0.0;
            for j in 1..s {
                for e in 0..m {
                    let d = res[(j - 1) * m + e];
                    r[j * mf + p + e] -= d;
                    dmax = dmax.max(d.abs());
                }
            }
            if dmax <= NEWTON_RTOL * fscale {
                converged = true;
                break;
            }
        }
        converged
    }

    /// Hysteretic elements: their states marched through the converged
    /// nodes of the accepted step (the state at its end).
    fn advance_states(&mut self, sys: &FirstOrderSystem, lv: &Level, states: &mut [f64]) {
        let (s, m, np) = (self.s, self.m, self.np);
        // the states through the converged nodes of this step
        self.pall.copy_from(&self.base);
        self.pall.gemv_tr(1.0, &lv.pq_t, &self.r, 1.0);
        for j in 1..s {
            let pj = (j - 1) * np;
            for (e, se) in states.iter_mut().enumerate() {
                *se = sys
                    .element(e, *se, self.pall[pj + e], self.pall[pj + m + e])
                    .3;
            }
        }
    }

    /// Keeps the accepted step's start `t`, node spacing `tau` and node
    /// forces for the next step's guess.
    fn accept(&mut self, t: f64, tau: f64) {
        let (s, m, p, mf) = (self.s, self.m, self.p, self.mf);
        self.prev = Some((t, tau));
        for l in 0..s {
            for e in 0..m {
                self.prev_f[l * m + e] = self.r[l * mf + p + e];
            }
        }
    }
}

/// Most step sizes whose propagators a [`Propagators`] keeps (one integration
/// over a fixed grid uses at most `MAX_LEVEL + 1`).
const MAX_CACHED: usize = MAX_LEVEL as usize + 1;

/// Propagators, step level and error scale kept across the calls of
/// [`integrate_continued`], keyed by the step size.
///
/// With `modal` set, a new step size's propagators come from the eigenvectors
/// of `A` computed once (`A = V diag(lambda) V^-1`): `e^{sigma A} = V
/// diag(e^{sigma lambda}) V^-1` and `X_k(sigma) = V diag(sigma^{k+1}
/// phi_{k+1}(sigma lambda)) V^-1 F`, scalar functions per eigenvalue instead of
/// the exponential of the augmented matrix and its powers (about ten times
/// cheaper for the paper beam's 25 + 3 states). That serves a controller
/// whose excitation period, and so the step size, changes every period. The
/// eigenvectors are checked once against the augmented exponential (entries
/// agree to 1e-9 of the largest); where they do not (a defective or
/// ill-conditioned `A`) the augmented exponential is used.
pub(crate) struct Propagators {
    d: DVector<f64>,
    modal: Option<Modal>,
    modal_checked: bool,
    levels: Vec<(f64, Level)>,
    /// Step level of the last accepted step (relative to the grid interval).
    pub level: u32,
    /// Running maximum of `|z_i|` (the error scale).
    pub zmax: Vec<f64>,
}

/// Eigen-decomposition of `A` (balanced coordinates folded back in).
struct Modal {
    lambda: Vec<Complex64>,
    /// `V` (`nz x nz`).
    v: DMatrix<Complex64>,
    /// `V^-1`.
    v_inv: DMatrix<Complex64>,
    /// `V^-1 F` (`nz x mf`).
    g: DMatrix<Complex64>,
    /// `P V` (`2m x nz`).
    pv: DMatrix<Complex64>,
}

impl Propagators {
    /// An empty cache; `modal`: build new step sizes from the eigenvectors of `A`.
    pub(crate) fn new(sys: &FirstOrderSystem, modal: bool) -> Self {
        let d = balance(&sys.a);
        let modal = if modal { Modal::new(sys, &d) } else { None };
        Self {
            d,
            modal_checked: modal.is_none(),
            modal,
            levels: Vec::new(),
            level: 0,
            zmax: Vec::new(),
        }
    }

    fn level_for(
        &mut self,
        sys: &FirstOrderSystem,
        h: f64,
        s: usize,
        stats: &mut IntegrationStats,
    ) -> &Level {
        if let Some(k) = self.levels.iter().position(|(hk, _)| *hk == h) {
            return &self.levels[k].1;
        }
        let lv = match &self.modal {
            Some(md) if !self.modal_checked => {
                let exact = build_level(sys, &self.d, h, s);
                let fast = md.level(sys, h, s);
                self.modal_checked = true;
                if !fast.agrees_with(&exact, 1e-9) {
                    self.modal = None;
                }
                exact
            }
            Some(md) => md.level(sys, h, s),
            None => build_level(sys, &self.d, h, s),
        };
        stats.propagators += 1;
        if self.levels.len() >= MAX_CACHED {
            self.levels.remove(0);
        }
        self.levels.push((h, lv));
        &self.levels.last().unwrap().1
    }
}

impl Level {
    /// Every matrix within `tol` of the other's largest entry.
    fn agrees_with(&self, other: &Level, tol: f64) -> bool {
        [
            (&self.e, &other.e),
            (&self.zw, &other.zw),
            (&self.ew, &other.ew),
            (&self.pe_t, &other.pe_t),
            (&self.pq_t, &other.pq_t),
        ]
        .iter()
        .all(|(a, b)| {
            let scale = b.amax().max(f64::MIN_POSITIVE);
            a.shape() == b.shape() && (*a - *b).amax() <= tol * scale
        })
    }
}

/// `phi_0(x) ..= phi_kmax(x)`, `phi_0 = e^x`, `phi_k(x) = sum_j x^j/(j+k)!`:
/// for `|x| < 2` the series for `phi_kmax` and the downward recurrence
/// `phi_{k-1} = x phi_k + 1/(k-1)!`; otherwise the upward recurrence
/// `phi_k = (phi_{k-1} - 1/(k-1)!)/x` (each stable in its range).
fn phi_functions(x: Complex64, kmax: usize, out: &mut [Complex64]) {
    // squared moduli: the same tests without a `hypot` per series term
    if x.norm_sqr() < 4.0 {
        let mut term = Complex64::new(1.0 / factorial(kmax), 0.0);
        let mut sum = term;
        for j in 1..60 {
            term *= x / (j + kmax) as f64;
            sum += term;
            if term.norm_sqr() <= 1e-34 * sum.norm_sqr() {
                break;
            }
        }
        out[kmax] = sum;
        for k in (1..=kmax).rev() {
            out[k - 1] = x * out[k] + 1.0 / factorial(k - 1);
        }
        out[0] = x.exp();
    } else {
        out[0] = x.exp();
        for k in 1..=kmax {
            out[k] = (out[k - 1] - 1.0 / factorial(k - 1)) / x;
        }
    }
}

impl Modal {
    /// Eigenvalues by the real Schur form, eigenvectors by inverse iteration,
    /// of the balanced `D^-1 A D`; `None` if any step fails or `V` is
    /// numerically singular.
    fn new(sys: &FirstOrderSystem, d: &DVector<f64>) -> Option<Self> {
        let nz = sys.nz();
        let m = sys.m();
        if nz == 0 {
            return None;
        }
        let a_b = DMatrix::from_fn(nz, nz, |i, j| sys.a[(i, j)] * d[j] / d[i]);
        let schur = nalgebra::linalg::Schur::try_new(a_b.clone(), 1e-14 * a_b.amax(), 10_000)?;
        let mut lambda: Vec<Complex64> = schur.complex_eigenvalues().iter().copied().collect();
        let a_c = a_b.map(|x| Complex64::new(x, 0.0));
        let scale = a_b.amax();
        let mut v_b = DMatrix::<Complex64>::zeros(nz, nz);
        #[allow(clippy::needless_range_loop)] // lambda[i] is refined in the loop
        for i in 0..nz {
            let l = lambda[i];
            let shift = l + Complex64::new(1e-10 * scale.max(l.norm()), 0.0) * 1e-3;
            let mut shifted = a_c.clone();
            for k in 0..nz {
                shifted[(k, k)] -= shift;
            }
            let lu = shifted.lu();
            let mut x = DVector::from_fn(nz, |k, _| Complex64::new(1.0 + 0.1 * k as f64, 0.3));
            for _ in 0..3 {
                x = lu.solve(&x)?;
                let nrm = x.norm();
                if !(nrm.is_finite() && nrm > 0.0) {
                    return None;
                }
                x /= Complex64::new(nrm, 0.0);
            }
            // Rayleigh quotient: the eigenvalue to the accuracy of the vector
            lambda[i] = x.dotc(&(&a_c * &x));
            v_b.set_column(i, &x);
        }
        let v_b_inv = v_b.clone().try_inverse()?;
        // residual of the decomposition, relative
        let lam = DMatrix::from_diagonal(&DVector::from_vec(lambda.clone()));
        let res = (&a_c * &v_b - &v_b * &lam)
            .iter()
            .map(|x| x.norm())
            .fold(0.0, f64::max);
        if res.is_nan() || res > 1e-10 * scale || !v_b_inv.iter().all(|x| x.is_finite()) {
            return None;
        }
        let v = DMatrix::from_fn(nz, nz, |i, j| v_b[(i, j)] * d[i]);
        let v_inv = DMatrix::from_fn(nz, nz, |i, j| v_b_inv[(i, j)] / d[j]);
        let mut f = DMatrix::<Complex64>::zeros(nz, 1 + m);
        for i in 0..nz {
            f[(i, 0)] = Complex64::new(sys.b[i], 0.0);
            for e in 0..m {
                f[(i, 1 + e)] = Complex64::new(sys.g[(i, e)], 0.0);
            }
        }
        let g = &v_inv * f;
        let pv = sys.proj.map(|x| Complex64::new(x, 0.0)) * &v;
        Some(Self {
            lambda,
            v,
            v_inv,
            g,
            pv,
        })
    }

    /// The [`Level`] of step `h` (same content as [`build_level`]).
    fn level(&self, sys: &FirstOrderSystem, h: f64, s: usize) -> Level {
        let nz = sys.nz();
        let m = sys.m();
        let mf = 1 + m;
        let np = 2 * m;
        let tau = h / (s - 1) as f64;
        let vhat = DMatrix::from_fn(s, s, |l, k| (l as f64).powi(k as i32) / factorial(k));
        let vhat_inv = vhat
            .try_inverse()
            .expect("equidistant Vandermonde is regular");
        let mut phi = vec![Complex64::new(0.0, 0.0); s + 1];
        // c[j][l][i]: weight of node value l in mode i at time j tau (all k),
        // cs: the same from k = s-1 only (error estimate, j = s-1)
        let mut c = vec![vec![vec![Complex64::new(0.0, 0.0); nz]; s]; s];
        let mut cs = vec![vec![Complex64::new(0.0, 0.0); nz]; s];
        let mut ej = vec![vec![Complex64::new(0.0, 0.0); nz]; s];
        for (i, &l) in self.lambda.iter().enumerate() {
            for j in 1..s {
                let sigma = j as f64 * tau;
                phi_functions(l * sigma, s, &mut phi);
                ej[j][i] = phi[0];
                for k in 0..s {
                    // X_k(sigma) = sigma^{k+1} phi_{k+1}(sigma lambda), times tau^-k
                    let xk = phi[k + 1] * sigma * (j as f64).powi(k as i32);
                    for ll in 0..s {
                        let w = vhat_inv[(k, ll)];
                        if w != 0.0 {
                            c[j][ll][i] += xk * w;
                            if j == s - 1 && k == s - 1 {
                                cs[ll][i] += xk * w;
                            }
                        }
                    }
                }
            }
        }
        // V diag(w) M, real part
        let scaled = |left: &DMatrix<Complex64>, w: &[Complex64], right: &DMatrix<Complex64>| {
            let mut r = right.clone();
            for (i, wi) in w.iter().enumerate() {
                for x in r.row_mut(i).iter_mut() {
                    *x *= wi;
                }
            }
            (left * r).map(|x| x.re)
        };
        let e = scaled(&self.v, &ej[s - 1], &self.v_inv);
        let weights = |cw: &[Vec<Complex64>], left: &DMatrix<Complex64>| {
            let mut w = DMatrix::zeros(left.nrows(), s * mf);
            for (l, cl) in cw.iter().enumerate() {
                w.view_mut((0, l * mf), (left.nrows(), mf))
                    .copy_from(&scaled(left, cl, &self.g));
            }
            w
        };
        let zw = weights(&c[s - 1], &self.v);
        let ew = weights(&cs, &self.v);
        let mut pe_t = DMatrix::zeros(nz, (s - 1) * np);
        let mut pq_t = DMatrix::zeros(s * mf, (s - 1) * np);
        for j in 1..s {
            let pe = scaled(&self.pv, &ej[j], &self.v_inv);
            let pq = weights(&c[j], &self.pv);
            pe_t.view_mut((0, (j - 1) * np), (nz, np))
                .copy_from(&pe.transpose());
            pq_t.view_mut((0, (j - 1) * np), (s * mf, np))
                .copy_from(&pq.transpose());
        }
        Level {
            e,
            zw,
            ew,
            pe_t,
            pq_t,
        }
    }
}
