//! Modal tables refined to a stated interpolation accuracy by fresh Harmonic
//! Balance solves at interval midpoints.
use super::driver::AmplitudeSolver;
use super::epmc::Normalisation;
use super::errors::NmaError;
use super::modal_basis::ModalBasis;
use super::options::NmaOptions;
use super::results::{BranchPoint, NmaResult, TablePolicy};
use crate::structure::StructuralModel;
use crate::table::{ModalTable, TableAccuracy, TableDiscontinuity, HIGHEST_HARMONIC_SHARE_WARNING};
use crate::Complex64;
use rayon::prelude::*;
use std::sync::Arc;

/// Targets of [`NmaResult::refined_table`] (serialisable; missing keys take
/// the defaults): `omega_rel = 1e-5`, `rel = 1e-4` (damping ratio and point
/// shapes), `max_points = 400` (the cap on table points), `fold_margin = 0.01`
/// (a primary branch cut at its first fold `a_f` is tabulated up to
/// `(1 - fold_margin) a_f`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RefineOptions {
    /// Relative accuracy target of `omega(a)`.
    pub omega_rel: f64,
    /// Relative accuracy target of `D(a)` and of the point shapes.
    pub rel: f64,
    /// Largest number of table points; refinement stops there (recorded as
    /// [`TableAccuracy::capped`]).
    pub max_points: usize,
    /// Relative distance from the first fold `a_f` at which a truncated
    /// primary branch ([`TablePolicy::PrimaryBranch`]) ends: the last table
    /// point is the HB solution at `(1 - fold_margin) a_f` [-]. At the fold
    /// itself `omega(a)` has a vertical tangent, so intervals reaching it
    /// cannot meet the targets; `0` tabulates up to the last branch point.
    pub fold_margin: f64,
}

impl Default for RefineOptions {
    fn default() -> Self {
        Self {
            omega_rel: 1e-5,
            rel: 1e-4,
            max_points: 400,
            fold_margin: 0.01,
        }
    }
}

/// PCHIP errors of `interp` at `a` against the HB solution `sol`: relative
/// `omega`, relative `D` (against `max(|D|, 1e-10)`), largest point-shape
/// error relative to the point's largest harmonic.
pub fn table_errors(
    interp: &crate::table::TableInterpolator,
    sol: &BranchPoint,
) -> Result<(f64, f64, f64), crate::table::TableError> {
    let a = sol.amplitude;
    let p = interp.eval(a)?;
    let e_w = (p.omega_rad_s / sol.omega_rad_s - 1.0).abs();
    let e_d = (p.damping_ratio - sol.damping_ratio).abs() / sol.damping_ratio.abs().max(1e-10);
    let mut e_s: f64 = 0.0;
    let mut buf = vec![Complex64::new(0.0, 0.0); interp.harmonics() + 1];
    for (k, shape) in sol.points.iter().enumerate() {
        interp.shape_all(k, a, &mut buf)?;
        let scale = shape
            .iter()
            .map(|c| c.norm())
            .fold(0.0, f64::max)
            .max(1e-300);
        for (x, y) in buf.iter().zip(shape) {
            e_s = e_s.max((x - y).norm() / scale);
        }
    }
    Ok((e_w, e_d, e_s))
}

