//! Harmonic truncation you can trust: `harmonics = "auto"`, the smallest `H`
//! whose refined modal table agrees with that of `H + 4` within the table
//! accuracy.
use super::driver::nonlinear_modal_analysis_with_basis;
use super::errors::NmaError;
use super::modal_basis::ModalBasis;
use super::options::NmaOptions;
use super::refine::RefineOptions;
use super::results::TablePolicy;
use crate::structure::StructuralModel;
use crate::table::{ModalTable, TableError};
use crate::Complex64;
use std::collections::BTreeMap;
use std::sync::Arc;

/// The comparison step of the `auto` rule: `H` is checked against `H + 4`
/// (the next two odd harmonics of a symmetric nonlinearity, or four of an
/// asymmetric one).
pub const AUTO_HARMONICS_STEP: usize = 4;

/// Largest `H` the `auto` rule tries (then `H + 4` = 44 is the largest solved).
pub const AUTO_HARMONICS_MAX: usize = 40;

/// Largest relative differences `(omega, D, shape)` between the tables `a` and
/// `b` at 50 log-spaced amplitudes of their common range (shapes: every point
/// of `a` found in `b`, relative to the point's largest harmonic in `b`;
/// harmonics beyond a table's `H` count as zero; `D` against `max(|D|, 1e-10)`).
pub fn table_agreement(a: &ModalTable, b: &ModalTable) -> Result<(f64, f64, f64), TableError> {
    let (ia, ib) = (a.interpolator()?, b.interpolator()?);
    let (lo_a, hi_a) = ia.amplitude_range();
    let (lo_b, hi_b) = ib.amplitude_range();
    let (lo, hi) = (lo_a.max(lo_b), hi_a.min(hi_b));
    let h = a.harmonics.max(b.harmonics);
    let zero = Complex64::new(0.0, 0.0);
    let mut w = (0.0f64, 0.0f64, 0.0f64);
    if !(hi > lo && lo > 0.0) {
        return Ok((f64::INFINITY, f64::INFINITY, f64::INFINITY));
    }
    for k in 0..50 {
        let amp = lo * (hi / lo).powf(k as f64 / 49.0);
        let (p, q) = (ia.eval(amp)?, ib.eval(amp)?);
        w.0 = w.0.max((p.omega_rad_s / q.omega_rad_s - 1.0).abs());
        w.1 =
            w.1.max((p.damping_ratio - q.damping_ratio).abs() / q.damping_ratio.abs().max(1e-10));
        for (pa, shape) in a.points.iter().enumerate() {
            let Ok(pb) = b.point_index(&shape.name) else {
                continue;
            };
            let mut x = vec![zero; h + 1];
            let mut y = vec![zero; h + 1];
            ia.shape_all(pa, amp, &mut x[..a.harmonics + 1])?;
            ib.shape_all(pb, amp, &mut y[..b.harmonics + 1])?;
            let scale = y.iter().map(|c| c.norm()).fold(0.0, f64::max).max(1e-300);
            for (x, y) in x.iter().zip(&y) {
                w.2 = w.2.max((x - y).norm() / scale);
            }
        }
    }
    Ok(w)
}

/// The outcome of [`auto_harmonics`].
#[derive(Debug, Clone)]
pub struct AutoHarmonics {
    /// The chosen `H`.
    pub harmonics: usize,
    /// Its refined table.
    pub table: ModalTable,
    /// `(H, omega, D, shape)` differences from `H + 4` of every `H` tried.
    pub tried: Vec<(usize, f64, f64, f64)>,
}

/// `harmonics = "auto"`: the smallest `H >= h_min` whose refined table
/// ([`super::NmaResult::refined_table`], `policy`, `refine`) agrees with the
/// one of `H + 4` ([`AUTO_HARMONICS_STEP`]) within the refinement targets
/// (`omega` within `refine.omega_rel`, `D` and shapes within `refine.rel`, on
/// the common amplitude range, [`table_agreement`]). `opts.harmonics` is
/// ignored; `H` runs up to [`AUTO_HARMONICS_MAX`] (then
/// [`NmaError::AutoHarmonicsNotFound`]). Each table is computed once.
pub fn auto_harmonics(
    model: &StructuralModel,
    basis: Arc<ModalBasis>,
    opts: &NmaOptions,
    policy: TablePolicy,
    refine: &RefineOptions,
    h_min: usize,
) -> Result<AutoHarmonics, NmaError> {
    let mut tables: BTreeMap<usize, ModalTable> = BTreeMap::new();
    let mut table = |h: usize| -> Result<ModalTable, NmaError> {
        if let Some(t) = tables.get(&h) {
            return Ok(t.clone());
        }
        let o = NmaOptions {
            harmonics: h,
            store_coordinates: true,
            ..opts.clone()
        };
        let r = match nonlinear_modal_analysis_with_basis(model, basis.clone(), &o) {
            Ok(r) => r,
            Err(e) => match e.partial() {
                Some(p) if p.branch.len() >= 2 => p.clone(),
                _ => return Err(e),
            },
        };
        let t = r.refined_table(model, basis.clone(), &o, policy, refine)?;
        tables.insert(h, t.clone());
        Ok(t)
    };
    let mut tried = Vec::new();
    for h in h_min.max(1)..=AUTO_HARMONICS_MAX {
        let (t, t_ref) = (table(h)?, table(h + AUTO_HARMONICS_STEP)?);
        let (dw, dd, ds) =
            table_agreement(&t, &t_ref).map_err(|e| NmaError::Table(e.to_string()))?;
        tried.push((h, dw, dd, ds));
        if dw <= refine.omega_rel && dd <= refine.rel && ds <= refine.rel {
            return Ok(AutoHarmonics {
                harmonics: h,
                table: t,
                tried,
            });
        }
    }
    let (h, dw, dd, ds) = *tried.last().expect("at least one H tried");
    Err(NmaError::AutoHarmonicsNotFound {
        max_harmonics: h,
        omega_rel: dw,
        damping_rel: dd,
        shape_rel: ds,
    })
}
