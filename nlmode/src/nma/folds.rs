//! Folds of the amplitude, internal resonances and warnings from a computed branch.
use super::continuation::ContinuationSummary;
use super::errors::NmaWarning;
use super::results::{Fold, FoldKind, InternalResonance, NmaResult};

/// Folds, iteration count and the linear-regime warning from the summary.
pub(super) fn finish(result: &mut NmaResult, summary: &ContinuationSummary, tangent_sign: &[f64]) {
    result.newton_iterations = summary.newton_iterations;
    result.rejected_steps = summary.rejected_steps;
    for &i in &summary.turning_points {
        if i == 0 || i >= result.branch.len() {
            continue;
        }
        let (p, q) = (&result.branch[i - 1], &result.branch[i]);
        // the parameter log10 a was increasing before the turning point
        let kind = if tangent_sign[i - 1] > 0.0 {
            FoldKind::AmplitudeMaximum
        } else {
            FoldKind::AmplitudeMinimum
        };
        let index = match kind {
            FoldKind::AmplitudeMaximum if p.amplitude >= q.amplitude => i - 1,
            FoldKind::AmplitudeMinimum if p.amplitude <= q.amplitude => i - 1,
            _ => i,
        };
        let b = &result.branch[index];
        result.folds.push(Fold {
            index,
            kind,
            amplitude: b.amplitude,
            omega_rad_s: b.omega_rad_s,
            internal_resonance: None,
        });
    }
    linear_regime_warning(result);
}

/// [`finish`] for a continuation parameter other than `log10 a`: the folds of
/// `a` are the local extrema of the computed amplitudes.
pub(super) fn finish_from_amplitudes(result: &mut NmaResult, summary: &ContinuationSummary) {
    result.newton_iterations = summary.newton_iterations;
    result.rejected_steps = summary.rejected_steps;
    let a: Vec<f64> = result.branch.iter().map(|b| b.amplitude).collect();
    let mut rising = true;
    for i in 1..a.len() {
        let kind = if rising && a[i] < a[i - 1] {
            rising = false;
            FoldKind::AmplitudeMaximum
        } else if !rising && a[i] > a[i - 1] {
            rising = true;
            FoldKind::AmplitudeMinimum
        } else {
            continue;
        };
        let b = &result.branch[i - 1];
        result.folds.push(Fold {
            index: i - 1,
            kind,
            amplitude: b.amplitude,
            omega_rad_s: b.omega_rad_s,
            internal_resonance: None,
        });
    }
    linear_regime_warning(result);
}

/// Largest relative mismatch `|n omega / omega_k - 1|` (at the loop's amplitude
/// minimum, against the linear frequency `omega_k` of the participating mode)
/// for which a loop is labelled an internal resonance `1:n` with mode `k`: the
/// nonlinear shift of both modes (a tip spring stiffens the higher modes too)
/// moves the meeting point off the linear ratio, by up to ~20 % for the high
/// loops of the paper beam; a fold at `n omega = 0.55 omega_k` (regularised
/// friction saturating, NLvib example 05) is no resonance.
pub const INTERNAL_RESONANCE_MISMATCH: f64 = 0.35;

/// Least growth of the secondary component's energy share in a loop over its
/// share at the start of the branch for the loop to be labelled an internal
/// resonance (see [`identify_internal_resonances`]).
pub const INTERNAL_RESONANCE_MIN_GROWTH: f64 = 2.0;

