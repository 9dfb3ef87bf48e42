//! `run --mcap`: the recording read back with the format's reference
//! reader (the Python `mcap` package, which CI installs): channels,
//! schemas, message counts, and the values of one step against the run's
//! CSV files.

mod common;

use common::TempDir;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_cosim-server");

#[test]
fn a_recording_reads_back_with_the_reference_reader() {
    let tmp = TempDir::new("mcap");
    let out = tmp.path().join("run");
    let status = Command::new(BIN)
        .args(["run", "--steps", "700", "--mcap", "--quiet", "--out"])
        .arg(&out)
        .status()
        .expect("run");
    assert!(status.success());

    // The step of the lower sphere's floor contact with the largest
    // impulse, from impulses.csv.
    let csv = std::fs::read_to_string(out.join("impulses.csv")).unwrap();
    let (step, p) = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[2] == "normal" && c[3] == "lower/floor")
        .map(|c| {
            let p: Vec<f64> = c[6..9].iter().map(|v| v.parse().unwrap()).collect();
            (
                c[0].parse::<u64>().unwrap(),
                (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt(),
            )
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .expect("the lower sphere lands");
    let h = 1e-3;
    let log_time = (step as f64 * h * 1e9).round() as u64;
    let v = common::read_mcap(&out.join("recording.mcap"), log_time, "lower/floor");
    let topics = &v["topics"];
    for (topic, schema, count) in [
        ("/scene", "foxglove.SceneUpdate", 701),
        ("/tf", "foxglove.FrameTransforms", 701),
        ("/bodies/upper", "cosim.BodyState", 701),
        ("/bodies/lower", "cosim.BodyState", 701),
        ("/energy", "cosim.Energy", 700),
        ("/solver", "cosim.StepReport", 700),
    ] {
        let t = &topics[topic];
        assert_eq!(t["schema"], schema, "{topic}");
        assert_eq!(t["schema_encoding"], "jsonschema", "{topic}");
        assert_eq!(t["message_encoding"], "json", "{topic}");
        assert_eq!(t["messages"], count, "{topic}");
    }
    // One force message per step with an impulse.
    let rows = csv
        .lines()
        .filter(|l| l.contains(",normal,lower/floor,"))
        .count();
    assert_eq!(
        topics["/forces/normal/lower/floor"]["messages"],
        rows as u64
    );
    assert!(topics["/forces/joint/shoulder"]["messages"].as_u64() > Some(0));

    // The scene at that step: two bodies, three planes, two joints and the
    // contact arrows; the lower sphere's diameter; an arrow up from the floor.
    let entities = v["scene"].as_array().expect("a scene message at the step");
    let ids: Vec<&str> = entities.iter().map(|e| e["id"].as_str().unwrap()).collect();
    for id in [
        "body/upper",
        "body/lower",
        "plane/floor",
        "plane/wall_x",
        "plane/wall_y",
        "joint/shoulder",
        "joint/elbow",
        "contacts",
    ] {
        assert!(ids.contains(&id), "{id} missing from {ids:?}");
    }
    let lower = entities.iter().find(|e| e["id"] == "body/lower").unwrap();
    assert_eq!(lower["spheres"][0]["size"]["x"], 0.16);
    let arrows = entities.iter().find(|e| e["id"] == "contacts").unwrap()["arrows"]
        .as_array()
        .unwrap()
        .clone();
    let up = arrows
        .iter()
        .find(|a| a["pose"]["position"]["z"].as_f64().unwrap().abs() < 1e-9)
        .expect("an arrow at the floor");
    // Turned from +x to +z: a quarter turn about -y.
    let q = &up["pose"]["orientation"];
    assert!(
        (q["w"].as_f64().unwrap() - 0.5f64.sqrt()).abs() < 1e-6,
        "{q}"
    );
    assert!(
        (q["y"].as_f64().unwrap() + 0.5f64.sqrt()).abs() < 1e-6,
        "{q}"
    );
    // The force: the CSV's impulse over h (the CSV rounds nothing: same
    // number to 1e-12).
    let f = v["force"]["magnitude"].as_f64().expect("a force message");
    assert!((f - p / h).abs() <= 1e-9 * f, "{f} against {}", p / h);
}

/// A scene with a hinge and a slider: `/joints/NAME` per state, read back
/// by the reference reader, equal to joints.csv at a step to the bit (JSON
/// writes the shortest text that reads back the same).
#[test]
fn joint_coordinates_are_recorded_per_state() {
    let tmp = TempDir::new("mcap-joints");
    let out = tmp.path().join("run");
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/scenes/slider.toml"
    );
    let status = Command::new(BIN)
        .args(["run", scene, "--steps", "600", "--mcap", "--quiet", "--out"])
        .arg(&out)
        .status()
        .expect("run");
    assert!(status.success());
    let step = 450u64;
    let log_time = (step as f64 * 1e-3 * 1e9).round() as u64;
    let v = common::read_mcap(&out.join("recording.mcap"), log_time, "bob/ball");
    let csv = std::fs::read_to_string(out.join("joints.csv")).unwrap();
    for joint in ["rail", "pivot"] {
        let topic = format!("/joints/{joint}");
        assert_eq!(v["topics"][&topic]["schema"], "cosim.JointCoordinate");
        assert_eq!(v["topics"][&topic]["messages"], 601, "{topic}");
        let row: Vec<f64> = csv
            .lines()
            .map(|l| l.split(',').collect::<Vec<_>>())
            .find(|c| c[0] == step.to_string() && c[2] == joint)
            .map(|c| vec![c[4].parse().unwrap(), c[5].parse().unwrap()])
            .expect("the step's row");
        let msg = &v["joints"][&topic];
        assert_eq!(msg["position"].as_f64(), Some(row[0]), "{topic}: {msg}");
        assert_eq!(msg["rate"].as_f64(), Some(row[1]), "{topic}: {msg}");
    }
    // The pendulum has swung and the carriage has moved at that step.
    assert!(v["joints"]["/joints/rail"]["position"].as_f64() > Some(0.1));
}
