//! Linear steady state of the assembly (method `linear-frf`): the assembled
//! linear frequency response of structure + attachments (all modes), with the
//! closed forms `eq:fhfhNull` and `eq:forcedrop` beside it.
//!
//! For each excitation frequency `Omega` the linear part of `eq:component1`
//! (`M`, `C`, `K`; nonlinear elements are ignored) with the condensed
//! attachments of `eq:fc1` is solved,
//!
//! ```text
//! (-Omega^2 M + i Omega C + K + sum_a E_a Z_G,a E_a^T) q_hat = sum_a E_a T_G,a u_hat,a,
//! ```
//!
//! and the interface force of each attachment on the structure,
//! `F_G,a = -Z_G,a E_a^T q_hat + T_G,a u_hat,a` (positive along positive
//! structure displacement, see [`crate::attachment`]), and the complex response
//! `e^T q_hat` at every named point are returned. Amplitudes are complex
//! fundamental Fourier coefficients: `f(t) = Re(f_hat e^{i Omega t})`.
use crate::attachment::{
    AttachmentError, Condenser, InterfaceCondensation, LinearAttachment, ShakerParams,
};
use crate::structure::StructuralModel;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// Errors of the frequency response computation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FrfError {
    #[error(transparent)]
    Attachment(#[from] AttachmentError),
    #[error("{found} input vectors given for {expected} attachments")]
    AttachmentInputs { expected: usize, found: usize },
    #[error("excitation frequency {omega_rad_s} rad/s is not finite")]
    NonFiniteOmega { omega_rad_s: f64 },
    #[error("the assembled dynamic stiffness is singular at Omega = {omega_rad_s} rad/s (undamped resonance of the assembly)")]
    SingularDynamicStiffness { omega_rad_s: f64 },
    #[error("structure point `{point}` does not exist (available: {available:?})")]
    UnknownPoint {
        point: String,
        available: Vec<String>,
    },
}

/// The assembled linear response at one excitation frequency.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrfPoint {
    /// Excitation frequency `Omega` \[rad/s\].
    pub omega_rad_s: f64,
    /// Complex interface force amplitudes on the structure \[N\]: the `ncon`
    /// constraint forces of attachment 0, then of attachment 1, ... (one entry
    /// per attachment for single-point attachments such as the shaker).
    pub force_n: Vec<Complex64>,
    /// Complex displacement amplitude `e^T q_hat` \[m\] at every named point of
    /// the structure, in the order of `model.points`.
    pub points: Vec<Complex64>,
}

fn complex(m: &DMatrix<f64>) -> DMatrix<Complex64> {
    m.map(|v| Complex64::new(v, 0.0))
}

/// The assembled linear frequency response (`linear-frf`) of `model` (linear
/// part) with `attachments` driven by the complex input amplitudes `inputs`
/// (one vector of length `ninput` per attachment), at each `omegas` \[rad/s\].
///
/// The SVD localization of each attachment is computed once; per frequency the
/// cost is one `ndof`-sized complex LU.
pub fn assembled_frf(
    model: &StructuralModel,
    attachments: &[LinearAttachment],
    inputs: &[DVector<Complex64>],
    omegas: &[f64],
) -> Result<Vec<FrfPoint>, FrfError> {
    if inputs.len() != attachments.len() {
        return Err(FrfError::AttachmentInputs {
            expected: attachments.len(),
            found: inputs.len(),
        });
    }
    let ndof = model.mass.nrows();
    assert_eq!(model.stiffness.shape(), (ndof, ndof), "K shape");
    assert_eq!(model.damping.shape(), (ndof, ndof), "C shape");
    struct Prepared<'a> {
        condenser: Condenser,
        /// `E` (`ndof x ncon`).
        e: DMatrix<Complex64>,
        /// `e_a e_b^T` for all constraint pairs `(a, b)`, row-major in `(a, b)`.
        outer: Vec<DMatrix<f64>>,
        u: &'a DVector<Complex64>,
    }
    let mut prepared = Vec::with_capacity(attachments.len());
    for (att, u) in attachments.iter().zip(inputs) {
        att.check_input_count(u)?;
        let condenser = Condenser::new(att)?;
        let e = att.interface_vectors(model)?;
        let nc = e.ncols();
        let outer = (0..nc * nc)
            .map(|ab| e.column(ab / nc) * e.column(ab % nc).transpose())
            .collect();
        prepared.push(Prepared {
            condenser,
            e: complex(&e),
            outer,
            u,
        });
    }
    let mut observe = DMatrix::<Complex64>::zeros(model.points.len(), ndof);
    for (i, p) in model.points.iter().enumerate() {
        assert_eq!(
            p.direction.len(),
            ndof,
            "point `{}` direction length",
            p.name
        );
        observe
            .row_mut(i)
            .copy_from(&p.direction.transpose().map(|v| Complex64::new(v, 0.0)));
    }
    let (m, c, k) = (&model.mass, &model.damping, &model.stiffness);
    let mut out = Vec::with_capacity(omegas.len());
    let mut conds: Vec<InterfaceCondensation> = Vec::with_capacity(prepared.len());
    let mut dyn_stiff = DMatrix::<Complex64>::zeros(ndof, ndof);
    for &w in omegas {
        if !w.is_finite() {
            return Err(FrfError::NonFiniteOmega { omega_rad_s: w });
        }
        let w2 = w * w;
        for (d, ((kij, mij), cij)) in dyn_stiff
            .iter_mut()
            .zip(k.iter().zip(m.iter()).zip(c.iter()))
        {
            *d = Complex64::new(kij - w2 * mij, w * cij);
        }
        let mut rhs = DVector::<Complex64>::zeros(ndof);
        conds.clear();
        for p in &prepared {
            let cond = p.condenser.condense(w)?;
            let nc = cond.z_g.nrows();
            for (ab, outer) in p.outer.iter().enumerate() {
                let z = cond.z_g[(ab / nc, ab % nc)];
                dyn_stiff.zip_apply(outer, |d, o| *d += z * o);
            }
            rhs += &p.e * (&cond.t_g * p.u);
            conds.push(cond);
        }
        let q = dyn_stiff
            .clone()
            .lu()
            .solve(&rhs)
            .filter(|q| q.iter().all(|v| v.re.is_finite() && v.im.is_finite()))
            .ok_or(FrfError::SingularDynamicStiffness { omega_rad_s: w })?;
        let mut force_n = Vec::new();
        for (p, cond) in prepared.iter().zip(&conds) {
            let u_g = p.e.transpose() * &q;
            force_n.extend(cond.force(&u_g, p.u).iter().copied());
        }
        out.push(FrfPoint {
            omega_rad_s: w,
            force_n,
            points: (&observe * &q).iter().copied().collect(),
        });
    }
    Ok(out)
}

