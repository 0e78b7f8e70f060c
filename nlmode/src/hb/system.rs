//! The assembled model as the harmonic balance sees it: the structure's linear
//! part with every attachment condensed at each harmonic (`eq:fc1` at
//! `n Omega`), its receptance at the nonlinear elements, the imposed force at
//! `n = 1`, and the recovery of the response and interface forces.
use super::HbError;
use crate::attachment::{Condenser, LinearAttachment};
use crate::reference::assembly::{AssembledSystem, FirstOrderSystem};
use crate::structure::{NonlinearLaw, StructuralModel};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::sync::Arc;

/// Largest number of structural DOFs the dense per-harmonic condensation
/// accepts (it inverts an `ndof x ndof` complex matrix per harmonic and
/// Newton iteration: reduce larger models by Craig-Bampton first).
pub const MAX_DOFS: usize = 2000;

fn complex(m: &DMatrix<f64>) -> DMatrix<Complex64> {
    m.map(|v| Complex64::new(v, 0.0))
}

/// One attachment prepared for many frequencies.
#[derive(Debug, Clone)]
struct Attached {
    name: String,
    condenser: Condenser,
    /// `E` (`ndof x ncon`).
    e: DMatrix<Complex64>,
    /// Complex input amplitudes (voltage and phase) at `alpha = 1`.
    u: DVector<Complex64>,
}

/// The structure with its attachments and excitation, prepared for the
/// harmonic balance ([`super`] module docs). Built by [`HbSystem::new`].
#[derive(Debug, Clone)]
pub struct HbSystem {
    mass: DMatrix<Complex64>,
    damping: DMatrix<Complex64>,
    stiffness: DMatrix<Complex64>,
    attached: Vec<Attached>,
    /// Imposed point forces `(name, e, f_hat)` at `alpha = 1` \[N\].
    imposed: Vec<(String, DVector<Complex64>, Complex64)>,
    /// `W` (`ndof x E`): the nonlinear elements' directions.
    w: DMatrix<Complex64>,
    pub(crate) laws: Vec<Arc<dyn NonlinearLaw>>,
    /// Observation vector of the response point.
    response: DVector<Complex64>,
    response_point: String,
    /// The explicit first-order form of the assembly (Hill's method).
    pub(crate) first_order: Result<FirstOrderSystem, String>,
    /// `A`'s eigen-decomposition for the condensed Hill problem (`None`:
    /// the full Hill matrix is used).
    pub(crate) modal: Option<super::hill_band::ModalForm>,
}

/// Per-frequency linear quantities of harmonic `n`: `D_n^{-1}` and its
/// derivative with respect to `Omega`.
#[derive(Debug, Clone)]
pub(crate) struct HarmonicLinear {
    pub dinv: DMatrix<Complex64>,
    pub ddinv: DMatrix<Complex64>,
}

/// The linear part at one `Omega`, all harmonics `0..=H`.
#[derive(Debug, Clone)]
pub(crate) struct Linear {
    pub harmonics: Vec<HarmonicLinear>,
    /// Receptance at the elements `R_n = W^T D_n^{-1} W` and `dR_n/dOmega`.
    pub r: Vec<DMatrix<Complex64>>,
    pub dr: Vec<DMatrix<Complex64>>,
    /// Fundamental load `b_1` at `alpha = 1` and `db_1/dOmega` (`ndof`).
    pub b1: DVector<Complex64>,
    pub db1: DVector<Complex64>,
    /// `a_1 = W^T D_1^{-1} b_1` and its derivative (`E`).
    pub a1: DVector<Complex64>,
    pub da1: DVector<Complex64>,
    /// Per attachment `(Z_G, Z_G', T_G u, (T_G u)')` at `Omega`.
    pub cond: Vec<[DMatrix<Complex64>; 2]>,
    pub tgu: Vec<[DVector<Complex64>; 2]>,
}

