//! The lowest eigenpairs of `K phi = lambda M phi` (`K` positive definite,
//! factorised) by block subspace iteration started from a good subspace: the
//! Craig-Bampton basis `T` of the same model.
//!
//! `T = [Psi, Phi_i]` (constraint modes and fixed-interface modes) spans the
//! lowest modes of the full model closely: the Rayleigh-Ritz vectors of
//! `(K, M)` on `T` (from the reduced `T^T K T`, `T^T M T` already computed)
//! carry the lowest frequency to some six digits, and what they miss lies
//! mostly in high modes. The start block `X` is the lowest
//! `n_modes + SUBSPACE_RITZ_MARGIN` of them and [`SUBSPACE_EXTRA`]
//! pseudo-random columns (a guard against a start deficient in a low mode).
//! Each step applies `Op = K^{-1} M` to the whole block (one solve of all
//! columns: one pass over the factor, forward and back) and takes the
//! Rayleigh-Ritz pairs of `Op` on `X` in the inverse form, as the Lanczos
//! iteration does (inner products of smooth vectors only, no product with
//! `K`, whose quadratic forms lose `eps lambda_max / lambda` to cancellation):
//!
//! ```text
//! Z = Op X,   (X^T M Z) v = mu (X^T M X) v,   lambda = 1 / mu,   y = X v,
//! residual ||y - lambda Op y||_M = ||X v - lambda Z v||_M,
//! X <- M-orthonormalised Z V diag(lambda)   (= Y + R diag(1 / mu), R M-orthogonal to Y).
//! ```
//!
//! The content of mode `k` in the Ritz vector of mode `j` shrinks by
//! `lambda_j / lambda_k` per step, so the error of mode `j` decays as
//! `lambda_j / lambda_{p+1}` (`p` columns): about `1e-3` per step for the
//! lowest mode of the plates (`p = 8`), 4 steps from the Craig-Bampton start,
//! but `0.13` for the seventh at `p = 16` (11 steps: more work than the
//! Lanczos iteration). [`cb_first`] therefore asks only for the modes the
//! result uses (`omega0` and the mode of a stiffness-proportional damping)
//! and takes the Lanczos route for all `n_modes` otherwise.
//!
//! Convergence is tested on the residual of the original problem that
//! [`super::lanczos`] verifies, in the norm of `K^{-1}` relative to `||y||_M
//! = 1`, with the solve of the step (no extra solve), against
//! [`LANCZOS_RTOL`] (`1e-12`), the tolerance of the Lanczos iteration's own
//! Ritz residual `||Op y - mu y||_M / mu` (the same quantity), below the
//! [`RESIDUAL_RTOL`] that the Lanczos route then verifies. The iteration
//! also ends at a step that does not lower the largest residual (a rounding
//! floor), after [`MAX_SUBSPACE_ITERATIONS`] steps, when its observed rate
//! cannot reach [`LANCZOS_RTOL`] within them, or when `X^T M X` is not
//! positive definite or a wanted `mu` not positive (`M` indefinite on the
//! block); its best step is then taken if every wanted residual meets
//! [`RESIDUAL_RTOL`] (the bound the Lanczos route guarantees), and otherwise
//! the caller runs the Lanczos iteration ([`SubspaceOutcome::modes`] is
//! `None`): never a less accurate result than the Lanczos route's.
//!
//! The small eigenproblems use faer's self-adjoint eigensolver: on the
//! nearly diagonal matrices of the later steps nalgebra's `SymmetricEigen`
//! returned eigenvalues out of step with its eigenvectors, and with the
//! values recomputed from the vectors the second mode's residual still
//! jumped from `2e-8` to `1e-3` in one step (1500-DOF plate); with faer all
//! residuals fall steadily.
use super::craig_bampton::{craig_bampton_sparse_with, SparseCraigBampton};
use super::lanczos::{m_norm, modes, omega_of, ModalFactor, Pencil, ShiftInvert, SparseModes};
use super::lanczos::{LANCZOS_RTOL, RESIDUAL_RTOL};
use super::sparse::{SparseMatrix, SparseOptions, Stage, StageTimings, Xorshift};
use super::Result;
use nalgebra::DMatrix;

/// The start block: the `n_modes + SUBSPACE_RITZ_MARGIN` lowest Ritz
/// vectors of `(K, M)` on `T` (at most all of `T`'s columns), plus
/// [`SUBSPACE_EXTRA`] pseudo-random columns (module docs).
pub const SUBSPACE_RITZ_MARGIN: usize = 5;

