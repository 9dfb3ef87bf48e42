//! Joint limits (issue 17, point 1): a hinge's angle and a slider's offset
//! held within their range by unilateral rows, with the contacts'
//! stabilisation and restitution. Each test runs with the solver that
//! `COSIM_TEST_SOLVER` names (Lemke by default; `.ci/run` reruns the file
//! with PGS), so tolerances are PGS's: its answer is within
//! DEFAULT_PGS_TOLERANCE (m/s, or rad/s for a hinge's row) of the exact
//! one, an error that adds up over the run's time; Lemke's is round-off.

use cosim_server::engine::constraint::joint::coordinate;
use cosim_server::engine::{Engine, ImpulseKind, Party};
use cosim_shared::DEFAULT_PGS_TOLERANCE;
use cosim_tests::*;
use nalgebra::Vector3;

const TOL: f64 = DEFAULT_PGS_TOLERANCE;
const R: f64 = 0.05;

/// The first joint's coordinate and rate.
fn coord(e: &Engine) -> (f64, f64) {
    coordinate(&e.model().joints[0], e.state()).expect("a hinge or slider")
}

/// A pendulum falls onto its upper limit (0.5 rad) with e = 0: it stops
/// there in the step it arrives, neither passing the limit nor bouncing
/// back, and rests on it while gravity presses it on (the arm is below
/// the level: gravity's torque still turns it down).
#[test]
fn a_hinge_stops_at_its_limit_without_rebound_or_penetration() {
    let (h, steps) = (1e-3, 2000u64);
    let mut e = level_pendulum(h, steps, [0.0, 0.0, -G], 0.0, "range = [-1.0, 0.5]\n");
    let (mut hit, mut past, mut moved_after) = (None, 0.0f64, 0.0f64);
    run(&mut e, steps, |e, r| {
        let (x, v) = coord(e);
        past = past.max(x - 0.5);
        if hit.is_none() && x > 0.5 - 1e-6 {
            hit = Some(r.step);
        } else if hit.is_some() {
            moved_after = moved_after.max(v.abs());
        }
    });
    let hit = hit.expect("the pendulum reached its limit");
    // From level, theta'' = (g / l) cos theta, about 19.6 rad/s^2: 0.5 rad
    // in about sqrt(2 0.5 / 19.6) = 0.23 s.
    assert!((200..260).contains(&hit), "reached the limit at step {hit}");
    assert!(
        past < TOL * steps as f64 * h,
        "passed the limit by {past} rad"
    );
    assert!(
        moved_after < TOL,
        "moved at {moved_after} rad/s after the hit"
    );
    let (x, _) = coord(&e);
    assert!((x - 0.5).abs() < TOL * steps as f64 * h, "rests at {x} rad");
}

/// In zero gravity a pendulum turning at 2 rad/s hits its upper limit
/// with e = 0.5: it leaves at -e times the rate it came with (Newton's law
/// on the limit's row, exact: the row's impulse makes `x' = -e x'^-`;
/// the rate it comes with is 2 rad/s less what the velocity-level joint
/// takes from a turning body, 7e-6 rad/s here), having not passed the
/// limit, and the hinge's joint holds all the while.
#[test]
fn a_hinge_limit_with_restitution_returns_half_the_speed() {
    let (h, steps) = (1e-3, 600u64);
    let range = "range = [-1.0, 0.5]\nlimit_restitution = 0.5\n";
    let mut e = level_pendulum(h, steps, [0.0; 3], 2.0, range);
    let (mut before, mut after, mut past, mut drift) = (0.0, None, 0.0f64, 0.0f64);
    run(&mut e, steps, |e, r| {
        let (x, v) = coord(e);
        past = past.max(x - 0.5);
        drift = drift.max(r.max_joint_error);
        if after.is_none() && v < 0.0 {
            after = Some(v);
        } else if after.is_none() {
            before = v;
        }
    });
    let v = after.expect("the pendulum came back");
    assert!((before - 2.0).abs() < 1e-5, "came at {before} rad/s");
    assert!(
        (v + 0.5 * before).abs() < TOL,
        "left the limit at {v} rad/s, having come at {before} rad/s"
    );
    assert!(past < 1e-9, "passed the limit by {past} rad");
    // A body turning at w on a velocity-level joint leaves its circle by
    // l w^2 h^2 / 2 = 1e-6 m a step, which the stabilisation takes back:
    // measured 1.0e-6 m with either solver, with or without the limit.
    assert!(drift < 2e-6, "the hinge's anchors parted by {drift} m");
}

