//! The plant of the controlled tests driven by the full-order reference: the
//! assembled structure + attachments (`eq:finalassembly1`-`eq:finalassembly2`,
//! [`crate::reference`]) integrated one excitation period at a time from the
//! state the previous period left, so the response and the phase of the
//! excitation are continuous across the controller's frequency and voltage
//! updates. Every attachment input receives `u(t) = u_hat cos(Omega t)` over
//! the period `0 <= t < 2 pi / Omega` (the period's own time origin).
//!
//! The same type serves the paper beam with its shaker and the single-DOF
//! Duffing oscillator driven through the paper's shaker ([`DuffingOscillator`]),
//! the analytic test case of the phase-locked loop.
//!
//! With the exponential integrator (the default) one [`ContinuedIntegration`]
//! lives as long as the plant: the propagators of the step sizes met so far,
//! the step level and the states of hysteretic elements (Jenkins sliders)
//! carry over from one period to the next, and a period whose frequency is
//! new builds its propagators from the eigenvectors of the assembled `A`
//! rather than a matrix exponential. Dormand-Prince restarts every period
//! from the state the last one left and therefore refuses hysteretic elements.
use super::{ControlError, PeriodSamples, Plant};
use crate::attachment::{LinearAttachment, ShakerParams};
use crate::reference::{
    integrate, AssembledSystem, ContinuedIntegration, IntegrationStats, Integrator,
    ReferenceOptions, SampleGrid,
};
use crate::structure::{CubicSpring, StructuralModel};
use nalgebra::{DMatrix, DVector};

/// The full-order reference as a [`Plant`]; the measured force and drive point
/// are those of the first attachment with an interface point.
#[derive(Debug)]
pub struct ReferencePlant {
    system: AssembledSystem,
    options: ReferenceOptions,
    z: DVector<f64>,
    /// The exponential integration kept across periods (`None`: Dormand-Prince).
    continued: Option<ContinuedIntegration>,
    time_s: f64,
    voltage_v: f64,
    omega_rad_s: f64,
    drive_index: usize,
    force_index: usize,
    current_index: Option<usize>,
    samples: PeriodSamples,
    stats: IntegrationStats,
}

impl ReferencePlant {
    /// The assembled `model` + `attachments` at rest; `options.tip_point` names
    /// the response point, `options.samples_per_period` the samples per
    /// excitation period (the demodulation's `N`, and the integrator's largest
    /// step). `options.output_interval_s` and `envelope_periods` are not used.
    pub fn new(
        model: &StructuralModel,
        attachments: &[LinearAttachment],
        options: &ReferenceOptions,
    ) -> Result<Self, ControlError> {
        let system = AssembledSystem::new(model, attachments, &options.tip_point)
            .map_err(ControlError::Assembly)?;
        let exponential = options.method == Integrator::Exponential;
        if let Some(l) = system
            .first_order
            .laws
            .iter()
            .find(|l| l.hysteresis().is_some() && !exponential)
        {
            return Err(ControlError::Hysteretic {
                law: l.name().to_string(),
            });
        }
        let obs = system
            .observations
            .iter()
            .find(|o| !o.interface_points.is_empty())
            .ok_or(ControlError::NoAttachment)?;
        let (drive_index, force_index) = (obs.drive_index, obs.force_index);
        let current_index = obs
            .state_names
            .iter()
            .position(|s| s == "I")
            .map(|k| obs.state_index + k);
        let z = DVector::zeros(system.first_order.nz());
        let continued = if exponential {
            Some(
                ContinuedIntegration::new(&system, z.clone(), options)
                    .map_err(ControlError::Assembly)?,
            )
        } else {
            None
        };
        Ok(Self {
            system,
            options: options.clone(),
            z,
            continued,
            time_s: 0.0,
            voltage_v: 0.0,
            omega_rad_s: 0.0,
            drive_index,
            force_index,
            current_index,
            samples: PeriodSamples::default(),
            stats: IntegrationStats::default(),
        })
    }

    /// As [`ReferencePlant::new`], but restarting the integration every
    /// period from the state the last one left (new propagators per period:
    /// the behaviour before the integration was kept across periods, for
    /// comparison in the `pll` bench); memoryless elements only.
    pub fn restarting(
        model: &StructuralModel,
        attachments: &[LinearAttachment],
        options: &ReferenceOptions,
    ) -> Result<Self, ControlError> {
        let mut plant = Self::new(
            model,
            attachments,
            &ReferenceOptions {
                method: Integrator::DormandPrince,
                ..options.clone()
            },
        )?;
        plant.options.method = options.method;
        Ok(plant)
    }

    /// Work counters summed over all periods so far.
    pub fn stats(&self) -> IntegrationStats {
        self.stats
    }

    /// The assembled system.
    pub fn system(&self) -> &AssembledSystem {
        &self.system
    }
}

impl Plant for ReferencePlant {
    fn set_excitation(&mut self, voltage_v: f64, omega_rad_s: f64) {
        self.voltage_v = voltage_v;
        self.omega_rad_s = omega_rad_s;
    }

