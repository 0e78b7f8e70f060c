//! Linear attachments (`eq:component2`): `sum_k A_k d^k x/dt^k = f_ex2(t) + c2`,
//! coupled to the structure by the compatibility `B1 q + B2 x = 0`
//! (`eq:compatibility`), primal variables `x = L1 q + L2 x_r` (`eq:primal`,
//! `eq:L1L2`: `L1 = -pinv(B2) B1`, `L2 = null(B2)` from the SVD).
//!
//! # Interface convention
//!
//! The structure side of the interface is given by named structure points
//! ([`NamedPoint`]): the `c`-th constraint reads `(B2 x)_c - e_c^T q = 0`,
//! i.e. row `c` of `B1` is `-e_c^T` (the paper's `B1 = -e_ex^T` for the
//! shaker). With `E = [e_1 .. e_C]` (`ndof x ncon`) this is `B1 = -E^T` and,
//! with `P = pinv(B2)` (`ndim x ncon`),
//!
//! ```text
//! L1 = -P B1 = P E^T,      L2 = null(B2)  (orthonormal, ndim x (ndim - ncon)).
//! ```
//!
//! # Condensation (`eq:fc1`) in interface coordinates
//!
//! With `Z(Omega) = sum_k (i Omega)^k A_k` and `Z_mn = L_m^T Z L_n`, `eq:fc1`
//! reads `c1_hat = -Z_q q_hat + (L1^T - Z12 Z22^{-1} L2^T) f_ex2_hat`. Because
//! `L1 = P E^T`, everything factors through the `ncon` interface displacements
//! `u_G = E^T q_hat`:
//!
//! ```text
//! Z_q = E Z_G E^T,   Z_G = P^T Z P - P^T Z L2 Z22^{-1} L2^T Z P          (ncon x ncon)
//! (L1^T - Z12 Z22^{-1} L2^T) input_map = E T_G,
//!                    T_G = (P^T - P^T Z L2 Z22^{-1} L2^T) input_map      (ncon x ninput)
//! ```
//!
//! which is exact and costs only `ndim`-sized algebra per frequency. If
//! `ncon = ndim`, `L2` is empty and the `2` blocks vanish (paper, after
//! `eq:fc1`): `Z_G = P^T Z P`, `T_G = P^T input_map`.
//!
//! **Sign convention.** The force the attachment exerts on the structure at
//! its interface points (one entry per constraint, positive along `e_c`, i.e.
//! along positive structure displacement) is
//!
//! ```text
//! F_G = -Z_G u_G + T_G u_hat,       u_G = E^T q_hat,       c1_hat = E F_G,
//! ```
//!
//! so the structure's equation in the frequency domain reads
//! `(-Omega^2 M + i Omega C + K + E Z_G E^T) q_hat = E T_G u_hat` (+ `f_ex1`).
//! A passive attachment thus *adds* `Z_G` to the structure's dynamic stiffness
//! (a grounded spring `k` gives `Z_G = k`).
//!
//! The shaker of the paper's Section 4 is [`LinearAttachment::shaker`] with its
//! physical parameters in [`ShakerParams`].
use crate::structure::{NamedPoint, StructuralModel};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

mod shaker;
pub use shaker::{
    sweep_substeps, ArmatureDamping, LtiSystem, ShakerParams, ShakerStepper, Stinger,
    MAX_PHASE_PER_SUBSTEP, MAX_SWEEP_SUBSTEPS,
};

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

/// Relative rank tolerance factor for `B2`: a singular value `s_i` counts as
/// zero if `s_i <= max(ncon, ndim) * f64::EPSILON * s_max` (the usual
/// pseudo-inverse / matrix-rank default, e.g. of LAPACK-based `pinv`).
pub fn rank_tolerance(b2: &DMatrix<f64>) -> f64 {
    let smax = b2
        .clone()
        .svd(false, false)
        .singular_values
        .iter()
        .cloned()
        .fold(0.0, f64::max);
    b2.nrows().max(b2.ncols()) as f64 * f64::EPSILON * smax
}

/// Condition-number limit above which `Z22` counts as singular (see
/// [`AttachmentError::SingularZ22`] for the measure).
pub const Z22_CONDITION_LIMIT: f64 = 1e12;

