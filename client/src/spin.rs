//! The hybrid wait's spin (issue 47, point 3): spin while spinning pays,
//! block when it takes a core another process of the lockstep needs.
//!
//! Spinning wins when every process has a core: the answer arrives on
//! another core and the spinner sees it within a poll. It loses badly when
//! processes outnumber cores: the spinner holds the core its peer needs to
//! compute the answer, until the kernel preempts it (measured before this
//! rule: 2 controllers on 2 cores, 1,509 steps a second with a fixed 200 us
//! spin against 21,557 blocking). What tells the two apart is seen from
//! inside the spin at no cost: a spinner that is preempted finds a gap
//! between two of its polls (the time it was off the core), [`PREEMPTED`]
//! or more, where a spinner with a core of its own polls every fraction of
//! a microsecond.
//!
//! A spin that ends without its answer says the same more slowly: under
//! contention the kernel lets a spinner run out its budget before the
//! peer it waits for gets the core back, so the spin fails. On idle cores
//! a spin fails only when the wait is long (a heavy step), where blocking
//! costs a wake-up against a long wait anyway.
//!
//! So a wait spins for at most [`SpinRule::budget`]: twice what the recent
//! waits took (an average that forgets in about eight waits), within
//! [`MIN_SPIN`] and [`HYBRID_SPIN`]. A spin that fails (preempted or run
//! out) makes the next waits block outright for a cool-down that doubles
//! with each failure (up to [`MAX_COOLDOWN`] waits); a spin that ends in
//! its answer halves the next cool-down. On idle cores that is spinning;
//! on shared ones it is blocking but for one probe every few thousand
//! waits.

use std::time::{Duration, Instant};

/// The longest a hybrid wait spins before it blocks: a few step
/// computations of the reference scene (about 20 us each), so that a
/// controller on its own core wakes at spinning speed.
pub const HYBRID_SPIN: Duration = Duration::from_micros(200);

/// The shortest spin budget when spinning: below a wake-up's cost
/// (tens of microseconds), where blocking cannot win.
pub const MIN_SPIN: Duration = Duration::from_micros(20);

/// A gap between two polls of a spin that says the spinner was off its
/// core: a poll takes well under a microsecond, a timer interrupt a few.
pub const PREEMPTED: Duration = Duration::from_micros(50);

/// The longest cool-down (waits that block outright) after preempted
/// spins in a row.
pub const MAX_COOLDOWN: u32 = 4096;

/// One waiter's rule (a server's or a controller's): how long its next
/// wait spins, from how its last waits went.
#[derive(Debug, Clone, Copy)]
pub struct SpinRule {
    /// Mean wait (s), exponentially weighted.
    mean: f64,
    /// Waits left that block outright.
    cooldown: u32,
    /// The next cool-down's length.
    next_cooldown: u32,
    /// Preempted spins so far (reported by `bench ipc`).
    preemptions: u64,
}

impl Default for SpinRule {
    fn default() -> Self {
        SpinRule {
            mean: 0.0,
            cooldown: 0,
            next_cooldown: 0,
            preemptions: 0,
        }
    }
}

impl SpinRule {
    /// How long the next wait may spin (and counts a waiting cool-down's
    /// wait).
    pub fn budget(&mut self) -> Duration {
        if self.cooldown > 0 {
            self.cooldown -= 1;
            return Duration::ZERO;
        }
        Duration::from_secs_f64(2.0 * self.mean).clamp(MIN_SPIN, HYBRID_SPIN)
    }

    /// A spin's poll at `now` after the last at `last`: true when the gap
    /// says the spinner was preempted, which ends the spin (the caller
    /// blocks for the rest of the wait) as a failure.
    pub fn preempted(&mut self, last: Instant, now: Instant) -> bool {
        if now.saturating_duration_since(last) < PREEMPTED {
            return false;
        }
        self.preemptions += 1;
        self.failed();
        true
    }