/// Pseudo-random columns added to the start block (module docs).
pub const SUBSPACE_EXTRA: usize = 2;

/// Most block steps of [`subspace_modes`] before it gives up.
pub const MAX_SUBSPACE_ITERATIONS: usize = 12;

/// The subspace iteration of the full model's modes in [`StageTimings`]:
/// the modes it was asked for (the ones the result uses), block steps done,
/// columns per step, and whether its modes were taken (if not, the Lanczos
/// iteration gave the modes and `lanczos_basis[0]` is its basis).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SubspaceStats {
    pub modes: usize,
    pub iterations: usize,
    pub columns: usize,
    pub converged: bool,
}

/// The full model's lowest modes and the Craig-Bampton reduction, from
/// [`cb_first`].
pub struct CbFirst {
    /// Natural frequencies [rad/s] ascending ([`omega_of`]).
    pub omega: Vec<f64>,
    /// Mass-normalised shapes (`n x omega.len()`).
    pub phi: DMatrix<f64>,
    /// The reduction, or its error (reported after the full model's checks,
    /// in the order of the Lanczos route).
    pub cb: Result<SparseCraigBampton>,
}

/// With `K` positive definite (`f.sigma == 0`, factorised with the
/// `masters` last): the Craig-Bampton reduction first (fixed-interface
/// modes, constraint modes, projection: [`craig_bampton_sparse_with`] on the
/// same factor), then the `wanted` lowest modes of the full pencil by
/// [`subspace_modes`] from its basis `T` (timed as [`Stage::Eigen`]). The
/// `n_modes >= wanted` lowest modes by the Lanczos iteration ([`modes`],
/// the route before, also timed as [`Stage::Eigen`]) instead when the
/// subspace iteration does not converge, when one of its modes has zero
/// frequency (rigid-body modes are counted on the Lanczos route), or when
/// the reduction failed. Errors of the full model's modes are returned
/// (shift 0); the reduction's in [`CbFirst::cb`].
#[allow(clippy::too_many_arguments)]
pub fn cb_first(
    pencil: &Pencil,
    f: &ModalFactor,
    damping: Option<&SparseMatrix>,
    masters: &[usize],
    cb_modes: usize,
    counts: (usize, usize),
    opts: &SparseOptions,
    timings: &mut StageTimings,
) -> Result<CbFirst> {
    let most = MAX_SUBSPACE_ITERATIONS;
    cb_first_with(
        pencil, f, damping, masters, cb_modes, counts, opts, timings, most,
    )
}

/// [`cb_first`] with at most `max_iterations` subspace steps.
#[allow(clippy::too_many_arguments)]
fn cb_first_with(
    pencil: &Pencil,
    f: &ModalFactor,
    damping: Option<&SparseMatrix>,
    masters: &[usize],
    cb_modes: usize,
    (wanted, n_modes): (usize, usize),
    opts: &SparseOptions,
    timings: &mut StageTimings,
    max_iterations: usize,
) -> Result<CbFirst> {
    let (m, k, factor) = (pencil.m, pencil.k, &f.factor);
    let cb = craig_bampton_sparse_with(
        m,
        k,
        damping,
        masters,
        cb_modes,
        Some(factor),
        opts,
        timings,
    );
    let outcome = match &cb {
        Ok(cb) => Some(timings.time(Stage::Eigen, opts, || {
            subspace_modes(pencil, factor, cb, wanted, SUBSPACE_EXTRA, max_iterations)
        })?),
        Err(_) => None,
    };
    timings.subspace = outcome.as_ref().map(|o| SubspaceStats {
        modes: wanted,
        iterations: o.iterations,
        columns: o.columns,
        converged: o.modes.is_some(),
    });
    let elastic = |s: &SparseModes| s.lambda.iter().all(|&l| l > 1e-12 * s.lambda_scale);
    let (omega, phi, basis) = match outcome.and_then(|o| o.modes).filter(elastic) {
        Some(modes) => (
            omega_of(&modes.lambda, modes.lambda_scale)?,
            modes.shapes,
            modes.basis,
        ),
        None => {
            if let Some(s) = &mut timings.subspace {
                s.converged = false;
            }
            timings.time(Stage::Eigen, opts, || modes(pencil, f, n_modes, "n_modes"))?
        }
    };
    timings.lanczos_basis.insert(0, basis);
    Ok(CbFirst { omega, phi, cb })
}

