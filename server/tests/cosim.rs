//! Co-simulation end to end: real server processes, controllers in the
//! test process or in child processes, a unique server name per test, and
//! every process stopped when the test ends, passing or failing.

mod common;

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
    fn spawn(name: &str, out: &Path, extra: &[&str]) -> ServerProc {
        let child = Command::new(EXE)
            .args(["serve", "--quiet", "--name", name, "--out"])
            .arg(out)
            .args(extra)
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

#[test]
fn a_controller_answers_every_step_in_lockstep_and_the_run_replays_bit_for_bit() {
    let (server, dir, name) = serve_test("lockstep", &["--controllers", "1", "--steps", "300"]);
    let mut c = Controller::join(&name, WaitMode::Hybrid).expect("join");
    assert_eq!(c.info().body_count, 2);
    let mut seen = Vec::new();
    let mut frames = Vec::new();
    loop {
        let f = match c.next_state(Duration::from_secs(10)) {
            Ok(f) => f,
            Err(ClientError::Shutdown) => {
                // The final state comes only in the shutdown frame.
                let last = c.last_state().unwrap().clone();
                if seen.last() != Some(&last.step) {
                    seen.push(last.step);
                    frames.push(last.bodies[0].position);
                }
                break;
            }
            Err(e) => panic!("{e}"),
        };
        seen.push(f.step);
        frames.push(f.bodies[0].position);
        // A torque that changes every step: replay must see each one.
        let mut input = InputFrame::default();
        input.push_torque(0, [0.0, -0.2 * (f.step as f64 * 0.01).sin(), 0.0]);
        c.send(input).expect("send");
    }
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    // Lockstep: every state 0..=300 seen once, in order, none skipped.
    assert_eq!(seen, (0..=300).collect::<Vec<u64>>());
    // Inputs for 0..=299 applied; the final state asks for none.
    let s = summary(dir.path());
    assert_eq!(s["steps"], 300);
    assert_eq!(s["inputs_applied"], 300);
    assert_eq!(s["deadline_misses"], 0);
    assert_eq!(s["controllers_joined"], 1);
    assert!(s["round_trip_us"]["median"].as_f64().unwrap() > 0.0);
    // Most steps solved on the matrix made while the controller computed
    // (it is kept unless the new torque selects other contacts), and the
    // offline comparison below shows that changed no bit.
    assert!(s["early_matrix_steps"].as_u64().unwrap() >= 150, "{s}");
    // The frames carry the states the server wrote, to the bit.
    let rows = positions(dir.path(), "upper");
    assert_eq!(rows.len(), 301);
    for ((step, x), f) in rows.iter().zip(&frames) {
        assert_eq!(x, f, "step {step}");
    }
    let (ok, text) = replay(dir.path());
    assert!(ok && text.contains("300 steps"), "{text}");
    // The torque sent for step k acts in step k: an offline run fed the
    // same torques gives the same trajectory, bit for bit.
    let expected = offline(300, |k| Some([0.0, -0.2 * (k as f64 * 0.01).sin(), 0.0]));
    assert_eq!(rows, expected);
}

#[test]
fn a_replay_with_a_changed_input_names_the_first_differing_step() {
    let (server, dir, name) =
        serve_test("replay-differs", &["--controllers", "1", "--steps", "50"]);
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    while let Ok(f) = c.next_state(Duration::from_secs(10)) {
        let mut input = InputFrame::default();
        input.push_torque(1, [0.01 * f.step as f64, 0.0, 0.0]);
        c.send(input).expect("send");
    }
    assert!(server.finish().0.success());
    let path = dir.path().join("replay.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    // Change the torque given before step 20 (state 20 -> 21).
    let edited = text.replace("torque,20,1,0.2,", "torque,20,1,0.25,");
    assert_ne!(edited, text, "the log holds the torque of step 20");
    std::fs::write(&path, edited).unwrap();
    let (ok, text) = replay(dir.path());
    assert!(!ok);
    assert!(text.contains("differs at step 21"), "{text}");
}

#[test]
fn bad_inputs_are_rejected_by_reason_and_the_run_goes_on() {
    let (server, dir, name) = serve_test(
        "rejects",
        &[
            "--controllers",
            "1",
            "--steps",
            "40",
            "--deadline-ms",
            "5000",
        ],
    );
    let mut c = Controller::join(&name, WaitMode::Hybrid).expect("join");
    let mut rejected_seen = 0u32;
    loop {
        let f = match c.next_state(Duration::from_secs(10)) {
            Ok(f) => f,
            Err(ClientError::Shutdown) => break,
            Err(e) => panic!("{e}"),
        };
        if let Some(slot) = f.controller(c.id()) {
            rejected_seen |= slot.rejected;
        }
        let mut input = InputFrame::default();
        match f.step {
            5 => {
                input.push_torque(0, [f64::NAN, 0.0, 0.0]);
            }
            6 => {
                input.push_torque(7, [0.0; 3]);
            }
            7 => {
                // An answer to an old step first (rejected, not an
                // answer), then the right one.
                let mut stale = input.clone();
                stale.controller_id = c.id();
                stale.step = 3;
                stale.version = cosim_client::PROTOCOL_VERSION;
                c.send_raw(&stale).unwrap();
            }
            8 => {
                input.push_impulse(0, [0.0, 0.0, f64::INFINITY], [0.0; 3]);
            }
            9 => {
                input.push_torque(1, [0.1, 0.0, 0.0]);
                input.push_torque(1, [0.2, 0.0, 0.0]);
            }
            _ => {
                input.push_torque(0, [0.0, -0.1, 0.0]);
            }
        }
        c.send(input).expect("send");
    }
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let s = summary(dir.path());
    assert_eq!(s["steps"], 40, "the run went on");
    let r = &s["inputs_rejected"];
    assert_eq!(r["non_finite"], 2, "{s}");
    assert_eq!(r["unknown_index"], 1, "{s}");
    assert_eq!(r["wrong_step"], 1, "{s}");
    // A joint given twice in one input is a duplicate.
    assert_eq!(r["duplicate"], 1, "{s}");
    assert_eq!(s["inputs_applied"], 40 - 4);
    assert_eq!(
        s["deadline_misses"], 0,
        "a rejected answer is still an answer"
    );
    assert_eq!(
        rejected_seen & (REJECT_NON_FINITE | REJECT_UNKNOWN_INDEX | REJECT_DUPLICATE),
        REJECT_NON_FINITE | REJECT_UNKNOWN_INDEX | REJECT_DUPLICATE,
        "the state frames report the reasons back"
    );
    // Logged once per reason, not once per input.
    assert_eq!(stderr.matches("(non_finite)").count(), 1, "{stderr}");
    let log = std::fs::read_to_string(dir.path().join("inputs.csv")).unwrap();
    assert!(log.contains(",non_finite,"));
    assert!(log.contains(",wrong_step,"));
    // A rejected input keeps the values sent (issue 15, point 11).
    assert!(log.contains(",non_finite,torque,0,NaN,0,0,,,"), "{log}");
    assert!(log.contains(",unknown_index,torque,7,0,0,0,,,"), "{log}");
    assert!(log.contains(",non_finite,impulse,0,0,0,inf,0,0,0"), "{log}");
    assert!(log.contains(",duplicate,torque,1,0.1,0,0,,,"), "{log}");
    assert!(log.contains(",duplicate,torque,1,0.2,0,0,,,"), "{log}");
    // The rejected steps ran with the policy's input (hold: the last
    // torque, which is the scene's own -0.1 here): the trajectory is the
    // offline one with that torque throughout.
    assert_eq!(
        positions(dir.path(), "upper"),
        offline(40, |_| Some([0.0, -0.1, 0.0]))
    );
}

#[test]
fn a_killed_controller_is_dropped_the_run_goes_on_and_another_can_join() {
    let (server, dir, name) = serve_test(
        "killed",
        &[
            "--controllers",
            "1",
            "--deadline-ms",
            "300",
            "--drop-after",
            "50",
        ],
    );
    let monitor = Monitor::open(&name, 1).expect("monitor");
    let controller = Proc(
        Command::new(EXE)
            .args(["pd-controller", "--name", &name])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start the controller"),
    );
    let step_of = |min: u64| loop {
        let f = monitor.next(Duration::from_secs(10)).expect("frame");
        if f.step >= min {
            return f;
        }
    };
    let f = step_of(100);
    assert_eq!(f.controller_count, 1);
    // SIGKILL: no goodbye. Noticed by iceoryx2's node list (dead) while
    // the server waits, before the deadline (300 ms) and long before the
    // 50 misses of --drop-after.
    drop(controller);
    let start = Instant::now();
    loop {
        let f = monitor.next(Duration::from_secs(10)).expect("frame");
        if f.controller_count == 0 {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(10), "not dropped");
    }
    let after = step_of(0).step;
    let later = step_of(after + 100).step;
    assert!(later > after, "the run goes on without controllers");
    let mut c = Controller::join(&name, WaitMode::Block).expect("join again");
    for _ in 0..20 {
        let f = c.next_state(Duration::from_secs(10)).expect("state");
        c.send(InputFrame::default()).expect("send");
        assert_eq!(f.controller_count, 1);
    }
    c.leave().expect("leave");
    Connection::connect(&name).unwrap().shutdown().unwrap();
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    assert!(stderr.contains("exited without leaving"), "{stderr}");
    let s = summary(dir.path());
    assert_eq!(s["controllers_joined"], 2);
    assert_eq!(s["controllers_dropped"], 1);
    assert_eq!(s["controllers_departed"], 1);
    assert_eq!(s["deadline_misses"], 0);
    assert_eq!(s["failures"], 0);
}

#[test]
fn a_silent_controller_misses_under_the_policy_and_is_dropped() {
    let (server, dir, name) = serve_test(
        "silent",
        &[
            "--controllers",
            "1",
            "--deadline-ms",
            "300",
            "--drop-after",
            "3",
            "--on-miss",
            "zero",
            "--steps",
            "100",
        ],
    );
    // Joins, sets a torque once, then never answers again while alive.
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    let f = c.next_state(Duration::from_secs(10)).expect("state");
    assert_eq!(f.step, 0);
    let mut input = InputFrame::default();
    input.push_torque(0, [0.0, -0.5, 0.0]);
    c.send(input).unwrap();
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    assert!(
        stderr.contains("missed 3 deadlines in a row; dropped"),
        "{stderr}"
    );
    let s = summary(dir.path());
    assert_eq!(s["deadline_misses"], 3);
    assert_eq!(s["controllers_dropped"], 1);
    assert_eq!(s["steps"], 100);
    // --on-miss zero: the torque of steps 1 and 2 is zero; at the third
    // miss (step 3) the controller is dropped and the scene's own torque
    // applies again.
    let log = std::fs::read_to_string(dir.path().join("replay.csv")).unwrap();
    assert!(log.contains("torque,0,0,0,-0.5,0"), "{log:.300}");
    assert!(log.contains("torque,1,0,0,0,0"), "{log:.300}");
    assert!(log.contains("torque,3,0,0,-0.1,0"), "{log:.300}");
    drop(c);
}

#[test]
fn control_commands_pause_step_snapshot_restore_reset_and_replay() {
    let (server, dir, name) = serve_test("control", &[]);
    let conn = Connection::connect(&name).expect("connect");
    let paused = conn.pause().expect("pause");
    assert_eq!(paused.paused, 1);
    let a = conn.info().unwrap().step;
    let b = conn.info().unwrap().step;
    assert_eq!(a, b, "a paused server does not step");
    let stepped = conn.step(10).unwrap();
    assert_eq!(stepped.paused, 0);
    // `step 10` runs ten steps, then pauses again.
    let start = Instant::now();
    let after = loop {
        let i = conn.info().unwrap();
        if i.paused == 1 {
            break i.step;
        }
        assert!(start.elapsed() < Duration::from_secs(10));
    };
    assert_eq!(after, a + 10);
    let snap = conn.snapshot().unwrap();
    assert_eq!(snap.value, 1);
    conn.step(25).unwrap();
    while conn.info().unwrap().paused == 0 {}
    assert_eq!(conn.info().unwrap().step, a + 35);
    let restored = conn.restore(1).unwrap();
    assert_eq!(restored.step, a + 10);
    let bad = conn.restore(9);
    assert!(
        matches!(&bad, Err(ClientError::Refused { message, .. }) if message.contains("no snapshot 9")),
        "{bad:?}"
    );
    conn.step(5).unwrap();
    while conn.info().unwrap().paused == 0 {}
    assert_eq!(conn.info().unwrap().step, a + 15);
    let reset = conn.reset().unwrap();
    assert_eq!(reset.step, 0);
    conn.step(7).unwrap();
    while conn.info().unwrap().paused == 0 {}
    assert_eq!(conn.info().unwrap().step, 7);
    let toml = conn.scene_toml().unwrap();
    assert!(toml.contains("name = \"reference\""), "{toml}");
    conn.shutdown().unwrap();
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let (ok, text) = replay(dir.path());
    assert!(ok, "{text}");
}

#[test]
fn a_monitor_that_never_reads_does_not_block_the_server() {
    let (server, dir, name) =
        serve_test("stuck-monitor", &["--controllers", "1", "--steps", "3000"]);
    // Subscribed with a buffer of one and never read.
    let _stuck = Monitor::open(&name, 1).expect("monitor");
    let mut c = Controller::join(&name, WaitMode::Hybrid).expect("join");
    let mut n = 0;
    while let Ok(_f) = c.next_state(Duration::from_secs(10)) {
        c.send(InputFrame::default()).unwrap();
        n += 1;
    }
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    // States 0..=2999 are answered; 3000 may come only with the shutdown.
    assert!(n == 3000 || n == 3001, "{n}");
    assert_eq!(summary(dir.path())["steps"], 3000);
    // Nor the trajectory: the offline run without inputs.
    assert_eq!(positions(dir.path(), "upper"), offline(3000, |_| None));
}

#[test]
fn a_recording_matches_the_servers_own_files_and_plots() {
    let dir = TempDir::new("record");
    let rec = TempDir::new("record-out");
    let name = unique("record");
    let server = ServerProc::start(&name, dir.path(), &["--controllers", "1", "--steps", "400"]);
    let rec_path = rec.path().to_path_buf();
    let rname = name.clone();
    let recorder = std::thread::spawn(move || {
        cosim_client::cli::record(&rname, &rec_path, None, true).map_err(|e| e.to_string())
    });
    // The recorder writes scene.toml once subscribed: from then on it
    // receives every frame, so the controller may join.
    let start = Instant::now();
    while !rec.path().join("scene.toml").exists() {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "recorder did not start"
        );
        assert!(!recorder.is_finished(), "recorder ended early");
        std::thread::yield_now();
    }
    let mut c = Controller::join(&name, WaitMode::Hybrid).expect("join");
    while let Ok(_f) = c.next_state(Duration::from_secs(10)) {
        let mut input = InputFrame::default();
        input.push_torque(0, [0.0, -0.3, 0.0]);
        c.send(input).unwrap();
    }
    assert!(server.finish().0.success());
    let frames = recorder.join().unwrap().expect("record");
    assert!(frames >= 401, "{frames}");
    let ours = positions(dir.path(), "lower");
    let theirs = positions(rec.path(), "lower");
    assert_eq!(ours, theirs, "the recording holds the server's states");
    // joints.csv too, but for the errors the frames do not carry.
    let joints = |d: &Path| -> Vec<String> {
        let text = std::fs::read_to_string(d.join("joints.csv")).expect("joints.csv");
        text.lines()
            .map(|l| l.split(',').take(6).collect::<Vec<_>>().join(","))
            .collect()
    };
    let (served, recorded) = (joints(dir.path()), joints(rec.path()));
    assert!(served.len() > 2 * 400, "{} rows", served.len());
    assert_eq!(served, recorded, "the recording's joints.csv");
    recorded_mcap_reads_back(rec.path(), theirs.len());
    let figures = cosim_figures::render(
        rec.path(),
        &cosim_figures::PlotOptions {
            figures: true,
            ..Default::default()
        },
    )
    .expect("plot the recording");
    assert!(!figures.is_empty());
}

/// `cosim record --mcap`'s `recording.mcap` read back with the format's
/// reference reader (server/tests/read_mcap.py): a state message per
/// recorded step on each state channel, a force message per impulses.csv
/// row, and the hardest floor contact's force as impulse over h.
fn recorded_mcap_reads_back(dir: &Path, states: usize) {
    let csv = std::fs::read_to_string(dir.join("impulses.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .filter(|c: &Vec<&str>| c[2] == "normal" && c[3] == "lower/floor")
        .collect();
    let norm = |c: &[&str]| {
        let p: Vec<f64> = c[6..9].iter().map(|v| v.parse().unwrap()).collect();
        (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
    };
    let hardest = rows
        .iter()
        .max_by(|a, b| norm(a).total_cmp(&norm(b)))
        .expect("the lower sphere lands");
    let h = 1e-3;
    let log_time = (hardest[1].parse::<f64>().unwrap() * 1e9).round() as u64;
    let v = common::read_mcap(&dir.join("recording.mcap"), log_time, "lower/floor");
    let topics = &v["topics"];
    for (topic, schema) in [
        ("/scene", "foxglove.SceneUpdate"),
        ("/tf", "foxglove.FrameTransforms"),
        ("/bodies/lower", "cosim.BodyState"),
        ("/solver", "cosim.StepReport"),
    ] {
        let t = &topics[topic];
        assert_eq!(t["schema"], schema, "{topic}");
        assert_eq!(t["message_encoding"], "json", "{topic}");
        assert_eq!(t["messages"], states as u64, "{topic}");
    }
    assert_eq!(
        topics["/forces/normal/lower/floor"]["messages"],
        rows.len() as u64
    );
    let force = v["force"]["magnitude"]
        .as_f64()
        .expect("the force at that time");
    assert!(
        (force - norm(hardest) / h).abs() <= 1e-9 * force,
        "{force} against {} / h",
        norm(hardest)
    );
    let scene = v["scene"].as_array().expect("the scene at that time");
    assert!(scene.iter().any(|e| e["id"] == "body/lower"));
}

#[test]
fn a_second_server_of_the_same_name_is_refused() {
    let dir = TempDir::new("twice");
    let dir2 = TempDir::new("twice-2");
    let name = unique("twice");
    let first = ServerProc::start(&name, dir.path(), &[]);
    let out = Command::new(EXE)
        .args(["serve", "--quiet", "--name", &name, "--out"])
        .arg(dir2.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("a server named '{name}' is already running")),
        "{err}"
    );
    assert!(
        err.contains(&format!("pid {}", first.child.as_ref().unwrap().id())),
        "{err}"
    );
    // The first one is unharmed, and one of another name runs beside it.
    assert!(Connection::connect(&name).unwrap().info().is_ok());
    let (other, _dir3, other_name) = serve_test("twice-other", &[]);
    let a = Connection::connect(&name).unwrap().info().unwrap();
    let b = Connection::connect(&other_name).unwrap().info().unwrap();
    assert_ne!(a.pid, b.pid);
    drop(other);
}

#[test]
fn a_killed_server_leaves_nothing_that_blocks_its_name() {
    let (mut first, dir, name) = serve_test("stale", &[]);
    let mut child = first.child.take().unwrap();
    child.kill().unwrap(); // SIGKILL: no cleanup
    child.wait().unwrap();
    // The next server of that name removes the dead one's resources.
    let second = ServerProc::start(&name, dir.path(), &[]);
    Connection::connect(&name).unwrap().shutdown().unwrap();
    let (status, stderr) = second.finish();
    assert!(status.success(), "{stderr}");
}

/// Issue 15, defect 2: a killed server's services live on while a client
/// of it is attached; the next server of that name takes them over instead
/// of being refused as "already running".
#[test]
fn a_killed_servers_name_is_free_while_its_old_clients_live() {
    let (mut first, dir, name) = serve_test("stale-clients", &[]);
    let old_pid = first.child.as_ref().unwrap().id();
    let conn = Connection::connect(&name).expect("connect");
    let monitor = Monitor::open(&name, 4).expect("monitor");
    assert_eq!(conn.info().unwrap().pid, u64::from(old_pid));
    let mut child = first.child.take().unwrap();
    child.kill().unwrap(); // SIGKILL: the clients above stay attached
    child.wait().unwrap();
    let second = ServerProc::start(&name, dir.path(), &[]);
    let new_pid = u64::from(second.child.as_ref().unwrap().id());
    // The old clients talk to the new server on the same services.
    assert_eq!(conn.info().expect("info from the new server").pid, new_pid);
    monitor
        .next(Duration::from_secs(10))
        .expect("a frame of the new server");
    conn.shutdown().expect("shutdown");
    let (status, stderr) = second.finish();
    assert!(status.success(), "{stderr}");
    assert!(!stderr.contains("already running"), "{stderr}");
}

#[test]
fn sigint_and_sigterm_shut_down_cleanly_and_leave_no_services() {
    for signal in ["-INT", "-TERM"] {
        let dir = TempDir::new(&format!("signal{signal}"));
        let name = unique(&format!("signal{signal}"));
        let server = ServerProc::start(&name, dir.path(), &[]);
        let pid = server.child.as_ref().unwrap().id().to_string();
        assert!(Command::new("kill")
            .args([signal, &pid])
            .status()
            .unwrap()
            .success());
        let (status, stderr) = server.finish();
        assert!(status.success(), "{signal}: {stderr}");
        let s = summary(dir.path());
        assert_eq!(s["ending"], "signal");
        assert!(
            !cosim_client::list_servers().unwrap().contains(&name),
            "{signal}: the services are gone"
        );
        assert!(matches!(
            Connection::connect(&name),
            Err(ClientError::NoServer { .. })
        ));
        // The files written so far are complete and readable.
        let rows = positions(dir.path(), "upper");
        assert_eq!(rows.len() as u64, s["steps"].as_u64().unwrap() + 1);
    }
}

#[test]
fn the_demo_holds_the_pendulum_at_its_target() {
    let dir = TempDir::new("demo");
    let out = Command::new(EXE)
        .args(["demo", "--duration", "3", "--elevation", "15", "--out"])
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
    assert_eq!(rows.len(), 3001);
    for (step, x) in &rows[2000..] {
        let e = elevation_deg(*x);
        assert!((e - 15.0).abs() < 0.5, "step {step}: elevation {e}");
    }
    let s = summary(dir.path());
    assert_eq!(s["deadline_misses"], 0);
    assert_eq!(s["steps"], 3000);
    let _ = STATUS_SHUTDOWN;
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

#[test]
fn on_miss_abort_stops_the_run_and_keeps_its_files() {
    let (server, dir, name) = serve_test(
        "abort",
        &[
            "--controllers",
            "1",
            "--deadline-ms",
            "500",
            "--on-miss",
            "abort",
        ],
    );
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    for _ in 0..10 {
        c.next_state(Duration::from_secs(10)).unwrap();
        c.send(InputFrame::default()).unwrap();
    }
    // Then silence: the next deadline ends the run.
    let (status, stderr) = server.finish();
    assert_eq!(status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("aborting (--on-miss abort)"), "{stderr}");
    let s = summary(dir.path());
    assert_eq!(s["ending"], "aborted");
    assert_eq!(s["steps"], 10);
    assert_eq!(positions(dir.path(), "upper").len(), 11);
    drop(c);
}

#[test]
fn on_miss_pause_waits_for_resume_and_the_late_answer_counts() {
    let (server, dir, name) = serve_test(
        "pause",
        &[
            "--controllers",
            "1",
            "--deadline-ms",
            "500",
            "--on-miss",
            "pause",
            "--drop-after",
            "100",
            "--steps",
            "20",
        ],
    );
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    let conn = Connection::connect(&name).unwrap();
    let f = c.next_state(Duration::from_secs(10)).unwrap();
    assert_eq!(f.step, 0);
    // Silent past the deadline: the server pauses at step 0.
    let start = Instant::now();
    while conn.info().unwrap().paused == 0 {
        assert!(start.elapsed() < Duration::from_secs(10), "not paused");
    }
    assert_eq!(conn.info().unwrap().step, 0);
    // The late answer to step 0, then resume: the run completes.
    c.send(InputFrame::default()).unwrap();
    conn.resume().unwrap();
    answer_until_shutdown(&mut c, |c| c.send(InputFrame::default()).unwrap());
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let s = summary(dir.path());
    assert_eq!(s["steps"], 20);
    assert!(s["deadline_misses"].as_u64().unwrap() >= 1);
    assert_eq!(s["controllers_dropped"], 0);
}

#[test]
fn realtime_paces_the_run_and_list_finds_the_server() {
    let dir = TempDir::new("realtime");
    let name = unique("realtime");
    // 300 steps of 1 ms at twice real time: at least 0.15 s of wall time.
    let server = ServerProc::start(&name, dir.path(), &["--realtime", "2", "--steps", "300"]);
    let listed = cosim_client::list_servers().unwrap();
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let s = summary(dir.path());
    assert_eq!(s["steps"], 300);
    assert!(s["wall_seconds"].as_f64().unwrap() >= 0.15, "{s}");
    // Listed while it ran (it cannot have finished before: >= 0.15 s).
    assert!(listed.contains(&name), "{listed:?}");
}

#[test]
fn the_torque_player_applies_each_row_at_its_step() {
    let dir = TempDir::new("play");
    let name = unique("play");
    let file = dir.path().join("torques.csv");
    std::fs::write(
        &file,
        "step,joint,tx,ty,tz\n0,0,0,-0.25,0\n5,1,0.125,0,0\n12,0,0,0.5,0\n",
    )
    .unwrap();
    let out = dir.path().join("run");
    let server = ServerProc::start(&name, &out, &["--controllers", "1", "--steps", "30"]);
    let answered = cosim_client::cli::play(&name, &file, WaitMode::Block, Duration::from_secs(10))
        .map_err(|e| e.to_string())
        .expect("play");
    assert_eq!(answered, 13, "steps 0..=12 answered, then it leaves");
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let log = std::fs::read_to_string(out.join("replay.csv")).unwrap();
    for row in [
        "torque,0,0,0,-0.25,0",
        "torque,5,1,0.125,0,0",
        "torque,12,0,0,0.5,0",
    ] {
        assert!(log.contains(row), "{row} not in {log:.400}");
    }
    // After it left, the scene's own torque is back on the shoulder.
    assert!(log.contains("torque,13,0,0,-0.1,0"), "{log:.600}");
}

#[test]
fn spinning_server_and_controller_skip_the_events_and_stay_in_lockstep() {
    let (server, dir, name) = serve_test(
        "spin",
        &["--controllers", "1", "--steps", "200", "--wait", "spin"],
    );
    let mut c = Controller::join(&name, WaitMode::Spin).expect("join");
    let mut spins_flag = true;
    let mut n = 0;
    while let Ok(f) = c.next_state(Duration::from_secs(10)) {
        spins_flag &= f.status & cosim_client::STATUS_SERVER_SPINS != 0;
        c.send(InputFrame::default()).unwrap();
        n += 1;
    }
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    assert!(spins_flag, "every frame says the server spins");
    assert!(n >= 200, "{n}");
    let s = summary(dir.path());
    assert_eq!(s["steps"], 200);
    assert_eq!(s["deadline_misses"], 0);
    assert_eq!(s["wait"], "spin");
}

/// A ball pressed into a 90 degree corner of two walls and a floor with
/// mu = 1, overlapping each by 0.05 mm (under the projection's slop): the
/// stabilisation asks it to leave both walls, and friction at each wall
/// locks the motion out of the other. The rigid LCP has no solution.
fn locked_corner() -> String {
    use cosim_bench::text::{plane, sphere};
    let mut s = "[sim]\nname = \"locked_corner\"\ndt = 0.001\nsteps = 50\n\
                 gravity = [0.0, 0.0, -9.81]\nfriction_directions = 8\nsolver = \"lemke\"\n"
        .to_string();
    s += &sphere("ball", 0.1, 1.0, [0.09995; 3], [0.0; 3], 1.0, 0.0);
    for (name, n) in [
        ("wall_x", [1.0, 0.0, 0.0]),
        ("wall_y", [0.0, 1.0, 0.0]),
        ("floor", [0.0, 0.0, 1.0]),
    ] {
        s += &plane(name, n, [0.0; 3], 1.0, 0.0);
    }
    s
}

/// The locked corner served with `--on-failure POLICY` (and `extra`).
fn serve_locked(
    test: &str,
    policy: &str,
    extra: &[&str],
) -> (ServerProc, TempDir, TempDir, String) {
    let scene_dir = TempDir::new(&format!("{test}-scene"));
    let scene = scene_dir.path().join("locked_corner.toml");
    std::fs::write(&scene, locked_corner()).expect("scene file");
    let scene = scene.display().to_string();
    let mut args = vec![scene.as_str(), "--on-failure", policy];
    args.extend_from_slice(extra);
    // Not waited for: a run that aborts may be gone before its services
    // could be seen.
    let dir = TempDir::new(test);
    let name = unique(test);
    let server = ServerProc::spawn(&name, dir.path(), &args);
    (server, dir, scene_dir, name)
}

/// The default policy: every step of the locked corner falls back to the
/// relaxed formulation, says so in steps.csv and summary.json, and the run
/// reaches its end.
#[test]
fn on_failure_continue_steps_on_with_the_fallback_and_counts_it() {
    let (server, dir, _scene, _name) =
        serve_locked("fail-continue", "continue", &["--steps", "50"]);
    let (status, stderr) = server.finish();
    assert_eq!(status.code(), Some(0), "{stderr}");
    let s = summary(dir.path());
    assert_eq!(s["ending"], "steps");
    assert_eq!(
        (s["steps"].as_u64(), s["failures"].as_u64()),
        (Some(50), Some(0))
    );
    assert_eq!(s["fallback_steps"], 50, "{s}");
    assert_eq!(s["ladder"]["relaxed"], 50, "{s}");
    let steps = std::fs::read_to_string(dir.path().join("steps.csv")).unwrap();
    assert_eq!(
        steps.lines().filter(|l| l.contains(",relaxed,")).count(),
        50
    );
}

/// `--on-failure abort`: rigid answers only; the first step fails, the run
/// stops with exit code 1 and keeps its files.
#[test]
fn on_failure_abort_stops_at_the_first_failed_step() {
    let (server, dir, _scene, _name) = serve_locked("fail-abort", "abort", &["--steps", "50"]);
    let (status, stderr) = server.finish();
    assert_eq!(status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("--on-failure abort: stopping"), "{stderr}");
    // Issue 15: a stderr that is not a terminal gets no colour codes.
    assert!(!stderr.contains('\u{1b}'), "ANSI codes in {stderr:?}");
    let s = summary(dir.path());
    assert_eq!(s["ending"], "failed");
    assert_eq!(
        (s["steps"].as_u64(), s["failures"].as_u64()),
        (Some(0), Some(1))
    );
    assert_eq!(
        positions(dir.path(), "ball").len(),
        1,
        "only the initial state"
    );
}

/// `--on-failure pause`: the failed step is tried once, the run pauses at
/// the state before it and never re-runs it in a loop; `step 1` tries it
/// once more. Counted once per attempt, logged once per attempt.
#[test]
fn on_failure_pause_tries_a_failed_step_once_and_waits() {
    let (mut server, dir, _scene, name) = serve_locked("fail-pause", "pause", &["--steps", "50"]);
    server.wait_ready();
    let c = Connection::connect(&name).expect("connect");
    let start = Instant::now();
    while c.info().expect("info").paused == 0 {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "the server never paused"
        );
        std::thread::yield_now();
    }
    let info = c.info().expect("info");
    assert_eq!(info.step, 0, "the state did not advance");
    // Many requests later, still the one attempt: the loop is not running.
    for _ in 0..200 {
        assert_eq!(c.info().expect("info").step, 0);
    }
    // `step 1`: one more attempt, which fails the same way and pauses.
    c.step(1).expect("step");
    let start = Instant::now();
    while c.info().expect("info").paused == 0 {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "the server did not pause again"
        );
        std::thread::yield_now();
    }
    c.shutdown().expect("shutdown");
    let (status, stderr) = server.finish();
    assert_eq!(status.code(), Some(1), "failures exit with 1: {stderr}");
    assert!(
        stderr.matches("--on-failure pause").count() <= 2,
        "{stderr}"
    );
    let s = summary(dir.path());
    assert_eq!(s["steps"], 0);
    let failures = s["failures"].as_u64().unwrap();
    assert!((1..=2).contains(&failures), "{s}");
    let rows = std::fs::read_to_string(dir.path().join("steps.csv")).unwrap();
    assert_eq!(
        rows.lines().count() - 1,
        failures as usize,
        "one row per attempt"
    );
}

/// Issue 15, defect 1: a second server of a taken name, pointed at the
/// first one's folder with another scene, is refused before it writes a
/// file there: the first run's recording stays its own and replays.
#[test]
fn a_refused_server_leaves_the_first_ones_recording_alone() {
    let (first, dir, name) =
        serve_test("refused-files", &["--steps", "2000000", "--realtime", "1"]);
    let scene_before = std::fs::read_to_string(dir.path().join("scene.toml")).unwrap();
    let out = Command::new(EXE)
        .args([
            "serve", "--quiet", "--name", &name, "--dt", "0.002", "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("scene.toml")).unwrap(),
        scene_before,
        "the refused server rewrote the first one's scene.toml"
    );
    Connection::connect(&name).unwrap().shutdown().unwrap();
    let (status, stderr) = first.finish();
    assert!(status.success(), "{stderr}");
    let (ok, text) = replay(dir.path());
    assert!(ok, "{text}");
}

/// Issue 15, defect 7: the final state went out twice, first without the
/// last-frame bit, and a controller's answer to that first copy was
/// dropped uncounted. Now a monitor that reads every frame sees the final
/// step once, with the bit, and every answer the controller sent is
/// accounted for in summary.json.
#[test]
fn the_final_state_is_published_once_with_the_last_bit() {
    let (server, dir, name) = serve_test("final-once", &["--controllers", "1", "--steps", "50"]);
    let monitor = Monitor::open(&name, 1024).expect("monitor");
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    let mut sent = 0u64;
    answer_until_shutdown(&mut c, |c| {
        c.send(InputFrame::default()).expect("send");
        sent += 1;
    });
    let mut finals = Vec::new();
    loop {
        let f = monitor.next(Duration::from_secs(10)).expect("frame");
        if f.step == 50 {
            finals.push(f.status & STATUS_SHUTDOWN != 0);
        }
        if f.status & STATUS_SHUTDOWN != 0 {
            break;
        }
    }
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    assert_eq!(
        finals,
        vec![true],
        "the final step's frames (last bit set?)"
    );
    let s = summary(dir.path());
    let rejected: u64 = s["inputs_rejected"]
        .as_object()
        .map_or(0, |m| m.values().filter_map(|v| v.as_u64()).sum());
    assert_eq!(sent, 50, "one answer per step taken");
    assert_eq!(
        s["inputs_applied"].as_u64().unwrap() + rejected,
        sent,
        "{s}"
    );
}

/// Issue 15, defect 3: the round trip is timed from the publish. Paced at
/// real time, the server publishes a state and then waits for the next
/// step's due time, while the controller computes (0.3 ms here) and
/// answers; the old timer started after that wait and read a few us.
#[test]
fn the_round_trip_is_timed_from_the_publish() {
    let (server, dir, name) = serve_test(
        "round-trip",
        &["--controllers", "1", "--steps", "40", "--realtime", "1"],
    );
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    answer_until_shutdown(&mut c, |c| {
        // The controller's compute: 0.3 ms of work.
        let start = Instant::now();
        while start.elapsed() < Duration::from_micros(300) {
            std::hint::spin_loop();
        }
        c.send(InputFrame::default()).expect("send");
    });
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let s = summary(dir.path());
    let median = s["round_trip_us"]["median"].as_f64().unwrap();
    eprintln!("round trip median {median} us; wall {}", s["wall_seconds"]);
    assert!(
        median >= 300.0,
        "round trip median {median} us with 0.3 ms of compute"
    );
}

/// Issue 15, point 11: `wall_seconds` holds the wait for the controllers
/// to join; `stepping_seconds` is the loop's own time, and the printed
/// rate is taken over it. The controller joins 0.3 s after the server is
/// up; 50 steps take far less.
#[test]
fn the_summary_tells_the_stepping_from_the_wait_for_controllers() {
    let (server, dir, name) = serve_test("stepping", &["--controllers", "1", "--steps", "50"]);
    let start = Instant::now();
    while start.elapsed() < Duration::from_millis(300) {
        std::hint::spin_loop();
    }
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    answer_until_shutdown(&mut c, |c| c.send(InputFrame::default()).expect("send"));
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let s = summary(dir.path());
    let wall = s["wall_seconds"].as_f64().unwrap();
    let stepping = s["stepping_seconds"].as_f64().unwrap();
    assert!(wall >= 0.3, "{s}");
    assert!(stepping < wall - 0.25, "stepping {stepping} s of {wall} s");
}

/// Issue 15, point 9: a monitor that joins (role 2) gets an id of its own,
/// is counted in monitor_count, and leaves with that id; a controller's
/// ids are not taken by it.
#[test]
fn a_monitor_joins_with_an_id_and_leaves_with_it() {
    use cosim_shared::wire::{ControlRequest, CMD_JOIN, CMD_LEAVE, ROLE_MONITOR};
    let (server, _dir, name) =
        serve_test("monitor-join", &["--steps", "2000000", "--realtime", "1"]);
    let conn = Connection::connect(&name).expect("connect");
    let joined = conn
        .request(
            ControlRequest {
                command: CMD_JOIN,
                role: ROLE_MONITOR,
                ..Default::default()
            },
            Duration::from_secs(5),
        )
        .expect("monitor join");
    assert_ne!(joined.controller_id, 0, "a monitor's id");
    assert_eq!(conn.info().unwrap().monitor_count, 1);
    let c = Controller::join(&name, WaitMode::Block).expect("controller join");
    assert_ne!(c.id(), joined.controller_id);
    conn.request(
        ControlRequest {
            command: CMD_LEAVE,
            controller_id: joined.controller_id,
            ..Default::default()
        },
        Duration::from_secs(5),
    )
    .expect("monitor leave");
    assert_eq!(conn.info().unwrap().monitor_count, 0);
    drop(c);
    drop(server);
}

/// Issue 15, defect 8: a second answer to a step is a duplicate whether the
/// server reads it in the same wait or in the next step's (with one
/// controller it is read in the next one's, and counted as a wrong step
/// before). Every step answered twice: 30 duplicates, no wrong step.
#[test]
fn a_second_answer_is_a_duplicate_whenever_it_is_read() {
    let (server, dir, name) = serve_test("second-answer", &["--controllers", "1", "--steps", "30"]);
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    answer_until_shutdown(&mut c, |c| {
        c.send(InputFrame::default()).expect("send");
        // The same answer again, as a confused client would.
        let again = InputFrame {
            controller_id: c.id(),
            step: c.last_state().unwrap().step,
            version: cosim_client::PROTOCOL_VERSION,
            ..Default::default()
        };
        c.send_raw(&again).expect("send again");
    });
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let s = summary(dir.path());
    let r = &s["inputs_rejected"];
    assert_eq!(s["inputs_applied"], 30, "{s}");
    assert!(r.get("wrong_step").is_none(), "{s}");
    // The last step's second answer may come after the run ended.
    let late = r.get("after_end").and_then(|v| v.as_u64()).unwrap_or(0);
    assert_eq!(r["duplicate"].as_u64().unwrap() + late, 30, "{s}");
}

/// Issue 15, defect 4: an input is taken only from the publisher of the
/// process that joined as its controller. A process that never joined
/// sends as controller 1 before each of controller 1's own answers: every
/// one of its inputs is rejected as `foreign_sender`, and the trajectory is
/// the one of controller 1's torques alone (before the fix, about half of
/// the intruder's inputs were applied).
#[test]
fn an_input_from_a_process_that_did_not_join_is_rejected() {
    use iceoryx2::prelude::*;
    let steps = 40u64;
    let (server, dir, name) = serve_test(
        "foreign",
        &[
            "--controllers",
            "1",
            "--steps",
            &steps.to_string(),
            "--deadline-ms",
            "5000",
        ],
    );
    // The intruder's publisher first: the server's subscriber reads the
    // publishers in the order they connected, so its inputs come first.
    let node = NodeBuilder::new().create::<ipc::Service>().unwrap();
    let service: ServiceName = cosim_shared::wire::services::input(&name)
        .as_str()
        .try_into()
        .unwrap();
    let intruder = node
        .service_builder(&service)
        .publish_subscribe::<[u64]>()
        .user_header::<cosim_shared::wire::InputHeader>()
        .open()
        .unwrap()
        .publisher_builder()
        .initial_max_slice_len(64)
        .create()
        .unwrap();
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    let mut sent = 0u64;
    answer_until_shutdown(&mut c, |c| {
        let step = c.last_state().unwrap().step;
        let mut forged = InputFrame {
            controller_id: c.id(),
            step,
            ..Default::default()
        };
        forged.push_torque(0, [0.0, 5.0, 0.0]);
        cosim_shared::wire::send_words(&intruder, forged.header(), forged.words(), |w| {
            forged.encode(w)
        })
        .unwrap();
        sent += 1;
        let mut own = InputFrame::default();
        own.push_torque(0, [0.0, 0.2, 0.0]);
        c.send(own).unwrap();
    });
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let s = summary(dir.path());
    assert!(stderr.contains("did not join"), "{stderr} {s}");
    assert_eq!(sent, steps);
    assert_eq!(s["inputs_rejected"]["foreign_sender"], steps, "{s}");
    assert_eq!(s["inputs_applied"], steps, "{s}");
    assert_eq!(
        positions(dir.path(), "upper"),
        offline(steps, |_| Some([0.0, 0.2, 0.0]))
    );
    let log = std::fs::read_to_string(dir.path().join("inputs.csv")).unwrap();
    assert_eq!(log.matches(",foreign_sender").count() as u64, steps);
}

/// Issue 15, defect 5: a controller process that ends without `leave`
/// (here the Python controller with `os._exit`, which skips every
/// cleanup) is noticed by its dead node while the server waits, and the
/// run goes on at once: before the fix it waited the whole deadline (10 s
/// here), counted a miss, and only then found the node dead.
#[test]
fn a_controller_that_exits_without_leaving_is_noticed_before_its_deadline() {
    let (server, dir, name) = serve_test(
        "exit-no-leave",
        &[
            "--controllers",
            "1",
            "--steps",
            "300",
            "--deadline-ms",
            "10000",
        ],
    );
    let text = python_controller(&["--name", &name, "--exit-without-leave", "50"]);
    assert!(text.contains("exiting without leave"), "{text}");
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    assert!(
        stderr.contains("exited without leaving at step 50"),
        "{stderr}"
    );
    let s = summary(dir.path());
    assert_eq!(s["deadline_misses"], 0, "{s}");
    assert_eq!(s["controllers_departed"], 1, "{s}");
    assert_eq!(s["controllers_dropped"], 1, "{s}");
    assert_eq!(s["inputs_applied"], 50, "{s}");
    assert_eq!(s["steps"], 300, "{s}");
}

/// Issue 15, defect 5: a Rust controller dropped without `leave` leaves.
#[test]
fn a_dropped_controller_leaves() {
    let (server, dir, name) = serve_test(
        "drop-leaves",
        &[
            "--controllers",
            "1",
            "--steps",
            "100",
            "--deadline-ms",
            "10000",
        ],
    );
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    for _ in 0..20 {
        c.next_state(Duration::from_secs(10)).expect("state");
        c.send(InputFrame::default()).expect("send");
    }
    drop(c);
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    // A leave, not a drop: the server was told, nothing was noticed late.
    let s = summary(dir.path());
    assert_eq!(s["deadline_misses"], 0, "{s}");
    assert_eq!(s["controllers_dropped"], 0, "{s}");
    assert_eq!(s["inputs_applied"], 20, "{s}");
}

/// Issue 15, point 11: a client waiting on a server that is killed gets
/// `ServerGone` within `SERVER_CHECK`-ish time, not a timeout (30 s here).
#[test]
fn a_killed_servers_clients_are_told_it_is_gone() {
    let (mut server, _dir, name) = serve_test("gone", &["--controllers", "1"]);
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    c.next_state(Duration::from_secs(10)).expect("state");
    c.send(InputFrame::default()).expect("send");
    c.next_state(Duration::from_secs(10)).expect("state");
    let conn = Connection::connect(&name).expect("connect");
    let mut child = server.child.take().unwrap();
    child.kill().unwrap(); // SIGKILL: its ports stay behind a dead node
    child.wait().unwrap();
    // The controller owes step 1's answer and waits for step 2's frame.
    c.send(InputFrame::default()).expect("send");
    match c.next_state(Duration::from_secs(30)) {
        Err(ClientError::ServerGone { name: n }) => assert_eq!(n, name),
        other => panic!("expected ServerGone, got {other:?}"),
    }
    match conn.info() {
        Err(ClientError::ServerGone { .. }) => {}
        other => panic!("expected ServerGone, got {other:?}"),
    }
}

/// Issue 15, defect 10: a killed server leaves logs that end in a line cut
/// off mid-write, and no summary.json. `replay` replays the complete steps
/// and says where the log ends; `summarize` rebuilds a summary from the
/// files. Before the fix, replay failed on the cut line.
#[test]
fn a_killed_servers_logs_replay_to_the_cut_and_summarize_rebuilds_a_summary() {
    let (mut server, dir, name) = serve_test("killed-logs", &["--controllers", "1"]);
    let mut c = Controller::join(&name, WaitMode::Hybrid).expect("join");
    // Past two of the server's flushes (every 1000 steps).
    for _ in 0..2500 {
        let f = c.next_state(Duration::from_secs(10)).expect("state");
        let mut input = InputFrame::default();
        input.push_torque(0, [0.0, -0.2 * (f.step as f64 * 0.01).sin(), 0.0]);
        c.send(input).expect("send");
    }
    let mut child = server.child.take().unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
    drop(c);
    assert!(!dir.path().join("summary.json").exists());
    // A kill during a write cuts a row anywhere; cut each log inside its
    // last row so that the test does not depend on where the kill fell.
    for file in ["replay.csv", "inputs.csv", "steps.csv"] {
        let path = dir.path().join(file);
        let text = std::fs::read_to_string(&path).unwrap();
        let cut = text.trim_end_matches('\n').len() - 5;
        std::fs::write(&path, &text[..cut]).unwrap();
    }
    let (ok, text) = replay(dir.path());
    assert!(ok, "{text}");
    assert!(text.contains("every state identical"), "{text}");
    assert!(text.contains("cut off at line"), "{text}");
    assert!(text.contains("no summary.json"), "{text}");
    let out = Command::new(EXE)
        .arg("summarize")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let s = summary(dir.path());
    assert_eq!(s["rebuilt_from_files"], true, "{s}");
    let steps = s["steps"].as_u64().unwrap();
    assert!(steps >= 2000, "{s}");
    assert!(s["replayable_steps"].as_u64().unwrap() >= 2000, "{s}");
    assert!(s["inputs_applied"].as_u64().unwrap() >= 2000, "{s}");
    assert_eq!(s["failures"], 0, "{s}");
    assert!(s["files"]["replay.csv"]["cut_at_line"].is_u64(), "{s}");
    // The rebuilt summary is never written over, nor a server's own.
    let again = Command::new(EXE)
        .arg("summarize")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("exists"));
}

/// Issue 15 (protocol gaps): the scene stream was one request's responses,
/// and a scene over 256 chunks (30,720 bytes) lost its tail in the
/// client's response buffer. Now it comes in pages; chunks are cut at byte
/// boundaries, so a two-byte character split between two chunks must come
/// through whole.
#[test]
fn a_scene_larger_than_the_response_buffer_streams_whole() {
    let dir = TempDir::new("big-scene");
    let long = |c: &str| "é".repeat(12_000) + c;
    let text = format!(
        "[sim]\nname = \"big\"\ndt = 0.001\nduration = 1.0\n\n\
         [[body]]\nname = \"{}\"\nradius = 0.1\nmass = 1.0\nposition = [0.0, 0.0, 1.0]\n\n\
         [[body]]\nname = \"{}\"\nradius = 0.1\nmass = 1.0\nposition = [1.0, 0.0, 1.0]\n",
        long("a"),
        long("b")
    );
    let path = dir.path().join("big.toml");
    std::fs::write(&path, &text).unwrap();
    let name = unique("big-scene");
    let out = dir.path().join("out");
    let server = ServerProc::start(&name, &out, &[path.to_str().unwrap()]);
    let conn = Connection::connect(&name).unwrap();
    let got = conn.scene_toml().expect("the whole scene");
    assert!(got.len() > 48_000, "{}", got.len());
    let scene = cosim_shared::Scene::parse(&got, "<served>").expect("it parses");
    assert_eq!(scene.bodies[0].name, long("a"));
    assert_eq!(scene.bodies[1].name, long("b"));
    conn.shutdown().unwrap();
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
}

/// Issue 15, point 12: random control requests (every field random, sent
/// raw so that version and node ids are random too) and random input frames
/// at a live server, between the answers of a controller. The server
/// answers every request, goes on stepping, counts every bad input, and its
/// run replays bit for bit.
#[test]
fn random_requests_and_inputs_leave_the_server_running() {
    use cosim_bench::robust::Rng;
    use cosim_server::fuzz;
    use cosim_shared::wire::{ControlRequest, ControlResponse};
    use iceoryx2::prelude::*;
    // A short deadline and no drop: a random reset or restore can bring
    // back the step the controller answered last, which it then does not
    // answer again (it answers each step once), so the server waits that
    // step's deadline out.
    let (server, dir, name) = serve_test(
        "fuzz",
        &[
            "--controllers",
            "1",
            "--deadline-ms",
            "50",
            "--drop-after",
            "1000000",
        ],
    );
    let node = NodeBuilder::new().create::<ipc::Service>().unwrap();
    let control: ServiceName = cosim_shared::wire::services::control(&name)
        .as_str()
        .try_into()
        .unwrap();
    let client = node
        .service_builder(&control)
        .request_response::<ControlRequest, ControlResponse>()
        .open()
        .unwrap()
        .client_builder()
        .create()
        .unwrap();
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    let conn = Connection::connect(&name).unwrap();
    let mut rng = Rng::new(15);
    let (mut answered, mut bad_inputs) = (0u64, 0u64);
    for _ in 0..200 {
        // A random pause or step budget stops the stepping: resume it.
        let start = Instant::now();
        let f = loop {
            match c.next_state(Duration::from_millis(100)) {
                Ok(f) => break f,
                Err(ClientError::Timeout { .. }) => {
                    let i = conn.info().expect("the server answers");
                    assert!(
                        start.elapsed() < Duration::from_secs(20),
                        "no state: {:?} {:?}",
                        (i.step, i.paused, i.controller_count),
                        c.last_state()
                            .map(|f| (f.step, f.status, f.controller_count))
                    );
                    conn.resume().expect("the server answers");
                }
                Err(e) => panic!("the server stopped answering: {e}"),
            }
        };
        // Five random requests, each answered (a scene request with many
        // chunks, an error with a reason), before the controller answers.
        for _ in 0..5 {
            let req = fuzz::control_request(&mut rng);
            let pending = client.send_copy(req).unwrap();
            let start = Instant::now();
            let first = loop {
                if let Some(r) = pending.receive().unwrap() {
                    break *r.payload();
                }
                assert!(
                    start.elapsed() < Duration::from_secs(10),
                    "no answer to {req:?}"
                );
                std::thread::yield_now();
            };
            if first.status != 0 {
                assert!(
                    !first.message().is_empty(),
                    "{req:?} refused without a reason"
                );
            }
        }
        // A random input (rejected, or taken: it is the controller's own
        // publisher) and then, unless it was taken, the proper answer.
        let (header, words) = fuzz::input_frame(&mut rng, c.id(), f.step, 2, 2);
        c.send_words(header, words.len(), |w| {
            for &x in &words {
                cosim_client::WordSink::put(w, x)
            }
        })
        .unwrap();
        bad_inputs += 1;
        let mut input = InputFrame::default();
        input.push_torque(0, [0.0, -0.1, 0.0]);
        input.push_torque(1, [0.0; 3]);
        c.send(input).unwrap();
        answered += 1;
    }
    conn.shutdown().unwrap();
    let (status, stderr) = server.finish();
    let s = summary(dir.path());
    // Exit status 1 says that steps failed (inputs of 1e308 N m): each is
    // counted, and the run went on after it.
    let failures = s["failures"].as_u64().unwrap();
    assert_eq!(
        status.code(),
        Some(if failures > 0 { 1 } else { 0 }),
        "{stderr:.2000}"
    );
    assert_eq!(s["ending"], "shutdown", "{s}");
    let rejected: u64 = s["inputs_rejected"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert_eq!(
        rejected + s["inputs_applied"].as_u64().unwrap(),
        answered + bad_inputs,
        "{s}"
    );
    assert!(rejected >= 100, "{s}");
    let (ok, text) = replay(dir.path());
    assert!(ok, "{text}");
}

/// Found by the fuzz test above: a held torque that makes a step fail made
/// every retry fail too, since a controller answers each step once. The
/// frame of a failed step now asks for a new answer (its slot lacks
/// SLOT_ANSWERED); the controller sends a sane torque and the run goes on
/// as if that had been sent in the first place.
#[test]
fn a_failed_step_asks_the_controllers_for_a_new_answer() {
    use cosim_client::{SLOT_ANSWERED, STATUS_SOLVER_FAILED};
    let (server, dir, name) = serve_test(
        "answer-again",
        &[
            "--controllers",
            "1",
            "--steps",
            "30",
            "--deadline-ms",
            "5000",
        ],
    );
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    let conn = Connection::connect(&name).unwrap();
    let mut failed_frames = 0;
    answer_until_shutdown(&mut c, |c| {
        let f = c.last_state().unwrap().clone();
        let slot = f.controller(c.id()).unwrap();
        let mut input = InputFrame::default();
        if f.status & STATUS_SOLVER_FAILED != 0 {
            assert_eq!(slot.flags & SLOT_ANSWERED, 0);
            assert_eq!(f.step, 10);
            failed_frames += 1;
            input.push_torque(0, [0.0, 0.2, 0.0]);
            c.send(input).unwrap();
            conn.resume().unwrap();
            return;
        }
        let t = if f.step == 10 { 1e308 } else { 0.2 };
        input.push_torque(0, [0.0, t, 0.0]);
        c.send(input).unwrap();
    });
    let (status, stderr) = server.finish();
    assert_eq!(status.code(), Some(1), "one step failed: {stderr}");
    assert_eq!(failed_frames, 1);
    let s = summary(dir.path());
    assert_eq!(s["failures"], 1, "{s}");
    assert_eq!(s["steps"], 30, "{s}");
    assert_eq!(s["deadline_misses"], 0, "{s}");
    assert_eq!(
        positions(dir.path(), "upper"),
        offline(30, |_| Some([0.0, 0.2, 0.0]))
    );
    // The failed attempt is in the log and replays as it went.
    let (ok, text) = replay(dir.path());
    assert!(ok, "{text}");
}

/// Issue 14, point 6 (part): `--publish-every N` adds a decimated stream
/// for monitors that want fewer frames: every N-th step once (not again
/// when the frame is published anew after the join), and the last frame.
#[test]
fn a_decimated_stream_carries_every_nth_step_and_the_last() {
    let (server, _dir, name) = serve_test(
        "every",
        &[
            "--controllers",
            "1",
            "--steps",
            "95",
            "--publish-every",
            "10",
        ],
    );
    // Opened before the controller joins: nothing is stepped before.
    let m = Monitor::open_every(&name, 64).expect("the decimated stream");
    assert!(
        matches!(
            Monitor::open_every(&unique("every-none"), 4),
            Err(ClientError::NoServer { .. })
        ),
        "a server without --publish-every has no such stream"
    );
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    answer_until_shutdown(&mut c, |c| c.send(InputFrame::default()).unwrap());
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let mut seen = Vec::new();
    while let Ok(f) = m.next(Duration::from_millis(500)) {
        seen.push((f.step, f.status & STATUS_SHUTDOWN != 0));
        if f.status & STATUS_SHUTDOWN != 0 {
            break;
        }
    }
    let mut want: Vec<(u64, bool)> = (0..=90).step_by(10).map(|k| (k, false)).collect();
    want.push((95, true));
    assert_eq!(seen, want);
}

/// Issue 14, point 6: frames sized to the scene. A 4,000-sphere pile is
/// served in lockstep; a controller pushes the highest sphere up every
/// step while a monitor of the decimated stream reads along. Every frame
/// carries all 4,000 bodies; the pushed sphere, in free flight above the
/// pile, gains exactly `J / m` per step over gravity's `-g h`
/// (semi-implicit Euler, no contact); and the run replays to the bit.
#[test]
fn a_four_thousand_sphere_pile_is_served_in_lockstep() {
    const N: usize = 4000;
    const STEPS: u64 = 12;
    let dir = TempDir::new("pile4000");
    let scene = dir.path().join("pile.toml");
    let text = cosim_bench::pile::text(N, 0.01, 4, "pgs", STEPS, 1);
    std::fs::write(&scene, &text).unwrap();
    let name = unique("pile4000");
    let out = dir.path().join("run");
    let scene_arg = scene.to_str().unwrap();
    let server = ServerProc::start(
        &name,
        &out,
        &[
            scene_arg,
            "--controllers",
            "1",
            "--steps",
            &STEPS.to_string(),
            "--deadline-ms",
            "20000",
            "--publish-every",
            "4",
        ],
    );
    let monitor = Monitor::open_every(&name, 64).expect("monitor");
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    assert_eq!(c.info().body_count as usize, N);
    let f0 = c.next_state(Duration::from_secs(30)).expect("first state");
    assert_eq!(f0.bodies.len(), N);
    let (top, _) = f0
        .bodies
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.position[2].total_cmp(&b.1.position[2]))
        .unwrap();
    let v0 = f0.bodies[top].linear_velocity[2];
    let (m, g, h, j) = (1.0, 9.81, 0.01, 0.05);
    let mut pushes = 0u32;
    let mut last = f0;
    loop {
        assert_eq!(last.bodies.len(), N, "step {}", last.step);
        assert!(last.contacts.len() <= last.contact_count as usize);
        let expected = v0 + f64::from(pushes) * (j / m - g * h);
        let vz = last.bodies[top].linear_velocity[2];
        assert!(
            (vz - expected).abs() <= 1e-12 * (1.0 + expected.abs()),
            "step {}: vz {vz} against {expected}",
            last.step
        );
        let mut input = InputFrame::default();
        input.push_impulse(top as u32, [0.0, 0.0, j], [0.0; 3]);
        c.send(input).expect("send");
        pushes += 1;
        last = match c.next_state(Duration::from_secs(30)) {
            Ok(f) => f,
            Err(ClientError::Shutdown) => break,
            Err(e) => panic!("{e}"),
        };
    }
    assert_eq!(pushes as u64, STEPS);
    // The shutdown frame holds the final state.
    let end = c.last_state().unwrap().clone();
    assert_eq!(end.step, STEPS);
    let expected = v0 + f64::from(pushes) * (j / m - g * h);
    assert!((end.bodies[top].linear_velocity[2] - expected).abs() <= 1e-12 * (1.0 + expected));
    // The decimated stream's frames, in order, to its last.
    let mut seen = Vec::new();
    loop {
        let f = monitor
            .next(Duration::from_secs(10))
            .expect("decimated frame");
        assert_eq!(f.bodies.len(), N);
        seen.push(f.step);
        if f.status & STATUS_SHUTDOWN != 0 {
            break;
        }
    }
    assert!(seen.iter().all(|s| s % 4 == 0), "{seen:?}");
    assert_eq!(seen.last(), Some(&STEPS), "{seen:?}");
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    assert_eq!(summary(&out)["steps"], STEPS);
    let (ok, text) = replay(&out);
    assert!(ok, "{text}");
}

/// One Foxglove WebSocket message as the view sent it.
enum Fox {
    Json(serde_json::Value),
    /// Opcode 1: subscription id, time (ns), payload as JSON.
    Data(u32, u64, serde_json::Value),
    /// Opcode 2: time (ns).
    Time(u64),
}

fn fox(m: tungstenite::Message) -> Option<Fox> {
    match m {
        tungstenite::Message::Text(t) => Some(Fox::Json(
            serde_json::from_str(t.as_str()).expect("a JSON text message"),
        )),
        tungstenite::Message::Binary(b) => match b[0] {
            1 => Some(Fox::Data(
                u32::from_le_bytes(b[1..5].try_into().unwrap()),
                u64::from_le_bytes(b[5..13].try_into().unwrap()),
                serde_json::from_slice(&b[13..]).expect("a JSON payload"),
            )),
            2 => Some(Fox::Time(u64::from_le_bytes(b[1..9].try_into().unwrap()))),
            op => panic!("unknown binary opcode {op}"),
        },
        _ => None,
    }
}

/// The view of server `name` as `cosim view --listen 127.0.0.1:0 --rate
/// 200` runs it, in a thread, and the address it listens on.
fn start_view(
    name: &str,
) -> (
    std::thread::JoinHandle<Result<cosim_client::view::ViewStats, String>>,
    std::net::SocketAddr,
) {
    let (tx, rx) = std::sync::mpsc::channel();
    let vname = name.to_string();
    let view = std::thread::spawn(move || {
        let opts = cosim_client::view::ViewOptions {
            listen: "127.0.0.1:0".into(),
            rate: 200.0,
            seconds: Some(60.0),
        };
        cosim_client::view::view(&vname, &opts, |addr| tx.send(addr).unwrap())
            .map_err(|e| e.to_string())
    });
    let addr = rx
        .recv_timeout(Duration::from_secs(20))
        .expect("the view listens");
    (view, addr)
}

#[test]
fn the_live_view_serves_foxglove_the_servers_states() {
    use tungstenite::client::IntoClientRequest;
    // 1.5 s of real time: at 200 frames a second the view has 300 to
    // send, and the check below asks for 10 (400 steps once gave fewer
    // with the whole test suite loading both cores).
    let (server, dir, name) = serve_test(
        "view",
        &["--controllers", "1", "--realtime", "1", "--steps", "1500"],
    );
    let (view, addr) = start_view(&name);
    let url = format!("ws://{addr}");
    // A WebSocket client that does not ask for the protocol is refused.
    let refused = tungstenite::connect(url.as_str());
    assert!(
        matches!(&refused, Err(tungstenite::Error::Http(r)) if r.status() == 400),
        "{:?}",
        refused.map(|_| ())
    );

    let mut req = url.as_str().into_client_request().unwrap();
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().unwrap(),
    );
    let (mut ws, resp) = tungstenite::connect(req).expect("connect as Foxglove does");
    assert_eq!(
        resp.headers()["Sec-WebSocket-Protocol"],
        "foxglove.websocket.v1"
    );
    let next = |ws: &mut tungstenite::WebSocket<_>| loop {
        if let Some(m) = fox(ws.read().expect("a message")) {
            return m;
        }
    };
    let Fox::Json(info) = next(&mut ws) else {
        panic!("serverInfo first")
    };
    assert_eq!(info["op"], "serverInfo");
    assert!(info["capabilities"]
        .as_array()
        .unwrap()
        .contains(&"time".into()));
    let Fox::Json(adv) = next(&mut ws) else {
        panic!("advertise second")
    };
    assert_eq!(adv["op"], "advertise");
    let channels: std::collections::BTreeMap<u64, String> = adv["channels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            assert_eq!(c["encoding"], "json");
            assert_eq!(c["schemaEncoding"], "jsonschema");
            let schema: serde_json::Value =
                serde_json::from_str(c["schema"].as_str().unwrap()).expect("a JSON schema");
            assert_eq!(schema["title"], c["schemaName"]);
            (
                c["id"].as_u64().unwrap(),
                c["topic"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    let topics: Vec<&str> = channels.values().map(|s| s.as_str()).collect();
    for t in ["/scene", "/tf", "/solver", "/bodies/upper", "/bodies/lower"] {
        assert!(topics.contains(&t), "{t} not in {topics:?}");
    }
    // Subscription ids of the client's choosing: 100 + channel id.
    let subs: Vec<serde_json::Value> = channels
        .keys()
        .map(|&id| serde_json::json!({ "id": 100 + id, "channelId": id }))
        .collect();
    let subscribe = serde_json::json!({ "op": "subscribe", "subscriptions": subs });
    ws.send(tungstenite::Message::text(subscribe.to_string()))
        .unwrap();
    // A bad request is answered with a status naming what is wrong.
    let bad = r#"{"op":"subscribe","subscriptions":[{"id":7,"channelId":999}]}"#;
    ws.send(tungstenite::Message::text(bad)).unwrap();

    // Foxglove's own client of the protocol (@foxglove/ws-protocol under
    // Node.js, installed by .ci/run) beside ours.
    let client_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/foxglove_client");
    let mut node = Proc(
        Command::new("node")
            .arg(client_dir.join("client.mjs"))
            .arg(&url)
            .current_dir(&client_dir)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("node (Node.js, with the machine)"),
    );
    let mut node_lines =
        std::io::BufRead::lines(std::io::BufReader::new(node.0.stdout.take().unwrap()));
    let mut node_line = || -> String {
        match node_lines.next() {
            Some(Ok(l)) => l,
            _ => {
                let mut err = String::new();
                if let Some(mut e) = node.0.stderr.take() {
                    let _ = std::io::Read::read_to_string(&mut e, &mut err);
                }
                panic!("Foxglove's client ended early (npm ci --prefix server/tests/foxglove_client?): {err}")
            }
        }
    };
    assert_eq!(node_line(), "subscribed");

    // The controller joins once the view serves: the states it drives
    // are the ones the view must show.
    let cname = name.clone();
    let controller = std::thread::spawn(move || {
        let mut c = Controller::join(&cname, WaitMode::Hybrid).expect("join");
        answer_until_shutdown(&mut c, |c| c.send(InputFrame::default()).unwrap());
    });
    let mut status = None;
    let mut scenes = Vec::new();
    let mut bodies = Vec::new();
    let mut times = Vec::new();
    let mut solver_steps = Vec::new();
    if let tungstenite::stream::MaybeTlsStream::Plain(tcp) = ws.get_mut() {
        tcp.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    }
    // Until the view leaves (the server stopped) and closes the socket.
    while let Ok(m) = ws.read() {
        match fox(m) {
            Some(Fox::Json(j)) if j["op"] == "status" => status = Some(j),
            Some(Fox::Json(j)) => panic!("unexpected {j}"),
            Some(Fox::Data(sub, t, msg)) => {
                let topic = &channels[&(u64::from(sub) - 100)];
                match topic.as_str() {
                    "/scene" => scenes.push((t, msg)),
                    "/bodies/upper" => bodies.push((t, msg)),
                    "/solver" => solver_steps.push(msg["step"].as_u64().unwrap()),
                    _ => {}
                }
            }
            Some(Fox::Time(t)) => times.push(t),
            None => {}
        }
    }
    controller.join().unwrap();
    assert!(server.finish().0.success());
    let stats = view.join().unwrap().expect("the view ends with the server");
    assert_eq!(stats.dropped, 0);
    assert!(stats.frames as usize >= scenes.len());

    let status = status.expect("a status for the bad subscription");
    assert_eq!(status["level"], 2);
    assert!(
        status["message"]
            .as_str()
            .unwrap()
            .contains("channelId 999"),
        "{status}"
    );
    assert!(
        scenes.len() >= 10,
        "{} scenes, {} times, view {stats:?}, summary {}",
        scenes.len(),
        times.len(),
        summary(dir.path())
    );
    assert!(times.windows(2).all(|w| w[0] <= w[1]), "time goes back");
    // Steps never go back; one may come twice (the server publishes a
    // step again after a join: protocol.md), and CI once showed it.
    assert!(solver_steps.windows(2).all(|w| w[0] <= w[1]));
    let mut distinct = solver_steps.clone();
    distinct.dedup();
    assert!(distinct.len() >= 10, "{} steps drawn", distinct.len());
    // Every drawn state is one the server wrote, to the last digit JSON
    // keeps: the sphere at the lower body's position, its size 2 r.
    let lower = positions(dir.path(), "lower");
    let upper = positions(dir.path(), "upper");
    let h = 1e-3;
    let at = |states: &[(u64, [f64; 3])], t: u64| {
        let step = (t as f64 * 1e-9 / h).round() as u64;
        states
            .iter()
            .find(|s| s.0 == step)
            .unwrap_or_else(|| panic!("no state at step {step}"))
            .1
    };
    let xyz = |v: &serde_json::Value| ["x", "y", "z"].map(|c| v[c].as_f64().unwrap());
    let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12);
    for (t, msg) in &scenes {
        let e = &msg["entities"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["id"] == "body/lower")
            .expect("the lower body drawn")["spheres"][0];
        assert!(
            close(xyz(&e["pose"]["position"]), at(&lower, *t)),
            "t {t}: {e}"
        );
        assert_eq!(e["size"]["x"], 0.16);
    }
    for (t, msg) in &bodies {
        assert!(close(xyz(&msg["position"]), at(&upper, *t)), "t {t}: {msg}");
    }

    // What Foxglove's client read: the server's name and capabilities,
    // every channel with its schema name, messages on each, the time, no
    // error; its last body state is one the server wrote.
    let theirs: serde_json::Value = serde_json::from_str(&node_line()).expect("its JSON line");
    assert_eq!(theirs["errors"], serde_json::json!([]), "{theirs}");
    assert!(theirs["serverInfo"]["capabilities"]
        .as_array()
        .unwrap()
        .contains(&"time".into()));
    let schema_of = |topic: &str| {
        theirs["channels"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["topic"] == topic)
            .map(|c| c["schemaName"].clone())
    };
    assert_eq!(schema_of("/scene"), Some("foxglove.SceneUpdate".into()));
    assert_eq!(schema_of("/tf"), Some("foxglove.FrameTransforms".into()));
    assert_eq!(schema_of("/bodies/upper"), Some("cosim.BodyState".into()));
    for topic in ["/scene", "/tf", "/solver", "/bodies/upper", "/bodies/lower"] {
        assert!(
            theirs["counts"][topic].as_u64() >= Some(5),
            "{topic}: {theirs}"
        );
    }
    assert!(theirs["times"].as_u64() >= Some(5));
    let last = &theirs["last"]["/bodies/upper"];
    let t: u64 = last["timestamp"].as_str().unwrap().parse().unwrap();
    assert!(
        close(xyz(&last["msg"]["position"]), at(&upper, t)),
        "{last}"
    );
}

/// Issue 17: the state frame carries each joint's coordinate and rate
/// (protocol 3). slider.toml served with a controller that pushes the
/// carriage down its rail with a held force (a slider's effort): every
/// frame's coordinates equal the server's joints.csv at that step to the
/// bit, and the last one an offline run's with the same force.
#[test]
fn frames_carry_the_joints_coordinates() {
    use cosim_server::engine::constraint::joint;
    use cosim_server::engine::{Engine, Model};
    let scene = SLIDER;
    let steps = 300u64;
    let (server, dir, name) = serve_test(
        "joint-frames",
        &[scene, "--controllers", "1", "--steps", &steps.to_string()],
    );
    let monitor = Monitor::open(&name, 1024).expect("monitor");
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    let force = [-3.0, 0.0, 0.0];
    answer_until_shutdown(&mut c, |c| {
        let mut input = InputFrame::default();
        input.push_torque(0, force);
        c.send(input).expect("send");
    });
    let mut frames = std::collections::BTreeMap::new();
    loop {
        let f = monitor.next(Duration::from_secs(10)).expect("frame");
        frames.insert(f.step, f.joint_coordinates.clone());
        if f.status & STATUS_SHUTDOWN != 0 {
            break;
        }
    }
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let csv = std::fs::read_to_string(dir.path().join("joints.csv")).unwrap();
    let mut compared = 0;
    for row in csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
    {
        let step: u64 = row[0].parse().unwrap();
        let Some(coords) = frames.get(&step) else {
            continue;
        };
        let k = usize::from(row[2] == "pivot");
        let want = [
            row[4].parse::<f64>().unwrap(),
            row[5].parse::<f64>().unwrap(),
        ];
        assert_eq!(coords[k], want, "step {step}, {}", row[2]);
        compared += 1;
    }
    assert!(compared >= 2 * 250, "{compared} rows compared");
    // Offline, the same held force from the first step.
    let text = std::fs::read_to_string(scene).unwrap();
    let mut e = Engine::new(Model::from_scene(
        &cosim_shared::Scene::parse(&text, scene).unwrap(),
    ));
    e.set_joint_torque(0, force.into()).unwrap();
    for _ in 0..steps {
        assert!(e.step().ok());
    }
    let rail = joint::coordinate(&e.model().joints[0], e.state()).unwrap();
    assert_eq!(
        frames[&steps][0],
        [rail.0, rail.1],
        "the served run is the offline one"
    );
    // The force sped the carriage up: farther than without it.
    let mut free = Engine::new(Model::from_scene(
        &cosim_shared::Scene::parse(&text, scene).unwrap(),
    ));
    for _ in 0..steps {
        assert!(free.step().ok());
    }
    let unforced = joint::coordinate(&free.model().joints[0], free.state()).unwrap();
    assert!(
        rail.0 > unforced.0 + 0.01,
        "{} against {}",
        rail.0,
        unforced.0
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

/// The shipped limits scene (its rail has a motor: joint 2).
const LIMITS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../examples/scenes/limits.toml"
);

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

/// The live view serves each hinge's and slider's coordinate on
/// `/joints/NAME` (`cosim.JointCoordinate`), as recordings do: limits.toml
/// (two hinges swinging onto their limits, a slider driven by its motor),
/// served alone in real time; every message equals the server's
/// joints.csv row at its time's step to the last bit JSON's parser keeps.
#[test]
fn the_live_view_serves_the_joints_coordinates() {
    use tungstenite::client::IntoClientRequest;
    let (server, dir, name) = serve_test(
        "view-joints",
        &[LIMITS, "--realtime", "1", "--steps", "600"],
    );
    let (view, addr) = start_view(&name);
    let mut req = format!("ws://{addr}").into_client_request().unwrap();
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().unwrap(),
    );
    let (mut ws, _) = tungstenite::connect(req).expect("connect as Foxglove does");
    let mut joints = std::collections::BTreeMap::new();
    let mut samples = Vec::new();
    while let Ok(m) = ws.read() {
        match fox(m) {
            Some(Fox::Json(j)) if j["op"] == "advertise" => {
                for c in j["channels"].as_array().unwrap() {
                    let topic = c["topic"].as_str().unwrap();
                    if let Some(joint) = topic.strip_prefix("/joints/") {
                        assert_eq!(c["schemaName"], "cosim.JointCoordinate");
                        let id = c["id"].as_u64().unwrap();
                        joints.insert(id, joint.to_string());
                        let sub = serde_json::json!({ "op": "subscribe",
                            "subscriptions": [{ "id": id, "channelId": id }] });
                        ws.send(tungstenite::Message::text(sub.to_string()))
                            .unwrap();
                    }
                }
            }
            Some(Fox::Data(sub, t, msg)) => samples.push((joints[&u64::from(sub)].clone(), t, msg)),
            _ => {}
        }
    }
    assert!(server.finish().0.success());
    view.join().unwrap().expect("the view ends with the server");
    let names: Vec<&str> = joints.values().map(|s| s.as_str()).collect();
    assert_eq!(names, ["shoulder", "elbow", "rail"]);
    let csv = std::fs::read_to_string(dir.path().join("joints.csv")).unwrap();
    let rows: std::collections::BTreeMap<(u64, String), [f64; 2]> = csv
        .lines()
        .skip(1)
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            let v = |k: usize| c[k].parse::<f64>().unwrap();
            ((c[0].parse().unwrap(), c[2].to_string()), [v(4), v(5)])
        })
        .collect();
    let drawn: std::collections::BTreeSet<&str> = samples.iter().map(|s| s.0.as_str()).collect();
    assert_eq!(drawn.len(), 3, "every joint drawn");
    assert!(samples.len() >= 20, "{} samples", samples.len());
    for (joint, t, msg) in &samples {
        let step = (*t as f64 * 1e-9 / 1e-3).round() as u64;
        let want = rows[&(step, joint.clone())];
        let got = [
            msg["position"].as_f64().unwrap(),
            msg["rate"].as_f64().unwrap(),
        ];
        // serde_json's parser may round the last bit of a number.
        let same = (0..2).all(|k| (got[k] - want[k]).abs() <= 1e-15 * want[k].abs());
        assert!(same, "{joint} at step {step}: {got:?} against {want:?}");
    }
}
