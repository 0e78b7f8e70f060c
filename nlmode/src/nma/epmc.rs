//! Harmonic Balance residuals in modal coordinates and their condensed
//! (Schur-complement) linear solver.
//!
//! The generalized coordinates are expanded in all mass-normalized linear modes
//! of the underlying undamped structure, `q = Phi eta` (`Phi^T M Phi = I`,
//! `Phi^T K Phi = diag(omega_k^2)`); this is exact (no truncation). The
//! Fourier coefficients of `eta` are stored harmonic-component major,
//! `X[h n + k]` = coefficient `h` (layout of [`super::hb::cos_index`]) of mode `k`.
//!
//! **EPMC** (`eq:EPMC`, `M q'' - 2 D omega M q' + C q' + K q + f_nl(q, q') = 0`)
//! with `q = a Psi`: per harmonic `n` and mode `k`, with `A = omega_k^2 - (n omega)^2`
//! and `B = n omega (C_m - 2 D omega I)` (`C_m = Phi^T C Phi`),
//!
//! ```text
//! R_c = A Psi_c + B Psi_s + (1/a) W F_c(a W^T Psi),
//! R_s = -B Psi_c + A Psi_s + (1/a) W F_s(a W^T Psi),
//! ```
//!
//! (the complex form `(K - (n omega)^2 M + i n omega (C - 2 D omega M)) q_n + f_n = 0`),
//! closed by the amplitude normalization `Psi_1^H Psi_1 = 1`, i.e.
//! `a = sqrt(q_1^H M q_1)` (Section 3.1), and the phase normalization
//! `Im(Psi_{1,j}) = 0` on the continued mode `j`. Unknowns
//! `X = [Psi; omega; D; log10 a]`; `log10 a` is the continuation parameter.
//! Here `W = Phi^T [w_1 ... w_E]` holds the nonlinear elements' directions.
//!
//! **Forced response** `M q'' + C q' + K q + f_nl = f cos(Omega t)` with
//! unknowns `X = [eta; Omega]`.
//!
//! **Condensation.** The linear part is block diagonal (2x2 per mode and
//! harmonic when `C_m` is diagonal, e.g. Rayleigh damping); the nonlinear part
//! is `P G P^T` with `P = I (x) W`. Newton systems bordered with the extra
//! unknowns and rows are solved by eliminating all well-conditioned modal
//! blocks (`|A + iB|` not small) and keeping explicitly the nonlinear
//! coordinates `z = G P^T y` (`E (2H+1)` of them), the near-resonant modal
//! blocks (always the continued mode's fundamental, plus any `n omega ~ omega_k`
//! internal resonance) and the bordered unknowns. The dense system left has
//! size `E(2H+1) + #near-resonant + #border`, independent of the model size;
//! forming it costs `O(n H (E^2 + #border))`. Non-diagonal modal damping falls
//! back to a dense solve of the full system.
use super::continuation::{BorderedFactor, BorderedSolve};
use super::hb::{cos_index, harmonic_of, sin_index, Aft};
use super::NmaError;
use crate::structure::{NonlinearLaw, StructuralModel};
use nalgebra::{DMatrix, DVector};
use std::f64::consts::LN_10;
use std::sync::Arc;

/// Most Rayleigh-quotient iterations of [`EpmcResidual::linearised_guess`].
pub const LINEARISED_GUESS_ITERATIONS: usize = 50;

/// Most modes for which [`EpmcResidual::linearised_guess`] solves the dense
/// complex eigenproblem (`O(n^3)` per iteration); above, the undamped linear
/// mode is the start.
pub const LINEARISED_GUESS_MAX_MODES: usize = 400;

/// Relative size of `|A + iB|` below which a modal block is kept explicitly.
const EXPLICIT_THRESHOLD: f64 = 0.05;

/// Linear modes of the structure and the nonlinear directions in modal coordinates.
#[derive(Debug, Clone)]
pub struct ModalBasis {
    /// Mass-normalized mode shapes (columns), ascending frequency.
    pub phi: DMatrix<f64>,
    /// Squared natural frequencies `omega_k^2` [rad^2/s^2].
    pub omega2: DVector<f64>,
    /// Modal damping matrix `Phi^T C Phi` [1/s] (zero if conservative).
    pub cm: DMatrix<f64>,
    /// Whether `cm` is diagonal (the condensed solver applies).
    pub diagonal_damping: bool,
    /// Nonlinear directions in modal coordinates, `n x E`.
    pub w: DMatrix<f64>,
    /// Nonlinear force laws, one per column of `w`.
    pub laws: Vec<Arc<dyn NonlinearLaw>>,
    /// Whether the damping was dropped (`cm = 0`).
    pub conservative: bool,
}

impl ModalBasis {
    /// All linear modes of `(M, K)`; `C` projected (or dropped if `conservative`).
    ///
    /// Mode signs: the first named point (else the first nonlinear direction,
    /// else the largest entry) moves in the positive direction.
    pub fn new(model: &StructuralModel, conservative: bool) -> Result<Self, NmaError> {
        let n = model.mass.nrows();
        assert_eq!(model.mass.shape(), (n, n), "mass matrix must be square");
        assert_eq!(
            model.stiffness.shape(),
            (n, n),
            "stiffness matrix must be n x n"
        );
        assert_eq!(
            model.damping.shape(),
            (n, n),
            "damping matrix must be n x n"
        );
        if nalgebra::Cholesky::new(model.mass.clone()).is_none() {
            return Err(NmaError::MassNotPositiveDefinite);
        }
        let (omega2, mut phi) = match nalgebra::Cholesky::new(model.stiffness.clone()) {
            Some(ck) => flexibility_modes(&model.mass, &ck.l()),
            None => stiffness_modes(&model.mass, &model.stiffness),
        };
        let reference: Option<&DVector<f64>> = model
            .points
            .first()
            .map(|p| &p.direction)
            .or_else(|| model.nonlinear.first().map(|e| &e.direction));
        for k in 0..n {
            let col = phi.column(k).clone_owned();
            let mut s = reference.map(|e| e.dot(&col)).unwrap_or(0.0);
            let tol = 1e-9 * col.amax() * reference.map(|e| e.norm()).unwrap_or(0.0);
            if s.abs() <= tol {
                let imax = col.iamax();
                s = col[imax];
            }
            if s < 0.0 {
                phi.column_mut(k).neg_mut();
            }
        }
        let cm = if conservative {
            DMatrix::zeros(n, n)
        } else {
            let cm = phi.transpose() * &model.damping * &phi;
            (&cm + cm.transpose()) * 0.5
        };
        // Off-diagonal modal damping counts if it exceeds both a relative
        // 1e-9 of the diagonal and the rounding level of Phi^T C Phi (about
        // eps times the largest modal damping; a fine FE mesh has
        // omega_max^2 / omega_1^2 ~ 1e10, so C = beta K is not diagonal to
        // much better than that in floating point).
        let c_max = (0..n).map(|k| cm[(k, k)].abs()).fold(0.0, f64::max);
        let mut diagonal_damping = true;
        for i in 0..n {
            for j in 0..n {
                if i != j {
                    let bound = (1e-9 * (cm[(i, i)].abs() * cm[(j, j)].abs()).sqrt())
                        .max(1e4 * f64::EPSILON * c_max);
                    if cm[(i, j)].abs() > bound {
                        diagonal_damping = false;
                    }
                }
            }
        }
        let ne = model.nonlinear.len();
        let mut w = DMatrix::zeros(n, ne);
        for (e, el) in model.nonlinear.iter().enumerate() {
            assert_eq!(
                el.direction.len(),
                n,
                "nonlinear direction '{}' has wrong length",
                el.name
            );
            w.set_column(e, &(phi.transpose() * &el.direction));
        }
        let laws = model.nonlinear.iter().map(|e| e.law.clone()).collect();
        Ok(Self {
            phi,
            omega2,
            cm,
            diagonal_damping,
            w,
            laws,
            conservative,
        })
    }

