//! The peer processes of `bench ipc`: this program started again (or the
//! Python package), pinned to its cores, killed when dropped.

use super::*;

/// A child killed when dropped.
pub(super) struct Peer(Child);

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Whether this process pinned itself to core 0 (see [`pin_self`]); then
/// peers are started on the cores [`peer_on`] is given.
pub(super) static PINNED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Pins this process's main thread (and so the server thread it starts
/// later) to core 0 with `taskset`, when there are two cores or more and
/// the tool exists. Why: spinning lockstep assumes a core per process, and
/// unpinned, the scheduler's migrations between runs were larger than the
/// effects measured (a monitor's few percent).
pub(super) fn pin_self(cores: usize) -> bool {
    let ok = cores >= 2
        && Command::new("taskset")
            .args(["-p", "-c", "0", &std::process::id().to_string()])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
    PINNED.store(ok, std::sync::atomic::Ordering::Relaxed);
    ok
}

/// Every core, as a taskset list.
pub(super) fn all_cores() -> String {
    let n = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("0-{}", n.saturating_sub(1))
}

/// A peer on core 1 (the one other process of a two-process measurement).
pub(super) fn peer(args: &[&str]) -> std::io::Result<Peer> {
    peer_on("1", args)
}

/// A peer on `cores` (a taskset list) when this process is pinned, else
/// wherever the scheduler puts it.
pub(super) fn peer_on(cores: &str, args: &[&str]) -> std::io::Result<Peer> {
    let exe = std::env::current_exe()?;
    let mut cmd = if PINNED.load(std::sync::atomic::Ordering::Relaxed) {
        let mut c = Command::new("taskset");
        c.arg("-c").arg(cores).arg(exe);
        c
    } else {
        Command::new(exe)
    };
    cmd.arg("bench-peer")
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .map(Peer)
}

/// Who answers the lockstep: this program's Rust controller, or the
/// Python package's (`python3 -m cosim.peer`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Client {
    Rust,
    Python,
}

/// A Python controller of the `cosim` package on `cores`, as `peer_on`
/// places this program's peers.
pub(super) fn python_peer_on(cores: &str, name: &str, mode: WaitMode) -> std::io::Result<Peer> {
    let mut cmd = if PINNED.load(std::sync::atomic::Ordering::Relaxed) {
        let mut c = Command::new("taskset");
        c.args(["-c", cores, "python3"]);
        c
    } else {
        Command::new("python3")
    };
    cmd.args(["-m", "cosim.peer", name, mode.as_str()])
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .map(Peer)
}

