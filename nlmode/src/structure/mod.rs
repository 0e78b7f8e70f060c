//! Structural model of `eq:component1`: `M q'' + g(q, q') = f_ex1(t) + f_c1`,
//! with `g(q, q') = C q' + K q + sum_e w_e f_e(w_e^T q, w_e^T q')`.
//!
//! * [`StructuralModel`] holds `M`, `K`, `C`, the local nonlinear elements and the
//!   named points; it evaluates `g` and its Jacobians ([`StructuralModel::internal_force`],
//!   [`StructuralModel::internal_force_jacobians`]).
//! * [`beam`]: Euler-Bernoulli beam finite elements (cubic Hermite shape functions,
//!   consistent mass), 2 DOF per node, common boundary conditions.
//! * [`CubicSpring`]: `f = k3 u^3`, the paper's nonlinearity (Section 5). Further laws
//!   are one [`NonlinearLaw`] type each; [`laws`] has polynomial springs, a
//!   unilateral spring, regularised Coulomb friction, a quadratic damper and the
//!   hysteretic Jenkins element (with a [`Hysteresis`]).
//! * [`damping`]: stiffness-proportional (calibrated on a mode), Rayleigh and modal damping.
//! * [`modal`]: linear modal analysis, `K phi = omega^2 M phi`.
//! * [`mod@craig_bampton`]: Craig-Bampton reduction with chosen master DOFs and fixed-interface modes.
//! * [`paper`]: the benchmark structure of the paper (Section 5).
//! * [`matrices`]: the user's structure from FE matrices (Matrix Market files).
//! * [`sparse`]: sparse FE matrices (faer): sparse Cholesky with its memory
//!   estimate; [`lanczos`]: the shift-invert block Lanczos eigensolver of the
//!   large-model Craig-Bampton path; [`solid`]: a hexahedral plate test model.
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

/// A scalar nonlinear force law `f(u, v)` acting along a direction `w` of the
/// generalized coordinates: relative displacement `u = w^T q` [m], velocity
/// `v = w^T q'` [m/s]; it adds `w f(u, v)` to `g(q, q')`.
///
/// A new nonlinearity (unilateral spring, regularised friction, ...) is one
/// type implementing this trait.
///
/// A law with memory (hysteresis, e.g. the Jenkins element
/// [`laws::ElasticDryFriction`]) also returns its [`Hysteresis`] from
/// [`NonlinearLaw::hysteresis`]: the consumers (the AFT of [`crate::nma::hb`], the
/// reference integrators) then march its internal state instead of calling
/// [`NonlinearLaw::eval`], which for such a law is the virgin response from the
/// relaxed state at `u = 0` (the first-loading curve).
pub trait NonlinearLaw: std::fmt::Debug + Send + Sync {
    /// Short name used in logs and files.
    fn name(&self) -> &str;
    /// Force [N] and its partial derivatives `(f, df/du, df/dv)`.
    fn eval(&self, u: f64, v: f64) -> (f64, f64, f64);
    /// The internal-state description of a hysteretic law; `None` (the default)
    /// for a memoryless law `f(u, v)`.
    fn hysteresis(&self) -> Option<&dyn Hysteresis> {
        None
    }
    /// For a law that saturates over a velocity scale (regularised Coulomb
    /// friction): `(F_s [N], v_r [m/s])`, the saturation force and the
    /// velocity over which the force turns. The AFT then needs samples across
    /// the transition ([`crate::nma::NmaOptions::samples`]). Default `None`.
    fn velocity_saturation(&self) -> Option<(f64, f64)> {
        None
    }
}