/// The internal resonance of every loop (from an amplitude maximum to the next
/// minimum, or the branch end): the energy component other than the
/// fundamental that carries most energy at the point of least fundamental share,
/// if it belongs to another linear mode `k` whose frequency `linear_omegas[k]`
/// the harmonic meets within [`INTERNAL_RESONANCE_MISMATCH`], and whose share
/// in the loop exceeds [`INTERNAL_RESONANCE_MIN_GROWTH`] times its share at
/// the branch start (a mode mixed into the shape from the linear regime on, as
/// in the stick mode of a friction chain, is no resonance). A fold that is
/// not one (e.g. where friction saturates) gets a
/// [`NmaWarning::FoldNotInternalResonance`] instead.
pub(super) fn identify_internal_resonances(result: &mut NmaResult, linear_omegas: &[f64]) {
    let n_folds = result.folds.len();
    for f in 0..n_folds {
        if result.folds[f].kind != FoldKind::AmplitudeMaximum {
            continue;
        }
        let start = result.folds[f].index;
        let end = result.folds[f + 1..]
            .iter()
            .find(|g| g.kind == FoldKind::AmplitudeMinimum)
            .map(|g| g.index)
            .unwrap_or(result.branch.len() - 1);
        let Some(low) = (start..=end).min_by(|&p, &q| {
            result.branch[p]
                .fundamental_energy_share
                .total_cmp(&result.branch[q].fundamental_energy_share)
        }) else {
            continue;
        };
        let c = result.branch[low].secondary;
        let max_share = (start..=end)
            .map(|i| {
                let s = result.branch[i].secondary;
                if (s.harmonic, s.mode_index) == (c.harmonic, c.mode_index) {
                    s.share
                } else {
                    0.0
                }
            })
            .fold(0.0, f64::max);
        let lowest = (start..=end)
            .min_by(|&p, &q| {
                result.branch[p]
                    .amplitude
                    .total_cmp(&result.branch[q].amplitude)
            })
            .unwrap_or(low);
        let ir = InternalResonance {
            harmonic: c.harmonic,
            mode_index: c.mode_index,
            max_share,
            min_fundamental_share: result.branch[low].fundamental_energy_share,
            omega_rad_s: result.branch[lowest].omega_rad_s,
        };
        let omega_k = linear_omegas.get(c.mode_index).copied().unwrap_or(f64::NAN);
        let mismatch = (c.harmonic as f64 * ir.omega_rad_s / omega_k - 1.0).abs();
        // the component's share at the start of the branch: a mode already in
        // the shape in the linear regime (the start mode of a system whose
        // elements add stiffness or damping mixes the undamped modes, e.g.
        // friction in stick) is no resonance the loop runs into
        let s0 = result.branch[0].secondary;
        let baseline = if (s0.harmonic, s0.mode_index) == (c.harmonic, c.mode_index) {
            s0.share
        } else {
            0.0
        };
        if c.mode_index != result.mode_index
            && mismatch <= INTERNAL_RESONANCE_MISMATCH
            && max_share > INTERNAL_RESONANCE_MIN_GROWTH * baseline
        {
            result.folds[f].internal_resonance = Some(ir);
        } else {
            let fold = &result.folds[f];
            result.warnings.push(NmaWarning::FoldNotInternalResonance {
                amplitude: fold.amplitude,
                omega_rad_s: fold.omega_rad_s,
                harmonic: c.harmonic,
                mode: c.mode_index + 1,
                ratio: c.harmonic as f64 * ir.omega_rad_s / omega_k,
                share: max_share,
            });
        }
    }
}

/// The warning that the branch never left the linear regime.
pub(super) fn linear_regime_warning(result: &mut NmaResult) {
    if let Some(first) = result.branch.first() {
        let mut omega_shift_rel: f64 = 0.0;
        let mut damping_shift: f64 = 0.0;
        let mut max_amplitude: f64 = 0.0;
        for b in &result.branch {
            omega_shift_rel = omega_shift_rel.max((b.omega_rad_s / first.omega_rad_s - 1.0).abs());
            damping_shift = damping_shift.max((b.damping_ratio - first.damping_ratio).abs());
            max_amplitude = max_amplitude.max(b.amplitude);
        }
        let d_ref = first.damping_ratio.abs().max(1e-6);
        if result.branch.len() > 1 && omega_shift_rel < 1e-4 && damping_shift < 1e-3 * d_ref {
            result.warnings.push(NmaWarning::LinearRegimeOnly {
                max_amplitude,
                omega_shift_rel,
                damping_shift,
            });
        }
    }
}