impl NmaResult {
    /// The modal table under `policy`, refined to a stated accuracy: the PCHIP
    /// interpolation is compared with fresh Harmonic Balance solves
    /// ([`solve_at_amplitude`], paper normalisation) at the midpoint of every
    /// interval, and each solve that misses a target is inserted, until
    /// `omega` is within `refine.omega_rel / 2` and `D` and the shapes within
    /// `refine.rel / 2` at every midpoint (half the target: the midpoint error
    /// underestimates the largest error of an interval), or the table has
    /// `refine.max_points`, or an interval is too narrow to split in floating
    /// point (next to a fold; both end the refinement there with `capped`).
    /// Intervals whose PCHIP slopes change by an insertion are checked again
    /// (against their midpoint solution, which stays valid while the
    /// interval's end points do), so [`ModalTable::accuracy`] holds the
    /// midpoint errors of the final table. The midpoint solves are converged
    /// HB solutions (tolerance of `opts.continuation`) by chord Newton
    /// ([`super::continuation::solve_fixed_parameter_chord`]: one
    /// factorisation per check from the close PCHIP guess).
    ///
    /// `model`, `basis` and `opts` are those of the analysis; the branch must
    /// have been computed with `store_coordinates` (the Newton guesses).
    pub fn refined_table(
        &self,
        model: &StructuralModel,
        basis: Arc<ModalBasis>,
        opts: &NmaOptions,
        policy: TablePolicy,
        refine: &RefineOptions,
    ) -> Result<ModalTable, NmaError> {
        let (idx, truncated) = self.table_indices(policy);
        let discontinuity = self.branch_discontinuity(policy);
        let mut pts: Vec<BranchPoint> = idx.iter().map(|&i| self.branch[i].clone()).collect();
        if pts.iter().any(|b| b.coordinates.is_empty()) {
            return Err(NmaError::RefinementNeedsCoordinates);
        }
        let fixed = NmaOptions {
            normalisation: Normalisation::Fundamental,
            store_coordinates: true,
            points: self.point_names.clone(),
            ..opts.clone()
        };
        let solver = AmplitudeSolver {
            chord: true,
            ..AmplitudeSolver::new(model, basis.clone(), &fixed)?
        };
        // end a truncated primary branch a stated margin before the fold
        let range_end = match (truncated, policy) {
            (Some(a_f), TablePolicy::PrimaryBranch) => {
                end_before_fold(&solver, &mut pts, a_f, refine)?
            }
            _ => None,
        };
        let n_int = pts.len().saturating_sub(1);
        let mut st = Refinement {
            pts,
            checked: vec![false; n_int],
            errors: vec![(0.0, 0.0, 0.0); n_int],
            mids: vec![None; n_int],
            checks: 0,
            capped: false,
            truncated,
            discontinuity,
        };
        // a fold tabulated without margin is steep by nature, not a jump
        let steep_end_ok = truncated.is_some() && range_end.is_none();
        loop {
            let refs: Vec<&BranchPoint> = st.pts.iter().collect();
            let table = self.table_of(&refs, st.truncated, policy);
            let interp = table
                .interpolator()
                .map_err(|e| NmaError::Table(e.to_string()))?;
            if st.pass(&solver, &interp, refine, steep_end_ok)? {
                break;
            }
        }
        let refs: Vec<&BranchPoint> = st.pts.iter().collect();
        let mut table = self.table_of(&refs, st.truncated, policy);
        st.describe(&mut table, range_end, refine);
        Ok(table)
    }
}

/// A truncated primary branch (first fold at `a_f`) ended at
/// `a_end = (1 - fold_margin) a_f`: the points from `a_end` on replaced by
/// the HB solution there (Newton from the nearest branch point above, else
/// below). Returns `a_end`, or `None` with `fold_margin = 0` or no point
/// below `a_end`.
fn end_before_fold(
    solver: &AmplitudeSolver,
    pts: &mut Vec<BranchPoint>,
    a_f: f64,
    refine: &RefineOptions,
) -> Result<Option<f64>, NmaError> {
    let m = refine.fold_margin;
    if !(0.0..1.0).contains(&m) {
        return Err(NmaError::InvalidFoldMargin { fold_margin: m });
    }
    if m > 0.0 {
        let a_end = (1.0 - m) * a_f;
        let keep = pts.iter().take_while(|b| b.amplitude < a_end).count();
        if keep >= 1 {
            // Newton from the nearest branch point above (else below)
            let guess = pts.get(keep).unwrap_or(&pts[keep - 1]).clone();
            let sol = solver
                .solve(a_end, &guess)
                .or_else(|_| solver.solve(a_end, &pts[keep - 1]))
                .map_err(|e| refine_failed(e, a_end))?;
            pts.truncate(keep);
            pts.push(sol);
            return Ok(Some(a_end));
        }
    }
    Ok(None)
}

/// Relative errors of `omega`, `D` and the shapes at an interval's midpoint.
type Errors = (f64, f64, f64);