/// A rate-independent hysteretic law with one scalar internal state `s` (for the
/// Jenkins element the slider position [m]): the force after moving to the
/// displacement `u` from state `s` is `f(s, u)`, and the state becomes `s'(s, u)`.
/// The partial derivatives make the chain rule through a whole time march exact
/// (the AFT Jacobian of [`crate::nma::hb::Aft::eval`]).
pub trait Hysteresis: std::fmt::Debug + Send + Sync {
    /// The relaxed state at displacement `u` (zero force, e.g. a stuck slider at
    /// `u`) and its derivative `ds/du`.
    fn relaxed_state(&self, u: f64) -> (f64, f64);
    /// The state a periodic AFT march ([`crate::nma::hb::Aft`]) starts from at
    /// the mean displacement `u` of the period, and its derivative `ds/du`
    /// (default: [`Hysteresis::relaxed_state`]; the Jenkins element can start
    /// its slider at zero instead, [`laws::InitialSlider`]). It matters only
    /// where the element never slips: a stuck element keeps this state.
    fn initial_state(&self, u: f64) -> (f64, f64) {
        self.relaxed_state(u)
    }
    /// Move from state `s` to displacement `u`.
    fn step(&self, s: f64, u: f64) -> HystereticStep;
    /// The parameters of a play-type (Jenkins) law, if this is one: the AFT
    /// then integrates its loop exactly between located stick-slip transition
    /// instants ([`crate::nma::hb`]) instead of marching time samples.
    /// Default `None` (sampled march).
    fn play(&self) -> Option<PlayOperator> {
        None
    }
}

/// A play-type hysteresis (Jenkins element): a spring of stiffness `k_t`
/// [N/m] in series with a Coulomb slider of slip force `F_s` [N]; the slider
/// `w` moves only where `|k_t (u - w)| = F_s`. See [`Hysteresis::play`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlayOperator {
    /// `k_t` [N/m].
    pub stiffness_n_per_m: f64,
    /// `F_s` [N].
    pub slip_force_n: f64,
}

/// Result of [`Hysteresis::step`]: force [N], new state and their partial
/// derivatives with respect to the displacement `u` and the previous state `s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HystereticStep {
    pub force: f64,
    pub dforce_du: f64,
    pub dforce_ds: f64,
    pub state: f64,
    pub dstate_du: f64,
    pub dstate_ds: f64,
}

/// A nonlinear element of the structure: a law and the direction it acts along.
#[derive(Debug, Clone)]
pub struct NonlinearElement {
    pub name: String,
    /// Direction in generalized coordinates (length `ndof`).
    pub direction: DVector<f64>,
    pub law: Arc<dyn NonlinearLaw>,
}

/// A named physical point of the structure (tip, exciter location, any DOF):
/// its displacement is `u = e^T q` and a point force `F` enters as `e F`.
#[derive(Debug, Clone)]
pub struct NamedPoint {
    pub name: String,
    /// Observation / load vector `e` in generalized coordinates (length `ndof`).
    pub direction: DVector<f64>,
}

/// The structural model of `eq:component1` in generalized coordinates.
#[derive(Debug, Clone)]
pub struct StructuralModel {
    /// Mass matrix `M` (symmetric positive definite).
    pub mass: DMatrix<f64>,
    /// Linear stiffness matrix `K`.
    pub stiffness: DMatrix<f64>,
    /// Linear viscous damping matrix `C`.
    pub damping: DMatrix<f64>,
    /// Local nonlinear elements.
    pub nonlinear: Vec<NonlinearElement>,
    /// Named observation / load points.
    pub points: Vec<NamedPoint>,
}

pub mod beam;
pub mod craig_bampton;
pub mod damping;
pub mod lanczos;
pub mod laws;
pub mod matrices;
pub mod modal;
pub mod ordering;
pub mod paper;
pub mod product;
pub mod solid;
pub mod sparse;
pub mod subspace;
pub mod supernodal;

pub use beam::{Beam, BeamSpec, BoundaryCondition};
pub use craig_bampton::{craig_bampton, craig_bampton_sparse, CraigBampton, SparseCraigBampton};
pub use damping::{
    modal_damping, rayleigh_damping, stiffness_proportional_damping,
    stiffness_proportional_damping_from_modes,
};
pub use laws::{
    ElasticDryFriction, InitialSlider, PolynomialSpring, QuadraticDamper, RegularizedFriction,
    UnilateralSpring,
};
pub use matrices::{
    matrix_structure, matrix_structure_sparse, matrix_structure_sparse_cb, read_matrix_market,
    read_matrix_market_sparse, MatricesError, MatrixDamping, MatrixRole, MatrixStructure,
    MatrixStructureOptions,
};
pub use modal::{modal_analysis, LinearModes};
pub use paper::{paper_structure, PaperStructure, PaperStructureOptions};
pub use sparse::SparseMatrix;

