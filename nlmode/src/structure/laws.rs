//! Further [`NonlinearLaw`]s besides the paper's [`super::CubicSpring`]: each is one
//! small type with a validating constructor, acting along a direction `w` with
//! `u = w^T q` [m] and `v = w^T q'` [m/s] (for a relative element between two
//! points `w = e_a - e_b`, so `u = u_a - u_b`). Each adds `w f` to `g(q, q')` of
//! `eq:component1`.
//!
//! * [`PolynomialSpring`]: `f = sum_p c_p u^p`.
//! * [`UnilateralSpring`]: contact `f = k max(u - g, 0)`.
//! * [`RegularizedFriction`]: `f = F_s tanh(v / v_r)`.
//! * [`QuadraticDamper`]: `f = c2 v |v|`.
//! * [`ElasticDryFriction`]: the hysteretic Jenkins element (tangential stiffness
//!   `k_t` in series with a Coulomb slider), a [`Hysteresis`] with the slider
//!   position as state.
use super::{Hysteresis, HystereticStep, NonlinearLaw, Result, StructureError};
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
    fn velocity_saturation(&self) -> Option<(f64, f64)> {
        Some((self.slip_force_n, self.regularization_m_s))
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

/// Polynomial spring `f = sum_p c_p u^p` (powers `p >= 1`, coefficient `c_p` in
/// [N/m^p]: `c_2` in N/m^2, `c_3` in N/m^3, ...). An even power acts with the sign
/// of `u^p` (`c_2 u^2 >= 0` for `c_2 > 0`), i.e. it is asymmetric, as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolynomialSpring {
    /// `(p, c_p)` pairs, powers ascending and distinct.
    pub terms: Vec<(i32, f64)>,
}

impl PolynomialSpring {
    /// Highest admissible power.
    pub const MAX_POWER: i32 = 15;

    /// A polynomial spring from `(power, coefficient)` pairs: powers between 1
    /// and [`Self::MAX_POWER`], each once, coefficients finite.
    pub fn new(terms: &[(i32, f64)]) -> Result<Self> {
        let mut terms = terms.to_vec();
        terms.sort_by_key(|t| t.0);
        for (i, &(p, c)) in terms.iter().enumerate() {
            if !(1..=Self::MAX_POWER).contains(&p) || (i > 0 && terms[i - 1].0 == p) {
                return Err(StructureError::InvalidParameter {
                    name: "coefficients",
                    value: p as f64,
                    expected: "distinct powers between 1 and 15",
                });
            }
            if !c.is_finite() {
                return Err(StructureError::InvalidParameter {
                    name: "coefficients",
                    value: c,
                    expected: "finite coefficients",
                });
            }
        }
        Ok(Self { terms })
    }
}

impl NonlinearLaw for PolynomialSpring {
    fn name(&self) -> &str {
        "polynomial_spring"
    }
    fn eval(&self, u: f64, _v: f64) -> (f64, f64, f64) {
        let mut f = 0.0;
        let mut dfdu = 0.0;
        for &(p, c) in &self.terms {
            f += c * u.powi(p);
            dfdu += c * p as f64 * u.powi(p - 1);
        }
        (f, dfdu, 0.0)
    }
}

/// Quadratic damper `f = c2 v |v|` (`c2` [N s^2/m^2] >= 0); `df/dv = 2 c2 |v|`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadraticDamper {
    /// Coefficient `c2` [N s^2/m^2].
    pub c2_n_s2_per_m2: f64,
}

impl QuadraticDamper {
    /// A quadratic damper; `c2 >= 0` and finite.
    pub fn new(c2_n_s2_per_m2: f64) -> Result<Self> {
        if !(c2_n_s2_per_m2.is_finite() && c2_n_s2_per_m2 >= 0.0) {
            return Err(StructureError::InvalidParameter {
                name: "c2_n_s2_per_m2",
                value: c2_n_s2_per_m2,
                expected: "a finite number >= 0",
            });
        }
        Ok(Self { c2_n_s2_per_m2 })
    }
}

impl NonlinearLaw for QuadraticDamper {
    fn name(&self) -> &str {
        "quadratic_damper"
    }
    fn eval(&self, _u: f64, v: f64) -> (f64, f64, f64) {
        (
            self.c2_n_s2_per_m2 * v * v.abs(),
            0.0,
            2.0 * self.c2_n_s2_per_m2 * v.abs(),
        )
    }
}

