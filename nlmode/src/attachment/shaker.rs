//! The electro-dynamic shaker of the paper's Section 4 (B&K V4808 in the
//! benchmark), as a [`LinearAttachment`] and as a state-space model.
//!
//! Free attachment (paper Section 4), states `x = [I, q_a, q_s]`:
//!
//! ```text
//! L I' + R I + G q_a'                        = u(t)
//! m_a q_a'' + d_a q_a' + (k_a + k_s) q_a - k_s q_s = G I
//! k_s q_s - k_s q_a                          = 0      (+ interface force)
//! ```
//!
//! coupled by `q_s = e^T q` (`B1 = -e^T`, `B2 = [0 0 1]`). The closed forms
//! (paper, below the impedance matrix) are the armature impedance
//! `z_a = -W^2 m_a + i W d_a + k_a + i W G^2/(R + i W L)`, the interface
//! impedance `k_s z_a/(z_a + k_s)` and the blocked force
//! `k_s/(z_a + k_s) G u_hat/(R + i W L)`. The rigid-stinger variant attaches
//! the armature directly: `x = [I, q_a]`, `B2 = [0 1]`, interface impedance
//! `z_a`, blocked force `G u_hat/(R + i W L)`.
use super::{AttachmentError, LinearAttachment, Result};
use crate::benchmark;
use crate::excitation::LinearSweep;
use crate::lti::{FohStep, LtiError, StepCache};
use nalgebra::{DMatrix, Matrix3, Matrix3x2, Vector2, Vector3};
use num_complex::Complex64;

/// Armature damping, given either as the total damping ratio `D_a` with
/// `2 D_a omega_a m_a = d_a + G^2/R` (electro-mechanical damping included, as
/// in the paper) or as the mechanical viscous coefficient `d_a` \[N s/m\].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum ArmatureDamping {
    /// Total damping ratio `D_a` \[-\].
    Ratio(f64),
    /// Mechanical viscous damping `d_a` \[N s/m\].
    Viscous(f64),
}

/// The stinger (push rod) between armature and structure.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Stinger {
    /// Axial spring of stiffness `k_s` \[N/m\].
    Elastic { stiffness_n_per_m: f64 },
    /// Armature attached directly to the structure.
    Rigid,
}

/// Physical parameters of the electro-dynamic shaker (paper Section 4).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShakerParams {
    /// Coil inductance `L` \[H\].
    pub inductance_h: f64,
    /// Coil resistance `R` \[Ohm\].
    pub resistance_ohm: f64,
    /// Force constant `G` \[N/A\] (= back-EMF constant \[V s/m\]).
    pub force_constant_n_per_a: f64,
    /// Armature mass `m_a` \[kg\].
    pub armature_mass_kg: f64,
    /// Armature suspension stiffness `k_a` \[N/m\].
    pub armature_stiffness_n_per_m: f64,
    /// Armature damping.
    pub armature_damping: ArmatureDamping,
    /// Stinger.
    pub stinger: Stinger,
}

/// A linear time-invariant state-space system `s' = A s + B u`, `y = C s + D u`.
#[derive(Debug, Clone)]
pub struct LtiSystem {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub d: DMatrix<f64>,
    pub state_names: Vec<String>,
    pub input_names: Vec<String>,
    pub output_names: Vec<String>,
}

impl LtiSystem {
    /// Frequency response `H(Omega) = C (i Omega I - A)^{-1} B + D`
    /// (`noutput x ninput`); `None` if `i Omega` is an eigenvalue of `A`.
    pub fn transfer(&self, omega_rad_s: f64) -> Option<DMatrix<Complex64>> {
        let n = self.a.nrows();
        let iw = Complex64::new(0.0, omega_rad_s);
        let m = DMatrix::<Complex64>::from_fn(n, n, |i, j| {
            let d = if i == j { iw } else { Complex64::new(0.0, 0.0) };
            d - self.a[(i, j)]
        });
        let b = self.b.map(|v| Complex64::new(v, 0.0));
        let x = m.lu().solve(&b)?;
        Some(self.c.map(|v| Complex64::new(v, 0.0)) * x + self.d.map(|v| Complex64::new(v, 0.0)))
    }
}

