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

/// An arm's text imported with the default options, with its notes.
fn import_arm(text: &str) -> cosim_import::urdf::Imported {
    cosim_import::urdf::import(
        text,
        "arm.urdf",
        "arm",
        None,
        cosim_import::urdf::Options::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

fn import(text: &str) -> Result<Scene, cosim_shared::SceneError> {
    cosim_import::urdf::scene(text, "robot.urdf", "robot")
}

/// The arm's links are its bodies where the kinematic tree puts them
/// (each joint's origin composed from the root, each body on its inertial
/// origin), with the URDF's masses and inertias; the cylinder is a
/// cylinder of its radius and length; the world link is the world and the
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
        Shape::Hull {
            cylinder: Some((radius, half_length)),
            ..
        } => assert!(radius == 0.04 && (half_length - 0.15).abs() < 1e-15),
        s => panic!("upper is {s:?}"),
    }
    assert_eq!(model.bodies[1].mass, 1.0);
    assert_eq!(model.bodies[1].inertia[(0, 0)], 0.0079);
    assert_eq!(model.bodies[1].inertia[(2, 2)], 0.0008);
    // The cylinder's axis (body z) along world x.
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

/// Every problem of a file in one error, each with its line and element
/// (issue 45: one error per run): a mesh (not read yet), a planar joint,
/// an unknown parent link, a box without size, a number that is not one,
/// and a link that moves with no mass.
#[test]
fn every_problem_of_a_file_is_said_at_once_with_its_line() {
    let arm = arm_text();
    let text = arm
        .replace(
            r#"<capsule radius="0.035" length="0.23"/>"#,
            r#"<mesh filename="fore.stl"/>"#,
        )
        .replace(
            r#"name="elbow" type="revolute""#,
            r#"name="elbow" type="planar""#,
        )
        .replace(r#"<parent link="base"/>"#, r#"<parent link="bse"/>"#)
        .replace(r#"<box size="0.1 0.1 0.1"/>"#, r#"<box/>"#)
        .replace(r#"<mass value="1.0"/>"#, r#"<mass value="one"/>"#);
    let e = import(&text).expect_err("six faults");
    let s = e.to_string();
    let line = |needle: &str| {
        arm.lines()
            .position(|l| l.contains(needle))
            .map(|k| k + 1)
            .unwrap_or_else(|| panic!("{needle}"))
    };
    for expect in [
        format!(
            "line {}: link \"fore\" <collision>: the mesh \"fore.stl\"",
            line_after(&arm, "<link name=\"fore\">", "<collision>")
        ),
        format!(
            "line {}: joint \"elbow\": type=\"planar\": not modelled",
            line(r#"name="elbow""#)
        ),
        format!(
            "line {}: joint \"shoulder\": <parent link=\"bse\">: no such link",
            line(r#"name="shoulder""#)
        ),
        format!(
            "line {}: link \"base\" <collision> 1 <box>: <box> has no size",
            line(r#"<box size="0.1 0.1 0.1"/>"#)
        ),
        format!(
            "line {}: link \"upper\" <inertial>: value=\"one\": not 1 finite number",
            line(r#"<mass value="1.0"/>"#)
        ),
    ] {
        assert!(s.contains(&expect), "{expect}\n in\n{s}");
    }
    // Nothing that follows from them (the links below the unknown parent,
    // the mass that could not be read) is said again.
    assert!(s.contains("5 problems"), "{s}");
}

/// The 1-based line of the first `needle` after the line holding `after`.
fn line_after(text: &str, after: &str, needle: &str) -> usize {
    let start = text.lines().position(|l| l.contains(after)).expect("after");
    text.lines()
        .enumerate()
        .skip(start)
        .find(|(_, l)| l.contains(needle))
        .map(|(k, _)| k + 1)
        .expect("needle")
}

/// What PyBullet and MuJoCo read, read (urdf-rs refused both): a
/// `<material>` inside `<visual>` before its geometry, a `<limit>` without
/// `velocity`, elements of Gazebo's and transmissions, an `<origin>`
/// without `rpy`.
#[test]
fn a_urdf_as_people_write_it_loads() {
    let text = arm_text()
        .replace(
            r#"<limit lower="-1.5" upper="1.5" effort="20" velocity="2"/>"#,
            r#"<limit lower="-1.5" upper="1.5" effort="20"/>"#,
        )
        .replace(
            "<link name=\"base\">",
            "<link name=\"base\">\n    <visual><material name=\"grey\"><color rgba=\"0.5 0.5 0.5 1\"/></material><geometry><box size=\"0.1 0.1 0.1\"/></geometry></visual>",
        )
        .replace(
            "</robot>",
            "<gazebo reference=\"base\"><mu1>0.5</mu1></gazebo>\n<transmission name=\"t\"><type>x</type></transmission>\n</robot>",
        )
        .replace(r#"<origin xyz="0 0 0.5" rpy="0 0 0"/>"#, r#"<origin xyz="0 0 0.5"/>"#);
    let scene = import(&text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.bodies.len(), 3);
    assert_eq!(scene.joints[1].range, Some([-1.5, 1.5]));
}

/// A URDF of one link with mass: it floats (PyBullet's and Drake's
/// default) and falls freely, with no floor under it; asked for a fixed
/// base and a floor, it is welded to the world above one.
#[test]
fn a_root_with_mass_floats_unless_asked_and_no_floor_is_added() {
    let cube = r#"<robot name="cube"><link name="cube">
      <inertial><mass value="2"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>
      <collision><origin xyz="0 0 0.5"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision>
    </link></robot>"#;
    let free = import(cube).unwrap_or_else(|e| panic!("{e}"));
    assert!(free.planes.is_empty() && free.joints.is_empty());
    let mut e = Engine::new(Model::from_scene(&free));
    for _ in 0..100 {
        assert!(e.step().ok());
    }
    // Semi-implicit Euler: z_k = -g h^2 k (k + 1) / 2.
    let want = -9.81 * 1e-6 * 100.0 * 101.0 / 2.0;
    assert!((e.state().bodies[0].x.z - want).abs() < 1e-12);
    let options = cosim_import::urdf::Options {
        fixed_base: true,
        floor: true,
        ..Default::default()
    };
    let held = cosim_import::urdf::import(cube, "cube.urdf", "cube", None, options)
        .unwrap_or_else(|e| panic!("{e}"))
        .scene;
    assert_eq!(held.planes.len(), 1);
    assert_eq!(held.joints.len(), 1);
    assert_eq!(held.joints[0].body_a, "world");
    let mut e = Engine::new(Model::from_scene(&held));
    for _ in 0..100 {
        assert!(e.step().ok());
    }
    assert!(e.state().bodies[0].x.norm() < 1e-9);
}

/// A link of several collisions away from its centre of mass (the common
/// case: 10 of 16 of pybullet_data's failures): each shape where the URDF
/// puts it in the world; links fixed to each other (a hand and its tool
/// frame without mass, a second mass) are one body, with mass, centre of
/// mass and inertia combined by the parallel axis theorem, and said.
#[test]
fn several_shapes_off_the_centre_and_fixed_links_merge_as_mujoco_does() {
    let text = r#"<robot name="r">
      <link name="base">
        <inertial><origin xyz="0 0 0.1"/><mass value="2"/>
          <inertia ixx="0.02" iyy="0.03" izz="0.04" ixy="0" ixz="0" iyz="0"/></inertial>
        <collision><origin xyz="0.2 0 0"/><geometry><sphere radius="0.05"/></geometry></collision>
        <collision><origin xyz="-0.2 0 0" rpy="0 0 1.5707963267948966"/><geometry><box size="0.1 0.2 0.3"/></geometry></collision>
      </link>
      <link name="weight">
        <inertial><origin xyz="0 0 0"/><mass value="1"/>
          <inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
        <collision><geometry><sphere radius="0.03"/></geometry></collision>
      </link>
      <link name="tool"/>
      <joint name="w" type="fixed"><origin xyz="0 0.3 0.1"/><parent link="base"/><child link="weight"/></joint>
      <joint name="t" type="fixed"><origin xyz="0 0 0.5"/><parent link="weight"/><child link="tool"/></joint>
    </robot>"#;
    let imported = cosim_import::urdf::import(
        text,
        "r.urdf",
        "r",
        None,
        cosim_import::urdf::Options::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        imported
            .notes
            .iter()
            .any(|n| n.contains("[\"weight\", \"tool\"]")),
        "{:?}",
        imported.notes
    );
    let model = Model::from_scene(&imported.scene);
    assert_eq!(model.bodies.len(), 1);
    let b = &model.bodies[0];
    assert_eq!(b.mass, 3.0);
    // Centre of mass: (2 (0, 0, 0.1) + 1 (0, 0.3, 0.1)) / 3.
    let c = Vector3::new(0.0, 0.1, 0.1);
    assert!((model.initial[0].position - c).norm() < 1e-15);
    // Inertia about c: each part's own plus m (|d|^2 I - d d^T), d from c:
    // base d = (0, -0.1, 0), weight d = (0, 0.2, 0).
    let want = nalgebra::Matrix3::from_diagonal(&Vector3::new(
        0.02 + 0.001 + 2.0 * 0.01 + 0.04,
        0.03 + 0.001,
        0.04 + 0.001 + 2.0 * 0.01 + 0.04,
    ));
    assert!((b.inertia - want).norm() < 1e-15, "{}", b.inertia);
    // The shapes where the URDF puts them: base's sphere at (0.2, 0, 0),
    // its box at (-0.2, 0, 0) turned a quarter about z, the weight's
    // sphere at (0, 0.3, 0.1).
    let world = |k: usize| {
        let g = &b.shapes[k];
        let o = g.offset.expect("off the centre");
        (
            model.initial[0].position + model.initial[0].orientation * o.x,
            model.initial[0].orientation * o.q,
        )
    };
    assert_eq!(b.shapes.len(), 3);
    assert!((world(0).0 - Vector3::new(0.2, 0.0, 0.0)).norm() < 1e-15);
    assert!((world(1).0 - Vector3::new(-0.2, 0.0, 0.0)).norm() < 1e-15);
    assert!((world(1).1 * Vector3::x() - Vector3::y()).norm() < 1e-15);
    assert!((world(2).0 - Vector3::new(0.0, 0.3, 0.1)).norm() < 1e-15);
    // The merged links keep their names as frames of the body, where the
    // URDF puts them: weight at (0, 0.3, 0.1), tool 0.5 above it.
    let desc = &imported.scene.bodies[0];
    let frames: Vec<(&str, Vector3<f64>)> = desc
        .frame
        .iter()
        .map(|f| {
            let at = model.initial[0].position
                + model.initial[0].orientation * Vector3::from(f.position);
            (f.name.as_str(), at)
        })
        .collect();
    assert_eq!(frames.len(), 2, "{frames:?}");
    assert_eq!((frames[0].0, frames[1].0), ("weight", "tool"));
    assert!((frames[0].1 - Vector3::new(0.0, 0.3, 0.1)).norm() < 1e-15);
    assert!((frames[1].1 - Vector3::new(0.0, 0.3, 0.6)).norm() < 1e-15);
}

/// A link that moves on a joint needs mass (MuJoCo refuses it too); a
/// `<dynamics damping>` is a damper (a velocity actuator holding rate 0,
/// bounded by the effort limit), `<dynamics friction>` the joint's dry
/// friction where there is no damping (a motor holding rate 0 with at most
/// that effort); the effort limit bounds a controller's torque; mimic is
/// said; a `spherical` joint is one.
#[test]
fn joints_dynamics_and_massless_links() {
    let arm = arm_text();
    let massless = arm.replace(r#"<mass value="0.5"/>"#, r#"<mass value="0"/>"#);
    let e = import(&massless).expect_err("fore has no mass");
    assert!(
        e.to_string()
            .contains("link \"fore\": moves on a joint but has no mass"),
        "{e}"
    );
    let limit = r#"<limit lower="-2.5" upper="2.5" effort="8" velocity="3"/>"#;
    let with = |dynamics: &str| {
        arm.replace(
            limit,
            &format!(r#"{limit}{dynamics}<mimic joint="shoulder"/>"#),
        )
        .replace(
            r#"name="shoulder" type="revolute""#,
            r#"name="shoulder" type="spherical""#,
        )
    };
    let imported = import_arm(&with(r#"<dynamics friction="0.2"/>"#));
    let j = &imported.scene.joints;
    assert_eq!(j[1].kind, cosim_shared::JointKind::Spherical);
    let m = j[2].motor.expect("friction");
    assert_eq!((m.speed, m.kv, m.max_effort), (0.0, None, 0.2));
    assert_eq!(j[2].max_effort, Some(8.0));
    let notes = imported.notes.join("\n");
    assert!(
        notes.contains("joint \"elbow\": <mimic joint=\"shoulder\">"),
        "{notes}"
    );
    let imported = import_arm(&with(r#"<dynamics damping="0.1" friction="0.2"/>"#));
    let m = imported.scene.joints[2].motor.expect("damping");
    assert_eq!((m.speed, m.kv, m.max_effort), (0.0, Some(0.1), 8.0));
    let notes = imported.notes.join("\n");
    assert!(
        notes.contains("joint \"elbow\": its <dynamics friction> is left out beside its damping"),
        "{notes}"
    );
}

/// A URDF joint's damping acts as MuJoCo's implicit joint damping: a link
/// turning about a vertical hinge (so gravity has no moment) under a
/// held torque `tau` of a controller follows `w' = (tau - c w) / I`
/// integrated implicitly, `w_{n+1} = (w_n + h tau / I) / (1 + h c / I)`,
/// to round-off, towards `tau / c`; a torque beyond the effort limit acts
/// as the limit.
#[test]
fn a_urdf_joints_damping_is_an_implicit_damper_and_its_effort_a_bound() {
    let (m, d, izz, c) = (2.0, 0.3, 0.01, 0.4);
    let text = format!(
        r#"<robot name="wheel">
  <link name="world"/>
  <link name="arm">
    <inertial><origin xyz="{d} 0 0"/><mass value="{m}"/>
      <inertia ixx="0.01" iyy="0.01" izz="{izz}" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="hinge" type="continuous">
    <parent link="world"/><child link="arm"/><origin xyz="0 0 1"/><axis xyz="0 0 1"/>
    <limit effort="1.5" velocity="10"/><dynamics damping="{c}"/>
  </joint>
</robot>"#
    );
    let scene = import(&text).unwrap_or_else(|e| panic!("{e}"));
    let i = izz + m * d * d;
    let h = scene.sim.dt;
    for (tau, applied) in [(1.0, 1.0), (3.0, 1.5)] {
        let mut e = Engine::new(Model::from_scene(&scene));
        e.set_joint_torque(0, Vector3::new(0.0, 0.0, tau)).unwrap();
        let (mut w, mut worst) = (0.0, 0.0f64);
        for _ in 0..2000 {
            let r = e.step();
            assert!(r.ok());
            assert_eq!(r.clamped_efforts, usize::from(tau > applied));
            w = (w + h * applied / i) / (1.0 + h * c / i);
            let got = e.state().bodies[0].w.z;
            worst = worst.max((got - w).abs() / w.abs());
        }
        // The first-order step moves the centre along the tangent: its
        // radius, and I about the hinge, grow by about (h w)^2 before the
        // joint's stabilisation pulls them back; bounded by (h tau / c)^2
        // (measured: 1.5e-6 and 3.3e-6 of 6.3e-6 and 1.4e-5).
        assert!(worst < (h * applied / c).powi(2), "{worst:e}");
        // Two seconds are four time constants (I / c = 0.475 s): past
        // 95 % of the way to tau / c.
        assert!(w > 0.95 * applied / c, "{w}");
    }
}

/// A joint whose zero lies outside its limits starts at the nearer limit
/// (issue 45 point 5; iCub's elbows and the Unitree calves are so
/// written): the elbow limited to [0.5, 2.0] rad stands at 0.5, the
/// forearm turned by it about y, and the scene says `position = 0.5`; the
/// coordinate reads 0.5 at t = 0 and never leaves the range, and no step
/// gains energy beyond the step's first-order swing (before, the limit
/// yanked the joint into range in the first step).
#[test]
fn a_joint_whose_zero_is_outside_its_limits_starts_at_the_nearer_limit() {
    let text = arm_text().replace(
        r#"<limit lower="-2.5" upper="2.5" effort="8" velocity="3"/>"#,
        r#"<limit lower="0.5" upper="2.0" effort="8" velocity="3"/>"#,
    );
    let imported = import_arm(&text);
    let notes = imported.notes.join("\n");
    assert!(
        notes.contains("joint \"elbow\": its zero lies outside its limits: it starts at 0.5"),
        "{notes}"
    );
    assert_eq!(imported.scene.joints[2].position, Some(0.5));
    let model = Model::from_scene(&imported.scene);
    // Ry(0.5) takes the forearm's x towards -z.
    let fore = Vector3::new(0.4 + 0.15 * 0.5f64.cos(), 0.0, 0.5 - 0.15 * 0.5f64.sin());
    let at = model.initial[2].position;
    assert!((at - fore).norm() < 1e-12, "the forearm at {at:?}");
    let mut e = Engine::new(model);
    let elbow = |e: &Engine| coordinate(&e.model().joints[2], e.state()).expect("a hinge");
    assert!((elbow(&e).0 - 0.5).abs() < 1e-12, "{:?}", elbow(&e));
    let energy0 = cosim_server::engine::measure::energy(e.model(), e.state()).total;
    let mut gain = f64::NEG_INFINITY;
    for k in 0..1000 {
        let r = e.step();
        assert!(r.error.is_none(), "{:?}", r.error);
        gain = gain.max(r.energy.total - energy0);
        let (q, _) = elbow(&e);
        assert!(
            (0.5 - 1e-3..=2.0 + 1e-3).contains(&q),
            "step {k}: elbow at {q}"
        );
    }
    // The first-order step's energy swings by O(h) of the motion's (7.6e-3
    // J below the start mid-swing here); measured 1.5e-4 J above it at
    // most.
    assert!(gain < 1e-3, "a step gained {gain} J over the start");
}

/// A collision mesh (an STL and an OBJ written here, as robot packages
/// ship them) is its convex hull, scaled as `<mesh scale>` says, found by
/// a path relative to the robot file; the floor that `floor` asks for lies
/// under the robot's lowest point, and a link resting on it stays there.
#[test]
fn a_mesh_is_its_convex_hull_and_the_floor_lies_under_the_robot() {
    let dir = std::env::temp_dir().join(format!("cosim-urdf-mesh-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    // A unit cube's twelve triangles, and a point at its centre (a
    // vertex of no face: the hull leaves it out).
    let c = |k: usize| {
        let s = |bit: usize| if k & bit != 0 { 0.5 } else { -0.5 };
        [s(1), s(2), s(4)]
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut stl = String::from("solid cube\n");
    let mut obj = String::new();
    for k in 0..8 {
        let v = c(k);
        obj += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    obj += "v 0 0 0\n";
    for q in quads {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            stl += "facet normal 0 0 0\nouter loop\n";
            for k in t {
                let v = c(k);
                stl += &format!("vertex {} {} {}\n", v[0], v[1], v[2]);
            }
            stl += "endloop\nendfacet\n";
            obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
        }
    }
    stl += "endsolid cube\n";
    std::fs::write(dir.join("meshes/cube.stl"), stl).unwrap();
    std::fs::write(dir.join("meshes/cube.obj"), obj).unwrap();
    for mesh in ["cube.stl", "cube.obj"] {
        let urdf = format!(
            r#"<robot name="r"><link name="block">
              <inertial><mass value="1"/><inertia ixx="0.0067" iyy="0.0167" izz="0.0167"/></inertial>
              <collision><origin xyz="0 0 1" rpy="0 0 0.3"/>
                <geometry><mesh filename="meshes/{mesh}" scale="0.2 0.1 0.1"/></geometry></collision>
            </link></robot>"#
        );
        let path = dir.join("r.urdf");
        std::fs::write(&path, urdf).unwrap();
        let options = cosim_import::urdf::Options {
            floor: true,
            ..Default::default()
        };
        let imported =
            cosim_import::urdf::load(&path, options).unwrap_or_else(|e| panic!("{mesh}: {e}"));
        let scene = imported.scene;
        let shape = &scene.bodies[0].shape[0];
        let hull = shape.hull.as_ref().expect("a hull");
        assert_eq!(hull.len(), 8, "{mesh}: {hull:?}");
        for v in hull {
            assert!(
                (v[0].abs() - 0.1).abs() < 1e-7 && (v[1].abs() - 0.05).abs() < 1e-7,
                "{v:?}"
            );
        }
        // The floor under the block's bottom face: z = 1 - 0.05.
        let floor = scene.planes[0].point[2];
        assert!((floor - 0.95).abs() < 1e-7, "{mesh}: {floor}");
        let mut e = Engine::new(Model::from_scene(&scene));
        for _ in 0..500 {
            assert!(e.step().ok());
        }
        let b = e.state().bodies[0];
        assert!((b.x.z - 0.0).abs() < 1e-4, "{mesh}: {}", b.x);
        assert!(b.v.norm() < 1e-6, "{mesh}: {}", b.v);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A robot's links do not touch each other unless asked (PyBullet's
/// default); asked, two overlapping links that no joint joins do.
#[test]
fn a_robots_links_touch_each_other_only_when_asked() {
    let text = r#"<robot name="r">
      <link name="a"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>
        <collision><geometry><sphere radius="0.1"/></geometry></collision></link>
      <link name="b"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial></link>
      <link name="c"><inertial><origin xyz="0.15 0 0"/><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>
        <collision><origin xyz="0.15 0 0"/><geometry><sphere radius="0.1"/></geometry></collision></link>
      <joint name="ab" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint>
      <joint name="bc" type="revolute"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/></joint>
    </robot>"#;
    for (self_collision, touching) in [(false, false), (true, true)] {
        let options = cosim_import::urdf::Options {
            self_collision,
            ..Default::default()
        };
        let scene = cosim_import::urdf::import(text, "r.urdf", "r", None, options)
            .unwrap_or_else(|e| panic!("{e}"))
            .scene;
        let model = Model::from_scene(&scene);
        let (a, c) = (0, 2);
        assert_eq!(model.may_touch(a, c), touching);
    }
}

/// The shipped `arms.toml` places examples/urdf/arm.urdf twice (issue 45,
/// point 5): each robot's bodies and joints named `robot/...`, set at the
/// robot's pose (right: turned half a turn about z), its links a group of
/// their own, the right arm's joints at their initial coordinates, the
/// table and box beside them; the scene written out (`scene.toml` of a
/// run) reads back as the same scene without its robots' files.
#[test]
fn a_scene_places_two_robots_at_their_poses_and_joint_positions() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes/arms.toml");
    let imported = cosim_import::scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let scene = &imported.scene;
    let names: Vec<&str> = scene.bodies.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "table",
            "box",
            "left/base",
            "left/upper",
            "left/fore",
            "right/base",
            "right/upper",
            "right/fore"
        ]
    );
    let joints: Vec<&str> = scene.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(
        joints,
        [
            "left/mount",
            "left/shoulder",
            "left/elbow",
            "right/mount",
            "right/shoulder",
            "right/elbow"
        ]
    );
    assert!(scene.robots.is_empty());
    let body = |n: &str| scene.bodies.iter().find(|b| b.name == n).expect(n);
    assert_eq!(body("left/upper").group.as_deref(), Some("left"));
    assert_eq!(body("right/fore").group.as_deref(), Some("right"));
    assert_eq!(body("table").group, None);
    // The left arm's base at its file's (0, 0, 0.5) moved by (-0.6, -0.15, 0).
    let p = body("left/base").position;
    assert!(
        (Vector3::from(p) - Vector3::new(-0.6, -0.15, 0.5)).norm() < 1e-12,
        "{p:?}"
    );
    // The right shoulder at (0.6, 0.15, 0) + Rz(pi) (0.1, 0, 0.5), its axis
    // y turned to -y.
    let shoulder = scene
        .joints
        .iter()
        .find(|j| j.name == "right/shoulder")
        .expect("shoulder");
    assert!((Vector3::from(shoulder.anchor) - Vector3::new(0.5, 0.15, 0.5)).norm() < 1e-12);
    let axis = Vector3::from(shoulder.axis.expect("a hinge"));
    assert!((axis + Vector3::y()).norm() < 1e-12, "{axis:?}");
    assert_eq!(shoulder.position, Some(-0.4));
    let model = Model::from_scene(scene);
    let e = Engine::new(model);
    let q = |n: &str| {
        let j = e.model().joints.iter().find(|j| j.name == n).expect(n);
        coordinate(j, e.state()).expect("a hinge").0
    };
    assert!((q("right/shoulder") + 0.4).abs() < 1e-12);
    assert!((q("right/elbow") - 0.6).abs() < 1e-12);
    assert!(q("left/elbow").abs() < 1e-12);
    // The right upper arm raised: its centre 0.15 m out along the arm
    // turned up by 0.4 rad (a negative turn about y raises +x).
    let upper = body("right/upper").position;
    let expect = Vector3::new(0.5 - 0.15 * 0.4f64.cos(), 0.15, 0.5 + 0.15 * 0.4f64.sin());
    assert!((Vector3::from(upper) - expect).norm() < 1e-12, "{upper:?}");
    let again = Scene::parse(&scene.to_toml(), "scene.toml").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(&again, scene);
}

/// A scene's robot problems are said at once, naming each robot: two
/// robots of one name, a joint position for a joint the robot lacks,
/// one outside its limits, a file that is not there; and a scene with a
/// robot read without the importer says where robots are placed.
#[test]
fn a_scenes_robot_problems_are_said_at_once() {
    let dir = std::env::temp_dir().join(format!("cosim-robot-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("arm.urdf"), arm_text()).unwrap();
    let text = r#"
[sim]
dt = 0.001
duration = 1.0

[[robot]]
file = "arm.urdf"
joints = { wrist = 0.1, elbow = 3.0 }

[[robot]]
file = "arm.urdf"

[[robot]]
file = "gone.urdf"
name = "gone"
"#;
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let e = cosim_import::scene::load(&path)
        .expect_err("refused")
        .to_string();
    std::fs::remove_dir_all(&dir).ok();
    for expect in [
        "3 problems",
        "robot[0] \"arm\": ",
        "joint \"wrist\": given an initial position, but the robot has no such joint",
        "joint \"elbow\": the initial position 3 lies outside its limits [-2.5, 2.5]",
        "robot[1] \"arm\": a second robot of this name",
        "robot[2] \"gone\": ",
        "cannot read the file",
    ] {
        assert!(e.contains(expect), "{expect:?} not in: {e}");
    }
    let e = Scene::parse(text, "scene.toml")
        .expect_err("refused")
        .to_string();
    assert!(
        e.contains("robot = \"arm.urdf\": a robot is placed by the importer"),
        "{e}"
    );
}

/// A robot's servos (`servo` of a scene's `[[robot]]`, issue 45 point 6):
/// every hinge a position servo holding its initial coordinate with the
/// given gains, bounded by the URDF's `<limit effort>` (MuJoCo's
/// forcerange from it); a joint without an effort limit is a problem
/// naming it, unless the servo gives its own bound.
#[test]
fn a_robots_servos_hold_its_joints_bounded_by_their_effort() {
    let servo = cosim_shared::ServoDesc {
        kp: 100.0,
        kd: 1.0,
        max_effort: None,
    };
    let options = cosim_import::urdf::Options {
        servo: Some(servo),
        positions: [("elbow".to_string(), 0.25)].into(),
        ..Default::default()
    };
    let with = |text: &str, options: cosim_import::urdf::Options| {
        cosim_import::urdf::import(text, "arm.urdf", "arm", None, options)
    };
    let imported = with(&arm_text(), options.clone()).unwrap_or_else(|e| panic!("{e}"));
    let motors: Vec<_> = imported.scene.joints[1..]
        .iter()
        .map(|j| j.motor.expect("a servo"))
        .map(|m| (m.position, m.kp, m.kd, m.max_effort))
        .collect();
    assert_eq!(
        motors,
        [
            (Some(0.0), Some(100.0), Some(1.0), 20.0),
            (Some(0.25), Some(100.0), Some(1.0), 8.0)
        ]
    );
    let no_effort = arm_text().replace(r#"effort="8" "#, "");
    let e = with(&no_effort, options.clone())
        .expect_err("no bound")
        .to_string();
    assert!(
        e.contains("joint \"elbow\"") && e.contains("a servo needs the joint's <limit effort>"),
        "{e}"
    );
    let own = cosim_import::urdf::Options {
        servo: Some(cosim_shared::ServoDesc {
            max_effort: Some(5.0),
            ..servo
        }),
        ..options
    };
    let imported = with(&no_effort, own).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        imported.scene.joints[2].motor.map(|m| m.max_effort),
        Some(5.0)
    );
}