    pub fn n_modes(&self) -> usize {
        self.omega2.len()
    }

    /// Natural frequency of mode `k` [rad/s].
    pub fn omega(&self, k: usize) -> f64 {
        self.omega2[k].max(0.0).sqrt()
    }

    /// Linear modal damping ratio of mode `k`, `c_kk / (2 omega_k)`.
    pub fn damping_ratio(&self, k: usize) -> f64 {
        self.cm[(k, k)] / (2.0 * self.omega(k))
    }

    /// Row scales of the harmonic residual: `max(omega_k^2, (n omega_ref)^2)`.
    fn row_scale(&self, harmonics: usize, omega_ref: f64) -> DVector<f64> {
        let n = self.n_modes();
        let nh = 2 * harmonics + 1;
        let mut s = DVector::zeros(n * nh);
        for h in 0..nh {
            let nn = harmonic_of(h) as f64;
            for k in 0..n {
                s[h * n + k] = self.omega2[k]
                    .abs()
                    .max((nn * omega_ref).powi(2))
                    .max(1e-300);
            }
        }
        s
    }

    /// `Y = B_n X` per mode for `B_n = n omega (C_m - 2 D omega I)`, `x` one component block.
    fn apply_b(&self, nn: f64, omega: f64, d: f64, x: &[f64], out: &mut [f64]) {
        let n = self.n_modes();
        if self.diagonal_damping {
            for k in 0..n {
                out[k] = nn * omega * (self.cm[(k, k)] - 2.0 * d * omega) * x[k];
            }
        } else {
            let xv = DVector::from_column_slice(x);
            let cx = &self.cm * xv;
            for k in 0..n {
                out[k] = nn * omega * (cx[k] - 2.0 * d * omega * x[k]);
            }
        }
    }

    /// Relative displacement harmonics `U_e = scale * W_e^T X` of every element.
    fn element_coeffs(&self, x: &[f64], nh: usize, scale: f64) -> Vec<DVector<f64>> {
        let n = self.n_modes();
        (0..self.w.ncols())
            .map(|e| {
                let we = self.w.column(e);
                DVector::from_fn(nh, |h, _| {
                    scale * (0..n).map(|k| we[k] * x[h * n + k]).sum::<f64>()
                })
            })
            .collect()
    }
}

/// All modes from the flexibility form `B = L_K^-1 M L_K^-T`, `K = L_K L_K^T`:
/// `B u = (1/omega^2) u`, `phi = L_K^-T u / sqrt(mu)`. A dense eigensolver has
/// an absolute eigenvalue error of about `eps max(mu)`, so the low modes (large
/// `mu = 1/omega^2`) come out to machine precision even on fine FE meshes
/// where `omega_max^2 / omega_1^2 ~ 1e14` (the stiffness form would lose
/// `omega_1` there). The highest modes of such meshes are not resolved
/// (`mu` at rounding level): their `mu` is floored at `1e3 eps max(mu)`,
/// which keeps their quasi-static flexibility `phi phi^T / omega^2 =
/// L_K^-T u u^T L_K^-1` exact and only misstates their negligible inertia.
fn flexibility_modes(m: &DMatrix<f64>, lk: &DMatrix<f64>) -> (DVector<f64>, DMatrix<f64>) {
    let n = m.nrows();
    let linv_m = lk
        .solve_lower_triangular(m)
        .expect("Cholesky factor is regular");
    let b = lk
        .solve_lower_triangular(&linv_m.transpose())
        .expect("Cholesky factor is regular");
    let b = (&b + b.transpose()) * 0.5;
    let eig = nalgebra::SymmetricEigen::new(b);
    let mu_max = eig.eigenvalues.max();
    let floor = 1e3 * f64::EPSILON * mu_max;
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let mut u = DMatrix::zeros(n, n);
    let mut omega2 = DVector::zeros(n);
    for (c, &i) in order.iter().enumerate() {
        let mu = eig.eigenvalues[i].max(floor);
        u.set_column(c, &(eig.eigenvectors.column(i) / mu.sqrt()));
        omega2[c] = 1.0 / mu;
    }
    let phi = lk
        .transpose()
        .solve_upper_triangular(&u)
        .expect("Cholesky factor is regular");
    (omega2, phi)
}

/// All modes from `A = L_M^-1 K L_M^-T` (used when `K` is singular, e.g. free
/// structures); low modes carry an absolute error of `eps omega_max^2`.
fn stiffness_modes(m: &DMatrix<f64>, k: &DMatrix<f64>) -> (DVector<f64>, DMatrix<f64>) {
    let n = m.nrows();
    let l = nalgebra::Cholesky::new(m.clone())
        .expect("mass checked positive definite")
        .l();
    let linv_k = l
        .solve_lower_triangular(k)
        .expect("Cholesky factor is regular");
    let a = l
        .solve_lower_triangular(&linv_k.transpose())
        .expect("Cholesky factor is regular");
    let a = (&a + a.transpose()) * 0.5;
    let eig = nalgebra::SymmetricEigen::new(a);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let mut v = DMatrix::zeros(n, n);
    let mut omega2 = DVector::zeros(n);
    for (c, &i) in order.iter().enumerate() {
        v.set_column(c, &eig.eigenvectors.column(i));
        omega2[c] = eig.eigenvalues[i];
    }
    let phi = l
        .transpose()
        .solve_upper_triangular(&v)
        .expect("Cholesky factor is regular");
    (omega2, phi)
}

/// Structured Jacobian of a modal Harmonic Balance residual (see module doc):
/// rows `0..m` (scaled by `1/row_scale`) are the harmonic equations, then `r`
/// extra residual rows; columns are the `m` modal coefficients and `p = r + 1`
/// extra unknowns.
#[derive(Debug, Clone)]
pub struct HbJacobian {
    basis: Arc<ModalBasis>,
    harmonics: usize,
    omega: f64,
    d: f64,
    /// `dF_e/dU_e` of each element.
    g: Vec<DMatrix<f64>>,
    row_scale: Arc<DVector<f64>>,
    /// Unscaled derivatives of the harmonic rows w.r.t. the extra unknowns, `m x p`.
    border_cols: DMatrix<f64>,
    /// Extra residual rows, `r x (m + p)`.
    border_rows: DMatrix<f64>,
    /// Modal blocks `(k, n)` always kept explicit.
    explicit: Vec<(usize, usize)>,
}

/// The real coefficient indices of harmonic `nn`: the mean alone, or its
/// cosine and sine.
#[derive(Clone, Copy)]
struct Components {
    idx: [usize; 2],
    len: usize,
}

impl Components {
    fn as_slice(&self) -> &[usize] {
        &self.idx[..self.len]
    }
}

