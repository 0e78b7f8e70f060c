//! `host`: the command-line front end (clap and the exit code; the work is in
//! the `host` library).
//!
//! Exit status: 0 success; 2 error (nothing or not everything written);
//! 3 `host run` wrote the outputs of every method it could run but a
//! requested method could not run (e.g. `cosim` without the FMU libraries;
//! `summary.json` lists it under `failed_methods`).
use clap::{Parser, Subcommand};
use host::{cosim_cmd, nma_cmd, package, run, study};
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
        /// Folder with libstructure.so and libshaker.so (default: $NLMODE_FMU_DIR,
        /// else beside this executable).
        #[arg(long)]
        fmu_dir: Option<PathBuf>,
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
    /// Package structure.fmu and shaker.fmu (with the paper beam's modal table)
    /// from the built FMU libraries.
    Package {
        /// Output directory.
        #[arg(short, long, default_value = "out/fmus")]
        out: PathBuf,
        /// Folder with libstructure.so and libshaker.so (default: $NLMODE_FMU_DIR,
        /// else beside this executable).
        #[arg(long)]
        fmu_dir: Option<PathBuf>,
        /// FMI version of the FMUs: 2 (<id>.fmu), 3 (<id>_fmi3.fmu) or all (both).
        #[arg(long, default_value = "2", value_parser = ["2", "3", "all"])]
        fmi: String,
    },
    /// Generic co-simulation: any FMI 2.0 or 3.0 CS FMUs and connections from a TOML file (docs/cosim.md).
    Cosim {
        /// Co-simulation file (TOML).
        spec: PathBuf,
        /// Output directory.
        #[arg(short, long, default_value = "out")]
        out: PathBuf,
    },
    /// Parameter study: a design over any scenario keys, figures of merit per
    /// sample (results.csv, results.parquet, study_summary.json, plots/).
    Study {
        /// Study file (TOML): base scenario, parameters, design, method.
        study: PathBuf,
        /// Output directory.
        #[arg(short, long, default_value = "out/study")]
        out: PathBuf,
        /// Keep the finished samples of the same study in DIR and run the others.
        #[arg(long)]
        resume: bool,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Measurements (no files kept).
    #[command(subcommand)]
    Bench(BenchCommand),
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Samples per second of `host study` on an embedded case-(a) study at 1
    /// and 2 threads, the parallel efficiency, and against the
    /// envelope-storing path.
    Study {
        /// Samples of the study.
        #[arg(long, default_value_t = 4000)]
        samples: usize,
        /// Most worker threads (1, 2 and this are measured).
        #[arg(long, default_value_t = 2)]
        threads: usize,
        /// Repetitions (the best counts).
        #[arg(long, default_value_t = 2)]
        repeat: usize,
    },
}

/// `host run` wrote what it could, but a requested method could not run.
const EXIT_PARTIAL: u8 = 3;

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run {
            scenario,
            out,
            fmu_dir,
        } => run::run(scenario.as_deref(), &out, fmu_dir.as_deref()).map(|failed| {
            if failed.is_empty() {
                ExitCode::SUCCESS
            } else {
                for (m, e) in &failed {
                    eprintln!("error: method {m} could not run: {e}");
                }
                ExitCode::from(EXIT_PARTIAL)
            }
        }),
        Command::Nma { scenario, out } => {
            nma_cmd::nma(scenario.as_deref(), &out).map(|()| ExitCode::SUCCESS)
        }
        Command::Frf { scenario, out } => {
            nma_cmd::frf(scenario.as_deref(), &out).map(|()| ExitCode::SUCCESS)
        }
        Command::Study {
            study: spec,
            out,
            resume,
            threads,
        } => {
            let opts = study::Options {
                resume,
                threads,
                progress: true,
            };
            study::study(&spec, &out, &opts).map(|o| {
                println!(
                    "study: {} samples ({} computed, {} failed, {} distinct structures) on {} threads: \
                     structures and NMA {:.3} s, samples {:.3} s ({:.0} samples/s), total {:.3} s",
                    o.samples,
                    o.computed,
                    o.failed,
                    o.distinct_structures,
                    o.threads,
                    o.structures_s,
                    o.samples_s,
                    o.samples_per_s,
                    o.wall_time_s
                );
                println!("wrote {} files in {}", o.files.len(), out.display());
                ExitCode::SUCCESS
            })
        }
        Command::Bench(BenchCommand::Study {
            samples,
            threads,
            repeat,
        }) => study::bench::bench(samples, threads, repeat).map(|r| {
            for l in study::bench::lines(&r) {
                println!("{l}");
            }
            if r.identical {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(2)
            }
        }),
        Command::Cosim { spec, out } => cosim_cmd::cosim(&spec, &out).map(|()| ExitCode::SUCCESS),
        Command::Package { out, fmu_dir, fmi } => {
            let versions = host::fmus::FmiVersions::parse(&fmi).expect("clap checked --fmi");
            package::package_versions(&out, fmu_dir.as_deref(), versions).map(|paths| {
                for p in paths {
                    println!("wrote {}", p.display());
                }
                ExitCode::SUCCESS
            })
        }
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
