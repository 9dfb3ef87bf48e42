//! The shipped examples served with their controllers, Rust and Python.

use super::*;

#[test]
fn the_demo_holds_the_pendulum_at_its_target() {
    let dir = TempDir::new("demo");
    let out = Command::new(EXE)
        .args(["demo", "--duration", "4", "--elevation", "15", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("figures"), "{text}");
    assert!(dir.path().join("animation.gif").exists());
    assert!(dir.path().join("plots/positions.png").exists());
    // The upper sphere is 0.3 m from the shoulder at (0, 0, 0.45): its
    // elevation over the last second stays within 0.5 degrees of 15.
    let rows = positions(dir.path(), "upper");
    assert_eq!(rows.len(), 4001);
    for (step, x) in &rows[3000..] {
        let e = elevation_deg(*x);
        assert!((e - 15.0).abs() < 0.5, "step {step}: elevation {e}");
    }
    let s = summary(dir.path());
    assert_eq!(s["deadline_misses"], 0);
    assert_eq!(s["steps"], 4000);
    let _ = STATUS_SHUTDOWN;
    // The strike (issue 46, point 5): from 0.8 s to 1.8 s the arm swings
    // down; the lower sphere hits the floor (an impact far above the
    // resting push that follows), then presses on it and slides
    // (friction), and leaves it when the arm lifts.
    let csv = std::fs::read_to_string(dir.path().join("impulses.csv")).unwrap();
    let rows = |kind: &str| -> Vec<(u64, f64)> {
        csv.lines()
            .filter(|l| l.contains(&format!(",{kind},lower/floor,")))
            .map(|l| {
                let c: Vec<&str> = l.split(',').collect();
                let p: Vec<f64> = c[6..9].iter().map(|v| v.parse().unwrap()).collect();
                (
                    c[0].parse().unwrap(),
                    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt(),
                )
            })
            .collect()
    };
    let (normal, friction) = (rows("normal"), rows("friction"));
    assert!(normal.len() > 300, "{} normal rows", normal.len());
    assert!(friction.len() > 100, "{} friction rows", friction.len());
    assert!(
        normal.iter().all(|&(k, _)| (800..1900).contains(&k)),
        "contact outside the strike"
    );
    let impact = normal.iter().map(|r| r.1).fold(0.0, f64::max);
    let resting = normal[normal.len() / 2].1;
    assert!(
        impact > 20.0 * resting,
        "impact {impact} N s, resting {resting} N s"
    );
}

/// examples/python/slider_controller.py: a Python controller that reads
/// the rail's offset and speed from the frames (protocol 3) and holds
/// slider.toml's carriage at 0.5 m down its rail with a PD force (the
/// slider's effort). Over the last second the carriage stays within 1 cm
/// of the target while the pendulum under it swings freely (measured
/// 7 mm), per the server's joints.csv, and the offset the controller
/// printed for its last frame is one the server wrote.
#[test]
fn a_python_pd_controller_holds_a_slider_at_its_target() {
    let scene = SLIDER;
    let (server, dir, name) = serve_test(
        "py-slider",
        &[scene, "--controllers", "1", "--steps", "3000"],
    );
    let text = python_example(
        "slider_controller.py",
        &["--name", &name, "--target", "0.5"],
    );
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let csv = std::fs::read_to_string(dir.path().join("joints.csv")).unwrap();
    let rail: Vec<(u64, f64)> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[2] == "rail")
        .map(|c| (c[0].parse().unwrap(), c[4].parse().unwrap()))
        .collect();
    assert_eq!(rail.len(), 3001);
    let worst = rail[2000..]
        .iter()
        .map(|(_, x)| (x - 0.5).abs())
        .fold(0.0f64, f64::max);
    assert!(worst < 0.01, "the carriage strayed {worst} m from 0.5 m");
    let printed = printed_after(&text, "rail offset ");
    assert!(
        rail[2990..].iter().any(|(_, x)| *x == printed),
        "printed {printed}, joints.csv {:?}",
        &rail[2990..]
    );
}

