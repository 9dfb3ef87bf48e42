//! Joint motors (issue 17, point 1): a hinge's or slider's rate driven to
//! a target by a bounded effort, one bounded row in both solvers. Each
//! test runs with the solver `COSIM_TEST_SOLVER` names (Lemke by default;
//! `.ci/run` reruns the file with PGS): PGS's answers are within
//! DEFAULT_PGS_TOLERANCE (m/s or rad/s) of the exact ones, Lemke's are
//! round-off.

use cosim_server::engine::constraint::joint::coordinate;
use cosim_server::engine::{Engine, ImpulseKind, InputError};
use cosim_shared::DEFAULT_PGS_TOLERANCE;
use cosim_tests::*;
use nalgebra::Vector3;

const TOL: f64 = DEFAULT_PGS_TOLERANCE;

/// The first joint's rate.
fn rate(e: &Engine) -> f64 {
    coordinate(&e.model().joints[0], e.state())
        .expect("a hinge or slider")
        .1
}

/// The motor's impulse of the last step (N m s or N s, on body_a), zero
/// when none was recorded.
fn motor_impulse(e: &Engine) -> Vector3<f64> {
    e.impulses()
        .iter()
        .find(|i| i.kind == ImpulseKind::JointMotor)
        .map_or_else(Vector3::zeros, |i| i.impulse)
}

/// A wheel (a sphere on a hinge through its centre, about z, zero
/// gravity) with a motor of `max_effort` N m towards `speed` rad/s.
fn wheel(h: f64, steps: u64, speed: f64, max_effort: f64) -> Engine {
    wheel_with(
        h,
        steps,
        &format!("{{ speed = {speed:e}, max_effort = {max_effort:e} }}"),
    )
}

/// A wheel of I = 2/5 m r^2 = 0.004 kg m^2 under a motor of 0.01 N m
/// towards 5 rad/s: each step's impulse is the bound F h until the rate
/// is reached, so the rate is `min(n h F / I, 5)` (2.5 rad/s^2 for 2 s),
/// the last step taking only what is left; then no load, no impulse.
/// Set to -2 rad/s, it turns back at the same bound. Every step's
/// impulse within the bound, the kinetic energy gained within the motor's
/// work `F h |v*|` (the step's allowance).
#[test]
fn a_motor_reaches_its_target_speed_with_its_torque_bounded() {
    let (h, f, inertia) = (1e-3, 0.01, 0.4 * 1.0 * 0.1 * 0.1);
    let mut e = wheel(h, 5000, 5.0, f);
    let alpha = f / inertia;
    let (mut worst, mut over_bound, mut gained) = (0.0f64, 0.0f64, 0.0f64);
    let mut k_prev = 0.0;
    for n in 1..=2500u64 {
        let r = e.step();
        assert!(r.ok(), "step {n}: {:?}", r.error);
        let expected = (n as f64 * h * alpha).min(5.0);
        worst = worst.max((rate(&e) - expected).abs());
        let p = motor_impulse(&e);
        over_bound = over_bound.max(p.norm() - f * h);
        gained = gained.max(r.energy.kinetic - k_prev - r.energy_allowance);
        k_prev = r.energy.kinetic;
    }
    assert!(
        worst < TOL,
        "the rate left min(alpha t, 5) by {worst} rad/s"
    );
    assert!(over_bound <= 1e-15, "an impulse passed F h by {over_bound}");
    assert!(gained <= 1e-12, "a step gained {gained} J beyond the work");
    // At speed with no load: no impulse (to the solver's tolerance).
    assert!(
        motor_impulse(&e).norm() < TOL * inertia,
        "{:?}",
        motor_impulse(&e)
    );
    // Back to -2 rad/s at the bound: 7 rad/s at 2.5 rad/s^2 is 2.8 s.
    e.set_motor_speed(0, -2.0).expect("joint 0 has a motor");
    for n in 1..=3000u64 {
        assert!(e.step().ok());
        let expected = (5.0 - n as f64 * h * alpha).max(-2.0);
        worst = worst.max((rate(&e) - expected).abs());
    }
    assert!(
        worst < TOL,
        "turning back, the rate left its line by {worst}"
    );
    // The torque on the world (body_a) is the opposite of the wheel's:
    // at -2 rad/s the last impulse is round-off; earlier ones were +F h.
    assert!((rate(&e) + 2.0).abs() < TOL);
}

