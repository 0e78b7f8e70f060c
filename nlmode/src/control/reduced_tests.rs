//! The phase-locked loop and force control on the single-nonlinear-mode plant
//! (benchmark-like Duffing table, `k3 = 6e9 N/m^3` at the tip, the paper's
//! shaker at 2l/3).
use super::{
    force_controlled_stepped_sine, phase_resonance, ForceControlOptions, PllOptions, ReducedPlant,
};
use crate::attachment::{LinearAttachment, ShakerParams};
use crate::reduced::problems::{benchmark_duffing_table, benchmark_points};
use crate::reduced::ReducedModel;

pub(super) fn plant() -> ReducedPlant {
    let table = benchmark_duffing_table(6e9);
    let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
    let model = ReducedModel::new(&table, "tip", "2l3")
        .unwrap()
        .with_linear_attachment(&shaker, &[1.0.into()])
        .unwrap();
    ReducedPlant::new(model, 40).unwrap()
}

/// Drive-point modal mass `1/|phi_2l3|^2` of the benchmark-like points.
pub(super) fn drive_mass() -> f64 {
    1.0 / benchmark_points()[1].1.norm_sqr()
}

/// Six levels 0.5..20 V from omega0. The loop sees only the fundamental, so
/// each settled level lies on the table's backbone `omega(a)` and its
/// power-balance damping is the table's `D(a)`. Measured (test profile): both
/// within 6e-6 at every level (the phase tolerance 1e-3 rad moves the
/// frequency by about `D e`), 60-140 periods per level; tolerance 1e-4.
#[test]
fn pll_on_the_slow_flow_lands_on_the_table_backbone() {
    let mut plant = plant();
    let volts = [0.5, 1.0, 2.0, 5.0, 10.0, 20.0];
    let res = phase_resonance(
        &mut plant,
        356.2,
        &volts,
        drive_mass(),
        &PllOptions::default(),
    )
    .unwrap();
    assert!(res.failure.is_none(), "{:?}", res.failure);
    let m = plant.model();
    let phi_d = benchmark_points()[1].1.norm();
    for l in &res.levels {
        let a = l.drive_amplitude_m() / phi_d;
        let p = m.modal_properties(a).unwrap();
        eprintln!(
            "U = {} V: a = {a:.4e}, omega/omega0 = {:.5}, vs table {:.2e}, D = {:.5} vs {:.5} ({:.2e}), periods {}",
            l.voltage_v,
            l.omega_rad_s / 356.2,
            l.omega_rad_s / p.omega_rad_s - 1.0,
            l.damping_ratio,
            p.damping_ratio,
            l.damping_ratio / p.damping_ratio - 1.0,
            l.periods
        );
        assert!(l.settled);
        assert!((l.omega_rad_s / p.omega_rad_s - 1.0).abs() < 1e-4);
        assert!((l.damping_ratio / p.damping_ratio - 1.0).abs() < 1e-4);
        assert!(l.harmonics.drive_m[3].norm() < 1e-12 * l.drive_amplitude_m());
    }
    assert!(res.levels.last().unwrap().omega_rad_s / 356.2 > 1.3);
}

/// Force control on the slow flow: the force fundamental held at the set
/// value through the resonance (a settled step is the steady state of `eq:NM`
/// at the voltage found).
#[test]
fn force_control_on_the_slow_flow_holds_the_force() {
    let mut plant = plant();
    let omegas: Vec<f64> = [0.95, 0.99, 1.0, 1.01, 1.05]
        .iter()
        .map(|e| e * 356.2)
        .collect();
    let res = force_controlled_stepped_sine(
        &mut plant,
        &omegas,
        0.1,
        0.5,
        &ForceControlOptions::default(),
    )
    .unwrap();
    assert!(res.failure.is_none());
    for s in &res.steps {
        assert!(s.settled && !s.saturated, "{s:?}");
    }
    assert!(res.flatness < 2e-3, "{}", res.flatness);
}
