//! `host`: the command-line front end of the nlmode tool.
//!
//! `host run [SCENARIO] -o DIR` sweeps through resonance by the methods the
//! scenario lists and writes the output contract (DESIGN.md section 7);
//! `host nma` computes the nonlinear mode; `host frf` the steady-state
//! frequency responses; `host package` builds the FMUs.
mod cosim;
mod cosim_cmd;
mod methods;
mod model;
mod nma_cmd;
mod package;
mod plot;
mod results;
mod run;
mod scenario;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "host",
    version,
    about = "Nonlinear vibration testing with attached exciters: sweeps, NMA, FMUs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Sweep through resonance by every method the scenario lists.
    Run {
        /// Scenario file (TOML); the embedded default (paper case (a)) if omitted.
        scenario: Option<PathBuf>,
        /// Output directory.
        #[arg(short, long, default_value = "out")]
        out: PathBuf,
    },
    /// Nonlinear modal analysis: modal table, backbone and damping plots.
    Nma {
        /// Scenario file (TOML); the embedded default if omitted.
        scenario: Option<PathBuf>,
        /// Output directory.
        #[arg(short, long, default_value = "out")]
        out: PathBuf,
    },
    /// Steady-state frequency response of the single-nonlinear-mode model (all branches).
    Frf {
        /// Scenario file (TOML); the embedded default if omitted.
        scenario: Option<PathBuf>,
        /// Output directory.
        #[arg(short, long, default_value = "out")]
        out: PathBuf,
    },
    /// Build structure.fmu and shaker.fmu (with the paper beam's modal table).
    Package {
        /// Output directory.
        #[arg(short, long, default_value = "out/fmus")]
        out: PathBuf,
    },
    /// Generic co-simulation: any FMI 2.0 CS FMUs and connections from a TOML file (docs/cosim.md).
    Cosim {
        /// Co-simulation file (TOML).
        spec: PathBuf,
        /// Output directory.
        #[arg(short, long, default_value = "out")]
        out: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run { scenario, out } => run::run(scenario.as_deref(), &out),
        Command::Nma { scenario, out } => nma_cmd::nma(scenario.as_deref(), &out),
        Command::Frf { scenario, out } => nma_cmd::frf(scenario.as_deref(), &out),
        Command::Cosim { spec, out } => cosim_cmd::cosim(&spec, &out),
        Command::Package { out } => package::package(&out).map(|paths| {
            for p in paths {
                println!("wrote {}", p.display());
            }
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
