//! One run as processes: `cosim-server run`, or `cosim-server serve` and
//! the controller's command in lockstep, in the run's own iceoryx2
//! domain, their output in the run's folder.

use super::plan::{scene_with, text, Plan, Run};
use super::{folder, Options};
use crate::domain::DOMAIN_VAR;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

pub struct Runner<'a> {
    plan: &'a Plan,
    out: PathBuf,
    server: PathBuf,
    cosim: PathBuf,
    /// The scene's text (TOML scenes), to set values in.
    scene_text: Option<String>,
    /// This sweep's mark in its runs' domain names.
    tag: String,
}

impl<'a> Runner<'a> {
    pub fn new(plan: &'a Plan, o: &Options) -> Result<Runner<'a>, String> {
        let cosim = std::env::current_exe().map_err(|e| format!("this program's path: {e}"))?;
        let server = match &o.server {
            Some(s) => s.clone(),
            None => {
                let beside = cosim.with_file_name("cosim-server");
                if beside.exists() {
                    beside
                } else {
                    PathBuf::from("cosim-server")
                }
            }
        };
        let scene_text = match plan.scene() {
            Some(p) if p.extension().is_some_and(|e| e == "toml") => Some(
                std::fs::read_to_string(&p)
                    .map_err(|e| format!("{}: cannot read: {e}", p.display()))?,
            ),
            Some(p) if !p.exists() => return Err(format!("{}: no such scene", p.display())),
            Some(_) => None,
            // The server's own reference scene, whose values a sweep may
            // set as a file's.
            None => Some(cosim_shared::scenes::REFERENCE.to_string()),
        };
        Ok(Runner {
            plan,
            out: o.out.clone(),
            server,
            cosim,
            scene_text,
            tag: format!("sweep{}", std::process::id()),
        })
    }

    /// Whether run `run` has its summary, for the same parameters.
    pub fn done(&self, run: &Run) -> bool {
        let dir = folder(&self.out, run.index);
        let same =
            std::fs::read_to_string(dir.join("params.json")).is_ok_and(|p| p == params_json(run));
        same && dir.join("summary.json").exists()
    }

    /// Runs `run`; "ok", or what went wrong.
    pub fn run(&self, run: &Run) -> String {
        match self.try_run(run) {
            Ok(()) => "ok".into(),
            Err(e) => {
                let dir = folder(&self.out, run.index);
                let _ = std::fs::write(dir.join("status"), &e);
                e
            }
        }
    }

    fn try_run(&self, run: &Run) -> Result<(), String> {
        let dir = folder(&self.out, run.index);
        if dir.exists() {
            std::fs::remove_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        std::fs::write(dir.join("params.json"), params_json(run))
            .map_err(|e| format!("params.json: {e}"))?;
        let scene: Option<PathBuf> = match (&self.scene_text, self.plan.scene()) {
            (Some(t), p) => {
                let parent = p.as_deref().and_then(Path::parent);
                let parent = parent.filter(|d| !d.as_os_str().is_empty());
                let parent = parent.unwrap_or(Path::new("."));
                let base = std::fs::canonicalize(parent).unwrap_or(parent.to_path_buf());
                let text = scene_with(t, &base, run)?;
                let input = dir.join("input.toml");
                std::fs::write(&input, text).map_err(|e| format!("input.toml: {e}"))?;
                Some(input)
            }
            (None, p) => p,
        };
        let s = &self.plan.sweep;
        let outputs = dir.join("out");
        let mut server = Command::new(&self.server);
        let controller = s.controller.as_ref();
        server.arg(if controller.is_some() { "serve" } else { "run" });
        server.args(scene.iter());
        if let Some(d) = s.duration {
            server.args(["--duration", &d.to_string()]);
        }
        if let Some(solver) = &s.solver {
            server.args(["--solver", solver]);
        }
        server.arg("--out").arg(&outputs).arg("--overwrite");
        let domain = format!("{}-{}", self.tag, run.index);
        server.env(DOMAIN_VAR, &domain);
        let log =
            |name: &str| std::fs::File::create(dir.join(name)).map_err(|e| format!("{name}: {e}"));
        server.stdout(Stdio::from(log("server.log")?));
        server.stderr(Stdio::from(log("server.err")?));
        let Some(command) = controller else {
            let status = server
                .status()
                .map_err(|e| format!("cannot start {}: {e}", self.server.display()))?;
            return finish(&dir, &outputs, status.success(), "the server");
        };
        let name = "sweep";
        server.args(["--name", name, "--controllers", "1", "--quiet"]);
        let mut srv =
            Kill(Some(server.spawn().map_err(|e| {
                format!("cannot start {}: {e}", self.server.display())
            })?));
        wait_ready(&domain, name, &mut srv)?;
        let mut line = command
            .replace("{server}", name)
            .replace("{run}", &run.index.to_string())
            .replace("{cosim}", &self.cosim.to_string_lossy());
        let mut ctl = Command::new("sh");
        for (k, v) in &run.params {
            line = line.replace(&format!("{{{k}}}"), &text(v));
            let var: String = k
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() {
                        c.to_ascii_uppercase()
                    } else {
                        '_'
                    }
                })
                .collect();
            ctl.env(format!("COSIM_PARAM_{var}"), text(v));
        }
        ctl.arg("-c")
            .arg(&line)
            .current_dir(self.plan.dir())
            .env(DOMAIN_VAR, &domain)
            .env("COSIM_SERVER", name)
            .env("COSIM_RUN", run.index.to_string())
            .stdout(Stdio::from(log("controller.log")?))
            .stderr(Stdio::from(log("controller.err")?));
        let ctl_status = ctl
            .status()
            .map_err(|e| format!("cannot start the controller: {e}"))?;
        if !ctl_status.success() {
            // The server would wait for it: stopped (dropped) here.
            return Err(format!(
                "the controller exited with {ctl_status} (see controller.err)"
            ));
        }
        let srv_status = srv.wait();
        finish(
            &dir,
            &outputs,
            srv_status.is_some_and(|s| s.success()),
            "the server",
        )
    }
}