impl HbSystem {
    /// Prepares `model` with `attachments` driven by `inputs` (complex input
    /// amplitudes per attachment, e.g. the shaker voltage `u_hat e^{i phase}`
    /// \[V\]) and the imposed point forces `imposed` (`(point, f_hat)` \[N\],
    /// at `n = 1`), observed at `response_point`.
    pub fn new(
        model: &StructuralModel,
        attachments: &[LinearAttachment],
        inputs: &[DVector<Complex64>],
        imposed: &[(String, Complex64)],
        response_point: &str,
    ) -> Result<Self, HbError> {
        let ndof = model.mass.nrows();
        if ndof == 0 || ndof > MAX_DOFS {
            return Err(HbError::ModelSize {
                ndof,
                max: MAX_DOFS,
            });
        }
        if inputs.len() != attachments.len() {
            return Err(HbError::InputCount {
                expected: attachments.len(),
                found: inputs.len(),
            });
        }
        let point = |name: &str| {
            model
                .points
                .iter()
                .find(|p| p.name == name)
                .map(|p| p.direction.map(|v| Complex64::new(v, 0.0)))
                .ok_or_else(|| HbError::UnknownPoint {
                    point: name.to_string(),
                    available: model.points.iter().map(|p| p.name.clone()).collect(),
                })
        };
        let mut attached = Vec::with_capacity(attachments.len());
        for (att, u) in attachments.iter().zip(inputs) {
            att.check_input_count(u)?;
            if let Some(v) = u.iter().find(|v| !(v.re.is_finite() && v.im.is_finite())) {
                return Err(HbError::NonFiniteExcitation {
                    name: att.name.clone(),
                    value: v.norm(),
                });
            }
            attached.push(Attached {
                name: att.name.clone(),
                condenser: Condenser::new(att)?,
                e: complex(&att.interface_vectors(model)?),
                u: u.clone(),
            });
        }
        let mut imp = Vec::with_capacity(imposed.len());
        for (name, f) in imposed {
            if !(f.re.is_finite() && f.im.is_finite()) {
                return Err(HbError::NonFiniteExcitation {
                    name: name.clone(),
                    value: f.norm(),
                });
            }
            imp.push((name.clone(), point(name)?, *f));
        }
        let mut w = DMatrix::zeros(ndof, model.nonlinear.len());
        for (e, el) in model.nonlinear.iter().enumerate() {
            w.set_column(e, &el.direction.map(|v| Complex64::new(v, 0.0)));
        }
        let first_order = AssembledSystem::new(model, attachments, response_point)
            .map(|a| a.first_order)
            .map_err(|e| e.to_string());
        let modal = first_order
            .as_ref()
            .ok()
            .and_then(super::hill_band::ModalForm::new);
        Ok(Self {
            mass: complex(&model.mass),
            damping: complex(&model.damping),
            stiffness: complex(&model.stiffness),
            attached,
            imposed: imp,
            w,
            laws: model.nonlinear.iter().map(|e| e.law.clone()).collect(),
            response: point(response_point)?,
            response_point: response_point.to_string(),
            first_order,
            modal,
        })
    }

    /// Number of nonlinear elements `E`.
    pub fn n_elements(&self) -> usize {
        self.laws.len()
    }

    /// Name of the response point.
    pub fn response_point(&self) -> &str {
        &self.response_point
    }

    /// Names of the force columns: every attachment (its first interface
    /// constraint), then every imposed force.
    pub fn force_names(&self) -> Vec<String> {
        self.attached
            .iter()
            .map(|a| a.name.clone())
            .chain(self.imposed.iter().map(|i| i.0.clone()))
            .collect()
    }

    /// The linear part at `omega` for harmonics `0..=h`.
    pub(crate) fn linear(&self, omega: f64, h: usize) -> Result<Linear, HbError> {
        let mut cond = Vec::with_capacity(self.attached.len());
        let mut tgu = Vec::with_capacity(self.attached.len());
        let mut harmonics = Vec::with_capacity(h + 1);
        for n in 0..=h {
            let nf = n as f64;
            let w = nf * omega;
            let mut d = &self.stiffness - &self.mass * Complex64::new(w * w, 0.0)
                + &self.damping * Complex64::new(0.0, w);
            let mut dd = &self.mass * Complex64::new(-2.0 * nf * w, 0.0)
                + &self.damping * Complex64::new(0.0, nf);
            for a in &self.attached {
                let (c, dc) = a.condenser.condense_with_derivative(w)?;
                let et = a.e.transpose();
                d += &a.e * &c.z_g * &et;
                dd += &a.e * (&dc.z_g * Complex64::new(nf, 0.0)) * &et;
                if n == 1 {
                    tgu.push([&c.t_g * &a.u, &dc.t_g * &a.u]);
                    cond.push([c.z_g, dc.z_g]);
                }
            }
            let dinv = d
                .try_inverse()
                .filter(|m| m.iter().all(|v| v.re.is_finite() && v.im.is_finite()))
                .ok_or(HbError::SingularDynamicStiffness {
                    omega_rad_s: omega,
                    harmonic: n,
                })?;
            let ddinv = -(&dinv * dd * &dinv);
            harmonics.push(HarmonicLinear { dinv, ddinv });
        }
        if h == 0 {
            // the fundamental's condensation is needed for the outputs
            for a in &self.attached {
                let (c, dc) = a.condenser.condense_with_derivative(omega)?;
                tgu.push([&c.t_g * &a.u, &dc.t_g * &a.u]);
                cond.push([c.z_g, dc.z_g]);
            }
        }
        let ndof = self.mass.nrows();
        let mut b1 = DVector::zeros(ndof);
        let mut db1 = DVector::zeros(ndof);
        for (a, t) in self.attached.iter().zip(&tgu) {
            b1 += &a.e * &t[0];
            db1 += &a.e * &t[1];
        }
        for (_, e, f) in &self.imposed {
            b1 += e * *f;
        }
        let wt = self.w.transpose();
        let r = harmonics
            .iter()
            .map(|hl| &wt * &hl.dinv * &self.w)
            .collect();
        let dr = harmonics
            .iter()
            .map(|hl| &wt * &hl.ddinv * &self.w)
            .collect();
        let (a1, da1) = match harmonics.get(1) {
            Some(h1) => (
                &wt * (&h1.dinv * &b1),
                &wt * (&h1.ddinv * &b1 + &h1.dinv * &db1),
            ),
            None => (
                DVector::zeros(self.w.ncols()),
                DVector::zeros(self.w.ncols()),
            ),
        };
        Ok(Linear {
            harmonics,
            r,
            dr,
            b1,
            db1,
            a1,
            da1,
            cond,
            tgu,
        })
    }