/// Errors of attachment construction and condensation; each names the input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AttachmentError {
    #[error("attachment parameter `{name}` must be positive, got {value}")]
    NonPositive { name: &'static str, value: f64 },
    #[error("attachment parameter `{name}` must be non-negative, got {value}")]
    Negative { name: &'static str, value: f64 },
    #[error("attachment `{attachment}`: `{name}` contains a non-finite value ({value})")]
    NotFinite {
        attachment: String,
        name: String,
        value: f64,
    },
    #[error("attachment `{attachment}`: `{what}` has dimension {found}, expected {expected}")]
    DimensionMismatch {
        attachment: String,
        what: String,
        expected: usize,
        found: usize,
    },
    #[error("attachment `{attachment}` has no coefficient matrices A_k (need at least A_0)")]
    NoCoefficients { attachment: String },
    #[error("attachment `{attachment}`: {ncon} interface constraints exceed the {ndim} attachment states (the paper requires ncon <= ndim)")]
    TooManyConstraints {
        attachment: String,
        ncon: usize,
        ndim: usize,
    },
    #[error("attachment `{attachment}`: B2 has rank {rank} < ncon = {ncon} (redundant or contradictory constraints; singular values {singular_values:?}, tolerance {tolerance:e})")]
    RankDeficientB2 {
        attachment: String,
        rank: usize,
        ncon: usize,
        singular_values: Vec<f64>,
        tolerance: f64,
    },
    #[error("attachment `{attachment}`: interface point `{point}` does not exist in the structural model (available: {available:?})")]
    UnknownPoint {
        attachment: String,
        point: String,
        available: Vec<String>,
    },
    #[error("attachment `{attachment}`: interface point `{point}` has a direction of length {found}, the structure has {ndof} DOFs")]
    PointDimension {
        attachment: String,
        point: String,
        found: usize,
        ndof: usize,
    },
    #[error("attachment `{attachment}`: Z22 is singular at Omega = {omega_rad_s} rad/s (condition number {condition_number:e} > {limit:e}): the attachment has an undamped resonance under fixed interface (eq:fc1 requires Z22 regular)")]
    SingularZ22 {
        attachment: String,
        omega_rad_s: f64,
        condition_number: f64,
        limit: f64,
    },
    #[error("shaker: the armature damping ratio D_a = {d_a_ratio} is below the electro-mechanical part G^2/(2 R omega_a m_a) = {electrical_ratio}: the mechanical damping d_a = {d_a} N s/m would be negative")]
    NegativeMechanicalDamping {
        d_a_ratio: f64,
        electrical_ratio: f64,
        d_a: f64,
    },
    #[error("shaker: a rigid stinger has no state-space form with the structure displacement as input (the force depends on the structure's acceleration); use an elastic stinger")]
    RigidStingerStateSpace,
    #[error("attachment `{attachment}`: {found} input amplitudes given, the attachment has {expected} inputs")]
    InputCount {
        attachment: String,
        expected: usize,
        found: usize,
    },
}

/// Result type of this module.
pub type Result<T> = std::result::Result<T, AttachmentError>;

/// The SVD-based localization of `eq:L1L2`, independent of the structure.
#[derive(Debug, Clone)]
pub struct Localization {
    /// `P = pinv(B2)` (`ndim x ncon`); `L1 = P E^T`.
    pub pinv_b2: DMatrix<f64>,
    /// `L2 = null(B2)` (`ndim x (ndim - ncon)`), orthonormal columns: the right
    /// singular vectors of `B2` belonging to zero singular values.
    pub l2: DMatrix<f64>,
    /// Singular values of `B2` (descending).
    pub singular_values: Vec<f64>,
    /// Tolerance below which a singular value counted as zero ([`rank_tolerance`]).
    pub tolerance: f64,
}

/// The interface (condensed) quantities of one attachment at one frequency.
#[derive(Debug, Clone)]
pub struct InterfaceCondensation {
    /// Excitation frequency `Omega` \[rad/s\].
    pub omega_rad_s: f64,
    /// `Z_G` (`ncon x ncon`) \[N/m for mechanical interfaces\].
    pub z_g: DMatrix<Complex64>,
    /// `T_G` (`ncon x ninput`) \[N per input unit, e.g. N/V\].
    pub t_g: DMatrix<Complex64>,
}

impl InterfaceCondensation {
    /// Interface force on the structure `F_G = -Z_G u_G + T_G u_hat` (sign
    /// convention of the module docs).
    pub fn force(
        &self,
        u_g: &DVector<Complex64>,
        u_hat: &DVector<Complex64>,
    ) -> DVector<Complex64> {
        &self.t_g * u_hat - &self.z_g * u_g
    }
}

/// Full-size impedance blocks `Z_mn = L_m^T Z L_n` of `eq:assemblyF1`-`eq:assemblyF2`.
#[derive(Debug, Clone)]
pub struct ImpedanceBlocks {
    /// `Z11` (`ndof x ndof`).
    pub z11: DMatrix<Complex64>,
    /// `Z12` (`ndof x (ndim - ncon)`).
    pub z12: DMatrix<Complex64>,
    /// `Z21` (`(ndim - ncon) x ndof`).
    pub z21: DMatrix<Complex64>,
    /// `Z22` (`(ndim - ncon) x (ndim - ncon)`).
    pub z22: DMatrix<Complex64>,
}

fn to_complex(m: &DMatrix<f64>) -> DMatrix<Complex64> {
    m.map(|v| Complex64::new(v, 0.0))
}

fn check_finite(attachment: &str, name: &str, m: &DMatrix<f64>) -> Result<()> {
    match m.iter().find(|v| !v.is_finite()) {
        Some(&value) => Err(AttachmentError::NotFinite {
            attachment: attachment.to_string(),
            name: name.to_string(),
            value,
        }),
        None => Ok(()),
    }
}

impl LinearAttachment {
    /// A tuned-mass damper at the structure point `point`: a mass `m` on a spring
    /// `k` and a dashpot `d` to the interface (eq:component2 with `x = [x_m, x_s]`,
    /// `x_s` the interface coordinate fixed to the structure by `B2 = [0, 1]`):
    /// `A_0 = k [[1, -1], [-1, 1]]`, `A_1 = d [[1, -1], [-1, 1]]`,
    /// `A_2 = [[m, 0], [0, 0]]`. `m > 0`, `k > 0`, `d >= 0` (SI units).
    pub fn tuned_mass_damper(
        name: &str,
        point: &str,
        mass_kg: f64,
        stiffness_n_per_m: f64,
        damping_n_s_per_m: f64,
    ) -> Result<Self> {
        for (name, value) in [
            ("mass_kg", mass_kg),
            ("stiffness_n_per_m", stiffness_n_per_m),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(AttachmentError::NonPositive { name, value });
            }
        }
        if !(damping_n_s_per_m.is_finite() && damping_n_s_per_m >= 0.0) {
            return Err(AttachmentError::Negative {
                name: "damping_n_s_per_m",
                value: damping_n_s_per_m,
            });
        }
        let (m, k, d) = (mass_kg, stiffness_n_per_m, damping_n_s_per_m);
        Ok(LinearAttachment {
            name: name.into(),
            coefficients: vec![
                DMatrix::from_row_slice(2, 2, &[k, -k, -k, k]),
                DMatrix::from_row_slice(2, 2, &[d, -d, -d, d]),
                DMatrix::from_row_slice(2, 2, &[m, 0.0, 0.0, 0.0]),
            ],
            b2: DMatrix::from_row_slice(1, 2, &[0.0, 1.0]),
            interface_points: vec![point.into()],
            input_map: DMatrix::zeros(2, 0),
            state_names: vec!["x_m".into(), "x_s".into()],
            input_names: vec![],
        })
    }

    /// A rigid mass `m` \[kg\] at the structure point `point` (eq:component2 with
    /// `x = [x_s]`, `A_2 = [m]`, `B2 = [1]`): `Z_G = -Omega^2 m`.
    pub fn rigid_mass(name: &str, point: &str, mass_kg: f64) -> Result<Self> {
        if !(mass_kg.is_finite() && mass_kg > 0.0) {
            return Err(AttachmentError::NonPositive {
                name: "mass_kg",
                value: mass_kg,
            });
        }
        Ok(LinearAttachment {
            name: name.into(),
            coefficients: vec![
                DMatrix::zeros(1, 1),
                DMatrix::zeros(1, 1),
                DMatrix::from_element(1, 1, mass_kg),
            ],
            b2: DMatrix::from_element(1, 1, 1.0),
            interface_points: vec![point.into()],
            input_map: DMatrix::zeros(1, 0),
            state_names: vec!["x_s".into()],
            input_names: vec![],
        })
    }

    /// A piezoelectric stack between the structure point `point` and ground,
    /// its electrodes shunted by a resistor (energy harvesting). States
    /// `x = [x_s, v]` (interface displacement \[m\], electrode voltage \[V\]),
    /// `B2 = [1, 0]`, with the short-circuit stack stiffness `k_p`, the coupling
    /// `theta` \[N/V = C/m\], the blocked capacitance `C_p` and the shunt `R`:
    ///
    /// ```text
    /// k_p x_s - theta v = c2          (force of the structure on the stack)
    /// theta x_s' + C_p v' + v / R = 0 (charge balance: piezo current = shunt current)
    /// ```
    ///
    /// i.e. `A_0 = [[k_p, -theta], [0, 1/R]]`, `A_1 = [[0, 0], [theta, C_p]]`.
    /// The force on the structure is `-k_p x_s + theta v`; the power dissipated in
    /// the shunt (harvested) is `v^2 / R`, mean `|v_hat|^2 / (2 R)` in steady state.
    /// `C_p, R, theta > 0`, `k_p >= 0`.
    pub fn piezo_shunt(
        name: &str,
        point: &str,
        capacitance_f: f64,
        resistance_ohm: f64,
        coupling_n_per_v: f64,
        stiffness_n_per_m: f64,
    ) -> Result<Self> {
        for (name, value) in [
            ("capacitance_f", capacitance_f),
            ("resistance_ohm", resistance_ohm),
            ("coupling_n_per_v", coupling_n_per_v),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(AttachmentError::NonPositive { name, value });
            }
        }
        if !(stiffness_n_per_m.is_finite() && stiffness_n_per_m >= 0.0) {
            return Err(AttachmentError::Negative {
                name: "stiffness_n_per_m",
                value: stiffness_n_per_m,
            });
        }
        let (kp, th, cp, r) = (
            stiffness_n_per_m,
            coupling_n_per_v,
            capacitance_f,
            resistance_ohm,
        );
        Ok(LinearAttachment {
            name: name.into(),
            coefficients: vec![
                DMatrix::from_row_slice(2, 2, &[kp, -th, 0.0, 1.0 / r]),
                DMatrix::from_row_slice(2, 2, &[0.0, 0.0, th, cp]),
            ],
            b2: DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
            interface_points: vec![point.into()],
            input_map: DMatrix::zeros(2, 0),
            state_names: vec!["x_s".into(), "v".into()],
            input_names: vec![],
        })
    }

    /// Fixed-interface poles of the attachment: the roots `s` of
    /// `det(sum_k s^k L2^T A_k L2) = 0` (`Z22` of `eq:fc1` at `Omega = s / i`),
    /// finite ones only. Computed from the companion linearisation of the
    /// reversed polynomial in `mu = 1/s`, whose leading coefficient
    /// `L2^T A_0 L2` is regular unless the fixed attachment has a static
    /// (zero-stiffness) mode ([`AttachmentError::SingularZ22`] at `Omega = 0`);
    /// `mu = 0` (`s = infinity`, e.g. a massless state) is dropped. Empty when
    /// the interface fixes every state. \[rad/s, complex\]
    pub fn fixed_interface_poles(&self) -> Result<Vec<Complex64>> {
        let loc = self.localization()?;
        let l2 = &loc.l2;
        let nr = l2.ncols();
        if nr == 0 {
            return Ok(Vec::new());
        }
        let a: Vec<DMatrix<f64>> = self
            .coefficients
            .iter()
            .map(|ak| l2.transpose() * ak * l2)
            .collect();
        let p = a.len() - 1;
        if p == 0 {
            return Ok(Vec::new());
        }
        // reversed polynomial sum_k mu^(p-k) A_k: leading coefficient A_0
        let Some(a0_inv) = a[0].clone().try_inverse() else {
            return Err(AttachmentError::SingularZ22 {
                attachment: self.name.clone(),
                omega_rad_s: 0.0,
                condition_number: f64::INFINITY,
                limit: Z22_CONDITION_LIMIT,
            });
        };
        // companion matrix of mu^p I + sum_{j<p} mu^j A0^-1 A_{p-j}
        let n = nr * p;
        let mut c = DMatrix::<f64>::zeros(n, n);
        for blk in 0..p - 1 {
            for i in 0..nr {
                c[(blk * nr + i, (blk + 1) * nr + i)] = 1.0;
            }
        }
        for j in 0..p {
            let coef = -(&a0_inv * &a[p - j]);
            c.view_mut(((p - 1) * nr, j * nr), (nr, nr))
                .copy_from(&coef);
        }
        let mus = c.complex_eigenvalues();
        let scale = mus.iter().map(|m| m.norm()).fold(0.0, f64::max);
        Ok(mus
            .iter()
            .filter(|m| m.norm() > 1e-12 * scale.max(f64::MIN_POSITIVE))
            .map(|m| Complex64::new(1.0, 0.0) / m)
            .collect())
    }

    /// Number of attachment states `N = dim x`.
    pub fn ndim(&self) -> usize {
        self.b2.ncols()
    }

    /// Number of interface constraints `C` (rows of `B2`).
    pub fn ncon(&self) -> usize {
        self.b2.nrows()
    }

    /// Highest time-derivative order `k` of the `A_k`.
    pub fn order(&self) -> usize {
        self.coefficients.len().saturating_sub(1)
    }

    /// Number of inputs `u` (columns of the input map).
    pub fn ninput(&self) -> usize {
        self.input_map.ncols()
    }

    /// [`AttachmentError::InputCount`] unless `u` holds one amplitude per input.
    pub(crate) fn check_input_count(&self, u: &DVector<Complex64>) -> Result<()> {
        if u.len() != self.ninput() {
            return Err(AttachmentError::InputCount {
                attachment: self.name.clone(),
                expected: self.ninput(),
                found: u.len(),
            });
        }
        Ok(())
    }

    fn dim_err(&self, what: &str, expected: usize, found: usize) -> AttachmentError {
        AttachmentError::DimensionMismatch {
            attachment: self.name.clone(),
            what: what.to_string(),
            expected,
            found,
        }
    }

    /// Checks dimensions, finiteness and `ncon <= ndim`. (The rank of `B2` is
    /// checked by [`Self::localization`].)
    pub fn validate(&self) -> Result<()> {
        let n = self.ndim();
        let c = self.ncon();
        if self.coefficients.is_empty() {
            return Err(AttachmentError::NoCoefficients {
                attachment: self.name.clone(),
            });
        }
        if n == 0 {
            return Err(self.dim_err("B2 columns (ndim)", 1, 0));
        }
        if c == 0 {
            return Err(self.dim_err("B2 rows (ncon)", 1, 0));
        }
        for (k, a) in self.coefficients.iter().enumerate() {
            if a.nrows() != n {
                return Err(self.dim_err(&format!("A_{k} rows"), n, a.nrows()));
            }
            if a.ncols() != n {
                return Err(self.dim_err(&format!("A_{k} columns"), n, a.ncols()));
            }
            check_finite(&self.name, &format!("A_{k}"), a)?;
        }
        if c > n {
            return Err(AttachmentError::TooManyConstraints {
                attachment: self.name.clone(),
                ncon: c,
                ndim: n,
            });
        }
        check_finite(&self.name, "B2", &self.b2)?;
        if self.interface_points.len() != c {
            return Err(self.dim_err("interface_points", c, self.interface_points.len()));
        }
        if self.input_map.nrows() != n {
            return Err(self.dim_err("input_map rows", n, self.input_map.nrows()));
        }
        check_finite(&self.name, "input_map", &self.input_map)?;
        if self.input_names.len() != self.ninput() {
            return Err(self.dim_err("input_names", self.ninput(), self.input_names.len()));
        }
        if self.state_names.len() != n {
            return Err(self.dim_err("state_names", n, self.state_names.len()));
        }
        Ok(())
    }

    /// `pinv(B2)` and `L2 = null(B2)` from one SVD of `B2` (`eq:L1L2`).
    ///
    /// `B2` is padded with zero rows to a square `ndim x ndim` matrix so that the
    /// SVD returns the full set of right singular vectors (the padding does not
    /// change the null space nor the non-zero singular triplets). Singular values
    /// below [`rank_tolerance`] count as zero; `B2` must have full row rank
    /// `ncon`, otherwise [`AttachmentError::RankDeficientB2`].
    pub fn localization(&self) -> Result<Localization> {
        self.validate()?;
        let n = self.ndim();
        let c = self.ncon();
        let mut padded = DMatrix::<f64>::zeros(n, n);
        padded.rows_mut(0, c).copy_from(&self.b2);
        let svd = padded.svd(true, true);
        let u = svd.u.as_ref().expect("U requested");
        let v_t = svd.v_t.as_ref().expect("V^T requested");
        let sv: Vec<f64> = svd.singular_values.iter().cloned().collect();
        let tolerance = rank_tolerance(&self.b2);
        let rank = sv.iter().filter(|&&s| s > tolerance).count();
        if rank < c {
            return Err(AttachmentError::RankDeficientB2 {
                attachment: self.name.clone(),
                rank,
                ncon: c,
                singular_values: sv[..c.min(sv.len())].to_vec(),
                tolerance,
            });
        }
        // pinv(padded) = V S^+ U^T (ndim x ndim); pinv(B2) is its first ncon columns.
        let mut pinv_b2 = DMatrix::<f64>::zeros(n, c);
        let mut l2 = DMatrix::<f64>::zeros(n, n - c);
        let mut j2 = 0;
        for (i, &s) in sv.iter().enumerate() {
            let v_i = v_t.row(i).transpose();
            if s > tolerance {
                let u_i = u.column(i).rows(0, c).into_owned();
                pinv_b2 += (&v_i / s) * u_i.transpose();
            } else {
                l2.column_mut(j2).copy_from(&v_i);
                j2 += 1;
            }
        }
        debug_assert_eq!(j2, n - c);
        Ok(Localization {
            pinv_b2,
            l2,
            singular_values: sv[..c].to_vec(),
            tolerance,
        })
    }

    /// The interface point vectors `E = [e_1 .. e_C]` (`ndof x ncon`) from the
    /// structure's named points.
    pub fn interface_vectors(&self, model: &StructuralModel) -> Result<DMatrix<f64>> {
        let ndof = model.mass.nrows();
        let mut e = DMatrix::<f64>::zeros(ndof, self.interface_points.len());
        for (c, name) in self.interface_points.iter().enumerate() {
            let p: &NamedPoint =
                model
                    .points
                    .iter()
                    .find(|p| &p.name == name)
                    .ok_or_else(|| AttachmentError::UnknownPoint {
                        attachment: self.name.clone(),
                        point: name.clone(),
                        available: model.points.iter().map(|p| p.name.clone()).collect(),
                    })?;
            if p.direction.len() != ndof {
                return Err(AttachmentError::PointDimension {
                    attachment: self.name.clone(),
                    point: name.clone(),
                    found: p.direction.len(),
                    ndof,
                });
            }
            e.column_mut(c).copy_from(&p.direction);
        }
        Ok(e)
    }

    /// Structure side of the compatibility matrix, `B1 = -E^T` (`ncon x ndof`).
    pub fn b1(&self, model: &StructuralModel) -> Result<DMatrix<f64>> {
        Ok(-self.interface_vectors(model)?.transpose())
    }

    /// `L1 = -pinv(B2) B1 = pinv(B2) E^T` (`ndim x ndof`, `eq:L1L2`).
    pub fn l1(&self, model: &StructuralModel) -> Result<DMatrix<f64>> {
        let loc = self.localization()?;
        Ok(&loc.pinv_b2 * self.interface_vectors(model)?.transpose())
    }

    /// `L2 = null(B2)` (`ndim x (ndim - ncon)`, orthonormal, `eq:L1L2`).
    pub fn l2(&self) -> Result<DMatrix<f64>> {
        Ok(self.localization()?.l2)
    }

    /// Impedance of the free attachment `Z(Omega) = sum_k (i Omega)^k A_k`
    /// (`ndim x ndim`, below `eq:assemblyF2`).
    pub fn impedance(&self, omega_rad_s: f64) -> DMatrix<Complex64> {
        let n = self.ndim();
        let mut z = DMatrix::<Complex64>::zeros(n, n);
        let mut factor = Complex64::new(1.0, 0.0);
        let i_omega = Complex64::new(0.0, omega_rad_s);
        for a in &self.coefficients {
            z.zip_apply(a, |zij, aij| *zij += factor * aij);
            factor *= i_omega;
        }
        z
    }

    /// Full-size blocks `Z_mn = L_m^T Z L_n` (`eq:assemblyF1`-`eq:assemblyF2`).
    pub fn impedance_blocks(
        &self,
        model: &StructuralModel,
        omega_rad_s: f64,
    ) -> Result<ImpedanceBlocks> {
        let l1 = to_complex(&self.l1(model)?);
        let l2 = to_complex(&self.l2()?);
        let z = self.impedance(omega_rad_s);
        Ok(ImpedanceBlocks {
            z11: l1.transpose() * &z * &l1,
            z12: l1.transpose() * &z * &l2,
            z21: l2.transpose() * &z * &l1,
            z22: l2.transpose() * &z * &l2,
        })
    }

    /// `Z_G` and `T_G` at `Omega` (module docs). For many frequencies build a
    /// [`Condenser`] once and call [`Condenser::condense`].
    pub fn interface_condensation(&self, omega_rad_s: f64) -> Result<InterfaceCondensation> {
        Condenser::new(self)?.condense(omega_rad_s)
    }

    /// Interface impedance `Z_G(Omega)` (`ncon x ncon`), see the module docs.
    pub fn interface_impedance(&self, omega_rad_s: f64) -> Result<DMatrix<Complex64>> {
        Ok(self.interface_condensation(omega_rad_s)?.z_g)
    }

    /// Interface input force map `T_G(Omega)` (`ncon x ninput`): the blocked
    /// force per unit input, see the module docs.
    pub fn interface_input_force(&self, omega_rad_s: f64) -> Result<DMatrix<Complex64>> {
        Ok(self.interface_condensation(omega_rad_s)?.t_g)
    }

    /// Full-size condensation of `eq:fc1`: `(Z_q, force_map)` with
    /// `Z_q = E Z_G E^T` (`ndof x ndof`) and
    /// `force_map = (L1^T - Z12 Z22^{-1} L2^T) input_map = E T_G` (`ndof x ninput`),
    /// so that `c1_hat = -Z_q q_hat + force_map u_hat`.
    pub fn condensed(
        &self,
        model: &StructuralModel,
        omega_rad_s: f64,
    ) -> Result<(DMatrix<Complex64>, DMatrix<Complex64>)> {
        let e = to_complex(&self.interface_vectors(model)?);
        let cond = self.interface_condensation(omega_rad_s)?;
        Ok((&e * &cond.z_g * e.transpose(), &e * &cond.t_g))
    }

    /// Recovers the attachment states `x_hat = L1 q_hat + L2 x_r_hat` from the
    /// interface displacements `u_G = E^T q_hat` and the inputs, with
    /// `x_r_hat = Z22^{-1} (L2^T input_map u_hat - Z21 q_hat)` (`eq:assemblyF2`).
    pub fn states(
        &self,
        omega_rad_s: f64,
        u_g: &DVector<Complex64>,
        u_hat: &DVector<Complex64>,
    ) -> Result<DVector<Complex64>> {
        let loc = self.localization()?;
        assert_eq!(u_g.len(), self.ncon(), "u_G length");
        if u_hat.len() != self.ninput() {
            return Err(AttachmentError::InputCount {
                attachment: self.name.clone(),
                expected: self.ninput(),
                found: u_hat.len(),
            });
        }
        let p = to_complex(&loc.pinv_b2);
        let mut x = &p * u_g;
        if !loc.l2.is_empty() {
            let l2 = to_complex(&loc.l2);
            let z = self.impedance(omega_rad_s);
            let z22 = l2.transpose() * &z * &l2;
            let z22_inv =
                Condenser::with_localization(self, &loc).checked_inverse(omega_rad_s, z22)?;
            let rhs = l2.transpose() * (to_complex(&self.input_map) * u_hat - &z * &p * u_g);
            let xr = z22_inv * rhs;
            x += l2 * xr;
        }
        Ok(x)
    }
}

