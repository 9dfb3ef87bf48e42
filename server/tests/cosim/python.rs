//! The Python package: its controller and its numpy monitor.

use super::*;

/// The Python controller of examples/python, written from docs/protocol.md
/// with the official iceoryx2 package (.ci/run installs it).
#[test]
fn the_python_controller_joins_and_answers_every_step() {
    let (server, dir, name) = serve_test("python", &["--controllers", "1", "--steps", "1000"]);
    let text = python_controller(&["--name", &name, "--steps", "100000"]);
    // Steps 0..=999 are answered; state 1000 comes with the shutdown frame
    // right behind it, so it may be read or skipped.
    assert!(
        text.contains("server shut down; answered 1000 steps")
            || text.contains("server shut down; answered 1001 steps"),
        "{text}"
    );
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let s = summary(dir.path());
    assert_eq!(s["inputs_applied"], 1000, "{s}");
    assert_eq!(s["inputs_rejected"], serde_json::json!({}));
    assert_eq!(s["deadline_misses"], 0);
    // It read the frames right (it copies only the entries in use): the
    // elevation it printed for its last frame is the one in states.csv.
    let printed = printed_after(&text, "elevation ");
    let rows = positions(dir.path(), "upper");
    assert!(
        rows[999..]
            .iter()
            .any(|(_, x)| (elevation_deg(*x) - printed).abs() < 1e-3),
        "printed {printed}, states.csv {:?}",
        &rows[999..]
    );
}

/// Issue 16, point 9: the Python package's monitor reads the decimated
/// stream into numpy arrays that hold the server's states to the bit
/// (compared with states.csv), while the example controller, on the same
/// package, drives the lockstep.
#[test]
fn the_python_package_reads_numpy_states_to_the_bit() {
    use std::io::BufRead;
    let (server, dir, name) = serve_test(
        "pymon",
        &[
            "--controllers",
            "1",
            "--steps",
            "300",
            "--publish-every",
            "50",
        ],
    );
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python_monitor.py");
    let mut monitor = Proc(
        Command::new("python3")
            .arg(&script)
            .arg(&name)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("python3"),
    );
    let mut lines = std::io::BufReader::new(monitor.0.stdout.take().unwrap()).lines();
    assert_eq!(lines.next().map(|l| l.unwrap()), Some("ready".into()));
    python_controller(&["--name", &name, "--steps", "100000"]);
    let frames: Vec<serde_json::Value> = lines
        .map(|l| serde_json::from_str(&l.unwrap()).unwrap())
        .collect();
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let steps: Vec<u64> = frames.iter().map(|f| f["step"].as_u64().unwrap()).collect();
    assert_eq!(steps, [0, 50, 100, 150, 200, 250, 300], "{frames:?}");
    let text = std::fs::read_to_string(dir.path().join("states.csv")).unwrap();
    for f in &frames {
        assert_eq!(f["shape"], serde_json::json!([2, 3]));
        assert_eq!(f["joints"], serde_json::json!([2, 3]));
        assert_eq!(f["joint_positions"], serde_json::json!(["nan", "nan"]));
        assert_eq!(f["contact_fields"][4], "normal");
        let step = f["step"].as_u64().unwrap();
        let row: Vec<f64> = text
            .lines()
            .map(|l| l.split(',').collect::<Vec<_>>())
            .find(|c| c[0] == step.to_string() && c[2] == "lower")
            .map(|c| c[3..16].iter().map(|v| v.parse().unwrap()).collect())
            .unwrap();
        let got: Vec<f64> = ["position", "orientation", "angular_velocity"]
            .iter()
            .flat_map(|k| {
                f[*k]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_str().unwrap().parse::<f64>().unwrap())
            })
            .collect();
        let want: Vec<f64> = row[0..7].iter().chain(&row[10..13]).copied().collect();
        assert_eq!(got, want, "step {step}");
    }
}

/// The Python blocks of README.md and python/README.md, as a user pastes
/// them beside the serve command the README gives (issue 46, point 6): each
/// joins, answers every step until the server's end and, in the package's,
/// reads the scene's names and sends by name.
#[test]
fn the_readmes_python_runs_against_a_server() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for (k, readme) in ["README.md", "python/README.md"].iter().enumerate() {
        let text = std::fs::read_to_string(root.join(readme)).unwrap();
        let code = text
            .split("```python\n")
            .nth(1)
            .and_then(|s| s.split("```").next())
            .unwrap_or_else(|| panic!("{readme} has a python block"));
        assert!(code.contains("\"lab\""), "{readme}: the server name");
        let (server, dir, name) = serve_test(
            &format!("readme-py-{k}"),
            &["--controllers", "1", "--duration", "1"],
        );
        let code = code.replace("\"lab\"", &format!("{name:?}"));
        let out = Command::new("python3")
            .args(["-c", &code])
            .output()
            .unwrap();
        let printed = String::from_utf8_lossy(&out.stdout).into_owned()
            + &String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{readme}: {printed}");
        if readme.starts_with("python") {
            assert!(printed.contains("protocol 4"), "{printed}");
            assert!(
                printed.contains("joints ['shoulder', 'elbow']"),
                "{printed}"
            );
        }
        let (status, stderr) = server.finish();
        assert!(status.success(), "{stderr}");
        let s = summary(dir.path());
        assert_eq!(s["steps"], 1000, "{s}");
        assert_eq!(s["inputs_applied"], 1000, "{readme}: {s}");
        assert_eq!(s["inputs_rejected"], serde_json::json!({}), "{s}");
    }
}

/// The package's `Names.frame`: a named frame (`[[body.frame]]`, a
/// robot's merged link) is its body's index and its pose there; a body's
/// name is its own frame; an unknown name lists the frames there are.
#[test]
fn the_python_names_find_a_frame_by_name() {
    let code = r#"
from cosim.client import Names
n = Names({"body": [{"name": "base"}, {"name": "arm", "frame": [
    {"name": "hand", "position": [0.0, 0.0, 0.1], "orientation": [0.0, 1.0, 0.0, 0.0]}]}]})
assert n.frame("hand") == (1, [0.0, 0.0, 0.1], [0.0, 1.0, 0.0, 0.0]), n.frame("hand")
assert n.frame("base") == (0, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0])
try:
    n.frame("hnad")
    raise SystemExit("an unknown frame was found")
except KeyError as e:
    assert "'hand'" in str(e), e
print("ok")
"#;
    let out = Command::new("python3").args(["-c", code]).output().unwrap();
    let printed =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && printed.trim() == "ok", "{printed}");
}
