//! `cosim`: the structure and shaker FMUs co-simulated by the host's master.
use super::{MethodOutput, RunContext};
use crate::model::Setup;
use crate::results::MethodResult;
use crate::scenario::{CosimAlgorithm, Method};
use anyhow::{Context, Result};

/// `cosim`: the structure and shaker FMUs co-simulated by the host's master.
///
/// `table`: the modal table of the scenario's own structure (a matrices
/// structure), written to `out/cosim_modal_table.json` and given to the
/// structure FMU by its `modal_table` parameter; `None`: the FMU's own table
/// (the paper beam's, in its `resources/`). The FMU reports `x_tip` at the
/// table's point `tip`; the table written gets the response point's shape under
/// that name (replacing a user point `tip` that is not the response point).
pub fn cosim(
    setup: &Setup,
    sc: &crate::scenario::Scenario,
    fmus: &(std::path::PathBuf, std::path::PathBuf),
    table: Option<(&nlmode::nma::ModalTable, &std::path::Path)>,
    progress: &mut dyn FnMut(f64),
) -> Result<MethodResult> {
    use crate::fmus::structure_shaker::{run_cosim, CosimParams};
    use cosim::Algorithm;
    setup.check_cosim()?;
    let structure = sc
        .cosim
        .structure_fmu
        .as_ref()
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| fmus.0.clone());
    let shaker = sc
        .cosim
        .shaker_fmu
        .as_ref()
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| fmus.1.clone());
    let mut p = CosimParams::new(setup.shakers[0], setup.sweep);
    p.algorithm = match sc.cosim.algorithm {
        CosimAlgorithm::Jacobi => Algorithm::Jacobi,
        CosimAlgorithm::GaussSeidel => Algorithm::GaussSeidel,
        CosimAlgorithm::Iterative => Algorithm::Iterative,
    };
    p.macro_step_s = sc.cosim.macro_step_s;
    p.drive_point = setup.exciter_points[0].clone();
    p.residual_modes = sc.cosim.residual_modes;
    p.harmonic_force_projection = sc.cosim.harmonic_force_projection;
    if let Some((table, out)) = table {
        let mut t = table.clone();
        let tip = nlmode::structure::paper::TIP;
        if setup.response_point != tip {
            // the FMU's x_tip is the table's point `tip`: the response point's
            // shape under that name (a user point named `tip` gives way to it)
            anyhow::ensure!(
                p.drive_point != tip,
                "cosim: the exciter's point is named '{tip}' but output.response_point = '{}'; the structure FMU reports x_tip at the table point '{tip}': rename the point",
                setup.response_point
            );
            let mut alias = t
                .points
                .iter()
                .find(|q| q.name == setup.response_point)
                .context("cosim: the modal table lacks the response point")?
                .clone();
            alias.name = tip.into();
            t.points.retain(|q| q.name != tip);
            t.points.push(alias);
            // the linear modes' shapes in the same order
            if let Some(lm) = &mut t.linear_modes {
                if let Some(mut a) = lm
                    .points
                    .iter()
                    .find(|q| q.name == setup.response_point)
                    .cloned()
                {
                    a.name = tip.into();
                    lm.points.retain(|q| q.name != tip);
                    lm.points.push(a);
                }
            }
        }
        let path = out.join("cosim_modal_table.json");
        t.write(&path)?;
        p.modal_table = Some(std::fs::canonicalize(&path).unwrap_or(path));
    }
    let out = run_cosim(&structure, &shaker, &p, progress).context("cosim")?;
    let env = out.envelope.clone();
    let mut r = MethodResult::new(Method::Cosim.name(), out.wall_time_s, env, true);
    r.time_series = Some(crate::results::TimeSeries {
        columns: vec![
            ("t_s".into(), out.time_s.clone()),
            ("omega_rad_s".into(), out.omega_rad_s.clone()),
            ("voltage_V".into(), out.voltage_v.clone()),
            ("tip_m".into(), out.x_tip_m.clone()),
            ("drive_m".into(), out.x_m.clone()),
            ("force_N".into(), out.force_n.clone()),
            ("current_A".into(), out.current_a.clone()),
        ],
    });
    r.summary.set("algorithm", sc.cosim.algorithm);
    if p.harmonic_force_projection {
        r.summary.set("harmonic_force_projection", true);
    }
    r.summary.set("macro_step_s", p.macro_step_s);
    r.summary.set("macro_steps", out.stats.steps as u64);
    if let Some((t, msg)) = &out.stopped {
        r.summary
            .warnings
            .push(format!("cosim stopped at t = {t} s: {msg}"));
        r.summary.set("stopped_at_s", *t);
    }
    Ok(r)
}

/// `cosim` (options: `[cosim]`).
pub struct Cosim;

/// Its name in scenarios and output files.
impl super::MethodId {
    #[allow(non_upper_case_globals)]
    pub const Cosim: Self = Self::new("cosim");
}

impl super::Method for Cosim {
    fn id(&self) -> Method {
        Method::Cosim
    }

    fn section(&self) -> Option<&'static str> {
        Some("cosim")
    }

    /// A matrices structure's own modal table goes into the structure FMU.
    fn needs_mode(&self, sc: &crate::scenario::Scenario) -> bool {
        sc.structure.matrices().is_some()
    }

    fn check(&self, _sc: &crate::scenario::Scenario, setup: &Setup) -> Result<()> {
        setup.check_cosim()
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        let Some(f) = ctx.fmus.as_ref() else {
            return Ok(MethodOutput::default()); // FMUs not packaged: a failed method
        };
        let mut bar = ctx.progress("cosim");
        let table = self.needs_mode(ctx.sc).then(|| (ctx.table(), ctx.out));
        let r = cosim(ctx.setup, ctx.sc, f, table, &mut |x| bar.set(x))?;
        bar.finish();
        Ok(MethodOutput::one(r))
    }
}
