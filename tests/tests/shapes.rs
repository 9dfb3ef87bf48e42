//! Boxes and capsules (issue 17, points 2 and 4) against analytic
//! results: a box at rest on four contacts, a box sliding to rest on an
//! incline, a box tipping at the angle where its centre passes over its
//! edge, a capsule rolling down an incline without slip. Each test runs
//! with the solver `COSIM_TEST_SOLVER` names (Lemke by default; `.ci/run`
//! reruns the file with PGS), so tolerances are PGS's: its answer is
//! within DEFAULT_PGS_TOLERANCE (m/s) of the exact one, an error that adds
//! up over the run's time; Lemke's is round-off.

use cosim_server::engine::collision::vertex;
use cosim_server::engine::model::Counterpart;
use cosim_server::engine::{Engine, ImpulseKind};
use cosim_shared::DEFAULT_PGS_TOLERANCE;
use cosim_tests::*;
use nalgebra::{UnitQuaternion, Vector3};

const TOL: f64 = DEFAULT_PGS_TOLERANCE;

/// `[w, x, y, z]` of a turn by `angle` about unit `axis`.
fn turn(axis: Vector3<f64>, angle: f64) -> [f64; 4] {
    let q = UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
    [q.w, q.i, q.j, q.k]
}

/// An incline turned by `theta` about y: its normal, and the unit
/// direction down its slope.
fn incline(theta: f64) -> (Vector3<f64>, Vector3<f64>) {
    let n = Vector3::new(theta.sin(), 0.0, theta.cos());
    let down = Vector3::new(theta.cos(), 0.0, -theta.sin());
    (n, down)
}

fn q_of(e: &Engine, i: usize) -> UnitQuaternion<f64> {
    e.state().bodies[i].q
}

/// A 2 kg box (0.4 x 0.2 x 0.1 m) set on a level plane rests there for
/// 10 s on its four lower vertices: every step lists the four, their
/// normal impulses carry its weight (sum m g h) with no moment about its
/// centre (the support is statically indeterminate: Lemke answers a
/// vertex of the solution set, three of the four carrying it, PGS a
/// spread; both hold the box), and it neither moves nor turns.
#[test]
fn a_box_rests_on_a_plane_on_four_contacts() {
    let (h, steps, m) = (1e-3, 10_000u64, 2.0);
    let half = [0.2, 0.1, 0.05];
    let mut s = sim(h, steps, [0.0, 0.0, -G]);
    s += &cuboid(
        "box",
        half,
        m,
        [0.1, -0.2, half[2]],
        [1.0, 0.0, 0.0, 0.0],
        [0.0; 3],
        [0.0; 3],
        0.5,
    );
    s += &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0);
    let mut e = engine(&s);
    let x0 = e.state().bodies[0].x;
    let hv = Vector3::from(half);
    let (mut worst_sum, mut worst_moment, mut counts) = (0.0f64, 0.0f64, Vec::new());
    run(&mut e, steps, |e, r| {
        // Asleep (the default sleeping), the box's contacts leave the LCP
        // and report the impulses they held.
        if r.sleeping == 0 {
            counts.push(r.contacts_in_lcp);
        }
        let (mut sum, mut moment) = (0.0, Vector3::zeros());
        for i in e
            .impulses()
            .iter()
            .filter(|i| i.kind == ImpulseKind::Normal)
        {
            assert_eq!(
                e.model().contact_bodies(i.index),
                (0, Counterpart::Plane(0))
            );
            let k = e.model().contact_feature(i.index);
            let arm = q_of(e, 0).transform_vector(&vertex(&hv, k));
            sum += i.impulse.z;
            moment += arm.cross(&i.impulse);
        }
        worst_sum = worst_sum.max((sum - m * G * h).abs());
        worst_moment = worst_moment.max(moment.norm());
    });
    eprintln!("support off by {worst_sum:e} N s, moment {worst_moment:e} N m s");
    assert!(
        counts.iter().all(|&c| c == 4),
        "contacts in the LCP: {:?}",
        {
            let mut c = counts.clone();
            c.dedup();
            c
        }
    );
    // Lemke: round-off of m g h = 0.02 N s. PGS: its tolerance times the
    // box's effective mass along a row (of order m).
    assert!(worst_sum < TOL * m, "the support is off by {worst_sum} N s");
    assert!(
        worst_moment < TOL * m,
        "the support's moment: {worst_moment} N m s"
    );
    let st = &e.state().bodies[0];
    let moved = (st.x - x0).norm();
    let turned = q_of(&e, 0).angle();
    eprintln!("moved {moved:e} m, turned {turned:e} rad in 10 s");
    assert!(moved < TOL * 10.0, "moved {moved} m in 10 s");
    assert!(turned < TOL * 10.0, "turned {turned} rad in 10 s");
    assert!(st.v.norm() < TOL && st.w.norm() < TOL, "{st:?}");
}

