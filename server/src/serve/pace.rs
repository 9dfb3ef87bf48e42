//! `--realtime`: the loop paced to simulated time.

use std::time::{Duration, Instant};

/// How far behind its schedule the loop may fall before pacing starts
/// over from where it is, instead of running steps back to back to catch
/// up (a stall, a pause in a debugger, a machine under load).
const BEHIND: Duration = Duration::from_millis(50);

/// Pacing against the wall clock for `--realtime`.
pub(super) struct Pace {
    factor: Option<f64>,
    wall0: Instant,
    sim0: f64,
    /// How often the schedule started over after a stall.
    pub(super) restarts: u64,
}

impl Pace {
    pub(super) fn new(factor: Option<f64>, sim0: f64) -> Pace {
        Pace {
            factor,
            wall0: Instant::now(),
            sim0,
            restarts: 0,
        }
    }
    /// Waits until simulated time `sim` is due; whether it paced (read the
    /// clock) at all. More than [`BEHIND`] late, the schedule starts over
    /// at `sim` now (issue 46: after a stall the loop ran steps back to
    /// back until it caught up).
    pub(super) fn wait(&mut self, sim: f64) -> bool {
        let Some(f) = self.factor else { return false };
        let due = self.wall0 + Duration::from_secs_f64(((sim - self.sim0) / f).max(0.0));
        loop {
            let now = Instant::now();
            if now >= due {
                if now - due > BEHIND {
                    if self.restarts == 0 {
                        tracing::warn!(
                            "--realtime: {:.0} ms behind the schedule; pacing starts over from here (later restarts are not logged)",
                            (now - due).as_secs_f64() * 1e3
                        );
                    }
                    self.wall0 = now;
                    self.sim0 = sim;
                    self.restarts += 1;
                }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 46: after a stall the schedule starts over. 120 ms late, the
    /// next step is taken at once and counted as a restart; the one after
    /// it waits its own 10 ms (a sleep never ends early), where the old
    /// pacing ran the late steps back to back.
    #[test]
    fn a_stall_restarts_the_schedule_instead_of_catching_up() {
        let mut p = Pace::new(Some(1.0), 0.0);
        assert!(p.wait(0.0));
        std::thread::sleep(Duration::from_millis(120));
        assert!(p.wait(0.01));
        assert_eq!(p.restarts, 1);
        let start = Instant::now();
        assert!(p.wait(0.02));
        assert!(
            start.elapsed() >= Duration::from_millis(9),
            "{:?}",
            start.elapsed()
        );
        assert_eq!(p.restarts, 1);
    }
}
