//! Fundamental-harmonic envelopes of swept signals.
//!
//! For a signal `x(t)` driven by `u(t) = u_hat cos Phi(t)`, the complex
//! fundamental harmonic at the window centre `Phi_c` is the sliding Fourier
//! projection on `e^{i Phi}` over `K` excitation periods, taken in the phase
//! variable:
//!
//! ```text
//! X(Phi_c) = 1/(K pi) int_{Phi_c - K pi}^{Phi_c + K pi} x(t(Phi)) e^{-i Phi} dPhi,
//! ```
//!
//! so that `x = A cos(Phi + phi)` gives `X = A e^{i phi}` exactly, and every
//! higher harmonic `e^{i n Phi}` of a steady response integrates to zero over the
//! window even while `Omega` changes. The amplitude is `|X|`, reported against
//! `Omega` at the window centre. The integral is a trapezoidal rule in `Phi` on
//! the samples (`dPhi = Omega dt` is not uniform during a sweep), with the
//! window ends interpolated linearly between samples. `Phi(t)` increases for
//! forward and backward sweeps alike (`Omega > 0`).
//!
//! Hand-written for exactness: an FFT (`rustfft`) needs uniform samples in
//! `Phi`, which a sweep sampled uniformly in time does not give.
use num_complex::Complex64;

/// Amplitudes `|X|` of `x` (sampled at phases `phase`, increasing) for windows
/// centred at the samples `centers`; `None` where the window leaves the data.
pub fn fundamental_amplitudes(
    phase: &[f64],
    x: &[f64],
    centers: &[usize],
    periods: f64,
) -> Vec<Option<f64>> {
    fundamental_harmonics(phase, x, centers, periods)
        .into_iter()
        .map(|v| v.map(|z| z.norm()))
        .collect()
}

/// Complex fundamental harmonics `X = A e^{i phi}` (`x ~ A cos(Phi + phi)`), as
/// [`fundamental_amplitudes`].
pub fn fundamental_harmonics(
    phase: &[f64],
    x: &[f64],
    centers: &[usize],
    periods: f64,
) -> Vec<Option<Complex64>> {
    assert_eq!(phase.len(), x.len(), "phase and signal lengths");
    let n = x.len();
    if n < 2 {
        return vec![None; centers.len()];
    }
    let w: Vec<Complex64> = (0..n)
        .map(|i| x[i] * Complex64::from_polar(1.0, -phase[i]))
        .collect();
    // cumulative trapezoid S_i = int_{Phi_0}^{Phi_i} w dPhi
    let mut cum = vec![Complex64::new(0.0, 0.0); n];
    for i in 1..n {
        cum[i] = cum[i - 1] + 0.5 * (w[i - 1] + w[i]) * (phase[i] - phase[i - 1]);
    }
    // S at an arbitrary phase inside the data (w linear between samples)
    let s_at = |p: f64| -> Complex64 {
        let i = match phase.partition_point(|&q| q <= p) {
            0 => 0,
            k => (k - 1).min(n - 2),
        };
        let dp = phase[i + 1] - phase[i];
        let th = ((p - phase[i]) / dp).clamp(0.0, 1.0);
        let wp = w[i] + th * (w[i + 1] - w[i]);
        cum[i] + 0.5 * (w[i] + wp) * (p - phase[i])
    };
    let half = periods * std::f64::consts::PI;
    centers
        .iter()
        .map(|&c| {
            let (lo, hi) = (phase[c] - half, phase[c] + half);
            if lo < phase[0] || hi > phase[n - 1] {
                None
            } else {
                Some((s_at(hi) - s_at(lo)) / half)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_amplitude_of_chirped_signal_with_harmonics() {
        // Phi = w0 t + 0.5 a t^2; x = A(t) cos(Phi + 0.3) + 0.4 cos(3 Phi) + 0.2
        let (w0, a) = (300.0, 400.0);
        let dt = 2.0 * std::f64::consts::PI / 700.0 / 40.0;
        let n = 20000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let phase: Vec<f64> = t.iter().map(|&t| w0 * t + 0.5 * a * t * t).collect();
        let amp = |t: f64| 1.0 + 0.5 * t;
        let x: Vec<f64> = (0..n)
            .map(|i| amp(t[i]) * (phase[i] + 0.3).cos() + 0.4 * (3.0 * phase[i]).cos() + 0.2)
            .collect();
        let centers: Vec<usize> = (0..n).step_by(500).collect();
        let res = fundamental_amplitudes(&phase, &x, &centers, 1.0);
        assert!(res[0].is_none());
        let mut checked = 0;
        for (k, &c) in centers.iter().enumerate() {
            if let Some(v) = res[k] {
                // a slowly, linearly varying amplitude is recovered at the centre
                assert!(
                    (v - amp(t[c])).abs() < 2e-3 * amp(t[c]),
                    "{v} vs {}",
                    amp(t[c])
                );
                checked += 1;
            }
        }
        assert!(checked > 30);
        // the phase of the fundamental (0.3 rad) too
        let z = fundamental_harmonics(&phase, &x, &centers, 1.0);
        for v in z.iter().flatten() {
            assert!((v.arg() - 0.3).abs() < 2e-3, "{}", v.arg());
        }
    }
}
