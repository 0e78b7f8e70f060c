//! `host cosim SPEC -o DIR`: the generic mode of the co-simulation master:
//! any FMI 2.0 or FMI 3.0 Co-Simulation FMUs (mixed freely), connections and parameters from a TOML file
//! (format in `docs/cosim.md`, read by [`cosim::spec`]), recorded variables
//! written to `cosim.csv`.
use crate::results::write_csv;
use anyhow::{bail, Context, Result};
use cosim::master::run_generic;
use std::path::Path;

/// Run the generic co-simulation described by the TOML file `path`.
pub fn cosim(path: &Path, out: &Path) -> Result<()> {
    let g = cosim::spec::load_spec(path)?;
    let rec =
        run_generic(&g, &mut |_| {}).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut header = vec!["t_s".to_string()];
    let mut cols: Vec<&[f64]> = vec![&rec.time_s];
    for (n, v) in &rec.columns {
        header.push(n.clone());
        cols.push(v);
    }
    write_csv(&out.join("cosim.csv"), &header, &cols)?;
    let iterative = if g.options.algorithm == cosim::Algorithm::Iterative {
        format!(
            ", {} interface evaluations, Jacobians: {} by finite differences, {} from directional derivatives",
            rec.stats.evaluations, rec.stats.jacobian_builds, rec.stats.directional_jacobians
        )
    } else {
        String::new()
    };
    println!(
        "{} macro steps of {} s ({} unit steps{iterative}) in {:.3} s; wrote {}",
        rec.stats.steps,
        g.options.macro_step_s,
        rec.stats.do_steps,
        rec.wall_time_s,
        out.join("cosim.csv").display()
    );
    if let Some((t, msg)) = &rec.stopped {
        bail!("co-simulation stopped at t = {t} s (results up to there are in cosim.csv): {msg}");
    }
    Ok(())
}
