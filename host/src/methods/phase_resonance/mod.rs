//! The controlled virtual tests of `host run` (issue 16): the
//! phase-resonance test (`phase-resonance`), a phase-locked loop
//! ([`nlmode::control::pll`]) stepped through `[phase_resonance]
//! voltage_levels_v` on the full-order reference with the shaker
//! (`model = "reference"`) or on the single-nonlinear-mode model
//! (`model = "nlmode"`, [`nlmode::control::reduced_plant`]: the loop sees only
//! the fundamental, the harmonic ratios are 0, the current is not sampled). Writes
//! `phase_resonance.csv` (one row per level, the column contract in
//! [`PHASE_RESONANCE_COLUMNS`] then the harmonic ratios), the measured backbone
//! over the numerical NMA (`phase_resonance_backbone.svg`, `omega/omega0`
//! against `|q_tip,1|`) and the damping (`phase_resonance_damping.svg`), and
//! the measured modal table `modal_table.json`
//! ([`nlmode::control::modal_table_from_phase_resonance`]: force appropriation
//! at phase resonance, shapes at the drive point and the response point) that
//! `[nma] table` and the structure FMU's `modal_table` parameter accept.
pub mod cosim;
mod levels;

pub use self::cosim::{loop_connections, run_levels, CosimPll};
pub use levels::{amplitude_at_tip, nma_at_tip_amplitude, MEASURED_TABLE_FILE};

use super::{MethodId, MethodOutput, RunContext};
use crate::model::Setup;
use crate::results::MethodResult;
use crate::scenario::{PhaseResonanceModel, Scenario};
use anyhow::{anyhow, Context, Result};
use levels::measured_levels_result;
use nlmode::control::{phase_resonance as run_pll, Plant, ReducedPlant, ReferencePlant};
use nlmode::nma::ModalTable;
use nlmode::reference::ReferenceOptions;
use std::path::Path;
use std::time::Instant;

/// The contract columns of `phase_resonance.csv`, in this order; then
/// `nma_omega_rad_s`, `nma_damping_ratio` (the numerical NMA at the measured
/// `|q_tip,1|`, empty outside the table), `phase_error_rad`, `periods`,
/// `current_amplitude_A`, and the harmonic ratios `tip_h<n>_ratio`,
/// `drive_h<n>_ratio`, `force_h<n>_ratio` (`|X_n| / |X_1|`, `n = 2..=H`).
pub const PHASE_RESONANCE_COLUMNS: [&str; 7] = [
    "tip_amplitude_m",
    "drive_amplitude_m",
    "omega_rad_s",
    "damping_ratio",
    "force_amplitude_N",
    "voltage_v",
    "settled",
];

/// `host run`'s `phase-resonance`: runs the test, writes `phase_resonance.csv`
/// and the plots into `out`, and returns the method's envelope (one point per
/// level) and summary. `table`: the numerical NMA to compare with.
pub fn phase_resonance(
    setup: &Setup,
    sc: &Scenario,
    table: &ModalTable,
    out: &Path,
) -> Result<MethodResult> {
    let spec = &sc.phase_resonance;
    if spec.model == PhaseResonanceModel::Cosim {
        return self::cosim::phase_resonance(setup, sc, table, out);
    }
    let t0 = Instant::now();
    let drive_mass = setup.modal_masses[0].0;
    // the loop starts at eta_start and follows the backbone
    let start = spec.eta_start * setup.omega0_rad_s;
    let band = table
        .omega_rad_s
        .iter()
        .fold((start, start), |(lo, hi), &w| (lo.min(w), hi.max(w)));
    let mut plant = plant(setup, sc, table, spec.model, spec.samples_per_period, band)?;
    let res = run_pll(
        plant.as_plant(),
        spec.eta_start * setup.omega0_rad_s,
        &spec.voltage_levels_v,
        drive_mass,
        &spec.pll,
    )
    .context("phase-resonance")?;
    let wall = t0.elapsed().as_secs_f64();
    let failure = res.failure.as_ref().map(|(u, e)| (*u, e.to_string()));
    let mut r = measured_levels_result(
        setup,
        sc,
        table,
        out,
        &res.levels,
        failure.as_ref(),
        wall,
        "phase-resonance",
    )?;
    match &plant {
        ControlledPlant::Reference(p) => {
            r.summary.set("steps", p.stats().steps as u64);
            r.summary.set("rejected_steps", p.stats().rejected as u64);
        }
        ControlledPlant::Nlmode(p) => {
            if sc.slowflow.attachments == nlmode::reduced::AttachmentStates::Dynamic {
                r.summary
                    .set("attachment_states", p.carried_states() as u64);
            }
            if sc.slowflow.harmonic_force_projection {
                r.summary.set("harmonic_force_projection", true);
            }
        }
    }
    Ok(r)
}