fn components(nn: usize) -> Components {
    if nn == 0 {
        Components {
            idx: [0, 0],
            len: 1,
        }
    } else {
        Components {
            idx: [cos_index(nn), sin_index(nn)],
            len: 2,
        }
    }
}

impl HbJacobian {
    fn m(&self) -> usize {
        self.basis.n_modes() * (2 * self.harmonics + 1)
    }

    /// `A`, `B` of the diagonal modal block `(k, nn)`.
    fn block(&self, k: usize, nn: usize) -> (f64, f64) {
        let nf = nn as f64;
        let a = self.basis.omega2[k] - (nf * self.omega).powi(2);
        let b = nf * self.omega * (self.basis.cm[(k, k)] - 2.0 * self.d * self.omega);
        (a, b)
    }

    /// The full (scaled) Jacobian as a dense matrix, `(m + r) x (m + p)`.
    pub fn to_dense(&self) -> DMatrix<f64> {
        let ju = self.dense_unscaled_harmonic_rows();
        let m = self.m();
        let (r, p) = (self.border_rows.nrows(), self.border_cols.ncols());
        let mut j = DMatrix::zeros(m + r, m + p);
        for i in 0..m {
            for c in 0..m + p {
                j[(i, c)] = ju[(i, c)] / self.row_scale[i];
            }
        }
        j.view_mut((m, 0), (r, m + p)).copy_from(&self.border_rows);
        j
    }

    /// Unscaled harmonic rows `m x (m + p)`.
    fn dense_unscaled_harmonic_rows(&self) -> DMatrix<f64> {
        let n = self.basis.n_modes();
        let nh = 2 * self.harmonics + 1;
        let m = n * nh;
        let p = self.border_cols.ncols();
        let mut j = DMatrix::zeros(m, m + p);
        let mut col = vec![0.0; n];
        let mut out = vec![0.0; n];
        for nn in 0..=self.harmonics {
            let nf = nn as f64;
            let hc = cos_index(nn);
            for k in 0..n {
                j[(hc * n + k, hc * n + k)] = self.basis.omega2[k] - (nf * self.omega).powi(2);
            }
            if nn == 0 {
                continue;
            }
            let hs = sin_index(nn);
            for k in 0..n {
                j[(hs * n + k, hs * n + k)] = self.basis.omega2[k] - (nf * self.omega).powi(2);
            }
            for kk in 0..n {
                col.iter_mut().for_each(|v| *v = 0.0);
                col[kk] = 1.0;
                self.basis.apply_b(nf, self.omega, self.d, &col, &mut out);
                for k in 0..n {
                    j[(hc * n + k, hs * n + kk)] += out[k];
                    j[(hs * n + k, hc * n + kk)] -= out[k];
                }
            }
        }
        for (e, g) in self.g.iter().enumerate() {
            let we = self.basis.w.column(e);
            for h in 0..nh {
                for h2 in 0..nh {
                    let gv = g[(h, h2)];
                    if gv == 0.0 {
                        continue;
                    }
                    for k in 0..n {
                        for k2 in 0..n {
                            j[(h * n + k, h2 * n + k2)] += we[k] * gv * we[k2];
                        }
                    }
                }
            }
        }
        j.view_mut((0, m), (m, p)).copy_from(&self.border_cols);
        j
    }

    /// The dense bordered matrix `[J; border rows; row]` with unscaled harmonic
    /// rows, factored (the fallback for non-diagonal modal damping).
    fn factor_dense(&self, row: &DVector<f64>) -> Option<HbFactor> {
        let m = self.m();
        let (r, p) = (self.border_rows.nrows(), self.border_cols.ncols());
        let mut a = DMatrix::zeros(m + p, m + p);
        a.view_mut((0, 0), (m, m + p))
            .copy_from(&self.dense_unscaled_harmonic_rows());
        a.view_mut((m, 0), (r, m + p)).copy_from(&self.border_rows);
        a.row_mut(m + r).copy_from(&row.transpose());
        let lu = a.lu();
        lu.is_invertible().then(|| HbFactor::Dense {
            lu,
            row_scale: self.row_scale.clone(),
        })
    }

