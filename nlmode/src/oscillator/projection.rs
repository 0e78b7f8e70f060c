//! The modal force projected on every harmonic of the mode
//! (`harmonic_force_projection`): the drive-point force does work on the
//! mode's whole multi-harmonic motion at the drive point, not on its
//! fundamental alone.
//!
//! # Why
//!
//! `eq:NM` projects the force on the fundamental harmonic of the mode,
//! `phi_1^H c_hat_1`, and so does the oscillator's default modal force
//! `p(t) = |phi_ex(a)| c(t)`: under averaging only the fundamental of
//! `c(t)` acts on the mode. An attachment that answers the mode's higher
//! harmonics (the paper's shaker at the drive point: its stinger force's
//! third harmonic reaches `|F_3|/|F_1|` = 0.9 at 5 V and 2.0 at 10 V at
//! phase resonance, where the fundamental of the force drops, `eq:forcedrop`)
//! then exchanges power with the mode's own harmonics `phi_n,ex` (`eq:ansatz`)
//! that the modal equation never sees: at phase resonance the fundamental
//! balances the damping less that power, so the single-mode force
//! fundamental is low by about its share of the input power, `3 |F_3|/|F_1|
//! |x_3|/|x_1|` (2.5 % at 5 V, 12 % at 10 V on the paper beam).
//!
//! # Equations
//!
//! Write the drive point's motion along the mode (`eq:ansatz`, the gauge of
//! the oscillator's module docs, `phi_n` = `phi_n,ex(a) g^{-n}`) as `q_ex =
//! a s(psi)`, `s(psi) = Re sum_{n=0}^{H} phi_n e^{i n psi}`, and take the
//! force's virtual work `c dq_ex` on the amplitude and the phase of `z = a
//! e^{i psi}` as the generalized forces, `Q_psi = c a s'(psi)`, `Q_a = c
//! s(psi)` (the paper's `phi'(a) = 0`, as in `eq:NM`). With the modal
//! energy `omega^2 a^2 / 2` the forced normal form becomes
//!
//! ```text
//! a'        = ... + c s'(psi) / omega,        (so omega^2 a a' = c q_ex'  along the motion)
//! a psi'    = ... - c s(psi) / omega,
//! z'        = i omega z + 2 i D omega u + (c/omega) e^{i psi} (s'(psi) - i s(psi)),
//! ```
//!
//! that is `eta' += Re f`, `u' -= Im f` with `f = (c/omega) e^{i psi} (s' -
//! i s)`. For a mode with the fundamental only, `s = |phi_ex| cos psi`,
//! `f = -i |phi_ex| c / omega`: the default modal force, exactly. Averaged
//! over a period, harmonic `n` of the force, `c_hat_n`, drives `a'` with
//! `Re(conj(i n phi_n) c_hat_n) / (2 omega)`: the power `Re(conj(i n Omega
//! a phi_n) c_hat_n)/2` of that harmonic on the mode's `n`-th harmonic, over
//! `omega^2 a` (to the order of the averaging, `Omega ~ omega`). At `a = 0`
//! the phase is undefined and the harmonics vanish: the default force.
//!
//! # Verified
//!
//! The three-FMU phase-resonance loop (structure, shaker, controller)
//! against the phase-locked loop on the full-order reference, relative
//! difference of the force fundamental at 1 / 5 / 10 V: `-4.5e-4 / -2.45e-2
//! / -1.24e-1` with the projection on the fundamental, `-3.8e-4 / -1.6e-3 /
//! -5.5e-3` with this one, `-3.8e-4 / -1.2e-3 / -2.4e-3` with ten residual
//! modes beside it; frequency and response within 4e-4 throughout
//! (`host/tests/it/phase_resonance_cosim.rs`).
use super::{gauge, harmonic_buffer, HARMONICS_ON_STACK};
use crate::table::{TableInterpolator, TableLocation};
use num_complex::Complex64;