/// The state of [`NmaResult::refined_table`]'s refinement: the table's
/// points and, per interval, whether it is checked against the current
/// table, its errors and its midpoint HB solution once solved.
struct Refinement {
    pts: Vec<BranchPoint>,
    /// Per interval: checked against the current table.
    checked: Vec<bool>,
    /// Per interval: its midpoint errors.
    errors: Vec<Errors>,
    /// Per interval: its midpoint HB solution once solved (it stays valid
    /// while the interval's end points do; a re-check after a neighbour's
    /// insertion only measures the new interpolant against it).
    mids: Vec<Option<BranchPoint>>,
    /// HB solves made.
    checks: usize,
    /// Some interval kept without meeting the targets.
    capped: bool,
    /// Where the table ends (a fold or a jump).
    truncated: Option<f64>,
    discontinuity: Option<TableDiscontinuity>,
}

impl Refinement {
    /// One pass over the intervals against the table `interp` of the current
    /// points: the unchecked ones checked (their midpoints solved in
    /// parallel, taken in interval order), a midpoint inserted where the
    /// targets are missed, the neighbours of an insertion unchecked (PCHIP
    /// slopes change). Returns whether the refinement is over (nothing
    /// inserted, or the table cut before a jump).
    fn pass(
        &mut self,
        solver: &AmplitudeSolver,
        interp: &crate::table::TableInterpolator,
        refine: &RefineOptions,
        steep_end_ok: bool,
    ) -> Result<bool, NmaError> {
        let pts = &self.pts;
        // the unchecked intervals' HB solves are independent of each
        // other: solved in parallel, then taken in interval order (the
        // table is the same for any number of threads)
        let unsolved: Vec<usize> = (0..pts.len().saturating_sub(1))
            .filter(|&i| !self.checked[i] && self.mids[i].is_none())
            .collect();
        let mut solved = unsolved
            .par_iter()
            .map(|&i| check_interval(solver, interp, &pts[i], &pts[i + 1]))
            .collect::<Vec<_>>()
            .into_iter();
        let mut next: Vec<BranchPoint> = Vec::with_capacity(2 * pts.len());
        let mut next_checked = Vec::new();
        let mut next_errors = Vec::new();
        let mut next_mids = Vec::new();
        let mut inserted = Vec::new();
        let mut cut = false;
        for i in 0..pts.len().saturating_sub(1) {
            next.push(pts[i].clone());
            if self.checked[i] {
                next_checked.push(true);
                next_errors.push(self.errors[i]);
                next_mids.push(self.mids[i].take());
                continue;
            }
            let (p, q) = (&pts[i], &pts[i + 1]);
            let (sol, err) = match self.mids[i].take() {
                Some(sol) => {
                    let err =
                        table_errors(interp, &sol).map_err(|e| NmaError::Table(e.to_string()))?;
                    (sol, err)
                }
                None => {
                    self.checks += 1;
                    solved.next().expect("one solve per unsolved interval")?
                }
            };
            // the midpoint error underestimates an interval's largest
            // error (PCHIP's error is not symmetric): ask half the target
            let good = err.0 <= 0.5 * refine.omega_rel
                && err.1 <= 0.5 * refine.rel
                && err.2 <= 0.5 * refine.rel;
            // an interval too narrow to split in floating point (next to
            // the fold, where omega(a) has an infinite slope) stays as is
            let narrow = !(sol.amplitude > p.amplitude && sol.amplitude < q.amplitude);
            // an interval bisected down to a relative width of
            // JUMP_WIDTH without meeting the targets is a jump of the
            // branch (a stepped-over loop): the table ends before it
            let last = i + 2 == pts.len();
            if !good
                && q.amplitude - p.amplitude <= JUMP_WIDTH * q.amplitude
                && !(last && steep_end_ok)
            {
                self.discontinuity = Some(jump(p, q, err));
                cut = true;
                break;
            }
            if good || narrow || pts.len() + inserted.len() >= refine.max_points {
                self.capped |= !good;
                next_checked.push(true);
                next_errors.push(err);
                next_mids.push(Some(sol));
            } else {
                inserted.push(next.len());
                next.push(sol);
                next_checked.extend([false, false]);
                next_errors.extend([err, err]);
                next_mids.extend([None, None]);
            }
        }
        if cut {
            // keep the points up to the jump's left end
            let keep = next.len();
            next_checked.truncate(keep - 1);
            next_errors.truncate(keep - 1);
            next_mids.truncate(keep - 1);
            inserted.retain(|&node| node < keep);
            let a = next[keep - 1].amplitude;
            self.truncated = Some(self.truncated.map_or(a, |t: f64| t.min(a)));
        } else if let Some(last) = pts.last() {
            next.push(last.clone());
        }
        if inserted.is_empty() {
            self.errors = next_errors;
            if cut {
                self.pts = next;
            }
            return Ok(true);
        }
        // PCHIP slopes at the nodes next to an insertion change: check the
        // neighbouring intervals again
        for &node in &inserted {
            if node >= 2 {
                next_checked[node - 2] = false;
            }
            if node + 1 < next_checked.len() {
                next_checked[node + 1] = false;
            }
        }
        self.pts = next;
        self.checked = next_checked;
        self.errors = next_errors;
        self.mids = next_mids;
        Ok(false)
    }

