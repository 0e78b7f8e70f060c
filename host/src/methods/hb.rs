//! `hb`: the periodic steady state of the full model (every nonlinearity,
//! exciter and attachment, condensed exactly per harmonic) by harmonic
//! balance with arc-length continuation in Omega, its stability (Hill's
//! method) and bifurcations (`nlmode::hb`, docs/hb.md). Writes `hb_frc.csv`.
use super::common::{frf_omegas, reduced_model};
use super::{MethodOutput, RunContext};
use crate::model::Setup;
use crate::results::{Column, Envelope, MethodResult, Table};
use crate::scenario::{Method, Scenario};
use anyhow::{Context, Result};
use nlmode::hb::{
    add_seeded_branches, frequency_response, Bifurcation, BranchStatus, HbResult, HbSystem, Seed,
};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Largest number of seeds taken from the single-mode steady state.
pub const MAX_HB_SEEDS: usize = 60;

/// Frequencies of the single-mode steady state searched for seeds.
const SEED_FREQUENCIES: usize = 120;

/// Seeds for isolated branches: every solution of the single-mode steady
/// state (`eq:NM`, as `host frf`) at the frequencies where it has several
/// (evenly thinned to [`MAX_HB_SEEDS`]); the response point's fundamental
/// `a phi_tip,1(a) e^{-i theta}`.
pub fn single_mode_seeds(setup: &Setup, table: &nlmode::nma::ModalTable) -> Result<Vec<Seed>> {
    single_mode_seeds_at(setup, table, &frf_omegas(setup, SEED_FREQUENCIES), true)
}

/// [`single_mode_seeds`] at `omegas`; with `only_multiple`, only where the
/// single-mode steady state has several solutions.
fn single_mode_seeds_at(
    setup: &Setup,
    table: &nlmode::nma::ModalTable,
    omegas: &[f64],
    only_multiple: bool,
) -> Result<Vec<Seed>> {
    let model = reduced_model(setup, table, None)?;
    let ss = model
        .steady_state(omegas, setup.sweep.amplitude)
        .context("hb: seeds from the single-mode steady state")?;
    let tip = table
        .points
        .iter()
        .find(|p| p.name == setup.response_point)
        .context("hb: the modal table has no response point")?;
    // the sign of the linear mode at the response point
    let sign = tip
        .re
        .first()
        .and_then(|r| r.get(1))
        .map_or(1.0, |v| v.signum());
    let mut seeds: Vec<Seed> = ss
        .iter()
        .filter(|p| !only_multiple || p.solutions.len() > 1)
        .flat_map(|p| {
            p.solutions.iter().map(move |s| Seed {
                omega_rad_s: p.omega_rad_s,
                amplitude_m: s.tip_amplitude_m,
                phase_rad: -s.theta_rad
                    + if sign < 0.0 {
                        std::f64::consts::PI
                    } else {
                        0.0
                    },
            })
        })
        .filter(|s| s.amplitude_m > 0.0 && s.amplitude_m.is_finite())
        .collect();
    if seeds.len() > MAX_HB_SEEDS {
        let n = seeds.len();
        seeds = (0..MAX_HB_SEEDS)
            .map(|i| seeds[i * n / MAX_HB_SEEDS])
            .collect();
    }
    Ok(seeds)
}

/// The HB frequency response of `setup` over the sweep's band with `[hb]`'s
/// options. With `hb.seeds` and the modal table: seeded from every solution
/// of the single-mode steady state where it has several
/// ([`single_mode_seeds`]), then from every single-mode solution at the
/// frequencies of the main branch's folds (an isola near a fold of the full
/// model that the single-mode grid missed).
pub fn hb_response(
    setup: &Setup,
    sc: &Scenario,
    table: Option<&nlmode::nma::ModalTable>,
) -> Result<HbResult> {
    let sys = HbSystem::new(
        &setup.model,
        &setup.attachments,
        &setup.input_amplitudes(),
        &[],
        &setup.response_point,
    )
    .context("hb")?;
    let opts = sc
        .hb
        .options(setup.sweep.omega_start_rad_s, setup.sweep.omega_end_rad_s);
    let table = table.filter(|_| sc.hb.seeds);
    let seeds = match table {
        Some(t) => single_mode_seeds(setup, t)?,
        None => Vec::new(),
    };
    let mut r = frequency_response(&sys, &opts, &seeds).context("hb")?;
    if let Some(t) = table {
        let folds: Vec<f64> = r
            .branches
            .first()
            .map(|b| {
                b.points
                    .iter()
                    .filter(|p| p.bifurcation == Bifurcation::Fold)
                    .map(|p| p.omega_rad_s)
                    .collect()
            })
            .unwrap_or_default();
        if !folds.is_empty() {
            let more = single_mode_seeds_at(setup, t, &folds, false)?;
            add_seeded_branches(&sys, &opts, &mut r, &more).context("hb")?;
        }
    }
    Ok(r)
}