fn positive(name: &'static str, value: f64) -> Result<()> {
    if !value.is_finite() {
        return Err(AttachmentError::NotFinite {
            attachment: "shaker".into(),
            name: name.into(),
            value,
        });
    }
    if value <= 0.0 {
        return Err(AttachmentError::NonPositive { name, value });
    }
    Ok(())
}

impl ShakerParams {
    /// The paper's B&K V4808 with the elastic stinger `k_s = 2.6e7 N/m`
    /// (values in [`crate::benchmark`]).
    pub fn paper() -> Self {
        ShakerParams {
            inductance_h: benchmark::SHAKER_L_H,
            resistance_ohm: benchmark::SHAKER_R_OHM,
            force_constant_n_per_a: benchmark::SHAKER_G_N_PER_A,
            armature_mass_kg: benchmark::SHAKER_MA_KG,
            armature_stiffness_n_per_m: benchmark::SHAKER_KA_N_PER_M,
            armature_damping: ArmatureDamping::Ratio(benchmark::SHAKER_DA),
            stinger: Stinger::Elastic {
                stiffness_n_per_m: benchmark::STINGER_KS_N_PER_M,
            },
        }
    }

    /// The same shaker with the armature attached directly (rigid stinger).
    pub fn with_rigid_stinger(mut self) -> Self {
        self.stinger = Stinger::Rigid;
        self
    }

    /// Rejects non-positive or non-finite `L`, `R`, `G`, `m_a`, `k_a`, `k_s`,
    /// a negative or non-finite damping, and a ratio `D_a` that would imply a
    /// negative mechanical damping `d_a`.
    pub fn validate(&self) -> Result<()> {
        positive("inductance_h", self.inductance_h)?;
        positive("resistance_ohm", self.resistance_ohm)?;
        positive("force_constant_n_per_a", self.force_constant_n_per_a)?;
        positive("armature_mass_kg", self.armature_mass_kg)?;
        positive(
            "armature_stiffness_n_per_m",
            self.armature_stiffness_n_per_m,
        )?;
        if let Stinger::Elastic { stiffness_n_per_m } = self.stinger {
            positive("stinger_stiffness_n_per_m", stiffness_n_per_m)?;
        }
        let (name, value) = match self.armature_damping {
            ArmatureDamping::Ratio(v) => ("armature_damping_ratio", v),
            ArmatureDamping::Viscous(v) => ("armature_damping_n_s_per_m", v),
        };
        if !value.is_finite() {
            return Err(AttachmentError::NotFinite {
                attachment: "shaker".into(),
                name: name.into(),
                value,
            });
        }
        if value < 0.0 {
            return Err(AttachmentError::Negative { name, value });
        }
        if let ArmatureDamping::Ratio(d_ratio) = self.armature_damping {
            let d_a = self.d_a();
            if d_a < 0.0 {
                let electrical_ratio = self.force_constant_n_per_a.powi(2)
                    / self.resistance_ohm
                    / (2.0 * self.omega_a() * self.armature_mass_kg);
                return Err(AttachmentError::NegativeMechanicalDamping {
                    d_a_ratio: d_ratio,
                    electrical_ratio,
                    d_a,
                });
            }
        }
        Ok(())
    }

    /// Mechanical armature damping `d_a` \[N s/m\]; from a ratio `D_a`:
    /// `d_a = 2 D_a omega_a m_a - G^2/R`.
    pub fn d_a(&self) -> f64 {
        match self.armature_damping {
            ArmatureDamping::Viscous(d) => d,
            ArmatureDamping::Ratio(r) => {
                2.0 * r * self.omega_a() * self.armature_mass_kg
                    - self.force_constant_n_per_a.powi(2) / self.resistance_ohm
            }
        }
    }

    /// Total armature damping ratio `D_a = (d_a + G^2/R) / (2 omega_a m_a)`.
    pub fn damping_ratio(&self) -> f64 {
        (self.d_a() + self.force_constant_n_per_a.powi(2) / self.resistance_ohm)
            / (2.0 * self.omega_a() * self.armature_mass_kg)
    }

    /// Armature natural frequency `omega_a = sqrt(k_a/m_a)` \[rad/s\].
    pub fn omega_a(&self) -> f64 {
        (self.armature_stiffness_n_per_m / self.armature_mass_kg).sqrt()
    }

    /// Electrical cutoff frequency `omega_c = R/L` \[rad/s\].
    pub fn omega_c(&self) -> f64 {
        self.resistance_ohm / self.inductance_h
    }