/// Waits until server `name` of `domain` has its wake event, the last of
/// the services it creates (it is up), or its process ended, or 30 s went
/// by.
fn wait_ready(domain: &str, name: &str, srv: &mut Kill) -> Result<(), String> {
    use iceoryx2::prelude::*;
    let config = crate::domain::of(domain)?;
    let service = crate::service_name(&cosim_shared::wire::services::wake(name))
        .map_err(|e| e.to_string())?;
    let start = std::time::Instant::now();
    loop {
        let up = ipc::Service::does_exist(&service, &config, MessagingPattern::Event)
            .map_err(|e| format!("cannot look up the server: {e:?}"))?;
        if up {
            return Ok(());
        }
        if let Some(c) = srv.0.as_mut() {
            if let Ok(Some(status)) = c.try_wait() {
                return Err(format!("the server exited with {status} (see server.err)"));
            }
        }
        if start.elapsed() > std::time::Duration::from_secs(30) {
            return Err("the server did not come up in 30 s".into());
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
}

/// The run's summary moved up to its folder, or why there is none.
fn finish(dir: &Path, outputs: &Path, ok: bool, who: &str) -> Result<(), String> {
    if !ok {
        return Err(format!("{who} failed (see server.err)"));
    }
    std::fs::copy(outputs.join("summary.json"), dir.join("summary.json"))
        .map(|_| ())
        .map_err(|e| format!("no summary.json: {e}"))
}

/// A child process killed if still running when dropped.
struct Kill(Option<std::process::Child>);

impl Kill {
    fn wait(&mut self) -> Option<std::process::ExitStatus> {
        self.0.take().and_then(|mut c| c.wait().ok())
    }
}

impl Drop for Kill {
    fn drop(&mut self) {
        if let Some(c) = self.0.as_mut() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// A run's parameters as JSON, in the order of their names.
pub fn params_json(run: &Run) -> String {
    let mut m = serde_json::Map::new();
    for (k, v) in &run.params {
        let j = serde_json::to_value(v).unwrap_or(serde_json::Value::Null);
        m.insert(k.clone(), j);
    }
    serde_json::Value::Object(m).to_string()
}
