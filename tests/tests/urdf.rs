//! URDF import (issue 17, point 3): examples/urdf/arm.urdf becomes the
//! scene its links and joints describe, runs ten times its duration with
//! each solver, and what lies outside the subset is refused by name.

use cosim_server::engine::constraint::joint::coordinate;
use cosim_server::engine::model::Shape;
use cosim_server::engine::{Attachment, Engine, Model, Turning};
use cosim_shared::{Scene, SolverChoice};
use nalgebra::Vector3;

fn arm_text() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/urdf/arm.urdf");
    std::fs::read_to_string(path).expect("examples/urdf/arm.urdf")
}

fn import(text: &str) -> Result<Scene, cosim_shared::SceneError> {
    cosim_import::urdf::scene(text, "robot.urdf", "robot")
}

/// The arm's links are its bodies where the kinematic tree puts them
/// (each joint's origin composed from the root, each body on its inertial
/// origin), with the URDF's masses and inertias; the cylinder is the
/// capsule of its radius and length; the world link is the world and the
/// base is fixed to it; the hinges keep their axes and limits and are
/// passive (issue 45: an `effort` made a velocity motor that held the arm
/// level): released level, the arm falls; its shoulder turns as a
/// compound pendulum's would at first, and the run keeps its energy but
/// for what contact and the limits take.
#[test]
fn the_urdf_arm_is_the_scene_it_describes() {
    let scene = import(&arm_text()).unwrap_or_else(|e| panic!("{e}"));
    let model = Model::from_scene(&scene);
    let names: Vec<&str> = model.bodies.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(names, ["base", "upper", "fore"]);
    let at = |i: usize| model.initial[i].position;
    assert!((at(0) - Vector3::new(0.0, 0.0, 0.5)).norm() < 1e-12);
    assert!((at(1) - Vector3::new(0.25, 0.0, 0.5)).norm() < 1e-12);
    assert!((at(2) - Vector3::new(0.55, 0.0, 0.5)).norm() < 1e-12);
    assert_eq!(
        model.bodies[0].shapes[0].shape,
        Shape::Box {
            half: Vector3::repeat(0.05)
        }
    );
    match model.bodies[1].shapes[0].shape {
        Shape::Capsule {
            radius,
            half_length,
        } => assert!(radius == 0.04 && (half_length - 0.11).abs() < 1e-15),
        s => panic!("upper is {s:?}"),
    }
    assert_eq!(model.bodies[1].mass, 1.0);
    assert_eq!(model.bodies[1].inertia[(0, 0)], 0.0079);
    assert_eq!(model.bodies[1].inertia[(2, 2)], 0.0008);
    // The capsule's axis (body z) along world x.
    let axis = model.initial[1].orientation * Vector3::z();
    assert!((axis - Vector3::x()).norm() < 1e-12, "{axis:?}");
    let kinds: Vec<&str> = model.joints.iter().map(|j| j.kind()).collect();
    assert_eq!(kinds, ["fixed", "revolute", "revolute"]);
    assert_eq!(model.joints[0].a, Attachment::World);
    assert!(model.joints.iter().all(|j| !j.collide));
    for (j, (lo, hi)) in [(1, (-1.5, 1.5)), (2, (-2.5, 2.5))] {
        let joint = &model.joints[j];
        let l = joint.limits.expect("a range");
        assert_eq!((l.lower, l.upper), (lo, hi));
        assert!(joint.motor.is_none(), "joint {j} is passive");
        let Turning::Axis { a, .. } = joint.turning else {
            panic!("a hinge")
        };
        assert!((a.abs() - Vector3::y()).norm() < 1e-12, "{a:?}");
    }
    assert!((model.joints[2].local_a - Vector3::new(0.0, 0.0, 0.15)).norm() < 1e-12);

    let mut e = Engine::new(model);
    let energy0 = cosim_server::engine::measure::energy(e.model(), e.state()).total;
    for k in 0..3000 {
        let r = e.step();
        assert!(r.error.is_none(), "{:?}", r.error);
        // No step gains energy beyond the start's (no input acts).
        assert!(
            r.energy.total <= energy0 + 1e-6,
            "step {k}: {} J",
            r.energy.total
        );
        if k == 49 {
            // 0.05 s in, released from rest at level: a fall, the
            // shoulder turning the arm down (either sign of its axis).
            let (x, _) = coordinate(&e.model().joints[1], e.state()).expect("a hinge");
            assert!(x.abs() > 0.01, "the shoulder held at {x} rad");
        }
    }
    let (x, _) = coordinate(&e.model().joints[1], e.state()).expect("a hinge");
    assert!(x.abs() > 0.5, "the arm fell: shoulder at {x} rad");
}

/// Like a shipped scene: ten times its duration with each solver, no
/// failed step.
#[test]
fn the_urdf_arm_runs_ten_times_its_duration_with_each_solver() {
    let scene = import(&arm_text()).unwrap_or_else(|e| panic!("{e}"));
    for solver in [SolverChoice::Lemke, SolverChoice::Pgs, SolverChoice::Auto] {
        let mut model = Model::from_scene(&scene);
        model.params.solver = solver;
        let mut e = Engine::new(model);
        for _ in 0..10 * scene.step_count() {
            let r = e.step();
            assert!(r.error.is_none(), "{}: {:?}", solver.as_str(), r.error);
        }
    }
}

/// Outside the subset, named: a mesh, a floating joint, a collision away
/// from the centre of mass, two collisions, two roots, a mimic joint, an
/// unknown link.
#[test]
fn what_lies_outside_the_subset_is_named() {
    let arm = arm_text();
    let cases = [
        (
            arm.replace(
                r#"<capsule radius="0.035" length="0.23"/>"#,
                r#"<mesh filename="fore.stl"/>"#,
            ),
            r#"link "fore".collision.geometry: is the mesh "fore.stl""#,
        ),
        (
            arm.replace(r#"name="elbow" type="revolute""#, r#"name="elbow" type="floating""#),
            r#"joint "elbow".type = Floating: outside the subset"#,
        ),
        (
            arm.replace(
                r#"<origin xyz="0.15 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><capsule"#,
                r#"<origin xyz="0.2 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><capsule"#,
            ),
            r#"link "fore".collision.origin"#,
        ),
        (
            arm.replace(
                "<geometry><box size=\"0.1 0.1 0.1\"/></geometry>\n    </collision>",
                "<geometry><box size=\"0.1 0.1 0.1\"/></geometry>\n    </collision>\n    <collision><geometry><sphere radius=\"0.1\"/></geometry></collision>",
            ),
            r#"link "base".collision: has 2 <collision> elements"#,
        ),
        (
            arm.replace(
                r#"<link name="world"/>"#,
                r#"<link name="world"/><link name="loose"/>"#,
            ),
            "robot: has 2 root links",
        ),
        (
            arm.replace(
                r#"<limit lower="-2.5" upper="2.5" effort="8" velocity="3"/>"#,
                r#"<limit lower="-2.5" upper="2.5" effort="8" velocity="3"/><mimic joint="shoulder"/>"#,
            ),
            r#"joint "elbow".mimic = "shoulder": outside the subset"#,
        ),
        (
            arm.replace(r#"<parent link="upper"/>"#, r#"<parent link="uper"/>"#),
            r#"joint "elbow".parent = "uper": no such link"#,
        ),
    ];
    for (text, expect) in cases {
        assert_ne!(text, arm, "the case's edit applies: {expect}");
        let e = import(&text).expect_err(expect);
        assert!(e.to_string().contains(expect), "{expect}: {e}");
    }
}
