//! Progress of long work on stderr (the globe-data imports, `globe report`, `globe bench`, the
//! import of a raster into the cache): an `indicatif` bar when stderr is a terminal; otherwise
//! (CI logs, pipes) plain lines, at most one every [`LINE_INTERVAL`] plus one at the end, so
//! that a log holds a readable history instead of carriage returns.

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// The most often a line is written when stderr is not a terminal.
pub const LINE_INTERVAL: Duration = Duration::from_secs(5);

/// How progress is shown.
enum Output {
    Bar(ProgressBar),
    /// Lines to this writer, at most one per interval (zero: one per update).
    Lines {
        out: Box<dyn Write + Send>,
        interval: Duration,
        last: Option<Instant>,
    },
}

/// Progress of `total` units of work (`unit` names them: "rows", "frames"; None for a bare
/// fraction).
pub struct Progress {
    label: String,
    total: u64,
    done: u64,
    unit: Option<&'static str>,
    message: String,
    started: Instant,
    output: Output,
}

impl Progress {
    /// A bar on a terminal, lines every [`LINE_INTERVAL`] otherwise.
    pub fn new(label: impl Into<String>, total: u64, unit: Option<&'static str>) -> Self {
        let output = if std::io::stderr().is_terminal() {
            Output::Bar(terminal_bar(total, unit))
        } else {
            Output::Lines {
                out: Box::new(std::io::stderr()),
                interval: LINE_INTERVAL,
                last: None,
            }
        };
        Self::with_output(label.into(), total, unit, output)
    }

    /// Plain lines to `out`, at most one per `interval` (and always the last): what
    /// [`Progress::new`] writes when stderr is not a terminal.
    pub fn lines(
        label: impl Into<String>,
        total: u64,
        unit: Option<&'static str>,
        out: Box<dyn Write + Send>,
        interval: Duration,
    ) -> Self {
        let output = Output::Lines {
            out,
            interval,
            last: None,
        };
        Self::with_output(label.into(), total, unit, output)
    }

    fn with_output(label: String, total: u64, unit: Option<&'static str>, output: Output) -> Self {
        if let Output::Bar(bar) = &output {
            bar.set_prefix(label.clone());
        }
        Self {
            label,
            total: total.max(1),
            done: 0,
            unit,
            message: String::new(),
            started: Instant::now(),
            output,
        }
    }

    /// `n` more units done.
    pub fn add(&mut self, n: u64) {
        self.set(self.done.saturating_add(n));
    }

    /// `done` units done in all.
    pub fn set(&mut self, done: u64) {
        self.done = done.min(self.total);
        self.show(false);
    }

    /// The fraction done, 0…1 (for work that reports only that; `total` sets the resolution).
    pub fn set_fraction(&mut self, fraction: f64) {
        let f = if fraction.is_finite() {
            fraction.clamp(0.0, 1.0)
        } else {
            0.0
        };
        self.set((f * self.total as f64).round() as u64);
    }

    /// What is being done now, shown beside the bar (on a line of its own without a terminal,
    /// since a step is worth a line).
    pub fn step(&mut self, done: u64, message: impl Into<String>) {
        self.message = message.into();
        self.done = done.min(self.total);
        if let Output::Bar(bar) = &self.output {
            bar.set_message(self.message.clone());
        }
        self.show(true);
    }

    /// What is being done now, within the current step (a step's own progress): shown beside
    /// the bar, or in the next rate-limited line.
    pub fn note(&mut self, message: impl Into<String>) {
        self.message = message.into();
        if let Output::Bar(bar) = &self.output {
            bar.set_message(self.message.clone());
        }
        self.show(false);
    }

    fn show(&mut self, force: bool) {
        let line = self.line();
        match &mut self.output {
            Output::Bar(bar) => bar.set_position(self.done),
            Output::Lines {
                out,
                interval,
                last,
            } => {
                let now = Instant::now();
                if force || last.is_none_or(|t| now.duration_since(t) >= *interval) {
                    *last = Some(now);
                    let _ = writeln!(out, "{line}");
                }
            }
        }
    }