/// What [`subspace_modes`] found: the converged modes (`None`: not converged,
/// see the module docs), the block steps (solves of `columns` vectors) done,
/// and the largest residual of the wanted pairs at the last step.
#[derive(Debug, Clone)]
pub struct SubspaceOutcome {
    pub modes: Option<SparseModes>,
    pub iterations: usize,
    pub columns: usize,
    pub residual: f64,
}

/// The `n_modes` lowest eigenpairs of `K phi = lambda M phi` by subspace
/// iteration (module docs) from the Craig-Bampton basis `T` of `cb` (its
/// `T^T K T`, `T^T M T` the first Rayleigh-Ritz step) plus `extra`
/// pseudo-random columns, with `solver` of `K` itself (shift 0), at most
/// `max_iterations` block steps. The modes as [`super::lanczos::lanczos`]'s
/// (`lambda` ascending, mass-normalised shapes with its sign convention, the
/// verified residuals; [`SparseModes::basis`] counts the solved vectors).
/// A clearly negative `x^T M x` is
/// [`super::StructureError::MassNotPositiveDefinite`].
pub fn subspace_modes(
    pencil: &Pencil,
    solver: &dyn ShiftInvert,
    cb: &SparseCraigBampton,
    n_modes: usize,
    extra: usize,
    max_iterations: usize,
) -> Result<SubspaceOutcome> {
    let (n, nt) = (pencil.m.nrows(), cb.transform.ncols());
    let ritz_cols = (n_modes + SUBSPACE_RITZ_MARGIN).min(nt);
    let p = (ritz_cols + extra).min(n - pencil.fixed.len());
    let mut outcome = SubspaceOutcome {
        modes: None,
        iterations: 0,
        columns: p,
        residual: f64::INFINITY,
    };
    let shapes_ok = cb.transform.nrows() == n && cb.stiffness.shape() == (nt, nt);
    if n_modes == 0 || n == 0 || !shapes_ok || p < n_modes || p < ritz_cols {
        return Ok(outcome);
    }
    // the lowest Ritz vectors of (K, M) on T from the reduced matrices
    let Some((_, q)) = ritz(&cb.stiffness, &cb.mass) else {
        return Ok(outcome);
    };
    let mut x = start_block(pencil, &(&cb.transform * q.columns(0, ritz_cols)), p);
    let mut mx = pencil.mul_m(&x);
    let (m_scale, lambda_scale) = pencil.scales();
    let mut history = Vec::new();
    let mut best: Option<Best> = None;
    for it in 1..=max_iterations {
        let mut z = mx.clone();
        solver.solve_in_place(&mut z);
        pencil.mask(&mut z);
        let mz = pencil.mul_m(&z);
        outcome.iterations = it;
        // Rayleigh-Ritz of Op on span X: X^T M Op X v = mu X^T M X v
        let Some((lambda, v)) = ritz_inverse(&mx.tr_mul(&z), &x.tr_mul(&mx), n_modes) else {
            break;
        };
        let vw = v.columns(0, n_modes);
        let (y, my) = (&x * vw, &mx * vw);
        let res = residuals(
            &y,
            &my,
            &(&z * vw),
            &(&mz * vw),
            &lambda[..n_modes],
            m_scale,
        )?;
        let worst = res.iter().fold(0.0f64, |a, &r| a.max(r));
        let step = Best {
            worst,
            x: y,
            mx: my,
            lambda: lambda[..n_modes].to_vec(),
            res,
        };
        if worst <= LANCZOS_RTOL {
            best = Some(step);
            break;
        }
        // no progress: the rounding floor (module docs)
        if best.as_ref().is_some_and(|b| worst >= b.worst) {
            break;
        }
        best = Some(step);
        history.push(worst);
        if hopeless(&history, it, max_iterations) {
            break;
        }
        // the next block Op Y, M-orthonormalised in the order of the modes
        let mut vs = v;
        for (j, l) in lambda.iter().enumerate() {
            vs.column_mut(j)
                .scale_mut(if l.is_finite() { l.abs() } else { 1.0 });
        }
        let Some((w, mw)) = orthonormalize(&z * &vs, &mz * &vs) else {
            break;
        };
        x = w;
        mx = mw;
    }
    outcome.residual = best.as_ref().map_or(f64::INFINITY, |b| b.worst);
    if let Some(b) = best.filter(|b| b.worst <= RESIDUAL_RTOL) {
        let solved = p * outcome.iterations;
        outcome.modes = Some(converged(
            pencil,
            b.x,
            &b.mx,
            &b.lambda,
            b.res,
            solved,
            lambda_scale,
        ));
    }
    Ok(outcome)
}

