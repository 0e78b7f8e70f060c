//! `host bench study`: the throughput of `host study` on an embedded
//! case-(a) study (`nlmode`, Latin hypercube over the voltage and the sweep
//! rate, one structure), results written to a temporary folder.
//!
//! Each thread count runs the study twice per repetition, once with the
//! figures of merit folded as the sweep integrates ([`SweepPath::Fold`],
//! what `host study` does) and once with the sweep's samples stored first
//! ([`SweepPath::Stored`], the path before the sink), interleaved so that
//! the load of a shared machine hits both alike; the best of the
//! repetitions counts. The two paths must write the same `results.csv`
//! (checked, byte for byte). No timing is asserted anywhere: this prints.
use super::{run_study_with, Options, Study, SweepPath};
use anyhow::{bail, Context, Result};
use std::path::Path;

/// Largest `--samples` of the bench.
pub const MAX_SAMPLES: usize = 1_000_000;
/// Largest `--threads` and `--repeat` of the bench.
pub const MAX_THREADS: usize = 256;
pub const MAX_REPEAT: usize = 100;

/// Samples per second of one configuration (best of the repetitions).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Point {
    pub threads: usize,
    /// Figures folded as the sweep integrates.
    pub fold_samples_per_s: f64,
    /// The sweep's samples stored, then folded.
    pub stored_samples_per_s: f64,
}

/// What [`bench`] measured.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Report {
    pub samples: usize,
    pub repeat: usize,
    pub points: Vec<Point>,
    /// Both paths wrote the same `results.csv`.
    pub identical: bool,
}

impl Report {
    /// Parallel efficiency of `p` against one thread (fold path).
    pub fn efficiency(&self, p: &Point) -> f64 {
        let one = self.points[0].fold_samples_per_s;
        p.fold_samples_per_s / (one * p.threads as f64 / self.points[0].threads as f64)
    }
}

/// The embedded study of `samples` samples.
fn study_text(samples: usize) -> String {
    format!(
        "method = \"nlmode\"\ndesign = \"lhs\"\nsamples = {samples}\nseed = 1\n\
         [[parameter]]\nkey = \"excitation.voltage_v\"\ndistribution = \"uniform\"\nlow = 2.0\nhigh = 10.0\n\
         [[parameter]]\nkey = \"excitation.rate_per_pseudo_period\"\ndistribution = \"uniform\"\n\
         low = 0.01\nhigh = 0.03\n"
    )
}

/// Run the bench at 1 and `threads` threads (`threads` >= 2 also runs 2).
pub fn bench(samples: usize, threads: usize, repeat: usize) -> Result<Report> {
    if !(1..=MAX_SAMPLES).contains(&samples) {
        bail!("--samples: {samples} is not in 1..={MAX_SAMPLES}");
    }
    if !(1..=MAX_THREADS).contains(&threads) {
        bail!("--threads: {threads} is not in 1..={MAX_THREADS}");
    }
    if !(1..=MAX_REPEAT).contains(&repeat) {
        bail!("--repeat: {repeat} is not in 1..={MAX_REPEAT}");
    }
    let st = Study::from_text(&study_text(samples), Path::new("."))?;
    let tmp = tempfile::tempdir().context("bench: cannot create a temporary folder")?;
    let mut counts = vec![1];
    if threads >= 2 {
        counts.push(2);
    }
    if threads > 2 {
        counts.push(threads);
    }
    let opts = |t: usize| Options {
        resume: false,
        threads: Some(t),
        progress: false,
    };
    let mut points = Vec::new();
    let mut identical = true;
    for &t in &counts {
        let (mut fold, mut stored) = (0.0f64, 0.0f64);
        for r in 0..repeat {
            let a = tmp.path().join(format!("fold-{t}-{r}"));
            let b = tmp.path().join(format!("stored-{t}-{r}"));
            fold = fold.max(run_study_with(&st, &a, &opts(t), SweepPath::Fold)?.samples_per_s);
            stored =
                stored.max(run_study_with(&st, &b, &opts(t), SweepPath::Stored)?.samples_per_s);
            let read = |d: &Path| std::fs::read(d.join("results.csv")).ok();
            identical &= read(&a).is_some() && read(&a) == read(&b);
            let _ = std::fs::remove_dir_all(&a);
            let _ = std::fs::remove_dir_all(&b);
        }
        points.push(Point {
            threads: t,
            fold_samples_per_s: fold,
            stored_samples_per_s: stored,
        });
    }
    Ok(Report {
        samples,
        repeat,
        points,
        identical,
    })
}

/// The report as the lines `host bench study` prints.
pub fn lines(r: &Report) -> Vec<String> {
    let mut out = vec![format!(
        "bench study: case (a) by nlmode, {} samples, best of {}, results written",
        r.samples, r.repeat
    )];
    for p in &r.points {
        out.push(format!(
            "  {} thread(s): {:.0} samples/s folded, {:.0} samples/s stored (x{:.2}), \
             parallel efficiency {:.0} %",
            p.threads,
            p.fold_samples_per_s,
            p.stored_samples_per_s,
            p.fold_samples_per_s / p.stored_samples_per_s,
            100.0 * r.efficiency(p)
        ));
    }
    out.push(format!(
        "  results.csv of both paths identical: {}",
        if r.identical { "yes" } else { "NO" }
    ));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_bench_runs_and_both_paths_agree() {
        let r = bench(6, 1, 1).unwrap();
        assert!(r.identical, "{r:?}");
        assert_eq!(r.points.len(), 1);
        assert_eq!(lines(&r).len(), 3);
        assert!(bench(0, 2, 1).is_err());
        assert!(bench(10, 0, 1).is_err());
        assert!(bench(10, 2, MAX_REPEAT + 1).is_err());
    }
}
