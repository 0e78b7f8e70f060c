//! The primal localization of the assembly (`eq:primal`, `eq:L1L2`): the
//! points' directions in the structure's coordinates, the attachments'
//! interface localizations and null spaces, the assembled coefficient
//! matrices (`eq:finalassembly1`-`eq:finalassembly2`), the differential
//! orders and the explicit first-order form of [`super::AssembledSystem`].
use super::*;

pub(super) fn point_direction<'a>(
    model: &'a StructuralModel,
    owner: &str,
    name: &str,
) -> Result<&'a DVector<f64>, ReferenceError> {
    model
        .points
        .iter()
        .find(|p| p.name == name)
        .map(|p| &p.direction)
        .ok_or_else(|| ReferenceError::UnknownPoint {
            owner: owner.to_string(),
            point: name.to_string(),
            known: model.points.iter().map(|p| p.name.clone()).collect(),
        })
}

/// Basis of `null(B)` from the reduced row-echelon form (partial pivoting), and
/// the rank. Free columns get unit entries, so a signed-Boolean `B` gives an
/// exact, sparse basis.
/// Hand-written for exactness: an SVD null space (nalgebra) would be dense
/// and only accurate to rounding.
fn rref_null_space(b: &DMatrix<f64>) -> (DMatrix<f64>, usize) {
    let (rows, cols) = b.shape();
    let mut r = b.clone();
    let scale = b.amax().max(f64::MIN_POSITIVE);
    let tol = 1e-12 * scale * (rows.max(cols) as f64);
    let mut pivots: Vec<usize> = Vec::new();
    let mut row = 0;
    for col in 0..cols {
        if row == rows {
            break;
        }
        let (mut best, mut best_val) = (row, r[(row, col)].abs());
        for i in row + 1..rows {
            if r[(i, col)].abs() > best_val {
                best = i;
                best_val = r[(i, col)].abs();
            }
        }
        if best_val <= tol {
            continue;
        }
        r.swap_rows(row, best);
        let p = r[(row, col)];
        for j in 0..cols {
            r[(row, j)] /= p;
        }
        for i in 0..rows {
            if i != row {
                let fct = r[(i, col)];
                if fct != 0.0 {
                    for j in 0..cols {
                        r[(i, j)] -= fct * r[(row, j)];
                    }
                }
            }
        }
        pivots.push(col);
        row += 1;
    }
    let free: Vec<usize> = (0..cols).filter(|c| !pivots.contains(c)).collect();
    let mut null = DMatrix::zeros(cols, free.len());
    for (k, &fc) in free.iter().enumerate() {
        null[(fc, k)] = 1.0;
        for (pr, &pc) in pivots.iter().enumerate() {
            null[(pc, k)] = -r[(pr, fc)];
        }
    }
    (null, pivots.len())
}

/// The (in-phase, quadrature) input vector of each attachment (`ndim` rows:
/// `input_map Re(c)`, `-input_map Im(c)` with `c` its input factors, every
/// factor 1 without `factors`) and whether the quadrature input signal is
/// needed (some factor has a non-zero imaginary part).
#[allow(clippy::type_complexity)]
pub(super) fn attachment_inputs(
    attachments: &[LinearAttachment],
    factors: Option<&[Vec<num_complex::Complex64>]>,
) -> (Vec<(DVector<f64>, DVector<f64>)>, bool) {
    if let Some(f) = factors {
        assert_eq!(f.len(), attachments.len(), "one factor list per attachment");
        for (att, fa) in attachments.iter().zip(f) {
            assert_eq!(
                fa.len(),
                att.input_map.ncols(),
                "attachment '{}': one factor per input",
                att.name
            );
        }
    }
    // (in-phase, quadrature) input vector of each attachment, `ndim` rows
    let quadrature = factors.is_some_and(|f| f.iter().flatten().any(|c| c.im != 0.0));
    let att_inputs = attachments
        .iter()
        .enumerate()
        .map(|(a, att)| {
            let nu = att.input_map.ncols();
            let (re, im) = match factors {
                Some(f) => (
                    DVector::from_iterator(nu, f[a].iter().map(|c| c.re)),
                    DVector::from_iterator(nu, f[a].iter().map(|c| -c.im)),
                ),
                None => (DVector::from_element(nu, 1.0), DVector::zeros(nu)),
            };
            (&att.input_map * re, &att.input_map * im)
        })
        .collect();
    (att_inputs, quadrature)
}

/// `M`, `K` and `D` are `ndof x ndof` (panics otherwise).
pub(super) fn check_structure_shapes(model: &StructuralModel, ndof: usize) {
    assert_eq!(
        model.mass.shape(),
        (ndof, ndof),
        "mass matrix must be square"
    );
    assert_eq!(
        model.stiffness.shape(),
        (ndof, ndof),
        "stiffness vs mass dimensions"
    );
    assert_eq!(
        model.damping.shape(),
        (ndof, ndof),
        "damping vs mass dimensions"
    );
}