    /// The refined table's description and [`TableAccuracy`]: the worst
    /// midpoint errors, the targets, the checks, where the worst errors are.
    fn describe(&self, table: &mut ModalTable, range_end: Option<f64>, refine: &RefineOptions) {
        let (pts, errors) = (&self.pts, &self.errors);
        let worst = errors.iter().fold((0.0f64, 0.0f64, 0.0f64), |w, e| {
            (w.0.max(e.0), w.1.max(e.1), w.2.max(e.2))
        });
        if let Some(a_end) = range_end {
            table.description += &format!(
                "; tabulated up to a = {a_end:e} = (1 - {}) times the first fold",
                refine.fold_margin
            );
        }
        table.description += &format!(
            "; refined to {} points: PCHIP vs HB at every interval midpoint within omega {:.1e}, D {:.1e}, shapes {:.1e} (relative){}",
            pts.len(),
            worst.0,
            worst.1,
            worst.2,
            if self.capped { ", capped" } else { "" }
        );
        table.accuracy = Some(TableAccuracy {
            omega_rel: worst.0,
            damping_rel: worst.1,
            shape_rel: worst.2,
            target_omega_rel: refine.omega_rel,
            target_rel: refine.rel,
            checks: self.checks,
            capped: self.capped,
            fold_margin: range_end.map(|_| refine.fold_margin),
            omega_worst_amplitude: None,
            damping_worst_amplitude: None,
            shape_worst_amplitude: None,
            discontinuity: self.discontinuity.clone(),
            highest_harmonic_share: None,
            highest_harmonic_share_amplitude: None,
            highest_harmonic_share_from_amplitude: None,
        });
        if let Some(acc) = table.accuracy.as_mut() {
            worst_locations(acc, pts, errors, refine);
            highest_harmonic(acc, pts);
        }
    }
}

/// The jump of the branch in the interval `p`..`q` whose midpoint errors
/// `err` stay above the targets at a relative width [`JUMP_WIDTH`].
fn jump(p: &BranchPoint, q: &BranchPoint, err: Errors) -> TableDiscontinuity {
    TableDiscontinuity {
        amplitude: p.amplitude,
        amplitude_after: q.amplitude,
        omega_jump_rel: (q.omega_rad_s / p.omega_rad_s - 1.0).abs(),
        reason: format!(
            "the refinement bisected the interval to a relative width {JUMP_WIDTH:.0e} and still missed the targets (omega error {:.1e})",
            err.0
        ),
    }
}

/// A failed Newton solve of the refinement at amplitude `a` as
/// [`NmaError::RefinementSolveFailed`].
pub(super) fn refine_failed(e: NmaError, amplitude: f64) -> NmaError {
    match e {
        NmaError::StartNotConverged {
            residual_norm,
            iterations,
            ..
        } => NmaError::RefinementSolveFailed {
            amplitude,
            residual_norm,
            iterations,
        },
        other => other,
    }
}