/// Errors of the structure layer. Every variant names the offending input and
/// carries its value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StructureError {
    /// A physical parameter that must be positive and finite is not.
    #[error("`{name}` must be positive and finite, got {value}")]
    NonPositive { name: &'static str, value: f64 },
    /// A parameter outside its admissible range (other than positivity).
    #[error("`{name}` = {value} is invalid: expected {expected}")]
    InvalidParameter {
        name: &'static str,
        value: f64,
        expected: &'static str,
    },
    /// The beam needs at least `min` nodes.
    #[error("`n_nodes` = {n_nodes} is too few: the beam needs at least {min} nodes")]
    TooFewNodes { n_nodes: usize, min: usize },
    /// An unknown boundary-condition name.
    #[error("unknown boundary condition `{name}`; expected one of {expected}")]
    UnknownBoundaryCondition { name: String, expected: String },
    /// An initial slider state other than `mean` or `zero`.
    #[error("unknown initial slider state '{name}' (expected: mean, zero)")]
    UnknownInitialSlider { name: String },
    /// A location outside `[0, l]`.
    #[error("location x = {x_m} m lies outside the beam [0, {length_m}] m")]
    LocationOutsideBeam { x_m: f64, length_m: f64 },
    /// A location that is not a node (tolerance `1e-9 l`); no snapping is done.
    #[error(
        "location x = {x_m} m lies between node {left_node} (x = {left_x_m} m) and node \
         {right_node} (x = {right_x_m} m); choose a node position or change `n_nodes`"
    )]
    LocationBetweenNodes {
        x_m: f64,
        left_node: usize,
        left_x_m: f64,
        right_node: usize,
        right_x_m: f64,
    },
    /// A node index beyond the last node.
    #[error("node {node} does not exist: the beam has {n_nodes} nodes")]
    NodeOutOfRange { node: usize, n_nodes: usize },
    /// A point or element requested on a DOF removed by the boundary condition.
    #[error("`{name}`: the translation of node {node} (x = {x_m} m) is constrained by the boundary condition")]
    ConstrainedDof { name: String, node: usize, x_m: f64 },
    /// No named point with this name.
    #[error("unknown point `{name}`; the model has the points {available:?}")]
    UnknownPoint {
        name: String,
        available: Vec<String>,
    },
    /// A point or nonlinear element name used twice.
    #[error("duplicate {kind} name `{name}`")]
    DuplicateName { kind: &'static str, name: String },
    /// A user-supplied vector of the wrong length.
    #[error("`{name}` has length {got}, expected {expected}")]
    WrongLength {
        name: String,
        expected: usize,
        got: usize,
    },
    /// A DOF index beyond `ndof`.
    #[error("`{name}`: DOF {dof} is out of range (the model has {ndof} DOFs)")]
    DofOutOfRange {
        name: &'static str,
        dof: usize,
        ndof: usize,
    },
    /// A DOF listed twice (e.g. among the Craig-Bampton masters).
    #[error("`{name}`: DOF {dof} is listed twice")]
    DuplicateDof { name: &'static str, dof: usize },
    /// A mode index (0-based) beyond the computed/available modes.
    #[error("mode index {index} is out of range: {available} modes are available")]
    ModeIndexOutOfRange { index: usize, available: usize },
    /// A number of modes that is zero or exceeds the available DOFs.
    #[error("`{name}` = {requested} modes requested, but between 1 and {available} are possible")]
    ModeCount {
        name: &'static str,
        requested: usize,
        available: usize,
    },
    /// Calibrating damping on a mode with (numerically) zero frequency.
    #[error("mode {index} has omega = {omega_rad_s} rad/s (rigid-body mode): cannot calibrate damping on it")]
    ZeroFrequencyMode { index: usize, omega_rad_s: f64 },
    /// `K phi = lambda M phi` has a clearly negative eigenvalue (unstable linear model).
    #[error("eigenvalue {index} of K phi = lambda M phi is negative ({lambda:e}): the stiffness is not positive semi-definite")]
    NegativeEigenvalue { index: usize, lambda: f64 },
    /// The mass matrix is not symmetric positive definite.
    #[error("the mass matrix `{name}` is not symmetric positive definite (Cholesky failed)")]
    MassNotPositiveDefinite { name: &'static str },
    /// The interior stiffness `K_ii` of a Craig-Bampton split is singular: the masters
    /// do not restrain the rigid-body motion.
    #[error("the interior stiffness K_ii is not positive definite: the masters {masters:?} do not restrain all rigid-body motion")]
    SingularInterior { masters: Vec<usize> },
    /// The sparse eigensolver did not converge within its bounded basis.
    #[error(
        "`{name}`: the sparse eigensolver did not converge for {requested} modes within a \
         basis of {basis} vectors (relative residual {residual:e})"
    )]
    EigenNotConverged {
        name: &'static str,
        requested: usize,
        basis: usize,
        residual: f64,
    },
    /// A matrix that must be symmetric is not.
    #[error(
        "matrix `{name}` is not symmetric: max |A - A^T| = {asymmetry:e}, max |A| = {scale:e}"
    )]
    NotSymmetric {
        name: &'static str,
        asymmetry: f64,
        scale: f64,
    },
    /// Non-finite entries (NaN or infinity).
    #[error("`{name}` contains non-finite entries")]
    NonFinite { name: String },
    /// The large-model path would need more memory than allowed (estimated from
    /// the symbolic factorisation, before any numeric work).
    #[error(
        "the {ndof}-DOF model needs about {:.2} GB for the sparse reduction (its Cholesky \
         factor has {factor_nnz} non-zeros, {:.2} GB), above the memory limit of {:.2} GB: \
         use a coarser mesh, free memory or raise the limit",
        *needed_bytes as f64 / 1e9, *factor_bytes as f64 / 1e9, *limit_bytes as f64 / 1e9
    )]
    MemoryLimit {
        ndof: usize,
        factor_nnz: usize,
        needed_bytes: u64,
        factor_bytes: u64,
        limit_bytes: u64,
    },
    /// Inconsistent matrix sizes.
    #[error("`{name}` is {rows}x{cols}, expected {expected}x{expected}")]
    WrongShape {
        name: &'static str,
        rows: usize,
        cols: usize,
        expected: usize,
    },
}