/// Whether `python3` imports the `cosim` package (`pip install ./python`).
pub(super) fn python_package() -> bool {
    Command::new("python3")
        .args(["-c", "import cosim"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// `bench-peer`: the other process of each measurement.
pub(crate) fn run_peer(role: &str, name: &str, mode: WaitMode) -> Result<(), BoxError> {
    match role {
        "pong" => ponger(name, mode),
        "controller" => {
            let patience = Duration::from_secs(30);
            let mut c = cosim_client::when_up(patience, || Controller::join(name, mode))?;
            let mut input = InputFrame::default();
            while c.next_state_ref(Duration::from_secs(30)).is_ok() {
                c.send_ref(&mut input)?;
            }
            Ok(())
        }
        // The recorder takes every frame, woken for each.
        "recorder" => {
            let m = cosim_client::when_up(Duration::from_secs(30), || Monitor::open(name, 64))?;
            while let Ok(f) = m.next(Duration::from_secs(30)) {
                if f.status & cosim_shared::wire::STATUS_SHUTDOWN != 0 {
                    break;
                }
            }
            Ok(())
        }
        // As `cosim monitor` (the newest frame, ten times a second) for a
        // window, detached for the next, until the server is gone; the
        // attached intervals go to `intervals_file`.
        "monitor-toggle" => {
            let mut out = std::fs::File::create(intervals_file(name))?;
            loop {
                let Ok(m) =
                    cosim_client::when_up(Duration::from_secs(5), || Monitor::polling(name))
                else {
                    return Ok(());
                };
                let start = epoch_seconds();
                while epoch_seconds() < start + WINDOW {
                    if m.node().wait(Duration::from_millis(100)).is_err() {
                        return Ok(());
                    }
                    if let Some(f) = m.latest()? {
                        if f.status & cosim_shared::wire::STATUS_SHUTDOWN != 0 {
                            return Ok(());
                        }
                    }
                }
                drop(m);
                let end = epoch_seconds();
                std::thread::sleep(Duration::from_secs_f64(WINDOW));
                writeln!(out, "{start} {end} {}", epoch_seconds())?;
                out.flush()?;
            }
        }
        // As `cosim view --rate 30` with a Foxglove client subscribed to
        // every channel, for a window, detached for the next, as
        // `monitor-toggle`. The window starts once the view has its
        // monitor and listens (its scene request to the server is before).
        "view-toggle" => {
            let mut out = std::fs::File::create(intervals_file(name))?;
            loop {
                // The server may not be up yet; once it is gone, done.
                let up = cosim_client::when_up(Duration::from_secs(5), || {
                    cosim_client::Connection::connect(name)
                });
                if up.is_err() {
                    return Ok(());
                }
                let (tx, rx) = std::sync::mpsc::channel();
                let vname = name.to_string();
                let view = std::thread::spawn(move || {
                    let opts = cosim_client::view::ViewOptions {
                        listen: "127.0.0.1:0".into(),
                        rate: 30.0,
                        seconds: Some(WINDOW),
                    };
                    cosim_client::view::view(&vname, &opts, |a| {
                        let _ = tx.send(a);
                    })
                    .map_err(|e| e.to_string())
                });
                // No address: the server is gone (the view failed).
                let Ok(addr) = rx.recv_timeout(Duration::from_secs(5)) else {
                    return Ok(());
                };
                let start = epoch_seconds();
                let client = std::thread::spawn(move || foxglove_client(addr));
                let done = view.join().map_err(|_| "the view panicked")?;
                let end = epoch_seconds();
                let _ = client.join();
                if done.is_err() {
                    return Ok(());
                }
                std::thread::sleep(Duration::from_secs_f64(WINDOW));
                writeln!(out, "{start} {end} {}", epoch_seconds())?;
                out.flush()?;
            }
        }
        "tcp" => {
            let mut sock = std::net::TcpStream::connect(("127.0.0.1", name.parse::<u16>()?))?;
            sock.set_nodelay(true)?;
            let mut len = [0u8; 8];
            let mut state = Vec::new();
            let reply = vec![0u8; input_bytes()];
            while sock.read_exact(&mut len).is_ok() {
                let n = usize::try_from(u64::from_le_bytes(len))?;
                state.resize(n, 0);
                sock.read_exact(&mut state)?;
                sock.write_all(&reply)?;
            }
            Ok(())
        }
        other => Err(format!("unknown bench peer role {other:?}").into()),
    }
}

/// A Foxglove client of `cosim view` at `addr`: subscribes to every
/// channel advertised and reads until the view closes the connection.
pub(super) fn foxglove_client(addr: std::net::SocketAddr) -> Result<(), String> {
    use tungstenite::client::IntoClientRequest;
    let mut req = format!("ws://{addr}")
        .into_client_request()
        .map_err(|e| e.to_string())?;
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        tungstenite::http::HeaderValue::from_static(cosim_foxglove::live::SUBPROTOCOL),
    );
    let (mut ws, _) = tungstenite::connect(req).map_err(|e| e.to_string())?;
    while let Ok(m) = ws.read() {
        let tungstenite::Message::Text(t) = m else {
            continue;
        };
        let v: serde_json::Value = serde_json::from_str(t.as_str()).map_err(|e| e.to_string())?;
        if v["op"] == "advertise" {
            let subs: Vec<serde_json::Value> = v["channels"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|c| serde_json::json!({ "id": c["id"], "channelId": c["id"] }))
                .collect();
            let msg = serde_json::json!({ "op": "subscribe", "subscriptions": subs });
            ws.send(tungstenite::Message::text(msg.to_string()))
                .map_err(|e| e.to_string())?;
        }
    }
    Ok(())
}
