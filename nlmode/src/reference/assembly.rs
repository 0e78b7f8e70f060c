//! Primal assembly (`eq:primal`, `eq:finalassembly1`-`eq:finalassembly2`) of a
//! structure and any number of linear attachments, and its reduction to one
//! explicit first-order system.
//!
//! # Primal variables and assembled coefficients
//!
//! The primal variables are `y = [q; x_r^(1); x_r^(2); ...]`, one block `x_r` per
//! attachment, with `x = L1 q + L2 x_r` (`eq:primal`). Writing `T_a` for the
//! `ndim_a x N` matrix with `L1` in the `q` columns and `L2` in the attachment's
//! `x_r` columns (`x_a = T_a y`), `eq:finalassembly1`-`eq:finalassembly2` read
//!
//! ```text
//! sum_k A_k^asm y^(k) + W f(W^T q, W^T q') = b u(t) + b_q u_q(t),
//! A_2^asm = [M 0; 0 0] + sum_a T_a^T A_2^a T_a,  A_1^asm = [C 0; 0 0] + ...,
//! A_0^asm = [K 0; 0 0] + ...,                    A_k^asm = sum_a T_a^T A_k^a T_a (k > 2),
//! b = sum_a T_a^T (input_map_a Re c_a),        b_q = -sum_a T_a^T (input_map_a Im c_a),
//! ```
//!
//! where `W` holds the directions of the structure's nonlinear elements (zero in
//! the `x_r` rows). The input `j` of attachment `a` receives
//! `Re(c_aj e^{i Phi}) u_hat = Re(c_aj) u(t) - Im(c_aj) u_q(t)` with the in-phase
//! signal `u(t) = u_hat cos Phi(t)` (the sweep) and the quadrature signal
//! `u_q(t) = u_hat sin Phi(t)`, `c_aj` its complex input factor
//! ([`AssembledSystem::with_input_factors`]; 1 by default, every input then
//! receives `u(t)` and the system has the one input signal, `b` one column).
//!
//! `L1 = -pinv(B2) B1 = pinv(B2) E^T` (`eq:L1L2`, with `B1 = -E^T` and `E` the
//! interface points' directions) uses `pinv(B2) = B2^T (B2 B2^T)^-1`, exact for
//! the full row rank `B2` the paper requires. `L2` may be *any* basis of
//! `null(B2)`: the physical states `x = L1 q + L2 x_r` do not depend on it. We take
//! the basis read off the reduced row-echelon form of `B2` (one column per free
//! attachment state, e.g. `x_r = [I, q_a]` for the shaker, the paper's `L2`),
//! not the orthonormal SVD basis: an SVD basis may mix states of different
//! differential order (current and armature displacement), which would make the
//! leading-coefficient matrix below singular for a perfectly regular attachment.
//!
//! # Reduction to first order
//!
//! Each primal variable `y_j` gets its differential order `k_j`, the highest `k`
//! for which column `j` of `A_k^asm` is non-zero. The states are
//! `z = [y_j^(d)]` for `d = 0..k_j-1` (variables with `k_j = 0` are algebraic and
//! carry no state). The *leading matrix* has column `j` equal to column `j` of
//! `A_{k_j}^asm`; the remaining terms only involve lower derivatives, i.e. states:
//!
//! ```text
//! Lead w + Lower z + W f = b u,   w_j = y_j^(k_j).
//! ```
//!
//! When `Lead` is regular, `w = Lead^-1 (b u - W f - Lower z)` and the system is the
//! explicit ODE `z' = A z + b_z u(t) + G f(P z)` (the shaker with elastic or rigid
//! stinger is of this kind: `I` is first order, `q_a` and `q` second order; an
//! index-1 DAE with algebraic variables whose columns are regular is covered as
//! well). A singular `Lead` means a higher-index DAE (e.g. an algebraic
//! constraint between states, or a variable that enters no equation); it is
//! rejected with [`ReferenceError::SingularLeadingMatrix`] naming the variables in
//! the offending null vector, since index reduction is out of scope.
use super::ReferenceError;
use crate::attachment::LinearAttachment;
use crate::structure::{NonlinearLaw, StructuralModel};
use nalgebra::{DMatrix, DVector, RowDVector};
use nalgebra_sparse::CsrMatrix;
use std::sync::Arc;

