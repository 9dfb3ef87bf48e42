//! `cosim sweep` end to end: real `cosim-server` processes, two at once,
//! each run in its own iceoryx2 domain and folder.

use std::path::{Path, PathBuf};
use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_cosim");

/// `cosim-server` beside `cosim`, built (same profile) if it is not there.
fn server() -> PathBuf {
    let exe = Path::new(EXE).with_file_name("cosim-server");
    if !exe.exists() {
        let release = Path::new(EXE)
            .parent()
            .is_some_and(|d| d.ends_with("release"));
        let status = Command::new(env!("CARGO"))
            .args(["build", "-q", "-p", "cosim-server"])
            .args(release.then_some("--release"))
            .status()
            .expect("cargo build -p cosim-server");
        assert!(status.success());
    }
    exe
}

/// `cosim sweep FILE --out OUT` with `extra`: its exit status and what it
/// said.
fn run_sweep(file: &Path, out: &Path, extra: &[&str]) -> (std::process::ExitStatus, String) {
    let o = Command::new(EXE)
        .arg("sweep")
        .arg(file)
        .arg("--out")
        .arg(out)
        .arg("--server")
        .arg(server())
        .args(extra)
        .output()
        .expect("cosim sweep");
    (o.status, String::from_utf8_lossy(&o.stderr).into_owned())
}

/// [`run_sweep`] that must succeed: what it said.
fn sweep(file: &Path, out: &Path, extra: &[&str]) -> String {
    let (status, err) = run_sweep(file, out, extra);
    assert!(status.success(), "cosim sweep: {err}");
    err
}