/// Issue 17: a controller sets a motor's target over the wire (protocol
/// 4). limits.toml served with a controller that slows the rail's motor
/// to 0.3 m/s from step 10 and sends, once each, a target for a joint
/// without a motor and a non-finite one (both refused, named, the run
/// going on): the served run is an offline one with the same target from
/// the same step, to the bit; the replay log holds the change and replays
/// to the same hashes.
#[test]
fn a_controllers_motor_target_drives_the_served_run_and_replays() {
    use cosim_server::engine::constraint::joint;
    use cosim_server::engine::{Engine, Model};
    let steps = 200u64;
    let (server, dir, name) = serve_test(
        "motor-targets",
        &[
            LIMITS,
            "--controllers",
            "1",
            "--steps",
            &steps.to_string(),
            "--deadline-ms",
            "5000",
        ],
    );
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    let mut last = None;
    answer_until_shutdown(&mut c, |c| {
        let f = c.last_state().expect("a state").clone();
        let mut input = InputFrame::default();
        match f.step {
            5 => input.push_motor(0, 1.0),
            6 => input.push_motor(2, f64::NAN),
            k if k >= 10 => input.push_motor(2, 0.3),
            _ => {}
        }
        last = Some((f.step, f.joint_coordinates[2]));
        c.send(input).expect("send");
    });
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let s = summary(dir.path());
    assert_eq!(s["steps"], steps, "the run went on");
    let r = &s["inputs_rejected"];
    assert_eq!(r["unknown_index"], 1, "{s}");
    assert_eq!(r["non_finite"], 1, "{s}");
    // Offline: the scene's target until step 10, then 0.3 m/s, to the
    // last frame the controller answered.
    let (seen, coords) = last.expect("frames");
    let text = std::fs::read_to_string(LIMITS).unwrap();
    let mut e = Engine::new(Model::from_scene(
        &cosim_shared::Scene::parse(&text, LIMITS).unwrap(),
    ));
    for k in 0..seen {
        if k == 10 {
            e.set_motor_speed(2, 0.3).unwrap();
        }
        assert!(e.step().ok());
    }
    let rail = joint::coordinate(&e.model().joints[2], e.state()).unwrap();
    assert_eq!(
        coords,
        [rail.0, rail.1],
        "the served run is the offline one at step {seen}"
    );
    // Near 0.2 s the car runs at the new target, not the scene's 0.8 m/s.
    assert!((rail.1 - 0.3).abs() < 1e-9, "rail rate {}", rail.1);
    let log = std::fs::read_to_string(dir.path().join("replay.csv")).unwrap();
    assert!(log.contains("\nmotor,10,2,0.3\n"), "{log}");
    let inputs = std::fs::read_to_string(dir.path().join("inputs.csv")).unwrap();
    assert!(inputs.contains(",unknown_index,motor,0,1,"), "{inputs}");
    let (ok, out) = replay(dir.path());
    assert!(ok, "{out}");
}

/// examples/python/motor_controller.py: a Python controller sets the rail
/// motor of limits.toml to 0.3 m/s (protocol 4's motor target) and reads
/// the rate back from the frames: the car runs at 0.3 m/s, not the scene's
/// 0.8, to round-off (Lemke), 0.15 s in (before its end stop).
#[test]
fn a_python_controller_sets_a_motor_target() {
    let (server, _dir, name) = serve_test(
        "python-motor",
        &[LIMITS, "--controllers", "1", "--steps", "150"],
    );
    let text = python_example("motor_controller.py", &["--name", &name, "--speed", "0.3"]);
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let rate = printed_after(&text, "rail rate ");
    assert!((rate - 0.3).abs() < 1e-9, "{text}");
}

/// The shipped arm (a two-link arm on hinges with limits and velocity
/// motors).
const ARM: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/scenes/arm.toml");

/// Issue 17, point 5 (capsules for links): the arm
/// steered to (0.6, -1.0) rad by its motors from a controller
/// (`cosim_client::arm`, the law of the examples' `arm_controller` and of
/// arm_controller.py) reaches its target: within the motors' bounds each
/// error decays by `1 - k h` a step (k = 5/s), 1 rad to 3e-7 in 3 s, so
/// after 3,000 steps both angles are within 1e-5 rad (the hinge's angle
/// also carries the joint's drift, 1e-6 here), the Rust and the Python
/// controller alike.
#[test]
fn a_two_link_arm_reaches_its_target_under_a_motor_controller_rust_and_python() {
    let target = [0.6, -1.0];
    let args = three_seconds_with_one_controller(ARM);
    let (server, _dir, name) = serve_test("arm-rust", &args);
    let out = cosim_client::arm::run(&name, target, Duration::from_secs(30)).expect("arm");
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    assert!(out.steps >= 2999, "{out:?}");
    for (q, t) in out.angles.iter().zip(target) {
        assert!((q - t).abs() < 1e-5, "{out:?}");
    }
    let (server, _dir, name) = serve_test("arm-python", &args);
    let text = python_example(
        "arm_controller.py",
        &["--name", &name, "--shoulder", "0.6", "--elbow", "-1.0"],
    );
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let (s, e) = (
        printed_after(&text, "shoulder "),
        printed_after(&text, "elbow "),
    );
    assert!((s - 0.6).abs() < 1e-5 && (e + 1.0).abs() < 1e-5, "{text}");
}

/// The shipped push scene: a 2 kg box on a floor with friction.
const PUSH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/scenes/push.toml");