mod primal;
use primal::{
    assembled_coefficients, attachment_inputs, check_structure_shapes, differential_orders,
    first_order_form, localizations, nonlinear_directions, point_direction,
};

/// Threshold, relative to the largest entry of `A_k^asm`, below which a column of
/// `A_k^asm` counts as zero (round-off of the localization products).
const ZERO_COLUMN_RTOL: f64 = 1e-13;
/// Reciprocal condition number (after equilibration) below which the leading
/// matrix is taken as singular.
const SINGULAR_RCOND: f64 = 1e-12;

/// Localization of one attachment (`eq:primal`, `eq:L1L2`).
#[derive(Debug, Clone)]
pub struct AttachmentLocalization {
    pub name: String,
    /// Interface point names (one per constraint).
    pub interface_points: Vec<String>,
    /// `E` (`ndof x ncon`): directions of the interface points, `B1 = -E^T`.
    pub interface_directions: DMatrix<f64>,
    /// `pinv(B2)` (`ndim x ncon`).
    pub pinv_b2: DMatrix<f64>,
    /// `L1 = pinv(B2) E^T` (`ndim x ndof`).
    pub l1: DMatrix<f64>,
    /// `L2`, a basis of `null(B2)` (`ndim x nr`), see the module docs.
    pub l2: DMatrix<f64>,
    /// Index of this attachment's first `x_r` variable in `y`.
    pub offset: usize,
    /// `T_a` (`ndim x N`): `x = T_a y`.
    pub t: DMatrix<f64>,
}

/// The explicit first-order form `z' = A z + b u(t) + G f` (`b u` summed over the
/// input signals, [`super::MAX_INPUT_SIGNALS`]), with the nonlinear
/// forces `f_e = law_e(c_e^T z, d_e^T z)` (`c_e`, `d_e` pick `w_e^T q`, `w_e^T q'`).
#[derive(Debug, Clone)]
pub struct FirstOrderSystem {
    /// `A` (`nz x nz`).
    pub a: DMatrix<f64>,
    /// `b` (`nz x p`): response of `z'` to the `p` input signals (column 0 the
    /// in-phase `u(t)`, column 1, when present, the quadrature `u_q(t)`).
    pub b: DMatrix<f64>,
    /// `G` (`nz x m`): response of `z'` to the nonlinear forces.
    pub g: DMatrix<f64>,
    /// `P` (`2m x nz`): rows `c_e^T` (displacements of the elements) then `d_e^T`
    /// (velocities).
    pub proj: DMatrix<f64>,
    /// The nonlinear force laws.
    pub laws: Vec<Arc<dyn NonlinearLaw>>,
    /// The non-zero entries of `P` by rows (built once from `proj`).
    proj_rows: CsrMatrix<f64>,
}

