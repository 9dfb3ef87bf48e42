//! `cosim-link bench`: the remote lockstep (server and exporter in one
//! iceoryx2 domain, importer and controller in another, Zenoh on
//! loopback between them) beside the same lockstep local and beside
//! Zenoh's own round trip of the same message sizes, in one run, at the
//! defaults (wait modes `hybrid`, the reference scene).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use zenoh::Wait;

pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// The reference scene's state frame without contacts (header and 2
/// bodies, 2 joints) and an empty input with the link's framing: the
/// sizes the lockstep sends each way.
const STATE_BYTES: usize = 280 + 8 * (13 * 2 + 5 * 2);
const INPUT_BYTES: usize = 40 + 32;

/// A peer process, killed when dropped.
struct Peer(Child);

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn spawn(exe: &Path, domain: &str, args: &[&str]) -> Result<Peer, BoxError> {
    Ok(Peer(
        Command::new(exe)
            .args(args)
            .env("COSIM_DOMAIN", domain)
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| format!("cannot start {}: {e}", exe.display()))?,
    ))
}

fn beside(bin: &str) -> Result<PathBuf, BoxError> {
    let me = std::env::current_exe()?;
    let exe = me.with_file_name(bin);
    if !exe.exists() {
        return Err(format!(
            "{} not found beside {} (cargo build --release -p cosim-server -p cosim-link)",
            exe.display(),
            me.display()
        )
        .into());
    }
    Ok(exe)
}

fn free_endpoint() -> Result<String, BoxError> {
    let port = std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port();
    Ok(format!("tcp/127.0.0.1:{port}"))
}

/// One lockstep run's figures, from the server's summary.json.
struct Lockstep {
    steps_per_s: f64,
    rt_median_us: f64,
    rt_p99_us: f64,
}

fn lockstep(steps: u64, remote: bool, round: usize) -> Result<Lockstep, BoxError> {
    let server = beside("cosim-server")?;
    let link = std::env::current_exe()?;
    let pid = std::process::id();
    let name = format!("linkbench-{pid}-{round}-{remote}");
    let (here, there) = (format!("lbh{pid}{round}"), format!("lbt{pid}{round}"));
    let out = std::env::temp_dir().join(&name);
    let steps_s = steps.to_string();
    let out_s = out.to_string_lossy().into_owned();
    let mut peers = vec![spawn(
        &server,
        &here,
        &[
            "serve",
            "--name",
            &name,
            "--controllers",
            "1",
            "--steps",
            &steps_s,
            "--out",
            &out_s,
            "--overwrite",
            "--quiet",
        ],
    )?];
    let controller_domain = if remote {
        let endpoint = free_endpoint()?;
        peers.push(spawn(
            &link,
            &here,
            &["export", &name, "--listen", &endpoint],
        )?);
        let mut import = spawn(&link, &there, &["import", &name, "--connect", &endpoint])?;
        let stdout = import.0.stdout.take().ok_or("no stdout")?;
        let mut line = String::new();
        BufReader::new(stdout).read_line(&mut line)?;
        if !line.starts_with("ready") {
            return Err("the importer did not start".into());
        }
        peers.push(import);
        there
    } else {
        here
    };
    peers.push(spawn(
        &server,
        &controller_domain,
        &[
            "bench-peer",
            "controller",
            "--name",
            &name,
            "--wait",
            "hybrid",
        ],
    )?);
    let start = Instant::now();
    loop {
        if let Some(status) = peers[0].0.try_wait()? {
            if !status.success() {
                return Err(format!("the server of {name} failed").into());
            }
            break;
        }
        if start.elapsed() > Duration::from_secs(600) {
            return Err(format!("{name} did not end").into());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    drop(peers);
    let text = std::fs::read_to_string(out.join("summary.json"))?;
    let _ = std::fs::remove_dir_all(&out);
    let field = |key: &str| -> Result<f64, BoxError> {
        number_after(&text, key).ok_or_else(|| format!("no {key} in summary.json").into())
    };
    let steps_done = field("\"steps\"")?;
    Ok(Lockstep {
        steps_per_s: steps_done / field("\"stepping_seconds\"")?,
        rt_median_us: field("\"median\"")?,
        rt_p99_us: field("\"p99\"")?,
    })
}

/// The number after the first `key:` of a JSON text (the summary's
/// `round_trip_us` comes before `step_compute_us`, so its median is the
/// first); a `key` that is a value elsewhere is skipped.
fn number_after(text: &str, key: &str) -> Option<f64> {
    text.match_indices(key).find_map(|(at, _)| {
        let rest = text[at + key.len()..]
            .trim_start()
            .strip_prefix(':')?
            .trim_start();
        let end = rest
            .find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c)))
            .unwrap_or(rest.len());
        rest[..end].parse().ok()
    })
}

