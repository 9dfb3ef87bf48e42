//! A controller on "another host": the server and the exporter in one
//! iceoryx2 domain, the importer and the controller in another, joined
//! only through Zenoh on loopback (two domains share no shared memory:
//! their files have different prefixes). Real processes, unique names and
//! ports, killed when a test ends however it ends.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

const LINK: &str = env!("CARGO_BIN_EXE_cosim-link");

/// A binary of another package of the workspace, beside `cosim-link`,
/// built (same profile) if it is not there.
fn sibling(bin: &str, package: &str) -> PathBuf {
    let exe = Path::new(LINK).with_file_name(bin);
    if !exe.exists() {
        let release = Path::new(LINK)
            .parent()
            .is_some_and(|d| d.ends_with("release"));
        let status = Command::new(env!("CARGO"))
            .args(["build", "-q", "-p", package])
            .args(release.then_some("--release"))
            .status()
            .expect("cargo build");
        assert!(status.success(), "cargo build -p {package}");
    }
    exe
}

fn server_exe() -> PathBuf {
    sibling("cosim-server", "cosim-server")
}
fn cosim_exe() -> PathBuf {
    sibling("cosim", "cosim-client")
}

/// A process killed (and reaped) when dropped.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Proc {
    fn start(exe: &Path, domain: &str, args: &[&str]) -> Proc {
        let child = Command::new(exe)
            .args(args)
            .env("COSIM_DOMAIN", domain)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {}: {e}", exe.display()));
        Proc(child)
    }

    /// Waits up to `within` for the process to end.
    fn wait(&mut self, within: Duration) -> Option<ExitStatus> {
        let start = Instant::now();
        loop {
            if let Some(s) = self.0.try_wait().expect("try_wait") {
                return Some(s);
            }
            if start.elapsed() > within {
                return None;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// What it wrote to stderr (after it ended).
    fn stderr(&mut self) -> String {
        let mut s = String::new();
        if let Some(mut e) = self.0.stderr.take() {
            let _ = std::io::Read::read_to_string(&mut e, &mut s);
        }
        s
    }

    /// Reads stdout lines until one starts with `prefix`; panics at its end.
    fn line_starting(&mut self, prefix: &str) -> String {
        let out = self.0.stdout.take().expect("stdout");
        let mut lines = BufReader::new(out).lines();
        loop {
            match lines.next() {
                Some(Ok(l)) if l.starts_with(prefix) => return l,
                Some(Ok(_)) => {}
                _ => panic!("ended before a line '{prefix}...': {}", self.stderr()),
            }
        }
    }
}

/// A free TCP port on loopback (the system's pick, released for the
/// exporter to take).
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port()
}

/// The names of one test: its server and its two domains.
struct Names {
    server: String,
    here: String,
    there: String,
    endpoint: String,
}

fn names(tag: &str) -> Names {
    let id = std::process::id();
    Names {
        server: format!("remote-{tag}-{id}"),
        here: format!("srv{tag}{id}"),
        there: format!("ctl{tag}{id}"),
        endpoint: format!("tcp/127.0.0.1:{}", free_port()),
    }
}

/// A server waiting for one controller, its exporter, and an importer in
/// the other domain, ready.
struct Link {
    server: Proc,
    export: Proc,
    import: Proc,
}

fn link(n: &Names, out: &Path, steps: u64) -> Link {
    let steps = steps.to_string();
    let out = out.to_string_lossy().into_owned();
    let server = Proc::start(
        &server_exe(),
        &n.here,
        &[
            "serve",
            "--name",
            &n.server,
            "--controllers",
            "1",
            "--steps",
            &steps,
            "--out",
            &out,
            "--overwrite",
        ],
    );
    let export = Proc::start(
        Path::new(LINK),
        &n.here,
        &["export", &n.server, "--listen", &n.endpoint],
    );
    let mut import = Proc::start(
        Path::new(LINK),
        &n.there,
        &["import", &n.server, "--connect", &n.endpoint],
    );
    import.line_starting("ready");
    Link {
        server,
        export,
        import,
    }
}

fn summary(out: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(out.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("summary.json is JSON")
}

fn pd(domain: &str, server: &str) -> Proc {
    Proc::start(&cosim_exe(), domain, &["--name", server, "pd"])
}

/// The server's controller count, asked in its own domain.
fn controllers(domain: &str, server: &str) -> Option<u32> {
    let o = Command::new(cosim_exe())
        .args(["--name", server, "info"])
        .env("COSIM_DOMAIN", domain)
        .output()
        .ok()?;
    let text = String::from_utf8_lossy(&o.stdout);
    let at = text.find(" controllers")?;
    text[..at].rsplit(' ').next()?.parse().ok()
}

/// Waits until the server has a joined controller.
fn joined(n: &Names) {
    let start = Instant::now();
    while controllers(&n.here, &n.server) != Some(1) {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "no controller joined"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn temp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cosim-link-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

#[test]
fn a_remote_controller_steps_the_run_a_local_one_does() {
    let n = names("same");
    let dir = temp("same");
    let (remote, local) = (dir.join("remote"), dir.join("local"));

    let mut l = link(&n, &remote, 1500);
    let mut c = pd(&n.there, &n.server);
    let status = c
        .wait(Duration::from_secs(60))
        .expect("the controller ends");
    assert!(status.success(), "remote pd: {}", c.stderr());
    l.server
        .wait(Duration::from_secs(20))
        .expect("the server ends");
    // The server gone, each half ends of itself.
    assert!(
        l.export.wait(Duration::from_secs(10)).is_some(),
        "exporter still up"
    );
    assert!(
        l.import.wait(Duration::from_secs(10)).is_some(),
        "importer still up"
    );

    // The same controller beside the server, in a third domain.
    let alone = format!("{}-local", n.here);
    let mut s = Proc::start(
        &server_exe(),
        &alone,
        &[
            "serve",
            "--name",
            &n.server,
            "--controllers",
            "1",
            "--steps",
            "1500",
            "--out",
            &local.to_string_lossy(),
            "--overwrite",
        ],
    );
    let mut c = Proc::start(
        &cosim_exe(),
        &alone,
        &["--name", &n.server, "pd", "--timeout", "30"],
    );
    // `pd` fails at once when no server is up yet: try until one is.
    let start = Instant::now();
    loop {
        let status = c.wait(Duration::from_secs(60)).expect("local pd ends");
        if status.success() {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(20), "{}", c.stderr());
        std::thread::sleep(Duration::from_millis(20));
        c = Proc::start(&cosim_exe(), &alone, &["--name", &n.server, "pd"]);
    }
    s.wait(Duration::from_secs(20))
        .expect("the local server ends");

    for file in ["states.csv", "joints.csv", "impulses.csv"] {
        let a = std::fs::read(remote.join(file)).expect(file);
        let b = std::fs::read(local.join(file)).expect(file);
        assert!(
            a == b,
            "{file} differs between the remote and the local run"
        );
    }
    let s = summary(&remote);
    assert_eq!(s["steps"], 1500, "{s}");
    assert_eq!(s["inputs_applied"], 1500, "{s}");
    assert_eq!(s["deadline_misses"], 0, "{s}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_killed_remote_controller_is_let_go_as_a_local_one() {
    let n = names("kill");
    let dir = temp("kill");
    let mut l = link(&n, &dir, 200_000);
    let c = pd(&n.there, &n.server);
    joined(&n);
    drop(c); // SIGKILL: its ports are left behind a dead node
    l.server
        .wait(Duration::from_secs(60))
        .expect("the server runs on to its end");
    let s = summary(&dir);
    assert_eq!(s["controllers_departed"], 1, "{s}");
    assert_eq!(s["deadline_misses"], 0, "{s}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_lost_controller_host_is_let_go() {
    let n = names("host");
    let dir = temp("host");
    let mut l = link(&n, &dir, 200_000);
    let mut c = pd(&n.there, &n.server);
    joined(&n);
    // The importer killed: the controller's "host" is cut off. Zenoh's
    // liveliness tells the exporter, whose proxy goes.
    let _ = l.import.0.kill();
    l.server
        .wait(Duration::from_secs(60))
        .expect("the server runs on to its end");
    let s = summary(&dir);
    assert_eq!(s["controllers_departed"], 1, "{s}");
    assert_eq!(s["deadline_misses"], 0, "{s}");
    // And the controller, its server's services gone, says so.
    let status = c
        .wait(Duration::from_secs(20))
        .expect("the controller ends");
    let err = c.stderr();
    assert!(!status.success() && err.contains("gone"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_killed_server_ends_the_remote_controller() {
    let n = names("srv");
    let dir = temp("srv");
    let mut l = link(&n, &dir, 200_000);
    let mut c = pd(&n.there, &n.server);
    joined(&n);
    let _ = l.server.0.kill();
    let status = c
        .wait(Duration::from_secs(20))
        .expect("the controller ends");
    let err = c.stderr();
    assert!(!status.success() && err.contains("gone"), "{err}");
    assert!(
        l.export.wait(Duration::from_secs(10)).is_some(),
        "exporter still up"
    );
    assert!(
        l.import.wait(Duration::from_secs(10)).is_some(),
        "importer still up"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The Python package's controller (written from docs/protocol.md) on the
/// far side: it finds "the server" by the pid the responses carry, which
/// the importer gives as its own, and it is dropped when it exits without
/// leaving, as a local one would be.
#[test]
fn a_python_controller_runs_remote_unchanged() {
    let n = names("py");
    let dir = temp("py");
    let mut l = link(&n, &dir, 3000);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/python/controller.py");
    let o = Command::new("python3")
        .arg(&script)
        .args([
            "--name",
            &n.server,
            "--steps",
            "1000",
            "--exit-without-leave",
            "1000",
        ])
        .env("COSIM_DOMAIN", &n.there)
        .output()
        .expect("python3 (scripts/test.sh installs the cosim package)");
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && said.contains("answered 1000 steps"),
        "{said}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    l.server
        .wait(Duration::from_secs(60))
        .expect("the server runs on to its end");
    let s = summary(&dir);
    assert_eq!(s["inputs_applied"], 1000, "{s}");
    assert_eq!(s["controllers_departed"], 1, "{s}");
    assert_eq!(s["deadline_misses"], 0, "{s}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A remote recorder in the lockstep: it asks for the scene (a request
/// answered in many responses, pages of chunks) and takes every frame.
#[test]
fn a_remote_recorder_gets_the_scene_and_every_frame() {
    let n = names("rec");
    let dir = temp("rec");
    let (served, recorded) = (dir.join("served"), dir.join("recorded"));
    let mut l = link(&n, &served, 800);
    let mut r = Proc::start(
        &cosim_exe(),
        &n.there,
        &[
            "--name",
            &n.server,
            "record",
            "--out",
            &recorded.to_string_lossy(),
            "--lockstep",
        ],
    );
    let status = r.wait(Duration::from_secs(60)).expect("the recorder ends");
    assert!(status.success(), "{}", r.stderr());
    l.server
        .wait(Duration::from_secs(20))
        .expect("the server ends");
    let scene = |d: &Path| std::fs::read(d.join("scene.toml")).expect("scene.toml");
    assert!(
        scene(&served) == scene(&recorded),
        "the scene came across changed"
    );
    // Byte for byte: the recorder writes numbers as the server does
    // (`cosim_shared::num`).
    let states = |d: &Path| -> Vec<String> {
        std::fs::read_to_string(d.join("states.csv"))
            .expect("states.csv")
            .lines()
            .map(str::to_string)
            .collect()
    };
    let (a, b) = (states(&served), states(&recorded));
    assert_eq!(
        a.len(),
        2 * 801 + 1,
        "a line per body and step and a header"
    );
    assert!(a == b, "the frames came across changed");
    let _ = std::fs::remove_dir_all(&dir);
}
