//! A sweep file and the runs it lists: a grid (every combination of its
//! values) and listed runs, each a set of parameters. A parameter whose
//! name has a dot is a scene value by its path (`sim.dt`; an array of
//! tables by its element's name, `body.ball.restitution`); the others are
//! the controller's (`{name}` in its command, `COSIM_PARAM_NAME` in its
//! environment).

use serde::Deserialize;
use std::path::{Path, PathBuf};
use toml::{Table, Value};

/// The sweep file (TOML).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepFile {
    /// Scene (TOML), robot (URDF, MJCF), relative to the sweep file;
    /// absent: the built-in reference scene (its values may be set too).
    pub scene: Option<String>,
    /// Simulated seconds of each run (default: the scene's).
    pub duration: Option<f64>,
    /// `lemke`, `pgs` or `auto` (default: the scene's).
    pub solver: Option<String>,
    /// A controller's command line (run by `sh -c`), stepped in lockstep
    /// with the server: `{name}` is a parameter's value, `{server}` the
    /// server's name, `{cosim}` this program, `{run}` the run's number.
    pub controller: Option<String>,
    /// Runs at once (default: the machine's cores).
    pub parallel: Option<usize>,
    /// Every combination of these values.
    #[serde(default)]
    pub grid: Table,
    /// Runs listed one by one, after the grid's.
    #[serde(default)]
    pub run: Vec<Table>,
}

/// One run: its number and parameters, in the order of their names.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    pub index: usize,
    pub params: Vec<(String, Value)>,
}

/// The sweep: its file read, where it lies, and its runs.
#[derive(Debug)]
pub struct Plan {
    pub file: PathBuf,
    pub sweep: SweepFile,
    pub runs: Vec<Run>,
}

impl Plan {
    /// Reads the sweep file and lists its runs; every problem of the file
    /// is said at once, each naming its key.
    pub fn read(file: &Path) -> Result<Plan, String> {
        let text = std::fs::read_to_string(file)
            .map_err(|e| format!("{}: cannot read: {e}", file.display()))?;
        let sweep: SweepFile =
            toml::from_str(&text).map_err(|e| format!("{}: {e}", file.display()))?;
        let mut problems = Vec::new();
        let mut axes: Vec<(String, Vec<Value>)> = Vec::new();
        for (key, v) in &sweep.grid {
            match v {
                Value::Array(values) if !values.is_empty() => {
                    axes.push((key.clone(), values.clone()))
                }
                _ => problems.push(format!("grid.{key}: a list of one value or more")),
            }
        }
        for (i, r) in sweep.run.iter().enumerate() {
            for (key, v) in r {
                if matches!(v, Value::Array(_) | Value::Table(_)) {
                    problems.push(format!(
                        "run[{i}].{key}: one value (a number, string or boolean)"
                    ));
                }
            }
        }
        for (key, v) in axes
            .iter()
            .flat_map(|(k, vs)| vs.iter().map(move |v| (k, v)))
        {
            if matches!(v, Value::Array(_) | Value::Table(_)) {
                problems.push(format!(
                    "grid.{key}: its values are numbers, strings or booleans"
                ));
            }
        }
        if sweep.parallel == Some(0) {
            problems.push("parallel: at least 1".into());
        }
        if let Some(d) = sweep.duration.filter(|d| !(d.is_finite() && *d > 0.0)) {
            problems.push(format!("duration = {d}: a positive number of seconds"));
        }
        let overrides = axes
            .iter()
            .map(|(k, _)| k)
            .chain(sweep.run.iter().flat_map(|r| r.keys()))
            .any(|k| k.contains('.'));
        if overrides
            && sweep
                .scene
                .as_deref()
                .is_some_and(|s| !s.ends_with(".toml"))
        {
            problems.push("scene: values set by path need a TOML scene".into());
        }
        if !problems.is_empty() {
            return Err(format!("{}:\n  {}", file.display(), problems.join("\n  ")));
        }
        let mut runs: Vec<Run> = Vec::new();
        if !axes.is_empty() {
            let total: usize = axes.iter().map(|(_, vs)| vs.len()).product();
            for n in 0..total {
                // Mixed radix, the last name turning fastest.
                let mut rest = n;
                let mut params: Vec<(String, Value)> = axes
                    .iter()
                    .rev()
                    .map(|(k, vs)| {
                        let v = vs[rest % vs.len()].clone();
                        rest /= vs.len();
                        (k.clone(), v)
                    })
                    .collect();
                params.reverse();
                runs.push(Run {
                    index: runs.len(),
                    params,
                });
            }
        }
        for r in &sweep.run {
            let params = r.iter().map(|(k, v)| (k.clone(), v.clone())).collect();
            runs.push(Run {
                index: runs.len(),
                params,
            });
        }
        if runs.is_empty() {
            runs.push(Run {
                index: 0,
                params: Vec::new(),
            });
        }
        Ok(Plan {
            file: file.to_path_buf(),
            sweep,
            runs,
        })
    }

    /// The sweep file's folder (where its relative paths start and its
    /// controller runs).
    pub fn dir(&self) -> &Path {
        match self.file.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        }
    }

    /// The scene's path, relative to the sweep file.
    pub fn scene(&self) -> Option<PathBuf> {
        self.sweep.scene.as_ref().map(|s| self.dir().join(s))
    }
}

