//! Further [`NonlinearLaw`]s besides the paper's [`super::CubicSpring`]: each is one
//! small type with a validating constructor, acting along a direction `w` with
//! `u = w^T q` [m] and `v = w^T q'` [m/s].
use super::{NonlinearLaw, Result, StructureError};
use serde::{Deserialize, Serialize};

/// Unilateral (contact) spring: `f = k (u - g)` for `u > g`, else `0` (gap `g` [m],
/// stiffness `k` [N/m]). At `u = g` the derivative is taken from the open side (`0`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnilateralSpring {
    /// Contact stiffness `k` [N/m] (> 0).
    pub stiffness_n_per_m: f64,
    /// Gap `g` [m] (contact for `u > g`; negative = preload).
    pub gap_m: f64,
}

impl UnilateralSpring {
    /// A unilateral spring; `k > 0` and `g` finite.
    pub fn new(stiffness_n_per_m: f64, gap_m: f64) -> Result<Self> {
        if !(stiffness_n_per_m.is_finite() && stiffness_n_per_m > 0.0) {
            return Err(StructureError::NonPositive {
                name: "stiffness_n_per_m",
                value: stiffness_n_per_m,
            });
        }
        if !gap_m.is_finite() {
            return Err(StructureError::InvalidParameter {
                name: "gap_m",
                value: gap_m,
                expected: "a finite number",
            });
        }
        Ok(Self {
            stiffness_n_per_m,
            gap_m,
        })
    }
}

impl NonlinearLaw for UnilateralSpring {
    fn name(&self) -> &str {
        "unilateral_spring"
    }
    fn eval(&self, u: f64, _v: f64) -> (f64, f64, f64) {
        if u > self.gap_m {
            (
                self.stiffness_n_per_m * (u - self.gap_m),
                self.stiffness_n_per_m,
                0.0,
            )
        } else {
            (0.0, 0.0, 0.0)
        }
    }
}

/// Coulomb friction regularised with `tanh`: `f = F_s tanh(v / v_r)` (slip force
/// `F_s` [N], regularisation velocity `v_r` [m/s]); `f -> F_s sign(v)` for `v_r -> 0`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegularizedFriction {
    /// Slip force `F_s` [N] (>= 0).
    pub slip_force_n: f64,
    /// Regularisation velocity `v_r` [m/s] (> 0).
    pub regularization_m_s: f64,
}

impl RegularizedFriction {
    /// A regularised friction element; `F_s >= 0`, `v_r > 0`.
    pub fn new(slip_force_n: f64, regularization_m_s: f64) -> Result<Self> {
        if !(slip_force_n.is_finite() && slip_force_n >= 0.0) {
            return Err(StructureError::InvalidParameter {
                name: "slip_force_n",
                value: slip_force_n,
                expected: "a finite number >= 0",
            });
        }
        if !(regularization_m_s.is_finite() && regularization_m_s > 0.0) {
            return Err(StructureError::NonPositive {
                name: "regularization_m_s",
                value: regularization_m_s,
            });
        }
        Ok(Self {
            slip_force_n,
            regularization_m_s,
        })
    }
}

impl NonlinearLaw for RegularizedFriction {
    fn name(&self) -> &str {
        "regularized_friction"
    }
    fn eval(&self, _u: f64, v: f64) -> (f64, f64, f64) {
        let t = (v / self.regularization_m_s).tanh();
        (
            self.slip_force_n * t,
            0.0,
            self.slip_force_n / self.regularization_m_s * (1.0 - t * t),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fd_check(law: &dyn NonlinearLaw, u: f64, v: f64) {
        let h = 1e-8;
        let (_, dfdu, dfdv) = law.eval(u, v);
        let fu = (law.eval(u + h, v).0 - law.eval(u - h, v).0) / (2.0 * h);
        let fv = (law.eval(u, v + h).0 - law.eval(u, v - h).0) / (2.0 * h);
        assert!(
            (dfdu - fu).abs() < 1e-5 * (1.0 + fu.abs()),
            "{}: df/du {dfdu} vs {fu}",
            law.name()
        );
        assert!(
            (dfdv - fv).abs() < 1e-5 * (1.0 + fv.abs()),
            "{}: df/dv {dfdv} vs {fv}",
            law.name()
        );
    }

    #[test]
    fn unilateral_spring_opens_and_closes() {
        let s = UnilateralSpring::new(1e5, 1e-3).unwrap();
        assert_eq!(s.eval(0.5e-3, 1.0), (0.0, 0.0, 0.0));
        let (f, k, _) = s.eval(3e-3, 0.0);
        assert!((f - 200.0).abs() < 1e-9 && k == 1e5);
        fd_check(&s, 2e-3, 0.3);
        fd_check(&s, -2e-3, 0.3);
        assert!(matches!(
            UnilateralSpring::new(0.0, 0.0),
            Err(StructureError::NonPositive { .. })
        ));
        assert!(matches!(
            UnilateralSpring::new(1.0, f64::NAN),
            Err(StructureError::InvalidParameter { .. })
        ));
    }

    #[test]
    fn regularized_friction_tends_to_coulomb() {
        let f = RegularizedFriction::new(2.0, 1e-3).unwrap();
        assert!((f.eval(0.0, 0.1).0 - 2.0).abs() < 1e-12);
        assert!((f.eval(0.0, -0.1).0 + 2.0).abs() < 1e-12);
        assert_eq!(f.eval(5.0, 0.0).0, 0.0);
        // slope at v = 0 is F_s / v_r
        assert!((f.eval(0.0, 0.0).2 - 2000.0).abs() < 1e-9);
        fd_check(&f, 0.0, 4e-4);
        fd_check(&f, 1.0, -2e-3);
        assert!(matches!(
            RegularizedFriction::new(1.0, 0.0),
            Err(StructureError::NonPositive { .. })
        ));
        assert!(matches!(
            RegularizedFriction::new(-1.0, 1e-3),
            Err(StructureError::InvalidParameter { .. })
        ));
    }
}
