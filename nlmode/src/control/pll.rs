//! Phase-locked loop for phase-resonant testing (Scheel 2018, cited by the
//! paper as a source of experimental modal properties), stepped through
//! voltage levels.
//!
//! # Phase detector
//!
//! Over each excitation period the fundamentals `F_1` of the measured force and
//! `X_1` of the drive-point displacement are demodulated ([`super`]); the lag
//! of the displacement behind the force and the phase error are
//!
//! ```text
//! lag = arg F_1 - arg X_1,     e = pi/2 - lag     (wrapped to (-pi, pi]).
//! ```
//!
//! `e > 0` (lag below 90 degrees) means the excitation is below the phase
//! resonance, so the frequency must rise.
//!
//! # PI frequency update (velocity form, once per period `n`)
//!
//! ```text
//! Omega_{n+1} = Omega_n + Omega_n (k_p (e_n - e_{n-1}) + k_i e_n),
//! ```
//!
//! the change limited to `max_step_ratio Omega_n`. Near phase resonance the
//! lag responds to a frequency step `delta` like a first-order lag: its steady
//! value changes by `delta / (D omega)` (the structure's own driving-point
//! receptance, since the force is measured at the structure), reached at the
//! rate `sigma = |F_b / F| D omega`, where `F_b` is the force the exciter would
//! give on a blocked structure and `F` the measured one. Under an imposed force
//! (`F = F_b`) the lag integrates the frequency error slowly (time constant
//! `1/(D omega)`); with the shaker at a light structure the force drops at
//! resonance (`|F_b/F|` about 30 for the paper beam at 2l/3, `eq:forcedrop`)
//! and the lag follows the frequency within about a period: the plant is then
//! almost static, `e_{n+1} = e_n - (k_i e_n + k_p (e_n - e_{n-1})) / D`, and
//! stable only for `k_i + 2 k_p < 2 D`. The defaults `k_i = k_p = 0.001`
//! therefore hold for modal damping ratios down to about 0.15 %; they reduce the
//! phase error by a factor of about `1 - k_i / D` per period in the strongly coupled case
//! (0.75 for the paper beam, `D = 0.4 %`) and, under an imposed force, close a
//! loop of natural frequency `Omega sqrt(k_i / (2 pi))` (a loop period of about
//! 80 excitation periods). Lightly damped structures need smaller gains.
//!
//! # Settle criterion and record
//!
//! A level is settled when, for `settle_periods` consecutive periods,
//! `|e| < phase_tolerance_rad` and the relative change of `|X_1|` from one
//! period to the next is below `amplitude_tolerance`. The last period is then
//! recorded: `Omega`, the harmonics of force, drive point and tip, and the
//! modal damping from the power balance at phase resonance,
//!
//! ```text
//! P = 1/2 sum_h Re(F_h conj(i h Omega X_h)),
//! D = P / (Omega m_d sum_h (h Omega)^2 |X_h|^2),
//! ```
//!
//! i.e. `P = 2 D Omega <q'^T M q'>` of `eq:EPMC` (the mode's negative damping
//! term balances the input power) with the kinetic term taken at the drive
//! point, `m_d = 1/|phi_d|^2` the modal mass at the drive point (exact for a
//! single DOF: `D = c / (2 m Omega)`). A level that does not settle within
//! `max_periods_per_level` is recorded with `settled = false` and the loop
//! goes on with the next level.
//!
//! # Level start
//!
//! A new level starts at the frequency predicted from the levels settled
//! before it ([`predicted_level_start_rad_s`]) rather than at the last
//! level's: the PI update then starts from a small phase error instead of
//! climbing the backbone at `max_step_ratio` per period. With `Omega_s` the
//! loop's start frequency, the settled `Delta_k = Omega_k - Omega_s` of the
//! last (up to three) settled levels are taken as a smooth function of the
//! voltage in `(ln U, ln |Delta|)` and extrapolated to the new voltage by the
//! polynomial through them (a straight line through two: `Delta ~ U^p`, the
//! shape of a backbone `Delta ~ a^2` at small amplitude with `a ~ U`). With
//! fewer than two settled levels, levels of either side of `Omega_s`, or
//! voltages too close together, the level starts where the last one ended.
//! The start moves the frequency by at most `LEVEL_START_JUMP_PERIODS
//! max_step_ratio` (25 periods of the rate limit, 5 % by default): the
//! amplitude has to follow the jump, and a hardening structure excited far
//! above the backbone of its current amplitude falls to the lower branch
//! (measured on the single-nonlinear-mode plant of the paper beam: a 10 %
//! jump at 25 V lost the resonance, 9.5 % at 20 V did not). The rest is
//! climbed by the PI update. The prediction only moves the start: the PI
//! update, the settle criterion and the recorded period are unchanged.
//! Measured on the 20-level test of the paper beam (0.5-40 V, the `pll`
//! bench, `pll_tests::pll_20_levels_measurement`): the prediction (three
//! levels) lies within 1e-6 to 1.5e-3 of the settled frequency (5e-4
//! typical); the reference then needs 1033 periods (35-78 per level) instead
//! of 1430 (36-111), the single-nonlinear-mode plant 1086 instead of 1477;
//! the settled frequency, `|q_tip,1|`, damping and `|F_1|` of every level
//! move by at most 1.3e-7, 2.5e-7, 3.4e-6 and 3.0e-6 (relative).
use super::{wrap_angle, ControlError, PeriodHarmonics, Plant};
use num_complex::Complex64;
use std::f64::consts::FRAC_PI_2;