    fn advance_period(&mut self) -> Result<&PeriodSamples, ControlError> {
        let omega = self.omega_rad_s;
        if !(omega.is_finite() && omega > 0.0) {
            return Err(ControlError::BadOption {
                name: "omega_rad_s",
                value: omega.to_string(),
                expected: "a positive excitation frequency",
            });
        }
        let n = self.options.samples_per_period;
        let dt = 2.0 * std::f64::consts::PI / omega / n as f64;
        let u_hat = self.voltage_v;
        let input = move |t: f64| u_hat * (omega * t).cos();
        let s = &mut self.samples;
        s.omega_rad_s = omega;
        s.voltage_v = u_hat;
        for v in [
            &mut s.force_n,
            &mut s.drive_m,
            &mut s.tip_m,
            &mut s.current_a,
        ] {
            v.clear();
        }
        let sys = &self.system;
        let mut obs = DVector::zeros(sys.n_observed());
        let mut f = vec![0.0; sys.first_order.m()];
        let (di, fi, ci) = (self.drive_index, self.force_index, self.current_index);
        let mut on_sample = |i: usize, z: &DVector<f64>, states: &[f64]| {
            if i == n {
                return;
            }
            sys.first_order.forces(z, states, &mut f);
            sys.observe(z, input(i as f64 * dt), &f, &mut obs);
            s.tip_m.push(obs[0]);
            s.drive_m.push(obs[di]);
            s.force_n.push(obs[fi]);
            if let Some(c) = ci {
                s.current_a.push(obs[c]);
            }
        };
        let grid = SampleGrid {
            interval_s: dt,
            count: n,
        };
        let time_s = self.time_s;
        let failed = |source| ControlError::Integration { time_s, source };
        let stats = match &mut self.continued {
            Some(c) => {
                let st = c
                    .advance(sys, grid, &input, &mut on_sample)
                    .map_err(failed)?;
                self.z.copy_from(c.state());
                st
            }
            None => {
                // memoryless laws only (checked in `new`): their states are unused
                let states = vec![0.0; sys.first_order.m()];
                let mut z_end = self.z.clone();
                let st = integrate(
                    sys,
                    &self.z,
                    grid,
                    &input,
                    &self.options,
                    &mut |i, z| {
                        if i == n {
                            z_end.copy_from(z);
                        }
                        on_sample(i, z, &states)
                    },
                    &mut |_| {},
                )
                .map_err(failed)?;
                self.z = z_end;
                st
            }
        };
        self.time_s += n as f64 * dt;
        let t = &mut self.stats;
        t.steps += stats.steps;
        t.rejected += stats.rejected;
        t.rhs_evals += stats.rhs_evals;
        t.law_evals += stats.law_evals;
        t.newton_iterations += stats.newton_iterations;
        t.propagators += stats.propagators;
        Ok(&self.samples)
    }

    fn time_s(&self) -> f64 {
        self.time_s
    }
}

/// A single-DOF Duffing oscillator `m x'' + c x' + k x + k3 x^3 = F`, driven
/// through a shaker at its only point `tip` (also the drive point).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DuffingOscillator {
    /// Mass `m` \[kg\].
    pub mass_kg: f64,
    /// Viscous damping `c` \[N s/m\].
    pub damping_n_s_per_m: f64,
    /// Linear stiffness `k` \[N/m\].
    pub stiffness_n_per_m: f64,
    /// Cubic stiffness `k3` \[N/m^3\].
    pub k3_n_per_m3: f64,
}

impl DuffingOscillator {
    /// Linear natural frequency `omega0 = sqrt(k/m)` \[rad/s\].
    pub fn omega0_rad_s(&self) -> f64 {
        (self.stiffness_n_per_m / self.mass_kg).sqrt()
    }

    /// Viscous damping ratio at `omega`, `c / (2 m omega)` (the modal damping
    /// ratio of the nonlinear mode of `eq:EPMC` at that frequency: `2 D omega = c/m`).
    pub fn damping_ratio_at(&self, omega_rad_s: f64) -> f64 {
        self.damping_n_s_per_m / (2.0 * self.mass_kg * omega_rad_s)
    }

    /// The H = 1 backbone `omega^2 = omega0^2 + 3/4 k3/m a^2` at amplitude `a` \[m\].
    pub fn backbone_h1_rad_s(&self, amplitude_m: f64) -> f64 {
        (self.stiffness_n_per_m / self.mass_kg
            + 0.75 * self.k3_n_per_m3 / self.mass_kg * amplitude_m * amplitude_m)
            .sqrt()
    }

    /// The structural model: one DOF, point `tip`, cubic spring `k3`.
    pub fn model(&self) -> Result<StructuralModel, ControlError> {
        let one = DMatrix::from_element(1, 1, 1.0);
        let mut model = StructuralModel::new(&one * self.mass_kg, &one * self.stiffness_n_per_m);
        model.damping = &one * self.damping_n_s_per_m;
        let e = DVector::from_element(1, 1.0);
        model.add_named_point("tip", e.clone())?;
        if self.k3_n_per_m3 != 0.0 {
            model.add_nonlinear("k3", e, CubicSpring::new(self.k3_n_per_m3)?)?;
        }
        model.validate()?;
        Ok(model)
    }

    /// The oscillator with the shaker `shaker` at `tip`, as a [`ReferencePlant`]
    /// (`options.tip_point` is set to `tip`).
    pub fn with_shaker(
        &self,
        shaker: &ShakerParams,
        options: &ReferenceOptions,
    ) -> Result<ReferencePlant, ControlError> {
        let model = self.model()?;
        let att = LinearAttachment::shaker("shaker", shaker, "tip")?;
        let options = ReferenceOptions {
            tip_point: "tip".into(),
            ..options.clone()
        };
        ReferencePlant::new(&model, &[att], &options)
    }
}
