//! The phase-locked loop of [`super::pll`] stepped in time, for a
//! co-simulation master (the controller FMU of issue 16): it is given the
//! measured force at the structure and the drive-point displacement at each
//! communication point instead of one excitation period at a time.
//!
//! # Phase and output
//!
//! ```text
//! theta' = Omega,   theta(t_0) = 0,   u_ext = u_hat cos(theta),   u_ext' = -u_hat Omega sin(theta),
//! ```
//!
//! `Omega` constant within an excitation period. A period ends at the first
//! communication point where `theta >= 2 pi`; the loop then updates `Omega`
//! by the PI law of [`PhaseLockedLoop::step`] and `theta` goes on from
//! `theta - 2 pi` (phase continuous, like the period-based plant where each
//! period starts at phase 0).
//!
//! # Demodulation
//!
//! The communication points `t_n` may have any spacing (at most
//! `2 pi / (MIN_STEPS_PER_PERIOD Omega)`). Each signal of the running period
//! is resampled at the `N` uniform phases `theta_i = 2 pi i / N` by linear
//! interpolation between the neighbouring communication points (`Omega` is
//! constant between them, so linear in phase is linear in time; the error is
//! about `(Omega h)^2 / 8` of the amplitude, 1.6e-6 at `h = 1e-5 s`,
//! `Omega = 356 rad/s`). The completed period is then exactly a period of
//! [`super::PeriodSamples`]: the same harmonics ([`super::period_harmonics`],
//! module docs of [`super`]), phase detector and PI update, through
//! [`PhaseLockedLoop::step`] on a plant that replays it.
//!
//! # Any communication step
//!
//! [`StreamingPll::step`] takes one communication step of any length: the
//! sample at its start is held (zero-order hold) over internal steps of at
//! most `2 pi / (MIN_STEPS_PER_PERIOD Omega)`, each one
//! [`StreamingPll::measure`] and [`StreamingPll::advance`]. A step within
//! that limit is exactly one `measure` and one `advance`, so a master at
//! about 100 or more points per period sees no difference; at fewer points
//! the held inputs are the only signal the loop has, and its measurement is
//! correspondingly coarse (a master that wants the loop's accuracy steps at
//! 100 or more points per period).
//!
//! # Periods without signal
//!
//! A period whose force or drive-point fundamental is zero (all inputs 0:
//! the exciter or the sensors are not on yet), whose phase error or damping
//! is not a finite number, or that got fewer than
//! [`MIN_SAMPLES_TO_MEASURE`] samples from the master (a communication step
//! of more than a quarter period: held inputs carry no phase) has no phase
//! to measure. The loop then
//! holds: the frequency, the record of the last measured period and the
//! settle bookkeeping stay as they were, the period is not counted, and the
//! output goes on at the held frequency ([`StreamEvent::Unmeasured`],
//! [`StreamingPll::unmeasured_periods`]). The first period with signal
//! continues the loop as if the held ones had not been.
//!
//! # Levels and settle criterion
//!
//! A new voltage amplitude ([`StreamingPll::set_voltage`]) applies from the
//! next period start and starts a new level. The settle criterion is
//! [`PhaseLockedLoop::run_level`]'s: `settle_periods` consecutive periods with
//! `|e| < phase_tolerance_rad` and a relative change of `|X_1|` below
//! `amplitude_tolerance`; the level is done (latched until the next voltage)
//! when settled or after `max_periods_per_level` periods. The loop keeps
//! tracking after that; [`StreamingPll::last_period`] is the record of the
//! last completed period (a [`PllLevel`] with the power-balance damping of
//! [`super::pll`]). A new level starts at the frequency the settled levels
//! before it predict, as in [`super::phase_resonance`] (module docs of
//! [`super::pll`], "Level start").
use super::pll::{predicted_level_start_rad_s, LEVEL_START_FIT, LEVEL_START_JUMP_PERIODS};
use super::{
    mean_power_w, ControlError, PeriodHarmonics, PeriodSamples, PhaseLockedLoop, PhaseMeasurement,
    Plant, PllLevel, PllOptions,
};
use std::f64::consts::TAU;

/// Fewest communication points per excitation period (`Omega h <= 2 pi / 8`).
pub const MIN_STEPS_PER_PERIOD: f64 = 8.0;
/// Most uniform phases `N` per period of the demodulation.
pub const MAX_SAMPLES_PER_PERIOD: usize = 1000;
/// Fewest samples from the master ([`StreamingPll::measure`], or the first
/// of a [`StreamingPll::step`]) in a period for it to be measured (module
/// docs, "Periods without signal"); 8 or more at the steps
/// [`StreamingPll::advance`] accepts.
pub const MIN_SAMPLES_TO_MEASURE: usize = 4;
/// Most internal steps of one [`StreamingPll::step`] (about 2.2e4 s of
/// excitation at 356 rad/s); a longer communication step is refused.
pub const MAX_INTERNAL_STEPS: f64 = 1e7;