/// The attachments' localizations (eq:primal, eq:L1L2), each `T_a` over all
/// `N` variables, and the names of the variables `y` (the structure's `q[i]`,
/// then each attachment's `x_r`).
pub(super) fn localizations(
    model: &StructuralModel,
    attachments: &[LinearAttachment],
    ndof: usize,
) -> Result<(Vec<AttachmentLocalization>, Vec<String>), ReferenceError> {
    let mut locs = Vec::new();
    let mut names: Vec<String> = (0..ndof).map(|i| format!("q[{i}]")).collect();
    let mut offset = ndof;
    for att in attachments {
        let (e, pinv_b2, l1, l2) = localize(model, att, ndof)?;
        let ndim = l1.nrows();
        let nr = l2.ncols();
        for r in 0..nr {
            let col = l2.column(r);
            let nonzero: Vec<usize> = (0..ndim).filter(|&i| col[i] != 0.0).collect();
            let state = if nonzero.len() == 1 && col[nonzero[0]] == 1.0 {
                att.state_names
                    .get(nonzero[0])
                    .cloned()
                    .unwrap_or_else(|| format!("x[{}]", nonzero[0]))
            } else {
                format!("x_r[{r}]")
            };
            names.push(format!("{}.{}", att.name, state));
        }
        locs.push((att, e, pinv_b2, l1, l2, offset));
        offset += nr;
    }
    let n = offset;
    let locs = locs
        .into_iter()
        .map(|(att, e, pinv_b2, l1, l2, off)| {
            let ndim = l1.nrows();
            let mut t = DMatrix::zeros(ndim, n);
            t.view_mut((0, 0), (ndim, ndof)).copy_from(&l1);
            t.view_mut((0, off), (ndim, l2.ncols())).copy_from(&l2);
            AttachmentLocalization {
                name: att.name.clone(),
                interface_points: att.interface_points.clone(),
                interface_directions: e,
                pinv_b2,
                l1,
                l2,
                offset: off,
                t,
            }
        })
        .collect();
    Ok((locs, names))
}

/// One attachment's localization (eq:L1L2): `E` (the interface points'
/// directions), `pinv(B2)`, `L1 = pinv(B2) E^T` and `L2`, a basis of
/// `null(B2)`; its dimensions checked (panics) and `B2` of full row rank
/// (an error otherwise).
#[allow(clippy::type_complexity)]
fn localize(
    model: &StructuralModel,
    att: &LinearAttachment,
    ndof: usize,
) -> Result<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>), ReferenceError> {
    let ndim = att.coefficients.first().map(|a| a.nrows()).unwrap_or(0);
    if att.coefficients.is_empty() || ndim == 0 {
        return Err(ReferenceError::EmptyAttachment {
            attachment: att.name.clone(),
        });
    }
    for a in &att.coefficients {
        assert_eq!(
            a.shape(),
            (ndim, ndim),
            "attachment '{}': A_k dimensions",
            att.name
        );
    }
    let ncon = att.b2.nrows();
    assert_eq!(
        att.b2.ncols(),
        ndim,
        "attachment '{}': B2 columns",
        att.name
    );
    assert_eq!(
        att.interface_points.len(),
        ncon,
        "attachment '{}': interface points",
        att.name
    );
    assert_eq!(
        att.input_map.nrows(),
        ndim,
        "attachment '{}': input map rows",
        att.name
    );
    let mut e = DMatrix::zeros(ndof, ncon);
    for (c, p) in att.interface_points.iter().enumerate() {
        let dir = point_direction(model, &att.name, p)?;
        assert_eq!(dir.len(), ndof, "point '{p}' direction length");
        e.set_column(c, dir);
    }
    let (l2, rank) = rref_null_space(&att.b2);
    if rank != ncon {
        return Err(ReferenceError::CompatibilityRank {
            attachment: att.name.clone(),
            rank,
            constraints: ncon,
        });
    }
    let gram = &att.b2 * att.b2.transpose();
    let gram_inv = gram
        .try_inverse()
        .ok_or_else(|| ReferenceError::CompatibilityRank {
            attachment: att.name.clone(),
            rank,
            constraints: ncon,
        })?;
    let pinv_b2 = att.b2.transpose() * gram_inv;
    let l1 = &pinv_b2 * e.transpose();
    Ok((e, pinv_b2, l1, l2))
}

