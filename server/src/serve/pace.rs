//! `--realtime`: the loop paced to simulated time.

use std::time::{Duration, Instant};

/// Pacing against the wall clock for `--realtime`.
pub(super) struct Pace {
    factor: Option<f64>,
    wall0: Instant,
    sim0: f64,
}

impl Pace {
    pub(super) fn new(factor: Option<f64>, sim0: f64) -> Pace {
        Pace {
            factor,
            wall0: Instant::now(),
            sim0,
        }
    }
    /// Whether it paced (read the clock) at all.
    pub(super) fn wait(&self, sim: f64) -> bool {
        let Some(f) = self.factor else { return false };
        let due = self.wall0 + Duration::from_secs_f64(((sim - self.sim0) / f).max(0.0));
        loop {
            let now = Instant::now();
            if now >= due {
                return true;
            }
            let left = due - now;
            // Sleep most of the way, spin the last stretch: sleeps
            // overshoot by up to a scheduler tick.
            if left > Duration::from_micros(1500) {
                std::thread::sleep(left - Duration::from_millis(1));
            } else {
                std::hint::spin_loop();
            }
        }
    }
}
