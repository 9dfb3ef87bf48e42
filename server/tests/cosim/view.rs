//! The live view, read by a Foxglove WebSocket client.

use super::*;

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