impl Localization {
    /// `Z_G`, `T_G` at `Omega` for `att` (which this localization belongs to).
    /// For many frequencies build a [`Condenser`] once instead.
    pub fn condense(
        &self,
        att: &LinearAttachment,
        omega_rad_s: f64,
    ) -> Result<InterfaceCondensation> {
        Condenser::with_localization(att, self).condense(omega_rad_s)
    }
}

/// The blocks of one attachment at one frequency in interface (`G`, through
/// `P = pinv(B2)`) and internal (`2`, through `L2`) coordinates
/// ([`Condenser::averaged_blocks`]). With `u_G` the interface displacements,
/// `x_r` the internal states and `u` the inputs, the attachment's equations
/// in the frequency domain read
/// `Z_2G u_G + Z_22 x_r = B_u2 u` and the force on the structure
/// `F_G = -(Z_GG u_G + Z_G2 x_r) + B_uG u`.
#[derive(Debug, Clone)]
pub struct AveragedBlocks {
    /// `P^T Z P` (`ncon x ncon`).
    pub z_gg: DMatrix<Complex64>,
    /// `P^T Z L2` (`ncon x nr`).
    pub z_g2: DMatrix<Complex64>,
    /// `L2^T Z P` (`nr x ncon`).
    pub z_2g: DMatrix<Complex64>,
    /// `L2^T Z L2` (`nr x nr`).
    pub z_22: DMatrix<Complex64>,
    /// `dZ22/d(i Omega)` (`nr x nr`).
    pub b_22: DMatrix<Complex64>,
    /// `P^T input_map` (`ncon x ninput`).
    pub bu_g: DMatrix<Complex64>,
    /// `L2^T input_map` (`nr x ninput`).
    pub bu_2: DMatrix<Complex64>,
}