/// A carriage on a level rail from the world, pushed along it by a slider
/// force of 2 N: it runs into its upper limit at 0.3 m and stays, the
/// limit's impulse each step then F h against the push (recorded on A,
/// the world: +F h along the rail, as B gets -F h).
#[test]
fn a_slider_runs_into_its_limit_and_the_limit_carries_the_push() {
    let (h, steps, f) = (1e-3, 1000u64, 2.0);
    let mut e = rail_car(
        h,
        steps,
        &format!("force = [{f:e}, 0.0, 0.0]\nrange = [-0.2, 0.3]\n"),
    );
    let mut past = 0.0f64;
    run(&mut e, steps, |e, _| past = past.max(coord(e).0 - 0.3));
    assert!(
        past < TOL * steps as f64 * h,
        "passed the limit by {past} m"
    );
    let (x, v) = coord(&e);
    assert!((x - 0.3).abs() < TOL * steps as f64 * h, "rests at {x} m");
    assert!(v.abs() < TOL, "moves at {v} m/s at the limit");
    let limit: Vec<_> = e
        .impulses()
        .iter()
        .filter(|i| i.kind == ImpulseKind::JointLimit)
        .collect();
    assert_eq!(limit.len(), 1, "one limit pushes: {limit:?}");
    assert_eq!((limit[0].a, limit[0].b), (Party::World, Party::Body(0)));
    let expected = Vector3::new(f * h, 0.0, 0.0);
    assert!(
        (limit[0].impulse - expected).norm() < TOL * 1.0,
        "the limit's impulse on the world is {:?}, not {expected:?}",
        limit[0].impulse
    );
}

/// Two free spheres in zero gravity on a hinge, B turning about it at 3
/// rad/s relative to A, with limits at +-0.4 rad and e = 0: the limit's
/// impulses are internal, so the linear momentum is the start's to
/// round-off through the hit, and the angular momentum too but for the
/// moment of the anchor forces' pair across the joint's drift: with the
/// anchors `psi` apart, the pair `+-p` has the moment `psi x p`, so over
/// the run `|dL| <= sum |psi| |p|` (a limit's couple misapplied would
/// break it by its own size, 1e-3 N m s: put on A alone, it is
/// off by 6e-3). The relative turning stops at
/// the limit, and no step gains kinetic energy beyond what the
/// stabilisation of the joint's drift may give (`energy_allowance`).
#[test]
fn a_limit_between_two_bodies_keeps_the_momenta() {
    let (h, steps) = (1e-3, 500u64);
    let mut e = elbow_pair(h, steps, 3.0, "range = [-0.4, 0.4]\n");
    let k0 = cosim_server::engine::measure::energy(e.model(), e.state()).kinetic;
    let mut watch = Momenta::start(&e);
    let (mut gained, mut past, mut k_prev) = (0.0f64, 0.0f64, k0);
    run(&mut e, steps, |e, r| {
        watch.after_step(e, r);
        // Zero gravity: the free motion keeps the start's energy, so a
        // gain is what the stabilisation gave, within its allowance.
        gained = gained.max(r.energy.kinetic - k_prev - r.energy_allowance);
        k_prev = r.energy.kinetic;
        past = past.max(coord(e).0.abs() - 0.4);
    });
    let (dp, dl, moments) = (watch.dp, watch.dl, watch.moments);
    assert!(dp < 1e-12, "linear momentum changed by {dp}");
    // Measured 3.1e-12, the same to the digit without the limit (the
    // hinge's own round-off on |L| = 0.12 N m s over 500 steps).
    assert!(
        dl < 1e-11,
        "angular momentum changed by {dl} more than the drift's moments"
    );
    assert!(moments < 1e-6, "the drift's moments are {moments} N m s");
    assert!(gained <= 1e-12, "a step gained {gained} J");
    assert!(
        past < TOL * steps as f64 * h,
        "passed the limit by {past} rad"
    );
    let (x, v) = coord(&e);
    assert!((x - 0.4).abs() < TOL * steps as f64 * h, "ends at {x} rad");
    assert!(v.abs() < TOL, "still turns at {v} rad/s");
    assert!(k_prev < k0, "the hit took no energy: {k_prev} J of {k0} J");
}