/// `hb_frc`: one row per point of every branch (a contract: `branch`,
/// `omega_rad_s`, `tip_amplitude_m`, `force_amplitude_N`, `stable`,
/// `bifurcation`, `<name>_force_amplitude_N` per force column,
/// `tip_h<n>_amplitude_m` per harmonic `n = 0..=H`), written as `hb_frc.csv`
/// and returned to Python.
pub fn hb_table(r: &HbResult) -> Table {
    let pts = || {
        r.branches
            .iter()
            .enumerate()
            .flat_map(|(b, br)| br.points.iter().map(move |p| (b, p)))
    };
    let num = |f: &dyn Fn(usize, &nlmode::hb::HbPoint) -> f64| {
        Column::Numbers(pts().map(|(b, p)| f(b, p)).collect())
    };
    let mut columns = vec![
        ("branch".to_string(), num(&|b, _| b as f64)),
        ("omega_rad_s".into(), num(&|_, p| p.omega_rad_s)),
        ("tip_amplitude_m".into(), num(&|_, p| p.tip_amplitude_m())),
        (
            "force_amplitude_N".into(),
            num(&|_, p| p.force_amplitudes_n().first().copied().unwrap_or(f64::NAN)),
        ),
        (
            "stable".into(),
            Column::Text(
                pts()
                    .map(|(_, p)| p.stable().map_or(String::new(), |s| s.to_string()))
                    .collect(),
            ),
        ),
        (
            "bifurcation".into(),
            Column::Text(
                pts()
                    .map(|(_, p)| p.bifurcation.label().to_string())
                    .collect(),
            ),
        ),
    ];
    for (i, n) in r.force_names.iter().enumerate() {
        columns.push((
            format!("{n}_force_amplitude_N"),
            num(&|_, p| p.force_amplitudes_n().get(i).copied().unwrap_or(f64::NAN)),
        ));
    }
    for h in 0..=r.harmonics {
        columns.push((
            format!("tip_h{h}_amplitude_m"),
            num(&|_, p| {
                p.harmonic_amplitudes_m()
                    .get(h)
                    .copied()
                    .unwrap_or(f64::NAN)
            }),
        ));
    }
    Table {
        name: "hb_frc".into(),
        columns,
    }
}

/// A fold (limit point) of a steady-state branch (`methods.hb.folds`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FoldSummary {
    pub omega_rad_s: f64,
    pub tip_amplitude_m: f64,
}

/// `hb`'s entry of `summary.json`: the folds of every branch ([`FoldSummary`]s).
pub const FOLDS: &str = "folds";
/// `hb`'s entry of `summary.json`: the `[from, to]` Omega ranges of
/// consecutive unstable points of every branch [rad/s] (with stability only).
pub const UNSTABLE_RANGES: &str = "unstable_ranges_rad_s";
/// `hb`'s entry of `summary.json`: how each branch ended.
pub const STATUS: &str = "status";

