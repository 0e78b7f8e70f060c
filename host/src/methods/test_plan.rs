//! `host run`'s `test-plan` (issue 16, item 4): for each target amplitude
//! `|q_tip,1|` of `[test_plan] target_amplitudes_m`, on the single-nonlinear-mode
//! model with the scenario's shaker, the steady state of `eq:NM` at phase
//! resonance ([`nlmode::control::phase_resonance_voltage`]): the voltage, coil
//! current and armature stroke the shaker needs, the frequency and the force
//! at the structure; then the open-loop sweep of `[excitation]` at that
//! voltage (the `nlmode` method's slow flow) and the force drop it shows,
//! `1 - |F_1| / |F_b|` at its least force `|F_1|` (`F_b` the blocked force
//! there, `eq:forcedrop`'s reference). Each limit of `[test_plan]` exceeded is
//! flagged in `test_plan.csv` and warned about with the numbers; a target
//! beyond the modal table is warned about and left out.
use super::phase_resonance::amplitude_at_tip;
use super::{MethodId, MethodOutput, RunContext};
use crate::model::Setup;
use crate::results::{Envelope, MethodResult};
use crate::scenario::{Method, Scenario};
use anyhow::{Context, Result};
use nlmode::control::{attachment_states, phase_resonance_voltage};
use nlmode::nma::ModalTable;
use nlmode::reduced::SweepStatus;
use std::path::Path;
use std::time::Instant;

/// The columns of `test_plan.csv`, in this order.
pub const TEST_PLAN_COLUMNS: [&str; 17] = [
    "target_tip_amplitude_m",
    "modal_amplitude",
    "omega_rad_s",
    "eta",
    "damping_ratio",
    "voltage_v",
    "current_amplitude_A",
    "stroke_amplitude_m",
    "force_amplitude_N",
    "drive_amplitude_m",
    "open_loop_force_drop",
    "open_loop_min_force_N",
    "open_loop_peak_tip_m",
    "open_loop_status",
    "voltage_exceeded",
    "current_exceeded",
    "stroke_exceeded",
];

/// One planned target.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedTarget {
    /// Target `|q_tip,1|` \[m\].
    pub target_tip_m: f64,
    /// The steady state at phase resonance.
    pub point: nlmode::control::PhaseResonancePoint,
    /// Coil current and armature stroke amplitudes of the first exciter \[A, m\].
    pub current_a: f64,
    pub stroke_m: f64,
    /// The open-loop sweep at the voltage: force drop, least force \[N\],
    /// peak `|q_tip,1|` \[m\] and how it ended (`None` if not run).
    pub open_loop: Option<(f64, f64, f64, String)>,
    /// Limits exceeded: voltage, current, stroke.
    pub exceeded: [bool; 3],
}