/// Tuning and settle criterion of the [`PhaseLockedLoop`]; `Default` gives the
/// documented defaults.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PllOptions {
    /// Proportional gain `k_p` (relative frequency change per rad of phase-error
    /// change; default 0.001, `>= 0`).
    pub kp: f64,
    /// Integral gain `k_i` (relative frequency change per rad of phase error per
    /// period; default 0.001).
    pub ki: f64,
    /// Largest relative frequency change per period (default 0.002).
    pub max_step_ratio: f64,
    /// Phase-error tolerance of the settle criterion \[rad\] (default 1e-3).
    pub phase_tolerance_rad: f64,
    /// Tolerance on the relative change of `|X_1|` per period (default 1e-4).
    pub amplitude_tolerance: f64,
    /// Consecutive periods inside both tolerances to count as settled (default 10).
    pub settle_periods: usize,
    /// Periods per level before the level is given up as not settled (default 3000).
    pub max_periods_per_level: usize,
    /// Harmonics demodulated and recorded (default 5; at most `N/2 - 1` for `N`
    /// samples per period).
    pub harmonics: usize,
}

impl Default for PllOptions {
    fn default() -> Self {
        Self {
            kp: 0.001,
            ki: 0.001,
            max_step_ratio: 0.002,
            phase_tolerance_rad: 1e-3,
            amplitude_tolerance: 1e-4,
            settle_periods: 10,
            max_periods_per_level: 3000,
            harmonics: 5,
        }
    }
}

impl PllOptions {
    /// Checks every option; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ControlError> {
        let pos = super::positive_option;
        if !(self.kp.is_finite() && self.kp >= 0.0) {
            return Err(ControlError::BadOption {
                name: "kp",
                value: self.kp.to_string(),
                expected: "a number >= 0",
            });
        }
        pos("ki", self.ki)?;
        pos("max_step_ratio", self.max_step_ratio)?;
        pos("phase_tolerance_rad", self.phase_tolerance_rad)?;
        pos("amplitude_tolerance", self.amplitude_tolerance)?;
        if self.max_step_ratio >= 0.5 {
            return Err(ControlError::BadOption {
                name: "max_step_ratio",
                value: self.max_step_ratio.to_string(),
                expected: "a number below 0.5",
            });
        }
        let count = |name: &'static str, v: usize| {
            if v > 0 {
                Ok(())
            } else {
                Err(ControlError::BadOption {
                    name,
                    value: "0".into(),
                    expected: "a positive integer",
                })
            }
        };
        count("settle_periods", self.settle_periods)?;
        count("max_periods_per_level", self.max_periods_per_level)?;
        count("harmonics", self.harmonics)
    }
}