/// The main branch as an envelope (for the figures of merit and the plot),
/// the folds and unstable ranges of every branch, warnings for branches that
/// stopped.
pub fn hb_result(r: &HbResult, wall_time_s: f64) -> MethodResult {
    let main = r.branches.first();
    let pts = main.map(|b| b.points.as_slice()).unwrap_or_default();
    let env = Envelope {
        omega_rad_s: pts.iter().map(|p| p.omega_rad_s).collect(),
        force_amplitude_n: pts
            .iter()
            .map(|p| p.force_amplitudes_n().first().copied().unwrap_or(0.0))
            .collect(),
        tip_amplitude_m: pts.iter().map(|p| p.tip_amplitude_m()).collect(),
        force_phase_rad: None,
        drive_amplitude_m: None,
        modal_amplitude: None,
        modal_frequency_rad_s: None,
    };
    let mut m = MethodResult::new(Method::Hb.name(), wall_time_s, env, false);
    m.tables.push(hb_table(r));
    if pts.iter().any(|p| p.floquet.is_some()) {
        // `stable` column of hb_envelope.csv (1 stable, 0 unstable; the plot
        // dashes the unstable parts)
        m.extra_columns.push((
            "stable".into(),
            pts.iter()
                .map(|p| match p.stable() {
                    Some(false) => 0.0,
                    _ => 1.0,
                })
                .collect(),
        ));
    }
    let s = &mut m.summary;
    let folds: Vec<FoldSummary> = r
        .branches
        .iter()
        .flat_map(|b| &b.points)
        .filter(|p| p.bifurcation == Bifurcation::Fold)
        .map(|p| FoldSummary {
            omega_rad_s: p.omega_rad_s,
            tip_amplitude_m: p.tip_amplitude_m(),
        })
        .collect();
    s.set(FOLDS, folds);
    let mut ranges: Vec<[f64; 2]> = Vec::new();
    for b in &r.branches {
        let mut open: Option<[f64; 2]> = None;
        for p in &b.points {
            match (p.stable(), open.as_mut()) {
                (Some(false), Some(rg)) => {
                    rg[0] = rg[0].min(p.omega_rad_s);
                    rg[1] = rg[1].max(p.omega_rad_s);
                }
                (Some(false), None) => open = Some([p.omega_rad_s; 2]),
                (_, Some(_)) => ranges.extend(open.take()),
                _ => {}
            }
        }
        ranges.extend(open);
    }
    if r.branches
        .iter()
        .any(|b| b.points.iter().any(|p| p.floquet.is_some()))
    {
        s.set(UNSTABLE_RANGES, ranges);
    }
    let status: Vec<String> = r
        .branches
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let kind = match &b.status {
                BranchStatus::Complete => "complete".to_string(),
                BranchStatus::Closed => "closed (isola)".to_string(),
                BranchStatus::MaxPoints => "max_points reached".to_string(),
                BranchStatus::Stopped { omega_rad_s, .. } => {
                    format!("stopped at Omega = {omega_rad_s:.4} rad/s")
                }
            };
            format!("branch {i}: {kind}, {} points", b.points.len())
        })
        .collect();
    s.set(STATUS, status.join("; "));
    for (i, b) in r.branches.iter().enumerate() {
        match &b.status {
            BranchStatus::Stopped {
                omega_rad_s,
                reason,
            } => s.warnings.push(format!(
                "hb: branch {i} stopped at Omega = {omega_rad_s:.4} rad/s: {reason}; hb_frc.csv holds the points before it"
            )),
            BranchStatus::MaxPoints => s.warnings.push(format!(
                "hb: branch {i} reached hb.max_points = {} before the end of the band; raise it or hb.ds",
                b.points.len()
            )),
            _ => {}
        }
    }
    m
}

/// `hb` (options: `[hb]`).
pub struct Hb;

/// Its name in scenarios and output files.
impl super::MethodId {
    #[allow(non_upper_case_globals)]
    pub const Hb: Self = Self::new("hb");
}

impl super::Method for Hb {
    fn id(&self) -> Method {
        Method::Hb
    }

    fn section(&self) -> Option<&'static str> {
        Some("hb")
    }

    fn needs_mode(&self, sc: &Scenario) -> bool {
        // the seeds come from the single-mode steady state
        sc.hb.seeds
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        let t0 = Instant::now();
        let table = if ctx.sc.hb.seeds {
            Some(ctx.table())
        } else {
            None
        };
        let r = hb_response(ctx.setup, ctx.sc, table)?;
        let wall = t0.elapsed().as_secs_f64();
        let m = hb_result(&r, wall);
        if ctx.published(Method::Hb) {
            for t in &m.tables {
                t.write_csv(&ctx.out.join(format!("{}.csv", t.name)))?;
            }
        }
        Ok(MethodOutput::one(m))
    }
}