    /// The condensed factorisation (diagonal modal damping, see the module
    /// doc): the modal blocks' inverses, `V_B = Lambda_II^-1 B_I` and the LU
    /// of the reduced system in `[y_E; z; y_b]`; the right-hand side enters
    /// only in [`CondensedFactor::solve`].
    fn factor_condensed(&self, row: &DVector<f64>) -> Option<HbFactor> {
        let basis = &*self.basis;
        let n = basis.n_modes();
        let hmax = self.harmonics;
        let nh = 2 * hmax + 1;
        let m = n * nh;
        let ne = basis.w.ncols();
        let s = ne * nh;
        let (r, p) = (self.border_rows.nrows(), self.border_cols.ncols());
        debug_assert_eq!(r + 1, p);
        let w = &basis.w;
        // border rows incl. the continuation row: p x (m + p)
        let mut cfull = DMatrix::zeros(p, m + p);
        cfull
            .view_mut((0, 0), (r, m + p))
            .copy_from(&self.border_rows);
        cfull.row_mut(r).copy_from(&row.transpose());

        // the modal blocks (A, B) by `nn n + k`; classify them, explicit
        // components in order
        let mut blocks = Vec::with_capacity((hmax + 1) * n);
        let mut explicit_block = vec![false; (hmax + 1) * n];
        let mut e_list: Vec<usize> = Vec::new(); // global component indices
        for nn in 0..=hmax {
            for k in 0..n {
                let (a, b) = self.block(k, nn);
                blocks.push((a, b));
                let scale = self.row_scale[cos_index(nn) * n + k];
                let forced = self.explicit.contains(&(k, nn));
                if forced || a.hypot(b) < EXPLICIT_THRESHOLD * scale {
                    explicit_block[nn * n + k] = true;
                    for &h in components(nn).as_slice() {
                        e_list.push(h * n + k);
                    }
                }
            }
        }
        let ne_e = e_list.len();
        // V_B = Lambda_II^-1 B_I  (m x p), Q, CLP
        let mut v_b: DMatrix<f64> = DMatrix::zeros(m, p);
        let mut q: DMatrix<f64> = DMatrix::zeros(s, s);
        let mut clp: DMatrix<f64> = DMatrix::zeros(p, s);
        let src = &self.border_cols;
        for nn in 0..=hmax {
            let comps = components(nn);
            let comps = comps.as_slice();
            for k in 0..n {
                if explicit_block[nn * n + k] {
                    continue;
                }
                let linv = block_inverse(blocks[nn * n + k], nn);
                let nc = comps.len();
                for col in 0..p {
                    for (ia, &ha) in comps.iter().enumerate() {
                        let mut acc = 0.0;
                        for (ib, &hb) in comps.iter().enumerate() {
                            acc += linv[ia][ib] * src[(hb * n + k, col)];
                        }
                        v_b[(ha * n + k, col)] = acc;
                    }
                }
                for ia in 0..nc {
                    for ib in 0..nc {
                        let l = linv[ia][ib];
                        for e in 0..ne {
                            let wl = w[(k, e)] * l;
                            for e2 in 0..ne {
                                q[(e * nh + comps[ia], e2 * nh + comps[ib])] += wl * w[(k, e2)];
                            }
                        }
                        for rr in 0..p {
                            let cl = cfull[(rr, comps[ia] * n + k)] * l;
                            if cl != 0.0 {
                                for e2 in 0..ne {
                                    clp[(rr, e2 * nh + comps[ib])] += cl * w[(k, e2)];
                                }
                            }
                        }
                    }
                }
            }
        }
        // P^T V_B (s x p) and C V_B (p x p), V_B is zero on explicit rows
        let ptv = p_transpose(w, &v_b, nh);
        let cv = cfull.columns(0, m) * &v_b;

        // reduced system [y_E; z; y_b]
        let dim = ne_e + s + p;
        let mut a: DMatrix<f64> = DMatrix::zeros(dim, dim);
        let mut e_pos = vec![usize::MAX; m];
        for (i, &gi) in e_list.iter().enumerate() {
            e_pos[gi] = i;
        }
        for (i, &gi) in e_list.iter().enumerate() {
            let h = gi / n;
            let k = gi % n;
            let nn = harmonic_of(h);
            let (la, lb) = blocks[nn * n + k];
            a[(i, i)] = la;
            if nn > 0 {
                if h == cos_index(nn) {
                    a[(i, e_pos[sin_index(nn) * n + k])] = lb;
                } else {
                    a[(i, e_pos[cos_index(nn) * n + k])] = -lb;
                }
            }
            for e in 0..ne {
                a[(i, ne_e + e * nh + h)] = w[(k, e)];
            }
            for c in 0..p {
                a[(i, ne_e + s + c)] = self.border_cols[(gi, c)];
            }
        }
        // the explicit components by harmonic component `h`, in `e_list` order:
        // `e_by_h[e_start[h]..e_start[h + 1]]` holds `(position in e_list, mode)`
        let mut e_start = vec![0usize; nh + 1];
        for &gi in &e_list {
            e_start[gi / n + 1] += 1;
        }
        for h in 0..nh {
            e_start[h + 1] += e_start[h];
        }
        let mut e_fill = e_start.clone();
        let mut e_by_h = vec![(0usize, 0usize); ne_e];
        for (i, &gi) in e_list.iter().enumerate() {
            let h = gi / n;
            e_by_h[e_fill[h]] = (i, gi % n);
            e_fill[h] += 1;
        }
        for (e, g) in self.g.iter().enumerate() {
            for h in 0..nh {
                let ri = ne_e + e * nh + h;
                a[(ri, ri)] += 1.0;
                for h2 in 0..nh {
                    let gv = g[(h, h2)];
                    if gv == 0.0 {
                        continue;
                    }
                    // Q couples only the two components of one harmonic
                    let comps2 = components(harmonic_of(h2));
                    for e2 in 0..ne {
                        for &hz in comps2.as_slice() {
                            let cz = e2 * nh + hz;
                            a[(ri, ne_e + cz)] += gv * q[(e * nh + h2, cz)];
                        }
                    }
                    for &(i, k) in &e_by_h[e_start[h2]..e_start[h2 + 1]] {
                        a[(ri, i)] -= gv * w[(k, e)];
                    }
                    for c in 0..p {
                        a[(ri, ne_e + s + c)] += gv * ptv[(e * nh + h2, c)];
                    }
                }
            }
        }
        for rr in 0..p {
            let ri = ne_e + s + rr;
            for (i, &gi) in e_list.iter().enumerate() {
                a[(ri, i)] = cfull[(rr, gi)];
            }
            for cz in 0..s {
                a[(ri, ne_e + cz)] = -clp[(rr, cz)];
            }
            for c in 0..p {
                a[(ri, ne_e + s + c)] = cfull[(rr, m + c)] - cv[(rr, c)];
            }
        }
        let lu = a.lu();
        if !lu.is_invertible() {
            return None;
        }
        Some(HbFactor::Condensed(Box::new(CondensedFactor {
            basis: self.basis.clone(),
            harmonics: hmax,
            g: self.g.clone(),
            row_scale: self.row_scale.clone(),
            blocks,
            explicit_block,
            e_list,
            v_b,
            cfull,
            lu,
        })))
    }

    /// Solve with the dense fallback even when the condensed solver applies
    /// (for cross-checks and benchmarks).
    pub fn solve_bordered_dense(
        &self,
        row: &DVector<f64>,
        rhs: &DVector<f64>,
    ) -> Option<DVector<f64>> {
        self.factor_dense(row)?.solve(rhs)
    }
}

/// The inverse of the modal block `[[A, B], [-B, A]]` of harmonic `nn >= 1`
/// (`1/A` for the mean, `nn = 0`).
fn block_inverse((a, b): (f64, f64), nn: usize) -> [[f64; 2]; 2] {
    if nn == 0 {
        [[1.0 / a, 0.0], [0.0, 0.0]]
    } else {
        let det = a * a + b * b;
        [[a / det, -b / det], [b / det, a / det]]
    }
}

/// `P^T V`: `(e nh + h, c)` = `sum_k W[k, e] V[h n + k, c]` (`nh x ncols` per element).
fn p_transpose(w: &DMatrix<f64>, v: &DMatrix<f64>, nh: usize) -> DMatrix<f64> {
    let (n, ne) = w.shape();
    let mut ptv = DMatrix::zeros(ne * nh, v.ncols());
    for e in 0..ne {
        for h in 0..nh {
            for col in 0..v.ncols() {
                let mut acc = 0.0;
                for k in 0..n {
                    acc += w[(k, e)] * v[(h * n + k, col)];
                }
                ptv[(e * nh + h, col)] = acc;
            }
        }
    }
    ptv
}

/// A factored bordered [`HbJacobian`] ([`BorderedSolve::factor_bordered`]).
#[derive(Debug, Clone)]
pub enum HbFactor {
    /// LU of the full system with unscaled harmonic rows (non-diagonal modal damping).
    Dense {
        lu: nalgebra::linalg::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
        row_scale: Arc<DVector<f64>>,
    },
    /// The condensed factorisation (diagonal modal damping).
    Condensed(Box<CondensedFactor>),
}

/// The condensed factorisation of a bordered [`HbJacobian`] (module doc):
/// for a right-hand side `[f; f_b]`, `V_f = Lambda_II^-1 f_I` and the reduced
/// system's right-hand side cost `O(n H E)`, its solve `O(dim^2)`.
#[derive(Debug, Clone)]
pub struct CondensedFactor {
    basis: Arc<ModalBasis>,
    harmonics: usize,
    /// `dF_e/dU_e` of each element.
    g: Vec<DMatrix<f64>>,
    row_scale: Arc<DVector<f64>>,
    /// `(A, B)` of the modal block `(k, nn)` at `nn n + k`.
    blocks: Vec<(f64, f64)>,
    /// Whether the modal block `(k, nn)` (at `nn n + k`) is kept explicitly.
    explicit_block: Vec<bool>,
    /// Global indices of the explicit components, in the reduced system's order.
    e_list: Vec<usize>,
    /// `Lambda_II^-1 B_I`, `m x p` (zero on explicit rows).
    v_b: DMatrix<f64>,
    /// Border rows including the appended row, `p x (m + p)`.
    cfull: DMatrix<f64>,
    /// LU of the reduced system in `[y_E; z; y_b]`.
    lu: nalgebra::linalg::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
}

