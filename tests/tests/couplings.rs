//! Couplings (issue 45, points 3 and 4: URDF `<mimic>`, MJCF
//! `<equality><joint>`): a joint's coordinate tied to another's,
//! `q_F = r q_L + o`, by one row across both joints' bodies. Two wheels
//! tied so are a gear train: one degree of freedom whose inertia is
//! `I_L + r^2 I_F` seen from the leader, driven by `tau_L + r tau_F`
//! (the follower's torque reaches the leader through the coupling). Each
//! test runs with the solver `COSIM_TEST_SOLVER` names (Lemke by
//! default; `.ci/run` reruns the file with PGS).

use cosim_server::engine::constraint::joint::coordinate;
use cosim_server::engine::Engine;
use cosim_shared::Scene;
use cosim_tests::*;

/// Joint `j`'s coordinate and rate.
fn q(e: &Engine, j: usize) -> (f64, f64) {
    coordinate(&e.model().joints[j], e.state()).expect("a hinge or slider")
}

/// Two wheels (spheres about their own vertical axles, zero gravity): the
/// leader (I = 0.4 * 1 * 0.1^2 = 0.004 kg m^2) at the origin, the
/// follower (I = 0.4 * 0.5 * 0.2^2 = 0.008) a metre away, `q_F = ratio
/// q_L`; torques (N m about z) on each axle. No joint links them but the
/// coupling: two islands without it.
fn gears(h: f64, ratio: f64, tau_l: f64, tau_f: f64) -> Engine {
    let mut s = sim(h, 1000, [0.0; 3]);
    s += &sphere("lead", 0.1, 1.0, [0.0; 3], [0.0; 3], 0.0, 0.0);
    s += &sphere("follow", 0.2, 0.5, [1.0, 0.0, 0.0], [0.0; 3], 0.0, 0.0);
    let z = Some([0.0, 0.0, 1.0]);
    s += &joint_of("revolute", "axle_l", "world", "lead", [0.0; 3], z);
    s += &format!("torque = [0.0, 0.0, {tau_l:e}]\n");
    s += &joint_of("revolute", "axle_f", "world", "follow", [1.0, 0.0, 0.0], z);
    s += &format!("torque = [0.0, 0.0, {tau_f:e}]\n");
    s += &format!("mimic = {{ joint = \"axle_l\", multiplier = {ratio:e} }}\n");
    engine(&s)
}

/// The tolerance of a rate (rad/s): Lemke's answers are round-off; PGS
/// stops at 1e-6 m/s per row (`sim`'s distance rule), over 1,000 steps.
fn rate_tolerance() -> f64 {
    if solver() == "pgs" {
        1e-4
    } else {
        1e-10
    }
}

/// Leader driven, follower geared at -2: the leader's rate after `n`
/// steps is `n h tau / (I_L + r^2 I_F)` (the velocity-level step is exact
/// for a constant torque), the follower's `-2` times it, and the coupling
/// holds the coordinates to round-off (Lemke).
#[test]
fn a_gear_train_turns_with_the_reflected_inertia() {
    let (h, r, tau) = (1e-3, -2.0, 0.01);
    let inertia = 0.004 + r * r * 0.008;
    let mut e = gears(h, r, tau, 0.0);
    let mut worst_rate = 0.0f64;
    let mut worst_tie = 0.0f64;
    for n in 1..=1000u64 {
        let rep = e.step();
        assert!(rep.ok(), "step {n}: {:?}", rep.error);
        let (ql, wl) = q(&e, 0);
        let (qf, wf) = q(&e, 1);
        worst_rate = worst_rate.max((wl - n as f64 * h * tau / inertia).abs());
        worst_rate = worst_rate.max((wf - r * wl).abs());
        worst_tie = worst_tie.max((qf - r * ql).abs());
    }
    let tol = rate_tolerance();
    assert!(
        worst_rate < tol,
        "rates off the gear train's by {worst_rate}"
    );
    assert!(
        worst_tie < 10.0 * tol,
        "the coupling drifted by {worst_tie} rad"
    );
    // It turned: 1 s at 0.278 rad/s^2.
    assert!(q(&e, 0).1 > 0.27, "{:?}", q(&e, 0));
}