/// The wanted Ritz pairs of one step of [`subspace_modes`] (the best so
/// far): shapes `Y`, `M Y`, eigenvalues and residuals.
struct Best {
    worst: f64,
    x: DMatrix<f64>,
    mx: DMatrix<f64>,
    lambda: Vec<f64>,
    res: Vec<f64>,
}

/// The start block `[T, R]` (`R`: `p - ncols(T)` pseudo-random columns,
/// here `T` the chosen Ritz vectors), the fixed rows zero.
fn start_block(pencil: &Pencil, t: &DMatrix<f64>, p: usize) -> DMatrix<f64> {
    let (n, nt) = t.shape();
    let mut x = DMatrix::zeros(n, p);
    x.columns_mut(0, nt).copy_from(t);
    let mut rng = Xorshift(0x9e37_79b9_7f4a_7c15);
    for c in nt..p {
        x.set_column(c, &rng.block(n, 1).column(0));
    }
    pencil.mask(&mut x);
    x
}

/// `W` `M`-orthonormalised column by column (two classical Gram-Schmidt
/// passes against the columns before, `M W` updated alongside): the first
/// columns, the lowest modes, are changed least. `None` when a column
/// vanishes (relative `1e-10`) or its `M`-norm is not positive.
fn orthonormalize(
    mut w: DMatrix<f64>,
    mut mw: DMatrix<f64>,
) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    for c in 0..w.ncols() {
        let before = w.column(c).dot(&mw.column(c));
        for _ in 0..2 {
            let s = mw.columns(0, c).tr_mul(&w.column(c));
            let (dw, dmw) = (w.columns(0, c) * &s, mw.columns(0, c) * &s);
            w.column_mut(c).axpy(-1.0, &dw, 1.0);
            mw.column_mut(c).axpy(-1.0, &dmw, 1.0);
        }
        let q = w.column(c).dot(&mw.column(c));
        if !(q > 1e-20 * before && q > 0.0) {
            return None;
        }
        let norm = q.sqrt();
        w.column_mut(c).scale_mut(1.0 / norm);
        mw.column_mut(c).scale_mut(1.0 / norm);
    }
    Some((w, mw))
}

/// Rayleigh-Ritz of `Op = K^{-1} M` on a block `X` from `h = X^T M Op X`
/// and `g = X^T M X` (both symmetrised): the eigenvalues `lambda = 1 / mu`
/// ascending (`mu` descending) and `V` with `V^T g V = I`; `None` when `g`
/// is not positive definite or one of the `n_modes` largest `mu` is not
/// positive (`M` indefinite on the block).
fn ritz_inverse(
    h: &DMatrix<f64>,
    g: &DMatrix<f64>,
    n_modes: usize,
) -> Option<(Vec<f64>, DMatrix<f64>)> {
    let (neg_mu, v) = ritz(&(-h), g)?;
    if !neg_mu.iter().take(n_modes).all(|&m| m < 0.0) {
        return None;
    }
    Some((neg_mu.iter().map(|m| -1.0 / m).collect(), v))
}

/// The converged modes: the first `lambda`s of `x` (as many as the
/// residuals `res`) with the sign convention of [`super::modal`] (the first
/// largest entry positive), their residuals (the plain one `||K x - lambda M
/// x|| / ||K x||` as [`super::lanczos`] reports it), and `solved` for
/// [`SparseModes::basis`].
fn converged(
    pencil: &Pencil,
    x: DMatrix<f64>,
    mx: &DMatrix<f64>,
    lambda: &[f64],
    res: Vec<f64>,
    solved: usize,
    lambda_scale: f64,
) -> SparseModes {
    let nm = res.len();
    let mut shapes = x.columns(0, nm).into_owned();
    let mut mx = mx.columns(0, nm).into_owned();
    for (mut col, mut mcol) in shapes.column_iter_mut().zip(mx.column_iter_mut()) {
        let amax = col.amax();
        if let Some(first) = col.iter().position(|v| v.abs() >= (1.0 - 1e-6) * amax) {
            if col[first] < 0.0 {
                col.neg_mut();
                mcol.neg_mut();
            }
        }
    }
    let kx = pencil.mul_k(&shapes);
    let residual = (0..nm)
        .map(|j| {
            let kn = kx.column(j).norm();
            let r = kx.column(j) - mx.column(j) * lambda[j];
            if kn > 0.0 {
                r.norm() / kn
            } else {
                0.0
            }
        })
        .collect();
    SparseModes {
        lambda: lambda[..nm].to_vec(),
        shapes,
        inverse_residual: res,
        residual,
        basis: solved,
        lambda_scale,
    }
}