impl CondensedFactor {
    fn solve(&self, rhs: &DVector<f64>) -> Option<DVector<f64>> {
        let basis = &*self.basis;
        let w = &basis.w;
        let n = basis.n_modes();
        let hmax = self.harmonics;
        let nh = 2 * hmax + 1;
        let m = n * nh;
        let ne = w.ncols();
        let s = ne * nh;
        let p = self.cfull.nrows();
        let ne_e = self.e_list.len();
        let f: DVector<f64> = DVector::from_fn(m, |i, _| rhs[i] * self.row_scale[i]);
        // V_f = Lambda_II^-1 f_I (zero on explicit rows)
        let mut v_f = DMatrix::zeros(m, 1);
        for nn in 0..=hmax {
            let comps = components(nn);
            let comps = comps.as_slice();
            for k in 0..n {
                if self.explicit_block[nn * n + k] {
                    continue;
                }
                let linv = block_inverse(self.blocks[nn * n + k], nn);
                for (ia, &ha) in comps.iter().enumerate() {
                    let mut acc = 0.0;
                    for (ib, &hb) in comps.iter().enumerate() {
                        acc += linv[ia][ib] * f[hb * n + k];
                    }
                    v_f[ha * n + k] = acc;
                }
            }
        }
        let ptv = p_transpose(w, &v_f, nh);
        let cv = self.cfull.columns(0, m) * &v_f;
        let dim = ne_e + s + p;
        let mut b = DVector::zeros(dim);
        for (i, &gi) in self.e_list.iter().enumerate() {
            b[i] = f[gi];
        }
        for (e, g) in self.g.iter().enumerate() {
            for h in 0..nh {
                let mut acc = 0.0;
                for h2 in 0..nh {
                    acc += g[(h, h2)] * ptv[e * nh + h2];
                }
                b[ne_e + e * nh + h] = acc;
            }
        }
        for rr in 0..p {
            b[ne_e + s + rr] = rhs[m + rr] - cv[rr];
        }
        let sol = self.lu.solve(&b)?;
        if !sol.iter().all(|x| x.is_finite()) {
            return None;
        }
        let z = sol.rows(ne_e, s);
        let yb = sol.rows(ne_e + s, p);
        // recover y_I = V_f - Lambda^-1 P_I z - V_B y_b
        let mut y = DVector::zeros(m + p);
        let vb_yb = &self.v_b * yb;
        for i in 0..m {
            y[i] = v_f[i] - vb_yb[i];
        }
        for nn in 0..=hmax {
            let comps = components(nn);
            let comps = comps.as_slice();
            for k in 0..n {
                if self.explicit_block[nn * n + k] {
                    continue;
                }
                let (la, lb) = self.blocks[nn * n + k];
                let mut pz = [0.0; 2];
                for (pzi, &h) in pz.iter_mut().zip(comps) {
                    *pzi = (0..ne).map(|e| w[(k, e)] * z[e * nh + h]).sum::<f64>();
                }
                if nn == 0 {
                    y[k] -= pz[0] / la;
                } else {
                    let det = la * la + lb * lb;
                    y[comps[0] * n + k] -= (la * pz[0] - lb * pz[1]) / det;
                    y[comps[1] * n + k] -= (lb * pz[0] + la * pz[1]) / det;
                }
            }
        }
        for (i, &gi) in self.e_list.iter().enumerate() {
            y[gi] = sol[i];
        }
        for c in 0..p {
            y[m + c] = yb[c];
        }
        Some(y)
    }
}

impl BorderedFactor for HbFactor {
    fn solve(&self, rhs: &DVector<f64>) -> Option<DVector<f64>> {
        match self {
            HbFactor::Dense { lu, row_scale } => {
                let mut b = rhs.clone();
                for i in 0..row_scale.len() {
                    b[i] *= row_scale[i];
                }
                let y = lu.solve(&b)?;
                y.iter().all(|v| v.is_finite()).then_some(y)
            }
            HbFactor::Condensed(c) => c.solve(rhs),
        }
    }
}

impl BorderedSolve for HbJacobian {
    type Factor = HbFactor;
    fn factor_bordered(&self, row: &DVector<f64>) -> Option<HbFactor> {
        if self.basis.diagonal_damping {
            self.factor_condensed(row)
        } else {
            self.factor_dense(row)
        }
    }
}

/// Linear harmonic rows `Lambda(omega, D) X` (unscaled) and their derivatives
/// w.r.t. `omega` and `D`.
fn linear_rows(
    basis: &ModalBasis,
    harmonics: usize,
    omega: f64,
    d: f64,
    x: &[f64],
) -> (DVector<f64>, DVector<f64>, DVector<f64>) {
    let n = basis.n_modes();
    let m = n * (2 * harmonics + 1);
    let mut r = DVector::zeros(m);
    let mut dr_dom = DVector::zeros(m);
    let mut dr_dd = DVector::zeros(m);
    for k in 0..n {
        r[k] = basis.omega2[k] * x[k];
    }
    let mut bs = vec![0.0; n];
    let mut bc = vec![0.0; n];
    let mut cs = vec![0.0; n];
    let mut cc = vec![0.0; n];
    for nn in 1..=harmonics {
        let nf = nn as f64;
        let (hc, hs) = (cos_index(nn), sin_index(nn));
        let xc = &x[hc * n..(hc + 1) * n];
        let xs = &x[hs * n..(hs + 1) * n];
        basis.apply_b(nf, omega, d, xs, &mut bs);
        basis.apply_b(nf, omega, d, xc, &mut bc);
        // d B / d omega = n (C_m - 4 D omega I): apply via B(omega, 2D) / omega
        basis.apply_b(nf, omega, 2.0 * d, xs, &mut cs);
        basis.apply_b(nf, omega, 2.0 * d, xc, &mut cc);
        for k in 0..n {
            let a = basis.omega2[k] - (nf * omega).powi(2);
            let da = -2.0 * nf * nf * omega;
            r[hc * n + k] = a * xc[k] + bs[k];
            r[hs * n + k] = -bc[k] + a * xs[k];
            dr_dom[hc * n + k] = da * xc[k] + cs[k] / omega;
            dr_dom[hs * n + k] = -cc[k] / omega + da * xs[k];
            dr_dd[hc * n + k] = -2.0 * nf * omega * omega * xs[k];
            dr_dd[hs * n + k] = 2.0 * nf * omega * omega * xc[k];
        }
    }
    (r, dr_dom, dr_dd)
}

/// How the EPMC unknowns are normalised and which amplitude is the
/// continuation parameter (last unknown `X = [Psi; omega; D; log10 A]`,
/// `q = A Psi` in modal coordinates).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Normalisation {
    /// `A = a = sqrt(q_1^H M q_1)` (paper Section 3.1): `Psi_1^H Psi_1 = 1` and
    /// phase `Im(Psi_{1,j}) = 0` on the continued mode `j` (default). Along an
    /// internal-resonance loop the fundamental passes near zero, so `Psi`
    /// diverges and `log10 a -> -inf`: this form cannot pass loops.
    #[default]
    Fundamental,
    /// `A^2 = sum_{n>=1} n^2 q_n^H M q_n` (the kinetic-energy norm over all
    /// harmonics, `2 T_mean / omega^2`): `sum_n n^2 Psi_n^H Psi_n = 1` and phase
    /// `sum_n n s_{n,j} = 0` (the continued mode's modal velocity vanishes at
    /// `t = 0`), neither of which rests on the fundamental. All unknowns stay
    /// finite along loops; the paper's `a = A |Psi_1|` and `phi_n = Psi_n /
    /// |Psi_1|` are computed after each solve
    /// ([`EpmcResidual::to_fundamental`]).
    HarmonicEnergy,
}