/// The plant of a controlled test, by `model`.
pub enum ControlledPlant {
    /// The full-order reference with the shaker.
    Reference(Box<ReferencePlant>),
    /// The slow flow of `eq:NM` with the scenario's shakers.
    Nlmode(Box<ReducedPlant>),
}

impl ControlledPlant {
    /// The plant for the controllers.
    pub fn as_plant(&mut self) -> &mut dyn Plant {
        match self {
            ControlledPlant::Reference(p) => p.as_mut(),
            ControlledPlant::Nlmode(p) => p.as_mut(),
        }
    }
}

/// The plant of the model `model`, sampled `samples_per_period` times per
/// period, from rest: the reference assembly (`reference`, with the
/// scenario's integrator and `rtol`) or the single-nonlinear-mode model on
/// `table` (`nlmode`; with `[slowflow] attachments = "dynamic"` the
/// attachments' states with a pole near `band_rad_s`, the frequencies the
/// test covers, are carried). `cosim` is refused with its reason.
pub fn plant(
    setup: &Setup,
    sc: &Scenario,
    table: &ModalTable,
    model: PhaseResonanceModel,
    samples_per_period: usize,
    band_rad_s: (f64, f64),
) -> Result<ControlledPlant> {
    match model {
        PhaseResonanceModel::Reference => {
            let opts = ReferenceOptions {
                method: sc.reference.integrator.unwrap_or_default(),
                rtol: sc.reference.rtol,
                samples_per_period,
                tip_point: setup.response_point.clone(),
                ..Default::default()
            };
            let p = ReferencePlant::new(&setup.model, &setup.attachments, &opts)
                .context("controlled test on the reference model")?;
            Ok(ControlledPlant::Reference(Box::new(p)))
        }
        PhaseResonanceModel::Nlmode => {
            let m = super::reduced_model(setup, table, None)
                .context("controlled test on the nlmode model")?;
            let mut p = ReducedPlant::new(m, samples_per_period)
                .context("controlled test on the nlmode model")?
                .with_harmonic_force_projection(sc.slowflow.harmonic_force_projection);
            if sc.slowflow.attachments == nlmode::reduced::AttachmentStates::Dynamic {
                p = p
                    .with_attachment_states(
                        band_rad_s.0,
                        band_rad_s.1,
                        nlmode::reduced::dynamic::FAST_POLE_FACTOR,
                    )
                    .context("[slowflow] attachments = \"dynamic\" in the controlled test")?;
            }
            Ok(ControlledPlant::Nlmode(Box::new(p)))
        }
        PhaseResonanceModel::Cosim => Err(anyhow!(
            "model = \"cosim\" runs the phase-resonance test only (structure.fmu, shaker.fmu and \
             controller.fmu, whose loop is the phase-locked loop); the force- and \
             response-controlled tests take \"reference\" or \"nlmode\""
        )),
    }
}
/// `phase-resonance` (options: `[phase_resonance]`).
pub struct PhaseResonance;

/// Its name in scenarios and output files.
impl super::MethodId {
    #[allow(non_upper_case_globals)]
    pub const PhaseResonance: Self = Self::new("phase-resonance");
}

impl super::Method for PhaseResonance {
    fn id(&self) -> MethodId {
        MethodId::PhaseResonance
    }

    fn section(&self) -> Option<&'static str> {
        Some("phase_resonance")
    }

    fn needs_mode(&self, _sc: &Scenario) -> bool {
        true
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        Ok(MethodOutput::one(phase_resonance(
            ctx.setup,
            ctx.sc,
            ctx.table(),
            ctx.out,
        )?))
    }
}