/// The table's rows as maps of column to field.
fn table(out: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let text = std::fs::read_to_string(out.join("sweep.csv")).expect("sweep.csv");
    let mut lines = text.lines();
    let head: Vec<String> = lines
        .next()
        .expect("a header")
        .split(',')
        .map(String::from)
        .collect();
    lines
        .map(|l| {
            head.iter()
                .cloned()
                .zip(l.split(',').map(String::from))
                .collect()
        })
        .collect()
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cosim-sweep-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A grid of two steps by two solvers over a shipped scene, two runs at
/// once: four lines, each run at its own step (steps = duration / dt);
/// run 3 alone, in another folder, gives the same states to the byte; a
/// run whose folder is gone is the only one run again (resume).
#[test]
fn a_grid_runs_in_parallel_reproduces_alone_and_resumes() {
    let dir = temp("grid");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes/joint_torques.toml");
    let file = dir.join("grid.toml");
    std::fs::write(
        &file,
        format!(
            "scene = {:?}\nduration = 0.2\nparallel = 2\n[grid]\n\"sim.dt\" = [0.001, 0.002]\n\"sim.solver\" = [\"lemke\", \"pgs\"]\n",
            scene.to_string_lossy()
        ),
    )
    .unwrap();
    let out = dir.join("out");
    sweep(&file, &out, &[]);
    let rows = table(&out);
    assert_eq!(rows.len(), 4);
    for (i, (dt, solver)) in [
        (0.001, "lemke"),
        (0.001, "pgs"),
        (0.002, "lemke"),
        (0.002, "pgs"),
    ]
    .into_iter()
    .enumerate()
    {
        let r = &rows[i];
        assert_eq!(r["status"], "ok", "{r:?}");
        assert_eq!(r["sim.dt"].parse::<f64>().unwrap(), dt);
        assert_eq!(r["sim.solver"], solver);
        assert_eq!(r["steps"], (0.2 / dt).round().to_string(), "{r:?}");
        assert_eq!(r["failures"], "0");
        let written =
            std::fs::read_to_string(out.join(format!("run-000{i}/out/scene.toml"))).unwrap();
        assert!(
            written.contains(&format!("solver = \"{solver}\"")),
            "{written}"
        );
    }
    let states = |o: &Path| std::fs::read(o.join("run-0003/out/states.csv")).expect("states.csv");
    let alone = dir.join("alone");
    sweep(&file, &alone, &["--only", "3"]);
    assert!(
        states(&out) == states(&alone),
        "run 3 alone differs from run 3 beside others"
    );
    assert!(!alone.join("run-0000").exists());

    let kept = std::fs::metadata(out.join("run-0000/summary.json"))
        .unwrap()
        .modified()
        .unwrap();
    std::fs::remove_dir_all(out.join("run-0001")).unwrap();
    let said = sweep(&file, &out, &[]);
    assert!(said.contains("1 runs to do (3 done before)"), "{said}");
    assert_eq!(
        std::fs::metadata(out.join("run-0000/summary.json"))
            .unwrap()
            .modified()
            .unwrap(),
        kept
    );
    assert!(table(&out).iter().all(|r| r["status"] == "ok"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A controller in lockstep per run: the reference scene's PD at two
/// target elevations, both servers named "sweep" and running at once (in
/// one domain the second would be refused). Each ends near its own
/// target, which the controller's parameter set.
#[test]
fn each_run_has_its_controller_in_its_own_domain() {
    let dir = temp("pd");
    let file = dir.join("pd.toml");
    std::fs::write(
        &file,
        "duration = 1.0\nparallel = 2\ncontroller = \"{cosim} --name {server} pd --elevation {elevation}\"\n[grid]\nelevation = [5, 25]\n",
    )
    .unwrap();
    let out = dir.join("out");
    sweep(&file, &out, &[]);
    let rows = table(&out);
    assert!(
        rows.iter()
            .all(|r| r["status"] == "ok" && r["steps"] == "1000"),
        "{rows:?}"
    );
    // The lockstep server's summary has the energy figures `run`'s has.
    for r in &rows {
        for f in ["energy_initial", "energy_final", "max_energy_rise"] {
            assert!(r[f].parse::<f64>().is_ok(), "{f}: {r:?}");
        }
    }
    for (i, target) in [5.0, 25.0].into_iter().enumerate() {
        let log = std::fs::read_to_string(out.join(format!("run-000{i}/controller.log"))).unwrap();
        let final_deg: f64 = log
            .split("final elevation ")
            .nth(1)
            .and_then(|s| s.split_whitespace().next())
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("{log}"));
        assert!((final_deg - target).abs() < 1.0, "run {i}: {log}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The shipped example sweep runs to the end: four runs, all ok.
#[test]
fn the_shipped_sweep_runs() {
    let dir = temp("shipped");
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/sweeps/grid.toml");
    sweep(&file, &dir, &[]);
    let rows = table(&dir);
    assert_eq!(rows.len(), 4);
    assert!(
        rows.iter()
            .all(|r| r["status"] == "ok" && r["failures"] == "0"),
        "{rows:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Without a scene the sweep runs the built-in reference scene, whose
/// values it sets as a file's: two steps, twice as many steps at the
/// finer one.
#[test]
fn the_reference_scenes_values_are_swept_too() {
    let dir = temp("reference");
    let file = dir.join("ref.toml");
    std::fs::write(
        &file,
        "duration = 0.2\n[grid]\n\"sim.dt\" = [0.001, 0.002]\n",
    )
    .unwrap();
    let out = dir.join("out");
    sweep(&file, &out, &[]);
    let steps: Vec<String> = table(&out).iter().map(|r| r["steps"].clone()).collect();
    assert_eq!(steps, ["200", "100"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run that cannot be made (a value set on a body the scene does not
/// have) fails alone: its line says why, the others run, and the sweep
/// exits with 1 so that a scheduler sees it.
#[test]
fn a_failed_run_is_said_in_its_line_and_the_exit_status() {
    let dir = temp("failed");
    let file = dir.join("bad.toml");
    std::fs::write(
        &file,
        "duration = 0.1\n[[run]]\n\"sim.dt\" = 0.001\n[[run]]\n\"body.nobody.mass\" = 2.0\n",
    )
    .unwrap();
    let out = dir.join("out");
    let (status, err) = run_sweep(&file, &out, &[]);
    assert_eq!(status.code(), Some(1));
    assert!(err.contains("1 of 2 runs did not end well: [1]"), "{err}");
    let rows = table(&out);
    assert_eq!(rows[0]["status"], "ok");
    assert!(rows[1]["status"].contains("no body named"), "{rows:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
