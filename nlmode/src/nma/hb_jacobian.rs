//! The structured Jacobian of the modal Harmonic Balance residuals of
//! [`super::epmc`] and its condensed (Schur-complement) bordered solver: the
//! well-conditioned modal blocks are eliminated, the nonlinear coordinates,
//! the near-resonant blocks and the bordered unknowns kept (module docs of
//! [`super::epmc`], "Condensation").
use super::continuation::{BorderedFactor, BorderedSolve};
use super::hb::{cos_index, harmonic_of, sin_index};
use super::modal_basis::ModalBasis;
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

/// Relative size of `|A + iB|` below which a modal block is kept explicitly.
const EXPLICIT_THRESHOLD: f64 = 0.05;

/// Structured Jacobian of a modal Harmonic Balance residual (see module doc):
/// rows `0..m` (scaled by `1/row_scale`) are the harmonic equations, then `r`
/// extra residual rows; columns are the `m` modal coefficients and `p = r + 1`
/// extra unknowns.
#[derive(Debug, Clone)]
pub struct HbJacobian {
    pub(super) basis: Arc<ModalBasis>,
    pub(super) harmonics: usize,
    pub(super) omega: f64,
    pub(super) d: f64,
    /// `dF_e/dU_e` of each element.
    pub(super) g: Vec<DMatrix<f64>>,
    pub(super) row_scale: Arc<DVector<f64>>,
    /// Unscaled derivatives of the harmonic rows w.r.t. the extra unknowns, `m x p`.
    pub(super) border_cols: DMatrix<f64>,
    /// Extra residual rows, `r x (m + p)`.
    pub(super) border_rows: DMatrix<f64>,
    /// Modal blocks `(k, n)` always kept explicit.
    pub(super) explicit: Vec<(usize, usize)>,
}

/// The real coefficient indices of harmonic `nn`: the mean alone, or its
/// cosine and sine.
#[derive(Clone, Copy)]
struct Components {
    pub(super) idx: [usize; 2],
    pub(super) len: usize,
}