/// The follower's torque alone turns the leader: `r tau_F / (I_L + r^2
/// I_F)` per second, the reaction a servo chasing its leader would not
/// give.
#[test]
fn the_followers_load_reaches_the_leader() {
    let (h, r, tau) = (1e-3, 0.5, 0.02);
    let inertia = 0.004 + r * r * 0.008;
    let mut e = gears(h, r, 0.0, tau);
    run(&mut e, 1000, |_, _| {});
    let expected = 1000.0 * h * r * tau / inertia;
    let (_, wl) = q(&e, 0);
    assert!(
        (wl - expected).abs() < rate_tolerance(),
        "leader at {wl} rad/s, expected {expected}"
    );
    assert!((q(&e, 1).1 - r * wl).abs() < rate_tolerance());
}

/// A gripper's fingers: two sliders on one palm (a free body in zero
/// gravity), opposite axes, the second following the first (URDF's
/// Panda: `finger_joint2` mimics `finger_joint1`). A force on the first
/// finger opens both symmetrically; the palm, pushed back by each finger
/// along opposite axes, stays where it was (no net force), and the
/// momentum of the three bodies stays zero.
#[test]
fn a_grippers_fingers_open_together_and_the_palm_stays() {
    let h = 1e-3;
    let mut s = sim(h, 500, [0.0; 3]);
    s += &sphere("palm", 0.1, 2.0, [0.0; 3], [0.0; 3], 0.0, 0.0);
    s += &sphere("left", 0.02, 0.1, [0.0, 0.05, 0.0], [0.0; 3], 0.0, 0.0);
    s += &sphere("right", 0.02, 0.1, [0.0, -0.05, 0.0], [0.0; 3], 0.0, 0.0);
    s += &joint_of(
        "prismatic",
        "finger1",
        "palm",
        "left",
        [0.0, 0.05, 0.0],
        Some([0.0, 1.0, 0.0]),
    );
    s += "force = [0.0, 0.5, 0.0]\ncollide = false\n";
    s += &joint_of(
        "prismatic",
        "finger2",
        "palm",
        "right",
        [0.0, -0.05, 0.0],
        Some([0.0, -1.0, 0.0]),
    );
    s += "collide = false\nmimic = { joint = \"finger1\" }\n";
    let mut e = engine(&s);
    run(&mut e, 500, |_, _| {});
    let (q1, w1) = q(&e, 0);
    let (q2, w2) = q(&e, 1);
    // One degree of freedom of mass 0.1 + 0.1 (the palm does not move):
    // a = 0.5 / 0.2 m/s^2 for 0.5 s.
    let tol = rate_tolerance();
    assert!((w1 - 0.5 * 2.5).abs() < tol, "finger 1 at {w1} m/s");
    assert!(
        (w2 - w1).abs() < tol,
        "finger 2 at {w2} m/s, finger 1 at {w1}"
    );
    assert!((q2 - q1).abs() < 10.0 * tol, "{q1} against {q2}");
    let palm = &e.state().bodies[0];
    assert!(palm.v.norm() < tol, "the palm moves at {}", palm.v);
    assert!(palm.x.norm() < tol, "the palm moved to {}", palm.x);
}