/// [`EpmcResidual`]'s unknowns, split (see [`EpmcResidual::unknowns`]).
struct Unknowns<'x> {
    n: usize,
    nh: usize,
    m: usize,
    omega: f64,
    d: f64,
    amp: f64,
    psi: &'x [f64],
}

/// The EPMC residual (`eq:EPMC`) in modal Harmonic Balance form; unknowns
/// `X = [Psi; omega; D; log10 A]` (see module doc and [`Normalisation`]).
#[derive(Debug, Clone)]
pub struct EpmcResidual {
    basis: Arc<ModalBasis>,
    aft: Aft,
    mode: usize,
    row_scale: Arc<DVector<f64>>,
    normalisation: Normalisation,
}

impl EpmcResidual {
    /// Residual for the nonlinear mode continuing linear mode `mode` (0-based).
    pub fn new(basis: Arc<ModalBasis>, harmonics: usize, samples: usize, mode: usize) -> Self {
        assert!(harmonics >= 1, "EPMC needs at least one harmonic");
        assert!(mode < basis.n_modes());
        let row_scale = Arc::new(basis.row_scale(harmonics, basis.omega(mode)));
        Self {
            aft: Aft::new(harmonics, samples),
            basis,
            mode,
            row_scale,
            normalisation: Normalisation::Fundamental,
        }
    }

    /// The same residual with another normalisation.
    pub fn with_normalisation(mut self, normalisation: Normalisation) -> Self {
        self.normalisation = normalisation;
        self
    }

    /// The continued linear mode (0-based).
    pub fn mode(&self) -> usize {
        self.mode
    }

    pub fn normalisation(&self) -> Normalisation {
        self.normalisation
    }

    /// A solution `x` in the [`Normalisation::Fundamental`] form
    /// `[Psi; omega; D; log10 a]`: `a = A |Psi_1|`, `Psi_n` divided by `|Psi_1|`
    /// and shifted in time (`Psi_n e^{i n theta}`) so that `Im(Psi_{1,j}) = 0`,
    /// `Re(Psi_{1,j}) >= 0`. Identity for the fundamental normalisation.
    pub fn to_fundamental(&self, x: &DVector<f64>) -> DVector<f64> {
        if self.normalisation == Normalisation::Fundamental {
            return x.clone();
        }
        let n = self.basis.n_modes();
        let m = self.n_coeffs();
        let (ic, is) = (cos_index(1) * n, sin_index(1) * n);
        let p1 = (0..n)
            .map(|k| x[ic + k].powi(2) + x[is + k].powi(2))
            .sum::<f64>()
            .sqrt();
        // q_1j = c - i s; rotate by theta = -arg(q_1j)
        let theta = -(-x[is + self.mode]).atan2(x[ic + self.mode]);
        let mut y = x.clone();
        for nn in 0..=self.harmonics() {
            let (sn, cs) = ((nn as f64) * theta).sin_cos();
            for k in 0..n {
                let ck = x[cos_index(nn) * n + k];
                if nn == 0 {
                    y[k] = ck / p1;
                    continue;
                }
                let sk = x[sin_index(nn) * n + k];
                y[cos_index(nn) * n + k] = (ck * cs + sk * sn) / p1;
                y[sin_index(nn) * n + k] = (sk * cs - ck * sn) / p1;
            }
        }
        y[m + 2] = x[m + 2] + p1.log10();
        y
    }

    /// Kinetic-energy shares `n^2 Psi_{n,k}^2 / sum` of every harmonic `n`
    /// (index `n`, `0..=H`) and mode `k` (index `k`): `shares[n][k]`.
    pub fn harmonic_energy_shares(&self, x: &DVector<f64>) -> Vec<Vec<f64>> {
        let n = self.basis.n_modes();
        let mut e: Vec<Vec<f64>> = (0..=self.harmonics())
            .map(|nn| {
                (0..n)
                    .map(|k| {
                        if nn == 0 {
                            0.0
                        } else {
                            (nn * nn) as f64
                                * (x[cos_index(nn) * n + k].powi(2)
                                    + x[sin_index(nn) * n + k].powi(2))
                        }
                    })
                    .collect()
            })
            .collect();
        let total: f64 = e.iter().flatten().sum();
        for v in e.iter_mut().flatten() {
            *v /= total;
        }
        e
    }

    pub fn basis(&self) -> &ModalBasis {
        &self.basis
    }

    pub fn harmonics(&self) -> usize {
        self.aft.harmonics()
    }

    /// Number of modal Fourier coefficients `m = n (2H+1)`.
    pub fn n_coeffs(&self) -> usize {
        self.basis.n_modes() * self.aft.n_coeffs()
    }

    /// The linear mode as start vector at `log10 a`.
    pub fn linear_guess(&self, log10_a: f64) -> DVector<f64> {
        let m = self.n_coeffs();
        let n = self.basis.n_modes();
        let mut x = DVector::zeros(m + 3);
        x[cos_index(1) * n + self.mode] = 1.0;
        x[m] = self.basis.omega(self.mode);
        x[m + 1] = self.basis.damping_ratio(self.mode);
        x[m + 2] = log10_a;
        x
    }

    /// The start vector at `log10 a` from the linear mode of the system
    /// linearised at rest: every element's tangent `(df/du, df/dv)` at
    /// `u = v = 0` ([`NonlinearLaw::eval`]; for a Jenkins element its stick
    /// stiffness `k_t`, for `tanh` friction the damper `F_s / v_r`) added to
    /// `K` and `C`. The EPMC of a linear system is the nonlinear eigenproblem
    /// `(K_l + i omega C_l - s M) psi = 0`, `s = omega^2 (1 + 2 i D)`, solved by
    /// Rayleigh-quotient inverse iteration in modal coordinates from the
    /// continued mode (at most [`LINEARISED_GUESS_ITERATIONS`] iterations); for
    /// a damper-like element the start is thus the complex mode. Falls back to
    /// [`Self::linear_guess`] where all tangents vanish (then identical, e.g.
    /// cubic springs), for more than [`LINEARISED_GUESS_MAX_MODES`] modes, or
    /// if the iteration fails.
    pub fn linearised_guess(&self, log10_a: f64) -> DVector<f64> {
        use num_complex::Complex64 as C64;
        let basis = &*self.basis;
        let n = basis.n_modes();
        let tangents: Vec<(f64, f64)> = basis
            .laws
            .iter()
            .map(|l| {
                let (_, k, c) = l.eval(0.0, 0.0);
                (k, c)
            })
            .collect();
        let finite = tangents.iter().all(|t| t.0.is_finite() && t.1.is_finite());
        if !finite || tangents.iter().all(|t| *t == (0.0, 0.0)) || n > LINEARISED_GUESS_MAX_MODES {
            return self.linear_guess(log10_a);
        }
        let mut kl = DMatrix::from_diagonal(&basis.omega2);
        let mut cl = basis.cm.clone();
        for (e, &(k, c)) in tangents.iter().enumerate() {
            let we = basis.w.column(e);
            kl += (&we * we.transpose()) * k;
            cl += (&we * we.transpose()) * c;
        }
        let j = self.mode;
        let mut psi =
            DVector::<C64>::from_fn(n, |k, _| C64::new(if k == j { 1.0 } else { 0.0 }, 0.0));
        let mut s = C64::new(basis.omega2[j], 0.0);
        let mut converged = false;
        for _ in 0..LINEARISED_GUESS_ITERATIONS {
            let omega = s.re.max(0.0).sqrt();
            let b = DMatrix::<C64>::from_fn(n, n, |r, c| C64::new(kl[(r, c)], omega * cl[(r, c)]));
            let mut a = b.clone();
            for k in 0..n {
                a[(k, k)] -= s;
            }
            let next = match a.lu().solve(&psi) {
                Some(y) if y.iter().all(|v| v.re.is_finite() && v.im.is_finite()) => y,
                // `s` is an eigenvalue to machine precision
                _ => {
                    converged = true;
                    break;
                }
            };
            let norm = next.norm();
            if !(norm > 0.0) {
                break;
            }
            psi = next / C64::new(norm, 0.0);
            let s_new = psi.dotc(&(&b * &psi));
            let done = (s_new - s).norm() <= 1e-13 * s_new.norm();
            s = s_new;
            if done {
                converged = true;
                break;
            }
        }
        if !converged || !(s.re > 0.0) || psi[j].norm() == 0.0 {
            return self.linear_guess(log10_a);
        }
        // unit norm, psi_j real and positive
        let rot = psi[j].conj() / psi[j].norm();
        let psi = psi.map(|v| v * rot / C64::new(psi.norm(), 0.0));
        let m = self.n_coeffs();
        let mut x = DVector::zeros(m + 3);
        for k in 0..n {
            x[cos_index(1) * n + k] = psi[k].re;
            x[sin_index(1) * n + k] = -psi[k].im;
        }
        x[sin_index(1) * n + j] = 0.0;
        x[m] = s.re.sqrt();
        x[m + 1] = s.im / (2.0 * s.re);
        x[m + 2] = log10_a;
        x
    }