/// A pendulum held level by its motor (target 0) against gravity: a motor
/// strong enough holds it still with the gravity torque's impulse
/// `m g l h` each step; a weaker one lets it fall with the net torque, the
/// first step's rate `h (m g l - F) / I_pivot` exactly.
#[test]
fn a_motor_holds_a_load_within_its_bound_and_yields_beyond_it() {
    // level_pendulum's bob.
    let (h, m, l, r) = (1e-3, 1.0, 0.5, 0.05);
    let i_pivot = 0.4 * m * r * r + m * l * l;
    let load = m * G * l;
    for (f, holds) in [(2.0 * load, true), (0.5 * load, false)] {
        let motor = format!("motor = {{ speed = 0.0, max_effort = {f:e} }}\n");
        let mut e = level_pendulum(h, 100, [0.0, 0.0, -G], 0.0, &motor);
        assert!(e.step().ok());
        if holds {
            assert!(rate(&e).abs() < TOL, "moved at {} rad/s", rate(&e));
            // The couple on the world (body_a) about y is the load's:
            // gravity turns the bob about +y (down), the motor back.
            let p = motor_impulse(&e);
            assert!(
                (p.y - load * h).abs() < TOL * i_pivot && p.x.abs() + p.z.abs() < 1e-15,
                "motor impulse {p:?}, load {}",
                load * h
            );
            for _ in 0..99 {
                assert!(e.step().ok());
            }
            let (x, v) = coordinate(&e.model().joints[0], e.state()).expect("hinge");
            assert!(
                x.abs() < TOL * 0.1 && v.abs() < TOL,
                "drifted to {x} rad, {v} rad/s"
            );
        } else {
            let expected = h * (load - f) / i_pivot;
            assert!(
                (rate(&e) - expected).abs() < TOL,
                "first step's rate {} against {expected}",
                rate(&e)
            );
            let p = motor_impulse(&e);
            assert!((p.norm() - f * h).abs() < 1e-12, "{p:?} not at its bound");
        }
    }
}

/// A car on a level rail driven at 0.5 m/s by a 2 N motor (m = 1 kg:
/// 2 m/s^2 for 0.25 s), into its limit at 0.3 m: it stops there, the
/// motor pushing at its bound and the limit taking exactly that, F h a
/// step, both recorded on the world (body_a): the limit +F h along the
/// rail (it pushes the car back), the motor -F h.
#[test]
fn a_slider_motor_drives_into_its_limit_and_the_limit_takes_its_push() {
    let (h, f, steps) = (1e-3, 2.0, 1000u64);
    let motor = format!("range = [-1.0, 0.3]\nmotor = {{ speed = 0.5, max_effort = {f:e} }}\n");
    let mut e = rail_car(h, steps, &motor);
    let mut worst = 0.0f64;
    for n in 1..=200u64 {
        assert!(e.step().ok());
        worst = worst.max((rate(&e) - (n as f64 * h * f).min(0.5)).abs());
    }
    assert!(worst < TOL, "left the speed ramp by {worst} m/s");
    run(&mut e, steps - 200, |_, _| {});
    let (x, v) = coordinate(&e.model().joints[0], e.state()).expect("slider");
    assert!(
        (x - 0.3).abs() < TOL * steps as f64 * h && v.abs() < TOL,
        "{x} m, {v} m/s"
    );
    let find = |kind| {
        e.impulses()
            .iter()
            .find(|i| i.kind == kind)
            .map(|i| i.impulse)
            .unwrap_or_else(|| panic!("no {kind:?} record"))
    };
    let (limit, motor) = (find(ImpulseKind::JointLimit), find(ImpulseKind::JointMotor));
    assert!(
        (limit - Vector3::new(f * h, 0.0, 0.0)).norm() < TOL,
        "limit {limit:?}"
    );
    assert!(
        (motor - Vector3::new(-f * h, 0.0, 0.0)).norm() < TOL,
        "motor {motor:?}"
    );
}

/// A motor between two free spheres in zero gravity (a hinge about z at
/// A's centre) spins them apart from rest: its couples are internal, so
/// the momenta stay zero but for the anchor pair's moment across the
/// joint's drift (`|dL| <= sum |psi| |p|`, as for limits); the relative
/// rate reaches the target.
#[test]
fn a_motor_between_two_bodies_keeps_the_momenta() {
    let (h, steps) = (1e-3, 1000u64);
    let mut e = elbow_pair(h, steps, 0.0, "motor = { speed = 3.0, max_effort = 0.5 }\n");
    let mut watch = Momenta::start(&e);
    run(&mut e, steps, |e, r| watch.after_step(e, r));
    assert!(watch.dp < 1e-12, "linear momentum {}", watch.dp);
    assert!(
        watch.dl < 1e-11,
        "angular momentum {} beyond the drift's moments",
        watch.dl
    );
    assert!((rate(&e) - 3.0).abs() < TOL, "relative rate {}", rate(&e));
}

