//! A server's life: its name taken and freed, signals, kills, refusals.

use super::*;

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
    let second = ServerProc::start(&name, dir.path(), &["--overwrite"]);
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
    let second = ServerProc::start(&name, dir.path(), &["--overwrite"]);
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
    let out = summarize(dir.path());
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
    let again = summarize(dir.path());
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("exists"));
}

/// Issue 46: a server killed before its first step (still waiting for its
/// controller) leaves files `summarize` reads: zero steps, not "no column
/// 't'".
#[test]
fn a_server_killed_before_its_first_step_is_summarized() {
    let (mut server, dir, _name) = serve_test("killed-early", &["--controllers", "1"]);
    let mut child = server.child.take().unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
    let out = summarize(dir.path());
    assert!(out.status.success(), "{out:?}");
    let s = summary(dir.path());
    assert_eq!(s["steps"], 0, "{s}");
    assert_eq!(s["replayable_steps"], 0, "{s}");
}

/// `cosim-server summarize DIR`.
fn summarize(dir: &Path) -> std::process::Output {
    Command::new(EXE)
        .arg("summarize")
        .arg(dir)
        .output()
        .expect("run cosim-server summarize")
}