impl FirstOrderSystem {
    /// Number of states.
    pub fn nz(&self) -> usize {
        self.a.nrows()
    }
    /// Number of input signals `p` (1 or 2, the columns of `b`).
    pub fn n_inputs(&self) -> usize {
        self.b.ncols()
    }
    /// Number of nonlinear elements.
    pub fn m(&self) -> usize {
        self.laws.len()
    }
    /// Whether any element is hysteretic (carries an internal state).
    pub fn has_hysteresis(&self) -> bool {
        self.laws.iter().any(|l| l.hysteresis().is_some())
    }
    /// Internal states of the elements at state `z` (relaxed: a hysteretic
    /// element starts stuck at its current displacement with zero force; `0` for
    /// memoryless laws, which do not use it).
    pub fn initial_element_states(&self, z: &DVector<f64>) -> Vec<f64> {
        (0..self.m())
            .map(|e| match self.laws[e].hysteresis() {
                Some(h) => h.relaxed_state(self.proj.row(e).transpose().dot(z)).0,
                None => 0.0,
            })
            .collect()
    }
    /// Element `e` at displacement `u`, velocity `v` from internal state `s`:
    /// `(f, df/du, df/dv, s')` (a memoryless law: `law.eval(u, v)`, `s' = s`).
    #[inline]
    pub fn element(&self, e: usize, s: f64, u: f64, v: f64) -> (f64, f64, f64, f64) {
        match self.laws[e].hysteresis() {
            Some(h) => {
                let st = h.step(s, u);
                (st.force, st.dforce_du, 0.0, st.state)
            }
            None => {
                let (f, dfu, dfv) = self.laws[e].eval(u, v);
                (f, dfu, dfv, s)
            }
        }
    }
    /// Moves the hysteretic elements' states `states` to state `z` (an accepted step).
    pub fn advance_element_states(&self, z: &DVector<f64>, states: &mut [f64]) {
        for (e, s) in states.iter_mut().enumerate() {
            if let Some(h) = self.laws[e].hysteresis() {
                *s = h.step(*s, self.proj.row(e).transpose().dot(z)).state;
            }
        }
    }
    /// Nonlinear forces `f_e` \[N\] at state `z` with the element states `states`
    /// (unchanged; see [`FirstOrderSystem::advance_element_states`]).
    pub fn forces(&self, z: &DVector<f64>, states: &[f64], f: &mut [f64]) {
        let m = self.m();
        // sparse dots: an element's direction touches a few coordinates
        let dot = |r: usize| -> f64 {
            let row = self.proj_rows.row(r);
            let zs = z.as_slice();
            row.col_indices()
                .iter()
                .zip(row.values())
                .map(|(&k, p)| p * zs[k])
                .sum()
        };
        for (e, fe) in f.iter_mut().enumerate().take(m) {
            let (u, v) = (dot(e), dot(m + e));
            *fe = self.element(e, states[e], u, v).0;
        }
    }
    /// `z' = A z + b u + G f(z)`; `u` the input signals (the first
    /// [`Self::n_inputs`] entries are used), `f` is scratch of length `m`,
    /// `states` the element states.
    pub fn rhs(
        &self,
        u: &[f64],
        z: &DVector<f64>,
        states: &[f64],
        f: &mut [f64],
        out: &mut DVector<f64>,
    ) {
        self.forces(z, states, f);
        // `A z` column by column, each sum in the order of nalgebra's `gemv`
        // (the same numbers), hand-written because this loop vectorizes and
        // `gemv`'s generic one did not (performance: with the sparse element
        // projections, a case-(a) Dormand-Prince sweep takes 2.38 G instead of
        // 2.63 G instructions, callgrind).
        let zs = z.as_slice();
        let o_s = out.as_mut_slice();
        o_s.fill(0.0);
        for (col, zj) in self.a.as_slice().chunks_exact(zs.len()).zip(zs) {
            for (o, a) in o_s.iter_mut().zip(col) {
                *o += a * zj;
            }
        }
        for (c, uc) in u.iter().take(self.b.ncols()).enumerate() {
            out.axpy(*uc, &self.b.column(c), 1.0);
        }
        for (e, fe) in f.iter().enumerate() {
            out.axpy(*fe, &self.g.column(e), 1.0);
        }
    }
}

/// A linear map `(z, u, f) -> value` for observed quantities.
#[derive(Debug, Clone)]
struct LinearMap {
    z: DMatrix<f64>,
    /// `rows x p`: one column per input signal.
    u: DMatrix<f64>,
    f: DMatrix<f64>,
}

impl LinearMap {
    fn zeros(rows: usize, nz: usize, p: usize, m: usize) -> Self {
        Self {
            z: DMatrix::zeros(rows, nz),
            u: DMatrix::zeros(rows, p),
            f: DMatrix::zeros(rows, m),
        }
    }
}