/// The measured signals at one communication point.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StreamSample {
    /// Force on the structure at the drive point \[N\] (the force sensor's).
    pub force_n: f64,
    /// Drive-point displacement \[m\].
    pub drive_m: f64,
    /// Response-point (tip) displacement \[m\] (recorded only; 0 if not measured).
    pub tip_m: f64,
    /// Coil current \[A\] (recorded only; 0 if not measured).
    pub current_a: f64,
}

impl StreamSample {
    fn values(&self) -> [f64; 4] {
        [self.force_n, self.drive_m, self.tip_m, self.current_a]
    }
}

/// What [`StreamingPll::measure`] did with a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StreamEvent {
    /// The sample lies inside the running period.
    Sampled,
    /// The sample completed a period (the frequency was updated).
    PeriodEnd,
    /// The sample completed the period that finished the level (settled or
    /// out of periods).
    LevelDone,
    /// The sample completed a period without a measurable fundamental (module
    /// docs, "Periods without signal"): frequency and record held.
    Unmeasured,
}

impl StreamEvent {
    /// Order of importance when one communication step holds several events.
    fn rank(self) -> u8 {
        match self {
            StreamEvent::Sampled => 0,
            StreamEvent::Unmeasured => 1,
            StreamEvent::PeriodEnd => 2,
            StreamEvent::LevelDone => 3,
        }
    }
}

/// A completed period and the loop's bookkeeping at its end.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct Completed {
    /// `[force, drive, tip, current]` at the `N` uniform phases.
    grid: [Vec<f64>; 4],
    omega_rad_s: f64,
    voltage_v: f64,
    /// The loop's last phase error before this period (replay of the update).
    error_before_rad: Option<f64>,
    periods: usize,
    /// `None`: the level's first period (infinite change; JSON has no infinity).
    amplitude_change: Option<f64>,
    settled: bool,
    time_s: f64,
}

/// The time-stepped phase-locked loop (module docs).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct StreamingPll {
    options: PllOptions,
    drive_modal_mass_kg: f64,
    samples_per_period: usize,
    omega_rad_s: f64,
    last_error_rad: Option<f64>,
    voltage_v: f64,
    pending_voltage_v: Option<f64>,
    /// Phase since the running period's start \[rad\].
    theta_rad: f64,
    /// Time of the last sample \[s\].
    time_s: f64,
    /// The last sample and its phase.
    prev: Option<(f64, StreamSample)>,
    grid: [Vec<f64>; 4],
    /// Next uniform phase index to fill.
    next_index: usize,
    periods: usize,
    inside: usize,
    last_amplitude_m: Option<f64>,
    level_done: bool,
    completed: Option<Completed>,
    /// The loop's start frequency \[rad/s\] (0 in a state saved before the
    /// level-start prediction: no prediction).
    #[serde(default)]
    omega_start_rad_s: f64,
    /// `(voltage, frequency)` of the last settled levels (at most
    /// [`LEVEL_START_FIT`]), for the next level's start
    /// ([`predicted_level_start_rad_s`]).
    #[serde(default)]
    settled_levels: Vec<(f64, f64)>,
    /// Consecutive periods without signal up to now (module docs).
    #[serde(default)]
    unmeasured_periods: usize,
    /// Samples from the master in the running period (a state saved before
    /// this count: taken as enough).
    #[serde(default = "enough_samples")]
    fresh_samples: usize,
    /// [`Self::last_period`], rebuilt from `completed` (not serialized).
    #[serde(skip)]
    record: Option<PllLevel>,
}

/// Replays one completed period to [`PhaseLockedLoop::step`].
struct Replay<'a> {
    samples: &'a PeriodSamples,
    time_s: f64,
}

impl Plant for Replay<'_> {
    fn set_excitation(&mut self, _voltage_v: f64, _omega_rad_s: f64) {}
    fn advance_period(&mut self) -> Result<&PeriodSamples, ControlError> {
        Ok(self.samples)
    }
    fn time_s(&self) -> f64 {
        self.time_s
    }
}

fn bad(name: &'static str, value: impl ToString, expected: &'static str) -> ControlError {
    ControlError::BadOption {
        name,
        value: value.to_string(),
        expected,
    }
}