/// One voltage level of the phase-resonance test.
#[derive(Debug, Clone, PartialEq)]
pub struct PllLevel {
    /// Voltage amplitude \[V\].
    pub voltage_v: f64,
    /// Whether the settle criterion was met.
    pub settled: bool,
    /// Periods spent on the level.
    pub periods: usize,
    /// Time at the end of the recorded period \[s\].
    pub time_s: f64,
    /// Excitation frequency of the recorded period \[rad/s\].
    pub omega_rad_s: f64,
    /// Phase error `e` of the recorded period \[rad\].
    pub phase_error_rad: f64,
    /// Relative change of `|X_1|` in the recorded period.
    pub amplitude_change: f64,
    /// Harmonics of force, drive point, tip and the coil current of the
    /// recorded period.
    pub harmonics: PeriodHarmonics,
    /// Mean input power at the drive point \[W\].
    pub power_w: f64,
    /// Modal damping ratio from the power balance (module docs).
    pub damping_ratio: f64,
}

impl PllLevel {
    /// `|q_tip,1|` \[m\].
    pub fn tip_amplitude_m(&self) -> f64 {
        self.harmonics.tip_amplitude_m()
    }
    /// `|q_drive,1|` \[m\].
    pub fn drive_amplitude_m(&self) -> f64 {
        self.harmonics.drive_amplitude_m()
    }
    /// `|F_1|` \[N\].
    pub fn force_amplitude_n(&self) -> f64 {
        self.harmonics.force_amplitude_n()
    }
}

/// Result of [`phase_resonance`]: the levels measured, and the failure that
/// stopped the test early (the levels before it are kept).
#[derive(Debug, Clone, PartialEq)]
pub struct PllResult {
    pub levels: Vec<PllLevel>,
    /// `(voltage of the failing level, error)`.
    pub failure: Option<(f64, ControlError)>,
}

/// The controller state: current frequency and last phase error.
#[derive(Debug, Clone)]
pub struct PhaseLockedLoop {
    options: PllOptions,
    omega_rad_s: f64,
    last_error_rad: Option<f64>,
}

/// What the phase detector measured over one period.
#[derive(Debug, Clone, PartialEq)]
pub struct PhaseMeasurement {
    pub omega_rad_s: f64,
    pub phase_error_rad: f64,
    pub force_harmonics_n: Vec<Complex64>,
    pub drive_harmonics_m: Vec<Complex64>,
    pub tip_harmonics_m: Vec<Complex64>,
    pub current_amplitude_a: f64,
}

impl PhaseLockedLoop {
    /// A loop starting at `omega_start_rad_s` (e.g. the linear natural frequency).
    pub fn new(options: PllOptions, omega_start_rad_s: f64) -> Result<Self, ControlError> {
        options.validate()?;
        if !(omega_start_rad_s.is_finite() && omega_start_rad_s > 0.0) {
            return Err(ControlError::BadOption {
                name: "omega_start_rad_s",
                value: omega_start_rad_s.to_string(),
                expected: "a positive frequency",
            });
        }
        Ok(Self {
            options,
            omega_rad_s: omega_start_rad_s,
            last_error_rad: None,
        })
    }

    /// Frequency of the next period \[rad/s\].
    pub fn omega_rad_s(&self) -> f64 {
        self.omega_rad_s
    }

    /// Phase error of the last period \[rad\] (`None` before the first):
    /// with [`Self::omega_rad_s`] the loop's whole state.
    pub fn last_phase_error_rad(&self) -> Option<f64> {
        self.last_error_rad
    }

    /// A loop resumed from a saved state ([`Self::omega_rad_s`],
    /// [`Self::last_phase_error_rad`]), e.g. a co-simulation FMU's state.
    pub fn resume(
        options: PllOptions,
        omega_rad_s: f64,
        last_phase_error_rad: Option<f64>,
    ) -> Result<Self, ControlError> {
        let mut pll = Self::new(options, omega_rad_s)?;
        if let Some(e) = last_phase_error_rad.filter(|e| !e.is_finite()) {
            return Err(ControlError::BadOption {
                name: "last_phase_error_rad",
                value: e.to_string(),
                expected: "a finite phase error",
            });
        }
        pll.last_error_rad = last_phase_error_rad;
        Ok(pll)
    }

