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

/// Boxes and capsules in a recording, read back by the reference reader:
/// a box drawn as a cube of its size, a capsule as a cylinder between two
/// balls, and a resting box's floor contacts as arrows at its four lower
/// corners (`collision::contact_point`), each contact on its own topic
/// (`slider/floor`, `slider/floor#k`).
#[test]
fn boxes_and_capsules_are_drawn_with_their_contacts_at_the_corners() {
    let tmp = TempDir::new("mcap-shapes");
    let out = tmp.path().join("run");
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/scenes/shapes.toml"
    );
    let status = Command::new(BIN)
        .args([
            "run", scene, "--steps", "2500", "--mcap", "--quiet", "--out",
        ])
        .arg(&out)
        .status()
        .expect("run");
    assert!(status.success());
    let step = 2500u64;
    let log_time = (step as f64 * 1e-3 * 1e9).round() as u64;
    let v = common::read_mcap(&out.join("recording.mcap"), log_time, "slider/floor");
    let floor_topics: Vec<&String> = v["topics"]
        .as_object()
        .unwrap()
        .keys()
        .filter(|t| t.starts_with("/forces/normal/slider/floor"))
        .collect();
    assert!(floor_topics.len() >= 2, "{floor_topics:?}");
    let entities = v["scene"].as_array().expect("a scene message at the step");
    let body = |id: &str| entities.iter().find(|e| e["id"] == id).unwrap();
    let cube = &body("body/slider")["cubes"][0];
    assert_eq!(
        (&cube["size"]["x"], &cube["size"]["y"], &cube["size"]["z"]),
        (&0.2.into(), &0.12.into(), &0.08.into())
    );
    let roller = body("body/roller");
    assert_eq!(roller["cylinders"][0]["size"]["z"], 0.24);
    assert_eq!(roller["cylinders"][0]["size"]["x"], 0.08);
    // Two end balls and the marker.
    assert_eq!(roller["spheres"].as_array().unwrap().len(), 3);

    // The slider's lower corners at that step, from states.csv.
    let states = std::fs::read_to_string(out.join("states.csv")).unwrap();
    let r: Vec<f64> = states
        .lines()
        .map(|l| l.split(',').collect::<Vec<_>>())
        .find(|c| c[0] == step.to_string() && c[2] == "slider")
        .map(|c| c[3..10].iter().map(|x| x.parse().unwrap()).collect())
        .expect("the slider's row");
    let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
        r[3], r[4], r[5], r[6],
    ));
    let x = nalgebra::Vector3::new(r[0], r[1], r[2]);
    let corners: Vec<nalgebra::Vector3<f64>> = [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]
        .iter()
        .map(|&(sx, sy)| x + q * nalgebra::Vector3::new(sx * 0.1, sy * 0.06, -0.04))
        .collect();
    let arrows = body("contacts")["arrows"].as_array().unwrap().clone();
    let at = |a: &serde_json::Value| {
        let p = &a["pose"]["position"];
        nalgebra::Vector3::new(
            p["x"].as_f64().unwrap(),
            p["y"].as_f64().unwrap(),
            p["z"].as_f64().unwrap(),
        )
    };
    let on_corners = arrows
        .iter()
        .filter(|a| corners.iter().any(|c| (at(a) - c).norm() < 1e-9))
        .count();
    // One arrow per slider/floor contact that pushed in that step (a
    // box's centre lies over both diagonals, so two corners may carry it
    // alone: Lemke's answer is a vertex of the indeterminate support).
    let impulses = std::fs::read_to_string(out.join("impulses.csv")).unwrap();
    let pushed = impulses
        .lines()
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[0] == step.to_string() && c[2] == "normal" && c[4] == "slider")
        .count();
    assert!(pushed >= 2, "{pushed} contacts hold the slider");
    assert_eq!(
        on_corners, pushed,
        "arrows at the slider's corners {corners:?}"
    );
}

/// A pose of a Foxglove message (position, orientation x y z w).
fn pose_of(v: &serde_json::Value) -> nalgebra::Isometry3<f64> {
    let n = |x: &serde_json::Value| x.as_f64().expect("a number");
    let (p, q) = (&v["position"], &v["orientation"]);
    nalgebra::Isometry3::from_parts(
        nalgebra::Translation3::new(n(&p["x"]), n(&p["y"]), n(&p["z"])),
        nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            n(&q["w"]),
            n(&q["x"]),
            n(&q["y"]),
            n(&q["z"]),
        )),
    )
}

/// The box bounding `points`: (lower corner, upper corner).
fn bounds(points: impl Iterator<Item = nalgebra::Point3<f64>>) -> ([f64; 3], [f64; 3]) {
    let mut b = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in points {
        for k in 0..3 {
            b.0[k] = b.0[k].min(p[k]);
            b.1[k] = b.1[k].max(p[k]);
        }
    }
    b
}

