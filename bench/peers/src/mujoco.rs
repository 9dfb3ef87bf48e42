//! MuJoCo through its Python package: `mujoco_case.py` builds the MJCF from
//! our scene, steps it, writes the trajectory and times whole runs with
//! `mujoco.rollout`; the trajectory is scored here by our `Scorer`.

use cosim_bench::accuracy::{no_figure, Point, Trajectory};
use cosim_bench::cases::{corner_forces, CaseId, Pose, Sample, Scorer};
use cosim_engine::Model;
use cosim_shared::Scene;
use std::path::PathBuf;
use std::process::Command;

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/mujoco_case.py");

/// MuJoCo's version, or why it cannot be used.
pub fn available(python: &str) -> Result<String, String> {
    let out = Command::new(python)
        .args([
            "-c",
            "import mujoco, mujoco.rollout; print(mujoco.__version__)",
        ])
        .output()
        .map_err(|e| format!("{python}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "the mujoco package does not import (pip install mujoco): {}",
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("")
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn field<'a>(json: &'a str, key: &str) -> Option<&'a str> {
    let at = json.find(&format!("\"{key}\": "))? + key.len() + 4;
    let rest = &json[at..];
    let end = rest.find([',', '}']).unwrap_or(rest.len());
    Some(rest[..end].trim().trim_matches('"'))
}

/// The scene with each body's inertia written out as our engine takes it,
/// so that MuJoCo's bodies have ours and not its own geoms' (its capsule's
/// need not be the same solid).
fn with_inertia(scene: &Scene) -> Scene {
    let mut out = scene.clone();
    for (b, body) in out.bodies.iter_mut().zip(Model::from_scene(scene).bodies) {
        let j = body.inertia;
        b.inertia = Some([
            j[(0, 0)],
            j[(1, 1)],
            j[(2, 2)],
            j[(0, 1)],
            j[(0, 2)],
            j[(1, 2)],
        ]);
    }
    out
}

pub fn run(
    python: &str,
    integrator: &str,
    case: CaseId,
    h: f64,
    reference: Option<&Trajectory>,
) -> Result<Point, String> {
    let scene = case.scene(h, 8).map_err(|e| e.to_string())?;
    let dir = std::env::temp_dir().join(format!("cosim-peers-{}-{integrator}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let toml: PathBuf = dir.join(format!("{}.toml", case.key()));
    let bin: PathBuf = dir.join(format!("{}.bin", case.key()));
    std::fs::write(&toml, with_inertia(&scene).to_toml()).map_err(|e| e.to_string())?;
    let labels: Vec<&str> = if case == CaseId::Corner {
        corner_forces().iter().map(|(l, _)| *l).collect()
    } else {
        Vec::new()
    };
    let out = Command::new(python)
        .arg(SCRIPT)
        .arg(&toml)
        .arg(&bin)
        .arg(labels.join(","))
        .arg(integrator)
        .output()
        .map_err(|e| format!("{python}: {e}"))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).to_string());
    }
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    let seconds: f64 = field(&stdout, "seconds")
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| format!("no timing in {stdout:?}"))?;
    let bytes = std::fs::read(&bin).map_err(|e| e.to_string())?;
    let _ = std::fs::remove_dir_all(&dir);
    let nb = scene.bodies.len();
    let width = 1 + 13 * nb + labels.len();
    let values: Vec<f64> = bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
        .collect();
    let mut scorer = Scorer::new(case, &scene, reference.cloned());
    let mut s = Sample::default();
    let mut failure = None;
    for (k, row) in values.chunks_exact(width).enumerate() {
        // Time as steps * h, as ours, so that samples line up exactly.
        s.t = (k + 1) as f64 * h;
        s.bodies.clear();
        for i in 0..nb {
            let o = 1 + 13 * i;
            let a = |j: usize| [row[o + j], row[o + j + 1], row[o + j + 2]];
            s.bodies.push(Pose {
                x: a(0),
                q: [row[o + 3], row[o + 4], row[o + 5], row[o + 6]],
                v: a(7),
                w: a(10),
            });
        }
        s.forces.clear();
        for (j, l) in labels.iter().enumerate() {
            s.forces.push((l.to_string(), row[1 + 13 * nb + j]));
        }
        if !row.iter().all(|x| x.is_finite()) {
            failure = Some(format!("step {}: non-finite state", k + 1));
            break;
        }
        scorer.observe(&s);
    }
    let score = scorer.finish();
    let failure = no_figure(failure, &score);
    Ok(Point {
        engine: "mujoco".into(),
        setting: format!("{integrator}, Newton, pyramidal"),
        case,
        h,
        steps: scene.step_count(),
        wall_per_sim_s: seconds / case.duration(),
        score,
        failure,
    })
}
