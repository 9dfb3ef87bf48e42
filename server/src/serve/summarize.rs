//! `cosim-server summarize DIR`: a `summary.json` rebuilt from the files of
//! a serve run that did not write one (issue 15, defect 10: a killed server
//! leaves its logs but no summary). What the files hold is counted; what
//! only the server knew (wall time, round trips, why it ended) is left out
//! and the summary says that it was rebuilt and where each file ends.

use super::log::{complete_lines, read_replay, Op};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Reads `name` in `dir`: its complete lines and the line cut off, if any.
fn read(dir: &Path, name: &str) -> Result<(String, Option<usize>), String> {
    let path = dir.join(name);
    let text = std::fs::read_to_string(&path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let (complete, cut) = complete_lines(&text);
    Ok((complete.to_string(), cut))
}

/// Where a file ends: its complete rows and the line cut off.
fn ending(rows: usize, cut: Option<usize>) -> serde_json::Value {
    serde_json::json!({ "complete_rows": rows, "cut_at_line": cut })
}

/// The column `name` of a CSV header.
fn column(header: &str, name: &str, file: &str) -> Result<usize, String> {
    header
        .split(',')
        .position(|c| c == name)
        .ok_or_else(|| format!("{file}: no column '{name}' in its header"))
}

/// The summary of the files in `dir`, as JSON.
pub fn rebuild(dir: &Path) -> Result<serde_json::Value, String> {
    let scene = cosim_shared::Scene::load(&dir.join("scene.toml")).map_err(|e| e.to_string())?;

    let (steps_csv, steps_cut) = read(dir, "steps.csv")?;
    // A server killed before its first step may leave steps.csv without
    // even its header: no rows.
    let steps_csv = match steps_csv.trim().is_empty() {
        true => crate::output::STEPS_HEADER.to_string(),
        false => steps_csv,
    };
    let mut lines = steps_csv.lines();
    let header = lines.next().unwrap_or_default();
    let (c_t, c_status, c_pen, c_joint, c_fallback) = (
        column(header, "t", "steps.csv")?,
        column(header, "status", "steps.csv")?,
        column(header, "max_penetration", "steps.csv")?,
        column(header, "max_joint_error", "steps.csv")?,
        column(header, "fallback", "steps.csv")?,
    );
    let (mut steps, mut failures, mut fallback_steps) = (0u64, 0u64, 0u64);
    let (mut t_end, mut max_pen, mut max_joint) = (0.0f64, 0.0f64, 0.0f64);
    let mut first_failure = None;
    for (k, line) in lines.enumerate() {
        let c: Vec<&str> = line.split(',').collect();
        let field = |i: usize| {
            c.get(i)
                .copied()
                .ok_or_else(|| format!("steps.csv:{}: too few columns", k + 2))
        };
        let num = |i: usize| -> Result<f64, String> {
            field(i)?
                .parse()
                .map_err(|_| format!("steps.csv:{}: {:?} is not a number", k + 2, c[i]))
        };
        steps += 1;
        t_end = num(c_t)?;
        max_pen = max_pen.max(num(c_pen)?);
        max_joint = max_joint.max(num(c_joint)?);
        let status = field(c_status)?;
        if status != "solved" && status != "not_converged" {
            failures += 1;
            first_failure.get_or_insert(k as u64 + 1);
        }
        if field(c_fallback)? != "none" {
            fallback_steps += 1;
        }
    }

    let replay_path = dir.join("replay.csv");
    let replay_text = std::fs::read_to_string(&replay_path)
        .map_err(|e| format!("cannot read {}: {e}", replay_path.display()))?;
    let replay = read_replay(&replay_text, &replay_path.display().to_string())?;
    let replay_steps = replay
        .ops
        .iter()
        .filter(|o| matches!(o, Op::Step { .. }))
        .count();
    // With `--record-every N` steps.csv holds every N-th step (and every
    // failed one); replay.csv every step attempted. The state after the
    // last step attempted that did not fail is where the files end.
    if replay_steps as u64 > steps + failures {
        steps = replay_steps as u64 - failures;
        let last = replay.ops.iter().rev().find_map(|o| match o {
            Op::Step { step, .. } => Some(*step),
            _ => None,
        });
        if let Some(k) = last {
            t_end = t_end.max((k + 1) as f64 * scene.sim.dt);
        }
    }

    // One input frame is a row per torque and impulse (one row if it has
    // neither), all with the same step, controller, sequence and status.
    let (inputs_csv, inputs_cut) = read(dir, "inputs.csv")?;
    let mut applied = 0u64;
    let mut rejected: BTreeMap<String, u64> = BTreeMap::new();
    let mut controllers = std::collections::BTreeSet::new();
    let mut last_frame: Option<(String, String, String, String)> = None;
    let mut input_rows = 0usize;
    for line in inputs_csv.lines().skip(1) {
        input_rows += 1;
        let c: Vec<&str> = line.splitn(5, ',').collect();
        let [step, controller, sequence, status, ..] = c[..] else {
            continue;
        };
        let key = (
            step.into(),
            controller.into(),
            sequence.into(),
            status.into(),
        );
        let same = last_frame.as_ref() == Some(&key);
        last_frame = Some(key);
        if same {
            continue;
        }
        controllers.insert(controller.to_string());
        if status == "applied" {
            applied += 1;
        } else {
            *rejected.entry(status.to_string()).or_default() += 1;
        }
    }

    Ok(serde_json::json!({
        "rebuilt_from_files": true,
        "ending": "unknown (no summary.json: the server did not end cleanly)",
        "scene": scene.name(),
        "dt": scene.sim.dt,
        "steps": steps,
        "t_end": t_end,
        "failures": failures,
        "first_failure": first_failure,
        "fallback_steps": fallback_steps,
        "max_penetration": max_pen,
        "max_joint_error": max_joint,
        "replayable_steps": replay_steps,
        "inputs_applied": applied,
        "inputs_rejected": rejected,
        "controllers_seen": controllers.len(),
        "files": {
            "steps.csv": ending(steps as usize, steps_cut),
            "replay.csv": ending(replay.ops.len(), replay.cut_at),
            "inputs.csv": ending(input_rows, inputs_cut),
        },
    }))
}

/// Writes the rebuilt summary to `DIR/summary.json`; a summary the server
/// wrote is never replaced.
pub fn summarize(dir: &Path) -> Result<PathBuf, String> {
    let path = dir.join("summary.json");
    if path.exists() {
        return Err(format!(
            "{} exists: the server wrote it, and it holds more than the files do",
            path.display()
        ));
    }
    let json = rebuild(dir)?;
    let text = serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?;
    std::fs::write(&path, text + "\n")
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(path)
}