    /// Armature impedance `z_a = -W^2 m_a + i W d_a + k_a + i W G^2/(R + i W L)` \[N/m\].
    pub fn armature_impedance(&self, omega_rad_s: f64) -> Complex64 {
        let w = omega_rad_s;
        let i = Complex64::i();
        let g = self.force_constant_n_per_a;
        let coil = Complex64::new(self.resistance_ohm, w * self.inductance_h);
        -w * w * self.armature_mass_kg
            + i * w * self.d_a()
            + self.armature_stiffness_n_per_m
            + i * w * g * g / coil
    }

    /// Closed-form interface impedance (paper Section 4): `k_s z_a/(z_a + k_s)`
    /// (elastic stinger) or `z_a` (rigid) \[N/m\].
    pub fn closed_form_interface_impedance(&self, omega_rad_s: f64) -> Complex64 {
        let za = self.armature_impedance(omega_rad_s);
        match self.stinger {
            Stinger::Elastic {
                stiffness_n_per_m: ks,
            } => ks * za / (za + ks),
            Stinger::Rigid => za,
        }
    }

    /// Closed-form blocked force (paper Section 4, the imposed force on the
    /// structure at rest) \[N\]: `k_s/(z_a + k_s) G u_hat/(R + i W L)` (elastic)
    /// or `G u_hat/(R + i W L)` (rigid).
    pub fn closed_form_blocked_force(&self, omega_rad_s: f64, u_hat: Complex64) -> Complex64 {
        let coil = Complex64::new(self.resistance_ohm, omega_rad_s * self.inductance_h);
        let f = self.force_constant_n_per_a * u_hat / coil;
        match self.stinger {
            Stinger::Elastic {
                stiffness_n_per_m: ks,
            } => ks / (self.armature_impedance(omega_rad_s) + ks) * f,
            Stinger::Rigid => f,
        }
    }

    /// State-space form of the shaker with elastic stinger, as used by the
    /// shaker FMU.
    ///
    /// States `s = [I, q_a, v_a]` (A, m, m/s), inputs `[u, x]` (voltage \[V\],
    /// structure displacement at the drive point \[m\]), outputs `[F, I, q_a]`:
    ///
    /// ```text
    /// I'   = (u - R I - G v_a) / L
    /// q_a' = v_a
    /// v_a' = (G I - d_a v_a - (k_a + k_s) q_a + k_s x) / m_a
    /// F    = k_s (q_a - x)
    /// ```
    ///
    /// The structure's velocity is not needed (the stinger is a pure spring).
    /// `F` is the stinger force on the structure, positive along positive
    /// structure displacement, so the structure's equation reads
    /// `M q'' + ... = e F`; `F` depends directly on the input `x` (`D[0][1] = -k_s`).
    /// In the frequency domain `F = T_G u - Z_G x` with the `Z_G`, `T_G` of
    /// [`LinearAttachment::shaker`]. A rigid stinger has no such form
    /// ([`AttachmentError::RigidStingerStateSpace`]).
    pub fn state_space(&self) -> Result<LtiSystem> {
        self.validate()?;
        let ks = match self.stinger {
            Stinger::Elastic { stiffness_n_per_m } => stiffness_n_per_m,
            Stinger::Rigid => return Err(AttachmentError::RigidStingerStateSpace),
        };
        let (l, r, g) = (
            self.inductance_h,
            self.resistance_ohm,
            self.force_constant_n_per_a,
        );
        let (m, k, d) = (
            self.armature_mass_kg,
            self.armature_stiffness_n_per_m,
            self.d_a(),
        );
        #[rustfmt::skip]
        let a = DMatrix::from_row_slice(3, 3, &[
            -r / l, 0.0,           -g / l,
            0.0,    0.0,           1.0,
            g / m,  -(k + ks) / m, -d / m,
        ]);
        #[rustfmt::skip]
        let b = DMatrix::from_row_slice(3, 2, &[
            1.0 / l, 0.0,
            0.0,     0.0,
            0.0,     ks / m,
        ]);
        #[rustfmt::skip]
        let c = DMatrix::from_row_slice(3, 3, &[
            0.0, ks,  0.0,
            1.0, 0.0, 0.0,
            0.0, 1.0, 0.0,
        ]);
        #[rustfmt::skip]
        let dm = DMatrix::from_row_slice(3, 2, &[
            0.0, -ks,
            0.0, 0.0,
            0.0, 0.0,
        ]);
        Ok(LtiSystem {
            a,
            b,
            c,
            d: dm,
            state_names: vec!["I".into(), "q_a".into(), "v_a".into()],
            input_names: vec!["u".into(), "x".into()],
            output_names: vec!["F".into(), "I".into(), "q_a".into()],
        })
    }
}