impl Components {
    pub(super) fn as_slice(&self) -> &[usize] {
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
    pub(super) fn m(&self) -> usize {
        self.basis.n_modes() * (2 * self.harmonics + 1)
    }

    /// `A`, `B` of the diagonal modal block `(k, nn)`.
    pub(super) fn block(&self, k: usize, nn: usize) -> (f64, f64) {
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
    pub(super) fn dense_unscaled_harmonic_rows(&self) -> DMatrix<f64> {
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
    pub(super) fn factor_dense(&self, row: &DVector<f64>) -> Option<HbFactor> {
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
    pub(super) fn factor_condensed(&self, row: &DVector<f64>) -> Option<HbFactor> {
        let basis = &*self.basis;
        let n = basis.n_modes();
        let hmax = self.harmonics;
        let nh = 2 * hmax + 1;
        let m = n * nh;
        let (r, p) = (self.border_rows.nrows(), self.border_cols.ncols());
        debug_assert_eq!(r + 1, p);
        let w = &basis.w;
        // border rows incl. the continuation row: p x (m + p)
        let mut cfull = DMatrix::zeros(p, m + p);
        cfull
            .view_mut((0, 0), (r, m + p))
            .copy_from(&self.border_rows);
        cfull.row_mut(r).copy_from(&row.transpose());

        let (blocks, explicit_block, e_list) = self.classify_blocks();
        // V_B = Lambda_II^-1 B_I  (m x p), Q, CLP
        let (v_b, q, clp) = self.eliminate_implicit(&blocks, &explicit_block, &cfull);
        // P^T V_B (s x p) and C V_B (p x p), V_B is zero on explicit rows
        let ptv = p_transpose(w, &v_b, nh);
        let cv = cfull.columns(0, m) * &v_b;

        // reduced system [y_E; z; y_b]
        let a = self.reduced_system(&blocks, &e_list, &q, &clp, &ptv, &cv, &cfull);
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

    /// The modal blocks `(A, B)` by `nn n + k` (mode `k`, harmonic `nn`),
    /// whether each is solved explicitly (forced, or `|(A, B)|` below
    /// [`EXPLICIT_THRESHOLD`] times its row scale) and the global component
    /// indices of the explicit ones, in order.
    #[allow(clippy::type_complexity)]
    fn classify_blocks(&self) -> (Vec<(f64, f64)>, Vec<bool>, Vec<usize>) {
        let n = self.basis.n_modes();
        let hmax = self.harmonics;
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
        (blocks, explicit_block, e_list)
    }

    /// The implicit (non-explicit) modal blocks eliminated: `V_B = Lambda_II^-1
    /// B_I` (`m x p`), `Q = P^T Lambda_II^-1 P` (`s x s`) and `C Lambda_II^-1
    /// P` (`p x s`), with `cfull` the border rows and the continuation row.
    fn eliminate_implicit(
        &self,
        blocks: &[(f64, f64)],
        explicit_block: &[bool],
        cfull: &DMatrix<f64>,
    ) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        let w = &self.basis.w;
        let n = self.basis.n_modes();
        let hmax = self.harmonics;
        let nh = 2 * hmax + 1;
        let m = n * nh;
        let ne = w.ncols();
        let s = ne * nh;
        let p = self.border_cols.ncols();
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
        (v_b, q, clp)
    }

    /// The reduced system in `[y_E; z; y_b]` (module doc): the explicit
    /// components' rows, the nonlinear elements' rows (`z + G (Q z - P^T y_E
    /// + P^T V_B y_b)`) and the border rows.
    #[allow(clippy::too_many_arguments)]
    fn reduced_system(
        &self,
        blocks: &[(f64, f64)],
        e_list: &[usize],
        q: &DMatrix<f64>,
        clp: &DMatrix<f64>,
        ptv: &DMatrix<f64>,
        cv: &DMatrix<f64>,
        cfull: &DMatrix<f64>,
    ) -> DMatrix<f64> {
        let w = &self.basis.w;
        let n = self.basis.n_modes();
        let nh = 2 * self.harmonics + 1;
        let m = n * nh;
        let ne = w.ncols();
        let s = ne * nh;
        let p = self.border_cols.ncols();
        let ne_e = e_list.len();
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
        self.element_rows(&mut a, e_list, q, ptv);
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
        a
    }

    /// The nonlinear elements' rows of the reduced system `a` (`z + G (Q z -
    /// P^T y_E + P^T V_B y_b)`, `G` the elements' harmonic stiffness blocks).
    fn element_rows(
        &self,
        a: &mut DMatrix<f64>,
        e_list: &[usize],
        q: &DMatrix<f64>,
        ptv: &DMatrix<f64>,
    ) {
        let w = &self.basis.w;
        let n = self.basis.n_modes();
        let nh = 2 * self.harmonics + 1;
        let ne = w.ncols();
        let s = ne * nh;
        let p = self.border_cols.ncols();
        let ne_e = e_list.len();
        // the explicit components by harmonic component `h`, in `e_list` order:
        // `e_by_h[e_start[h]..e_start[h + 1]]` holds `(position in e_list, mode)`
        let mut e_start = vec![0usize; nh + 1];
        for &gi in e_list {
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
    pub(super) basis: Arc<ModalBasis>,
    pub(super) harmonics: usize,
    /// `dF_e/dU_e` of each element.
    pub(super) g: Vec<DMatrix<f64>>,
    pub(super) row_scale: Arc<DVector<f64>>,
    /// `(A, B)` of the modal block `(k, nn)` at `nn n + k`.
    pub(super) blocks: Vec<(f64, f64)>,
    /// Whether the modal block `(k, nn)` (at `nn n + k`) is kept explicitly.
    pub(super) explicit_block: Vec<bool>,
    /// Global indices of the explicit components, in the reduced system's order.
    pub(super) e_list: Vec<usize>,
    /// `Lambda_II^-1 B_I`, `m x p` (zero on explicit rows).
    pub(super) v_b: DMatrix<f64>,
    /// Border rows including the appended row, `p x (m + p)`.
    pub(super) cfull: DMatrix<f64>,
    /// LU of the reduced system in `[y_E; z; y_b]`.
    pub(super) lu: nalgebra::linalg::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
}

impl CondensedFactor {
    pub(super) fn solve(&self, rhs: &DVector<f64>) -> Option<DVector<f64>> {
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
