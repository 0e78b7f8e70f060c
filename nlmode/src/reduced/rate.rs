//! The modulation equation to first order in the slow derivatives
//! (`[slowflow] rate_terms = true`): the terms `eq:NM` drops.
//!
//! # Derivation
//!
//! Complexification-averaging (`eq:ansatz`, `q = Re(phi A e^{i Phi})`,
//! `Phi' = Omega`, `A = a e^{i theta}` slowly varying) applied to a linear
//! operator `sum_k A_k d^k/dt^k` gives, exactly,
//!
//! ```text
//! d^k/dt^k (A e^{i Phi}) = e^{i Phi} (i Omega + d/dt)^k A,
//! (i Omega + d/dt)^2 A = -Omega^2 A + 2 i Omega A' + i Omega' A + A''.
//! ```
//!
//! `eq:NMpre` keeps of the structure's modal mass the term `2 i Omega A'`
//! only, of its modal damping none (`2 D omega (i Omega A + A')` gives
//! `2 D omega A'`), drops the sweep's `i Omega' A` (`Omega' = dOmega/dt`),
//! and condenses the attachments at the frozen frequency (`eq:fc1`:
//! `Z_G(Omega) U`). To first order in the slow derivatives (`A''`, products
//! of slow derivatives and `dphi/da a'` dropped) the attachment's force is
//! `Z_G(i Omega + d/dt) U = Z_G U + Z_G,s U'` with
//! `Z_G,s = dZ_G/d(i Omega) = -i dZ_G/dOmega`, `U = phi_G A`, so that
//!
//! ```text
//! (2 i Omega + 2 D omega + z_s) A'
//!     + (omega^2 - Omega^2 + 2 i D omega Omega + Z_A + i Omega') A = phi^H f_ex,
//! z_s = sum_att phi_G^H Z_G,s phi_G = -i dZ_A/dOmega  (phi fixed).
//! ```
//!
//! `z_s` is the attachments' modal mass and damping as seen by the
//! modulation (a rigid mass `m` adds `2 i Omega m |phi_G|^2`, the same
//! share as the structure's unit modal mass has in `2 i Omega`; a dashpot
//! `c` adds `c |phi_G|^2`). `i Omega'` is the structure's own term of a
//! sweep (for the paper's 2 % per pseudo period, `Omega' / Omega^2 =
//! 0.02 / (2 pi) = 3.2e-3`, a third of the modal damping term `2 D` of the
//! beam). Dropped: the attachments' `Omega'` terms (`1/2 d^2Z_G/d(i Omega)^2
//! i Omega' U`, second order in the attachment's frequency dependence) and
//! `A''`.
//!
//! **Reduction to `eq:NM`.** In a steady state (`A' = 0`, `Omega' = 0`) the
//! equation is `eq:NM`; the rate terms change only how the envelope moves
//! between steady states (a sweep, a decay). They are a consistent
//! first-order correction where `eq:NM` itself holds: the attachments in
//! quasi-steady state (`z_s` tabulated with `Z_G`), the modulation slow. The
//! same terms enter the slow flow with carried attachment states
//! ([`super::dynamic`]), from the derivative of the condensed channels
//! (`Q1`).
use super::sweep::OmegaCache;
use super::{ImposedForces, ReducedError, ReducedModel, MAX_PHI};
use crate::excitation::LinearSweep;
use num_complex::Complex64;

/// The effective modal mass `|2 i Omega + 2 D omega + z_s| / (2 Omega)`
/// below which the rate terms are refused: the attachments' rate terms would
/// then not be a correction of the structure's modal mass but dominate it.
const MIN_MODAL_MASS: f64 = 0.5;

impl ReducedModel {
    /// `A'` of the first-order modulation equation (module docs) at the
    /// complex modal amplitude `y = [Re A, Im A]`, excitation frequency
    /// `omega` \[rad/s\] changing at `omega_dot` \[rad/s^2\], with the
    /// attachment channels `ch` and their derivatives `dch = dch/dOmega`
    /// (standard channels first); `phi` is scratch space.
    #[inline]
    #[allow(clippy::too_many_arguments)] // the integrator's hot path: its operands by value
    pub(crate) fn rhs_first_order(
        &self,
        y: &[f64],
        omega: f64,
        omega_dot: f64,
        ch: &[Complex64],
        dch: &[Complex64],
        fi: &ImposedForces,
        phi: &mut [Complex64; MAX_PHI],
    ) -> Result<Complex64, ReducedError> {
        let amp = Complex64::new(y[0], y[1]);
        let a = (y[0] * y[0] + y[1] * y[1]).sqrt();
        let p = self.gather(a, phi)?;
        let (k, fm, _) = self.terms_with(&p, phi, omega, ch, fi);
        self.first_order_rate(&p, phi, a, omega, omega_dot, dch, fm - k * amp, amp)
    }