/// A box sent down an incline of 0.2 rad at 1 m/s with mu = 0.5 (> tan
/// 0.2) slides to rest: it decelerates at a = g (mu cos - sin) each step,
/// exactly (the slip-aligned friction directions put the cone's edge
/// against the slip), so it stops after the distance the discrete run
/// gives, h sum_k (v0 - k a h), within h v0 of v0^2 / (2 a); then it
/// stays.
#[test]
fn a_box_slides_to_rest_on_an_incline_at_the_analytic_distance() {
    let (h, steps, theta, mu, v0) = (1e-3, 600u64, 0.2f64, 0.5, 1.0);
    let (n, down) = incline(theta);
    let half = [0.1, 0.1, 0.05];
    let mut s = sim(h, steps, [0.0, 0.0, -G]);
    let x0 = n * half[2];
    s += &cuboid(
        "box",
        half,
        1.0,
        x0.into(),
        turn(Vector3::y(), theta),
        (down * v0).into(),
        [0.0; 3],
        mu,
    );
    s += &plane("slope", n.into(), [0.0; 3], mu, 0.0);
    let mut e = engine(&s);
    let a = G * (mu * theta.cos() - theta.sin());
    let stop = (v0 / (a * h)).floor() as u64;
    let discrete: f64 = (1..=stop).map(|k| h * (v0 - k as f64 * a * h)).sum();
    let continuous = v0 * v0 / (2.0 * a);
    assert!((discrete - continuous).abs() < h * v0);
    let mut worst_speed = 0.0f64;
    run(&mut e, steps, |e, r| {
        let v = e.state().bodies[0].v.dot(&down);
        if r.step <= stop {
            let want = v0 - r.step as f64 * a * h;
            worst_speed = worst_speed.max((v - want).abs());
        } else {
            worst_speed = worst_speed.max(v.abs());
        }
    });
    assert!(
        worst_speed < TOL * 2.0,
        "the speed left the analytic ramp by {worst_speed} m/s"
    );
    let travelled = (e.state().bodies[0].x - x0).dot(&down);
    eprintln!(
        "slid {travelled} m (discrete {discrete} m, continuous {continuous} m), speed off by {worst_speed:e} m/s"
    );
    assert!(
        (travelled - discrete).abs() < TOL * steps as f64 * h,
        "slid {travelled} m, not {discrete} m (continuous {continuous} m)"
    );
    assert!(q_of(&e, 0).angle() - theta < 1e-6, "the box pitched");
}

/// A box of half extents a = 0.1 m along the slope and b = 0.2 m high, on
/// an incline with friction enough never to slide (mu = 1.2 > tan theta
/// over the cone's inscribed polygon), tips where its centre passes
/// over its lower edge, tan theta = a / b: at 0.01 rad below that angle
/// it stays put for 2 s; at 0.01 rad above, it falls over.
#[test]
fn a_box_tips_on_an_incline_at_the_analytic_angle() {
    let critical = (0.1f64 / 0.2).atan();
    let tilt_after = |theta: f64| {
        let (h, steps) = (1e-3, 2000u64);
        let (n, _) = incline(theta);
        let half = [0.1, 0.1, 0.2];
        let mut s = sim(h, steps, [0.0, 0.0, -G]);
        s += &cuboid(
            "box",
            half,
            1.0,
            (n * half[2]).into(),
            turn(Vector3::y(), theta),
            [0.0; 3],
            [0.0; 3],
            1.2,
        );
        s += &plane("slope", n.into(), [0.0; 3], 1.2, 0.0);
        let mut e = engine(&s);
        let x0 = e.state().bodies[0].x;
        run(&mut e, steps, |_, _| {});
        let st = &e.state().bodies[0];
        // The box's turn relative to the slope.
        let rel = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -theta) * st.q;
        (rel.angle(), (st.x - x0).norm())
    };
    let (below, moved) = tilt_after(critical - 0.01);
    let (above, _) = tilt_after(critical + 0.01);
    eprintln!("below: turned {below:e} rad, moved {moved:e} m; above: turned {above} rad");
    assert!(below < TOL * 2.0, "below the angle it turned {below} rad");
    assert!(moved < TOL * 2.0, "below the angle it moved {moved} m");
    assert!(above > 0.5, "above the angle it turned only {above} rad");
}