/// Result alias of the structure layer.
pub type Result<T, E = StructureError> = std::result::Result<T, E>;

impl StructuralModel {
    /// An undamped linear model `M q'' + K q = f` without points or nonlinear elements.
    ///
    /// Panics if `mass` and `stiffness` are not square of the same size (a programming
    /// error); call [`StructuralModel::validate`] to check the physics.
    pub fn new(mass: DMatrix<f64>, stiffness: DMatrix<f64>) -> Self {
        let n = mass.nrows();
        assert!(
            mass.is_square() && stiffness.shape() == (n, n),
            "M and K must be square of the same size"
        );
        Self {
            mass,
            stiffness,
            damping: DMatrix::zeros(n, n),
            nonlinear: Vec::new(),
            points: Vec::new(),
        }
    }

    /// Number of generalized coordinates.
    pub fn ndof(&self) -> usize {
        self.mass.nrows()
    }

    /// The named point `name`.
    pub fn point(&self, name: &str) -> Result<&NamedPoint> {
        self.points
            .iter()
            .find(|p| p.name == name)
            .ok_or_else(|| StructureError::UnknownPoint {
                name: name.to_string(),
                available: self.points.iter().map(|p| p.name.clone()).collect(),
            })
    }

    /// Adds a named point with observation / load vector `direction` (length `ndof`).
    pub fn add_named_point(&mut self, name: &str, direction: DVector<f64>) -> Result<()> {
        self.check_direction(name, &direction)?;
        if self.points.iter().any(|p| p.name == name) {
            return Err(StructureError::DuplicateName {
                kind: "point",
                name: name.to_string(),
            });
        }
        self.points.push(NamedPoint {
            name: name.to_string(),
            direction,
        });
        Ok(())
    }

