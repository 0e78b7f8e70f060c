//! The per-sample work of `host study` of case (a) by `nlmode` (issue 27,
//! item 4), without the host: one slow-flow sweep of the paper's beam with
//! the paper's shaker at 2l/3 from 0.8 to 1.8 omega0 (the default 2,001
//! output samples), the voltage and the rate drawn as the bench study draws
//! them (2-10 V, 1-3 % per pseudo period), its samples folded as they are computed
//! (`simulate_sweep_folded`: the envelope fields only, as the study's figures
//! of merit).
//!
//! `cargo bench -p nlmode --bench study_sweep [-- SWEEPS]` prints the CPU
//! time per sweep and a checksum of the folded figures (equal before and
//! after a change of the output path: the numbers must not move). Run it
//! under `valgrind --tool=callgrind` for the instructions per sweep.
//! `STUDY_SWEEP_TABLE=modal_table.json` takes the table `host nma` wrote
//! (the default scenario's: H = 7, 152 amplitudes) instead of the paper
//! beam's at H = 3.
use nlmode::attachment::{LinearAttachment, ShakerParams};
use nlmode::excitation::LinearSweep;
use nlmode::nma::{nonlinear_modal_analysis, TablePolicy};
use nlmode::reduced::{EnvelopeBatch, EnvelopeFold, ReducedError, ReducedModel, SlowFlowOptions};
use nlmode::structure::{paper_structure, PaperStructureOptions};
use nlmode::Complex64;

/// Peak tip amplitude, its frequency and the force extremes (a figure fold).
#[derive(Default)]
struct Fold {
    peak: (f64, f64),
    fmin: f64,
    fmax: f64,
    count: usize,
}

impl EnvelopeFold for Fold {
    fn fold<B: EnvelopeBatch>(&mut self, batch: B) -> Result<(), ReducedError> {
        batch.each(|x, y, f| {
            if y > self.peak.0 {
                self.peak = (y, x);
            }
            self.fmin = self.fmin.min(f);
            self.fmax = self.fmax.max(f);
            self.count += 1;
        })
    }
}

/// Process CPU time [s] (utime + stime from /proc/self/stat).
fn cpu_time_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

fn main() {
    // `cargo bench` passes `--bench`; the first number is the sweep count
    let sweeps: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(2000);
    // the table of `host nma` (e.g. the default scenario's) if given, else
    // the paper beam's of nlmode's benchmarks
    let table: nlmode::nma::ModalTable = match std::env::var("STUDY_SWEEP_TABLE") {
        Ok(path) => serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap(),
        Err(_) => {
            let ps = paper_structure(&PaperStructureOptions::default()).unwrap();
            nonlinear_modal_analysis(&ps.model, &nlmode::benchmark::sweep_table_options())
                .unwrap()
                .to_table(TablePolicy::PrimaryBranch)
        }
    };
    let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
    let m = ReducedModel::new(&table, "tip", "2l3")
        .unwrap()
        .with_linear_attachment(&shaker, &[Complex64::new(1.0, 0.0)])
        .unwrap();
    let omega0 = table.omega_rad_s[0];
    let opts = SlowFlowOptions::default();
    // a Weyl sequence over (voltage, rate): deterministic, spread like an LHS
    let (g1, g2) = (0.754_877_666_246_692_7, 0.569_840_290_998_053_3);
    let zero = Complex64::new(0.0, 0.0);
    let (mut checksum, mut samples) = (0.0, 0);
    let t0 = cpu_time_s();
    for j in 0..sweeps {
        let (u1, u2) = ((j as f64 * g1).fract(), (j as f64 * g2).fract());
        let sweep =
            LinearSweep::per_pseudo_period(omega0, 0.8, 1.8, 0.01 + 0.02 * u2, 2.0 + 8.0 * u1)
                .unwrap();
        let mut fold = Fold {
            fmin: f64::INFINITY,
            fmax: f64::NEG_INFINITY,
            ..Default::default()
        };
        m.simulate_sweep_folded(&sweep, &opts, zero, &mut fold)
            .unwrap();
        checksum += fold.peak.0 * 1e3 + fold.peak.1 + fold.fmin + fold.fmax;
        samples += fold.count;
    }
    let cpu = cpu_time_s() - t0;
    println!(
        "study_sweep: {sweeps} sweeps, {samples} output samples, {:.1} us CPU per sweep \
         ({:.0} sweeps/s), checksum {checksum:.17e}",
        1e6 * cpu / sweeps as f64,
        sweeps as f64 / cpu.max(1e-9)
    );
}
