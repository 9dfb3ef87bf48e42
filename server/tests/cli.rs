//! The command line: validation errors (acceptance 10) and the output files.

mod common;

use common::TempDir;
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_cosim-server");

fn run(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("run cosim-server")
}

/// `run`, which must succeed (else its stderr is the failure).
fn run_ok(args: &[&str]) -> Output {
    let out = run(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

const GOOD: &str = r#"[sim]
dt = 0.001
steps = 50

[[body]]
name = "ball"
radius = 0.1
mass = 1.0
position = [0.0, 0.0, 0.3]
orientation = [1.0, 0.0, 0.0, 0.0]
friction = 0.5

[[body]]
name = "other"
radius = 0.1
mass = 1.0
position = [0.5, 0.0, 0.3]

[[plane]]
name = "floor"
normal = [0.0, 0.0, 1.0]
point = [0.0, 0.0, 0.0]

[[joint]]
name = "pin"
type = "spherical"
body_a = "world"
body_b = "ball"
anchor = [0.0, 0.0, 0.6]
"#;

/// Each broken scene: (what, replace this, by this, expected field, expected line).
const CASES: &[(&str, &str, &str, &str, Option<usize>)] = &[
    (
        "toml syntax",
        "mass = 1.0\nposition",
        "mass = 1.0 1.0\nposition",
        "body[0].mass",
        Some(8),
    ),
    (
        "unknown field",
        "friction = 0.5",
        "frictoin = 0.5",
        "body[0].frictoin",
        Some(11),
    ),
    (
        "unknown body in joint",
        "body_b = \"ball\"",
        "body_b = \"bal\"",
        "joint \"pin\".body_b",
        None,
    ),
    (
        "duplicate name",
        "name = \"other\"",
        "name = \"ball\"",
        "body[1].name",
        None,
    ),
    (
        "non-positive mass",
        "mass = 1.0\nposition",
        "mass = -1.0\nposition",
        "body \"ball\".mass",
        None,
    ),
    (
        "zero radius",
        "radius = 0.1\nmass = 1.0\nposition = [0.0, 0.0, 0.3]",
        "radius = 0.0\nmass = 1.0\nposition = [0.0, 0.0, 0.3]",
        "body \"ball\".radius",
        None,
    ),
    ("non-positive dt", "dt = 0.001", "dt = 0.0", "sim.dt", None),
    (
        "zero normal",
        "normal = [0.0, 0.0, 1.0]",
        "normal = [0.0, 0.0, 0.0]",
        "plane \"floor\".normal",
        None,
    ),
    (
        "nan",
        "position = [0.0, 0.0, 0.3]",
        "position = [0.0, nan, 0.3]",
        "body \"ball\".position",
        None,
    ),
    (
        "infinity",
        "anchor = [0.0, 0.0, 0.6]",
        "anchor = [0.0, 0.0, inf]",
        "joint \"pin\".anchor",
        None,
    ),
    (
        "non-unit orientation",
        "orientation = [1.0, 0.0, 0.0, 0.0]",
        "orientation = [1.0, 0.1, 0.0, 0.0]",
        "body \"ball\".orientation",
        None,
    ),
];

#[test]
fn every_validation_case_exits_2_naming_the_field() {
    let dir = TempDir::new("cli-validation");
    // The good scene runs.
    let good = dir.path().join("good.toml");
    std::fs::write(&good, GOOD).unwrap();
    run_ok(&[
        "run",
        good.to_str().unwrap(),
        "--quiet",
        "--out",
        dir.path().join("o").to_str().unwrap(),
    ]);
    for (what, from, to, field, line) in CASES {
        assert!(GOOD.contains(from), "{what}: pattern not in the scene");
        let path = dir.path().join(format!("{}.toml", what.replace(' ', "_")));
        std::fs::write(&path, GOOD.replacen(from, to, 1)).unwrap();
        let out = run(&[
            "run",
            path.to_str().unwrap(),
            "--quiet",
            "--out",
            dir.path().join("o").to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{what}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{what}: not one line: {err}");
        assert!(
            err.contains(path.to_str().unwrap()),
            "{what}: file not named: {err}"
        );
        assert!(
            err.contains(field),
            "{what}: field {field} not named: {err}"
        );
        if let Some(line) = line {
            assert!(
                err.contains(&format!(":{line}:")),
                "{what}: line {line} not given: {err}"
            );
        }
    }
}

#[test]
fn bad_options_exit_2_naming_the_option() {
    for (args, name) in [
        (&["run", "--dt", "0", "--quiet"][..], "--dt"),
        (&["run", "--steps", "0", "--quiet"][..], "--steps"),
        (
            &["run", "--friction-directions", "2", "--quiet"][..],
            "--friction-directions",
        ),
        (
            &["run", "/nonexistent/scene.toml", "--quiet"][..],
            "/nonexistent/scene.toml",
        ),
    ] {
        let out = run(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(name), "{args:?}: {err}");
    }
}

#[test]
fn reference_run_writes_every_file() {
    let dir = TempDir::new("cli-reference");
    let out_dir = dir.path().join("out");
    let out = run_ok(&["run", "--steps", "300", "--out", out_dir.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("reference") && stdout.contains("failures     0"),
        "{stdout}"
    );

    let states = std::fs::read_to_string(out_dir.join("states.csv")).unwrap();
    let mut lines = states.lines();
    assert_eq!(
        lines.next(),
        Some("step,t,body,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz")
    );
    // Steps 0..=300, two bodies each.
    assert_eq!(lines.clone().count(), 301 * 2);
    assert!(lines
        .next()
        .unwrap()
        .starts_with("0,0,upper,0.3,0,0.45,1,0,0,0,"));

    let impulses = std::fs::read_to_string(out_dir.join("impulses.csv")).unwrap();
    assert!(impulses.starts_with("step,t,kind,name,body_a,body_b,px,py,pz\n"));
    for kind in [
        ",joint,shoulder,world,upper,",
        ",normal,upper/lower,upper,lower,",
        ",friction,lower/floor,lower,floor,",
    ] {
        assert!(impulses.contains(kind), "no {kind} row");
    }
    let steps = std::fs::read_to_string(out_dir.join("steps.csv")).unwrap();
    assert_eq!(steps.lines().count(), 301);

    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    for key in [
        "steps",
        "t_end",
        "solver",
        "failures",
        "max_penetration",
        "max_joint_error",
        "energy_initial",
        "energy_final",
        "wall_seconds",
    ] {
        assert!(summary.get(key).is_some(), "summary.json lacks {key}");
    }
    assert_eq!(summary["steps"], 300);
    assert_eq!(summary["failures"], 0);
    assert_eq!(summary["solver"], "lemke");
}

#[test]
fn shadow_records_the_other_solvers_velocity_difference() {
    let dir = TempDir::new("cli-shadow");
    let out_dir = dir.path().join("out");
    run_ok(&[
        "run",
        "--steps",
        "200",
        "--shadow",
        "--quiet",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let steps = std::fs::read_to_string(out_dir.join("steps.csv")).unwrap();
    let header: Vec<&str> = steps.lines().next().unwrap().split(',').collect();
    let col = header
        .iter()
        .position(|h| *h == "shadow_dv")
        .expect("shadow_dv column");
    let mut rows = 0;
    for line in steps.lines().skip(1) {
        let dv: f64 = line
            .split(',')
            .nth(col)
            .unwrap()
            .parse()
            .expect("a number on every step");
        // Lemke and PGS (1e-10) agree on the first 200 steps of the reference scene.
        assert!(dv < 1e-6, "{line}");
        rows += 1;
    }
    assert_eq!(rows, 200);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    assert!(summary["shadow_max_dv"].as_f64().unwrap() < 1e-6);
}

/// `joints.csv` beside `states.csv`: a row per joint per state, the
/// hinge's angle as the arm's orientation in states.csv gives it (the arm
/// hangs from the world, so its turn since t = 0 is the hinge's: about y,
/// `2 atan2(q_y, q_w)` of `q(t) q(0)^-1`), its rate the arm's `w_y`; the
/// fixed joint has no coordinate.
#[test]
fn joints_csv_gives_a_hinges_angle_as_the_states_show_it() {
    use nalgebra::{Quaternion, UnitQuaternion};
    let dir = TempDir::new("cli-joints");
    let out_dir = dir.path().join("out");
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/scenes/hinges.toml"
    );
    run_ok(&[
        "run",
        scene,
        "--steps",
        "800",
        "--quiet",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let read = |name: &str| std::fs::read_to_string(out_dir.join(name)).unwrap();
    let (states, joints) = (read("states.csv"), read("joints.csv"));
    let mut rows = joints.lines();
    assert_eq!(
        rows.next(),
        Some("step,t,joint,type,position,rate,anchor_error,angle_error")
    );
    let rows: Vec<Vec<&str>> = rows.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 801 * 2, "two joints, states 0..=800");
    let arm: Vec<Vec<f64>> = states
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[2] == "arm")
        .map(|c| c[3..].iter().map(|x| x.parse().unwrap()).collect())
        .collect();
    let q = |s: &[f64]| UnitQuaternion::from_quaternion(Quaternion::new(s[3], s[4], s[5], s[6]));
    let start = q(&arm[0]).inverse();
    let mut turned = 0.0f64;
    for (k, row) in rows.iter().filter(|r| r[2] == "hinge").enumerate() {
        assert_eq!(row[3], "revolute");
        let r = q(&arm[k]) * start;
        let angle = 2.0 * r.j.atan2(r.w);
        let (position, rate): (f64, f64) = (row[4].parse().unwrap(), row[5].parse().unwrap());
        assert!(
            (position - angle).abs() < 1e-9,
            "step {k}: {position} against {angle}"
        );
        assert!((rate - arm[k][11]).abs() < 1e-12, "step {k}: rate {rate}");
        turned = turned.max(angle.abs());
    }
    assert!(turned > 1.0, "the arm swung down ({turned} rad)");
    // steps.csv's largest rotation error is joints.csv's, step by step.
    let steps = read("steps.csv");
    let header: Vec<&str> = steps.lines().next().unwrap().split(',').collect();
    let col = header
        .iter()
        .position(|h| *h == "max_joint_angle_error")
        .expect("the column");
    for (k, line) in steps.lines().skip(1).enumerate() {
        let reported: f64 = line.split(',').nth(col).unwrap().parse().unwrap();
        let worst = rows[2 * (k + 1)..2 * (k + 2)]
            .iter()
            .map(|r| r[7].parse::<f64>().unwrap())
            .fold(0.0f64, f64::max);
        assert_eq!(reported, worst, "step {}", k + 1);
    }
    for row in rows.iter().filter(|r| r[2] == "wrist") {
        assert_eq!((row[3], row[4], row[5]), ("fixed", "", ""));
        // Issue 17's bound for a fixed joint at h = 1e-3 (measured 1.0e-6
        // m as the hand strikes the ball).
        assert!(
            row[6].parse::<f64>().unwrap() < 1e-4,
            "wrist apart by {}",
            row[6]
        );
    }
}

/// Issue 46, point 4: two runs never write into one folder unasked. A
/// second run into an `--out` that holds a run is refused (exit 2, the
/// folder named) and leaves it as it was; `--overwrite` replaces it; the
/// default folder gives way to `NAME-2` beside it.
#[test]
fn a_second_run_into_an_occupied_folder_is_refused_or_gets_its_own() {
    let tmp = TempDir::new("occupied");
    let out = tmp.path().join("run");
    let o = out.to_str().unwrap();
    run_ok(&["run", "--steps", "20", "--quiet", "--out", o]);
    let before = std::fs::read(out.join("states.csv")).unwrap();
    let second = run(&["run", "--steps", "30", "--quiet", "--out", o]);
    assert_eq!(second.status.code(), Some(2));
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(err.contains(o) && err.contains("--overwrite"), "{err}");
    assert_eq!(std::fs::read(out.join("states.csv")).unwrap(), before);
    run_ok(&["run", "--steps", "30", "--quiet", "--out", o, "--overwrite"]);
    assert_ne!(std::fs::read(out.join("states.csv")).unwrap(), before);
    // The default folder, out/<scene>, from the working directory.
    for _ in 0..2 {
        let r = Command::new(BIN)
            .args(["run", "--steps", "20"])
            .current_dir(tmp.path())
            .output()
            .unwrap();
        assert!(r.status.success(), "{r:?}");
    }
    assert!(tmp.path().join("out/reference/summary.json").exists());
    assert!(tmp.path().join("out/reference-2/summary.json").exists());
}

/// A scene torque beyond its joint's `max_effort` is clamped and said:
/// the summary counts each clamped joint-step, the printed summary names
/// them, and the car on its rail moves as under the bound (2 N on 1 kg
/// for 0.1 s: 0.2 m/s, in the last row of states.csv).
#[test]
fn clamped_efforts_are_counted_and_said() {
    let dir = TempDir::new("cli-clamp");
    let scene = dir.path().join("clamp.toml");
    std::fs::write(
        &scene,
        r#"[sim]
dt = 0.001
steps = 100
gravity = [0.0, 0.0, -9.81]

[[body]]
name = "car"
radius = 0.05
mass = 1.0
position = [0.0, 0.0, 1.0]

[[joint]]
name = "rail"
type = "prismatic"
body_a = "world"
body_b = "car"
anchor = [0.0, 0.0, 1.0]
axis = [1.0, 0.0, 0.0]
force = [10.0, 0.0, 0.0]
max_effort = 2.0
"#,
    )
    .unwrap();
    let out_dir = dir.path().join("out");
    let out = run_ok(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let printed = String::from_utf8_lossy(&out.stdout);
    assert!(
        printed.contains("efforts      100 joint-steps clamped"),
        "{printed}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["clamped_efforts"], 100);
    let states = std::fs::read_to_string(out_dir.join("states.csv")).unwrap();
    let header: Vec<&str> = states.lines().next().unwrap().split(',').collect();
    let vx = header.iter().position(|h| *h == "vx").expect("a vx column");
    let last: f64 = states
        .lines()
        .last()
        .unwrap()
        .split(',')
        .nth(vx)
        .unwrap()
        .parse()
        .unwrap();
    assert!((last - 0.2).abs() < 1e-12, "v = {last}");
}

/// `integrator = "rattle4"` in a scene: steps.csv counts the island RATTLE
/// stepped every step (a pendulum swinging clear of the floor, beside a
/// sphere resting on it, which takes the step) and the summary's joint
/// error is round-off.
#[test]
fn a_rattle_scene_counts_its_smooth_islands() {
    let dir = TempDir::new("cli-rattle");
    let scene = dir.path().join("rattle.toml");
    // GOOD's pinned ball swings 0.3 m below its pin, 0.2 m clear of the
    // floor; the other sphere rests on the floor.
    let text = GOOD
        .replace("dt = 0.001\n", "dt = 0.001\nintegrator = \"rattle4\"\n")
        .replace("position = [0.0, 0.0, 0.3]", "position = [0.3, 0.0, 0.6]")
        .replace("position = [0.5, 0.0, 0.3]", "position = [2.0, 0.0, 0.1]");
    std::fs::write(&scene, text).unwrap();
    let out_dir = dir.path().join("out");
    run_ok(&[
        "run",
        scene.to_str().unwrap(),
        "--quiet",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let steps = std::fs::read_to_string(out_dir.join("steps.csv")).unwrap();
    let header: Vec<&str> = steps.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (smooth, left) = (col("smooth_islands"), col("smooth_left"));
    let mut rows = 0;
    for line in steps.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!((f[smooth], f[left]), ("1", "0"), "{line}");
        rows += 1;
    }
    assert_eq!(rows, 50);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    assert!(
        summary["max_joint_error"].as_f64().unwrap() < 1e-12,
        "{summary}"
    );
}
