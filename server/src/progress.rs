//! The live progress line of `run` and `serve`: one line on a terminal,
//! rewritten in place a few times a second; nothing when stderr is not a
//! terminal (a log, a pipe, CI) or the run is `--quiet`.

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

/// How often the line is rewritten at most.
const EVERY: Duration = Duration::from_millis(200);

pub struct Progress {
    on: bool,
    total: Option<u64>,
    started: Instant,
    last: Instant,
    drawn: bool,
}

impl Progress {
    /// A line for a run of `total` steps (`None`: no end).
    pub fn new(quiet: bool, total: Option<u64>) -> Progress {
        let now = Instant::now();
        Progress {
            on: !quiet && std::io::stderr().is_terminal(),
            total,
            started: now,
            last: now,
            drawn: false,
        }
    }

    /// After step `done` of the run: the line again if it is due, with
    /// `extra` (controllers, misses) after the rate. `extra` is called
    /// only then.
    pub fn tick(&mut self, done: u64, extra: impl FnOnce() -> String) {
        // A clock read every 64 steps: the lockstep's step is a few us.
        if !self.on || !done.is_multiple_of(64) {
            return;
        }
        let now = Instant::now();
        if now - self.last < EVERY {
            return;
        }
        self.last = now;
        let rate = done as f64 / (now - self.started).as_secs_f64().max(1e-9);
        let head = match self.total {
            Some(n) if n > 0 => {
                let frac = (done as f64 / n as f64).min(1.0);
                let bar = (frac * 30.0) as usize;
                format!(
                    "[{}{}] {:3.0}% step {done}/{n}",
                    "#".repeat(bar),
                    " ".repeat(30 - bar),
                    frac * 100.0
                )
            }
            _ => format!("step {done} (no end: Ctrl-C stops)"),
        };
        let mut err = std::io::stderr().lock();
        let _ = write!(err, "\r\x1b[K{head}, {rate:.0} steps/s{}", extra());
        let _ = err.flush();
        self.drawn = true;
    }

    /// Clears the line, so that what is printed next starts on its own.
    pub fn finish(&mut self) {
        if self.drawn {
            let mut err = std::io::stderr().lock();
            let _ = write!(err, "\r\x1b[K");
            let _ = err.flush();
            self.drawn = false;
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}