/// Layout of the observation vector (see [`AssembledSystem::observe`]).
#[derive(Debug, Clone)]
pub struct AttachmentObservation {
    pub name: String,
    pub interface_points: Vec<String>,
    pub state_names: Vec<String>,
    /// Index of the first interface displacement `e_c^T q` \[m\] (`ncon` entries).
    pub drive_index: usize,
    /// Index of the first interface force `lambda_c` \[N\] on the structure
    /// (`ncon` entries), `f_c1 = E lambda`.
    pub force_index: usize,
    /// Index of the first attachment state `x` (`ndim` entries).
    pub state_index: usize,
}

/// Structure and attachments assembled (`eq:finalassembly1`-`eq:finalassembly2`)
/// and reduced to first order.
#[derive(Debug, Clone)]
pub struct AssembledSystem {
    /// Names of the primal variables `y` (`q[i]`, then `<attachment>.<state>`).
    pub variable_names: Vec<String>,
    /// Number of structural coordinates `ndof`.
    pub ndof: usize,
    /// `A_k^asm`, `k = 0..=K` (`N x N`).
    pub coefficients: Vec<DMatrix<f64>>,
    /// `b` (`N x p`): the assembled input vectors, one column per input signal
    /// (see the module docs).
    pub input: DMatrix<f64>,
    /// `W` (`N x m`): nonlinear element directions.
    pub nonlinear_directions: DMatrix<f64>,
    /// Differential order `k_j` of each primal variable.
    pub orders: Vec<usize>,
    /// `state_of[j][d]`: index in `z` of `y_j^(d)`, `d < k_j`.
    pub state_of: Vec<Vec<usize>>,
    /// The localizations, one per attachment.
    pub localizations: Vec<AttachmentLocalization>,
    /// The explicit first-order form.
    pub first_order: FirstOrderSystem,
    /// Observation layout per attachment; index 0 of the observation is the tip.
    pub observations: Vec<AttachmentObservation>,
    /// Direction of the tip point in `q`.
    pub tip_direction: DVector<f64>,
    obs: LinearMap,
    /// `Lead^-1` and `Lower`, for derivatives of order `k_j`.
    lead_inv: DMatrix<f64>,
    lower: DMatrix<f64>,
}

impl AssembledSystem {
    /// The linear poles of the assembly (nonlinear elements off): the
    /// eigenvalues `s` of the explicit first-order matrix `A`, `z' = A z`
    /// \[rad/s, complex\]. An oscillatory pole has natural frequency `|s|` and
    /// damping ratio `-Re s / |s|`.
    pub fn linear_poles(&self) -> Vec<num_complex::Complex64> {
        self.first_order
            .a
            .complex_eigenvalues()
            .iter()
            .copied()
            .collect()
    }

    /// The structure part `q` of the eigenvector of `A` belonging to the pole
    /// `s` (from [`Self::linear_poles`]), by three steps of inverse iteration
    /// shifted by `1e-9 |s|` off the pole; `None` if the shifted matrix is
    /// singular. Normalised to unit Euclidean norm of the whole state.
    pub fn structure_mode_shape(
        &self,
        s: num_complex::Complex64,
    ) -> Option<DVector<num_complex::Complex64>> {
        use num_complex::Complex64;
        let nz = self.first_order.nz();
        let sigma = s + Complex64::new(1e-9 * s.norm(), 1e-9 * s.norm());
        let a = self.first_order.a.map(|v| Complex64::new(v, 0.0))
            - DMatrix::<Complex64>::identity(nz, nz) * sigma;
        let lu = a.lu();
        let mut x = DVector::<Complex64>::from_element(nz, Complex64::new(1.0, 0.0));
        for _ in 0..3 {
            x = lu.solve(&x)?;
            let n = x.norm();
            if !(n.is_finite() && n > 0.0) {
                return None;
            }
            x /= Complex64::new(n, 0.0);
        }
        Some(DVector::from_iterator(
            self.ndof,
            (0..self.ndof).map(|i| x[self.state_of[i][0]]),
        ))
    }