/// A motor is checked and named like the rest of a joint; a controller's
/// target for a joint without one, or not finite, is refused by name.
#[test]
fn a_motor_is_checked_and_named() {
    let base = sim(1e-3, 10, [0.0; 3]) + &sphere("w", 0.1, 1.0, [0.0; 3], [0.0; 3], 0.0, 0.0);
    let with = |kind: &str, axis: Option<[f64; 3]>, line: &str| {
        joint_of(kind, "h", "world", "w", [0.0; 3], axis) + line + "\n"
    };
    let z = Some([0.0, 0.0, 1.0]);
    for (joint, expect) in [
        (
            with(
                "spherical",
                None,
                "motor = { speed = 1.0, max_effort = 1.0 }",
            ),
            "joint \"h\".motor: only a revolute or prismatic joint has a motor",
        ),
        (
            with("revolute", z, "motor = { speed = 1.0, max_effort = 0.0 }"),
            "joint \"h\".motor.max_effort = 0: must be a positive finite number",
        ),
        (
            with("revolute", z, "motor = { speed = nan, max_effort = 1.0 }"),
            "joint \"h\".motor.speed",
        ),
        (with("revolute", z, "motor = { speed = 1.0 }"), "max_effort"),
        (
            with(
                "revolute",
                z,
                "motor = { position = 0.5, max_effort = 1.0 }",
            ),
            "joint \"h\".motor.kp: missing: a position servo needs its stiffness kp",
        ),
        (
            with(
                "revolute",
                z,
                "motor = { position = 0.5, kp = 1.0, kd = -1.0, max_effort = 1.0 }",
            ),
            "joint \"h\".motor.kd = -1",
        ),
        (
            with(
                "revolute",
                z,
                "motor = { position = 0.5, kp = 1.0, speed = 1.0, max_effort = 1.0 }",
            ),
            "joint \"h\".motor.speed: a position servo has no speed",
        ),
        (
            with(
                "revolute",
                z,
                "motor = { position = 0.5, kp = 1.0, kv = 1.0, max_effort = 1.0 }",
            ),
            "joint \"h\".motor.kv: a position servo's gains are kp and kd",
        ),
        (
            with(
                "revolute",
                z,
                "motor = { speed = 1.0, kp = 1.0, max_effort = 1.0 }",
            ),
            "joint \"h\".motor.kp: kp and kd are a position servo's",
        ),
        (
            with(
                "revolute",
                z,
                "motor = { speed = 1.0, kv = 0.0, max_effort = 1.0 }",
            ),
            "joint \"h\".motor.kv = 0",
        ),
    ] {
        let err = cosim_shared::Scene::parse(&(base.clone() + &joint), "t.toml")
            .expect_err("refused")
            .to_string();
        assert!(err.contains(expect), "{err}");
    }
    let mut e = engine(&(base.clone() + &with("revolute", z, "")));
    assert_eq!(
        e.set_motor_speed(0, 1.0),
        Err(InputError::NoMotor { index: 0 })
    );
    assert!(matches!(
        e.set_motor_speed(1, 1.0),
        Err(InputError::UnknownJoint { index: 1, .. })
    ));
    let mut e = engine(&(base + &with("revolute", z, "motor = { speed = 1.0, max_effort = 1.0 }")));
    assert!(matches!(
        e.set_motor_speed(0, f64::NAN),
        Err(InputError::NonFinite { .. })
    ));
    assert_eq!(e.set_motor_speed(0, -1.0), Ok(()));
}

/// The wheel of `wheel` driven by `motor` (a TOML inline table).
fn wheel_with(h: f64, steps: u64, motor: &str) -> Engine {
    let mut s = sim(h, steps, [0.0; 3]);
    s += &sphere("wheel", 0.1, 1.0, [0.0; 3], [0.0; 3], 0.0, 0.0);
    s += &joint_of(
        "revolute",
        "axle",
        "world",
        "wheel",
        [0.0; 3],
        Some([0.0, 0.0, 1.0]),
    );
    s += &format!("motor = {motor}\n");
    engine(&s)
}

/// One step of a wheel of inertia `i` under an implicit law whose impulse
/// is `p = a - c w'` (`w'` the end rate), bounded by `cap`: the end rate,
/// from `i (w' - w) = p`, written here from the law alone.
fn implicit_step(i: f64, w: f64, a: f64, c: f64, cap: f64) -> (f64, f64) {
    let free = (i * w + a) / (i + c);
    let p = i * (free - w);
    if p.abs() <= cap {
        (free, p)
    } else {
        let p = cap.copysign(p);
        (w + p / i, p)
    }
}