/// A hinge may start away from its zero (`position`, MuJoCo's `qpos0`):
/// the level pendulum started with the coordinate at 0.3 rad reads 0.3 at
/// t = 0, its coordinate stays the bob's angle below the level plus 0.3
/// (to the joint's drift), and it reaches its upper limit at 0.5 rad
/// after falling 0.2 rad, not 0.5: sooner than the same pendulum from 0.
#[test]
fn a_hinge_starts_at_its_initial_position_and_its_limit_counts_from_zero() {
    let (h, steps) = (1e-3, 2000u64);
    let hit_of = |extra: &str| {
        let mut e = level_pendulum(h, steps, [0.0, 0.0, -G], 0.0, extra);
        let start = coord(&e).0;
        let (mut hit, mut off) = (None, 0.0f64);
        run(&mut e, steps, |e, r| {
            let (x, _) = coord(e);
            let p = e.state().bodies[0].x;
            // About +y, +x turns towards -z.
            let below = (-(p.z - 1.0)).atan2(p.x);
            off = off.max((x - below - start).abs());
            if hit.is_none() && x > 0.5 - 1e-6 {
                hit = Some(r.step);
            }
        });
        (start, hit.expect("reached the limit"), off)
    };
    let (start, hit, off) = hit_of("range = [-1.0, 0.5]\nposition = 0.3\n");
    assert!(
        (start - 0.3).abs() < 1e-12,
        "the coordinate at t = 0: {start}"
    );
    assert!(
        off < 1e-6,
        "the coordinate strays {off} rad from the bob's angle"
    );
    // theta'' = (g / l) cos theta from level: 0.2 rad in about
    // sqrt(2 0.2 / 19.6) = 0.14 s.
    assert!((130..160).contains(&hit), "reached the limit at step {hit}");
    let (_, hit0, _) = hit_of("range = [-1.0, 0.5]\n");
    assert!(hit < hit0, "from 0.3 at step {hit}, from 0 at step {hit0}");
}

/// A slider started at 0.1 m (`position`) reads 0.1 at t = 0, the car's
/// travel plus 0.1 after, and its upper limit at 0.3 m stops the car
/// 0.2 m from where it started.
#[test]
fn a_slider_starts_at_its_initial_position() {
    let (h, steps, f) = (1e-3, 1000u64, 2.0);
    let mut e = rail_car(
        h,
        steps,
        &format!("force = [{f:e}, 0.0, 0.0]\nrange = [-0.2, 0.3]\nposition = 0.1\n"),
    );
    assert!(
        (coord(&e).0 - 0.1).abs() < 1e-12,
        "starts at {}",
        coord(&e).0
    );
    let mut off = 0.0f64;
    run(&mut e, steps, |e, _| {
        off = off.max((coord(e).0 - e.state().bodies[0].x.x - 0.1).abs())
    });
    assert!(off < 1e-9, "the coordinate strays {off} m from the travel");
    let x = e.state().bodies[0].x.x;
    assert!((x - 0.2).abs() < TOL * steps as f64 * h, "stopped at {x} m");
}