/// `||x_j - lambda_j z_j||_M` of the wanted pairs (`z = K^{-1} M x`, `mx`
/// and `mz` their products with `M`): the residual [`super::lanczos`]
/// verifies, here with `M x`, `M z` known; a clearly negative square
/// proves `M` indefinite ([`m_norm`]).
fn residuals(
    x: &DMatrix<f64>,
    mx: &DMatrix<f64>,
    z: &DMatrix<f64>,
    mz: &DMatrix<f64>,
    lambda: &[f64],
    m_scale: f64,
) -> Result<Vec<f64>> {
    lambda
        .iter()
        .enumerate()
        .map(|(j, &l)| {
            let r = x.column(j) - z.column(j) * l;
            let mr = mx.column(j) - mz.column(j) * l;
            m_norm(r.dot(&mr), r.norm_squared(), m_scale)
        })
        .collect()
}

/// Whether the residual history (one per step) shows the iteration cannot
/// reach [`LANCZOS_RTOL`] within `max_iterations`: after three steps, the
/// rate of the last one extrapolated, or no progress (a rounding floor).
fn hopeless(history: &[f64], it: usize, max_iterations: usize) -> bool {
    let k = history.len();
    if k < 3 {
        return false;
    }
    let rate = history[k - 1] / history[k - 2];
    if rate.is_nan() || rate >= 0.9 {
        return true;
    }
    let needed = (LANCZOS_RTOL / history[k - 1]).ln() / rate.ln();
    it as f64 + needed > max_iterations as f64 + 1.0
}

