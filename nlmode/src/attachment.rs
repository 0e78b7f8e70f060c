//! Linear attachments (`eq:component2`): `sum_k A_k d^k x/dt^k = f_ex2(t) + c2`,
//! coupled to the structure by the compatibility `B1 q + B2 x = 0`
//! (`eq:compatibility`), primal variables `x = L1 q + L2 x_r` (`eq:primal`,
//! `eq:L1L2`: `L1 = -pinv(B2) B1`, `L2 = null(B2)` from the SVD).
//!
//! The structure side of the interface is given by named structure points: the
//! `c`-th constraint reads `(B2 x)_c - e_c^T q = 0`, i.e. row `c` of `B1` is
//! `-e_c^T` (the paper's `B1 = -e_ex^T` for the shaker).
//!
//! (skeleton: the shared data type; L1/L2, impedances, the condensation of
//! `eq:fc1` and the shaker constructor are filled in by the attachment work.)
use nalgebra::DMatrix;

/// A generic linear attachment of `eq:component2`.
#[derive(Debug, Clone)]
pub struct LinearAttachment {
    pub name: String,
    /// `A_k`, `k = 0..=order`, each `ndim x ndim`.
    pub coefficients: Vec<DMatrix<f64>>,
    /// Attachment side of the compatibility matrix, `B2` (`ncon x ndim`).
    pub b2: DMatrix<f64>,
    /// Names of the structure points the `ncon` constraints attach to.
    pub interface_points: Vec<String>,
    /// Input map: `f_ex2(t) = input_map u(t)` (`ndim x ninput`).
    pub input_map: DMatrix<f64>,
    /// Names of the attachment states `x` (e.g. `I`, `q_a`, `q_s`).
    pub state_names: Vec<String>,
    /// Names of the inputs `u` (e.g. `voltage`).
    pub input_names: Vec<String>,
}