    /// `A'` from the `eq:NM` residual `z = phi^H f_ex - K A` (gathered
    /// properties `p` and shapes `phi` at `a`): `(z - i Omega' A) / (2 i Omega
    /// + 2 D omega + z_s)` (module docs).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn first_order_rate(
        &self,
        p: &crate::table::ModalProperties,
        phi: &[Complex64; MAX_PHI],
        a: f64,
        omega: f64,
        omega_dot: f64,
        dch: &[Complex64],
        z: Complex64,
        amp: Complex64,
    ) -> Result<Complex64, ReducedError> {
        // Z_A evaluated on the derivative channels: phi^H dZ_G/dOmega phi
        let (_, _, dza) = self.terms_with(p, phi, omega, dch, &ImposedForces::NONE);
        let zs = Complex64::new(dza.im, -dza.re);
        let den = Complex64::new(2.0 * p.damping_ratio * p.omega_rad_s, 2.0 * omega) + zs;
        let mass = den.norm() / (2.0 * omega);
        if mass.is_nan() || mass < MIN_MODAL_MASS {
            return Err(ReducedError::RateTerms {
                omega_rad_s: omega,
                a,
                modal_mass: mass,
            });
        }
        Ok((z - Complex64::new(0.0, omega_dot) * amp) / den)
    }

    /// The attachments' rate force in the outputs: each port's force channel
    /// (`T_G u_hat`, after the carried states' `-Q2 y`) less `Z_G,s U'`
    /// with `U' = phi_G A'` (`rate`), so that the reported force is
    /// `F_G = -Z_G U + T_G u_hat - Z_G,s U'`, the force of the slow flow
    /// (module docs). `dch` are the channels' derivatives `d/dOmega`, `phi`
    /// the gathered shapes.
    pub(crate) fn subtract_rate_forces(
        &self,
        ch: &mut [Complex64],
        dch: &[Complex64],
        phi: &[Complex64; MAX_PHI],
        rate: Complex64,
    ) {
        let mut j = 0;
        for port in &self.ports {
            let (nc, o) = (port.ncon(), port.offset);
            for r in 0..nc {
                let mut s = Complex64::new(0.0, 0.0);
                for c in 0..nc {
                    s += dch[o + r * nc + c] * phi[j + c];
                }
                // Z_G,s = -i dZ_G/dOmega
                ch[o + nc * nc + r] -= Complex64::new(s.im, -s.re) * rate;
            }
            j += nc;
        }
    }

    /// The channel rows of a batch of output samples of the quasi-steady
    /// sweep (times `ts`, frequencies `w`, amplitudes `amps`), appended to
    /// `rows` (`nch` each), each with its rate force subtracted
    /// ([`Self::subtract_rate_forces`], `A'` from the first-order slow flow
    /// at the sample): the channels and their derivatives from one
    /// evaluation of the tabulation.
    pub(crate) fn rate_rows_into(
        &self,
        cache: &OmegaCache,
        sweep: &LinearSweep,
        (ts, w, amps): (&[f64], &[f64], &[Complex64]),
        rows: &mut Vec<Complex64>,
    ) -> Result<(), ReducedError> {
        let nch = self.nch;
        if nch == 0 {
            return Ok(());
        }
        let mut ch = vec![Complex64::new(0.0, 0.0); nch];
        let mut dch = vec![Complex64::new(0.0, 0.0); nch];
        let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
        rows.reserve(nch * w.len());
        for ((&t, &wi), amp) in ts.iter().zip(w).zip(amps) {
            cache.eval_with_derivative(wi, &mut ch, &mut dch);
            let fi = self.imposed_at(wi)?;
            let y = [amp.re, amp.im];
            let wdot = sweep.omega_rate_rad_s2(t);
            let rate = self.rhs_first_order(&y, wi, wdot, &ch, &dch, &fi, &mut phi)?;
            self.subtract_rate_forces(&mut ch, &dch, &phi, rate);
            rows.extend_from_slice(&ch);
        }
        Ok(())
    }
}