/// The plan of `sc`'s `[test_plan]` on `table` with the setup's shakers, and
/// the warnings (targets beyond the table, limits exceeded, open-loop sweeps
/// that stopped early).
pub fn plan(
    setup: &Setup,
    sc: &Scenario,
    table: &ModalTable,
) -> Result<(Vec<PlannedTarget>, Vec<String>)> {
    let spec = &sc.test_plan;
    let model = super::reduced_model(setup, table, None).context("test-plan")?;
    let att = &setup.attachments[0];
    let inputs = &setup.inputs[0];
    let (a_lo, a_hi) = model.table().amplitude_range();
    let mut warnings = Vec::new();
    let mut out = Vec::with_capacity(spec.target_amplitudes_m.len());
    for (i, &x) in spec.target_amplitudes_m.iter().enumerate() {
        let Some(a) = amplitude_at_tip(table, &setup.response_point, x) else {
            warnings.push(format!(
                "test-plan: target {i} |q_tip,1| = {x:e} m lies beyond the modal table \
                 (a = {a_lo:.4e} ..= {a_hi:.4e} sqrt(kg) m, nma.max_tip_amplitude_m = {} m); left out",
                sc.nma.max_tip_amplitude_m
            ));
            continue;
        };
        let planned = || -> Result<_> {
            let p = phase_resonance_voltage(&model, a)?;
            let states = attachment_states(&model, &p, att, inputs)?;
            let open_loop = if spec.open_loop_sweep {
                Some(open_loop(setup, sc, &model, p.voltage_v)?)
            } else {
                None
            };
            Ok((p, states[0].norm(), states[1].norm(), open_loop))
        };
        let (p, current_a, stroke_m, open_loop) = match planned() {
            Ok(v) => v,
            Err(e) => {
                warnings.push(format!(
                    "test-plan: stopped at target {i} |q_tip,1| = {x:e} m (a = {a:.4e}): {e:#}; \
                     the {} targets before it are kept",
                    out.len()
                ));
                break;
            }
        };
        if let Some((_, _, _, status)) = &open_loop {
            if status != "Completed" {
                warnings.push(format!(
                    "test-plan: target {i} ({x:e} m): the open-loop sweep at {:.4} V stopped \
                     early ({status}); its force drop is that of the part swept",
                    p.voltage_v
                ));
            }
        }
        let exceeded = [
            p.voltage_v > spec.voltage_limit_v,
            current_a > spec.current_limit_a,
            stroke_m > spec.stroke_limit_m,
        ];
        for (k, (name, need, limit, unit)) in [
            ("voltage", p.voltage_v, spec.voltage_limit_v, "V"),
            ("current", current_a, spec.current_limit_a, "A"),
            ("stroke", stroke_m, spec.stroke_limit_m, "m"),
        ]
        .into_iter()
        .enumerate()
        {
            if exceeded[k] {
                warnings.push(format!(
                    "test-plan: target {i} |q_tip,1| = {x:e} m needs a {name} amplitude of \
                     {need:.4e} {unit} at phase resonance (Omega = {:.3} rad/s), above \
                     test_plan.{name}_limit_{} = {limit:e} {unit}",
                    p.omega_rad_s,
                    unit.to_lowercase()
                ));
            }
        }
        out.push(PlannedTarget {
            target_tip_m: x,
            point: p,
            current_a,
            stroke_m,
            open_loop,
            exceeded,
        });
    }
    Ok((out, warnings))
}

/// The `nlmode` sweep of `[excitation]` at `voltage_v`: (force drop, least
/// force \[N\], peak `|q_tip,1|` \[m\], status).
fn open_loop(
    setup: &Setup,
    sc: &Scenario,
    model: &nlmode::reduced::ReducedModel,
    voltage_v: f64,
) -> Result<(f64, f64, f64, String)> {
    let mut sweep = setup.sweep;
    sweep.amplitude = voltage_v;
    let res = model
        .simulate_sweep(&sweep, &sc.slowflow.options(Method::Nlmode))
        .context("test-plan: open-loop sweep")?;
    let s = &res.samples;
    let status = match res.status {
        SweepStatus::Completed => "Completed".to_string(),
        other => format!("{other:?}"),
    };
    let Some(k) =
        (0..s.len()).min_by(|&i, &j| s[i].force_amplitude_n.total_cmp(&s[j].force_amplitude_n))
    else {
        return Ok((f64::NAN, f64::NAN, f64::NAN, status));
    };
    let fb = model
        .blocked_force(s[k].omega_rad_s, voltage_v)
        .context("test-plan: blocked force")?
        .norm();
    let peak = s.iter().map(|x| x.tip_amplitude_m).fold(0.0, f64::max);
    Ok((
        1.0 - s[k].force_amplitude_n / fb,
        s[k].force_amplitude_n,
        peak,
        status,
    ))
}

