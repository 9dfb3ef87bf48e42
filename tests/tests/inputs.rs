//! The engine's input API: joint torques (held) and body impulses (one
//! step), the path the scene's constant torques and the co-simulation take.

use cosim_server::engine::InputError;
use cosim_tests::*;
use nalgebra::Vector3;

#[test]
fn body_impulse_acts_once_and_bad_inputs_are_refused() {
    let scene = sim(1e-3, 10, [0.0; 3]) + &sphere("ball", 0.1, 2.0, [0.0; 3], [0.0; 3], 0.0, 0.0);
    let mut e = engine(&scene);
    e.add_body_impulse(
        0,
        Vector3::new(4.0, 0.0, 0.0),
        Vector3::new(0.0, 0.0, 0.008),
    )
    .expect("valid impulse");
    run(&mut e, 3, |_, _| {});
    let b = e.state().bodies[0];
    // Delta v = J / m; delta w = L / (2/5 m R^2) = 0.008 / 0.008.
    assert_eq!(b.v, Vector3::new(2.0, 0.0, 0.0));
    assert!((b.w - Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-15);
    assert!(
        (b.x.x - 3.0 * 2.0e-3).abs() < 1e-15,
        "the impulse acted more than once"
    );

    assert_eq!(
        e.add_body_impulse(1, Vector3::zeros(), Vector3::zeros()),
        Err(InputError::UnknownBody {
            index: 1,
            bodies: 1
        })
    );
    assert!(matches!(
        e.add_body_impulse(0, Vector3::new(f64::NAN, 0.0, 0.0), Vector3::zeros()),
        Err(InputError::NonFinite { .. })
    ));
    assert_eq!(
        e.set_joint_torque(0, Vector3::zeros()),
        Err(InputError::UnknownJoint {
            index: 0,
            joints: 0
        })
    );
    let before = e.state().clone();
    run(&mut e, 1, |_, _| {});
    assert_eq!(
        e.state().bodies[0].v,
        before.bodies[0].v,
        "a refused input acted"
    );
}

#[test]
fn torque_through_the_api_equals_the_scene_torque() {
    let base = sim(1e-3, 500, [0.0, 0.0, -G])
        + &sphere("bob", 0.05, 1.0, [0.5, 0.0, 0.0], [0.0; 3], 0.0, 0.0)
        + &joint("pin", "world", "bob", [0.0; 3]);
    let with_torque = base.clone() + "torque = [0.0, 0.0, 0.3]\n";
    let mut from_scene = engine(&with_torque);
    let mut from_api = engine(&base);
    from_api
        .set_joint_torque(0, Vector3::new(0.0, 0.0, 0.3))
        .unwrap();
    assert!(from_api
        .set_joint_torque(0, Vector3::new(f64::INFINITY, 0.0, 0.0))
        .is_err());
    run(&mut from_scene, 500, |_, _| {});
    run(&mut from_api, 500, |_, _| {});
    assert_eq!(from_scene.state(), from_api.state());
    // The torque did something: the bob turned about z.
    assert!(from_api.state().bodies[0].w.z > 1.0);
}

/// A joint's `max_effort` bounds its held input, the scene's and a
/// controller's alike: a slider's force along its axis (the rest the
/// joint holds), a hinge's torque about its axis, a spherical joint's
/// torque by length; each clamped step is counted, and an effort within
/// the bound acts as it would without one, to the bit.
#[test]
fn held_efforts_are_clamped_to_the_joints_bound() {
    // The car on its rail (1 kg), pushed by 10 N along the rail and 5 N
    // across it, bounded at 2 N: a = 2 m/s^2, v = 2 t, exactly (a
    // constant force under the first-order step).
    let force = "force = [10.0, 0.0, 5.0]\nmax_effort = 2.0\n";
    let mut car = rail_car(1e-3, 100, force);
    run(&mut car, 100, |_, r| assert_eq!(r.clamped_efforts, 1));
    let v = car.state().bodies[0].v;
    assert!((v.x - 0.2).abs() < 1e-12, "v = {v}");
    assert!(v.z.abs() < 1e-12, "the part across the rail acted: {v}");

    // The hinge pair in zero gravity: a controller's 3 N m about the
    // hinge, bounded at 0.5 N m, spins B about A as 0.5 N m would.
    let mut clamped = elbow_pair(1e-3, 200, 0.0, "max_effort = 0.5\n");
    let mut within = elbow_pair(1e-3, 200, 0.0, "");
    clamped
        .set_joint_torque(0, Vector3::new(0.0, 0.0, 3.0))
        .unwrap();
    within
        .set_joint_torque(0, Vector3::new(0.0, 0.0, 0.5))
        .unwrap();
    let mut counted = 0;
    run(&mut clamped, 200, |_, r| counted += r.clamped_efforts);
    run(&mut within, 200, |_, _| {});
    assert_eq!(counted, 200);
    let (wc, ww) = (clamped.state().bodies[1].w, within.state().bodies[1].w);
    assert!((wc - ww).norm() < 1e-12 * ww.norm(), "{wc} vs {ww}");
    assert!(ww.z > 1.0, "the torque turned B: {ww}");

    // Within its bound an effort is untouched: the same state to the bit
    // as with no bound.
    let mut bounded = elbow_pair(1e-3, 200, 0.0, "max_effort = 0.5\n");
    let mut free = elbow_pair(1e-3, 200, 0.0, "");
    for e in [&mut bounded, &mut free] {
        e.set_joint_torque(0, Vector3::new(0.3, -0.2, 0.4)).unwrap();
        run(e, 200, |_, r| assert_eq!(r.clamped_efforts, 0));
    }
    assert_eq!(bounded.state(), free.state());

    // A spherical joint's torque is scaled to the bound's length: a ball
    // on a pin at its centre (zero gravity) spins as under (0.6, 0.8, 0).
    let ball = |extra: &str, torque: [f64; 3]| {
        let s = sim(1e-3, 100, [0.0; 3])
            + &sphere("ball", 0.1, 2.0, [0.0; 3], [0.0; 3], 0.0, 0.0)
            + &joint("pin", "world", "ball", [0.0; 3])
            + extra;
        let mut e = engine(&s);
        e.set_joint_torque(0, Vector3::from(torque)).unwrap();
        run(&mut e, 100, |_, _| {});
        e.state().bodies[0].w
    };
    let (wc, ww) = (
        ball("max_effort = 1.0\n", [3.0, 4.0, 0.0]),
        ball("", [0.6, 0.8, 0.0]),
    );
    assert!((wc - ww).norm() < 1e-12 * ww.norm(), "{wc} vs {ww}");
    // 0.1 s of 1 N m on I = 2/5 m r^2 = 0.008 kg m^2: 12.5 rad/s.
    assert!((ww.norm() - 12.5).abs() < 1e-9, "{ww}");
}