    /// Runs one period on `plant` at `voltage_v`, measures, and updates the frequency.
    pub fn step(
        &mut self,
        plant: &mut dyn Plant,
        voltage_v: f64,
    ) -> Result<PhaseMeasurement, ControlError> {
        plant.set_excitation(voltage_v, self.omega_rad_s);
        let s = plant.advance_period()?;
        let omega = s.omega_rad_s;
        let PeriodHarmonics {
            force_n: force,
            drive_m: drive,
            tip_m: tip,
            current_amplitude_a: current,
        } = PeriodHarmonics::from_samples(s, self.options.harmonics)?;
        let lag = wrap_angle(force[1].arg() - drive[1].arg());
        let e = wrap_angle(FRAC_PI_2 - lag);
        let o = &self.options;
        let de = self.last_error_rad.map_or(0.0, |p| e - p);
        let limit = o.max_step_ratio;
        let rel = (o.kp * de + o.ki * e).clamp(-limit, limit);
        self.omega_rad_s = omega * (1.0 + rel);
        self.last_error_rad = Some(e);
        Ok(PhaseMeasurement {
            omega_rad_s: omega,
            phase_error_rad: e,
            force_harmonics_n: force,
            drive_harmonics_m: drive,
            tip_harmonics_m: tip,
            current_amplitude_a: current,
        })
    }

    /// Runs one voltage level until settled (or `max_periods_per_level`).
    /// `drive_modal_mass_kg` is `m_d` of the power-balance damping.
    pub fn run_level(
        &mut self,
        plant: &mut dyn Plant,
        voltage_v: f64,
        drive_modal_mass_kg: f64,
    ) -> Result<PllLevel, ControlError> {
        let mut inside = 0;
        let mut last_amp: Option<f64> = None;
        let mut periods = 0;
        loop {
            let m = self.step(plant, voltage_v)?;
            periods += 1;
            let amp = m.drive_harmonics_m[1].norm();
            let change = last_amp.map_or(f64::INFINITY, |p| ((amp - p) / amp).abs());
            last_amp = Some(amp);
            let o = &self.options;
            if m.phase_error_rad.abs() < o.phase_tolerance_rad && change < o.amplitude_tolerance {
                inside += 1;
            } else {
                inside = 0;
            }
            let settled = inside >= o.settle_periods;
            if settled || periods >= o.max_periods_per_level {
                let omega = m.omega_rad_s;
                let harmonics = PeriodHarmonics {
                    force_n: m.force_harmonics_n,
                    drive_m: m.drive_harmonics_m,
                    tip_m: m.tip_harmonics_m,
                    current_amplitude_a: m.current_amplitude_a,
                };
                let power = harmonics.power_w(omega);
                let kinetic: f64 = harmonics
                    .drive_m
                    .iter()
                    .enumerate()
                    .skip(1)
                    .map(|(h, x)| (h as f64 * omega).powi(2) * x.norm_sqr())
                    .sum();
                return Ok(PllLevel {
                    voltage_v,
                    settled,
                    periods,
                    time_s: plant.time_s(),
                    omega_rad_s: omega,
                    phase_error_rad: m.phase_error_rad,
                    amplitude_change: change,
                    damping_ratio: power / (omega * drive_modal_mass_kg * kinetic),
                    power_w: power,
                    harmonics,
                });
            }
        }
    }
}

/// Settled levels the start prediction fits ([`predicted_level_start_rad_s`]).
pub const LEVEL_START_FIT: usize = 3;

/// The level start moves the frequency by at most this many periods' worth of
/// `max_step_ratio` (module docs, "Level start").
pub const LEVEL_START_JUMP_PERIODS: f64 = 25.0;

