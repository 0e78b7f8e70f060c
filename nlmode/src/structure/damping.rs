//! Linear viscous damping `C` of `eq:component1`.
//!
//! * stiffness-proportional `C = beta K`, calibrated so that mode `j` has the modal
//!   damping ratio `D_j`: `beta = 2 D_j / omega_j` (the paper's `D0 = 0.4 %` on mode 1,
//!   Section 5); mode `k` then has `D_k = D_j omega_k / omega_j`;
//! * Rayleigh `C = alpha M + beta K`, `D_k = alpha / (2 omega_k) + beta omega_k / 2`;
//! * modal `C = M Phi diag(2 D_k omega_k) Phi^T M` over the first modes (mass-normalised
//!   `Phi`), exactly `D_k` on those modes and no damping on the others.
use super::modal::{modal_analysis, LinearModes};
use super::{Result, StructuralModel, StructureError};
use nalgebra::DMatrix;

fn check_ratio(name: &'static str, value: f64) -> Result<()> {
    if !(value.is_finite() && value >= 0.0) {
        return Err(StructureError::InvalidParameter {
            name,
            value,
            expected: "a finite number >= 0",
        });
    }
    Ok(())
}

/// Sets `C = beta K` with `beta = 2 ratio / omega_j` [s], `j = mode_index` (0-based) of
/// the linear modes of `model`, and returns `beta`.
pub fn stiffness_proportional_damping(
    model: &mut StructuralModel,
    mode_index: usize,
    ratio: f64,
) -> Result<f64> {
    check_ratio("ratio", ratio)?;
    if mode_index >= model.ndof() {
        return Err(StructureError::ModeIndexOutOfRange {
            index: mode_index,
            available: model.ndof(),
        });
    }
    let modes = modal_analysis(model, mode_index + 1)?;
    stiffness_proportional_damping_from_modes(model, &modes, mode_index, ratio)
}

/// As [`stiffness_proportional_damping`] with the linear modes of `model` already
/// computed (`modes` must come from [`modal_analysis`] of this model).
pub fn stiffness_proportional_damping_from_modes(
    model: &mut StructuralModel,
    modes: &LinearModes,
    mode_index: usize,
    ratio: f64,
) -> Result<f64> {
    check_ratio("ratio", ratio)?;
    let omega = *modes
        .omega_rad_s
        .get(mode_index)
        .ok_or(StructureError::ModeIndexOutOfRange {
            index: mode_index,
            available: modes.n_modes(),
        })?;
    if omega == 0.0 {
        return Err(StructureError::ZeroFrequencyMode {
            index: mode_index,
            omega_rad_s: omega,
        });
    }
    let beta = 2.0 * ratio / omega;
    model.damping = &model.stiffness * beta;
    Ok(beta)
}

/// Sets `C = alpha M + beta K` (`alpha` [1/s], `beta` [s], both `>= 0`).
pub fn rayleigh_damping(model: &mut StructuralModel, alpha: f64, beta: f64) -> Result<()> {
    check_ratio("alpha", alpha)?;
    check_ratio("beta", beta)?;
    model.damping = &model.mass * alpha + &model.stiffness * beta;
    Ok(())
}

/// Sets `C = M Phi diag(2 D_k omega_k) Phi^T M` with `D_k = ratios[k]` on the
/// `ratios.len()` lowest modes.
pub fn modal_damping(model: &mut StructuralModel, ratios: &[f64]) -> Result<()> {
    for &r in ratios {
        check_ratio("ratios", r)?;
    }
    let modes = modal_analysis(model, ratios.len())?;
    let diag = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
        ratios.len(),
        ratios
            .iter()
            .zip(&modes.omega_rad_s)
            .map(|(d, w)| 2.0 * d * w),
    ));
    let mphi = &model.mass * &modes.shapes;
    model.damping = super::symmetrize(&mphi * diag * mphi.transpose());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::structure::{BeamSpec, BoundaryCondition};

    fn modal_ratios(model: &StructuralModel, n: usize) -> (Vec<f64>, DMatrix<f64>) {
        let modes = modal_analysis(model, n).unwrap();
        let cm = modes.shapes.transpose() * &model.damping * &modes.shapes;
        let d = (0..n)
            .map(|j| cm[(j, j)] / (2.0 * modes.omega_rad_s[j]))
            .collect();
        (d, cm)
    }

    fn beam() -> StructuralModel {
        BeamSpec {
            n_nodes: 20,
            ..BeamSpec::paper()
        }
        .assemble()
        .unwrap()
        .model
    }

    #[test]
    fn stiffness_proportional_gives_target_on_chosen_mode() {
        let mut m = beam();
        let beta = stiffness_proportional_damping(&mut m, 1, 0.01).unwrap();
        let modes = modal_analysis(&m, 4).unwrap();
        assert!((beta - 0.02 / modes.omega_rad_s[1]).abs() < 1e-15);
        let (d, _) = modal_ratios(&m, 4);
        for (j, (dj, wj)) in d.iter().zip(&modes.omega_rad_s).enumerate() {
            let expected = 0.01 * wj / modes.omega_rad_s[1];
            assert!(
                (dj - expected).abs() < 1e-10 * expected,
                "mode {j}: {dj} vs {expected}"
            );
        }
    }

    #[test]
    fn rayleigh_and_modal_damping_ratios() {
        let mut m = beam();
        rayleigh_damping(&mut m, 3.0, 1e-5).unwrap();
        let modes = modal_analysis(&m, 3).unwrap();
        let (d, _) = modal_ratios(&m, 3);
        for (dj, w) in d.iter().zip(&modes.omega_rad_s) {
            let expected = 3.0 / (2.0 * w) + 1e-5 * w / 2.0;
            assert!((dj - expected).abs() < 1e-10 * expected);
        }
        modal_damping(&mut m, &[0.01, 0.02]).unwrap();
        let (d, cm) = modal_ratios(&m, 3);
        assert!((d[0] - 0.01).abs() < 1e-10 && (d[1] - 0.02).abs() < 1e-10);
        assert!(d[2].abs() < 1e-10 && cm[(0, 1)].abs() < 1e-9 * cm[(1, 1)]);
    }

    #[test]
    fn bad_damping_inputs() {
        let mut m = beam();
        assert!(matches!(
            stiffness_proportional_damping(&mut m, 1000, 0.01),
            Err(StructureError::ModeIndexOutOfRange { index: 1000, .. })
        ));
        assert!(matches!(
            stiffness_proportional_damping(&mut m, 0, -0.01),
            Err(StructureError::InvalidParameter { name: "ratio", .. })
        ));
        assert!(matches!(
            rayleigh_damping(&mut m, f64::NAN, 0.0),
            Err(StructureError::InvalidParameter { name: "alpha", .. })
        ));
        let mut ff = BeamSpec {
            n_nodes: 5,
            boundary: BoundaryCondition::FreeFree,
            ..BeamSpec::paper()
        }
        .assemble()
        .unwrap()
        .model;
        assert!(matches!(
            stiffness_proportional_damping(&mut ff, 0, 0.01),
            Err(StructureError::ZeroFrequencyMode { index: 0, .. })
        ));
    }
}