/// Issue 45, point 7: a robot's recording draws its visual meshes. The
/// Panda of example-robot-data (COLLADA visuals, STL collision meshes) run
/// with --mcap; read back with the `mcap` package: `/visuals` and
/// `/shapes` once, at the first state's time, each body's entity locked
/// to its frame; every embedded model is its URDF mesh file byte for byte
/// with COLLADA's media type; and, placed by the first `/tf` and its
/// entity's pose, each link's visual mesh (read by `mesh-loader`, not by
/// us) spans the same box as its collision hull to within 1 cm (the
/// Panda's collision meshes are coarse hulls of its visual ones: a visual
/// mesh left at the link's origin instead of its centre of mass would be
/// off by up to 8 cm).
#[test]
fn a_robots_recording_draws_its_visual_meshes_where_its_links_are() {
    let robots = common::robot_data();
    let urdf = robots.join("panda_description/urdf/panda.urdf");
    let tmp = TempDir::new("mcap-visuals");
    let out = tmp.path().join("run");
    let status = Command::new(BIN)
        .arg("run")
        .arg(&urdf)
        .args(["--floor", "--steps", "20", "--mcap", "--quiet", "--out"])
        .arg(&out)
        .status()
        .expect("cosim-server");
    assert!(status.success());
    let recording = out.join("recording.mcap");
    let v = common::python_json(
        "read_visuals.py",
        &[recording.as_os_str(), tmp.path().as_os_str()],
    );
    let scene = cosim_shared::Scene::load(&out.join("scene.toml")).expect("the run's scene");
    assert_eq!(v["counts"]["/visuals"], 1);
    assert_eq!(v["counts"]["/shapes"], 1);
    assert_eq!(v["counts"]["/scene"], 21);
    let tf_time = v["tf_time"].as_u64().expect("a /tf");
    let frames: std::collections::HashMap<String, nalgebra::Isometry3<f64>> = v["tf"]
        .as_array()
        .expect("transforms")
        .iter()
        .map(|t| {
            let pose =
                serde_json::json!({ "position": t["translation"], "orientation": t["rotation"] });
            (
                t["child_frame_id"].as_str().expect("a frame").to_string(),
                pose_of(&pose),
            )
        })
        .collect();
    let entities = |topic: &str| {
        assert_eq!(v["once"][topic]["log_time"].as_u64(), Some(tf_time));
        v["once"][topic]["entities"]
            .as_array()
            .expect("entities")
            .clone()
    };
    let visuals = entities("/visuals");
    let hulls = entities("/shapes");
    let mut compared = 0;
    let mut worst = (0.0f64, String::new());
    for e in &visuals {
        let body = e["frame_id"].as_str().expect("a frame id");
        assert_eq!(e["frame_locked"], true);
        let desc = scene
            .bodies
            .iter()
            .find(|b| b.name == body)
            .expect("a body of the scene");
        let models = e["models"].as_array().expect("models");
        assert_eq!(models.len(), desc.visual.len(), "{body}");
        let frame = frames[body];
        let mut points = Vec::new();
        for (m, want) in models.iter().zip(&desc.visual) {
            assert_eq!(m["media_type"], "model/vnd.collada+xml");
            let file = m["data"].as_str().expect("the decoded file");
            let sent = std::fs::read(file).expect("the decoded model");
            let original = std::fs::read(want.mesh.as_deref().expect("a mesh")).expect("the mesh");
            assert!(
                sent == original,
                "{body}: the embedded model is not its file"
            );
            let mesh = mesh_loader::Loader::default()
                .load(file)
                .expect("mesh-loader reads it");
            let at = frame * pose_of(&m["pose"]);
            let s = &m["scale"];
            let scale = [&s["x"], &s["y"], &s["z"]].map(|x| x.as_f64().expect("a number"));
            for mm in &mesh.meshes {
                points.extend(mm.vertices.iter().map(|p| {
                    at * nalgebra::Point3::new(
                        p[0] as f64 * scale[0],
                        p[1] as f64 * scale[1],
                        p[2] as f64 * scale[2],
                    )
                }));
            }
        }
        let Some(hull) = hulls.iter().find(|h| h["frame_id"] == body) else {
            continue;
        };
        let mut hull_points = Vec::new();
        for t in hull["triangles"].as_array().expect("triangles") {
            let at = frame * pose_of(&t["pose"]);
            for p in t["points"].as_array().expect("points") {
                let n = |k: &str| p[k].as_f64().expect("a number");
                hull_points.push(at * nalgebra::Point3::new(n("x"), n("y"), n("z")));
            }
        }
        let (a, b) = (bounds(points.into_iter()), bounds(hull_points.into_iter()));
        for k in 0..3 {
            for d in [(a.0[k] - b.0[k]).abs(), (a.1[k] - b.1[k]).abs()] {
                if d > worst.0 {
                    worst = (d, format!("{body} axis {k}"));
                }
            }
        }
        compared += 1;
    }
    eprintln!(
        "{compared} links compared; worst box difference {:.4} m ({})",
        worst.0, worst.1
    );
    assert!(compared >= 8, "{compared} links compared");
    assert!(worst.0 < 0.01, "{worst:?}");
    // The links merged into panda_link7 by fixed joints (link8, the hand)
    // are frames of it in /tf, by their names; the hand's frame is where
    // its visual mesh (at the link's origin in the URDF) is drawn.
    let parent = |name: &str| {
        v["tf"]
            .as_array()
            .expect("transforms")
            .iter()
            .find(|t| t["child_frame_id"] == name)
            .map(|t| t["parent_frame_id"].as_str().unwrap_or("").to_string())
    };
    assert_eq!(parent("panda_link8").as_deref(), Some("panda_link7"));
    assert_eq!(parent("panda_hand").as_deref(), Some("panda_link7"));
    let hand = frames["panda_link7"] * frames["panda_hand"];
    let drawn = visuals
        .iter()
        .find(|e| e["frame_id"] == "panda_link7")
        .and_then(|e| {
            e["models"].as_array()?.iter().find(|m| {
                m["data"].as_str().is_some_and(|f| {
                    std::fs::read(f).ok()
                        == std::fs::read(robots.join("panda_description/meshes/visual/hand.dae"))
                            .ok()
                })
            })
        })
        .map(|m| frames["panda_link7"] * pose_of(&m["pose"]))
        .expect("the hand's visual on panda_link7");
    let d = (hand.translation.vector - drawn.translation.vector).norm()
        + hand.rotation.angle_to(&drawn.rotation);
    assert!(d < 1e-12, "the hand's frame is {d} from its visual");
}