/// Elastic dry friction (Jenkins element): a spring of tangential stiffness `k_t`
/// [N/m] in series with a Coulomb slider of slip force `F_s` [N]. State: the
/// slider position `w` [m]; the force is `f = k_t (u - w)` while `|f| <= F_s`
/// (stick, `df/du = k_t`), otherwise the slider moves so that `f = F_s sign`
/// (slip, `df/du = 0`, `w = u - f / k_t`). Rate independent.
///
/// Over a cycle `u = x cos(theta)` with `x > F_s / k_t` the loop dissipates
/// `4 F_s (x - F_s / k_t)`. [`NonlinearLaw::eval`] is the virgin curve from the
/// relaxed slider at `w = 0`, `f = clamp(k_t u, -F_s, F_s)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElasticDryFriction {
    /// Tangential stiffness `k_t` [N/m] (> 0).
    pub tangential_stiffness_n_per_m: f64,
    /// Slip force `F_s` [N] (>= 0).
    pub slip_force_n: f64,
    /// Slider position at the start of a periodic march (Harmonic Balance
    /// AFT): [`InitialSlider::Mean`] (default) or [`InitialSlider::Zero`].
    #[serde(default)]
    pub initial_slider: InitialSlider,
}

/// Where the slider of an [`ElasticDryFriction`] element sits at the start of
/// the periodic march of the Harmonic Balance AFT. Both are valid initial
/// states of a hysteretic element; they differ only where the element sticks
/// throughout the period (then the slider stays where it started):
/// - `Mean` (default): at the mean displacement `u_0` of the period, so a
///   stuck element carries no static force (`f = k_t (u - u_0)`);
/// - `Zero`: at `w = 0` (NLvib's convention), so a stuck element with a
///   nonzero mean displacement (e.g. next to a contact) carries the static
///   force `k_t u_0` (`f = k_t u` while `|k_t u| <= F_s`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InitialSlider {
    #[default]
    Mean,
    Zero,
}

impl InitialSlider {
    /// The scenario spelling (`"mean"`, `"zero"`).
    pub fn as_str(self) -> &'static str {
        match self {
            InitialSlider::Mean => "mean",
            InitialSlider::Zero => "zero",
        }
    }
}

impl std::str::FromStr for InitialSlider {
    type Err = StructureError;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "mean" => Ok(InitialSlider::Mean),
            "zero" => Ok(InitialSlider::Zero),
            _ => Err(StructureError::UnknownInitialSlider {
                name: s.to_string(),
            }),
        }
    }
}

impl ElasticDryFriction {
    /// A Jenkins element; `k_t > 0`, `F_s >= 0`, both finite.
    pub fn new(tangential_stiffness_n_per_m: f64, slip_force_n: f64) -> Result<Self> {
        if !(tangential_stiffness_n_per_m.is_finite() && tangential_stiffness_n_per_m > 0.0) {
            return Err(StructureError::NonPositive {
                name: "tangential_stiffness_n_per_m",
                value: tangential_stiffness_n_per_m,
            });
        }
        if !(slip_force_n.is_finite() && slip_force_n >= 0.0) {
            return Err(StructureError::InvalidParameter {
                name: "slip_force_n",
                value: slip_force_n,
                expected: "a finite number >= 0",
            });
        }
        Ok(Self {
            tangential_stiffness_n_per_m,
            slip_force_n,
            initial_slider: InitialSlider::Mean,
        })
    }

    /// The same element with the slider starting at `initial` in the AFT march.
    pub fn with_initial_slider(self, initial: InitialSlider) -> Self {
        Self {
            initial_slider: initial,
            ..self
        }
    }
}

impl NonlinearLaw for ElasticDryFriction {
    fn name(&self) -> &str {
        "elastic_dry_friction"
    }
    fn eval(&self, u: f64, _v: f64) -> (f64, f64, f64) {
        let s = self.step(0.0, u);
        (s.force, s.dforce_du, 0.0)
    }
    fn hysteresis(&self) -> Option<&dyn Hysteresis> {
        Some(self)
    }
}