/// Start frequency \[rad/s\] of a level at `voltage_v` predicted from
/// `settled`, the `(voltage, settled frequency)` of the levels settled so far
/// in order (only the last [`LEVEL_START_FIT`] are used), for a loop started
/// at `omega_start_rad_s` (module docs, "Level start"); `None` where the
/// level should start at the last frequency. The start differs from the last
/// settled frequency by at most the factor `1 +- max_jump_ratio`.
pub fn predicted_level_start_rad_s(
    omega_start_rad_s: f64,
    settled: &[(f64, f64)],
    voltage_v: f64,
    max_jump_ratio: f64,
) -> Option<f64> {
    let pts = &settled[settled.len().saturating_sub(LEVEL_START_FIT)..];
    if pts.len() < 2 || !(omega_start_rad_s > 0.0 && voltage_v > 0.0) {
        return None;
    }
    let sign = (pts[0].1 - omega_start_rad_s).signum();
    let mut xy = [(0.0, 0.0); LEVEL_START_FIT];
    for (k, &(u, w)) in pts.iter().enumerate() {
        let d = w - omega_start_rad_s;
        if !(u > 0.0 && d * sign > 0.0 && w.is_finite()) {
            return None;
        }
        xy[k] = (u.ln(), (d * sign).ln());
    }
    let xy = &xy[..pts.len()];
    // distinct voltages (relative spacing above 1e-6)
    for (i, a) in xy.iter().enumerate() {
        if xy[i + 1..].iter().any(|b| (a.0 - b.0).abs() < 1e-6) {
            return None;
        }
    }
    let x = voltage_v.ln();
    // Lagrange polynomial through the points, at x
    let y: f64 = xy
        .iter()
        .enumerate()
        .map(|(k, &(xk, yk))| {
            yk * xy
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != k)
                .map(|(_, &(xj, _))| (x - xj) / (xk - xj))
                .product::<f64>()
        })
        .sum();
    let last = pts[pts.len() - 1].1;
    let r = max_jump_ratio.clamp(0.0, 0.5);
    let w = (omega_start_rad_s + sign * y.exp()).clamp((1.0 - r) * last, (1.0 + r) * last);
    w.is_finite().then_some(w)
}

/// Phase-resonance test: the [`PhaseLockedLoop`] from `omega_start_rad_s`
/// through the voltage levels `voltages_v` in order, without resetting the
/// plant between levels, each level from the frequency the settled levels
/// before it predict ([`predicted_level_start_rad_s`]). `drive_modal_mass_kg` is the modal mass at the drive
/// point (`1/|phi_d|^2`, mass-normalized linear mode) for the damping.
/// Bad options are an `Err`; a plant failure stops the test and is returned
/// with the levels measured before it.
pub fn phase_resonance(
    plant: &mut dyn Plant,
    omega_start_rad_s: f64,
    voltages_v: &[f64],
    drive_modal_mass_kg: f64,
    options: &PllOptions,
) -> Result<PllResult, ControlError> {
    let mut pll = PhaseLockedLoop::new(options.clone(), omega_start_rad_s)?;
    if !(drive_modal_mass_kg.is_finite() && drive_modal_mass_kg > 0.0) {
        return Err(ControlError::BadOption {
            name: "drive_modal_mass_kg",
            value: drive_modal_mass_kg.to_string(),
            expected: "a positive mass",
        });
    }
    if let Some(v) = voltages_v.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        return Err(ControlError::BadOption {
            name: "voltage_levels_v",
            value: v.to_string(),
            expected: "positive voltage amplitudes",
        });
    }
    let mut levels = Vec::with_capacity(voltages_v.len());
    let mut settled: Vec<(f64, f64)> = Vec::with_capacity(LEVEL_START_FIT + 1);
    for &u in voltages_v {
        if let Some(w) = predicted_level_start_rad_s(
            omega_start_rad_s,
            &settled,
            u,
            LEVEL_START_JUMP_PERIODS * options.max_step_ratio,
        ) {
            pll.omega_rad_s = w;
        }
        match pll.run_level(plant, u, drive_modal_mass_kg) {
            Ok(l) => {
                if l.settled {
                    if settled.len() == LEVEL_START_FIT {
                        settled.remove(0);
                    }
                    settled.push((l.voltage_v, l.omega_rad_s));
                }
                levels.push(l)
            }
            Err(e) => {
                return Ok(PllResult {
                    levels,
                    failure: Some((u, e)),
                })
            }
        }
    }
    Ok(PllResult {
        levels,
        failure: None,
    })
}