/// `(f_eta, f_u)`: the modal force's terms in `(eta', u')` (module docs) at
/// the state `(eta, u)`, amplitude `a = hypot(eta, u) > 0` located at `loc`,
/// under the force `c` \[N\], with the modal frequency `w` \[rad/s\] and the
/// drive point's fundamental `phi_ex` at `loc` (its phase is the gauge).
#[allow(clippy::too_many_arguments)] // the state, the located table and the force, evaluated once by the caller
#[inline]
pub(super) fn harmonic_forcing(
    interp: &TableInterpolator,
    drive: usize,
    loc: &TableLocation,
    (eta, u): (f64, f64),
    a: f64,
    c: f64,
    w: f64,
    phi_ex: Complex64,
) -> (f64, f64) {
    let g = gauge(phi_ex);
    // e^{i psi}, and the table's own gauge's unit phasor e^{i psi}/g
    let e = Complex64::new(eta, -u) / a;
    let unit = e / g;
    let mut stack = [Complex64::new(0.0, 0.0); HARMONICS_ON_STACK];
    let mut heap = Vec::new();
    let phi = harmonic_buffer(interp.harmonics() + 1, &mut stack, &mut heap);
    interp.shape_all_at(drive, loc, phi);
    // s = Re sum phi_n w^n, s' = Re sum i n phi_n w^n = -sum n Im(phi_n w^n)
    let (mut s, mut ds) = (0.0, 0.0);
    let mut wn = Complex64::new(1.0, 0.0);
    for (n, p) in phi.iter().enumerate() {
        let term = p * wn;
        s += term.re;
        ds -= n as f64 * term.im;
        wn *= unit;
    }
    let f = c / w * e * Complex64::new(ds, -s);
    (f.re, -f.im)
}

#[cfg(test)]
mod tests {
    use crate::nma::{ModalTable, PointShape, MODAL_TABLE_FORMAT, MODAL_TABLE_VERSION};
    use crate::oscillator::{InputPolynomial, ModalOscillator, OscillatorState};
    use num_complex::Complex64;
    use std::f64::consts::PI;

    /// Constant `omega`, `D`; the drive point `ex` with the fundamental
    /// `phi1` and the third harmonic `phi3` at every amplitude.
    fn table(omega: f64, d: f64, phi1: Complex64, phi3: Complex64) -> ModalTable {
        let n = 40;
        let amplitude: Vec<f64> = (0..n).map(|j| 1e-2 * (j as f64 + 1.0) / n as f64).collect();
        ModalTable {
            format: MODAL_TABLE_FORMAT.into(),
            version: MODAL_TABLE_VERSION,
            description: "projection test table".into(),
            harmonics: 3,
            omega_rad_s: vec![omega; n],
            damping_ratio: vec![d; n],
            amplitude,
            points: vec![PointShape {
                name: "ex".into(),
                re: vec![vec![0.0, phi1.re, 0.0, phi3.re]; n],
                im: vec![vec![0.0, phi1.im, 0.0, phi3.im]; n],
            }],
            coordinates: vec![],
            truncated_at_fold: None,
            accuracy: None,
            linear_modes: None,
        }
    }

    /// Drive `osc` from `(eta, u) = (a0, 0)` by `c(t) = f sin(k omega t)`
    /// (the input polynomial exact to second order per step) over `periods`
    /// periods; the final amplitude.
    fn drive(mut osc: ModalOscillator, a0: f64, f: f64, k: f64, omega: f64, periods: usize) -> f64 {
        osc.set_state(OscillatorState {
            time_s: 0.0,
            eta: a0,
            u: 0.0,
        })
        .unwrap();
        let steps = 400 * periods;
        let dt = periods as f64 * 2.0 * PI / omega / steps as f64;
        let kw = k * omega;
        for j in 0..steps {
            let t = j as f64 * dt;
            let input = InputPolynomial {
                c0: f * (kw * t).sin(),
                c1: f * kw * (kw * t).cos(),
                c2: -f * kw * kw * (kw * t).sin(),
            };
            osc.step(dt, input).unwrap();
        }
        osc.state().amplitude()
    }

