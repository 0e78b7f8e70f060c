//! The paper's benchmark (Sections 4-5): parameters of the beam, cubic spring,
//! damping, Craig-Bampton reduction and the B&K V4808 shaker with stinger.

/// Beam length `l` [m].
pub const LENGTH_M: f64 = 0.53;
/// Beam height in the bending direction `h` [m].
pub const HEIGHT_M: f64 = 0.019;
/// Beam width `w` [m].
pub const WIDTH_M: f64 = 0.014;
/// Young's modulus `E` [Pa].
pub const YOUNGS_MODULUS_PA: f64 = 2.1e11;
/// Density `rho` [kg/m^3].
pub const DENSITY_KG_M3: f64 = 7800.0;
/// Number of FE nodes along the beam (including the clamped one).
pub const N_NODES: usize = 100;
/// Cubic spring at the tip `k3` [N/m^3].
pub const K3_N_PER_M3: f64 = 6e9;
/// Linear modal damping ratio of mode 1 (stiffness-proportional damping) `D0`.
pub const D0: f64 = 0.004;
/// Number of fixed-interface modes of the Craig-Bampton reduction.
pub const CB_MODES: usize = 10;

/// Shaker coil inductance `L` [H].
pub const SHAKER_L_H: f64 = 140e-6;
/// Shaker coil resistance `R` [Ohm].
pub const SHAKER_R_OHM: f64 = 3.0;
/// Force constant `G` [N/A].
pub const SHAKER_G_N_PER_A: f64 = 15.5;
/// Armature mass `m_a` [kg].
pub const SHAKER_MA_KG: f64 = 0.043;
/// Armature suspension stiffness `k_a` [N/m].
pub const SHAKER_KA_N_PER_M: f64 = 2.07e4;
/// Armature damping ratio including electro-mechanical damping, `D_a`, with
/// `2 D_a omega_a m_a = d_a + G^2 / R`.
pub const SHAKER_DA: f64 = 1.36;
/// Stinger stiffness `k_s` [N/m].
pub const STINGER_KS_N_PER_M: f64 = 2.6e7;

/// Mechanical armature damping `d_a` [N s/m] from `D_a`:
/// `d_a = 2 D_a sqrt(k_a m_a) - G^2/R`.
pub fn shaker_da_n_s_per_m() -> f64 {
    2.0 * SHAKER_DA * (SHAKER_KA_N_PER_M * SHAKER_MA_KG).sqrt()
        - SHAKER_G_N_PER_A * SHAKER_G_N_PER_A / SHAKER_R_OHM
}

/// NMA options of the modal table the paper's sweeps use: the damped mode
/// with `H = 3` (the paper: "found sufficient"), modal amplitudes 1e-6 to
/// 1e-2, the fundamental shape at `tip`, `2l3` and `l3`, and continuation steps
/// of at most 0.05 in `log10 a` (fine enough for the PCHIP interpolant).
pub fn sweep_table_options() -> crate::nma::NmaOptions {
    use crate::nma::{AmplitudeRange, ContinuationOptions, NmaOptions};
    NmaOptions {
        harmonics: 3,
        amplitude: AmplitudeRange::Modal {
            log10_start: -6.0,
            log10_end: -2.0,
        },
        points: vec!["tip".into(), "2l3".into(), "l3".into()],
        store_coordinates: false,
        continuation: ContinuationOptions {
            ds: 0.02,
            dsmax: Some(0.05),
            ..Default::default()
        },
        ..Default::default()
    }
}

/// NMA options of the tables the co-simulation checks and benches use: the
/// damped mode with `H = 3`, the tip's fundamental amplitude `|q_tip,1|` from
/// 1e-6 m to 0.02 m, default continuation steps.
pub fn tip_range_table_options() -> crate::nma::NmaOptions {
    use crate::nma::{AmplitudeRange, NmaOptions};
    NmaOptions {
        harmonics: 3,
        amplitude: AmplitudeRange::Point {
            name: "tip".into(),
            start_m: 1e-6,
            end_m: 0.02,
        },
        store_coordinates: false,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn da_relation_holds_and_table_damping_is_small() {
        let d_a = shaker_da_n_s_per_m();
        let omega_a = (SHAKER_KA_N_PER_M / SHAKER_MA_KG).sqrt();
        let lhs = 2.0 * SHAKER_DA * omega_a * SHAKER_MA_KG;
        assert!((lhs - (d_a + SHAKER_G_N_PER_A.powi(2) / SHAKER_R_OHM)).abs() < 1e-12 * lhs);
        // The paper says the table damping "only contributes 2.36 %" to D_a; with the
        // printed (rounded) parameters it is 1.31 % (d_a = 1.067 N s/m). Either way
        // the electro-mechanical damping G^2/R dominates.
        let share = d_a / lhs;
        assert!(share > 0.0 && share < 0.03, "{share}");
        assert!((share - 0.01314).abs() < 1e-4, "{share}");
    }
}