/// A value as text: a string without its quotes.
pub fn text(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// The scene's text with run `run`'s values set by path, its robots'
/// files made absolute (the text is written elsewhere). `dir`: the
/// scene's folder.
pub fn scene_with(scene: &str, dir: &Path, run: &Run) -> Result<String, String> {
    let mut doc: Table = toml::from_str(scene).map_err(|e| format!("the scene: {e}"))?;
    for (key, value) in run.params.iter().filter(|(k, _)| k.contains('.')) {
        set(&mut doc, key, value.clone()).map_err(|e| format!("{key}: {e}"))?;
    }
    if let Some(Value::Array(robots)) = doc.get_mut("robot") {
        for r in robots.iter_mut() {
            if let Some(Value::String(f)) = r.get_mut("file") {
                if Path::new(f.as_str()).is_relative() {
                    *f = dir.join(&*f).to_string_lossy().into_owned();
                }
            }
        }
    }
    toml::to_string(&doc).map_err(|e| format!("the scene: {e}"))
}

/// Sets `path` (dot-separated; an array of tables by its element's
/// `name`) in `doc` to `value`; the last key may be new, the others must
/// exist.
fn set(doc: &mut Table, path: &str, value: Value) -> Result<(), String> {
    let keys: Vec<&str> = path.split('.').collect();
    let mut here = doc;
    let mut i = 0;
    while i + 1 < keys.len() {
        let k = keys[i];
        here = match here.get_mut(k) {
            Some(Value::Table(t)) => t,
            Some(Value::Array(items)) => {
                let name = keys.get(i + 1).copied().filter(|_| i + 2 < keys.len());
                let Some(name) = name else {
                    return Err(format!("{k} is a list: name its element ({k}.NAME.key)"));
                };
                i += 1;
                items
                    .iter_mut()
                    .filter_map(|v| v.as_table_mut())
                    .find(|t| t.get("name").and_then(|n| n.as_str()) == Some(name))
                    .ok_or_else(|| format!("no {k} named {name:?} in the scene"))?
            }
            Some(_) => return Err(format!("{k} holds a value, not a table")),
            None => return Err(format!("the scene has no {k}")),
        };
        i += 1;
    }
    here.insert(keys[keys.len() - 1].to_string(), value);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(text: &str) -> Result<Plan, String> {
        let dir = std::env::temp_dir().join(format!("cosim-plan-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join(format!(
            "{:x}.toml",
            text.len() * 31 + text.bytes().map(usize::from).sum::<usize>()
        ));
        std::fs::write(&f, text).unwrap();
        Plan::read(&f)
    }

    #[test]
    fn a_grid_is_every_combination_then_the_listed_runs() {
        let p = plan("scene = \"s.toml\"\n[grid]\n\"sim.dt\" = [0.001, 0.002]\nkp = [1, 2, 3]\n[[run]]\nkp = 9\n")
            .unwrap();
        let names: Vec<String> = p
            .runs
            .iter()
            .map(|r| {
                r.params
                    .iter()
                    .map(|(k, v)| format!("{k}={}", text(v)))
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .collect();
        assert_eq!(
            names,
            [
                "kp=1 sim.dt=0.001",
                "kp=1 sim.dt=0.002",
                "kp=2 sim.dt=0.001",
                "kp=2 sim.dt=0.002",
                "kp=3 sim.dt=0.001",
                "kp=3 sim.dt=0.002",
                "kp=9"
            ]
        );
        assert_eq!(plan("[grid]\na = [1]\n").unwrap().runs.len(), 1);
        assert_eq!(plan("").unwrap().runs.len(), 1);
    }

    #[test]
    fn a_sweep_files_problems_are_said_at_once() {
        let e = plan("scene = \"r.urdf\"\nparallel = 0\nduration = -1\n[grid]\nkp = []\n\"sim.dt\" = [0.1]\n")
            .unwrap_err();
        for says in ["grid.kp", "parallel", "duration = -1", "need a TOML scene"] {
            assert!(e.contains(says), "{e}");
        }
    }

    #[test]
    fn scene_values_are_set_by_path_and_by_name() {
        let scene = "[sim]\ndt = 0.01\n[[body]]\nname = \"a\"\nmass = 1.0\n[[body]]\nname = \"b\"\nmass = 2.0\n[[robot]]\nfile = \"arm.urdf\"\n";
        let run = Run {
            index: 0,
            params: vec![
                ("body.b.mass".into(), Value::Float(5.0)),
                ("sim.dt".into(), Value::Float(0.002)),
                ("kp".into(), Value::Integer(3)),
            ],
        };
        let out: Table =
            toml::from_str(&scene_with(scene, Path::new("/x"), &run).unwrap()).unwrap();
        assert_eq!(out["sim"]["dt"].as_float(), Some(0.002));
        assert_eq!(out["body"][0]["mass"].as_float(), Some(1.0));
        assert_eq!(out["body"][1]["mass"].as_float(), Some(5.0));
        assert_eq!(out["robot"][0]["file"].as_str(), Some("/x/arm.urdf"));
        let bad = Run {
            index: 3,
            params: vec![("body.c.mass".into(), Value::Float(1.0))],
        };
        let e = scene_with(scene, Path::new("/x"), &bad).unwrap_err();
        assert!(e.contains("body.c.mass: no body named \"c\""), "{e}");
    }
}