/// The assembled coefficients `A_k` (eq:finalassembly1-2, `N x N`, at least
/// up to `k = 2`: `K`, `D`, `M` of the structure plus each attachment's
/// `T_a^T A_k T_a`) and the input matrix (`N x p`: `T_a^T b_a` of the
/// in-phase and, with `p = 2`, quadrature input vectors).
pub(super) fn assembled_coefficients(
    model: &StructuralModel,
    attachments: &[LinearAttachment],
    locs: &[AttachmentLocalization],
    att_inputs: &[(DVector<f64>, DVector<f64>)],
    n: usize,
    p: usize,
) -> (Vec<DMatrix<f64>>, DMatrix<f64>) {
    let ndof = model.mass.nrows();
    let quadrature = p == 2;
    let kmax = attachments
        .iter()
        .map(|a| a.coefficients.len() - 1)
        .max()
        .unwrap_or(0)
        .max(2);
    let mut coeffs = vec![DMatrix::<f64>::zeros(n, n); kmax + 1];
    coeffs[0]
        .view_mut((0, 0), (ndof, ndof))
        .copy_from(&model.stiffness);
    coeffs[1]
        .view_mut((0, 0), (ndof, ndof))
        .copy_from(&model.damping);
    coeffs[2]
        .view_mut((0, 0), (ndof, ndof))
        .copy_from(&model.mass);
    let mut input = DMatrix::zeros(n, p);
    for ((att, loc), (bc, bs)) in attachments.iter().zip(locs).zip(att_inputs) {
        for (k, a) in att.coefficients.iter().enumerate() {
            coeffs[k] += loc.t.transpose() * a * &loc.t;
        }
        let mut c0 = input.column_mut(0);
        c0 += loc.t.transpose() * bc;
        if quadrature {
            let mut c1 = input.column_mut(1);
            c1 += loc.t.transpose() * bs;
        }
    }
    (coeffs, input)
}

/// `W` (`N x m`): the nonlinear elements' directions over the structure's
/// coordinates.
pub(super) fn nonlinear_directions(model: &StructuralModel, n: usize) -> DMatrix<f64> {
    let ndof = model.mass.nrows();
    let m = model.nonlinear.len();
    let mut w = DMatrix::zeros(n, m);
    for (e, el) in model.nonlinear.iter().enumerate() {
        assert_eq!(
            el.direction.len(),
            ndof,
            "nonlinear element '{}' direction",
            el.name
        );
        w.view_mut((0, e), (ndof, 1)).copy_from(&el.direction);
    }
    w
}

/// Each variable's differential order (its highest `k` with a non-zero
/// column of `A_k`; at least 2 for the structure's coordinates), the states
/// `z` of each variable (its derivatives `0..order`) and their number `nz`.
pub(super) fn differential_orders(
    coeffs: &[DMatrix<f64>],
    kmax: usize,
    n: usize,
    ndof: usize,
) -> (Vec<usize>, Vec<Vec<usize>>, usize) {
    // a column counts as non-zero against the largest entry of the same A_k
    // (entries of different A_k carry different units)
    let kmax_abs: Vec<f64> = coeffs.iter().map(|a| a.amax()).collect();
    let nonzero = |k: usize, j: usize| coeffs[k].column(j).amax() > ZERO_COLUMN_RTOL * kmax_abs[k];
    let orders: Vec<usize> = (0..n)
        .map(|j| (0..=kmax).rev().find(|&k| nonzero(k, j)).unwrap_or(0))
        .collect();
    for (i, &k) in orders.iter().enumerate().take(ndof) {
        assert!(
            k >= 2,
            "structural coordinate {i} has no mass (M must be positive definite)"
        );
    }
    let mut state_of = vec![Vec::new(); n];
    let mut nz = 0;
    for j in 0..n {
        for _ in 0..orders[j] {
            state_of[j].push(nz);
            nz += 1;
        }
    }
    (orders, state_of, nz)
}

/// The explicit first-order form `z' = A z + b u + G f` from the leading
/// matrix's inverse `lead_inv`, the lower-order coefficients `lower`, the
/// input matrix and `W`, with the projections `c_e`, `d_e` of the nonlinear
/// elements.
#[allow(clippy::too_many_arguments)]
pub(super) fn first_order_form(
    model: &StructuralModel,
    lead_inv: &DMatrix<f64>,
    lower: &DMatrix<f64>,
    input: &DMatrix<f64>,
    w: &DMatrix<f64>,
    orders: &[usize],
    state_of: &[Vec<usize>],
    nz: usize,
) -> FirstOrderSystem {
    let (n, p, m) = (orders.len(), input.ncols(), w.ncols());
    let ndof = model.mass.nrows();
    let pl = lead_inv * lower;
    let pb = lead_inv * input;
    let pw = lead_inv * w;
    let mut a = DMatrix::zeros(nz, nz);
    let mut bz = DMatrix::zeros(nz, p);
    let mut g = DMatrix::zeros(nz, m);
    for j in 0..n {
        let kj = orders[j];
        if kj == 0 {
            continue;
        }
        for d in 0..kj - 1 {
            a[(state_of[j][d], state_of[j][d + 1])] = 1.0;
        }
        let row = state_of[j][kj - 1];
        a.set_row(row, &(-pl.row(j)));
        bz.set_row(row, &pb.row(j));
        g.set_row(row, &(-pw.row(j)));
    }
    let mut proj = DMatrix::zeros(2 * m, nz);
    for (e, el) in model.nonlinear.iter().enumerate() {
        for i in 0..ndof {
            proj[(e, state_of[i][0])] = el.direction[i];
            proj[(m + e, state_of[i][1])] = el.direction[i];
        }
    }
    FirstOrderSystem {
        proj_rows: CsrMatrix::from(&proj),
        a,
        b: bz,
        g,
        proj,
        laws: model.nonlinear.iter().map(|e| e.law.clone()).collect(),
    }
}