    /// Assemble `model` and `attachments`; `tip_point` names the structure point
    /// reported as the tip. Every attachment input receives the in-phase signal
    /// `u(t)` (input factors 1, one input signal).
    pub fn new(
        model: &StructuralModel,
        attachments: &[LinearAttachment],
        tip_point: &str,
    ) -> Result<Self, ReferenceError> {
        Self::with_input_factors(model, attachments, None, tip_point)
    }

    /// [`Self::new`] with complex input factors `factors[a][j]` of attachment
    /// `a`'s input `j`: it receives `Re(c e^{i Phi}) u_hat`, i.e. `Re(c) u(t) -
    /// Im(c) u_q(t)` (module docs). The system has a second input signal (the
    /// quadrature `u_q`) exactly when some factor has a non-zero imaginary part;
    /// `None` means every factor 1.
    pub fn with_input_factors(
        model: &StructuralModel,
        attachments: &[LinearAttachment],
        factors: Option<&[Vec<num_complex::Complex64>]>,
        tip_point: &str,
    ) -> Result<Self, ReferenceError> {
        let (att_inputs, quadrature) = attachment_inputs(attachments, factors);
        let p = if quadrature { 2 } else { 1 };
        let ndof = model.mass.nrows();
        check_structure_shapes(model, ndof);
        let tip_direction = point_direction(model, "options.tip_point", tip_point)?.clone();
        assert_eq!(tip_direction.len(), ndof, "tip direction length");

        // --- localizations (eq:primal, eq:L1L2)
        let (locs, names) = localizations(model, attachments, ndof)?;
        let n = names.len();

        // --- assembled coefficients (eq:finalassembly1-2)
        let (coeffs, input) = assembled_coefficients(model, attachments, &locs, &att_inputs, n, p);
        let kmax = coeffs.len() - 1;
        let m = model.nonlinear.len();
        let w = nonlinear_directions(model, n);

        // --- differential orders and states
        let (orders, state_of, nz) = differential_orders(&coeffs, kmax, n, ndof);
        let mut lead = DMatrix::zeros(n, n);
        let mut lower = DMatrix::zeros(n, nz);
        for j in 0..n {
            lead.set_column(j, &coeffs[orders[j]].column(j));
            for k in 0..orders[j] {
                lower.set_column(state_of[j][k], &coeffs[k].column(j));
            }
        }
        let lead_inv = Self::check_and_invert_lead(&lead, &names)?;

        // --- explicit first-order form
        let first_order =
            first_order_form(model, &lead_inv, &lower, &input, &w, &orders, &state_of, nz);

        let mut sys = AssembledSystem {
            variable_names: names,
            ndof,
            coefficients: coeffs,
            input,
            nonlinear_directions: w,
            orders,
            state_of,
            localizations: locs,
            first_order,
            observations: Vec::new(),
            tip_direction,
            obs: LinearMap::zeros(0, nz, p, m),
            lead_inv,
            lower,
        };
        sys.build_observations(attachments, &att_inputs)?;
        Ok(sys)
    }

    /// Equilibrate the leading matrix, check its reciprocal condition number and
    /// invert it.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(rcond > tol)` also rejects NaN
    fn check_and_invert_lead(
        lead: &DMatrix<f64>,
        names: &[String],
    ) -> Result<DMatrix<f64>, ReferenceError> {
        let n = lead.nrows();
        let mut scaled = lead.clone();
        let mut col_scale = DVector::from_element(n, 1.0);
        for j in 0..n {
            let s = scaled.column(j).amax();
            if s > 0.0 {
                col_scale[j] = 1.0 / s;
                scaled.column_mut(j).scale_mut(1.0 / s);
            }
        }
        for i in 0..n {
            let s = scaled.row(i).amax();
            if s > 0.0 {
                scaled.row_mut(i).scale_mut(1.0 / s);
            }
        }
        let svd = scaled.clone().svd(false, true);
        let (imin, smin) = svd.singular_values.argmin();
        let smax = svd.singular_values.max();
        let rcond = if smax > 0.0 { smin / smax } else { 0.0 };
        if !(rcond > SINGULAR_RCOND) {
            let v = svd
                .v_t
                .as_ref()
                .expect("requested V^T")
                .row(imin)
                .transpose();
            // null vector in unscaled variables
            let v = v.component_mul(&col_scale);
            let vmax = v.amax();
            let variables = (0..n)
                .filter(|&j| v[j].abs() > 0.1 * vmax)
                .map(|j| names[j].clone())
                .collect();
            return Err(ReferenceError::SingularLeadingMatrix { rcond, variables });
        }
        Ok(lead
            .clone()
            .lu()
            .try_inverse()
            .expect("leading matrix checked regular"))
    }

