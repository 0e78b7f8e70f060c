//! Force control: a stepped sine whose voltage is adjusted so that the
//! fundamental of the force at the structure (the stinger force) stays at a
//! set value, the way a test holds a constant force level by feedback ("if a
//! constant force level is desired, feedback control can be used", paper
//! Section 5).
//!
//! # Control law
//!
//! At each frequency `Omega_k` of the list the voltage amplitude `U` is held
//! until the response has settled (relative change of `|F_1|` and of the
//! drive-point `|x_1|` from one period to the next below
//! `settle_tolerance` for `settle_periods` consecutive periods); then, if
//! `| |F_1| / F_set - 1 | > force_tolerance`, the voltage is corrected by the
//! secant of the settled steady state,
//!
//! ```text
//! U <- min(U |F_set| / |F_1|, max_voltage_v),
//! ```
//!
//! exact in one correction for a linear structure (the steady force is
//! proportional to `U`), and repeated for a nonlinear one. The next frequency
//! starts from the last voltage. A dwell-and-correct loop rather than a
//! per-period integrator: near resonance the force responds to a voltage step
//! first by the blocked-shaker force and only later, as the structure's
//! response builds up, drops to its steady value (`eq:forcedrop`: 97 % on the
//! paper beam at 2l/3), so a per-period integral gain stable there would be
//! some 30 times too slow elsewhere.
//!
//! A step whose voltage hits `max_voltage_v` is reported as saturated (the
//! force it reached is recorded); one that does not settle within
//! `max_periods_per_step` is recorded as not settled.
use super::{ControlError, PeriodHarmonics, Plant};

/// Tolerances and limits of [`force_controlled_stepped_sine`] and
/// [`super::response_controlled_stepped_sine`]; `Default` gives the
/// documented defaults.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ForceControlOptions {
    /// Relative tolerance on the controlled amplitude (`|F_1|`, or `|x_1|` for
    /// response control) against the set value (default 2e-3).
    pub force_tolerance: f64,
    /// Relative change per period of `|F_1|` and `|x_1|` below which the
    /// response counts as settled (default 1e-4).
    pub settle_tolerance: f64,
    /// Consecutive settled periods required (default 10).
    pub settle_periods: usize,
    /// Periods per frequency before the step is given up (default 5000).
    pub max_periods_per_step: usize,
    /// Voltage limit of the amplifier \[V\] (default unlimited).
    pub max_voltage_v: f64,
    /// Harmonics demodulated and recorded (default 5).
    pub harmonics: usize,
}

impl Default for ForceControlOptions {
    fn default() -> Self {
        Self {
            force_tolerance: 2e-3,
            settle_tolerance: 1e-4,
            settle_periods: 10,
            max_periods_per_step: 5000,
            max_voltage_v: f64::INFINITY,
            harmonics: 5,
        }
    }
}

impl ForceControlOptions {
    /// Checks every option; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ControlError> {
        let bad = |name: &'static str, value: String, expected: &'static str| {
            Err(ControlError::BadOption {
                name,
                value,
                expected,
            })
        };
        for (name, v) in [
            ("force_tolerance", self.force_tolerance),
            ("settle_tolerance", self.settle_tolerance),
        ] {
            if !(v.is_finite() && v > 0.0 && v < 1.0) {
                return bad(name, v.to_string(), "a number in (0, 1)");
            }
        }
        if self.max_voltage_v.is_nan() || self.max_voltage_v <= 0.0 {
            return bad(
                "max_voltage_v",
                self.max_voltage_v.to_string(),
                "a positive voltage (or infinity)",
            );
        }
        for (name, v) in [
            ("settle_periods", self.settle_periods),
            ("max_periods_per_step", self.max_periods_per_step),
            ("harmonics", self.harmonics),
        ] {
            if v == 0 {
                return bad(name, "0".into(), "a positive integer");
            }
        }
        Ok(())
    }
}

/// One frequency step of the force-controlled test.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceStep {
    /// Excitation frequency \[rad/s\].
    pub omega_rad_s: f64,
    /// Voltage amplitude the force needed \[V\].
    pub voltage_v: f64,
    /// Whether the force reached the set value within the tolerance, settled.
    pub settled: bool,
    /// Whether the voltage limit stopped the controller.
    pub saturated: bool,
    /// Periods spent on the step.
    pub periods: usize,
    /// Voltage corrections made on the step.
    pub corrections: usize,
    /// Harmonics of force, drive point, tip and the coil current of the
    /// last period.
    pub harmonics: PeriodHarmonics,
}

