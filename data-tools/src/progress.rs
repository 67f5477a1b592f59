//! A one-line progress report on stderr for long work: fraction done, rate and time left.

use std::io::Write;
use std::time::Instant;

pub struct Progress {
    label: String,
    total: u64,
    done: u64,
    unit: &'static str,
    started: Instant,
    last_print: Option<Instant>,
}

impl Progress {
    pub fn new(label: impl Into<String>, total: u64, unit: &'static str) -> Self {
        Self {
            label: label.into(),
            total: total.max(1),
            done: 0,
            unit,
            started: Instant::now(),
            last_print: None,
        }
    }

    pub fn add(&mut self, n: u64) {
        self.done += n;
        let now = Instant::now();
        if self
            .last_print
            .is_none_or(|t| now.duration_since(t).as_millis() >= 250)
            || self.done >= self.total
        {
            self.last_print = Some(now);
            self.print();
        }
    }

    fn print(&self) {
        let elapsed = self.started.elapsed().as_secs_f64().max(1e-9);
        let rate = self.done as f64 / elapsed;
        let left = (self.total.saturating_sub(self.done)) as f64 / rate.max(1e-9);
        let pct = 100.0 * self.done as f64 / self.total as f64;
        eprint!(
            "\r{}: {pct:5.1} % ({} / {} {}, {:.0} {}/s, {:.0} s left)   ",
            self.label, self.done, self.total, self.unit, rate, self.unit, left
        );
        let _ = std::io::stderr().flush();
    }

    /// Ends the line and returns the elapsed seconds.
    pub fn finish(self) -> f64 {
        self.print();
        eprintln!();
        self.started.elapsed().as_secs_f64()
    }
}