impl StreamingPll {
    /// A loop at `omega_start_rad_s`, phase 0, with voltage amplitude
    /// `voltage_v` (`>= 0`); `drive_modal_mass_kg` is `m_d` of the
    /// power-balance damping, `samples_per_period` the demodulation's `N`
    /// (`2 (harmonics + 1) ..= MAX_SAMPLES_PER_PERIOD`).
    pub fn new(
        options: PllOptions,
        omega_start_rad_s: f64,
        voltage_v: f64,
        drive_modal_mass_kg: f64,
        samples_per_period: usize,
    ) -> Result<Self, ControlError> {
        PhaseLockedLoop::new(options.clone(), omega_start_rad_s)?;
        check_voltage(voltage_v)?;
        if !(drive_modal_mass_kg.is_finite() && drive_modal_mass_kg > 0.0) {
            return Err(bad(
                "drive_modal_mass_kg",
                drive_modal_mass_kg,
                "a positive mass",
            ));
        }
        if samples_per_period < 2 * (options.harmonics + 1)
            || samples_per_period > MAX_SAMPLES_PER_PERIOD
        {
            return Err(bad(
                "samples_per_period",
                samples_per_period,
                "2 (harmonics + 1) ..= 1000",
            ));
        }
        Ok(Self {
            options,
            drive_modal_mass_kg,
            samples_per_period,
            omega_rad_s: omega_start_rad_s,
            last_error_rad: None,
            voltage_v,
            pending_voltage_v: None,
            theta_rad: 0.0,
            time_s: 0.0,
            prev: None,
            grid: std::array::from_fn(|_| Vec::with_capacity(samples_per_period)),
            next_index: 0,
            periods: 0,
            inside: 0,
            last_amplitude_m: None,
            level_done: false,
            completed: None,
            omega_start_rad_s,
            settled_levels: Vec::with_capacity(LEVEL_START_FIT),
            unmeasured_periods: 0,
            fresh_samples: 0,
            record: None,
        })
    }

    /// Frequency of the running period \[rad/s\].
    pub fn omega_rad_s(&self) -> f64 {
        self.omega_rad_s
    }
    /// Phase within the running period, `[0, 2 pi)` between steps \[rad\].
    pub fn phase_rad(&self) -> f64 {
        self.theta_rad
    }
    /// Voltage amplitude of the running period \[V\].
    pub fn voltage_v(&self) -> f64 {
        self.voltage_v
    }
    /// The voltage applied from the next period, if one was set.
    pub fn pending_voltage_v(&self) -> Option<f64> {
        self.pending_voltage_v
    }
    /// Output `u_ext = u_hat cos(theta)` \[V\].
    pub fn output_v(&self) -> f64 {
        self.voltage_v * self.theta_rad.cos()
    }
    /// `d u_ext / dt = -u_hat Omega sin(theta)` \[V/s\].
    pub fn output_rate_v_per_s(&self) -> f64 {
        -self.voltage_v * self.omega_rad_s * self.theta_rad.sin()
    }
    /// Periods completed on the running level.
    pub fn periods(&self) -> usize {
        self.periods
    }
    /// Whether the running level is done (settled or out of periods).
    pub fn level_done(&self) -> bool {
        self.level_done
    }
    /// Whether the last completed period met the settle criterion.
    pub fn settled(&self) -> bool {
        self.completed.as_ref().is_some_and(|c| c.settled)
    }
    /// The record of the last completed period (`None` before the first).
    pub fn last_period(&self) -> Option<&PllLevel> {
        self.record.as_ref()
    }
    /// Consecutive periods without signal that ended last (0 once a period
    /// with signal ends; module docs, "Periods without signal").
    pub fn unmeasured_periods(&self) -> usize {
        self.unmeasured_periods
    }
    /// Longest internal step at the running frequency,
    /// `2 pi / (MIN_STEPS_PER_PERIOD Omega)` \[s\].
    pub fn max_internal_step_s(&self) -> f64 {
        TAU / (MIN_STEPS_PER_PERIOD * self.omega_rad_s)
    }

    /// Sets the voltage amplitude of the next level \[V\] (from the next
    /// period start); [`Self::level_done`] is false from now until the new
    /// level is done.
    pub fn set_voltage(&mut self, voltage_v: f64) -> Result<(), ControlError> {
        check_voltage(voltage_v)?;
        self.pending_voltage_v = Some(voltage_v);
        // the old level is over: `level_done` now waits for the new one
        self.level_done = false;
        Ok(())
    }

    /// Takes the measured signals at time `t_s`, the phase reached by the
    /// last [`Self::advance`] (the first sample starts the period at phase 0).
    pub fn measure(&mut self, t_s: f64, s: StreamSample) -> Result<StreamEvent, ControlError> {
        self.sample(t_s, s, true)
    }

