//! Structural model of `eq:component1`: `M q'' + g(q, q') = f_ex1(t) + f_c1`,
//! with `g(q, q') = C q' + K q + sum_e w_e f_e(w_e^T q, w_e^T q')`.
//!
//! (skeleton: the shared data types; beam FE, damping, Craig-Bampton and modal
//! analysis are filled in by the structure work.)
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

/// A scalar nonlinear force law `f(u, v)` acting along a direction `w` of the
/// generalized coordinates: relative displacement `u = w^T q` [m], velocity
/// `v = w^T q'` [m/s]; it adds `w f(u, v)` to `g(q, q')`.
///
/// A new nonlinearity (unilateral spring, regularised friction, ...) is one
/// type implementing this trait.
pub trait NonlinearLaw: std::fmt::Debug + Send + Sync {
    /// Short name used in logs and files.
    fn name(&self) -> &str;
    /// Force [N] and its partial derivatives `(f, df/du, df/dv)`.
    fn eval(&self, u: f64, v: f64) -> (f64, f64, f64);
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
