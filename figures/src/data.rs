//! Reads a run's files back (`scene.toml`, `states.csv`, `joints.csv`,
//! `impulses.csv`, `steps.csv`): plots are drawn from the files alone, so a recording made
//! during a co-simulation is drawn exactly like an offline run.

use super::PlotError;
use std::collections::BTreeMap;
use std::path::Path;

/// One body's trajectory, one entry per recorded step.
#[derive(Debug, Clone, Default)]
pub struct BodyTrack {
    pub name: String,
    /// `[x, y, z, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz]` per step.
    pub rows: Vec<[f64; 13]>,
}

/// A joint's name and the bodies it ties (`world` for the world).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JointEnds {
    pub name: String,
    pub body_a: String,
    pub body_b: String,
}

/// A hinge's or slider's coordinate from `joints.csv`, per recorded state
/// (`t` as in [`RunData::t`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JointCoordinate {
    pub name: String,
    /// `revolute` (rad, rad/s) or `prismatic` (m, m/s).
    pub kind: String,
    /// `(position, rate)` per recorded state.
    pub values: Vec<(f64, f64)>,
}

/// Everything a figure or the animation needs.
#[derive(Debug, Clone, Default)]
pub struct RunData {
    /// Time of each recorded state (step 0 first).
    pub t: Vec<f64>,
    pub bodies: Vec<BodyTrack>,
    /// `steps.csv` columns by name, one value per step (steps 1..).
    pub steps: BTreeMap<String, Vec<f64>>,
    /// Time of each step report.
    pub step_t: Vec<f64>,
    /// Impulse series by `(kind, name)`: one impulse vector per step
    /// (index `step - 1`), `None` where the file has no row (the contact
    /// was not active, or the joint impulse zero).
    pub impulses: BTreeMap<(String, String), Vec<Option<[f64; 3]>>>,
    /// The scene's joints (from `scene.toml`; none where it is missing or
    /// does not parse, and then no joint angles are drawn).
    pub joints: Vec<JointEnds>,
    /// The hinges' and sliders' coordinates (from `joints.csv`; none where
    /// the file is missing, as in a recording of a co-simulation).
    pub coordinates: Vec<JointCoordinate>,
    /// The first step report whose status says it failed: its time, the
    /// step that failed (one past the state it left unchanged, which its
    /// row names) and status.
    pub first_failure: Option<(f64, u64, String)>,
}

fn read(dir: &Path, name: &str) -> Result<String, PlotError> {
    let path = dir.join(name);
    std::fs::read_to_string(&path).map_err(|e| PlotError::Read(format!("{}: {e}", path.display())))
}

fn parse(path: &str, line: usize, field: &str, text: &str) -> Result<f64, PlotError> {
    text.trim()
        .parse::<f64>()
        .map_err(|_| PlotError::Read(format!("{path}:{line}: {field} = {text:?} is not a number")))
}

/// The rows of `joints.csv` with a coordinate (hinges and sliders), for
/// the `states` recorded states (a partial last state is cut, as there).
fn coordinates(text: &str, states: usize) -> Result<Vec<JointCoordinate>, PlotError> {
    let mut out: Vec<JointCoordinate> = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        if cols.len() != 8 || cols[4].is_empty() {
            continue;
        }
        let value = |i: usize, field: &str| parse("joints.csv", k + 1, field, cols[i]);
        let (position, rate) = (value(4, "position")?, value(5, "rate")?);
        let c = match out.iter().position(|c| c.name == cols[2]) {
            Some(i) => &mut out[i],
            None => {
                out.push(JointCoordinate {
                    name: cols[2].to_string(),
                    kind: cols[3].to_string(),
                    values: Vec::new(),
                });
                out.last_mut().expect("just pushed")
            }
        };
        c.values.push((position, rate));
    }
    for c in &mut out {
        c.values.truncate(states);
    }
    Ok(out)
}