/// A range is checked like the rest of a joint, each fault named: bounds
/// out of order or not finite, a hinge's beyond pi, a range on a joint
/// without a coordinate, an initial position outside the range, a restitution without a range or outside [0, 1].
#[test]
fn a_joints_range_is_checked_and_named() {
    let base =
        sim(1e-3, 10, [0.0, 0.0, -G]) + &sphere("bob", R, 1.0, [0.5, 0.0, 1.0], [0.0; 3], 0.0, 0.0);
    let with = |kind: &str, axis: Option<[f64; 3]>, lines: &str| {
        joint_of(kind, "h", "world", "bob", [0.0, 0.0, 1.0], axis) + lines + "\n"
    };
    let y = Some([0.0, 1.0, 0.0]);
    for (joint, expect) in [
        (
            with("revolute", y, "range = [0.5, -0.5]"),
            "joint \"h\".range = [0.5, -0.5]: needs finite bounds with lower < upper",
        ),
        (
            with("prismatic", y, "range = [nan, 1.0]"),
            "joint \"h\".range",
        ),
        (
            with("revolute", y, "range = [-4.0, 1.0]"),
            "a hinge's limits are angles within [-pi, pi]",
        ),
        (
            with("spherical", None, "range = [-1.0, 1.0]"),
            "joint \"h\".range: only a revolute or prismatic joint has a range",
        ),
        (
            with("revolute", y, "range = [-1.0, 1.0]\nposition = 1.5"),
            "joint \"h\".position = 1.5: must be finite and within [-1, 1]",
        ),
        (
            with("revolute", y, "position = 4.0"),
            "joint \"h\".position = 4: must be finite and within [-3.14",
        ),
        (
            with("spherical", None, "position = 0.1"),
            "joint \"h\".position: only a revolute or prismatic joint has a coordinate",
        ),
        (
            with("revolute", y, "limit_restitution = 0.5"),
            "joint \"h\".limit_restitution: a limit's restitution needs the joint's `range`",
        ),
        (
            with(
                "revolute",
                y,
                "range = [-1.0, 1.0]\nlimit_restitution = 1.5",
            ),
            "joint \"h\".limit_restitution",
        ),
        (
            with("fixed", None, "max_effort = 1.0"),
            "joint \"h\".max_effort: a fixed joint takes no effort",
        ),
        (
            with("revolute", y, "max_effort = -1.0"),
            "joint \"h\".max_effort",
        ),
    ] {
        let err = cosim_shared::Scene::parse(&(base.clone() + &joint), "t.toml")
            .expect_err("refused")
            .to_string();
        assert!(err.contains(expect), "{err}");
    }
    // A slider's range is in metres: beyond pi is fine.
    let ok = with("prismatic", y, "range = [-5.0, 5.0]");
    cosim_shared::Scene::parse(&(base + &ok), "t.toml").expect("a slider may travel 10 m");
}

/// A hinge whose upper limit is pi (a URDF's limit beyond pi is held at
/// pi), the limit soft (`[compliance] contact`, 10 N m/rad, 4 N m s/rad,
/// past critical for the bob's 0.251 kg m^2): turning at 4 rad/s in zero
/// gravity it reaches pi after 0.79 s and presses past it, less than the
/// undamped spring's `sqrt(I w^2 / k) = 0.63` rad. Its angle reads on the circle, (-pi, pi],
/// so past pi it reads near -pi; the limits take it as past pi
/// (`limit::nearest_turn`), not a whole turn below the lower limit
/// (before: it was let through a whole turn). No step falls back, and the
/// spring sends it back into its range.
#[test]
fn a_hinge_presses_past_a_limit_of_pi_and_comes_back() {
    let (h, steps) = (1e-3, 6000u64);
    let pi = std::f64::consts::PI;
    let extra = format!(
        "range = [-1.0, {pi:e}]\n\n[compliance]\ncontact = {{ stiffness = 10.0, damping = 4.0 }}\n"
    );
    let mut e = level_pendulum(h, steps, [0.0; 3], 4.0, &extra);
    let (mut hit, mut relaxed, mut deepest) = (None, 0u64, 0.0f64);
    let off = |x: f64| (x - pi + pi).rem_euclid(2.0 * pi) - pi;
    run(&mut e, steps, |e, r| {
        let (x, _) = coord(e);
        relaxed += u64::from(r.fallback.is_some());
        if hit.is_none() && off(x).abs() < 1e-2 {
            hit = Some(r.step);
        }
        if hit.is_some() {
            deepest = deepest.max(off(x));
        }
    });
    let hit = hit.expect("the pendulum reached pi");
    assert!((770..800).contains(&hit), "reached pi at step {hit}");
    assert_eq!(relaxed, 0, "steps fell back");
    assert!(
        (0.1..0.63).contains(&deepest),
        "pressed {deepest} rad past pi"
    );
    // The spring sent it back into its range, turning down (no gravity,
    // nothing else acts).
    let (x, v) = coord(&e);
    assert!(
        (-1.0..pi).contains(&x) && v < 0.0,
        "ends at {x} rad, {v} rad/s"
    );
}