/// A capsule (r = 0.05 m, segment 0.3 m) lying across an incline of 0.3
/// rad with mu = 1 rolls down without slipping: its speed grows at a = g
/// sin theta / (1 + J / (m r^2)), J its inertia about its axis (a
/// cylinder's and two hemispheres', `Shape::inertia`), exactly at each
/// step; both ends' contact points stay at rest, and it keeps its
/// heading.
#[test]
fn a_capsule_rolls_down_an_incline_without_slipping() {
    let (h, steps, theta, m, r, l) = (1e-3, 1000u64, 0.3f64, 1.0, 0.05, 0.15);
    let (n, down) = incline(theta);
    let mut s = sim(h, steps, [0.0, 0.0, -G]);
    // Its axis (body z) along world y, across the slope.
    let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), theta)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -std::f64::consts::FRAC_PI_2);
    s += &capsule(
        "pill",
        r,
        l,
        m,
        (n * r).into(),
        [q.w, q.i, q.j, q.k],
        [0.0; 3],
        [0.0; 3],
        1.0,
    );
    s += &plane("slope", n.into(), [0.0; 3], 1.0, 0.0);
    let mut e = engine(&s);
    // J about the axis: cylinder m_c r^2 / 2, hemispheres m_s 2 r^2 / 5,
    // masses by volume (2 r^2 l : 4/3 r^3, pi apart).
    let (vc, vs) = (2.0 * r * r * l, 4.0 / 3.0 * r * r * r);
    let j = m * vc / (vc + vs) * r * r / 2.0 + m * vs / (vc + vs) * 0.4 * r * r;
    let a = G * theta.sin() / (1.0 + j / (m * r * r));
    let (mut worst_speed, mut worst_slip, mut side) = (0.0f64, 0.0f64, 0.0f64);
    run(&mut e, steps, |e, r_| {
        let b = &e.state().bodies[0];
        let want = a * r_.step as f64 * h;
        worst_speed = worst_speed.max((b.v.dot(&down) - want).abs());
        // The material point at the bottom of the capsule, on the axis's
        // middle: the ends' points move the same (w is along the axis).
        let slip = b.v + b.w.cross(&(-n * r));
        worst_slip = worst_slip.max(slip.norm());
        side = side.max(b.v.y.abs());
    });
    eprintln!("a = {a} m/s^2: speed off by {worst_speed:e} m/s, slip {worst_slip:e} m/s");
    assert!(
        worst_speed < TOL * 2.0,
        "the speed left a t (a = {a} m/s^2) by {worst_speed} m/s"
    );
    assert!(worst_slip < TOL * 2.0, "slipped at {worst_slip} m/s");
    assert!(side < TOL, "drifted sideways at {side} m/s");
}

/// A body's shape fields are checked and named: exactly one shape
/// (radius; radius and half_length; half_extents), every size positive;
/// an explicit inertia positive definite.
#[test]
fn a_bodys_shape_is_checked_and_named() {
    let base = sim(1e-3, 10, [0.0, 0.0, -G]);
    for (fields, expect) in [
        (
            "radius = 0.1\nhalf_extents = [0.1, 0.1, 0.1]",
            "body \"b\".half_extents",
        ),
        (
            "half_length = 0.2",
            "body \"b\".radius: is missing: a capsule",
        ),
        ("", "body \"b\".radius: is missing: give radius"),
        (
            "radius = 0.1\nhalf_length = -0.2",
            "body \"b\".half_length = -0.2",
        ),
        (
            "radius = 0.1\ninertia = [1.0, 1.0, 1.0, 2.0, 0.0, 0.0]",
            "body \"b\".inertia = [1.0, 1.0, 1.0, 2.0, 0.0, 0.0]: [ixx, iyy, izz, ixy, ixz, iyz] must be finite and positive definite",
        ),
        (
            "half_extents = [0.1, 0.0, 0.1]",
            "body \"b\".half_extents = [0.1, 0.0, 0.1]: each half extent",
        ),
    ] {
        let text = format!(
            "{base}[[body]]\nname = \"b\"\n{fields}\nmass = 1.0\nposition = [0.0, 0.0, 1.0]\n"
        );
        let e = cosim_shared::Scene::parse(&text, "s.toml").expect_err(fields);
        assert!(e.to_string().contains(expect), "{fields}: {e}");
    }
}