    /// Whether a wait spinning since its last poll at `last` spins on at
    /// `now`, its spin budgeted to end at `until`. `adaptive` (the hybrid
    /// wait): a spin that ran out or was preempted fails (`failed`), and
    /// the rest of the wait blocks; otherwise it spins until `until`.
    pub fn keep_spinning(
        &mut self,
        adaptive: bool,
        last: Instant,
        now: Instant,
        until: Instant,
    ) -> bool {
        if now >= until {
            if adaptive {
                self.failed();
            }
            return false;
        }
        !(adaptive && self.preempted(last, now))
    }

    /// A spin ended without its answer (run out or preempted): the next
    /// waits block for a cool-down, twice the last one.
    pub fn failed(&mut self) {
        self.next_cooldown = (self.next_cooldown * 2).clamp(1, MAX_COOLDOWN);
        self.cooldown = self.next_cooldown;
    }

    /// A wait ended after `waited`; `spun` when its spin saw the answer.
    pub fn finished(&mut self, waited: Duration, spun: bool) {
        self.mean += (waited.as_secs_f64() - self.mean) / 8.0;
        if spun {
            self.next_cooldown /= 2;
        }
    }

    /// Preempted spins so far.
    pub fn preemptions(&self) -> u64 {
        self.preemptions
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_spin_blocks_the_next_waits_for_a_doubling_cooldown() {
        let mut r = SpinRule::default();
        assert_eq!(r.budget(), MIN_SPIN);
        let t = Instant::now();
        assert!(!r.preempted(t, t + Duration::from_micros(1)));
        // Preempted, run out, preempted: one wait blocks, then two, then four.
        for (k, expected) in [1, 2, 4].into_iter().enumerate() {
            if k == 1 {
                r.failed();
            } else {
                assert!(r.preempted(t, t + PREEMPTED));
            }
            for _ in 0..expected {
                assert_eq!(r.budget(), Duration::ZERO);
            }
            assert_eq!(r.budget(), MIN_SPIN);
        }
        assert_eq!(r.preemptions(), 2);
        // A spin that ends in its answer halves the next cool-down: from
        // 4 to 2, which the next failure doubles back to 4.
        r.finished(Duration::from_micros(5), true);
        r.failed();
        let blocked = |r: &mut SpinRule| {
            std::iter::repeat_with(|| r.budget())
                .take_while(|b| b.is_zero())
                .count()
        };
        assert_eq!(blocked(&mut r), 4);
        // Three in a row take it to none: a failure then blocks one wait.
        for _ in 0..3 {
            r.finished(Duration::from_micros(5), true);
        }
        r.failed();
        assert_eq!(blocked(&mut r), 1);
    }

    #[test]
    fn a_spin_ends_at_its_budget_and_fails_only_when_adaptive() {
        let t = Instant::now();
        let (poll, end) = (t + Duration::from_micros(1), t + MIN_SPIN);
        let mut r = SpinRule::default();
        // Within its budget and polled without a gap: it spins on.
        assert!(r.keep_spinning(true, t, poll, end));
        // Run out: a plain spin just stops; an adaptive one fails.
        assert!(!r.keep_spinning(false, t, end, end));
        assert_eq!(r.budget(), MIN_SPIN);
        assert!(!r.keep_spinning(true, t, end, end));
        assert_eq!(r.budget(), Duration::ZERO);
        // Preempted within its budget: adaptive only.
        let far = t + 4 * PREEMPTED;
        let gap = t + PREEMPTED;
        assert!(r.keep_spinning(false, t, gap, far));
        assert!(!r.keep_spinning(true, t, gap, far));
        assert_eq!(r.preemptions(), 1);
    }

    #[test]
    fn the_budget_follows_twice_the_recent_waits_within_its_bounds() {
        let mut r = SpinRule::default();
        for _ in 0..64 {
            r.finished(Duration::from_micros(40), false);
        }
        let b = r.budget().as_secs_f64();
        assert!((b - 80e-6).abs() < 1e-6, "{b}");
        for _ in 0..64 {
            r.finished(Duration::from_millis(5), false);
        }
        assert_eq!(r.budget(), HYBRID_SPIN);
        // The cool-down is capped.
        for _ in 0..20 {
            r.failed();
        }
        let blocked = std::iter::repeat_with(|| r.budget())
            .take_while(|b| b.is_zero())
            .count();
        assert_eq!(blocked, MAX_COOLDOWN as usize);
    }
}