impl LinearAttachment {
    /// The shaker of the paper's Section 4 attached at the structure point
    /// `point_name`.
    ///
    /// Elastic stinger: `x = [I, q_a, q_s]`,
    /// `A_0 = [[R, 0, 0], [-G, k_a + k_s, -k_s], [0, -k_s, k_s]]`,
    /// `A_1 = [[L, G, 0], [0, d_a, 0], [0, 0, 0]]`, `A_2 = diag(0, m_a, 0)`,
    /// `B2 = [0 0 1]`, `input_map = [1 0 0]^T` (voltage).
    /// Rigid stinger: `x = [I, q_a]`, `A_0 = [[R, 0], [-G, k_a]]`,
    /// `A_1 = [[L, G], [0, d_a]]`, `A_2 = diag(0, m_a)`, `B2 = [0 1]`,
    /// `input_map = [1 0]^T`.
    pub fn shaker(name: &str, params: &ShakerParams, point_name: &str) -> Result<LinearAttachment> {
        params.validate()?;
        let (l, r, g) = (
            params.inductance_h,
            params.resistance_ohm,
            params.force_constant_n_per_a,
        );
        let (m, k, d) = (
            params.armature_mass_kg,
            params.armature_stiffness_n_per_m,
            params.d_a(),
        );
        let att = match params.stinger {
            Stinger::Elastic {
                stiffness_n_per_m: ks,
            } => {
                #[rustfmt::skip]
                let a0 = DMatrix::from_row_slice(3, 3, &[
                    r,   0.0,     0.0,
                    -g,  k + ks,  -ks,
                    0.0, -ks,     ks,
                ]);
                #[rustfmt::skip]
                let a1 = DMatrix::from_row_slice(3, 3, &[
                    l,   g,   0.0,
                    0.0, d,   0.0,
                    0.0, 0.0, 0.0,
                ]);
                let mut a2 = DMatrix::zeros(3, 3);
                a2[(1, 1)] = m;
                LinearAttachment {
                    name: name.to_string(),
                    coefficients: vec![a0, a1, a2],
                    b2: DMatrix::from_row_slice(1, 3, &[0.0, 0.0, 1.0]),
                    interface_points: vec![point_name.to_string()],
                    input_map: DMatrix::from_column_slice(3, 1, &[1.0, 0.0, 0.0]),
                    state_names: vec!["I".into(), "q_a".into(), "q_s".into()],
                    input_names: vec!["voltage".into()],
                }
            }
            Stinger::Rigid => {
                let a0 = DMatrix::from_row_slice(2, 2, &[r, 0.0, -g, k]);
                let a1 = DMatrix::from_row_slice(2, 2, &[l, g, 0.0, d]);
                let a2 = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.0, m]);
                LinearAttachment {
                    name: name.to_string(),
                    coefficients: vec![a0, a1, a2],
                    b2: DMatrix::from_row_slice(1, 2, &[0.0, 1.0]),
                    interface_points: vec![point_name.to_string()],
                    input_map: DMatrix::from_column_slice(2, 1, &[1.0, 0.0]),
                    state_names: vec!["I".into(), "q_a".into()],
                    input_names: vec!["voltage".into()],
                }
            }
        };
        att.validate()?;
        Ok(att)
    }
}

/// Largest excitation-phase increment per sub-step [rad] when a sine-sweep
/// voltage drives [`ShakerStepper`]: the voltage is interpolated linearly
/// inside a sub-step, which scales its fundamental by `1 - (W h)^2/12`
/// (2e-4 at 0.05 rad) and adds no phase lag.
pub const MAX_PHASE_PER_SUBSTEP: f64 = 0.05;

/// Most sub-steps one call of [`sweep_substeps`] may ask for (a communication
/// step of 1 s at 5e4 rad/s needs 1e6): bounds the work of one step.
pub const MAX_SWEEP_SUBSTEPS: usize = 1_000_000;