    /// [`Self::measure`]; `fresh`: a sample from the master (else one held
    /// over an internal step of [`Self::step`]).
    fn sample(
        &mut self,
        t_s: f64,
        s: StreamSample,
        fresh: bool,
    ) -> Result<StreamEvent, ControlError> {
        if !t_s.is_finite() || s.values().iter().any(|v| !v.is_finite()) {
            return Err(bad(
                "measured signals",
                format!("{s:?} at t = {t_s} s"),
                "finite values",
            ));
        }
        self.time_s = t_s;
        if fresh {
            self.fresh_samples += 1;
        }
        let th = self.theta_rad;
        let Some((th0, s0)) = self.prev else {
            // the first sample: the period starts here at phase 0
            self.push_until(th, None, (th, s));
            self.prev = Some((th, s));
            return Ok(StreamEvent::Sampled);
        };
        self.push_until(th.min(TAU), Some((th0, s0)), (th, s));
        let mut event = StreamEvent::Sampled;
        if th >= TAU {
            event = self.end_period()?;
            // the sample that ends a period also starts the next
            self.fresh_samples = usize::from(fresh);
            self.theta_rad = th - TAU;
            self.next_index = 0;
            // the new period's first phases lie between the two samples
            self.push_until(self.theta_rad, Some((th0 - TAU, s0)), (self.theta_rad, s));
        }
        self.prev = Some((self.theta_rad, s));
        Ok(event)
    }

    /// Fills the uniform phases up to `upto` (inclusive) by linear
    /// interpolation between `from` and `to` (or with `to` alone).
    fn push_until(
        &mut self,
        upto: f64,
        from: Option<(f64, StreamSample)>,
        to: (f64, StreamSample),
    ) {
        let n = self.samples_per_period;
        while self.next_index < n {
            let phi = TAU * self.next_index as f64 / n as f64;
            if phi > upto {
                break;
            }
            let (th1, s1) = to;
            let v1 = s1.values();
            let v = match from {
                Some((th0, s0)) if th1 > th0 => {
                    let w = (phi - th0) / (th1 - th0);
                    let v0 = s0.values();
                    std::array::from_fn::<f64, 4, _>(|k| v0[k] + w * (v1[k] - v0[k]))
                }
                _ => v1,
            };
            for (g, x) in self.grid.iter_mut().zip(v) {
                g.push(x);
            }
            self.next_index += 1;
        }
    }

    /// The completed period through the loop, the settle bookkeeping and the
    /// voltage of the next level.
    fn end_period(&mut self) -> Result<StreamEvent, ControlError> {
        let grid = std::mem::replace(
            &mut self.grid,
            std::array::from_fn(|_| Vec::with_capacity(self.samples_per_period)),
        );
        let mut c = Completed {
            grid,
            omega_rad_s: self.omega_rad_s,
            voltage_v: self.voltage_v,
            error_before_rad: self.last_error_rad,
            periods: self.periods + 1,
            amplitude_change: None,
            settled: false,
            time_s: self.time_s,
        };
        if self.fresh_samples < MIN_SAMPLES_TO_MEASURE {
            return Ok(self.hold_period());
        }
        let (m, pll) = self.replay(&c)?;
        if !self.measurable(&m) {
            return Ok(self.hold_period());
        }
        self.unmeasured_periods = 0;
        self.omega_rad_s = pll.omega_rad_s();
        self.last_error_rad = pll.last_phase_error_rad();
        // the settle criterion of PhaseLockedLoop::run_level
        self.periods += 1;
        let amp = m.drive_harmonics_m[1].norm();
        let change = self
            .last_amplitude_m
            .map_or(f64::INFINITY, |p| ((amp - p) / amp).abs());
        self.last_amplitude_m = Some(amp);
        let o = &self.options;
        if m.phase_error_rad.abs() < o.phase_tolerance_rad && change < o.amplitude_tolerance {
            self.inside += 1;
        } else {
            self.inside = 0;
        }
        c.amplitude_change = Some(change).filter(|c| c.is_finite());
        c.settled = self.inside >= o.settle_periods;
        let finished = self.pending_voltage_v.is_none()
            && !self.level_done
            && (c.settled || self.periods >= o.max_periods_per_level);
        self.level_done |= finished;
        if finished && c.settled {
            if self.settled_levels.len() >= LEVEL_START_FIT {
                self.settled_levels.remove(0);
            }
            self.settled_levels.push((c.voltage_v, c.omega_rad_s));
        }
        self.record = Some(self.level_record(&c, m));
        self.completed = Some(c);
        if let Some(v) = self.pending_voltage_v.take() {
            if let Some(w) = predicted_level_start_rad_s(
                self.omega_start_rad_s,
                &self.settled_levels,
                v,
                LEVEL_START_JUMP_PERIODS * self.options.max_step_ratio,
            ) {
                self.omega_rad_s = w;
            }
            self.voltage_v = v;
            self.periods = 0;
            self.inside = 0;
            self.last_amplitude_m = None;
            self.level_done = false;
        }
        Ok(if finished {
            StreamEvent::LevelDone
        } else {
            StreamEvent::PeriodEnd
        })
    }

    /// Whether a completed period has a phase and a damping to measure: force
    /// and drive-point fundamentals non-zero, phase error and power-balance
    /// damping finite.
    fn measurable(&self, m: &PhaseMeasurement) -> bool {
        let (f1, x1) = (m.force_harmonics_n[1].norm(), m.drive_harmonics_m[1].norm());
        let (_, damping) = self.power_and_damping(m);
        f1 > 0.0
            && x1 > 0.0
            && f1.is_finite()
            && x1.is_finite()
            && m.phase_error_rad.is_finite()
            && damping.is_finite()
    }