impl Hysteresis for ElasticDryFriction {
    fn relaxed_state(&self, u: f64) -> (f64, f64) {
        (u, 1.0)
    }
    fn initial_state(&self, u: f64) -> (f64, f64) {
        match self.initial_slider {
            InitialSlider::Mean => (u, 1.0),
            InitialSlider::Zero => (0.0, 0.0),
        }
    }
    fn play(&self) -> Option<super::PlayOperator> {
        Some(super::PlayOperator {
            stiffness_n_per_m: self.tangential_stiffness_n_per_m,
            slip_force_n: self.slip_force_n,
        })
    }
    fn step(&self, w: f64, u: f64) -> HystereticStep {
        let kt = self.tangential_stiffness_n_per_m;
        let trial = kt * (u - w);
        if trial.abs() <= self.slip_force_n {
            HystereticStep {
                force: trial,
                dforce_du: kt,
                dforce_ds: -kt,
                state: w,
                dstate_du: 0.0,
                dstate_ds: 1.0,
            }
        } else {
            let f = self.slip_force_n.copysign(trial);
            HystereticStep {
                force: f,
                dforce_du: 0.0,
                dforce_ds: 0.0,
                state: u - f / kt,
                dstate_du: 1.0,
                dstate_ds: 0.0,
            }
        }
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

    #[test]
    fn polynomial_spring_sums_its_terms() {
        let p = PolynomialSpring::new(&[(3, 2e9), (2, -4e5)]).unwrap();
        assert_eq!(p.terms, vec![(2, -4e5), (3, 2e9)]);
        let (f, k, c) = p.eval(1e-3, 5.0);
        assert!((f - (-4e5 * 1e-6 + 2e9 * 1e-9)).abs() < 1e-12);
        assert!((k - (-8e5 * 1e-3 + 6e9 * 1e-6)).abs() < 1e-9);
        assert_eq!(c, 0.0);
        fd_check(&p, -2e-3, 0.0);
        for bad in [vec![(0, 1.0)], vec![(16, 1.0)], vec![(2, 1.0), (2, 3.0)]] {
            assert!(matches!(
                PolynomialSpring::new(&bad),
                Err(StructureError::InvalidParameter {
                    name: "coefficients",
                    ..
                })
            ));
        }
        assert!(PolynomialSpring::new(&[(3, f64::INFINITY)]).is_err());
    }

    #[test]
    fn quadratic_damper_opposes_the_velocity() {
        let d = QuadraticDamper::new(3.0).unwrap();
        assert_eq!(d.eval(1.0, -2.0), (-12.0, 0.0, 12.0));
        fd_check(&d, 0.0, 0.7);
        fd_check(&d, 0.0, -0.7);
        assert!(QuadraticDamper::new(-1.0).is_err());
    }

    #[test]
    fn jenkins_element_sticks_slips_and_dissipates_its_loop_area() {
        let j = ElasticDryFriction::new(1e5, 10.0).unwrap();
        // virgin curve: linear up to F_s / k_t = 1e-4, then F_s
        assert_eq!(j.eval(5e-5, 0.0), (5.0, 1e5, 0.0));
        assert_eq!(j.eval(-3e-4, 0.0), (-10.0, 0.0, 0.0));
        assert!(j.hysteresis().is_some());
        // a cycle u = x cos(theta), x = 3e-4, marched finely from the relaxed state:
        // loop area 4 F_s (x - F_s/k_t)
        let x = 3e-4;
        let n = 200_000;
        let (mut w, _) = j.relaxed_state(x);
        let mut work = 0.0;
        for pass in 0..2 {
            let mut u_prev = x;
            let mut f_prev = j.step(w, x).force;
            for i in 1..=n {
                let u = x * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos();
                let s = j.step(w, u);
                w = s.state;
                if pass == 1 {
                    work += 0.5 * (s.force + f_prev) * (u - u_prev);
                }
                u_prev = u;
                f_prev = s.force;
            }
        }
        let exact = 4.0 * 10.0 * (x - 10.0 / 1e5);
        assert!((work - exact).abs() < 1e-6 * exact, "{work} vs {exact}");
        assert!(ElasticDryFriction::new(0.0, 1.0).is_err());
        assert!(matches!(
            ElasticDryFriction::new(1.0, -1.0),
            Err(StructureError::InvalidParameter {
                name: "slip_force_n",
                ..
            })
        ));
    }
}