/// Number of equal sub-steps of `[tau, tau + h]` (sweep time [s]) that keep
/// the phase increment of `sweep` below [`MAX_PHASE_PER_SUBSTEP`]
/// (`1` for a zero amplitude); `Err(needed)` when that exceeds
/// [`MAX_SWEEP_SUBSTEPS`] or is not finite (the step is too long for the
/// sweep's frequency).
pub fn sweep_substeps(
    sweep: &LinearSweep,
    tau_s: f64,
    h_s: f64,
) -> std::result::Result<usize, f64> {
    if sweep.amplitude == 0.0 {
        return Ok(1);
    }
    let w = sweep.omega_rad_s(tau_s).max(sweep.omega_rad_s(tau_s + h_s));
    let n = (w * h_s / MAX_PHASE_PER_SUBSTEP).ceil().max(1.0);
    if n.is_finite() && n <= MAX_SWEEP_SUBSTEPS as f64 {
        Ok(n as usize)
    } else {
        Err(n)
    }
}

/// One exact discretization of [`ShakerStepper`] in fixed-size matrices.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FixedFoh {
    phi: Matrix3<f64>,
    p: Matrix3x2<f64>,
    q: Matrix3x2<f64>,
}

/// The shaker with elastic stinger as the LTI system of
/// [`ShakerParams::state_space`], `s' = A s + B [u, x]`, states
/// `s = [I, q_a, v_a]`, integrated exactly for inputs linear in time
/// ([`crate::lti::FohStep`]) and kept in fixed-size matrices with a
/// [`StepCache`] of discretizations (the shaker FMU's step stays well below
/// 1 us; `lti::LtiFoh` holds heap matrices).
#[derive(Debug, Clone, PartialEq)]
pub struct ShakerStepper {
    a: Matrix3<f64>,
    b: Matrix3x2<f64>,
    a_dyn: DMatrix<f64>,
    b_dyn: DMatrix<f64>,
    cache: StepCache<FixedFoh>,
}

impl ShakerStepper {
    /// Validates the parameters and builds the state space (elastic stinger
    /// only, [`AttachmentError::RigidStingerStateSpace`] otherwise).
    pub fn new(params: &ShakerParams) -> Result<Self> {
        let ss = params.state_space()?;
        Ok(Self {
            a: Matrix3::from_fn(|i, j| ss.a[(i, j)]),
            b: Matrix3x2::from_fn(|i, j| ss.b[(i, j)]),
            a_dyn: ss.a,
            b_dyn: ss.b,
            cache: StepCache::default(),
        })
    }

    /// State derivative `s' = A s + B [u, x]` (voltage `u` \[V\], structure
    /// displacement `x` \[m\]).
    pub fn rates(&self, s: &Vector3<f64>, u_v: f64, x_m: f64) -> Vector3<f64> {
        self.a * s + self.b * Vector2::new(u_v, x_m)
    }

    /// Advance `s` from `t` to `t + h` [s] in `substeps` equal sub-steps,
    /// exactly for inputs `[u, x] = inputs(t)` linear in time inside each
    /// sub-step (the last sub-step ends at `t + h` exactly).
    pub fn advance(
        &mut self,
        s: &mut Vector3<f64>,
        t: f64,
        h: f64,
        substeps: usize,
        inputs: impl Fn(f64) -> Vector2<f64>,
    ) -> std::result::Result<(), LtiError> {
        let n = substeps.max(1);
        let hs = h / n as f64;
        let (a, b) = (&self.a_dyn, &self.b_dyn);
        let d = *self.cache.get_or_try_insert(hs, || {
            let f = FohStep::new(a, b, hs)?;
            Ok::<_, LtiError>(FixedFoh {
                phi: Matrix3::from_fn(|i, j| f.phi[(i, j)]),
                p: Matrix3x2::from_fn(|i, j| f.p[(i, j)]),
                q: Matrix3x2::from_fn(|i, j| f.q[(i, j)]),
            })
        })?;
        let mut u0 = inputs(t);
        for k in 1..=n {
            let tk = if k == n { t + h } else { t + k as f64 * hs };
            let u1 = inputs(tk);
            *s = d.phi * *s + d.p * u0 + d.q * u1;
            u0 = u1;
        }
        Ok(())
    }
}
