//! Test planning on the single-nonlinear-mode model: what the shaker must give
//! to hold the structure at phase resonance at a target amplitude.
//!
//! # Steady state at phase resonance (`eq:NM`)
//!
//! In a steady state of `eq:NM` (`a' = 0`, `theta' = 0`) with the excitation
//! frequency at the modal frequency, `Omega = omega(a)`, the measured force at
//! the structure leads the drive-point fundamental by 90 degrees (the
//! structure's own terms of `eq:NMpre` are then `2 i D omega^2 a`), which is
//! what a phase-resonance test holds. `eq:NM` there reads
//!
//! ```text
//! K A = f_m u_hat,     K = 2 i D(a) omega(a)^2 + Z_A(a, omega(a)),
//! ```
//!
//! with `A = a e^{i theta}` and `f_m = phi^H f_ex(Omega)` the imposed modal
//! force per unit excitation amplitude (volts for a shaker). So the voltage
//! amplitude and the phase are
//!
//! ```text
//! u_hat = a |K| / |f_m|,     theta = arg(f_m / K).
//! ```
//!
//! The shaker's states follow from the interface displacement `u_G = phi_d(a)
//! A` and the voltage (`eq:assemblyF2`, [`LinearAttachment::states`]); for the
//! paper's shaker ([`LinearAttachment::shaker`]) state 0 is the coil current
//! `I` and state 1 the armature displacement `q_a`.
use crate::attachment::LinearAttachment;
use crate::reduced::{ReducedError, ReducedModel};
use nalgebra::DVector;
use num_complex::Complex64;

/// Errors of the test planning; each carries the numbers.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    #[error("modal amplitude a = {0} is not a finite positive number")]
    BadAmplitude(f64),
    #[error(
        "at a = {a:.6e} (Omega = {omega_rad_s:.3} rad/s) the excitation gives no modal force \
         (|phi^H f_ex| = {modal_force:.3e} per volt): no voltage reaches the amplitude"
    )]
    NoModalForce {
        a: f64,
        omega_rad_s: f64,
        modal_force: f64,
    },
    #[error(transparent)]
    Reduced(#[from] ReducedError),
    #[error("attachment '{name}' has {ncon} interface points; the plan takes an exciter with one, at the drive point")]
    InterfacePoints { name: String, ncon: usize },
    #[error("shaker states: {0}")]
    Attachment(#[from] crate::attachment::AttachmentError),
}

/// The steady state of `eq:NM` at phase resonance at one modal amplitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseResonancePoint {
    /// Modal amplitude `a` \[sqrt(kg) m\].
    pub a: f64,
    /// Excitation frequency `Omega = omega(a)` \[rad/s\].
    pub omega_rad_s: f64,
    /// `D(a)` \[-\].
    pub damping_ratio: f64,
    /// Excitation amplitude the model needs \[V for a shaker\].
    pub voltage_v: f64,
    /// Complex modal amplitude `A = a e^{i theta}` \[sqrt(kg) m\].
    pub modal_amplitude: Complex64,
    /// Fundamental of the force at the drive point (`eq:fc1`) \[N\].
    pub force_n: Complex64,
    /// `|q_tip,1|` \[m\].
    pub tip_amplitude_m: f64,
    /// `|q_drive,1|` \[m\].
    pub drive_amplitude_m: f64,
}

/// The excitation amplitude that holds `model` at phase resonance at the modal
/// amplitude `a` (module docs).
pub fn phase_resonance_voltage(
    model: &ReducedModel,
    a: f64,
) -> Result<PhaseResonancePoint, PlanError> {
    if !(a.is_finite() && a > 0.0) {
        return Err(PlanError::BadAmplitude(a));
    }
    let p = model.modal_properties(a)?;
    let w = p.omega_rad_s;
    let (za, fm) = model.modal_impedance_and_force(a, w, 1.0)?;
    let k = Complex64::new(0.0, 2.0 * p.damping_ratio * w * w) + za;
    if !(fm.norm() > 0.0 && fm.norm().is_finite()) {
        return Err(PlanError::NoModalForce {
            a,
            omega_rad_s: w,
            modal_force: fm.norm(),
        });
    }
    let u = a * k.norm() / fm.norm();
    let amp = fm * u / k;
    let force = model.force_harmonics(w, u, amp)?;
    let tip = model.displacement_harmonics(model.tip_name(), amp)?;
    let drive = model.displacement_harmonics(model.drive_name(), amp)?;
    Ok(PhaseResonancePoint {
        a,
        omega_rad_s: w,
        damping_ratio: p.damping_ratio,
        voltage_v: u,
        modal_amplitude: amp,
        force_n: force.get(1).copied().unwrap_or_default(),
        tip_amplitude_m: tip.get(1).map(|x| x.norm()).unwrap_or(0.0),
        drive_amplitude_m: drive.get(1).map(|x| x.norm()).unwrap_or(0.0),
    })
}

/// The complex states of the attachment `att` (one interface point, at the
/// drive point of `point`) in that steady state, with the inputs `inputs` per
/// unit excitation amplitude ([`LinearAttachment::states`]).
pub fn attachment_states(
    model: &ReducedModel,
    point: &PhaseResonancePoint,
    att: &LinearAttachment,
    inputs: &[Complex64],
) -> Result<DVector<Complex64>, PlanError> {
    if att.ncon() != 1 {
        return Err(PlanError::InterfacePoints {
            name: att.name.clone(),
            ncon: att.ncon(),
        });
    }
    let drive = model.displacement_harmonics(model.drive_name(), point.modal_amplitude)?;
    let u_g = DVector::from_element(att.ncon(), drive.get(1).copied().unwrap_or_default());
    let u_hat = DVector::from_iterator(inputs.len(), inputs.iter().map(|u| u * point.voltage_v));
    Ok(att.states(point.omega_rad_s, &u_g, &u_hat)?)
}
