//! Co-simulation end to end: real server processes, controllers in the
//! test process or in child processes, a unique server name per test, and
//! every process stopped when the test ends, passing or failing.

#[path = "../common/mod.rs"]
mod common;
mod controllers;
mod examples;
mod failures;
mod lockstep;
mod python;
mod recording;
mod servers;
mod view;

use common::TempDir;
use cosim_client::{
    ClientError, Connection, Controller, InputFrame, Monitor, WaitMode, REJECT_DUPLICATE,
    REJECT_NON_FINITE, REJECT_UNKNOWN_INDEX, STATUS_SHUTDOWN,
};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const EXE: &str = env!("CARGO_BIN_EXE_cosim-server");

/// A name no other test (or test run) uses.
fn unique(test: &str) -> String {
    format!("t-{test}-{}", std::process::id())
}

/// A child process killed and reaped when dropped.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A server process. Dropping it asks for a shutdown, then kills it if it
/// does not end, so a failing test leaves nothing running.
struct ServerProc {
    name: String,
    child: Option<Child>,
}

impl ServerProc {
    fn start(name: &str, out: &Path, extra: &[&str]) -> ServerProc {
        let mut s = ServerProc::spawn(name, out, extra);
        s.wait_ready();
        s
    }

    /// Starts the server without waiting for its services (a run that may
    /// end before a client could see it).
    /// Without `--steps` or `--duration` in `extra`, it serves until shut
    /// down (`--forever`), as the tests' clients expect, recording every
    /// step unless `extra` says otherwise.
    fn spawn(name: &str, out: &Path, extra: &[&str]) -> ServerProc {
        let bounded = extra.iter().any(|a| *a == "--steps" || *a == "--duration");
        let every = extra.contains(&"--record-every");
        let child = Command::new(EXE)
            .args(["serve", "--quiet", "--name", name, "--out"])
            .arg(out)
            .args(extra)
            .args((!bounded).then_some("--forever"))
            .args(
                (!every)
                    .then_some(["--record-every", "1"])
                    .into_iter()
                    .flatten(),
            )
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start cosim-server serve");
        ServerProc {
            name: name.into(),
            child: Some(child),
        }
    }

    /// Polls the control service until it answers (the server is up);
    /// a server that exits first fails the test with its stderr.
    fn wait_ready(&mut self) {
        let start = Instant::now();
        loop {
            if Connection::connect(&self.name)
                .and_then(|c| c.info())
                .is_ok()
            {
                return;
            }
            if let Some(child) = self.child.as_mut() {
                if let Ok(Some(status)) = child.try_wait() {
                    let mut stderr = String::new();
                    if let Some(mut e) = child.stderr.take() {
                        use std::io::Read;
                        let _ = e.read_to_string(&mut stderr);
                    }
                    panic!(
                        "server '{}' exited ({status}) before it came up: {stderr}",
                        self.name
                    );
                }
            }
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "server '{}' did not come up",
                self.name
            );
            std::thread::yield_now();
        }
    }

    /// Waits for the process to end; its exit status and stderr.
    fn finish(mut self) -> (std::process::ExitStatus, String) {
        let child = self.child.take().expect("child");
        let out = child.wait_with_output().expect("wait for the server");
        (
            out.status,
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    }
}

impl Drop for ServerProc {
    fn drop(&mut self) {
        let Some(mut child) = self.child.take() else {
            return;
        };
        if let Ok(c) = Connection::connect(&self.name) {
            let _ = c.shutdown();
        }
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(5) {
            if let Ok(Some(_)) = child.try_wait() {
                return;
            }
            std::thread::yield_now();
        }
        let _ = child.kill();
        let _ = child.wait();
    }
}

/// A temp folder, a unique name and a server writing into the folder.
fn serve_test(test: &str, extra: &[&str]) -> (ServerProc, TempDir, String) {
    let dir = TempDir::new(test);
    let name = unique(test);
    let server = ServerProc::start(&name, dir.path(), extra);
    (server, dir, name)
}

/// The upper sphere's positions of an offline run of the reference scene
/// (no server), with joint 0's torque set to `torque(k)` before step k
/// where it gives one.
fn offline(steps: u64, torque: impl Fn(u64) -> Option<[f64; 3]>) -> Vec<(u64, [f64; 3])> {
    use cosim_server::engine::{Engine, Model};
    let scene = cosim_shared::scenes::reference().unwrap();
    let mut e = Engine::new(Model::from_scene(&scene));
    let mut rows = vec![(0, e.state().bodies[0].x.into())];
    for k in 0..steps {
        if let Some(t) = torque(k) {
            e.set_joint_torque(0, t.into()).unwrap();
        }
        assert!(e.step().ok());
        rows.push((e.state().step, e.state().bodies[0].x.into()));
    }
    rows
}

fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("summary.json is JSON")
}

fn replay(dir: &Path) -> (bool, String) {
    let out = Command::new(EXE)
        .arg("replay")
        .arg(dir)
        .output()
        .expect("run replay");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr),
    )
}

/// Answers every state with `answer` until the server's last frame.
fn answer_until_shutdown(c: &mut Controller, mut answer: impl FnMut(&mut Controller)) {
    loop {
        match c.next_state(Duration::from_secs(10)) {
            Ok(_) => answer(c),
            Err(ClientError::Shutdown) => return,
            Err(e) => panic!("{e}"),
        }
    }
}

/// The rows of states.csv for one body: (step, x, y, z).
fn positions(dir: &Path, body: &str) -> Vec<(u64, [f64; 3])> {
    let text = std::fs::read_to_string(dir.join("states.csv")).expect("states.csv");
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (c[2] == body).then(|| {
                (
                    c[0].parse().unwrap(),
                    [
                        c[3].parse().unwrap(),
                        c[4].parse().unwrap(),
                        c[5].parse().unwrap(),
                    ],
                )
            })
        })
        .collect()
}

/// The elevation (deg) of the upper sphere at `x` above the reference
/// scene's shoulder at (0, 0, 0.45).
fn elevation_deg(x: [f64; 3]) -> f64 {
    let r = [x[0], x[1], x[2] - 0.45];
    (r[2] / (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt())
        .asin()
        .to_degrees()
}

/// Runs the Python controller of examples/python with `args`; its stdout
/// and stderr, after asserting that it succeeded.
fn python_controller(args: &[&str]) -> String {
    python_example("controller.py", args)
}

/// The shipped slider scene (a carriage on a prismatic rail with a
/// hinged pendulum).
const SLIDER: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../examples/scenes/slider.toml"
);

/// The number a controller printed after `label` (up to the next space).
fn printed_after(text: &str, label: &str) -> f64 {
    text.split(label)
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no {label:?} number in {text}"))
}

/// Runs `script` of examples/python with `args`; its stdout and stderr,
/// after asserting that it succeeded.
fn python_example(script: &str, args: &[&str]) -> String {
    let script = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples/python")
        .join(script);
    let out = Command::new("python3")
        .arg(&script)
        .args(args)
        .output()
        .expect("run python3");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    text
}

/// `serve` arguments for 3,000 steps of `scene` in lockstep with one
/// controller (a generous deadline: the test machine is shared).
fn three_seconds_with_one_controller(scene: &str) -> [&str; 7] {
    [
        scene,
        "--controllers",
        "1",
        "--steps",
        "3000",
        "--deadline-ms",
        "5000",
    ]
}

/// The shipped limits scene (its rail has a motor: joint 2).
const LIMITS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../examples/scenes/limits.toml"
);