    /// Adds a nonlinear element: the law `law` acting along `direction` (length `ndof`),
    /// contributing `w f(w^T q, w^T q')` to `g(q, q')` (`eq:component1`).
    pub fn add_nonlinear<L: NonlinearLaw + 'static>(
        &mut self,
        name: &str,
        direction: DVector<f64>,
        law: L,
    ) -> Result<()> {
        self.add_nonlinear_shared(name, direction, Arc::new(law))
    }

    /// As [`StructuralModel::add_nonlinear`] with an already shared law.
    pub fn add_nonlinear_shared(
        &mut self,
        name: &str,
        direction: DVector<f64>,
        law: Arc<dyn NonlinearLaw>,
    ) -> Result<()> {
        self.check_direction(name, &direction)?;
        if self.nonlinear.iter().any(|e| e.name == name) {
            return Err(StructureError::DuplicateName {
                kind: "nonlinear element",
                name: name.to_string(),
            });
        }
        self.nonlinear.push(NonlinearElement {
            name: name.to_string(),
            direction,
            law,
        });
        Ok(())
    }

    fn check_direction(&self, name: &str, direction: &DVector<f64>) -> Result<()> {
        if direction.len() != self.ndof() {
            return Err(StructureError::WrongLength {
                name: name.to_string(),
                expected: self.ndof(),
                got: direction.len(),
            });
        }
        if direction.iter().any(|v| !v.is_finite()) {
            return Err(StructureError::NonFinite {
                name: name.to_string(),
            });
        }
        Ok(())
    }

    /// Nonlinear part of `g`: `sum_e w_e f_e(w_e^T q, w_e^T q')` [N].
    pub fn nonlinear_force(&self, q: &DVector<f64>, qd: &DVector<f64>) -> DVector<f64> {
        assert_eq!(q.len(), self.ndof(), "q has the wrong length");
        assert_eq!(qd.len(), self.ndof(), "q' has the wrong length");
        let mut g = DVector::zeros(self.ndof());
        for e in &self.nonlinear {
            let (f, _, _) = e.law.eval(e.direction.dot(q), e.direction.dot(qd));
            g.axpy(f, &e.direction, 1.0);
        }
        g
    }

    /// The internal force `g(q, q') = C q' + K q + sum_e w_e f_e(w_e^T q, w_e^T q')`
    /// of `eq:component1` [N].
    pub fn internal_force(&self, q: &DVector<f64>, qd: &DVector<f64>) -> DVector<f64> {
        let mut g = self.nonlinear_force(q, qd);
        g.gemv(1.0, &self.stiffness, q, 1.0);
        g.gemv(1.0, &self.damping, qd, 1.0);
        g
    }

    /// Jacobians `(dg/dq, dg/dq')` of [`StructuralModel::internal_force`]:
    /// `K + sum_e w_e w_e^T df_e/du` and `C + sum_e w_e w_e^T df_e/dv`.
    pub fn internal_force_jacobians(
        &self,
        q: &DVector<f64>,
        qd: &DVector<f64>,
    ) -> (DMatrix<f64>, DMatrix<f64>) {
        assert_eq!(q.len(), self.ndof(), "q has the wrong length");
        assert_eq!(qd.len(), self.ndof(), "q' has the wrong length");
        let mut dq = self.stiffness.clone();
        let mut dqd = self.damping.clone();
        for e in &self.nonlinear {
            let (_, dfdu, dfdv) = e.law.eval(e.direction.dot(q), e.direction.dot(qd));
            dq.ger(dfdu, &e.direction, &e.direction, 1.0);
            dqd.ger(dfdv, &e.direction, &e.direction, 1.0);
        }
        (dq, dqd)
    }

    /// Checks shapes, finiteness, symmetry of `M`, `K`, `C` (relative tolerance `1e-9`)
    /// and positive definiteness of `M`.
    pub fn validate(&self) -> Result<()> {
        let n = self.ndof();
        for (name, a) in [
            ("mass", &self.mass),
            ("stiffness", &self.stiffness),
            ("damping", &self.damping),
        ] {
            if a.shape() != (n, n) {
                return Err(StructureError::WrongShape {
                    name,
                    rows: a.nrows(),
                    cols: a.ncols(),
                    expected: n,
                });
            }
            if a.iter().any(|v| !v.is_finite()) {
                return Err(StructureError::NonFinite {
                    name: name.to_string(),
                });
            }
            let scale = a.amax();
            let asymmetry = (a - a.transpose()).amax();
            if asymmetry > 1e-9 * scale {
                return Err(StructureError::NotSymmetric {
                    name,
                    asymmetry,
                    scale,
                });
            }
        }
        for p in &self.points {
            self.check_direction(&p.name, &p.direction)?;
        }
        for e in &self.nonlinear {
            self.check_direction(&e.name, &e.direction)?;
        }
        if n == 0 || self.mass.clone().cholesky().is_none() {
            return Err(StructureError::MassNotPositiveDefinite { name: "mass" });
        }
        Ok(())
    }
}