    /// Structure harmonics `q_n = D_n^{-1} (alpha b_n - W f_n)` for `n = 0..=H`
    /// from the complex element force harmonics `f[n]` (`E` each).
    pub(crate) fn structure_harmonics(
        &self,
        lin: &Linear,
        alpha: f64,
        f: &[DVector<Complex64>],
    ) -> Vec<DVector<Complex64>> {
        lin.harmonics
            .iter()
            .enumerate()
            .map(|(n, hl)| {
                let mut rhs = -(&self.w * &f[n]);
                if n == 1 {
                    rhs += &lin.b1 * Complex64::new(alpha, 0.0);
                }
                &hl.dinv * rhs
            })
            .collect()
    }

    /// Response-point harmonics `e^T q_n`.
    pub(crate) fn response_harmonics(&self, q: &[DVector<Complex64>]) -> Vec<Complex64> {
        q.iter().map(|qn| self.response.dot(qn)).collect()
    }

    /// Fundamental interface forces on the structure, `F_G = -Z_G E^T q_1 +
    /// alpha T_G u` (first constraint of each attachment), then the imposed
    /// forces `alpha f_hat` \[N\].
    pub(crate) fn forces(
        &self,
        lin: &Linear,
        alpha: f64,
        q1: &DVector<Complex64>,
    ) -> Vec<Complex64> {
        let al = Complex64::new(alpha, 0.0);
        let mut out = Vec::with_capacity(self.attached.len() + self.imposed.len());
        for ((a, c), t) in self.attached.iter().zip(&lin.cond).zip(&lin.tgu) {
            let f = &t[0] * al - &c[0] * (a.e.transpose() * q1);
            out.push(f[0]);
        }
        out.extend(self.imposed.iter().map(|i| i.2 * al));
        out
    }

    /// For force control of force column `j`: `F_j = alpha phi - psi^T f_1`
    /// with its derivatives; returns `(phi, phi', psi, psi')` where `psi`
    /// maps the complex fundamental element forces (`E`).
    pub(crate) fn force_map(
        &self,
        lin: &Linear,
        j: usize,
    ) -> (Complex64, Complex64, DVector<Complex64>, DVector<Complex64>) {
        let ne = self.w.ncols();
        if j >= self.attached.len() {
            let f = self.imposed[j - self.attached.len()].2;
            return (
                f,
                Complex64::new(0.0, 0.0),
                DVector::zeros(ne),
                DVector::zeros(ne),
            );
        }
        let a = &self.attached[j];
        let h1 = &lin.harmonics[1];
        // rho = Z_G[0,:] E^T (1 x ndof), F = alpha T_G u - rho q_1
        let et = a.e.transpose();
        let rho = lin.cond[j][0].row(0) * &et;
        let drho = lin.cond[j][1].row(0) * &et;
        let phi = lin.tgu[j][0][0] - (&rho * &h1.dinv * &lin.b1)[0];
        let dphi = lin.tgu[j][1][0]
            - (&drho * &h1.dinv * &lin.b1)[0]
            - (&rho * (&h1.ddinv * &lin.b1 + &h1.dinv * &lin.db1))[0];
        // F = alpha phi + rho D^-1 W f  ->  psi = -(rho D^-1 W)^T
        let psi = -(&rho * &h1.dinv * &self.w).transpose();
        let dpsi = -(&drho * &h1.dinv * &self.w + &rho * &h1.ddinv * &self.w).transpose();
        (phi, dphi, psi, dpsi)
    }
}
