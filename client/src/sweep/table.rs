//! The sweep's table: one line per run, its parameters and its summary's
//! figures (`sweep.csv` in the sweep's folder).

use super::folder;
use super::plan::{text, Plan, Run};
use std::path::{Path, PathBuf};

/// The summary's fields the table carries, in its order.
const FIGURES: [&str; 9] = [
    "steps",
    "failures",
    "fallback_steps",
    "max_penetration",
    "max_joint_error",
    "max_energy_rise",
    "energy_initial",
    "energy_final",
    "wall_seconds",
];

/// `name=value` pairs of a run, for messages.
pub fn params_text(run: &Run) -> String {
    run.params
        .iter()
        .map(|(k, v)| format!("{k}={}", text(v)))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Writes `sweep.csv` from the runs' folders: a run without a summary is
/// `not run` or what its `status` says.
pub fn write(plan: &Plan, out: &Path) -> Result<PathBuf, String> {
    let mut names: Vec<&str> = Vec::new();
    for r in &plan.runs {
        for (k, _) in &r.params {
            if !names.contains(&k.as_str()) {
                names.push(k);
            }
        }
    }
    let mut csv = String::from("run");
    for n in &names {
        csv += &format!(",{}", quote(n));
    }
    csv += ",status";
    for f in FIGURES {
        csv += &format!(",{f}");
    }
    csv += ",folder\n";
    for r in &plan.runs {
        let dir = folder(out, r.index);
        csv += &r.index.to_string();
        for n in &names {
            let v = r.params.iter().find(|(k, _)| k == n).map(|(_, v)| text(v));
            csv += &format!(",{}", quote(&v.unwrap_or_default()));
        }
        let summary: Option<serde_json::Value> = std::fs::read_to_string(dir.join("summary.json"))
            .ok()
            .and_then(|s| serde_json::from_str(&s).ok());
        let status = match &summary {
            Some(_) => "ok".to_string(),
            None => {
                std::fs::read_to_string(dir.join("status")).unwrap_or_else(|_| "not run".into())
            }
        };
        csv += &format!(",{}", quote(status.trim()));
        for f in FIGURES {
            let v = summary
                .as_ref()
                .and_then(|s| s.get(f))
                .filter(|v| !v.is_null());
            csv += &format!(",{}", v.map_or(String::new(), |v| v.to_string()));
        }
        csv += &format!(",{}\n", quote(&dir.to_string_lossy()));
    }
    let path = out.join("sweep.csv");
    std::fs::write(&path, csv).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path)
}

/// A CSV field, quoted where it needs to be.
fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}