    /// A mode with the fundamental alone: the projected force is the
    /// default `|phi_ex| c` (a complex `phi_ex`, so the gauge is exercised).
    #[test]
    fn fundamental_only_is_the_default_force() {
        let t = table(
            300.0,
            0.01,
            Complex64::from_polar(1.3, 0.7),
            Complex64::new(0.0, 0.0),
        );
        let plain = ModalOscillator::new(&t, "ex", 0.0).unwrap();
        let projected = plain.clone().with_harmonic_force_projection(true);
        for (f, k) in [(2.0, 1.0), (5.0, 3.0), (1.0, 0.7)] {
            let a = drive(plain.clone(), 2e-3, f, k, 300.0, 3);
            let b = drive(projected.clone(), 2e-3, f, k, 300.0, 3);
            assert!((a - b).abs() <= 1e-12 * a, "{a} {b}");
        }
    }

    /// The third harmonic of the force does work on the mode's third
    /// harmonic: over one period (free motion `psi = omega t`, `D = 0`),
    /// `c = f sin 3 psi` against `q_3 = a phi_3 cos 3 psi` is the power
    /// `-3 omega a phi_3 f / 2`, so `omega^2 a a' = power` gives the
    /// amplitude change `-3 phi_3 f T / (2 omega)`. The fundamental
    /// projection sees none of it (the force's third harmonic averages out
    /// against the fundamental).
    #[test]
    fn third_harmonic_power_changes_the_amplitude_by_its_work() {
        let (omega, phi3, f, a0) = (300.0, 0.1, 0.05, 3e-3);
        let t = table(
            omega,
            0.0,
            Complex64::new(1.0, 0.0),
            Complex64::new(phi3, 0.0),
        );
        let plain = ModalOscillator::new(&t, "ex", 0.0).unwrap();
        let projected = plain.clone().with_harmonic_force_projection(true);
        let expected = -3.0 * phi3 * f * (2.0 * PI / omega) / (2.0 * omega);
        let da = drive(projected, a0, f, 3.0, omega, 1) - a0;
        // the relative change is about 1e-4: second-order terms 1e-4 of it
        assert!((da / expected - 1.0).abs() < 1e-3, "{da:e} {expected:e}");
        let da_plain = drive(plain, a0, f, 3.0, omega, 1) - a0;
        assert!(da_plain.abs() < 1e-3 * expected.abs(), "{da_plain:e}");
    }

    /// The Jacobian with the projection: the force column exact, the state
    /// columns against a central difference with a different step.
    #[test]
    fn jacobian_matches_finite_differences() {
        let t = table(
            250.0,
            0.02,
            Complex64::from_polar(0.8, -0.4),
            Complex64::from_polar(0.05, 1.1),
        );
        let mut osc = ModalOscillator::new(&t, "ex", 0.0)
            .unwrap()
            .with_harmonic_force_projection(true);
        let c = 3.0;
        for (eta, u) in [(2e-3, 1e-3), (-1e-3, 4e-3), (5e-4, -2e-4)] {
            osc.set_state(OscillatorState {
                time_s: 0.0,
                eta,
                u,
            })
            .unwrap();
            let j = osc.jacobian(c).unwrap();
            let (r0, r1) = (osc.state_rate(0.0).unwrap(), osc.state_rate(1.0).unwrap());
            assert!((j[0][2] - (r1.0 - r0.0)).abs() <= 1e-12 * j[0][2].abs().max(1.0));
            assert!((j[1][2] - (r1.1 - r0.1)).abs() <= 1e-9 * j[1][2].abs());
            let h = 1e-5 * eta.hypot(u);
            for k in 0..2 {
                let at = |s: f64| {
                    let mut o = osc.clone();
                    let (e, v) = if k == 0 { (eta + s, u) } else { (eta, u + s) };
                    o.set_state(OscillatorState {
                        time_s: 0.0,
                        eta: e,
                        u: v,
                    })
                    .unwrap();
                    o.state_rate(c).unwrap()
                };
                let (p, m) = (at(h), at(-h));
                let fd = [(p.0 - m.0) / (2.0 * h), (p.1 - m.1) / (2.0 * h)];
                for row in 0..2 {
                    let scale = j[row][0].abs().max(j[row][1].abs());
                    assert!(
                        (j[row][k] - fd[row]).abs() <= 1e-7 * scale,
                        "row {row} col {k}: {} against {}",
                        j[row][k],
                        fd[row]
                    );
                }
            }
        }
    }
}