    /// A period without signal: nothing of the loop changes but the count of
    /// such periods, and a voltage set meanwhile applies from the next period.
    fn hold_period(&mut self) -> StreamEvent {
        self.unmeasured_periods += 1;
        if let Some(v) = self.pending_voltage_v.take() {
            self.voltage_v = v;
            self.periods = 0;
            self.inside = 0;
            self.last_amplitude_m = None;
            self.level_done = false;
        }
        StreamEvent::Unmeasured
    }

    /// Mean power and power-balance damping of a measured period (module docs
    /// of [`super::pll`]).
    fn power_and_damping(&self, m: &PhaseMeasurement) -> (f64, f64) {
        let omega = m.omega_rad_s;
        let power = mean_power_w(&m.force_harmonics_n, &m.drive_harmonics_m, omega);
        let kinetic: f64 = m
            .drive_harmonics_m
            .iter()
            .enumerate()
            .skip(1)
            .map(|(h, x)| (h as f64 * omega).powi(2) * x.norm_sqr())
            .sum();
        (power, power / (omega * self.drive_modal_mass_kg * kinetic))
    }

    /// [`PhaseLockedLoop::step`] on the completed period, from the loop's
    /// state before it.
    fn replay(&self, c: &Completed) -> Result<(PhaseMeasurement, PhaseLockedLoop), ControlError> {
        let samples = PeriodSamples {
            omega_rad_s: c.omega_rad_s,
            voltage_v: c.voltage_v,
            force_n: c.grid[0].clone(),
            drive_m: c.grid[1].clone(),
            tip_m: c.grid[2].clone(),
            current_a: c.grid[3].clone(),
        };
        let mut pll =
            PhaseLockedLoop::resume(self.options.clone(), c.omega_rad_s, c.error_before_rad)?;
        let m = pll.step(
            &mut Replay {
                samples: &samples,
                time_s: c.time_s,
            },
            c.voltage_v,
        )?;
        Ok((m, pll))
    }

    /// The record of a completed period (the damping of `super::pll`'s
    /// power balance, as [`PhaseLockedLoop::run_level`] records it).
    fn level_record(&self, c: &Completed, m: PhaseMeasurement) -> PllLevel {
        let omega = m.omega_rad_s;
        let (power, damping_ratio) = self.power_and_damping(&m);
        PllLevel {
            voltage_v: c.voltage_v,
            settled: c.settled,
            periods: c.periods,
            time_s: c.time_s,
            omega_rad_s: omega,
            phase_error_rad: m.phase_error_rad,
            amplitude_change: c.amplitude_change.unwrap_or(f64::INFINITY),
            damping_ratio,
            power_w: power,
            harmonics: PeriodHarmonics {
                force_n: m.force_harmonics_n,
                drive_m: m.drive_harmonics_m,
                tip_m: m.tip_harmonics_m,
                current_amplitude_a: m.current_amplitude_a,
            },
        }
    }

    /// Advances the phase by `Omega h_s` to the next communication point.
    /// Refuses a step longer than `2 pi / (MIN_STEPS_PER_PERIOD Omega)`.
    pub fn advance(&mut self, h_s: f64) -> Result<(), ControlError> {
        let max = TAU / (MIN_STEPS_PER_PERIOD * self.omega_rad_s);
        if !(h_s.is_finite() && h_s > 0.0 && h_s <= max) {
            return Err(ControlError::BadOption {
                name: "communication step h",
                value: format!("{h_s:e} s at Omega = {} rad/s", self.omega_rad_s),
                expected: "0 < h <= 2 pi / (8 Omega): at least 8 communication points per excitation period",
            });
        }
        self.theta_rad += self.omega_rad_s * h_s;
        Ok(())
    }

    /// One communication step from `t_s` to `t_s + h_s` of any length `h_s >
    /// 0`, with the sample `s` taken at `t_s` and held over the step (module
    /// docs, "Any communication step"); returns the most important event of
    /// the step (level done, period end, period without signal, sampled).
    /// Refuses a step that needs more than [`MAX_INTERNAL_STEPS`] internal
    /// steps. On an error the loop may be partly advanced: step a copy.
    pub fn step(
        &mut self,
        t_s: f64,
        h_s: f64,
        s: StreamSample,
    ) -> Result<StreamEvent, ControlError> {
        self.step_with(t_s, h_s, s, false).map(|(e, _)| e)
    }

