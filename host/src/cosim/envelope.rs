//! Fundamental-harmonic envelope of a swept response by a sliding
//! one-period Fourier projection on the excitation phase.
//!
//! With the excitation `u = u_hat cos(Phi(t))`, the complex fundamental
//! amplitude of a signal `y(t)` around the phase `Phi_c` is
//!
//! ```text
//! Y(Phi_c) = (1/pi) int_{Phi_c - pi}^{Phi_c + pi} y e^{-i Phi} dPhi,   dPhi = Omega dt,
//! ```
//!
//! so that `y = Re(Y e^{i Phi})` for a stationary harmonic response
//! (`y = A cos(Phi + theta)` gives exactly `Y = A e^{i theta}`). The integral
//! is the trapezoidal rule on the samples, evaluated for every window in O(1)
//! from prefix sums (window ends interpolated linearly).
use num_complex::Complex64;
use std::f64::consts::PI;

/// Envelope points: excitation frequency at the window centre [rad/s] and the
/// complex fundamental amplitude of each signal.
#[derive(Debug, Clone, Default)]
pub struct FourierEnvelope {
    pub omega_rad_s: Vec<f64>,
    pub time_s: Vec<f64>,
    pub amplitudes: Vec<Vec<Complex64>>,
}

/// Phase `Phi(t_k) = int Omega dt` from samples of `Omega` (trapezoidal rule,
/// exact for a linear sweep), starting at `phi0`.
pub fn phase_from_omega(t: &[f64], omega: &[f64], phi0: f64) -> Vec<f64> {
    let mut phi = Vec::with_capacity(t.len());
    let mut p = phi0;
    for k in 0..t.len() {
        if k > 0 {
            p += 0.5 * (omega[k] + omega[k - 1]) * (t[k] - t[k - 1]);
        }
        phi.push(p);
    }
    phi
}

/// Sliding projection of every signal in `ys` on `e^{-i Phi}`, windows of one
/// excitation period (2 pi of phase) centred every `step_rad` of phase.
/// `phi` must increase strictly.
pub fn fourier_envelope(t: &[f64], phi: &[f64], omega: &[f64], ys: &[&[f64]], step_rad: f64) -> FourierEnvelope {
    let n = t.len();
    assert!(phi.len() == n && omega.len() == n && ys.iter().all(|y| y.len() == n));
    let mut out = FourierEnvelope { amplitudes: vec![Vec::new(); ys.len()], ..Default::default() };
    if n < 3 || phi[n - 1] - phi[0] < 2.0 * PI {
        return out;
    }
    // prefix[j][k] = int_{Phi_0}^{Phi_k} y_j e^{-i Phi} dPhi
    let prefix: Vec<Vec<Complex64>> = ys
        .iter()
        .map(|y| {
            let mut p = Vec::with_capacity(n);
            let mut acc = Complex64::new(0.0, 0.0);
            p.push(acc);
            let mut prev = y[0] * Complex64::from_polar(1.0, -phi[0]);
            for k in 1..n {
                let cur = y[k] * Complex64::from_polar(1.0, -phi[k]);
                acc += 0.5 * (cur + prev) * (phi[k] - phi[k - 1]);
                prev = cur;
                p.push(acc);
            }
            p
        })
        .collect();
    // value of a sampled quantity at phase `p` by linear interpolation
    let locate = |p: f64| -> (usize, f64) {
        let k = phi.partition_point(|&x| x <= p).clamp(1, n - 1);
        let w = (p - phi[k - 1]) / (phi[k] - phi[k - 1]);
        (k - 1, w)
    };
    // The prefix integral between samples: integrate the linear interpolant of
    // y e^{-i Phi} up to p (trapezoid on the partial interval).
    let at = |pre: &[Complex64], y: &[f64], p: f64| -> Complex64 {
        let (k, w) = locate(p);
        let a = y[k] * Complex64::from_polar(1.0, -phi[k]);
        let b = y[k + 1] * Complex64::from_polar(1.0, -phi[k + 1]);
        let dp = p - phi[k];
        let mid = a + (b - a) * w;
        pre[k] + 0.5 * (a + mid) * dp
    };
    let mut c = phi[0] + PI;
    while c + PI <= phi[n - 1] {
        let (k, w) = locate(c);
        out.omega_rad_s.push(omega[k] + w * (omega[k + 1] - omega[k]));
        out.time_s.push(t[k] + w * (t[k + 1] - t[k]));
        for (j, y) in ys.iter().enumerate() {
            let v = (at(&prefix[j], y, c + PI) - at(&prefix[j], y, c - PI)) / PI;
            out.amplitudes[j].push(v);
        }
        c += step_rad;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_amplitude_and_phase_of_a_modulated_sweep() {
        // Omega = 300 + 400 t, y = A(t) cos(Phi + 0.7) + 0.2 cos(3 Phi) with slowly varying A
        let dt = 2e-5;
        let t: Vec<f64> = (0..50_000).map(|k| k as f64 * dt).collect();
        let om: Vec<f64> = t.iter().map(|t| 300.0 + 400.0 * t).collect();
        let phi = phase_from_omega(&t, &om, 0.0);
        for (k, &tk) in t.iter().enumerate() {
            let exact = 300.0 * tk + 200.0 * tk * tk;
            assert!((phi[k] - exact).abs() < 1e-9, "{k}");
        }
        // constant amplitude: exact up to the quadrature
        let y: Vec<f64> = (0..t.len()).map(|k| 1e-3 * (phi[k] + 0.7).cos() + 0.2e-3 * (3.0 * phi[k]).cos()).collect();
        let env = fourier_envelope(&t, &phi, &om, &[&y], PI);
        assert!(env.omega_rad_s.len() > 100);
        for (i, v) in env.amplitudes[0].iter().enumerate() {
            assert!((v.norm() - 1e-3).abs() < 1e-8, "{i}: {}", v.norm());
            assert!((v.arg() - 0.7).abs() < 1e-6, "{}", v.arg());
            assert!((env.omega_rad_s[i] - (300.0 + 400.0 * env.time_s[i])).abs() < 1e-9);
        }
        // amplitude varying along the sweep: the rectangular one-period window
        // leaks the 2 Phi term, bounded by |dA/dPhi| / (2 A) relative
        let amp = |t: f64| 1e-3 * (1.0 + 0.5 * t);
        let y: Vec<f64> = (0..t.len()).map(|k| amp(t[k]) * (phi[k] + 0.7).cos()).collect();
        let env = fourier_envelope(&t, &phi, &om, &[&y], PI);
        let mut worst: f64 = 0.0;
        for (i, v) in env.amplitudes[0].iter().enumerate() {
            let a = amp(env.time_s[i]);
            let bound = 0.5e-3 / env.omega_rad_s[i] / (2.0 * a);
            let rel = (v.norm() - a).abs() / a;
            assert!(rel <= 1.05 * bound, "{i}: {rel:e} > {bound:e}");
            worst = worst.max(rel / bound);
        }
        assert!(worst > 0.5, "the bound is attained: {worst}");
    }
}