/// Result of [`force_controlled_stepped_sine`].
#[derive(Debug, Clone, PartialEq)]
pub struct ForceControlResult {
    pub steps: Vec<ForceStep>,
    /// Largest `| |F_1| / F_set - 1 |` over the steps (the achieved flatness).
    pub flatness: f64,
    /// `(frequency of the failing step, error)`: a plant failure that stopped
    /// the test; the steps before it are kept.
    pub failure: Option<(f64, ControlError)>,
}

/// The amplitude a stepped controller holds at its set value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Controlled {
    /// `|F_1|` of the force at the structure (force control).
    Force,
    /// `|x_1|` of the drive-point displacement (response control).
    Response,
}

impl Controlled {
    pub(crate) fn of(self, h: &PeriodHarmonics) -> f64 {
        match self {
            Controlled::Force => h.force_amplitude_n(),
            Controlled::Response => h.drive_amplitude_m(),
        }
    }
    fn set_name(self) -> &'static str {
        match self {
            Controlled::Force => "force_set_n",
            Controlled::Response => "response_set_m",
        }
    }
}

/// Force-controlled stepped sine through `omegas_rad_s` (in the given order,
/// up or down) at the set force amplitude `force_set_n`, starting at the
/// voltage `voltage_start_v` (see the module docs).
pub fn force_controlled_stepped_sine(
    plant: &mut dyn Plant,
    omegas_rad_s: &[f64],
    force_set_n: f64,
    voltage_start_v: f64,
    options: &ForceControlOptions,
) -> Result<ForceControlResult, ControlError> {
    stepped_sine(
        plant,
        omegas_rad_s,
        Controlled::Force,
        force_set_n,
        voltage_start_v,
        options,
    )
}

/// The dwell-and-correct stepped sine holding `quantity` at `set`.
pub(crate) fn stepped_sine(
    plant: &mut dyn Plant,
    omegas_rad_s: &[f64],
    quantity: Controlled,
    set: f64,
    voltage_start_v: f64,
    options: &ForceControlOptions,
) -> Result<ForceControlResult, ControlError> {
    options.validate()?;
    let positive = super::positive_option;
    positive(quantity.set_name(), set)?;
    positive("voltage_start_v", voltage_start_v)?;
    for &w in omegas_rad_s {
        positive("omegas_rad_s", w)?;
    }
    let o = options;
    let mut u = voltage_start_v.min(o.max_voltage_v);
    let mut steps = Vec::with_capacity(omegas_rad_s.len());
    for &w in omegas_rad_s {
        match controlled_step(plant, w, quantity, set, &mut u, o) {
            Ok(s) => steps.push(s),
            Err(e) => {
                return Ok(ForceControlResult {
                    flatness: flatness(&steps, quantity, set),
                    steps,
                    failure: Some((w, e)),
                })
            }
        }
    }
    Ok(ForceControlResult {
        flatness: flatness(&steps, quantity, set),
        steps,
        failure: None,
    })
}

fn flatness(steps: &[ForceStep], quantity: Controlled, set: f64) -> f64 {
    steps
        .iter()
        .map(|s| (quantity.of(&s.harmonics) / set - 1.0).abs())
        .fold(0.0, f64::max)
}

fn controlled_step(
    plant: &mut dyn Plant,
    omega: f64,
    quantity: Controlled,
    set: f64,
    u: &mut f64,
    o: &ForceControlOptions,
) -> Result<ForceStep, ControlError> {
    let h = o.harmonics;
    let (mut periods, mut corrections, mut inside) = (0, 0, 0);
    let mut last: Option<(f64, f64)> = None;
    loop {
        plant.set_excitation(*u, omega);
        let s = plant.advance_period()?;
        periods += 1;
        let harmonics = PeriodHarmonics::from_samples(s, h)?;
        let (f1, x1) = (harmonics.force_amplitude_n(), harmonics.drive_amplitude_m());
        let settled_now = last.is_some_and(|(fp, xp)| {
            ((f1 - fp) / f1).abs() < o.settle_tolerance
                && ((x1 - xp) / x1).abs() < o.settle_tolerance
        });
        last = Some((f1, x1));
        inside = if settled_now { inside + 1 } else { 0 };
        let give_up = periods >= o.max_periods_per_step;
        if inside >= o.settle_periods || give_up {
            let y = quantity.of(&harmonics);
            let on_target = (y / set - 1.0).abs() <= o.force_tolerance;
            let next = (*u * set / y).min(o.max_voltage_v);
            let saturated = !on_target && next >= o.max_voltage_v && *u >= o.max_voltage_v;
            if on_target || saturated || give_up {
                return Ok(ForceStep {
                    omega_rad_s: omega,
                    voltage_v: *u,
                    settled: on_target && !give_up,
                    saturated,
                    periods,
                    corrections,
                    harmonics,
                });
            }
            *u = next;
            corrections += 1;
            inside = 0;
            last = None;
        }
    }
}
