//! Wall time, CPU time and peak memory of the stages of the large-model path
//! (read, check, order, factor, eigen, constraint modes, project), for
//! `summary.json` (`structure_stages`) and `modal_table.json` (`provenance`).
//! CPU and peak memory are the process' (Linux `/proc/self`; `NaN` and 0
//! elsewhere): a stage's CPU is the difference over the stage.
use nlmode::structure::sparse::{Progress, Stage, StageSample};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The process' CPU time (user + system) [s] from `/proc/self/stat` (clock
/// ticks of 1/100 s, Linux' `USER_HZ`); `NaN` where unknown.
pub fn cpu_s() -> f64 {
    let Ok(t) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    // the fields after the command name (which may hold spaces) in parentheses
    let rest = t.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are the 14th and 15th fields, 12th and 13th after ')'
    match (f.get(11), f.get(12)) {
        (Some(u), Some(s)) => match (u.parse::<f64>(), s.parse::<f64>()) {
            (Ok(u), Ok(s)) => (u + s) / 100.0,
            _ => f64::NAN,
        },
        _ => f64::NAN,
    }
}

/// The process' peak resident memory so far [bytes] (`VmHWM`), 0 where unknown.
pub fn peak_rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|t| {
            let l = t.lines().find(|l| l.starts_with("VmHWM:"))?.to_string();
            l.split_whitespace().nth(1)?.parse::<u64>().ok()
        })
        .map_or(0, |kb| kb * 1024)
}

/// The start of a stage: wall clock and CPU time.
#[derive(Debug, Clone, Copy)]
pub struct StageClock {
    wall: Instant,
    cpu: f64,
}

impl StageClock {
    pub fn now() -> Self {
        Self {
            wall: Instant::now(),
            cpu: cpu_s(),
        }
    }

    /// The stage `name` from this start to now.
    pub fn sample(&self, name: &str) -> StageSample {
        StageSample {
            stage: name.into(),
            wall_s: self.wall.elapsed().as_secs_f64(),
            cpu_s: cpu_s() - self.cpu,
            peak_rss_bytes: peak_rss_bytes(),
        }
    }
}

/// The stages reported by nlmode's progress callback, in order.
#[derive(Clone)]
pub struct StageLog {
    inner: Arc<Mutex<(f64, Vec<StageSample>)>>,
}

impl Default for StageLog {
    fn default() -> Self {
        Self {
            inner: Arc::new(Mutex::new((cpu_s(), Vec::new()))),
        }
    }
}

impl StageLog {
    /// The callback for [`nlmode::structure::sparse::SparseOptions::progress`].
    pub fn progress(&self) -> Progress {
        let inner = self.inner.clone();
        Arc::new(move |stage: Stage, dt: Duration| {
            let cpu = cpu_s();
            let mut g = inner.lock().unwrap_or_else(|e| e.into_inner());
            let sample = StageSample {
                stage: stage.name().into(),
                wall_s: dt.as_secs_f64(),
                cpu_s: cpu - g.0,
                peak_rss_bytes: peak_rss_bytes(),
            };
            g.0 = cpu;
            g.1.push(sample);
        })
    }

    /// The stages so far (the log is emptied).
    pub fn take(&self) -> Vec<StageSample> {
        std::mem::take(&mut self.inner.lock().unwrap_or_else(|e| e.into_inner()).1)
    }
}