/// Zenoh's own round trip between two processes on loopback: a
/// frame-sized put answered by an input-sized one, as the link sends them
/// (express, real-time priority, blocking congestion control).
fn raw_zenoh(n: usize) -> Result<(f64, f64), BoxError> {
    let endpoint = free_endpoint()?;
    let z = crate::session::open(&crate::session::Endpoints {
        listen: vec![endpoint.clone()],
        connect: vec![],
    })?;
    let _pong = spawn(
        &std::env::current_exe()?,
        "unused",
        &["bench-peer", "zpong", &endpoint],
    )?;
    let ping = z
        .declare_publisher("cosim-bench/ping")
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .priority(zenoh::qos::Priority::RealTime)
        .express(true)
        .wait()?;
    let replies = z.declare_subscriber("cosim-bench/pong").wait()?;
    let payload = vec![7u8; STATE_BYTES];
    // Until the pong answers (it connects and subscribes first).
    let start = Instant::now();
    loop {
        ping.put(payload.clone()).wait()?;
        if replies.recv_timeout(Duration::from_millis(20))?.is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(30) {
            return Err("the Zenoh pong did not answer".into());
        }
    }
    while replies.try_recv()?.is_some() {}
    let mut rt = Vec::with_capacity(n);
    for i in 0..n + 1000 {
        let t = Instant::now();
        ping.put(payload.clone()).wait()?;
        replies
            .recv_timeout(Duration::from_secs(5))?
            .ok_or("the Zenoh pong stopped answering")?;
        if i >= 1000 {
            rt.push(t.elapsed().as_secs_f64() * 1e6);
        }
    }
    ping.put(Vec::<u8>::new()).wait()?;
    rt.sort_by(f64::total_cmp);
    let q = |p: f64| rt[((rt.len() - 1) as f64 * p).round() as usize];
    Ok((q(0.5), q(0.99)))
}

/// The pong side of [`raw_zenoh`].
fn zpong(endpoint: &str) -> Result<(), BoxError> {
    let z = crate::session::open(&crate::session::Endpoints {
        listen: vec![],
        connect: vec![endpoint.to_string()],
    })?;
    let pong = z
        .declare_publisher("cosim-bench/pong")
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .priority(zenoh::qos::Priority::RealTime)
        .express(true)
        .wait()?;
    let (done_tx, done) = std::sync::mpsc::channel();
    let reply = vec![1u8; INPUT_BYTES];
    // Answered in Zenoh's own receiving thread: the floor of a round trip.
    let _pings = z
        .declare_subscriber("cosim-bench/ping")
        .callback(move |s| {
            if s.payload().is_empty() {
                let _ = done_tx.send(());
            } else {
                let _ = pong.put(reply.clone()).wait();
            }
        })
        .wait()?;
    let _ = done.recv_timeout(Duration::from_secs(120));
    Ok(())
}

/// A peer role of the benchmark.
pub fn peer(role: &str, arg: &str) -> Result<(), BoxError> {
    match role {
        "zpong" => zpong(arg),
        other => Err(format!("unknown bench peer role {other:?}").into()),
    }
}

/// The table: two rounds of each row, alternated.
pub fn run(steps: u64) -> Result<String, BoxError> {
    let mut out = String::from(
        "| what (wait modes at their defaults) | steps/s | round trip median (us) | p99 (us) |\n|---|---|---|---|\n",
    );
    for round in 0..2 {
        let (m, p) = raw_zenoh(steps as usize)?;
        out += &format!("| raw Zenoh round trip ({STATE_BYTES} B out, {INPUT_BYTES} B back), round {} | - | {m:.1} | {p:.1} |\n", round + 1);
        for remote in [false, true] {
            let l = lockstep(steps, remote, round)?;
            let what = if remote {
                "lockstep, remote over cosim-link (Zenoh, loopback)"
            } else {
                "lockstep, local (iceoryx2)"
            };
            out += &format!(
                "| {what}, round {} | {:.0} | {:.1} | {:.1} |\n",
                round + 1,
                l.steps_per_s,
                l.rt_median_us,
                l.rt_p99_us
            );
        }
    }
    Ok(out)
}