/// The HB solution at the midpoint amplitude of the interval `p`-`q` and the
/// PCHIP errors of `interp` there ([`NmaResult::refined_table`]).
pub(super) fn check_interval(
    solver: &AmplitudeSolver,
    interp: &crate::table::TableInterpolator,
    p: &BranchPoint,
    q: &BranchPoint,
) -> Result<(BranchPoint, (f64, f64, f64)), NmaError> {
    let am = 0.5 * (p.amplitude + q.amplitude);
    // frequency and damping from the table being checked (close to the
    // solution: fewer Newton steps), shapes blended
    let (omega_rad_s, damping_ratio) = match interp.eval(am) {
        Ok(t) => (t.omega_rad_s, t.damping_ratio),
        Err(_) => (
            0.5 * (p.omega_rad_s + q.omega_rad_s),
            0.5 * (p.damping_ratio + q.damping_ratio),
        ),
    };
    let guess = BranchPoint {
        omega_rad_s,
        damping_ratio,
        coordinates: p
            .coordinates
            .iter()
            .zip(&q.coordinates)
            .map(|(u, v)| u.iter().zip(v).map(|(x, y)| 0.5 * (x + y)).collect())
            .collect(),
        ..p.clone()
    };
    // Newton from the blended neighbours, else from either one (near the
    // fold ending the primary branch `omega(a)` is steep)
    let sol = solver
        .solve(am, &guess)
        .or_else(|_| solver.solve(am, q))
        .or_else(|_| solver.solve(am, p))
        .map_err(|e| refine_failed(e, am))?;
    let err = table_errors(interp, &sol).map_err(|e| NmaError::Table(e.to_string()))?;
    Ok((sol, err))
}

/// Relative width `(a_q - a_p) / a_q` of a table interval below which a
/// refinement that still misses its targets declares a jump of the branch
/// ([`TableDiscontinuity`]): a smooth `omega(a)` with a finite slope meets the
/// default targets at widths of 1e-3 and more; ~20 bisections of a
/// continuation step to reach 1e-6 mean the data is not continuous there.
pub const JUMP_WIDTH: f64 = 1e-6;

/// The amplitudes (interval midpoints) of the worst errors, where they miss
/// the targets.
fn worst_locations(
    acc: &mut TableAccuracy,
    pts: &[BranchPoint],
    errors: &[(f64, f64, f64)],
    refine: &RefineOptions,
) {
    let mid = |i: usize| 0.5 * (pts[i].amplitude + pts[i + 1].amplitude);
    let argmax = |get: &dyn Fn(&(f64, f64, f64)) -> f64| {
        (0..errors.len().min(pts.len().saturating_sub(1)))
            .max_by(|&i, &j| get(&errors[i]).total_cmp(&get(&errors[j])))
            .map(mid)
    };
    if acc.omega_rel > refine.omega_rel {
        acc.omega_worst_amplitude = argmax(&|e| e.0);
    }
    if acc.damping_rel > refine.rel {
        acc.damping_worst_amplitude = argmax(&|e| e.1);
    }
    if acc.shape_rel > refine.rel {
        acc.shape_worst_amplitude = argmax(&|e| e.2);
    }
}

/// The largest energy share of the highest harmonic over the table points,
/// recorded where it exceeds [`HIGHEST_HARMONIC_SHARE_WARNING`].
fn highest_harmonic(acc: &mut TableAccuracy, pts: &[BranchPoint]) {
    let (share, a) = pts
        .iter()
        .filter_map(|b| b.harmonic_energy_shares.last().map(|&s| (s, b.amplitude)))
        .fold((0.0f64, f64::NAN), |w, x| if x.0 > w.0 { x } else { w });
    if share > HIGHEST_HARMONIC_SHARE_WARNING {
        acc.highest_harmonic_share = Some(share);
        acc.highest_harmonic_share_amplitude = Some(a);
        acc.highest_harmonic_share_from_amplitude = pts
            .iter()
            .find(|b| {
                b.harmonic_energy_shares
                    .last()
                    .is_some_and(|&s| s > HIGHEST_HARMONIC_SHARE_WARNING)
            })
            .map(|b| b.amplitude);
    }
}