/// Issue 17, point 5: a box pushed across the floor by body impulses from
/// a controller (`cosim_client::push`, the law of the examples'
/// `push_controller` and of push_controller.py) stops at its target: the
/// servo asks for `k (x* - x)` (k = 5/s, at most 0.5 m/s), friction holds
/// the box once the impulse falls below `mu m g h`, within `mu g h / k`
/// = 0.8 mm of the target, and the box neither lifts nor turns much (its
/// friction is spread over an indeterminate support). The Rust and the
/// Python controller alike.
#[test]
fn a_box_pushed_by_body_impulses_stops_at_its_target_rust_and_python() {
    let target = [0.5, 0.2];
    let args = three_seconds_with_one_controller(PUSH);
    let within = 0.4 * 9.81 * 1e-3 / 5.0 + 1e-6;
    let (server, dir, name) = serve_test("push-rust", &args);
    let out = cosim_client::push::run(&name, target, Duration::from_secs(30)).expect("push");
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    assert!(out.steps >= 2999, "{out:?}");
    let miss =
        ((out.position[0] - target[0]).powi(2) + (out.position[1] - target[1]).powi(2)).sqrt();
    assert!(miss < within, "{out:?}: {miss} m from the target");
    assert!((out.position[2] - 0.05).abs() < 1e-4, "{out:?}");
    // The last state's orientation, from the server's states.csv: a turn
    // about the vertical of less than 0.05 rad.
    let states = std::fs::read_to_string(dir.path().join("states.csv")).unwrap();
    let last = states
        .lines()
        .last()
        .unwrap()
        .split(',')
        .collect::<Vec<_>>();
    let qw: f64 = last[6].parse().unwrap();
    let turned = 2.0 * qw.abs().min(1.0).acos();
    eprintln!("Rust: {miss:e} m from the target, turned {turned:e} rad");
    assert!(turned < 0.05, "turned: {last:?}");
    let (server, _dir, name) = serve_test("push-python", &args);
    let text = python_example(
        "push_controller.py",
        &["--name", &name, "--x", "0.5", "--y", "0.2"],
    );
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let (x, y) = (printed_after(&text, "x "), printed_after(&text, "y "));
    let miss = ((x - target[0]).powi(2) + (y - target[1]).powi(2)).sqrt();
    eprintln!("Python: {miss:e} m from the target");
    assert!(miss < within, "{text}");
}

/// Issue 45's named example: Go1 (example-robot-data's URDF, placed by
/// examples/robots/go1_stand.toml crouched on the floor, its joints
/// position servos) stood up by examples/python/go1_stand.py in a process
/// of its own, which moves the servos' targets by joint name. Per the
/// server's states.csv the base rises from the crouch (0.11 m) by more
/// than 0.12 m and then holds, level (tilt under 0.02 rad) and in place
/// (under 1 mm of drift in its last second); the height the controller printed for its last
/// frame is one the server wrote.
#[test]
fn a_python_posture_controller_stands_go1_up() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    common::robot_data();
    let scene = root.join("examples/robots/go1_stand.toml");
    let scene = scene.to_str().expect("a UTF-8 path");
    let (server, dir, name) =
        serve_test("py-go1", &[scene, "--controllers", "1", "--steps", "3000"]);
    let text = python_example("go1_stand.py", &["--name", &name]);
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let csv = std::fs::read_to_string(dir.path().join("states.csv")).unwrap();
    // step, x, y, z, qw of the base.
    let base: Vec<[f64; 5]> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[2] == "go1/base")
        .map(|c| [0, 3, 4, 5, 6].map(|k| c[k].parse().unwrap()))
        .collect();
    assert_eq!(base.len(), 3001);
    let crouch = base[0][3];
    let last = base[3000];
    assert!(
        last[3] - crouch > 0.12,
        "the base rose from {crouch} to {} m",
        last[3]
    );
    for b in &base[2000..] {
        // qw = cos(tilt / 2) bounds the tilt from above.
        let tilt = 2.0 * b[4].abs().min(1.0).acos();
        assert!(tilt < 0.02, "step {}: tilted {tilt} rad", b[0]);
        assert!(
            (b[3] - last[3]).abs() < 1e-3,
            "step {}: at {} m",
            b[0],
            b[3]
        );
    }
    // Standing shifts the base over the feet (the thighs turn about the
    // hips); stood, it stays.
    let moved = |a: &[f64; 5], b: &[f64; 5]| ((a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    let shift = moved(&last, &base[0]);
    assert!(shift < 0.05, "the base moved {shift} m standing up");
    let drift = moved(&last, &base[2000]);
    assert!(drift < 1e-3, "the base wandered {drift} m after standing");
    let printed = printed_after(&text, "base height ");
    assert!(
        base[2990..].iter().any(|b| b[3] == printed),
        "printed {printed}, states.csv {:?}",
        &base[2990..]
    );
}