/// The small symmetric pencil `kr q = lambda mr q` (both symmetrised) of a
/// Rayleigh-Ritz step on a block `X` (`kr = X^T K X`, `mr = X^T M X` for
/// `(K, M)` on `T`; `-X^T M Op X`, `X^T M X` for [`ritz_inverse`]): `lambda`
/// ascending and `Q` with `Q^T mr Q = I`, `Q^T kr Q = diag(lambda)`. The
/// columns are scaled to unit `M`-norm first. `None` when `mr` is not
/// positive definite (`M` indefinite on the block, or dependent columns).
fn ritz(kr: &DMatrix<f64>, mr: &DMatrix<f64>) -> Option<(Vec<f64>, DMatrix<f64>)> {
    let p = kr.nrows();
    let s: Vec<f64> = (0..p).map(|i| 1.0 / mr[(i, i)].sqrt()).collect();
    if s.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let scaled = |a: &DMatrix<f64>| {
        DMatrix::from_fn(p, p, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]) * s[i] * s[j])
    };
    let (kr, mr) = (scaled(kr), scaled(mr));
    let l = mr.cholesky()?.l();
    // A = L^{-1} K_r L^{-T}
    let lk = l.solve_lower_triangular(&kr)?;
    let a = l.solve_lower_triangular(&lk.transpose())?;
    let a = DMatrix::from_fn(p, p, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    // faer's eigensolver (values ascending, matched to the vectors): nalgebra's
    // SymmetricEigen returned values out of step with the vectors on a
    // nearly diagonal `A`, as the blocks here become
    let evd = faer::Mat::<f64>::from_fn(p, p, |i, j| a[(i, j)])
        .self_adjoint_eigen(faer::Side::Lower)
        .ok()?;
    let (sv, u) = (evd.S().column_vector(), evd.U());
    let values: Vec<f64> = (0..p).map(|j| sv[j]).collect();
    if values.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let v = DMatrix::from_fn(p, p, |i, j| u[(i, j)]);
    let mut q = l.transpose().solve_upper_triangular(&v)?;
    for (i, si) in s.iter().enumerate() {
        q.row_mut(i).scale_mut(*si);
    }
    Some((values, q))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::structure::lanczos::lanczos;
    use crate::structure::ordering::Ordering;
    use crate::structure::solid::HexPlate;
    use crate::structure::sparse::{SparseCholesky, SymbolicFactor};
    use faer::Par;

    /// The benchmark plate at about 1500 DOFs, its factor of `K` with the
    /// masters (tip and drive, transverse, as the benchmark) last, and the
    /// masters.
    fn plate() -> (SparseMatrix, SparseMatrix, ModalFactor, Vec<usize>) {
        let p = HexPlate::benchmark(1500);
        let (m, k) = p.assemble().unwrap();
        let masters = vec![
            p.dof(p.nx, p.ny / 2, p.nz, 2).unwrap(),
            p.dof(2 * p.nx / 3, p.ny / 2, p.nz, 2).unwrap(),
        ];
        let sym = SymbolicFactor::with_last(&k, Ordering::Amd, &masters).unwrap();
        let factor = SparseCholesky::with_symbolic(&sym, &k, Par::Seq).unwrap();
        (m, k, ModalFactor { factor, sigma: 0.0 }, masters)
    }

    /// The free pencil `(M, K)`, sequential.
    fn free<'a>(m: &'a SparseMatrix, k: &'a SparseMatrix) -> Pencil<'a> {
        Pencil {
            m,
            k,
            fixed: &[],
            par: Par::Seq,
        }
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    /// The lowest modes from the Craig-Bampton basis equal the Lanczos
    /// iteration's: eigenvalues to 1e-12 relative, shapes (same sign
    /// convention) to 1e-9 of their largest entry, the verified residual
    /// below `RESIDUAL_RTOL`; the seventh mode too (more steps).
    #[test]
    fn subspace_modes_equal_the_lanczos_modes() {
        let (m, k, f, masters) = plate();
        let pencil = free(&m, &k);
        let opts = SparseOptions::default();
        let mut t = StageTimings::default();
        let cb =
            craig_bampton_sparse_with(&m, &k, None, &masters, 10, Some(&f.factor), &opts, &mut t)
                .unwrap();
        let lz = lanczos(&pencil, &f.factor, 0.0, 7, "n_modes").unwrap();
        for wanted in [1, 3, 7] {
            let o = subspace_modes(&pencil, &f.factor, &cb, wanted, SUBSPACE_EXTRA, 30).unwrap();
            let s = o
                .modes
                .unwrap_or_else(|| panic!("{wanted}: {} steps, {:e}", o.iterations, o.residual));
            assert_eq!(s.lambda.len(), wanted);
            assert_eq!(o.columns, (wanted + 5).min(12) + SUBSPACE_EXTRA);

            for j in 0..wanted {
                let e = rel(s.lambda[j], lz.lambda[j]);
                assert!(e < 1e-12, "mode {j} of {wanted}: {e:e}");
                assert!(s.inverse_residual[j] <= RESIDUAL_RTOL);
                let d = (s.shapes.column(j) - lz.shapes.column(j)).amax();
                assert!(d < 1e-9 * lz.shapes.column(j).amax(), "shape {j}: {d:e}");
            }
            if wanted == 1 {
                assert!(o.iterations <= 5, "{} steps", o.iterations);
            }
        }
    }

    /// `cb_first` takes the subspace modes when they converge (equal to the
    /// Lanczos route's to 1e-12) and falls back to the Lanczos iteration,
    /// with `n_modes` modes, when they do not within the bound.
    #[test]
    fn cb_first_falls_back_to_lanczos() {
        let (m, k, f, masters) = plate();
        let pencil = free(&m, &k);
        let opts = SparseOptions::default();
        let (omega_lz, _, basis_lz) = modes(&pencil, &f, 7, "n_modes").unwrap();
        let run = |most| {
            let mut t = StageTimings::default();
            let r = cb_first_with(&pencil, &f, None, &masters, 10, (1, 7), &opts, &mut t, most);
            (r.unwrap(), t)
        };
        let (fast, t) = run(MAX_SUBSPACE_ITERATIONS);
        let s = t.subspace.clone().unwrap();
        assert!(s.converged && s.modes == 1 && s.iterations >= 1);
        assert_eq!(fast.omega.len(), 1);
        assert!(rel(fast.omega[0], omega_lz[0]) < 1e-12);
        assert_eq!(
            t.lanczos_basis,
            vec![s.iterations * s.columns, t.lanczos_basis[1]]
        );
        fast.cb.unwrap();
        // one step cannot converge: the Lanczos route, all 7 modes
        let (slow, t) = run(1);
        let s = t.subspace.unwrap();
        assert!(!s.converged && s.iterations == 1, "{s:?}");
        assert_eq!(slow.omega, omega_lz);
        assert_eq!(t.lanczos_basis[0], basis_lz);
        assert!(t.eigen_s > 0.0);
    }
}
