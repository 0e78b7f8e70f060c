//! `host run`: scenario -> setup -> methods -> output contract, plots, summary.
use crate::model::Setup;
use crate::plot;
use crate::results::{self, MethodResult, Summary};
use crate::scenario::{Method, Scenario, ScenarioSource};
use anyhow::{Context, Result};
use std::path::Path;

pub use crate::results::FailedMethods;
pub use crate::scenario::MAX_SCENARIO_BYTES;

/// Read a scenario file (a regular file of at most [`MAX_SCENARIO_BYTES`]: a
/// named pipe or device is refused without blocking) or take the embedded
/// default: [`crate::methods::load_scenario`].
pub fn load_scenario(path: Option<&Path>) -> Result<(Scenario, String)> {
    crate::methods::load_scenario(
        match path {
            None => ScenarioSource::Default,
            Some(p) => ScenarioSource::File(p),
        },
        None,
    )
}

/// `host run`: every method the scenario lists that can run is run and its
/// outputs written. A method that cannot run for want of something outside
/// the scenario (today: `cosim` without the FMU libraries, see
/// [`crate::fmus::locate_libraries`]) does not stop the others; it is
/// returned (and listed under `failed_methods` in summary.json), so that the
/// command line can exit non-zero. `fmu_dir`: where the FMU libraries are
/// (`--fmu-dir`).
pub fn run(path: Option<&Path>, out: &Path, fmu_dir: Option<&Path>) -> Result<FailedMethods> {
    let (sc, source) = load_scenario(path)?;
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    let r = crate::api::compute(
        &sc,
        &source,
        out,
        &crate::api::Options {
            fmu_dir: fmu_dir.map(Path::to_path_buf),
            echo: true,
            package_fmus: true,
        },
    )?;
    write_outputs(&sc, &r.setup, out, &r.results, &r.summary)?;
    print_summary(&r.setup, &r.results, &r.summary);
    Ok(r.failed)
}

fn write_outputs(
    sc: &Scenario,
    setup: &Setup,
    out: &Path,
    done: &[MethodResult],
    summary: &Summary,
) -> Result<()> {
    for r in done {
        results::write_envelope(out, r)?;
        if sc.output.time_series {
            results::write_time_series(out, r)?;
        }
    }
    let path = out.join("summary.json");
    std::fs::write(&path, serde_json::to_string_pretty(summary)?)
        .with_context(|| format!("cannot write {}", path.display()))?;
    if sc.output.plots {
        let refs: Vec<&MethodResult> = done.iter().collect();
        let title = if sc.title.is_empty() {
            "sweep".to_string()
        } else {
            sc.title.clone()
        };
        // The reference's time signals in grey under the envelopes, as in the paper's figures.
        let signal_cols = done
            .iter()
            .find(|r| r.name == Method::Reference.name())
            .and_then(|r| r.time_series.as_ref())
            .map(|ts| {
                let col = |n: &str| {
                    ts.columns
                        .iter()
                        .find(|(c, _)| c == n)
                        .map(|(_, v)| v.clone())
                        .unwrap_or_default()
                };
                let eta: Vec<f64> = col("omega_rad_s")
                    .iter()
                    .map(|w| w / setup.omega0_rad_s)
                    .collect();
                (eta, col("force_N"), col("tip_m"))
            });
        let signal = signal_cols.as_ref().map(|(eta, f, x)| plot::Signal {
            eta,
            force_n: f,
            tip_m: x,
        });
        plot::sweep_plot(
            &out.join("sweep.svg"),
            &title,
            setup.omega0_rad_s,
            &refs,
            signal,
        )?;
    }
    Ok(())
}

fn print_summary(setup: &Setup, done: &[MethodResult], summary: &Summary) {
    println!();
    println!(
        "{:<18} {:>10} {:>14} {:>12} {:>12} {:>12} {:>10}",
        "method",
        "wall [s]",
        "peak tip [mm]",
        "at Omega/w0",
        "min |F| [N]",
        "max |F| [N]",
        "drop [%]"
    );
    for r in done {
        let s = &summary.methods[&r.name];
        let g = |v: Option<f64>| v.unwrap_or(f64::NAN);
        // the linear methods' `force_drop` (null: not finite)
        let drop = s
            .extra
            .get("force_drop")
            .map(|d| format!("{:.1}", 100.0 * d.as_f64().unwrap_or(f64::NAN)))
            .unwrap_or_default();
        println!(
            "{:<18} {:>10.4} {:>14.4} {:>12.4} {:>12.4} {:>12.4} {:>10}",
            r.name,
            s.wall_time_s,
            1e3 * g(s.peak_tip_amplitude_m),
            g(s.peak_omega_rad_s) / setup.omega0_rad_s,
            g(s.min_force_amplitude_n),
            g(s.max_force_amplitude_n),
            drop
        );
    }
    if let Some(x) = summary.speedup_nlmode_over_reference {
        println!("nlmode is {x:.0} times faster than reference");
    }
}