/// The condensation of one attachment prepared for many frequencies: the
/// coefficient matrices projected once onto the interface (`P`) and internal
/// (`L2`) directions, `A_k^GG = P^T A_k P`, `A_k^G2 = P^T A_k L2`,
/// `A_k^2G = L2^T A_k P`, `A_k^22 = L2^T A_k L2`, and the input map
/// `P^T B_u`, `L2^T B_u`. Per frequency only these small matrices are summed
/// with `(i Omega)^k` and `Z22` (`(ndim - ncon)`-sized) is factorised.
#[derive(Debug, Clone)]
pub struct Condenser {
    name: String,
    a_gg: Vec<DMatrix<f64>>,
    a_g2: Vec<DMatrix<f64>>,
    a_2g: Vec<DMatrix<f64>>,
    a_22: Vec<DMatrix<f64>>,
    abs_22: Vec<DMatrix<f64>>,
    bu_g: DMatrix<Complex64>,
    bu_2: DMatrix<Complex64>,
}

fn poly(mats: &[DMatrix<f64>], omega_rad_s: f64) -> DMatrix<Complex64> {
    let (r, c) = mats[0].shape();
    let mut z = DMatrix::<Complex64>::zeros(r, c);
    let mut factor = Complex64::new(1.0, 0.0);
    let i_omega = Complex64::new(0.0, omega_rad_s);
    for a in mats {
        z.zip_apply(a, |zij, aij| *zij += factor * aij);
        factor *= i_omega;
    }
    z
}