/// A position servo (issue 45, point 6: PD, implicit in the step) turns
/// the wheel (I = 0.004 kg m^2) from 0 to 0.5 rad, then, its target set
/// by the controller's call, to -0.3: every step's rate is the implicit
/// PD law's, `I (w' - w) = h kp (q* - q) - (h^2 kp + h kd) w'` with the
/// coordinate `q' = q + h w'`, bounded by `F h`, computed here step by
/// step (the first steps at the bound); it settles on each target.
#[test]
fn a_position_servo_follows_the_implicit_pd_law_and_its_bound() {
    let (h, kp, kd, f, inertia) = (1e-3, 20.0, 0.4, 2.0, 0.4 * 1.0 * 0.1 * 0.1);
    let motor = format!("{{ position = 0.5, kp = {kp:e}, kd = {kd:e}, max_effort = {f:e} }}");
    let mut e = wheel_with(h, 3000, &motor);
    let c = h * h * kp + h * kd;
    let (mut q, mut w, mut worst, mut at_bound) = (0.0f64, 0.0f64, 0.0f64, 0);
    for n in 0..3000 {
        if n == 1500 {
            e.set_motor_speed(0, -0.3).expect("a motor");
        }
        let target = if n < 1500 { 0.5 } else { -0.3 };
        let (w1, p) = implicit_step(inertia, w, h * kp * (target - q), c, f * h);
        at_bound += usize::from(p.abs() == f * h);
        w = w1;
        q += h * w;
        assert!(e.step().ok());
        let (eq, ew) = coordinate(&e.model().joints[0], e.state()).expect("a hinge");
        worst = worst.max((ew - w).abs()).max((eq - q).abs());
        if n == 1499 {
            assert!((eq - 0.5).abs() < 1e-3, "settled at {eq} rad");
        }
    }
    assert!(at_bound > 0, "the bound never acted");
    // Lemke: round-off; PGS: within its tolerance, adding up.
    assert!(worst < 50.0 * TOL, "the wheel left the law by {worst}");
    let (eq, _) = coordinate(&e.model().joints[0], e.state()).expect("a hinge");
    assert!((eq + 0.3).abs() < 1e-3, "settled at {eq} rad");
}

/// Stiff gains hold at a large step: a 1 kg bob on a 0.5 m arm held level
/// against gravity by a servo of kp = 1e6 N m/rad at h = 10 ms, where an
/// explicit PD diverges (h^2 kp / I = 400 > 4). It sags by the static
/// deflection m g l / kp and stays there; no step gains energy.
#[test]
fn a_stiff_servo_holds_a_load_at_a_large_step() {
    let (h, kp, kd) = (1e-2, 1e6, 1e3);
    let motor =
        format!("motor = {{ position = 0.0, kp = {kp:e}, kd = {kd:e}, max_effort = 100.0 }}\n");
    let mut e = level_pendulum(h, 500, [0.0, 0.0, -G], 0.0, &motor);
    let sag = 1.0 * G * 0.5 / kp;
    let mut e_max = f64::NEG_INFINITY;
    let e0 = cosim_server::engine::measure::energy(e.model(), e.state()).total;
    run(&mut e, 500, |e, r| {
        e_max = e_max.max(r.energy.total);
        let (q, _) = coordinate(&e.model().joints[0], e.state()).expect("a hinge");
        assert!(q.abs() < 2.0 * sag, "step {}: {q} rad", r.step);
    });
    let (q, w) = coordinate(&e.model().joints[0], e.state()).expect("a hinge");
    // Gravity turns the bob about +y (down): the coordinate sags positive.
    assert!(
        (q - sag).abs() < 1e-3 * sag + TOL * h,
        "sags {q} rad, not {sag}"
    );
    assert!(w.abs() < TOL, "still turns at {w} rad/s");
    assert!(e_max <= e0 + 1e-9, "the energy rose {} J", e_max - e0);
}

/// A velocity actuator (`speed` with `kv`) is the implicit law `I (w' -
/// w) = h kv (v* - w')`: the wheel's rate approaches 5 rad/s as that
/// recursion does, and `speed = 0` with `kv` damps a spinning wheel as
/// the same law.
#[test]
fn a_velocity_actuator_follows_its_gain() {
    let (h, kv, inertia) = (1e-3, 0.02, 0.004);
    for (speed, w0) in [(5.0, 0.0), (0.0, 3.0)] {
        let motor = format!("{{ speed = {speed:e}, kv = {kv:e}, max_effort = 100.0 }}");
        let mut e = wheel_with(h, 1000, &motor);
        if w0 != 0.0 {
            let mut s = e.state().clone();
            s.bodies[0].w = Vector3::new(0.0, 0.0, w0);
            e.set_state(s);
        }
        let (mut w, mut worst) = (w0, 0.0f64);
        for _ in 0..1000 {
            w = implicit_step(inertia, w, h * kv * speed, h * kv, 1.0).0;
            assert!(e.step().ok());
            worst = worst.max((rate(&e) - w).abs());
        }
        assert!(worst < 10.0 * TOL, "the wheel left the law by {worst}");
        // 1 s is 5 time constants I / kv = 0.2 s.
        assert!((w - speed).abs() < 0.01 * (speed - w0).abs(), "{w}");
    }
}