    /// Linear map of `y_j^(k)` in terms of `(z, u, f)`, or `None` when `k > k_j`.
    fn derivative_map(
        &self,
        j: usize,
        k: usize,
    ) -> Option<(RowDVector<f64>, RowDVector<f64>, RowDVector<f64>)> {
        let nz = self.first_order.nz();
        let m = self.first_order.m();
        let p = self.first_order.n_inputs();
        let kj = self.orders[j];
        if k < kj {
            let mut r = RowDVector::zeros(nz);
            r[self.state_of[j][k]] = 1.0;
            Some((r, RowDVector::zeros(p), RowDVector::zeros(m)))
        } else if k == kj {
            let li = self.lead_inv.row(j);
            Some((
                -(li * &self.lower),
                li * &self.input,
                -(li * &self.nonlinear_directions),
            ))
        } else {
            None
        }
    }

    /// The map of `sum_k R_k y^(k)` (`R_k`: `rows x N`).
    fn combine(&self, r: &[DMatrix<f64>], owner: &str) -> Result<LinearMap, ReferenceError> {
        let rows = r[0].nrows();
        let mut out = LinearMap::zeros(
            rows,
            self.first_order.nz(),
            self.first_order.n_inputs(),
            self.first_order.m(),
        );
        for (k, rk) in r.iter().enumerate() {
            for j in 0..rk.ncols() {
                let col = rk.column(j);
                if col.amax() == 0.0 {
                    continue;
                }
                let (dz, du, df) = self.derivative_map(j, k).ok_or_else(|| {
                    ReferenceError::InterfaceForceOrder {
                        attachment: owner.to_string(),
                        variable: self.variable_names[j].clone(),
                        order: k,
                        available: self.orders[j],
                    }
                })?;
                out.z += col * dz;
                out.u += col * du;
                out.f += col * df;
            }
        }
        Ok(out)
    }