/// `d/dOmega` of [`poly`]: `sum_k k i (i Omega)^(k-1) A_k`.
fn poly_derivative(mats: &[DMatrix<f64>], omega_rad_s: f64) -> DMatrix<Complex64> {
    let (r, c) = mats[0].shape();
    let mut z = DMatrix::<Complex64>::zeros(r, c);
    let i = Complex64::new(0.0, 1.0);
    let mut power = Complex64::new(1.0, 0.0); // (i Omega)^(k-1)
    for (k, a) in mats.iter().enumerate().skip(1) {
        let factor = i * power * k as f64;
        z.zip_apply(a, |zij, aij| *zij += factor * aij);
        power *= Complex64::new(0.0, omega_rad_s);
    }
    z
}

fn one_norm(m: &DMatrix<Complex64>) -> f64 {
    m.column_iter()
        .map(|c| c.iter().map(|v| v.norm()).sum::<f64>())
        .fold(0.0, f64::max)
}

impl Condenser {
    /// Localizes (SVD of `B2`) and projects the coefficients of `att`.
    pub fn new(att: &LinearAttachment) -> Result<Self> {
        Ok(Self::with_localization(att, &att.localization()?))
    }

    fn with_localization(att: &LinearAttachment, loc: &Localization) -> Self {
        let p = &loc.pinv_b2;
        let l2 = &loc.l2;
        let proj = |left: &DMatrix<f64>, right: &DMatrix<f64>| -> Vec<DMatrix<f64>> {
            att.coefficients
                .iter()
                .map(|a| left.transpose() * a * right)
                .collect()
        };
        let a_22 = proj(l2, l2);
        Condenser {
            name: att.name.clone(),
            a_gg: proj(p, p),
            a_g2: proj(p, l2),
            a_2g: proj(l2, p),
            abs_22: a_22.iter().map(|a| a.abs()).collect(),
            a_22,
            bu_g: to_complex(&(p.transpose() * &att.input_map)),
            bu_2: to_complex(&(l2.transpose() * &att.input_map)),
        }
    }