    /// [`Self::step`] that stops at a level change inside the step (the
    /// stop hook of an FMI 3.0 early return): when an internal sample after
    /// the step's start (a held one, `t_s < t < t_s + h_s`) completes the
    /// period that finishes the level ([`StreamEvent::LevelDone`]) or starts
    /// a new level (a voltage set by [`Self::set_voltage`] applies from that
    /// period start, so the output's amplitude steps there), the loop stops
    /// right after that sample and returns its time `t`: the loop is then in
    /// the state a step from `t_s` to `t` ending at that period end would
    /// leave. The next step from `t` samples the master's inputs at `t`
    /// again (a sample at the phase of the last one only replaces it as the
    /// anchor of the interpolation, [`Self::measure`]). A change at the
    /// step's first sample (`t = t_s`, a communication point already) does
    /// not stop it, so a step of at most `2 pi / (8 Omega)` (one sample) is
    /// exactly [`Self::step`].
    pub fn step_to_level_change(
        &mut self,
        t_s: f64,
        h_s: f64,
        s: StreamSample,
    ) -> Result<(StreamEvent, Option<f64>), ControlError> {
        self.step_with(t_s, h_s, s, true)
    }

    /// [`Self::step`] (`stop = false`) or [`Self::step_to_level_change`].
    fn step_with(
        &mut self,
        t_s: f64,
        h_s: f64,
        s: StreamSample,
        stop: bool,
    ) -> Result<(StreamEvent, Option<f64>), ControlError> {
        let too_long = |pll: &Self| ControlError::BadOption {
            name: "communication step h",
            value: format!("{h_s:e} s at Omega = {} rad/s", pll.omega_rad_s),
            expected: "0 < h, at most 1e7 internal steps of 2 pi / (8 Omega) \
                       (the loop holds the inputs over internal steps of at most 1/8 period)",
        };
        if !(h_s.is_finite() && h_s > 0.0) {
            return Err(ControlError::BadOption {
                name: "communication step h",
                value: format!("{h_s:e} s"),
                expected: "a finite step h > 0",
            });
        }
        // the frequency changes by at most max_step_ratio < 0.5 per period
        if h_s / self.max_internal_step_s() > MAX_INTERNAL_STEPS / 2.0 {
            return Err(too_long(self));
        }
        let mut event = StreamEvent::Sampled;
        let (mut t, mut rest) = (t_s, h_s);
        let mut steps = 0.0;
        loop {
            // the sample is the master's at the first internal step, held after it
            let pending = self.pending_voltage_v.is_some();
            let e = self.sample(t, s, steps == 0.0)?;
            if e.rank() > event.rank() {
                event = e;
            }
            let level_change =
                e == StreamEvent::LevelDone || (pending && self.pending_voltage_v.is_none());
            if stop && steps > 0.0 && level_change {
                return Ok((event, Some(t)));
            }
            let max = self.max_internal_step_s();
            if rest <= max {
                self.advance(rest)?;
                return Ok((event, None));
            }
            steps += 1.0;
            if steps > MAX_INTERNAL_STEPS {
                return Err(too_long(self));
            }
            // equal internal steps over what is left, each at most `max`
            let sub = (rest / (rest / max).ceil()).min(max);
            self.advance(sub)?;
            t += sub;
            rest -= sub;
        }
    }

    /// Checks a deserialized loop (lengths, ranges, finiteness) and rebuilds
    /// its record; the error names the first inconsistency.
    pub fn restored(mut self) -> Result<Self, ControlError> {
        let n = self.samples_per_period;
        Self::new(
            self.options.clone(),
            self.omega_rad_s,
            self.voltage_v,
            self.drive_modal_mass_kg,
            n,
        )?;
        let finite = |x: f64| x.is_finite();
        let ok = finite(self.theta_rad)
            && (0.0..TAU + TAU / MIN_STEPS_PER_PERIOD).contains(&self.theta_rad)
            && finite(self.time_s)
            && self.last_error_rad.is_none_or(finite)
            && self
                .pending_voltage_v
                .is_none_or(|v| check_voltage(v).is_ok())
            && self.last_amplitude_m.is_none_or(finite)
            && self.next_index <= n
            && self
                .grid
                .iter()
                .all(|g| g.len() == self.next_index && g.iter().all(|x| x.is_finite()))
            && self
                .prev
                .is_none_or(|(t, s)| t.is_finite() && s.values().iter().all(|x| x.is_finite()))
            && self.omega_start_rad_s.is_finite()
            && self.omega_start_rad_s >= 0.0
            && self.settled_levels.len() <= LEVEL_START_FIT
            && self
                .settled_levels
                .iter()
                .all(|&(u, w)| u.is_finite() && w.is_finite())
            && self.completed.as_ref().is_none_or(|c| {
                c.grid
                    .iter()
                    .all(|g| g.len() == n && g.iter().all(|x| x.is_finite()))
            });
        if !ok {
            return Err(bad(
                "streaming PLL state",
                "inconsistent",
                "a state saved by StreamingPll",
            ));
        }
        self.record = match &self.completed {
            Some(c) => {
                let (m, _) = self.replay(c)?;
                Some(self.level_record(c, m))
            }
            None => None,
        };
        Ok(self)
    }
}

