//! Residual modes of the time-domain oscillator (`residual_modes`): linear
//! modal oscillators of the structure's other modes beside the nonlinear
//! mode, driven by the drive-point force (the time-domain counterpart of
//! [`crate::reduced::ResidualModes`]):
//!
//! ```text
//! q_r'' + 2 zeta_r omega_r q_r' + omega_r^2 q_r = phi_r,ex c(t),
//! x_k = (nonlinear mode) + sum_r phi_r,k q_r,   v_k = (nonlinear mode) + sum_r phi_r,k q_r'.
//! ```
//!
//! Every harmonic of `c(t)` drives them, so the power the force's higher
//! harmonics put into other modes (e.g. the third near a second mode) is
//! carried. They are linear: an exchange with the nonlinear mode through the
//! nonlinear element (a true internal resonance) is not.
//!
//! # Integration
//!
//! Exactly, for the polynomial input of a step `c(t0 + s) = c0 + c1 s + c2
//! s^2/2`: the particular solution is the polynomial `A + B s + C s^2`
//! (`C = b c2 / (2 w^2)`, `B = (b c1 - 4 z w C) / w^2`, `A = (b c0 - 2 C - 2 z w
//! B) / w^2`), the rest decays with the transition matrix `exp(M h)` of
//! `M = [[0, 1], [-w^2, -2 z w]]`, written with `sigma = -z w`, `mu^2 =
//! w^2 (z^2 - 1)` as `e^{sigma h} (cosh(mu h) I + sinh(mu h)/mu (M - sigma I))`
//! (under-, critically and over-damped alike). So a mode far above the
//! nonlinear mode costs no sub-steps and cannot make the step unstable
//! (the beam's tenth residual mode lies at 1.1e5 rad/s, where RK4 would need
//! steps below 2.5e-5 s).
use crate::reduced::ResidualModes;
use std::sync::Arc;

/// The residual modes at the oscillator's points.
#[derive(Debug, Clone)]
pub(crate) struct Residual {
    modes: Arc<ResidualModes>,
    /// `phi_r,ex`: each mode at the drive point.
    drive: Vec<f64>,
}

impl Residual {
    pub fn new(modes: ResidualModes, drive: usize) -> Self {
        let drive = (0..modes.len()).map(|r| modes.shape(drive, r)).collect();
        Self {
            modes: Arc::new(modes),
            drive,
        }
    }

    pub fn len(&self) -> usize {
        self.modes.len()
    }

    /// Advances the state `q` (`[q_1, q_1', q_2, q_2', ...]`) by `h` \[s\] under
    /// `c(s) = c0 + c1 s + c2 s^2 / 2` \[N\], exactly (module docs).
    pub fn advance(&self, q: &mut [f64], h: f64, c: [f64; 3]) {
        let [c0, c1, c2] = c;
        for (r, state) in q.chunks_exact_mut(2).enumerate() {
            let (w, z) = self.modes.mode(r);
            let b = self.drive[r];
            let w2 = w * w;
            let cc = b * c2 / (2.0 * w2);
            let bb = (b * c1 - 4.0 * z * w * cc) / w2;
            let aa = (b * c0 - 2.0 * cc - 2.0 * z * w * bb) / w2;
            // the homogeneous part e = q - q_p
            let (e0, e1) = (state[0] - aa, state[1] - bb);
            let [[p00, p01], [p10, p11]] = transition(w, z, h);
            let (f0, f1) = (p00 * e0 + p01 * e1, p10 * e0 + p11 * e1);
            state[0] = f0 + aa + h * (bb + h * cc);
            state[1] = f1 + bb + 2.0 * cc * h;
        }
    }

    /// `(sum_r phi_r,k q_r, sum_r phi_r,k q_r')` at table point `k`.
    pub fn response(&self, q: &[f64], k: usize) -> (f64, f64) {
        let (mut x, mut v) = (0.0, 0.0);
        for (r, s) in q.chunks_exact(2).enumerate() {
            let p = self.modes.shape(k, r);
            x += p * s[0];
            v += p * s[1];
        }
        (x, v)
    }