    /// `Z_G`, `T_G` at `Omega` (module docs). Errors with
    /// [`AttachmentError::SingularZ22`] if `Z22` is numerically singular.
    pub fn condense(&self, omega_rad_s: f64) -> Result<InterfaceCondensation> {
        let mut z_g = poly(&self.a_gg, omega_rad_s);
        let mut t_g = self.bu_g.clone();
        let nr = self.a_22[0].nrows();
        if nr > 0 {
            let z22 = poly(&self.a_22, omega_rad_s);
            let z22_inv = self.checked_inverse(omega_rad_s, z22)?;
            let z_g2 = poly(&self.a_g2, omega_rad_s);
            let z_2g = poly(&self.a_2g, omega_rad_s);
            let k = &z_g2 * z22_inv; // P^T Z L2 Z22^{-1}
            z_g -= &k * z_2g;
            t_g -= &k * &self.bu_2;
        }
        Ok(InterfaceCondensation {
            omega_rad_s,
            z_g,
            t_g,
        })
    }

    /// [`Self::condense`] and the derivatives `dZ_G/dOmega`, `dT_G/dOmega`
    /// (returned as a second [`InterfaceCondensation`]), exact: with
    /// `K = Z_G2 Z22^{-1}`, `dK = (Z_G2' - K Z22') Z22^{-1}`,
    /// `Z_G' = Z_GG' - dK Z_2G - K Z_2G'` and `T_G' = -dK B_2` (one inverse
    /// for both, about half the cost of central differences).
    pub fn condense_with_derivative(
        &self,
        omega_rad_s: f64,
    ) -> Result<(InterfaceCondensation, InterfaceCondensation)> {
        let mut z_g = poly(&self.a_gg, omega_rad_s);
        let mut dz_g = poly_derivative(&self.a_gg, omega_rad_s);
        let mut t_g = self.bu_g.clone();
        let mut dt_g = DMatrix::<Complex64>::zeros(t_g.nrows(), t_g.ncols());
        if self.a_22[0].nrows() > 0 {
            let z22_inv = self.checked_inverse(omega_rad_s, poly(&self.a_22, omega_rad_s))?;
            let z_g2 = poly(&self.a_g2, omega_rad_s);
            let z_2g = poly(&self.a_2g, omega_rad_s);
            let k = &z_g2 * &z22_inv;
            let dk = (poly_derivative(&self.a_g2, omega_rad_s)
                - &k * poly_derivative(&self.a_22, omega_rad_s))
                * &z22_inv;
            z_g -= &k * &z_2g;
            dz_g -= &dk * &z_2g + &k * poly_derivative(&self.a_2g, omega_rad_s);
            t_g -= &k * &self.bu_2;
            dt_g -= &dk * &self.bu_2;
        }
        let at = |z_g, t_g| InterfaceCondensation {
            omega_rad_s,
            z_g,
            t_g,
        };
        Ok((at(z_g, t_g), at(dz_g, dt_g)))
    }

