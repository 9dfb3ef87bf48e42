//! `cosim-server replay DIR`: re-runs a recorded serve session from its
//! `scene.toml` and `replay.csv` and checks the state hash after every
//! step. Determinism is the contract: the same scene and inputs give the
//! same bits on the same build.

use super::frame::state_hash;
use super::log::{read_replay, Op};
use crate::engine::{Engine, Model};
use cosim_shared::Scene;
use nalgebra::Vector3;
use std::path::Path;

/// What a replay found.
#[derive(Debug, Clone, PartialEq)]
pub enum ReplayOutcome {
    /// Every step matched; `cut_at` is the line of `replay.csv` that the
    /// server was writing when it stopped (killed), if it left one: the
    /// steps before it are the ones replayed.
    Identical { steps: u64, cut_at: Option<usize> },
    /// The first step whose state differs: the `n`-th step of the session
    /// (1-based), taken from state `step`.
    Differs {
        n: u64,
        step: u64,
        recorded: u64,
        replayed: u64,
    },
}

pub fn replay(dir: &Path) -> Result<ReplayOutcome, String> {
    let scene = Scene::load(&dir.join("scene.toml")).map_err(|e| e.to_string())?;
    let path = dir.join("replay.csv");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let log = read_replay(&text, &path.display().to_string())?;
    let mut engine = Engine::new(Model::from_scene(&scene));
    let initial = engine.state().clone();
    let mut snapshots = Vec::new();
    let mut n = 0u64;
    for op in log.ops {
        match op {
            Op::Torque { joint, t, .. } => engine
                .set_joint_torque(joint, Vector3::from(t))
                .map_err(|e| format!("{}: {e}", path.display()))?,
            Op::Motor { joint, speed, .. } => engine
                .set_motor_speed(joint, speed)
                .map_err(|e| format!("{}: {e}", path.display()))?,
            Op::Impulse { body, l, a, .. } => engine
                .add_body_impulse(body, Vector3::from(l), Vector3::from(a))
                .map_err(|e| format!("{}: {e}", path.display()))?,
            Op::Step { step, hash } => {
                n += 1;
                if engine.state().step != step {
                    return Err(format!(
                        "{}: step {n} of the session starts from step {step}, the replay is at step {}",
                        path.display(),
                        engine.state().step
                    ));
                }
                engine.step();
                let h = state_hash(&engine);
                if h != hash {
                    return Ok(ReplayOutcome::Differs {
                        n,
                        step,
                        recorded: hash,
                        replayed: h,
                    });
                }
            }
            Op::Reset { .. } => engine.set_state(initial.clone()),
            Op::Snapshot { id, .. } => {
                snapshots.push(engine.state().clone());
                if snapshots.len() as u64 != id {
                    return Err(format!(
                        "{}: snapshot ids out of order at {id}",
                        path.display()
                    ));
                }
            }
            Op::Restore { id, .. } => {
                let s = snapshots
                    .get((id as usize).wrapping_sub(1))
                    .ok_or_else(|| {
                        format!("{}: restore of unknown snapshot {id}", path.display())
                    })?;
                engine.set_state(s.clone());
            }
        }
    }
    Ok(ReplayOutcome::Identical {
        steps: n,
        cut_at: log.cut_at,
    })
}
