//! Apparent damping of a co-simulated linear structure + shaker, against the
//! monolithic model (issue: zero-order-hold coupling through the stiff stinger
//! biases the structure's damping by about k_s h / (4 sqrt(k m))).
//!
//! Structure: one linear mode at the exciter location (modal mass m, omega0 =
//! 356.2 rad/s, D0 = 0.4 %), `m x'' + c x' + k x = F`. Co-simulation: Jacobi
//! with macro step h; the structure holds F over the step (integrated
//! exactly), the shaker model receives x and v at the start of the step. The
//! coupled step map is linear, so its eigenvalues give the apparent modal
//! damping exactly; the monolithic 5-state model gives the reference.
use fmi2_export::{CoSimModel, InstantiateContext, Logger};
use nalgebra::{dmatrix, DMatrix, DVector};
use num_complex::Complex64;
use shaker::model::*;

const OMEGA0: f64 = 356.2;
const D0: f64 = 0.004;

fn shaker_params() -> nlmode::attachment::ShakerParams {
    nlmode::attachment::ShakerParams::paper()
}

/// Damping ratio of the structure-dominated mode (the slowest oscillating pair).
fn structure_mode(lambdas: impl Iterator<Item = Complex64>) -> (f64, f64) {
    let l = lambdas
        .filter(|l| l.im > 1.0)
        .min_by(|a, b| a.norm().partial_cmp(&b.norm()).unwrap())
        .unwrap();
    (-l.re / l.norm(), l.norm())
}

fn monolithic(m: f64) -> (f64, f64) {
    let p = shaker_params();
    let ss = p.state_space().unwrap();
    let (k, c) = (m * OMEGA0 * OMEGA0, 2.0 * D0 * OMEGA0 * m);
    let ks = 2.6e7;
    // z = [x, v, I, q_a, v_a]
    let mut a = DMatrix::zeros(5, 5);
    a[(0, 1)] = 1.0;
    a[(1, 0)] = (-k - ks) / m;
    a[(1, 1)] = -c / m;
    a[(1, 3)] = ks / m;
    a.view_mut((2, 2), (3, 3)).copy_from(&ss.a);
    for i in 0..3 {
        a[(2 + i, 0)] = ss.b[(i, 1)]; // shaker input x
    }
    structure_mode(a.complex_eigenvalues().iter().copied())
}

/// One Jacobi macro step of the coupled system from z = [x, v, I, q_a, v_a].
fn cosim_step(z: &DVector<f64>, m: f64, h: f64, feed_velocity: bool) -> DVector<f64> {
    let log = Logger::silent();
    let mut sh = Shaker::instantiate(&InstantiateContext {
        instance_name: "c",
        resource_dir: None,
        logger: &log,
    })
    .unwrap();
    sh.set_real(VR_U_HAT, 0.0).unwrap();
    sh.setup_experiment(0.0, None).unwrap();
    sh.exit_initialization_mode(&log).unwrap();
    sh.set_states([z[2], z[3], z[4]]);
    sh.set_real(VR_X, z[0]).unwrap();
    sh.set_real(VR_V, if feed_velocity { z[1] } else { 0.0 })
        .unwrap();
    let f = sh.get_real(VR_F);
    sh.do_step(0.0, h, &log).unwrap();
    let (k, c) = (m * OMEGA0 * OMEGA0, 2.0 * D0 * OMEGA0 * m);
    let a = dmatrix![0.0, 1.0; -k / m, -c / m];
    let b = dmatrix![0.0; 1.0 / m];
    let d = nlmode::lti::FohStep::new(&a, &b, h).unwrap();
    let xs = d.step(
        &DVector::from_vec(vec![z[0], z[1]]),
        &DVector::from_element(1, f),
        &DVector::from_element(1, f),
    );
    let s = sh.states();
    DVector::from_vec(vec![xs[0], xs[1], s[0], s[1], s[2]])
}

/// (damping ratio, frequency of the structure mode, spectral radius of the step map)
fn cosim(m: f64, h: f64, feed_velocity: bool) -> (f64, f64, f64) {
    // columns: images of scaled unit vectors (the map is linear)
    let scale = [1e-6, 1e-3, 1e-3, 1e-6, 1e-3];
    let mut phi = DMatrix::zeros(5, 5);
    for j in 0..5 {
        let mut e = DVector::zeros(5);
        e[j] = scale[j];
        let col = cosim_step(&e, m, h, feed_velocity) / scale[j];
        phi.set_column(j, &col);
    }
    let mus = phi.complex_eigenvalues();
    let rho = mus.iter().map(|m| m.norm()).fold(0.0, f64::max);
    // continuous-time equivalents lambda = ln(mu) / h
    let (d, w) = structure_mode(mus.iter().map(|mu| mu.ln() / h));
    (d, w, rho)
}

#[test]
fn extrapolated_coupling_keeps_the_apparent_damping_zoh_does_not() {
    // modal masses at 2l/3 and l/3 of the paper's beam
    for m in [0.92, 10.0] {
        let (d_mono, w_mono) = monolithic(m);
        // denominator of eq:fhfhNull (k_s >> k_a, omega_c >> omega0), mu = m_a/m:
        // (1+mu) w^2 = omega0^2 + mu omega_a^2, 2 D w (1+mu) = 2 (D0 + mu omega_a/omega0 D_a) omega0
        let p = shaker_params();
        let mu = 0.043 / m;
        let wa = p.omega_a();
        let w = ((OMEGA0 * OMEGA0 + mu * wa * wa) / (1.0 + mu)).sqrt();
        let d_expect = (D0 + mu * wa / OMEGA0 * 1.36) * OMEGA0 / ((1.0 + mu) * w);
        assert!((w_mono / w - 1.0).abs() < 0.01, "{w_mono} vs {w}");
        println!("m = {m} kg: monolithic D = {d_mono:.5} (simplified closed form {d_expect:.5}), omega = {w_mono:.2} rad/s");
        assert!(
            (d_mono / d_expect - 1.0).abs() < 0.05,
            "{d_mono} vs {d_expect}"
        );
        for h in [1e-6, 1e-5, 2e-5, 5e-5, 1e-4] {
            let (d_ext, _, rho_ext) = cosim(m, h, true);
            let (d_zoh, _, rho_zoh) = cosim(m, h, false);
            let bias = 2.6e7 * h / (4.0 * (m * OMEGA0 * OMEGA0 * m).sqrt());
            println!(
                "  h = {h:e} s: co-sim D with x, v extrapolation {d_ext:.5} ({:+.2} %), zero-order hold {d_zoh:.5} ({:+.2} %), k_s h/(4 sqrt(k m)) = {bias:.5}; spectral radius {rho_ext:.6} / {rho_zoh:.6}",
                100.0 * (d_ext / d_mono - 1.0),
                100.0 * (d_zoh / d_mono - 1.0)
            );
            if h <= 2e-5 {
                assert!(
                    rho_ext < 1.0,
                    "h={h}: co-simulation unstable, spectral radius {rho_ext}"
                );
                assert!(
                    (d_ext / d_mono - 1.0).abs() < 0.05,
                    "h={h}: {d_ext} vs {d_mono}"
                );
                // the zero-order-hold bias is the estimate k_s h / (4 sqrt(k m))
                let r = (d_zoh - d_mono) / bias;
                assert!(
                    r > 0.8 && r < 1.05,
                    "h={h}: ZOH bias {} vs estimate {bias}",
                    d_zoh - d_mono
                );
                assert!(
                    (d_zoh - d_mono).abs() > 50.0 * (d_ext - d_mono).abs(),
                    "h={h}"
                );
            }
        }
    }
}