    /// Number of internal (primal) states `ndim - ncon` of `x_r` (`eq:primal`).
    pub fn internal_states(&self) -> usize {
        self.a_22[0].nrows()
    }

    /// The blocks of the attachment in interface (`P`) and internal (`L2`)
    /// coordinates at `Omega`, for carrying `x_r` as a slowly varying complex
    /// amplitude in the slow flow (`crate::reduced` "attachment states"):
    /// `Z_mn` as in `eq:assemblyF1`-`eq:assemblyF2` and
    /// `B22 = dZ22/d(i Omega) = sum_k k (i Omega)^(k-1) L2^T A_k L2`, the
    /// coefficient of `x_r'` in the first-order averaged `eq:component2`.
    pub fn averaged_blocks(&self, omega_rad_s: f64) -> AveragedBlocks {
        // dZ/d(i Omega) = -i dZ/dOmega
        let minus_i = Complex64::new(0.0, -1.0);
        AveragedBlocks {
            z_gg: poly(&self.a_gg, omega_rad_s),
            z_g2: poly(&self.a_g2, omega_rad_s),
            z_2g: poly(&self.a_2g, omega_rad_s),
            z_22: poly(&self.a_22, omega_rad_s),
            b_22: poly_derivative(&self.a_22, omega_rad_s) * minus_i,
            bu_g: self.bu_g.clone(),
            bu_2: self.bu_2.clone(),
        }
    }