    /// `|Psi_1|^2 / sum_n n^2 |Psi_n|^2` (modal coordinates are mass-normalized).
    pub fn fundamental_energy_share(&self, x: &DVector<f64>) -> f64 {
        let n = self.basis.n_modes();
        let mut e1 = 0.0;
        let mut total = 0.0;
        for nn in 1..=self.harmonics() {
            let en: f64 = (cos_index(nn) * n..(sin_index(nn) + 1) * n)
                .map(|i| x[i] * x[i])
                .sum();
            if nn == 1 {
                e1 = en;
            }
            total += (nn * nn) as f64 * en;
        }
        e1 / total
    }

    /// Complex harmonics `phi_n`, `n = 0..=H`, of the generalized coordinates
    /// (`q = Re(a sum phi_n e^{i n omega t})`), from a solution `x`.
    pub fn shape_harmonics(
        &self,
        x: &DVector<f64>,
    ) -> Vec<nalgebra::DVector<num_complex::Complex64>> {
        let n = self.basis.n_modes();
        (0..=self.harmonics())
            .map(|nn| {
                let c = DVector::from_column_slice(
                    &x.as_slice()[cos_index(nn) * n..(cos_index(nn) + 1) * n],
                );
                let pc = &self.basis.phi * c;
                if nn == 0 {
                    pc.map(|v| num_complex::Complex64::new(v, 0.0))
                } else {
                    let s = DVector::from_column_slice(
                        &x.as_slice()[sin_index(nn) * n..(sin_index(nn) + 1) * n],
                    );
                    let ps = &self.basis.phi * s;
                    DVector::from_fn(n, |i, _| num_complex::Complex64::new(pc[i], -ps[i]))
                }
            })
            .collect()
    }

    /// Complex harmonics `e^T phi_n` of an observation direction `e` (physical).
    pub fn observe(&self, x: &DVector<f64>, e_modal: &DVector<f64>) -> Vec<num_complex::Complex64> {
        observe_harmonics(self.harmonics(), x, e_modal)
    }
}

/// Complex harmonics `e_modal^T psi_n`, `n = 0..=harmonics`, of the modal
/// harmonic coefficients at the start of `x` (cosine/sine blocks of
/// `n_modes = e_modal.len()` entries; `q_n = c_n - i s_n`).
fn observe_harmonics(
    harmonics: usize,
    x: &DVector<f64>,
    e_modal: &DVector<f64>,
) -> Vec<num_complex::Complex64> {
    let n = e_modal.len();
    let dot = |block: usize| -> f64 { (0..n).map(|k| e_modal[k] * x[block * n + k]).sum() };
    (0..=harmonics)
        .map(|nn| {
            if nn == 0 {
                num_complex::Complex64::new(dot(cos_index(0)), 0.0)
            } else {
                num_complex::Complex64::new(dot(cos_index(nn)), -dot(sin_index(nn)))
            }
        })
        .collect()
}

impl EpmcResidual {
    /// The unknowns `x = [psi (n modes x nh coefficients), omega, D, log10 a]`
    /// split into their parts (`a` = 10^lg), for the residual and its Jacobian.
    fn unknowns<'x>(&self, x: &'x DVector<f64>) -> Unknowns<'x> {
        let n = self.basis.n_modes();
        let nh = self.aft.n_coeffs();
        let m = n * nh;
        Unknowns {
            n,
            nh,
            m,
            omega: x[m],
            d: x[m + 1],
            amp: 10f64.powf(x[m + 2]),
            psi: &x.as_slice()[..m],
        }
    }

    /// The amplitude and phase rows of [`Normalisation`] into `res[m..m + 2]`
    /// and, if given, their derivatives into `border_rows` (`2 x (m + 3)`).
    fn normalisation_rows(
        &self,
        psi: &[f64],
        res: &mut DVector<f64>,
        mut border_rows: Option<&mut DMatrix<f64>>,
    ) {
        let n = self.basis.n_modes();
        let m = psi.len();
        match self.normalisation {
            Normalisation::Fundamental => {
                let (ic, is) = (cos_index(1) * n, sin_index(1) * n);
                res[m] = psi[is + self.mode];
                res[m + 1] = (0..n)
                    .map(|k| psi[ic + k].powi(2) + psi[is + k].powi(2))
                    .sum::<f64>()
                    - 1.0;
                if let Some(br) = border_rows.as_deref_mut() {
                    br[(0, is + self.mode)] = 1.0;
                    for k in 0..n {
                        br[(1, ic + k)] = 2.0 * psi[ic + k];
                        br[(1, is + k)] = 2.0 * psi[is + k];
                    }
                }
            }
            Normalisation::HarmonicEnergy => {
                let mut norm = -1.0;
                for nn in 1..=self.harmonics() {
                    let (w, nf) = (((nn * nn) as f64), nn as f64);
                    let (ic, is) = (cos_index(nn) * n, sin_index(nn) * n);
                    res[m] += nf * psi[is + self.mode];
                    if let Some(br) = border_rows.as_deref_mut() {
                        br[(0, is + self.mode)] = nf;
                    }
                    for k in 0..n {
                        norm += w * (psi[ic + k].powi(2) + psi[is + k].powi(2));
                        if let Some(br) = border_rows.as_deref_mut() {
                            br[(1, ic + k)] = 2.0 * w * psi[ic + k];
                            br[(1, is + k)] = 2.0 * w * psi[is + k];
                        }
                    }
                }
                res[m + 1] = norm;
            }
        }
    }
}