/// The structure's own (no attachment) receptance between two named points,
/// `H(Omega) = e_out^T (-Omega^2 M + i Omega C + K)^{-1} e_in` \[m/N\].
pub fn structure_receptance(
    model: &StructuralModel,
    input_point: &str,
    output_point: &str,
    omegas: &[f64],
) -> Result<Vec<Complex64>, FrfError> {
    let find = |name: &str| {
        model
            .points
            .iter()
            .find(|p| p.name == name)
            .ok_or_else(|| FrfError::UnknownPoint {
                point: name.to_string(),
                available: model.points.iter().map(|p| p.name.clone()).collect(),
            })
    };
    let e_in = find(input_point)?.direction.map(|v| Complex64::new(v, 0.0));
    let e_out = find(output_point)?
        .direction
        .map(|v| Complex64::new(v, 0.0));
    let ndof = model.mass.nrows();
    let (m, c, k) = (&model.mass, &model.damping, &model.stiffness);
    omegas
        .iter()
        .map(|&w| {
            if !w.is_finite() {
                return Err(FrfError::NonFiniteOmega { omega_rad_s: w });
            }
            let d = DMatrix::<Complex64>::from_fn(ndof, ndof, |i, j| {
                Complex64::new(k[(i, j)] - w * w * m[(i, j)], w * c[(i, j)])
            });
            let x = d
                .lu()
                .solve(&e_in)
                .ok_or(FrfError::SingularDynamicStiffness { omega_rad_s: w })?;
            Ok(e_out.dot(&x))
        })
        .collect()
}

/// Linear steady-state force drop at `omega_rad_s` (normally the structure's
/// natural frequency `omega0`, i.e. `eta = 1`) of one shaker at `point` from the
/// assembled FRF: `1 - |F| / |F0|` with the nominal force `F0 = G u_hat / R`
/// (the ratio does not depend on `u_hat` in the linear case).
pub fn linear_force_drop(
    model: &StructuralModel,
    shaker: &ShakerParams,
    point: &str,
    omega_rad_s: f64,
) -> Result<f64, FrfError> {
    let att = LinearAttachment::shaker("shaker", shaker, point)?;
    let u = DVector::from_element(1, Complex64::new(1.0, 0.0));
    let frf = assembled_frf(model, &[att], &[u], &[omega_rad_s])?;
    let f0 = shaker.force_constant_n_per_a / shaker.resistance_ohm;
    Ok(1.0 - frf[0].force_n[0].norm() / f0)
}

/// `eq:fhfhNull`: the applied-to-nominal force ratio `F_hat / F0_hat` of the
/// linear single-mode model with an attached passive exciter, at the frequency
/// ratio `eta = Omega/omega0`, for the structure's modal damping ratio `d0`,
/// mass ratio `mu = m_a/m_mod`, `omega_a/omega0` and the total armature damping
/// ratio `d_a` (`2 D_a omega_a m_a = d_a + G^2/R`). Assumes
/// `omega_c >> omega0` and `k_s >> k_a` (or a rigid stinger).
pub fn force_ratio_closed_form(
    eta: f64,
    d0: f64,
    mu: f64,
    omega_a_over_omega0: f64,
    d_a: f64,
) -> Complex64 {
    let i = Complex64::i();
    let r = omega_a_over_omega0;
    let num = -eta * eta + 2.0 * d0 * i * eta + 1.0;
    let den = -(1.0 + mu) * eta * eta + 2.0 * (d0 + mu * r * d_a) * i * eta + 1.0 + mu * r * r;
    num / den
}

/// `eq:forcedrop`: `|F_hat| / |F0_hat|` at the structural resonance `eta = 1`
/// (the *force drop* is `1 -` this value), same parameters as
/// [`force_ratio_closed_form`].
pub fn force_drop_closed_form(d0: f64, mu: f64, omega_a_over_omega0: f64, d_a: f64) -> f64 {
    let r = omega_a_over_omega0;
    2.0 * d0 / (mu * mu * (r * r - 1.0).powi(2) + 4.0 * (d0 + mu * r * d_a).powi(2)).sqrt()
}

/// Modal mass with respect to the exciter location, `m_mod = 1/|phi_ex|^2`
/// \[kg\], for the mass-normalised mode shape's value `phi_ex = e^T phi` there
/// (below `eq:forcedrop`).
pub fn modal_mass(phi_ex: impl Into<Complex64>) -> f64 {
    1.0 / phi_ex.into().norm_sqr()
}

/// Mass ratio `mu = m_a / m_mod` \[-\] (below `eq:forcedrop`).
pub fn mass_ratio(armature_mass_kg: f64, modal_mass_kg: f64) -> f64 {
    armature_mass_kg / modal_mass_kg
}
