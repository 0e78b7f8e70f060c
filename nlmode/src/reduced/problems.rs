//! Test problems with known answers, shared by tests and benchmarks: modal
//! tables of a Duffing-like mode (single mass-normalized mode with a cubic
//! spring `k3` at one point), whose steady state has a closed form.
use crate::nma::{ModalTable, PointShape, MODAL_TABLE_FORMAT, MODAL_TABLE_VERSION};
use num_complex::Complex64;

/// The modal table of a mode with constant shape `phi` and a cubic spring
/// `k3` \[N/m^3\] at point `nonlinear_point`: by single-harmonic averaging,
/// `omega(a)^2 = omega0^2 + 3/4 k3 |phi_nl|^4 a^2`, and with constant viscous
/// modal damping `2 D(a) omega(a) = 2 D0 omega0`. `n` points uniform in
/// `(0, a_max]`; shapes at `points` with the fundamental `phi` and zero
/// higher harmonics up to `harmonics`.
#[allow(clippy::too_many_arguments)] // the problem's parameters, each named
pub fn duffing_table(
    omega0_rad_s: f64,
    d0: f64,
    k3_n_per_m3: f64,
    points: &[(&str, Complex64)],
    nonlinear_point: &str,
    a_max: f64,
    n: usize,
    harmonics: usize,
) -> ModalTable {
    let phi_nl = points
        .iter()
        .find(|p| p.0 == nonlinear_point)
        .expect("nonlinear point listed")
        .1
        .norm();
    let kappa = 0.75 * k3_n_per_m3 * phi_nl.powi(4);
    let amplitude: Vec<f64> = (1..=n).map(|j| a_max * j as f64 / n as f64).collect();
    let omega: Vec<f64> = amplitude
        .iter()
        .map(|a| (omega0_rad_s.powi(2) + kappa * a * a).sqrt())
        .collect();
    let damping = omega.iter().map(|w| d0 * omega0_rad_s / w).collect();
    let shape = |v: f64| {
        let mut h = vec![0.0; harmonics + 1];
        h[1] = v;
        h
    };
    ModalTable {
        format: MODAL_TABLE_FORMAT.into(),
        version: MODAL_TABLE_VERSION,
        description: format!(
            "Duffing-like test mode: omega0 = {omega0_rad_s} rad/s, D0 = {d0}, k3 = {k3_n_per_m3} N/m^3 at '{nonlinear_point}'"
        ),
        harmonics,
        amplitude,
        omega_rad_s: omega,
        damping_ratio: damping,
        points: points
            .iter()
            .map(|(name, phi)| PointShape {
                name: name.to_string(),
                re: vec![shape(phi.re); n],
                im: vec![shape(phi.im); n],
            })
            .collect(),
        coordinates: Vec::new(),
        truncated_at_fold: None,
        accuracy: None,
        linear_modes: None,
    }
}

/// Benchmark-like values (paper Section 4 with the DESIGN numbers): `omega0 =
/// 356.2 rad/s`, `D0 = 0.4 %`, mass-normalized fundamental shapes of a uniform
/// cantilever of mass `rho A l = 1.0997 kg` at the tip (`2/sqrt(m)`), at
/// `2l/3` (modal mass 0.92 kg) and at `l/3` (modal mass 10.0 kg).
pub fn benchmark_points() -> [(&'static str, Complex64); 3] {
    let m_beam = crate::benchmark::DENSITY_KG_M3
        * crate::benchmark::HEIGHT_M
        * crate::benchmark::WIDTH_M
        * crate::benchmark::LENGTH_M;
    [
        ("tip", Complex64::new(2.0 / m_beam.sqrt(), 0.0)),
        ("2l3", Complex64::new(1.0 / 0.92f64.sqrt(), 0.0)),
        ("l3", Complex64::new(1.0 / 10.0f64.sqrt(), 0.0)),
    ]
}

/// Linear natural frequency of the benchmark-like tables \[rad/s\].
pub const BENCHMARK_OMEGA0: f64 = 356.2;

/// The benchmark-like Duffing table (cubic spring `k3` at the tip) up to
/// `omega(a_max) = 2.5 omega0`, 200 points, `H = 1`.
pub fn benchmark_duffing_table(k3_n_per_m3: f64) -> ModalTable {
    let pts = benchmark_points();
    let kappa = 0.75 * k3_n_per_m3 * pts[0].1.norm().powi(4);
    let a_max = if kappa > 0.0 {
        ((6.25 - 1.0) * BENCHMARK_OMEGA0.powi(2) / kappa).sqrt()
    } else {
        5e-3
    };
    duffing_table(
        BENCHMARK_OMEGA0,
        crate::benchmark::D0,
        k3_n_per_m3,
        &pts,
        "tip",
        a_max,
        200,
        1,
    )
}