impl super::continuation::Residual for EpmcResidual {
    type Jacobian = HbJacobian;

    fn n_unknowns(&self) -> usize {
        self.n_coeffs() + 3
    }

    /// The residual of [`Self::eval`] without the AFT Jacobians.
    fn residual(&self, x: &DVector<f64>) -> DVector<f64> {
        let basis = &*self.basis;
        let Unknowns {
            n,
            nh,
            m,
            omega,
            d,
            amp,
            psi,
        } = self.unknowns(x);
        let (mut r, _, _) = linear_rows(basis, self.harmonics(), omega, d, psi);
        let u = basis.element_coeffs(psi, nh, amp);
        for (e, ue) in u.iter().enumerate() {
            let force = self.aft.force(&*basis.laws[e], ue, omega);
            let we = basis.w.column(e);
            for h in 0..nh {
                let fh = force[h] / amp;
                for k in 0..n {
                    r[h * n + k] += we[k] * fh;
                }
            }
        }
        let mut res = DVector::zeros(m + 2);
        for i in 0..m {
            res[i] = r[i] / self.row_scale[i];
        }
        self.normalisation_rows(psi, &mut res, None);
        res
    }

    fn eval(&self, x: &DVector<f64>) -> (DVector<f64>, HbJacobian) {
        let basis = &*self.basis;
        let Unknowns {
            n,
            nh,
            m,
            omega,
            d,
            amp,
            psi,
        } = self.unknowns(x);
        let (mut r, mut dr_dom, dr_dd) = linear_rows(basis, self.harmonics(), omega, d, psi);
        let mut dr_dlg = DVector::zeros(m);
        let u = basis.element_coeffs(psi, nh, amp);
        let mut g = Vec::with_capacity(u.len());
        for (e, ue) in u.iter().enumerate() {
            let out = self.aft.eval(&*basis.laws[e], ue, omega);
            let we = basis.w.column(e);
            let gu_minus_f = &out.jac_u * ue - &out.force;
            for h in 0..nh {
                let (fh, fwh, glh) = (
                    out.force[h] / amp,
                    out.jac_omega[h] / amp,
                    LN_10 * gu_minus_f[h] / amp,
                );
                for k in 0..n {
                    r[h * n + k] += we[k] * fh;
                    dr_dom[h * n + k] += we[k] * fwh;
                    dr_dlg[h * n + k] += we[k] * glh;
                }
            }
            g.push(out.jac_u);
        }
        let mut res = DVector::zeros(m + 2);
        for i in 0..m {
            res[i] = r[i] / self.row_scale[i];
        }
        let mut border_cols = DMatrix::zeros(m, 3);
        border_cols.set_column(0, &dr_dom);
        border_cols.set_column(1, &dr_dd);
        border_cols.set_column(2, &dr_dlg);
        let mut border_rows = DMatrix::zeros(2, m + 3);
        self.normalisation_rows(psi, &mut res, Some(&mut border_rows));
        let jac = HbJacobian {
            basis: self.basis.clone(),
            harmonics: self.harmonics(),
            omega,
            d,
            g,
            row_scale: self.row_scale.clone(),
            border_cols,
            border_rows,
            explicit: vec![(self.mode, 1)],
        };
        (res, jac)
    }
}

/// Harmonic Balance residual of the forced response
/// `M q'' + C q' + K q + f_nl(q, q') = f cos(Omega t)`; unknowns
/// `X = [eta; Omega]` (modal Fourier coefficients, excitation frequency
/// [rad/s] as continuation parameter).
#[derive(Debug, Clone)]
pub struct ForcedResidual {
    basis: Arc<ModalBasis>,
    aft: Aft,
    force_modal: DVector<f64>,
    row_scale: Arc<DVector<f64>>,
}

impl ForcedResidual {
    /// `force` [N] in generalized coordinates (length `n`); `omega_ref` sets the
    /// row scaling (any frequency of the range of interest).
    pub fn new(
        basis: Arc<ModalBasis>,
        harmonics: usize,
        samples: usize,
        force: &DVector<f64>,
        omega_ref: f64,
    ) -> Self {
        assert_eq!(force.len(), basis.n_modes());
        let force_modal = basis.phi.transpose() * force;
        let row_scale = Arc::new(basis.row_scale(harmonics, omega_ref));
        Self {
            aft: Aft::new(harmonics, samples),
            basis,
            force_modal,
            row_scale,
        }
    }

    pub fn n_coeffs(&self) -> usize {
        self.basis.n_modes() * self.aft.n_coeffs()
    }

    /// Linear (harmonic-1, nonlinearity ignored) response at `omega` as start vector.
    pub fn linear_guess(&self, omega: f64) -> DVector<f64> {
        let n = self.basis.n_modes();
        let m = self.n_coeffs();
        let mut x = DVector::zeros(m + 1);
        for k in 0..n {
            let a = self.basis.omega2[k] - omega * omega;
            let b = omega * self.basis.cm[(k, k)];
            let det = a * a + b * b;
            // [[a, b], [-b, a]] (c, s) = (f, 0)
            x[cos_index(1) * n + k] = a * self.force_modal[k] / det;
            x[sin_index(1) * n + k] = b * self.force_modal[k] / det;
        }
        x[m] = omega;
        x
    }

    /// Complex harmonics `e^T q_n` [m] of a physical observation direction `e`.
    pub fn observe(&self, x: &DVector<f64>, e: &DVector<f64>) -> Vec<num_complex::Complex64> {
        observe_harmonics(self.aft.harmonics(), x, &(self.basis.phi.transpose() * e))
    }
}

impl super::continuation::Residual for ForcedResidual {
    type Jacobian = HbJacobian;

    fn n_unknowns(&self) -> usize {
        self.n_coeffs() + 1
    }

    fn eval(&self, x: &DVector<f64>) -> (DVector<f64>, HbJacobian) {
        let basis = &*self.basis;
        let n = basis.n_modes();
        let nh = self.aft.n_coeffs();
        let m = n * nh;
        let omega = x[m];
        let eta = &x.as_slice()[..m];
        let (mut r, mut dr_dom, _) = linear_rows(basis, self.aft.harmonics(), omega, 0.0, eta);
        for k in 0..n {
            r[cos_index(1) * n + k] -= self.force_modal[k];
        }
        let u = basis.element_coeffs(eta, nh, 1.0);
        let mut g = Vec::with_capacity(u.len());
        for (e, ue) in u.iter().enumerate() {
            let out = self.aft.eval(&*basis.laws[e], ue, omega);
            let we = basis.w.column(e);
            for h in 0..nh {
                for k in 0..n {
                    r[h * n + k] += we[k] * out.force[h];
                    dr_dom[h * n + k] += we[k] * out.jac_omega[h];
                }
            }
            g.push(out.jac_u);
        }
        let res = r.component_div(&self.row_scale);
        let jac = HbJacobian {
            basis: self.basis.clone(),
            harmonics: self.aft.harmonics(),
            omega,
            d: 0.0,
            g,
            row_scale: self.row_scale.clone(),
            border_cols: DMatrix::from_column_slice(m, 1, dr_dom.as_slice()),
            border_rows: DMatrix::zeros(0, m + 1),
            explicit: vec![],
        };
        (res, jac)
    }
}
