//! The progress bar of long methods.

/// A progress bar that appears only when a method runs longer than a second.
pub struct Progress {
    /// Drawn at all (`host run`; not from the library API).
    enabled: bool,
    bar: indicatif::ProgressBar,
    start: std::time::Instant,
    shown: bool,
}

impl Progress {
    pub fn new(name: &str, show: bool) -> Self {
        let bar = indicatif::ProgressBar::hidden();
        bar.set_length(1000);
        bar.set_message(name.to_string());
        if let Ok(style) =
            indicatif::ProgressStyle::with_template("{msg:>12} [{bar:40}] {percent:>3}% {elapsed}")
        {
            bar.set_style(style.progress_chars("=> "));
        }
        Self {
            enabled: show,
            bar,
            start: std::time::Instant::now(),
            shown: false,
        }
    }

    pub fn set(&mut self, fraction: f64) {
        if self.enabled && !self.shown && self.start.elapsed().as_secs_f64() > 1.0 {
            self.bar
                .set_draw_target(indicatif::ProgressDrawTarget::stderr());
            self.shown = true;
        }
        self.bar
            .set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
    }

    pub fn finish(&self) {
        if self.shown {
            self.bar.finish_and_clear();
        }
    }
}
