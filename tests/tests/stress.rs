//! The pass/fail part of the stress suite (`cosim-server bench stress`,
//! issue #6), with the solvers that pass it. `bench/results/stress.md`
//! holds the whole table, failures included (PGS at mass ratios >= 1e3,
//! Lemke alone on the 10^6-step run).

use cosim_bench::stress::{self, Outcome};
use cosim_shared::SolverChoice::{self, Auto, Lemke, Pgs};

fn check(o: Outcome) {
    assert!(
        o.pass,
        "{} with {}: {} [{}] {}",
        o.case,
        o.solver.as_str(),
        o.figure,
        o.solvers,
        o.note
    );
}

#[test]
fn heavy_on_light_up_to_1e4_rests_exactly() {
    for solver in [Lemke, Auto] {
        for ratio in [1.0, 1e1, 1e2, 1e3, 1e4] {
            check(stress::stack(ratio, solver));
        }
    }
    // PGS holds the stack up to 1:100 (at 1:1000 it hits its cap).
    for ratio in [1.0, 1e1, 1e2] {
        check(stress::stack(ratio, Pgs));
    }
}

#[test]
fn heavy_light_chain_up_to_1e4_keeps_its_joints() {
    for ratio in [1.0, 1e2, 1e4] {
        check(stress::heavy_light_chain(ratio, Auto));
    }
}

#[test]
fn pile_in_a_box_comes_to_rest_without_creep() {
    check(stress::pile(Auto));
}

#[test]
fn sphere_at_100_m_per_s_does_not_tunnel() {
    for solver in [Lemke, Pgs, Auto] {
        check(stress::high_speed(solver));
    }
}

#[test]
fn degenerate_contacts_rest_exactly() {
    for kind in ["crease", "coincident", "touching"] {
        check(stress::degenerate(kind, Auto));
    }
    for kind in ["coincident", "touching"] {
        check(stress::degenerate(kind, Pgs));
    }
}

/// A sphere built 5 mm into a corner of three planes, with friction: the
/// step projects it out (and says so) instead of launching it at
/// 5 sqrt(3) m/s; it ends at rest exactly where it touches all three.
#[test]
fn initial_overlap_is_projected_out_without_launching() {
    for solver in [Lemke, Pgs, Auto] {
        let o = stress::overlap(solver);
        assert!(
            o.note.contains("3 contacts projected"),
            "{}: {}",
            o.case,
            o.note
        );
        check(o);
    }
}

/// Redundant joints make the joint block singular: it is regularised and
/// reported (`regularized`), never NaN, and the joints hold.
#[test]
fn redundant_joints_are_regularised_and_reported() {
    for solver in [Lemke, Pgs] {
        for kind in ["same anchor", "hinge", "loop"] {
            let o = stress::redundant(kind, solver);
            assert!(
                o.note.contains("regularised"),
                "{}: not reported: {}",
                o.case,
                o.note
            );
            check(o);
        }
    }
}

#[test]
fn radii_from_1_mm_to_10_m_rest_exactly() {
    for solver in [Lemke, Pgs, Auto] {
        check(stress::radii(solver));
    }
}

/// 10^6 steps of the reference scene with `auto` (Lemke with the PGS
/// fallback): no failure, no NaN, joints and energy bounded.
#[test]
fn reference_scene_for_a_million_steps() {
    let solver: SolverChoice = Auto;
    check(stress::long_run(1_000_000, solver));
}