    /// `(sum_r phi_r,k q_r', sum_r phi_r,k q_r'')` at table point `k` under
    /// the force `c` \[N\]: the residual part of the output rates.
    pub fn response_rate(&self, q: &[f64], k: usize, c: f64) -> (f64, f64) {
        let (mut dx, mut dv) = (0.0, 0.0);
        for (r, s) in q.chunks_exact(2).enumerate() {
            let (w, z) = self.modes.mode(r);
            let p = self.modes.shape(k, r);
            dx += p * s[1];
            dv += p * (-2.0 * z * w * s[1] - w * w * s[0] + self.drive[r] * c);
        }
        (dx, dv)
    }
}

/// `exp(M h)` of `M = [[0, 1], [-w^2, -2 z w]]` (module docs), for any `z >= 0`.
fn transition(w: f64, z: f64, h: f64) -> [[f64; 2]; 2] {
    let sigma = -z * w;
    let mu2 = w * w * (z * z - 1.0);
    // ch = cosh(mu h), sh = sinh(mu h)/mu, both times e^{sigma h}
    let x2 = mu2 * h * h;
    let (ch, sh) = if x2.abs() < 1e-6 {
        // series in (mu h)^2: cosh = 1 + x2/2 + x2^2/24, sinh/mu = h (1 + x2/6 + x2^2/120)
        let e = (sigma * h).exp();
        (
            e * (1.0 + x2 / 2.0 + x2 * x2 / 24.0),
            e * h * (1.0 + x2 / 6.0 + x2 * x2 / 120.0),
        )
    } else if mu2 > 0.0 {
        // over-damped: from the two real exponentials (no overflow of cosh)
        let mu = mu2.sqrt();
        let (e1, e2) = (((sigma + mu) * h).exp(), ((sigma - mu) * h).exp());
        (0.5 * (e1 + e2), 0.5 * (e1 - e2) / mu)
    } else {
        let nu = (-mu2).sqrt();
        let e = (sigma * h).exp();
        (e * (nu * h).cos(), e * (nu * h).sin() / nu)
    };
    // ch I + sh (M - sigma I)
    [
        [ch - sigma * sh, sh],
        [-w * w * sh, ch + (-2.0 * z * w - sigma) * sh],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `exp(M h)` by a fine RK4 of the homogeneous system.
    fn rk4_transition(w: f64, z: f64, h: f64) -> [[f64; 2]; 2] {
        let f = |y: [f64; 2]| [y[1], -w * w * y[0] - 2.0 * z * w * y[1]];
        let mut out = [[0.0; 2]; 2];
        for col in 0..2 {
            let mut y = [0.0; 2];
            y[col] = 1.0;
            let n = 20_000;
            let dt = h / n as f64;
            for _ in 0..n {
                let k1 = f(y);
                let k2 = f([y[0] + 0.5 * dt * k1[0], y[1] + 0.5 * dt * k1[1]]);
                let k3 = f([y[0] + 0.5 * dt * k2[0], y[1] + 0.5 * dt * k2[1]]);
                let k4 = f([y[0] + dt * k3[0], y[1] + dt * k3[1]]);
                for i in 0..2 {
                    y[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
                }
            }
            out[0][col] = y[0];
            out[1][col] = y[1];
        }
        out
    }

    #[test]
    fn transition_matrix_is_the_exponential_for_any_damping() {
        let w = 2000.0;
        let h = 1e-3;
        for z in [0.0, 0.004, 0.5, 1.0 - 1e-9, 1.0, 1.0 + 1e-9, 1.27, 30.0] {
            let t = transition(w, z, h);
            let r = rk4_transition(w, z, h);
            for i in 0..2 {
                for j in 0..2 {
                    // scale of the entry: w^(i - j)
                    let s = w.powi(i as i32 - j as i32);
                    assert!(
                        (t[i][j] - r[i][j]).abs() < 1e-9 * s,
                        "z {z}: [{i}][{j}] {} vs {}",
                        t[i][j],
                        r[i][j]
                    );
                }
            }
        }
    }
}