/// Two pendulums from the world (arms 0.5 m and 0.8 m along x, released
/// level), the second's angle tied to the first's: one degree of freedom.
/// Over 10 s the coupling holds and the energy shows no upward trend; the
/// midpoint energy rises above its start by at most what the joints' and
/// the coupling's position errors can lift the bobs (`joints.rs`'s rule:
/// `sum m g |psi|`, the coupling's error moving the second bob by `l psi`).
#[test]
fn tied_pendulums_swing_as_one_and_gain_no_energy() {
    let (h, steps) = (1e-3, 10_000u64);
    let mut s = sim(h, steps, [0.0, 0.0, -G]);
    s += &sphere("p1", 0.05, 1.0, [0.5, 0.0, 0.0], [0.0; 3], 0.0, 0.0);
    s += &sphere("p2", 0.05, 0.5, [0.8, 1.0, 0.0], [0.0; 3], 0.0, 0.0);
    let y = Some([0.0, 1.0, 0.0]);
    s += &joint_of("revolute", "h1", "world", "p1", [0.0; 3], y);
    s += &joint_of("revolute", "h2", "world", "p2", [0.0, 1.0, 0.0], y);
    s += "mimic = { joint = \"h1\", multiplier = 1.0 }\n";
    let mut e = engine(&s);
    let e0 = cosim_server::engine::measure::energy(e.model(), e.state()).midpoint;
    let (mut rise, mut tie, mut joint_error) = (f64::NEG_INFINITY, 0.0f64, 0.0f64);
    let (mut first, mut last) = (0.0, 0.0);
    let mut lowest = f64::INFINITY;
    run(&mut e, steps, |e, r| {
        rise = rise.max(r.energy.midpoint - e0);
        tie = tie.max((q(e, 1).0 - q(e, 0).0).abs());
        joint_error = joint_error.max(r.max_joint_error);
        lowest = lowest.min(e.state().bodies[1].x.z);
        if r.step <= 1000 {
            first += r.energy.midpoint / 1000.0;
        } else if r.step > steps - 1000 {
            last += r.energy.midpoint / 1000.0;
        }
    });
    assert!(tie < 1e-6, "the coupling drifted by {tie} rad");
    let allowance = 1.5 * G * joint_error + 0.5 * G * 0.8 * tie;
    assert!(
        rise <= allowance,
        "rose {rise} J above the start (allowance {allowance} J)"
    );
    assert!(
        last <= first + 1e-9,
        "energy trends upwards: {first} -> {last} J"
    );
    // It swung: the second bob passed below its pivot.
    assert!(lowest < -0.7, "{lowest}");
}

/// What the scene refuses, by field: a leader that does not exist, is
/// fixed, is the joint itself, a loop of followers, and a follower that
/// does not start where its leader puts it.
#[test]
fn a_bad_mimic_is_refused_by_name() {
    let base = |m2: &str, m1: &str| {
        let mut s = sim(1e-3, 10, [0.0; 3]);
        s += &sphere("a", 0.1, 1.0, [0.0; 3], [0.0; 3], 0.0, 0.0);
        s += &sphere("b", 0.1, 1.0, [1.0, 0.0, 0.0], [0.0; 3], 0.0, 0.0);
        s += &joint_of(
            "revolute",
            "j1",
            "world",
            "a",
            [0.0; 3],
            Some([0.0, 0.0, 1.0]),
        );
        s += m1;
        s += &joint_of(
            "revolute",
            "j2",
            "world",
            "b",
            [1.0, 0.0, 0.0],
            Some([0.0, 0.0, 1.0]),
        );
        s += m2;
        s += &joint_of("fixed", "weld", "a", "b", [0.5, 0.0, 0.0], None);
        s
    };
    for (m2, m1, field, says) in [
        (
            "mimic = { joint = \"nope\" }\n",
            "",
            "mimic.joint",
            "no joint of that name",
        ),
        (
            "mimic = { joint = \"weld\" }\n",
            "",
            "mimic.joint",
            "a fixed joint has no coordinate",
        ),
        (
            "mimic = { joint = \"j2\" }\n",
            "",
            "mimic.joint",
            "cannot follow itself",
        ),
        (
            "mimic = { joint = \"j1\" }\n",
            "mimic = { joint = \"j2\" }\n",
            "mimic.joint",
            "form a loop",
        ),
        // A follower started off its leader's place.
        (
            "mimic = { joint = \"j1\", offset = 0.25 }\n",
            "position = 0.5\n",
            "j2\".position",
            "which puts it at 0.75: start it there",
        ),
    ] {
        let err = Scene::parse(&base(m2, m1), "t.toml").expect_err(says);
        let text = err.to_string();
        assert!(text.contains(field) && text.contains(says), "{text}");
    }
}