/// `host run`'s `test-plan`: writes `test_plan.csv` into `out` and returns
/// the method's result (one envelope point per planned target) with the
/// warnings.
pub fn test_plan(
    setup: &Setup,
    sc: &Scenario,
    table: &ModalTable,
    out: &Path,
) -> Result<MethodResult> {
    let t0 = Instant::now();
    let (targets, warnings) = plan(setup, sc, table)?;
    let wall = t0.elapsed().as_secs_f64();
    write_csv(&out.join("test_plan.csv"), &targets, setup.omega0_rad_s)?;
    if sc.output.plots && !targets.is_empty() {
        plot(&out.join("test_plan.svg"), sc, &targets)?;
    }
    let env = Envelope {
        omega_rad_s: targets.iter().map(|t| t.point.omega_rad_s).collect(),
        force_amplitude_n: targets.iter().map(|t| t.point.force_n.norm()).collect(),
        tip_amplitude_m: targets.iter().map(|t| t.point.tip_amplitude_m).collect(),
        force_phase_rad: Some(targets.iter().map(|t| t.point.force_n.arg()).collect()),
        drive_amplitude_m: Some(targets.iter().map(|t| t.point.drive_amplitude_m).collect()),
        modal_amplitude: Some(targets.iter().map(|t| t.point.a).collect()),
        modal_frequency_rad_s: Some(targets.iter().map(|t| t.point.omega_rad_s).collect()),
    };
    let mut r = MethodResult::new(Method::TestPlan.name(), wall, env, false);
    r.summary.warnings = warnings;
    Ok(r)
}

/// The voltage and the current needed against the target, over the limits.
fn plot(path: &Path, sc: &Scenario, targets: &[PlannedTarget]) -> Result<()> {
    let spec = &sc.test_plan;
    let x: Vec<f64> = targets.iter().map(|t| t.target_tip_m).collect();
    let u: Vec<f64> = targets.iter().map(|t| t.point.voltage_v).collect();
    let i: Vec<f64> = targets.iter().map(|t| t.current_a).collect();
    let ends = [x[0], x[x.len() - 1]];
    let (ul, il) = ([spec.voltage_limit_v; 2], [spec.current_limit_a; 2]);
    crate::plot::xy_plot(
        path,
        "Test plan: what the shaker needs at phase resonance",
        "target |q_tip,1| [m]",
        "voltage amplitude [V], current amplitude [A]",
        &[
            crate::plot::Curve {
                label: "voltage needed [V]".into(),
                x: &x,
                y: &u,
            },
            crate::plot::Curve {
                label: "current needed [A]".into(),
                x: &x,
                y: &i,
            },
            crate::plot::Curve {
                label: "voltage limit [V]".into(),
                x: &ends,
                y: &ul,
            },
            crate::plot::Curve {
                label: "current limit [A]".into(),
                x: &ends,
                y: &il,
            },
        ],
        crate::plot::Style::LinesLogX,
    )
}

fn write_csv(path: &Path, targets: &[PlannedTarget], omega0: f64) -> Result<()> {
    let mut w = csv::Writer::from_path(path)
        .with_context(|| format!("cannot create {}", path.display()))?;
    let mut write = || -> Result<(), csv::Error> {
        w.write_record(TEST_PLAN_COLUMNS)?;
        for t in targets {
            let f = |v: f64| v.to_string();
            let p = &t.point;
            let (drop, fmin, peak, status) = match &t.open_loop {
                Some((d, m, pk, s)) => (f(*d), f(*m), f(*pk), s.clone()),
                None => Default::default(),
            };
            w.write_record([
                f(t.target_tip_m),
                f(p.a),
                f(p.omega_rad_s),
                f(p.omega_rad_s / omega0),
                f(p.damping_ratio),
                f(p.voltage_v),
                f(t.current_a),
                f(t.stroke_m),
                f(p.force_n.norm()),
                f(p.drive_amplitude_m),
                drop,
                fmin,
                peak,
                status,
                t.exceeded[0].to_string(),
                t.exceeded[1].to_string(),
                t.exceeded[2].to_string(),
            ])?;
        }
        w.flush()?;
        Ok(())
    };
    write().with_context(|| format!("cannot write {}", path.display()))
}

/// `test-plan` (options: `[test_plan]`).
pub struct TestPlan;

/// Its name in scenarios and output files.
impl super::MethodId {
    #[allow(non_upper_case_globals)]
    pub const TestPlan: Self = Self::new("test-plan");
}

impl super::Method for TestPlan {
    fn id(&self) -> MethodId {
        MethodId::TestPlan
    }

    fn section(&self) -> Option<&'static str> {
        Some("test_plan")
    }

    fn needs_mode(&self, _sc: &crate::scenario::Scenario) -> bool {
        true
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        Ok(MethodOutput::one(test_plan(
            ctx.setup,
            ctx.sc,
            ctx.table(),
            ctx.out,
        )?))
    }
}