    /// `label: 42.0 % (420 / 1000 rows, 85 rows/s, 7 s left) message`.
    fn line(&self) -> String {
        let elapsed = self.started.elapsed().as_secs_f64().max(1e-9);
        let rate = self.done as f64 / elapsed;
        let pct = 100.0 * self.done as f64 / self.total as f64;
        let mut line = format!("{}: {pct:5.1} %", self.label);
        let left = (self.total - self.done) as f64 / rate;
        let left = if rate > 0.0 && left.is_finite() {
            format!("{left:.0} s left")
        } else {
            "time left unknown".into()
        };
        // Slow work (report steps of seconds each) keeps two digits of its rate.
        let digits = if rate < 10.0 { 2 } else { 0 };
        match self.unit {
            Some(u) => {
                let (done, total) = (self.done, self.total);
                line += &format!(" ({done} / {total} {u}, {rate:.digits$} {u}/s, {left})");
            }
            None => line += &format!(" ({left})"),
        }
        if !self.message.is_empty() {
            line += &format!("  {}", self.message);
        }
        line
    }

    /// Ends the display with one line, `label: done, 22 steps in 78.4 s`, and returns the
    /// elapsed seconds.
    pub fn finish(mut self) -> f64 {
        let seconds = self.started.elapsed().as_secs_f64();
        let units = self.unit.map(|u| format!(", {} {u}", self.total));
        let done = format!(
            "{}: done{} in {seconds:.1} s",
            self.label,
            units.unwrap_or_default()
        );
        match &mut self.output {
            // The bar gives way to the same closing line as in a log.
            Output::Bar(bar) => {
                bar.finish_and_clear();
                eprintln!("{done}");
            }
            Output::Lines { out, .. } => {
                let _ = writeln!(out, "{done}");
            }
        }
        seconds
    }
}

/// The bar's layout: label, bar, counts (or percent), rate and time left, the current step.
fn bar_template(unit: Option<&'static str>) -> String {
    let counts = match unit {
        Some(u) => format!("{{human_pos}}/{{human_len}} {u} ({{per_sec}}, {{eta}} left)"),
        None => "{percent:>3} % ({eta} left)".into(),
    };
    format!("{{prefix}} {{wide_bar}} {counts} {{msg}}")
}

fn terminal_bar(total: u64, unit: Option<&'static str>) -> ProgressBar {
    // The templates are fixed and checked by a test.
    let style = ProgressStyle::with_template(&bar_template(unit))
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");
    ProgressBar::with_draw_target(Some(total.max(1)), ProgressDrawTarget::stderr())
        .with_style(style)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// A writer the test can read back.
    #[derive(Clone, Default)]
    struct Sink(Arc<Mutex<Vec<u8>>>);

    impl Write for Sink {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Sink {
        fn text(&self) -> String {
            String::from_utf8(self.0.lock().unwrap().clone()).unwrap()
        }
    }

    #[test]
    fn the_bar_templates_parse() {
        for unit in [None, Some("rows")] {
            assert!(ProgressStyle::with_template(&bar_template(unit)).is_ok());
        }
    }

    #[test]
    fn without_a_terminal_progress_is_plain_lines() {
        let sink = Sink::default();
        let mut p = Progress::lines(
            "import",
            10,
            Some("rows"),
            Box::new(sink.clone()),
            Duration::ZERO,
        );
        for _ in 0..10 {
            p.add(1);
        }
        p.finish();
        let text = sink.text();
        assert!(!text.contains('\r') && !text.contains('\u{1b}'), "{text:?}");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 11, "{text}");
        assert!(
            lines[0].starts_with("import:  10.0 % (1 / 10 rows"),
            "{}",
            lines[0]
        );
        assert!(
            lines[9].starts_with("import: 100.0 % (10 / 10 rows"),
            "{}",
            lines[9]
        );
        assert!(
            lines[10].starts_with("import: done, 10 rows in "),
            "{}",
            lines[10]
        );
    }

    #[test]
    fn lines_are_rate_limited_but_steps_and_the_end_always_show() {
        let sink = Sink::default();
        let hour = Duration::from_secs(3600);
        let mut p = Progress::lines("report", 4, None, Box::new(sink.clone()), hour);
        p.set_fraction(0.25);
        p.set_fraction(0.5);
        p.set_fraction(f64::NAN);
        p.step(3, "ground: setting n=256");
        p.finish();
        let text = sink.text();
        let lines: Vec<&str> = text.lines().collect();
        // The first update, the step, the end; the others fell within the hour.
        assert_eq!(lines.len(), 3, "{text}");
        assert!(lines[0].starts_with("report:  25.0 %"));
        assert!(
            lines[1].starts_with("report:  75.0 %") && lines[1].ends_with("ground: setting n=256")
        );
        assert!(lines[2].starts_with("report: done in "), "{}", lines[2]);
    }
}
