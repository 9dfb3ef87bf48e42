//! Recorders and the decimated stream: what they keep, read back by others.

use super::*;

#[test]
fn a_recording_matches_the_servers_own_files_and_plots() {
    let dir = TempDir::new("record");
    let rec = TempDir::new("record-out");
    let name = unique("record");
    let server = ServerProc::start(&name, dir.path(), &["--controllers", "1", "--steps", "400"]);
    let rec_path = rec.path().to_path_buf();
    let rname = name.clone();
    let recorder = std::thread::spawn(move || {
        cosim_client::cli::record(&rname, &rec_path, None, true, false).map_err(|e| e.to_string())
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
    let frames = recorder.join().unwrap().expect("record").frames;
    assert!(frames >= 401, "{frames}");
    let ours = positions(dir.path(), "lower");
    let theirs = positions(rec.path(), "lower");
    assert_eq!(ours, theirs, "the recording holds the server's states");
    // The same text, number for number as the server writes it.
    let text = |d: &Path| std::fs::read_to_string(d.join("states.csv")).expect("states.csv");
    assert!(
        text(dir.path()) == text(rec.path()),
        "states.csv differs from the server's"
    );
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

/// Issue 46, point 4: `cosim record --lockstep` keeps every frame. It joins
/// as a controller that sends no input, so the server (waiting for one
/// controller, then stepping as fast as it can: far faster than a monitor
/// reads) waits for it each step; the recording holds every state the
/// server wrote, to the bit, and says so.
#[test]
fn a_lockstep_recording_keeps_every_frame() {
    let dir = TempDir::new("record-lockstep");
    let rec = TempDir::new("record-lockstep-out");
    let name = unique("record-lockstep");
    let server = ServerProc::start(
        &name,
        dir.path(),
        &["--controllers", "1", "--steps", "3000"],
    );
    let r = cosim_client::cli::record(&name, rec.path(), None, false, true).expect("record");
    assert!(server.finish().0.success());
    assert_eq!(
        (r.frames, r.first, r.last, r.dropped),
        (3001, Some(0), Some(3000), 0),
        "{r:?}"
    );
    let ours = positions(dir.path(), "lower");
    assert_eq!(ours.len(), 3001);
    assert_eq!(ours, positions(rec.path(), "lower"));
    // The recorder was the server's one controller: no input, no miss.
    let s = summary(dir.path());
    assert_eq!(s["deadline_misses"], 0, "{s}");
}
