//! Test problems with known answers, shared by the tests and the benchmarks.
use crate::structure::{NamedPoint, NonlinearElement, NonlinearLaw, StructuralModel};
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

pub mod nlvib;

/// Polynomial force law `f(u, v) = k3 u^3 + c3 v^3` [N].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CubicLaw {
    /// Cubic stiffness [N/m^3].
    pub k3: f64,
    /// Cubic damping [N s^3/m^3].
    pub c3: f64,
}

impl NonlinearLaw for CubicLaw {
    fn name(&self) -> &str {
        "cubic"
    }
    fn eval(&self, u: f64, v: f64) -> (f64, f64, f64) {
        (
            self.k3 * u * u * u + self.c3 * v * v * v,
            3.0 * self.k3 * u * u,
            3.0 * self.c3 * v * v,
        )
    }
}

/// Single-DOF Duffing oscillator `m x'' + c x' + k x + k3 x^3 = f`, with one
/// named point `x`.
pub fn duffing(m: f64, c: f64, k: f64, k3: f64) -> StructuralModel {
    let e = DVector::from_element(1, 1.0);
    StructuralModel {
        mass: DMatrix::from_element(1, 1, m),
        stiffness: DMatrix::from_element(1, 1, k),
        damping: DMatrix::from_element(1, 1, c),
        nonlinear: vec![NonlinearElement {
            name: "cubic".into(),
            direction: e.clone(),
            law: Arc::new(CubicLaw { k3, c3: 0.0 }),
        }],
        points: vec![NamedPoint {
            name: "x".into(),
            direction: e,
        }],
    }
}

/// EPMC backbone of the Duffing oscillator with `H = 1` (unit modal mass,
/// `a = |x_1|` for `m = 1`): `omega^2 = omega0^2 + 3/4 k3 a^2`.
pub fn duffing_backbone_h1(omega0: f64, k3: f64, a: f64) -> f64 {
    (omega0 * omega0 + 0.75 * k3 * a * a).sqrt()
}

/// Exact backbone of the conservative Duffing oscillator
/// `x'' + omega0^2 x + k3 x^3 = 0` (unit mass, `k3 > 0`) for the free vibration
/// of peak displacement `x_max`: returns `(omega, a)`, with `a` the magnitude
/// of the fundamental Fourier coefficient (`x = x_max cn(omega_c t, m)`,
/// elliptic nome series of `cn`).
pub fn duffing_exact_backbone(omega0: f64, k3: f64, x_max: f64) -> (f64, f64) {
    let w2 = omega0 * omega0 + k3 * x_max * x_max;
    let m = k3 * x_max * x_max / (2.0 * w2);
    let k = ellip_k(m);
    let kp = ellip_k(1.0 - m);
    let omega = std::f64::consts::PI * w2.sqrt() / (2.0 * k);
    let q = (-std::f64::consts::PI * kp / k).exp();
    let a = x_max * 2.0 * std::f64::consts::PI / (m.sqrt() * k) * q.sqrt() / (1.0 + q);
    (omega, a)
}

/// Complete elliptic integral of the first kind `K(m)` (parameter `m = k^2`)
/// by the arithmetic-geometric mean.
pub fn ellip_k(m: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, (1.0 - m).sqrt());
    for _ in 0..60 {
        let (an, bn) = (0.5 * (a + b), (a * b).sqrt());
        a = an;
        b = bn;
        if (a - b).abs() < 1e-16 * a {
            break;
        }
    }
    std::f64::consts::PI / (2.0 * a)
}

/// A fixed-free chain of `n` masses (`m` each, springs `k`) with Rayleigh
/// damping `C = alpha M + beta K` (or non-proportional if `extra_damper` adds a
/// dashpot `c` between ground and mass 0), a cubic spring/damper at the last
/// mass, and named points `first`, `last`.
pub fn chain(
    n: usize,
    m: f64,
    k: f64,
    alpha: f64,
    beta: f64,
    law: CubicLaw,
    extra_damper: f64,
) -> StructuralModel {
    let mass = DMatrix::from_diagonal_element(n, n, m);
    let mut stiffness = DMatrix::zeros(n, n);
    for i in 0..n {
        stiffness[(i, i)] += k;
        if i + 1 < n {
            stiffness[(i, i)] += k;
            stiffness[(i, i + 1)] -= k;
            stiffness[(i + 1, i)] -= k;
        }
    }
    let mut damping = &mass * alpha + &stiffness * beta;
    damping[(0, 0)] += extra_damper;
    let mut last = DVector::zeros(n);
    last[n - 1] = 1.0;
    let mut first = DVector::zeros(n);
    first[0] = 1.0;
    StructuralModel {
        mass,
        stiffness,
        damping,
        nonlinear: vec![NonlinearElement {
            name: "cubic".into(),
            direction: last.clone(),
            law: Arc::new(law),
        }],
        points: vec![
            NamedPoint {
                name: "last".into(),
                direction: last,
            },
            NamedPoint {
                name: "first".into(),
                direction: first,
            },
        ],
    }
}

/// Two uncoupled unit oscillators `x_i'' + omega_i^2 x_i = ...` (unit masses,
/// `omega_1 = 1 rad/s`, `omega_2 = ratio rad/s`), coupled only by a grounded
/// cubic spring `k3 u^3` on `u = x_1 + x_2`: for `ratio = 3` a 1:3 internal
/// resonance of the hardening first mode with the second. Named points `x1`,
/// `x2`; no linear damping.
pub fn two_dof_internal_resonance(ratio: f64, k3: f64) -> StructuralModel {
    let u = DVector::from_vec(vec![1.0, 1.0]);
    let e = |i: usize| DVector::from_fn(2, |j, _| if i == j { 1.0 } else { 0.0 });
    StructuralModel {
        mass: DMatrix::identity(2, 2),
        stiffness: DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, ratio * ratio])),
        damping: DMatrix::zeros(2, 2),
        nonlinear: vec![NonlinearElement {
            name: "cubic".into(),
            direction: u,
            law: Arc::new(CubicLaw { k3, c3: 0.0 }),
        }],
        points: vec![
            NamedPoint {
                name: "x1".into(),
                direction: e(0),
            },
            NamedPoint {
                name: "x2".into(),
                direction: e(1),
            },
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn elliptic_k_known_values() {
        assert!((ellip_k(0.0) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        // K(1/2) = Gamma(1/4)^2 / (4 sqrt(pi))
        assert!((ellip_k(0.5) - 1.854_074_677_301_372).abs() < 1e-13);
    }

    #[test]
    fn exact_backbone_has_the_right_small_amplitude_limit() {
        // weakly nonlinear: omega ~ omega0 + 3 k3 X^2 / (8 omega0), a ~ X
        let (om, a) = duffing_exact_backbone(2.0, 1.0, 1e-3);
        assert!((om - (2.0 + 3.0 * 1e-6 / 16.0)).abs() < 1e-10, "{om}");
        assert!((a / 1e-3 - 1.0).abs() < 1e-6, "{a}");
    }
}