    fn build_observations(
        &mut self,
        attachments: &[LinearAttachment],
        att_inputs: &[(DVector<f64>, DVector<f64>)],
    ) -> Result<(), ReferenceError> {
        let n = self.variable_names.len();
        let mut blocks: Vec<LinearMap> = Vec::new();
        let sel_q = |dirs: &DMatrix<f64>| -> DMatrix<f64> {
            let mut r = DMatrix::zeros(dirs.ncols(), n);
            r.view_mut((0, 0), (dirs.ncols(), self.ndof))
                .copy_from(&dirs.transpose());
            r
        };
        let tip = sel_q(&DMatrix::from_column_slice(
            self.ndof,
            1,
            self.tip_direction.as_slice(),
        ));
        let tip_map = self.combine(&[tip], "tip")?;
        blocks.push(tip_map);
        let mut index = 1;
        let mut observations = Vec::new();
        for ((att, loc), (bc, bs)) in attachments
            .iter()
            .zip(self.localizations.clone())
            .zip(att_inputs)
        {
            let ncon = loc.interface_points.len();
            let ndim = loc.l1.nrows();
            let drive = self.combine(&[sel_q(&loc.interface_directions)], &att.name)?;
            // lambda = pinv(B2)^T (input_map (Re c u - Im c u_q) - sum_k A_k T y^(k))
            let rk: Vec<DMatrix<f64>> = att
                .coefficients
                .iter()
                .map(|a| -(loc.pinv_b2.transpose() * a * &loc.t))
                .collect();
            let mut force = self.combine(&rk, &att.name)?;
            let mut f0 = force.u.column_mut(0);
            f0 += loc.pinv_b2.transpose() * bc;
            if force.u.ncols() > 1 {
                let mut f1 = force.u.column_mut(1);
                f1 += loc.pinv_b2.transpose() * bs;
            }
            let states = self.combine(std::slice::from_ref(&loc.t), &att.name)?;
            observations.push(AttachmentObservation {
                name: att.name.clone(),
                interface_points: loc.interface_points.clone(),
                state_names: (0..ndim)
                    .map(|i| {
                        att.state_names
                            .get(i)
                            .cloned()
                            .unwrap_or_else(|| format!("x[{i}]"))
                    })
                    .collect(),
                drive_index: index,
                force_index: index + ncon,
                state_index: index + 2 * ncon,
            });
            index += 2 * ncon + ndim;
            blocks.extend([drive, force, states]);
        }
        let nz = self.first_order.nz();
        let m = self.first_order.m();
        let p = self.first_order.n_inputs();
        let mut obs = LinearMap::zeros(index, nz, p, m);
        let mut row = 0;
        for b in blocks {
            let r = b.z.nrows();
            obs.z.view_mut((row, 0), (r, nz)).copy_from(&b.z);
            obs.u.view_mut((row, 0), (r, p)).copy_from(&b.u);
            obs.f.view_mut((row, 0), (r, m)).copy_from(&b.f);
            row += r;
        }
        self.obs = obs;
        self.observations = observations;
        Ok(())
    }

    /// Number of observed quantities (see [`Self::observe`]).
    pub fn n_observed(&self) -> usize {
        self.obs.z.nrows()
    }

    /// Observed quantities at state `z`, input `u` and nonlinear forces `f`:
    /// `[tip displacement [m], then per attachment: interface displacements [m],
    /// interface forces on the structure \[N\], attachment states x]` (indices in
    /// [`Self::observations`]). For a system with the one input signal; see
    /// [`Self::observe_inputs`] for the quadrature one.
    pub fn observe(&self, z: &DVector<f64>, u: f64, f: &[f64], out: &mut DVector<f64>) {
        assert_eq!(
            self.first_order.n_inputs(),
            1,
            "observe: the system has a quadrature input; use observe_inputs"
        );
        self.observe_inputs(z, &[u], f, out)
    }

    /// [`Self::observe`] with every input signal (`u[c]`, `c <
    /// first_order.n_inputs()`: in-phase, then quadrature).
    pub fn observe_inputs(&self, z: &DVector<f64>, u: &[f64], f: &[f64], out: &mut DVector<f64>) {
        out.gemv(1.0, &self.obs.z, z, 0.0);
        for (c, column) in self.obs.u.column_iter().enumerate() {
            out.axpy(u[c], &column, 1.0);
        }
        for (e, fe) in f.iter().enumerate() {
            out.axpy(*fe, &self.obs.f.column(e), 1.0);
        }
    }

    /// First-order state for structural displacements `q0` \[m\] and velocities
    /// `qd0` \[m/s\]; all attachment states zero.
    pub fn state_from_structure(&self, q0: &DVector<f64>, qd0: &DVector<f64>) -> DVector<f64> {
        let mut z = DVector::zeros(self.first_order.nz());
        for i in 0..self.ndof {
            z[self.state_of[i][0]] = q0[i];
            z[self.state_of[i][1]] = qd0[i];
        }
        z
    }

    /// Structural displacements `q` \[m\] and velocities `q'` \[m/s\] of state `z`.
    pub fn structure_state(&self, z: &DVector<f64>) -> (DVector<f64>, DVector<f64>) {
        let q = DVector::from_fn(self.ndof, |i, _| z[self.state_of[i][0]]);
        let qd = DVector::from_fn(self.ndof, |i, _| z[self.state_of[i][1]]);
        (q, qd)
    }
}
