//! A step the rigid LCP cannot take, under each `--on-failure` policy.

use super::*;

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
