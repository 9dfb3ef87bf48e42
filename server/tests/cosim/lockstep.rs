//! The lockstep itself: answers, rejects, control commands, replay, timing.

use super::*;

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
    // Steps that failed (inputs of 1e308 N m) are counted and the run went
    // on after each; exit status 1 only when it ended on one.
    let unrecovered = s["ended_on_failure"].as_bool().unwrap();
    assert_eq!(
        status.code(),
        Some(if unrecovered { 1 } else { 0 }),
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
    // Recovered: the run went on from its failure and ended at --steps,
    // so it succeeds (issue 46: exit status 1 after a recovered run); the
    // failure is counted. (A run that ends on a failure exits 1:
    // on_failure_pause_tries_a_failed_step_once_and_waits.)
    assert_eq!(status.code(), Some(0), "recovered: {stderr}");
    assert_eq!(failed_frames, 1);
    let s = summary(dir.path());
    assert_eq!(s["failures"], 1, "{s}");
    assert_eq!(s["ended_on_failure"], false, "{s}");
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

/// Issue 46: paced, the round trip holds no pacing wait. At h = 10 ms and
/// real time, a controller that answers at once: the state goes out when
/// it is due and the answer follows within a few hundred us; published
/// before the wait, the round trip read the wait's 10 ms.
#[test]
fn a_paced_round_trip_holds_no_pacing_wait() {
    let (server, dir, name) = serve_test(
        "round-trip-paced",
        &[
            "--controllers",
            "1",
            "--steps",
            "30",
            "--realtime",
            "1",
            "--dt",
            "0.01",
        ],
    );
    let mut c = Controller::join(&name, WaitMode::Block).expect("join");
    answer_until_shutdown(&mut c, |c| c.send(InputFrame::default()).expect("send"));
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    let s = summary(dir.path());
    let median = s["round_trip_us"]["median"].as_f64().unwrap();
    assert!(
        median < 5000.0,
        "round trip median {median} us at h = 10 ms"
    );
    // And the run still lasts its simulated time.
    assert!(s["stepping_seconds"].as_f64().unwrap() >= 0.29, "{s}");
}

/// A controller's torque beyond its joint's `max_effort` is clamped: the
/// run says so once and counts every clamped joint-step in its summary,
/// and its replay (which feeds the torques as sent) is bit for bit, since
/// the engine clamps what it is given; the trajectory is the offline one
/// under the bound.
#[test]
fn a_controllers_torque_beyond_the_joints_bound_is_clamped_counted_and_replays() {
    let dir = TempDir::new("clamp");
    let mut scene = cosim_shared::scenes::reference().unwrap();
    scene.joints[0].max_effort = Some(0.05);
    let path = dir.path().join("clamped.toml");
    std::fs::write(&path, scene.to_toml()).unwrap();
    let name = unique("clamp");
    let out = dir.path().join("out");
    let server = ServerProc::start(
        &name,
        &out,
        &[
            path.to_str().unwrap(),
            "--controllers",
            "1",
            "--steps",
            "100",
        ],
    );
    let mut c = Controller::join(&name, WaitMode::Hybrid).expect("join");
    answer_until_shutdown(&mut c, |c| {
        let mut input = InputFrame::default();
        input.push_torque(0, [0.0, 0.0, 0.5]);
        c.send(input).expect("send");
    });
    let (status, stderr) = server.finish();
    assert!(status.success(), "{stderr}");
    assert_eq!(
        stderr.matches("exceeds its effort bound").count(),
        1,
        "{stderr}"
    );
    let s = summary(&out);
    assert_eq!(s["steps"], 100);
    assert_eq!(s["clamped_efforts"], 100, "{s}");
    let (ok, text) = replay(&out);
    assert!(ok && text.contains("100 steps"), "{text}");
    // Offline: the same scene with the bound, fed the same torque.
    use cosim_server::engine::{Engine, Model};
    let mut e = Engine::new(Model::from_scene(&scene));
    e.set_joint_torque(0, [0.0, 0.0, 0.5].into()).unwrap();
    let mut unbounded = Engine::new(Model::from_scene(
        &cosim_shared::scenes::reference().unwrap(),
    ));
    unbounded
        .set_joint_torque(0, [0.0, 0.0, 0.5].into())
        .unwrap();
    for _ in 0..100 {
        assert!(e.step().ok() && unbounded.step().ok());
    }
    let rows = positions(&out, "upper");
    let last: [f64; 3] = e.state().bodies[0].x.into();
    assert_eq!(rows.last().map(|r| r.1), Some(last));
    let free: [f64; 3] = unbounded.state().bodies[0].x.into();
    assert_ne!(last, free, "the bound changed nothing");
}