fn enough_samples() -> usize {
    MIN_SAMPLES_TO_MEASURE
}

fn check_voltage(v: f64) -> Result<(), ControlError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(bad("voltage_v", v, "a voltage amplitude >= 0"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::phase_resonance;

    /// `m x'' + c x' + k x + k3 x^3 = g u(t)`: the Duffing oscillator of the
    /// PLL tests (`m = 1 kg`, `omega0 = 356 rad/s`, `D = 1 %`, `k3 = 1e10
    /// N/m^3`) under a force proportional to the voltage (`g = 2 N/V`),
    /// integrated by RK4.
    #[derive(Clone)]
    struct Duffing {
        z: [f64; 2],
        t: f64,
        samples: PeriodSamples,
        excitation: (f64, f64),
    }

    const M: f64 = 1.0;
    const W0: f64 = 356.0;
    const C: f64 = 2.0 * 0.01 * M * W0;
    const K3: f64 = 1e10;
    const G: f64 = 2.0;
    const N: usize = 40;

    impl Duffing {
        fn new() -> Self {
            Self {
                z: [0.0; 2],
                t: 0.0,
                samples: PeriodSamples::default(),
                excitation: (0.0, W0),
            }
        }
        fn rate(z: [f64; 2], f: f64) -> [f64; 2] {
            let (x, v) = (z[0], z[1]);
            [v, (f - C * v - M * W0 * W0 * x - K3 * x * x * x) / M]
        }
        /// One RK4 step of `h` under the force `f(s)`, `s` from the step start.
        fn rk4(&mut self, h: f64, f: impl Fn(f64) -> f64) {
            let z = self.z;
            let add = |a: [f64; 2], b: [f64; 2], s: f64| [a[0] + s * b[0], a[1] + s * b[1]];
            let k1 = Self::rate(z, f(0.0));
            let k2 = Self::rate(add(z, k1, h / 2.0), f(h / 2.0));
            let k3 = Self::rate(add(z, k2, h / 2.0), f(h / 2.0));
            let k4 = Self::rate(add(z, k3, h), f(h));
            for i in 0..2 {
                self.z[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            self.t += h;
        }
    }

    /// The period-based plant: `N` samples, sub-steps of at most 1e-5 s.
    impl Plant for Duffing {
        fn set_excitation(&mut self, voltage_v: f64, omega_rad_s: f64) {
            self.excitation = (voltage_v, omega_rad_s);
        }
        fn advance_period(&mut self) -> Result<&PeriodSamples, ControlError> {
            let (u, w) = self.excitation;
            let dt = TAU / w / N as f64;
            let sub = (dt / 1e-5).ceil() as usize;
            let hs = dt / sub as f64;
            let mut s = PeriodSamples {
                omega_rad_s: w,
                voltage_v: u,
                ..Default::default()
            };
            for i in 0..N {
                s.force_n.push(G * u * (TAU * i as f64 / N as f64).cos());
                s.drive_m.push(self.z[0]);
                s.tip_m.push(self.z[0]);
                for j in 0..sub {
                    let t0 = i as f64 * dt + j as f64 * hs;
                    self.rk4(hs, |s| G * u * (w * (t0 + s)).cos());
                }
            }
            self.samples = s;
            Ok(&self.samples)
        }
        fn time_s(&self) -> f64 {
            self.t
        }
    }

    /// The streaming loop on the same oscillator at a fixed communication
    /// step `h` (voltage extrapolated linearly over a step, as a master with
    /// output derivatives does); returns the record of each level.
    fn streamed(volts: &[f64], h: f64, opts: &PllOptions) -> Vec<PllLevel> {
        let mut plant = Duffing::new();
        let mut pll = StreamingPll::new(opts.clone(), W0, volts[0], M, N).unwrap();
        let mut levels = Vec::new();
        let mut n = 0u64;
        while levels.len() < volts.len() {
            let t = n as f64 * h;
            let s = StreamSample {
                force_n: G * pll.output_v(),
                drive_m: plant.z[0],
                tip_m: plant.z[0],
                current_a: 0.0,
            };
            if pll.measure(t, s).unwrap() == StreamEvent::LevelDone {
                levels.push(pll.last_period().unwrap().clone());
                if let Some(&v) = volts.get(levels.len()) {
                    pll.set_voltage(v).unwrap();
                }
            }
            let (u, du) = (pll.output_v(), pll.output_rate_v_per_s());
            pll.advance(h).unwrap();
            plant.rk4(h, |s| G * (u + du * s));
            n += 1;
            assert!(n < 50_000_000, "no end");
        }
        levels
    }

    /// Measured (test profile, 2 and 6 V): the streamed loop settles in the
    /// same number of periods (216, 483) as the period-based one, within
    /// 1.1e-6 in frequency, 1e-6 in `|x_1|`, 5e-6 in damping and 2e-6 in
    /// `|F_1|`.
    #[test]
    fn streaming_loop_settles_where_the_period_based_loop_does() {
        // the third level starts at the frequency the first two predict
        let volts = [2.0, 4.0, 6.0];
        let opts = PllOptions::default();
        let mut plant = Duffing::new();
        let reference = phase_resonance(&mut plant, W0, &volts, M, &opts).unwrap();
        assert!(reference.failure.is_none());
        // 1e-5 s, incommensurate with the period (about 1765 steps)
        let streamed = streamed(&volts, 1e-5, &opts);
        assert_eq!(streamed.len(), 3);
        for (r, s) in reference.levels.iter().zip(&streamed) {
            assert!(r.settled && s.settled, "{r:?} {s:?}");
            let dw = s.omega_rad_s / r.omega_rad_s - 1.0;
            let da = s.drive_amplitude_m() / r.drive_amplitude_m() - 1.0;
            let dd = s.damping_ratio / r.damping_ratio - 1.0;
            let df = s.force_amplitude_n() / r.force_amplitude_n() - 1.0;
            eprintln!(
                "U = {} V: omega {:.6} / {:.6} ({dw:.1e}), |x_1| {:.5e} ({da:.1e}), D {:.5} ({dd:.1e}), F ({df:.1e}), periods {} / {}",
                r.voltage_v, s.omega_rad_s, r.omega_rad_s, s.drive_amplitude_m(),
                s.damping_ratio, s.periods, r.periods
            );
            assert_eq!(s.voltage_v, r.voltage_v);
            assert_eq!(s.periods, r.periods);
            assert!(dw.abs() < 2e-6, "{dw}");
            assert!(da.abs() < 1e-5, "{da}");
            assert!(dd.abs() < 2e-5, "{dd}");
            assert!(df.abs() < 1e-5, "{df}");
            // the viscous damping ratio c / (2 m Omega)
            let dv = C / (2.0 * M * s.omega_rad_s);
            assert!(
                (s.damping_ratio / dv - 1.0).abs() < 2e-3,
                "{}",
                s.damping_ratio
            );
        }
    }

    #[test]
    fn serialized_loop_continues_identically() {
        let opts = PllOptions::default();
        let mut pll = StreamingPll::new(opts, W0, 1.0, M, N).unwrap();
        let h = 1.3e-5;
        let mut plant = Duffing::new();
        let run = |pll: &mut StreamingPll, plant: &mut Duffing, steps: usize| {
            for _ in 0..steps {
                let s = StreamSample {
                    force_n: G * pll.output_v(),
                    drive_m: plant.z[0],
                    ..Default::default()
                };
                pll.measure(plant.t, s).unwrap();
                let u = pll.output_v();
                pll.advance(h).unwrap();
                plant.rk4(h, |_| G * u);
            }
        };
        // right after the first period (its amplitude change is infinite)
        run(&mut pll, &mut plant, 1500);
        assert_eq!(pll.periods(), 1);
        let json = serde_json::to_string(&pll).unwrap();
        let copy = serde_json::from_str::<StreamingPll>(&json)
            .unwrap()
            .restored()
            .unwrap();
        assert_eq!(copy.last_period(), pll.last_period());
        run(&mut pll, &mut plant, 3500);
        let json = serde_json::to_string(&pll).unwrap();
        let mut copy: StreamingPll = serde_json::from_str::<StreamingPll>(&json)
            .unwrap()
            .restored()
            .unwrap();
        assert_eq!(copy.last_period(), pll.last_period());
        let mut plant2 = plant.clone();
        run(&mut pll, &mut plant, 3000);
        run(&mut copy, &mut plant2, 3000);
        assert_eq!(copy.omega_rad_s(), pll.omega_rad_s());
        assert_eq!(copy.output_v(), pll.output_v());
        assert_eq!(copy.last_period(), pll.last_period());
    }

    #[test]
    fn bad_inputs_are_errors_naming_the_value() {
        let opts = PllOptions::default();
        assert!(StreamingPll::new(opts.clone(), W0, -1.0, M, N).is_err());
        assert!(StreamingPll::new(opts.clone(), W0, 1.0, 0.0, N).is_err());
        assert!(StreamingPll::new(opts.clone(), W0, 1.0, M, 11).is_err());
        assert!(StreamingPll::new(opts.clone(), f64::NAN, 1.0, M, N).is_err());
        let mut pll = StreamingPll::new(opts, W0, 1.0, M, N).unwrap();
        let e = pll.advance(5e-3).unwrap_err().to_string();
        assert!(e.contains("5e-3 s") && e.contains("356"), "{e}");
        let s = StreamSample {
            force_n: f64::NAN,
            ..Default::default()
        };
        assert!(pll.measure(0.0, s).is_err());
        assert!(pll.set_voltage(f64::INFINITY).is_err());
    }
}
