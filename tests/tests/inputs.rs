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
