//! The skips of the step do not change the answer (issue #6): pruning,
//! no friction rows where mu = 0, Lemke's support guess, PGS warm start,
//! each on and off on the same scene (`cosim-server bench skips` times them).

use cosim_server::bench::skips;

#[test]
fn skips_do_not_change_the_trajectory() {
    let ms = skips::measure(2000).expect("scenes");
    for m in &ms {
        assert_eq!(
            m.on.failures + m.off.failures,
            0,
            "{}: a run failed",
            m.skip
        );
        assert_eq!(m.on.positions.len(), 2000, "{}", m.skip);
        // Pruning: identical to the bit (the canonical re-solve, prune.rs).
        // Friction rows at mu = 0 carry zero impulse: round-off apart.
        // Warm start changes only where PGS starts: each step's answer
        // agrees to the solver's tolerance (relative residual 1e-10 of
        // velocities of order 1 m/s); whole PGS trajectories of the chaotic
        // reference scene drift apart from that, so only steps are compared,
        // and only those where neither side stopped at the iteration cap
        // (closed-loop steps: the warm start from the last step's large
        // indeterminate impulses is what keeps PGS from converging there;
        // `bench skips` counts them).
        // Lemke's support guess gives the solution a pivoted path gives, by
        // another arithmetic (a small factorisation): each step agrees to
        // round-off (verified residual 1e-8 relative at most; velocities of
        // order 1 m/s), the chaotic trajectory then drifts as above.
        let (d, bound) = match m.skip {
            s if s.starts_with("pruning") => (skips::distance(&m.on, &m.off), 0.0),
            s if s.starts_with("no friction") => (skips::distance(&m.on, &m.off), 1e-12),
            s if s.starts_with("Lemke") => (m.per_step.difference, 1e-8),
            _ => (m.per_step.difference, 1e-6),
        };
        assert!(
            d <= bound,
            "{} on {}: differ by {d:e} (bound {bound:e})",
            m.skip,
            m.scene
        );
        assert!(
            m.per_step.difference <= 1e-6,
            "{}: one step apart by {:e}",
            m.skip,
            m.per_step.difference
        );
    }
}
