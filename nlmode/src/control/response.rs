//! Response-controlled stepped sine (Karaagacli 2021, cited by the paper as a
//! source of experimental modal properties): stepped frequencies, at each step
//! the voltage is adjusted until the fundamental of the drive-point
//! displacement `|x_1|` equals the set value.
//!
//! At a constant response amplitude the nonlinear element sees the same
//! displacement amplitude at every frequency, so the structure behaves like a
//! linear one tuned to that amplitude: the constant-response FRF `|x_1| /
//! |F_1|` over `Omega` is a linear resonance whose peak (the least force)
//! lies on the backbone, at the frequency of the nonlinear mode at that
//! amplitude (up to `D^2` for the viscous part).
//!
//! The control law is the force controller's dwell-and-correct loop
//! ([`super::force`]) with `|x_1|` in place of `|F_1|`: settle, then `U <- min(U
//! x_set / |x_1|, max_voltage_v)`, exact in one correction for a linear
//! structure and, at a constant response amplitude, nearly so for a nonlinear
//! one. The options are [`ForceControlOptions`] (`force_tolerance` is then the
//! tolerance on `|x_1|`); the result is a [`ForceControlResult`] whose
//! `flatness` is the largest relative deviation of `|x_1|` from the set value.
use super::force::{stepped_sine, Controlled};
use super::{ControlError, ForceControlOptions, ForceControlResult, Plant};

/// Response-controlled stepped sine through `omegas_rad_s` (in the given
/// order) at the drive-point response amplitude `response_set_m` \[m\],
/// starting at the voltage `voltage_start_v` (see the module docs).
pub fn response_controlled_stepped_sine(
    plant: &mut dyn Plant,
    omegas_rad_s: &[f64],
    response_set_m: f64,
    voltage_start_v: f64,
    options: &ForceControlOptions,
) -> Result<ForceControlResult, ControlError> {
    stepped_sine(
        plant,
        omegas_rad_s,
        Controlled::Response,
        response_set_m,
        voltage_start_v,
        options,
    )
}

/// The peak of a constant-response FRF: the frequency of the least force
/// `|F_1|` over the steps, refined by the parabola through the least one and
/// its neighbours (in `Omega`, on unequal spacing); `None` if the least force
/// is at either end of the list or fewer than three steps settled.
pub fn constant_response_peak(result: &ForceControlResult) -> Option<f64> {
    let s: Vec<_> = result.steps.iter().filter(|s| s.settled).collect();
    if s.len() < 3 {
        return None;
    }
    let f = |i: usize| s[i].harmonics.force_amplitude_n();
    let k = (0..s.len()).min_by(|&i, &j| f(i).total_cmp(&f(j)))?;
    if k == 0 || k + 1 == s.len() {
        return None;
    }
    let (x0, x1, x2) = (s[k - 1].omega_rad_s, s[k].omega_rad_s, s[k + 1].omega_rad_s);
    let (y0, y1, y2) = (f(k - 1), f(k), f(k + 1));
    // vertex of the interpolating parabola
    let num = (x1 - x0).powi(2) * (y1 - y2) - (x1 - x2).powi(2) * (y1 - y0);
    let den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0);
    if den == 0.0 {
        return Some(x1);
    }
    Some(x1 - 0.5 * num / den)
}