/// The cubic spring of the paper (Section 5): `f = k3 u^3` [N], `u` [m].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CubicSpring {
    /// Cubic stiffness `k3` [N/m^3] (negative = softening).
    pub k3_n_per_m3: f64,
}

impl CubicSpring {
    /// A cubic spring; `k3` must be finite.
    pub fn new(k3_n_per_m3: f64) -> Result<Self> {
        if !k3_n_per_m3.is_finite() {
            return Err(StructureError::InvalidParameter {
                name: "k3_n_per_m3",
                value: k3_n_per_m3,
                expected: "a finite number",
            });
        }
        Ok(Self { k3_n_per_m3 })
    }
}

impl NonlinearLaw for CubicSpring {
    fn name(&self) -> &str {
        "cubic_spring"
    }
    fn eval(&self, u: f64, _v: f64) -> (f64, f64, f64) {
        (
            self.k3_n_per_m3 * u * u * u,
            3.0 * self.k3_n_per_m3 * u * u,
            0.0,
        )
    }
}

/// Symmetric part `(A + A^T)/2` (removes rounding asymmetry after projections).
pub(crate) fn symmetrize(a: DMatrix<f64>) -> DMatrix<f64> {
    (&a + a.transpose()) * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two DOFs, spring between them, a velocity-dependent test law to check `dg/dq'`.
    #[derive(Debug)]
    struct QuadraticDamper(f64);
    impl NonlinearLaw for QuadraticDamper {
        fn name(&self) -> &str {
            "quadratic_damper"
        }
        fn eval(&self, u: f64, v: f64) -> (f64, f64, f64) {
            (self.0 * v * v.abs() + 0.5 * u, 0.5, 2.0 * self.0 * v.abs())
        }
    }

    fn two_dof() -> StructuralModel {
        let m = DMatrix::from_row_slice(2, 2, &[2.0, 0.0, 0.0, 1.0]);
        let k = DMatrix::from_row_slice(2, 2, &[300.0, -100.0, -100.0, 100.0]);
        let mut s = StructuralModel::new(m, k);
        s.damping = DMatrix::from_row_slice(2, 2, &[0.3, -0.1, -0.1, 0.1]);
        s.add_nonlinear(
            "spring",
            DVector::from_vec(vec![-1.0, 1.0]),
            CubicSpring::new(4e3).unwrap(),
        )
        .unwrap();
        s.add_nonlinear(
            "damper",
            DVector::from_vec(vec![0.0, 1.0]),
            QuadraticDamper(7.0),
        )
        .unwrap();
        s
    }

    #[test]
    fn cubic_spring_force_and_derivative() {
        let s = CubicSpring::new(6e9).unwrap();
        let (f, dfdu, dfdv) = s.eval(-2e-3, 5.0);
        assert!((f - (-6e9 * 8e-9)).abs() < 1e-12);
        assert!((dfdu - 3.0 * 6e9 * 4e-6).abs() < 1e-9);
        assert_eq!(dfdv, 0.0);
        assert!(matches!(
            CubicSpring::new(f64::NAN),
            Err(StructureError::InvalidParameter { .. })
        ));
    }

    #[test]
    fn internal_force_matches_hand_calculation() {
        let s = two_dof();
        let q = DVector::from_vec(vec![0.01, 0.03]);
        let qd = DVector::from_vec(vec![-0.2, 0.5]);
        let g = s.internal_force(&q, &qd);
        // K q + C q' by hand, spring u = 0.02, damper v = 0.5, u = 0.03
        let fs = 4e3 * 0.02f64.powi(3);
        let fd = 7.0 * 0.25 + 0.5 * 0.03;
        let g0 = 300.0 * 0.01 - 100.0 * 0.03 + 0.3 * -0.2 - 0.1 * 0.5 - fs;
        let g1 = -100.0 * 0.01 + 100.0 * 0.03 - 0.1 * -0.2 + 0.1 * 0.5 + fs + fd;
        assert!((g[0] - g0).abs() < 1e-12, "{} vs {g0}", g[0]);
        assert!((g[1] - g1).abs() < 1e-12, "{} vs {g1}", g[1]);
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let s = two_dof();
        let q = DVector::from_vec(vec![0.01, -0.03]);
        let qd = DVector::from_vec(vec![0.4, -0.7]);
        let (jq, jqd) = s.internal_force_jacobians(&q, &qd);
        let h = 1e-7;
        for j in 0..2 {
            let mut dq = DVector::zeros(2);
            dq[j] = h;
            let fdq = (s.internal_force(&(&q + &dq), &qd) - s.internal_force(&(&q - &dq), &qd))
                / (2.0 * h);
            let fdqd = (s.internal_force(&q, &(&qd + &dq)) - s.internal_force(&q, &(&qd - &dq)))
                / (2.0 * h);
            for i in 0..2 {
                assert!(
                    (jq[(i, j)] - fdq[i]).abs() < 1e-6 * (1.0 + fdq[i].abs()),
                    "dg/dq[{i},{j}]"
                );
                assert!(
                    (jqd[(i, j)] - fdqd[i]).abs() < 1e-6 * (1.0 + fdqd[i].abs()),
                    "dg/dq'[{i},{j}]"
                );
            }
        }
        // the nonlinear parts are not negligible at this state
        assert!((jq[(1, 1)] - 100.0).abs() > 1.0);
        assert!((jqd[(1, 1)] - 0.1).abs() > 1.0);
    }

    #[test]
    fn validate_and_lookups_reject_bad_input() {
        let mut s = two_dof();
        s.validate().unwrap();
        assert!(matches!(
            s.point("tip"),
            Err(StructureError::UnknownPoint { .. })
        ));
        s.add_named_point("tip", DVector::from_vec(vec![0.0, 1.0]))
            .unwrap();
        assert_eq!(s.point("tip").unwrap().direction[1], 1.0);
        assert!(matches!(
            s.add_named_point("tip", DVector::from_vec(vec![1.0, 0.0])),
            Err(StructureError::DuplicateName { .. })
        ));
        assert!(matches!(
            s.add_named_point("x", DVector::from_vec(vec![1.0])),
            Err(StructureError::WrongLength {
                expected: 2,
                got: 1,
                ..
            })
        ));
        let mut bad = s.clone();
        bad.stiffness[(0, 1)] = -50.0;
        assert!(matches!(
            bad.validate(),
            Err(StructureError::NotSymmetric {
                name: "stiffness",
                ..
            })
        ));
        let mut bad = s.clone();
        bad.mass[(1, 1)] = -1.0;
        assert!(matches!(
            bad.validate(),
            Err(StructureError::MassNotPositiveDefinite { .. })
        ));
        let mut bad = s.clone();
        bad.damping[(0, 0)] = f64::NAN;
        assert!(matches!(
            bad.validate(),
            Err(StructureError::NonFinite { .. })
        ));
    }
}