    /// The attachment's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The internal block's coefficients `A_k^22 = L2^T A_k L2`, `k = 0, 1, ...`
    /// (`Z22 = sum_k (i Omega)^k A_k^22`).
    pub fn internal_coefficients(&self) -> &[DMatrix<f64>] {
        &self.a_22
    }

    /// Inverts `Z22` after checking its condition; see
    /// [`AttachmentError::SingularZ22`].
    ///
    /// Measure: with the term-wise magnitude matrix
    /// `S = sum_k Omega^k |L2^T A_k L2|` (element-wise absolute values) and the
    /// diagonal row/column equilibration `D_r`, `D_c` of `S`, the condition
    /// number is `||D_r S D_c||_1 ||(D_r Z22 D_c)^{-1}||_1`. It does not depend on
    /// the units of the states (electrical vs. mechanical), and it detects a
    /// resonance by cancellation even for a 1 x 1 `Z22` (`k - Omega^2 m -> 0`
    /// gives `(k + Omega^2 m)/|k - Omega^2 m|`).
    fn checked_inverse(
        &self,
        omega_rad_s: f64,
        z22: DMatrix<Complex64>,
    ) -> Result<DMatrix<Complex64>> {
        let nr = z22.nrows();
        let mut s = DMatrix::<f64>::zeros(nr, nr);
        let mut w = 1.0;
        for a in &self.abs_22 {
            s.zip_apply(a, |sij, aij| *sij += w * aij);
            w *= omega_rad_s.abs();
        }
        let dr: Vec<f64> = (0..nr)
            .map(|i| {
                let m = s.row(i).iter().cloned().fold(0.0, f64::max);
                if m > 0.0 {
                    1.0 / m
                } else {
                    1.0
                }
            })
            .collect();
        let dc: Vec<f64> = (0..nr)
            .map(|j| {
                let m = (0..nr).map(|i| dr[i] * s[(i, j)]).fold(0.0, f64::max);
                if m > 0.0 {
                    1.0 / m
                } else {
                    1.0
                }
            })
            .collect();
        let s_norm = (0..nr)
            .map(|j| (0..nr).map(|i| dr[i] * s[(i, j)] * dc[j]).sum::<f64>())
            .fold(0.0, f64::max);
        let inv = z22.try_inverse();
        // (D_r Z D_c)^{-1} = D_c^{-1} Z^{-1} D_r^{-1}.
        let condition_number = match &inv {
            Some(zi) => {
                let scaled = DMatrix::from_fn(nr, nr, |i, j| zi[(i, j)] / (dc[i] * dr[j]));
                s_norm * one_norm(&scaled)
            }
            None => f64::INFINITY,
        };
        match inv {
            Some(zi) if condition_number <= Z22_CONDITION_LIMIT => Ok(zi),
            _ => Err(AttachmentError::SingularZ22 {
                attachment: self.name.clone(),
                omega_rad_s,
                condition_number,
                limit: Z22_CONDITION_LIMIT,
            }),
        }
    }
}

/// Several attachments on one structure: the summed condensation
/// `(sum_a E_a Z_G,a E_a^T, sum_a E_a T_G,a u_hat,a)` at `Omega`, i.e. the
/// added dynamic stiffness (`ndof x ndof`) and the imposed force (`ndof`) of
/// `eq:fc1` for all attachments together. `inputs[a]` are the complex input
/// amplitudes of attachment `a` (length `ninput`).
pub fn condensed_sum(
    model: &StructuralModel,
    attachments: &[LinearAttachment],
    inputs: &[DVector<Complex64>],
    omega_rad_s: f64,
) -> Result<(DMatrix<Complex64>, DVector<Complex64>)> {
    assert_eq!(
        attachments.len(),
        inputs.len(),
        "one input vector per attachment"
    );
    let ndof = model.mass.nrows();
    let mut zq = DMatrix::<Complex64>::zeros(ndof, ndof);
    let mut f = DVector::<Complex64>::zeros(ndof);
    for (att, u) in attachments.iter().zip(inputs) {
        att.check_input_count(u)?;
        let e = to_complex(&att.interface_vectors(model)?);
        let cond = att.interface_condensation(omega_rad_s)?;
        zq += &e * &cond.z_g * e.transpose();
        f += &e * (&cond.t_g * u);
    }
    Ok((zq, f))
}