impl RunData {
    pub fn load(dir: &Path) -> Result<RunData, PlotError> {
        let mut data = RunData::default();
        let states = read(dir, "states.csv")?;
        let mut body_index: BTreeMap<String, usize> = BTreeMap::new();
        for (k, line) in states.lines().enumerate().skip(1) {
            let cols: Vec<&str> = line.split(',').collect();
            if cols.len() != 16 {
                // A run stopped mid-write leaves at most one partial last line.
                continue;
            }
            let step = parse("states.csv", k + 1, "step", cols[0])? as usize;
            let t = parse("states.csv", k + 1, "t", cols[1])?;
            let name = cols[2].to_string();
            let i = *body_index.entry(name.clone()).or_insert_with(|| {
                data.bodies.push(BodyTrack {
                    name,
                    rows: Vec::new(),
                });
                data.bodies.len() - 1
            });
            let mut row = [0.0; 13];
            for (j, v) in row.iter_mut().enumerate() {
                *v = parse("states.csv", k + 1, "state", cols[3 + j])?;
            }
            if data.t.len() <= step {
                data.t.push(t);
            }
            data.bodies[i].rows.push(row);
        }
        // Keep only the steps every body has (a partial last step is cut).
        let n = data.bodies.iter().map(|b| b.rows.len()).min().unwrap_or(0);
        data.t.truncate(n);
        for b in &mut data.bodies {
            b.rows.truncate(n);
        }
        if n == 0 {
            return Err(PlotError::Read(format!(
                "{}: no states",
                dir.join("states.csv").display()
            )));
        }

        let steps = read(dir, "steps.csv")?;
        let mut lines = steps.lines();
        let header: Vec<String> = lines
            .next()
            .unwrap_or("")
            .split(',')
            .map(str::to_string)
            .collect();
        for (k, line) in lines.enumerate() {
            let cols: Vec<&str> = line.split(',').collect();
            if cols.len() != header.len() {
                continue;
            }
            let status = header.iter().position(|h| h == "status").map(|i| cols[i]);
            if let (None, Some(status)) = (&data.first_failure, status) {
                // `not_converged`: the iterative solver's answer, taken
                // (the state advanced); any other status failed the step.
                if status != "solved" && status != "not_converged" {
                    let t = cols[1].parse().unwrap_or(f64::NAN);
                    let step = cols[0].parse::<u64>().map_or(0, |k| k + 1);
                    data.first_failure = Some((t, step, status.to_string()));
                }
            }
            for (name, v) in header.iter().zip(&cols) {
                if let Ok(x) = v.parse::<f64>() {
                    data.steps.entry(name.clone()).or_default().push(x);
                } else if !v.is_empty()
                    && !["solver", "status", "rung", "fallback"].contains(&name.as_str())
                {
                    return Err(PlotError::Read(format!(
                        "steps.csv:{}: {name} = {v:?} is not a number",
                        k + 2
                    )));
                }
            }
        }
        data.step_t = data.steps.get("t").cloned().unwrap_or_default();

        let nsteps = data.step_t.len();
        let impulses = read(dir, "impulses.csv")?;
        for (k, line) in impulses.lines().enumerate().skip(1) {
            let cols: Vec<&str> = line.split(',').collect();
            if cols.len() != 9 {
                continue;
            }
            let step = parse("impulses.csv", k + 1, "step", cols[0])? as usize;
            if step == 0 || step > nsteps {
                continue;
            }
            let mut p = [0.0; 3];
            for (j, v) in p.iter_mut().enumerate() {
                *v = parse("impulses.csv", k + 1, "impulse", cols[6 + j])?;
            }
            let series = data
                .impulses
                .entry((cols[2].to_string(), cols[3].to_string()))
                .or_insert_with(|| vec![None; nsteps]);
            series[step - 1] = Some(p);
        }
        if let Ok(joints) = std::fs::read_to_string(dir.join("joints.csv")) {
            data.coordinates = coordinates(&joints, data.t.len())?;
        }
        if let Ok(scene) = cosim_shared::Scene::load(&dir.join("scene.toml")) {
            data.joints = scene
                .joints
                .into_iter()
                .map(|j| JointEnds {
                    name: j.name,
                    body_a: j.body_a,
                    body_b: j.body_b,
                })
                .collect();
        }
        Ok(data)
    }

    /// The part of the run from time `from` to `to` (either open): the
    /// states, step reports and impulses in that window.
    pub fn window(mut self, from: Option<f64>, to: Option<f64>) -> RunData {
        let inside = |t: f64| from.is_none_or(|f| t >= f) && to.is_none_or(|e| t <= e);
        let keep_states: Vec<bool> = self.t.iter().map(|&t| inside(t)).collect();
        let keep_steps: Vec<bool> = self.step_t.iter().map(|&t| inside(t)).collect();
        fn pick<T: Clone>(v: &[T], keep: &[bool]) -> Vec<T> {
            v.iter()
                .zip(keep)
                .filter(|(_, &k)| k)
                .map(|(x, _)| x.clone())
                .collect()
        }
        self.t = pick(&self.t, &keep_states);
        for b in &mut self.bodies {
            b.rows = pick(&b.rows, &keep_states);
        }
        self.step_t = pick(&self.step_t, &keep_steps);
        for v in self.steps.values_mut() {
            *v = pick(v, &keep_steps);
        }
        for v in self.impulses.values_mut() {
            *v = pick(v, &keep_steps);
        }
        for c in &mut self.coordinates {
            c.values = pick(&c.values, &keep_states);
        }
        self.first_failure = self.first_failure.filter(|f| inside(f.0));
        self
    }

    /// The run with only the bodies named (in the run's order) and the
    /// contacts that touch one of them; the joints stay.
    /// An unknown name is an error that lists the bodies there are.
    pub fn only_bodies(mut self, names: &[String]) -> Result<RunData, PlotError> {
        if let Some(bad) = names
            .iter()
            .find(|n| !self.bodies.iter().any(|b| &b.name == *n))
        {
            let there: Vec<&str> = self.bodies.iter().map(|b| b.name.as_str()).collect();
            return Err(PlotError::Read(format!(
                "--bodies {bad:?} is not a body of this run; its bodies are {}",
                there.join(", ")
            )));
        }
        self.bodies.retain(|b| names.contains(&b.name));
        self.impulses.retain(|(kind, name), _| {
            kind.starts_with("joint") || name.split('/').any(|part| names.iter().any(|n| n == part))
        });
        Ok(self)
    }

    /// The step size: the time of the first step report over its step.
    pub fn h(&self) -> Option<f64> {
        let step = *self.steps.get("step")?.first()?;
        let t = *self.step_t.first()?;
        (step > 0.0 && t > 0.0).then(|| t / step)
    }

    /// The `steps.csv` column `name` against time.
    pub fn step_series(&self, name: &str) -> Vec<(f64, f64)> {
        self.steps
            .get(name)
            .map(|v| self.step_t.iter().copied().zip(v.iter().copied()).collect())
            .unwrap_or_default()
    }
}
