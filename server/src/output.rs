//! Writers of a run's output files: `states.csv`, `joints.csv`,
//! `impulses.csv`, `steps.csv` and `summary.json`. Each CSV row is complete per step and the
//! writers are flushed regularly, so a run that stops early leaves readable
//! files.

use crate::engine::{Engine, ImpulseKind, StepReport};
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

pub use cosim_shared::num;
pub use cosim_shared::{IMPULSES_HEADER, JOINTS_HEADER, STATES_HEADER};

/// Whether `dir` holds a run's files already.
pub fn holds_run(dir: &Path) -> bool {
    ["summary.json", "states.csv", "replay.csv"]
        .iter()
        .any(|f| dir.join(f).exists())
}

/// Where a run writes. A folder given (`--out`) that holds a run is
/// refused unless `overwrite`; the default folder, when it holds one,
/// gives way to the first free `NAME-2`, `NAME-3`, ... beside it, so that
/// two runs never write into one folder unasked (said on stderr unless
/// `quiet`).
pub fn run_folder(
    given: Option<&Path>,
    default: PathBuf,
    overwrite: bool,
    quiet: bool,
) -> Result<PathBuf, String> {
    if let Some(dir) = given {
        if holds_run(dir) && !overwrite {
            return Err(format!(
                "{} holds an earlier run; choose another --out, or add --overwrite",
                dir.display()
            ));
        }
        return Ok(dir.to_path_buf());
    }
    if overwrite || !holds_run(&default) {
        return Ok(default);
    }
    let base = default.as_os_str().to_string_lossy().into_owned();
    let free = (2..)
        .map(|k| PathBuf::from(format!("{base}-{k}")))
        .find(|d| !holds_run(d))
        .ok_or_else(|| format!("no free folder beside {base}"))?;
    if !quiet {
        eprintln!(
            "{base} holds an earlier run: writing {} (--overwrite to replace it)",
            free.display()
        );
    }
    Ok(free)
}
pub const STEPS_HEADER: &str = "step,t,solver,status,pivots,residual,lcp_size,contacts_in_lcp,active_contacts,resolves,regularized,max_penetration,max_joint_error,kinetic,potential,energy,energy_midpoint,t_collision,t_assemble,t_solve,t_integrate,t_measure,t_total,shadow_dv,shadow_dw,projected,rung,refined,fallback,compliance,energy_refused,islands,largest_island,sleeping,lemke_islands,pgs_islands,max_joint_angle_error,left_out,smooth_islands,smooth_left";

/// The CSV files of a run.
pub struct Writers {
    dir: PathBuf,
    states: BufWriter<File>,
    joints: BufWriter<File>,
    impulses: BufWriter<File>,
    steps: BufWriter<File>,
    line: String,
}

fn create(dir: &Path, name: &str, header: &str) -> io::Result<BufWriter<File>> {
    let path = dir.join(name);
    let mut w =
        BufWriter::new(File::create(&path).map_err(|e| {
            io::Error::new(e.kind(), format!("cannot create {}: {e}", path.display()))
        })?);
    writeln!(w, "{header}")?;
    Ok(w)
}

impl Writers {
    pub fn create(dir: &Path) -> io::Result<Writers> {
        std::fs::create_dir_all(dir).map_err(|e| {
            io::Error::new(e.kind(), format!("cannot create {}: {e}", dir.display()))
        })?;
        Ok(Writers {
            dir: dir.to_path_buf(),
            states: create(dir, "states.csv", STATES_HEADER)?,
            joints: create(dir, "joints.csv", JOINTS_HEADER)?,
            impulses: create(dir, "impulses.csv", IMPULSES_HEADER)?,
            steps: create(dir, "steps.csv", STEPS_HEADER)?,
            line: String::new(),
        })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// One row per body of the engine's current state.
    pub fn state(&mut self, engine: &Engine) -> io::Result<()> {
        use std::fmt::Write as _;
        let s = engine.state();
        self.line.clear();
        for (b, body) in s.bodies.iter().zip(&engine.model().bodies) {
            let q = b.q.quaternion();
            let _ = write!(self.line, "{},{},{}", s.step, num(s.t), body.name);
            for v in [
                b.x.x, b.x.y, b.x.z, q.w, q.i, q.j, q.k, b.v.x, b.v.y, b.v.z, b.w.x, b.w.y, b.w.z,
            ] {
                let _ = write!(self.line, ",{}", num(v));
            }
            self.line.push('\n');
        }
        self.states.write_all(self.line.as_bytes())?;
        self.joints(engine)
    }

    /// One row per joint of the engine's current state (`JOINTS_HEADER`).
    fn joints(&mut self, engine: &Engine) -> io::Result<()> {
        use crate::engine::constraint::joint;
        use std::fmt::Write as _;
        let s = engine.state();
        self.line.clear();
        for j in &engine.model().joints {
            let (position, rate) = joint::coordinate(j, s)
                .map_or((String::new(), String::new()), |(x, v)| (num(x), num(v)));
            let _ = writeln!(
                self.line,
                "{},{},{},{},{position},{rate},{},{}",
                s.step,
                num(s.t),
                j.name,
                j.kind(),
                num(joint::anchor_error(j, s)),
                num(joint::angle_error(j, s)),
            );
        }
        self.joints.write_all(self.line.as_bytes())
    }

    /// The impulses of the step just taken, where they are not zero.
    pub fn impulses(&mut self, engine: &Engine) -> io::Result<()> {
        use std::fmt::Write as _;
        let model = engine.model();
        let s = engine.state();
        self.line.clear();
        for r in engine.impulses() {
            if r.impulse.iter().all(|x| *x == 0.0) {
                continue;
            }
            let (kind, name) = match r.kind {
                ImpulseKind::Joint => ("joint", model.joints[r.index].name.clone()),
                ImpulseKind::JointTorque => ("joint_torque", model.joints[r.index].name.clone()),
                ImpulseKind::JointLimit => ("joint_limit", model.joints[r.index].name.clone()),
                ImpulseKind::JointMotor => ("joint_motor", model.joints[r.index].name.clone()),
                ImpulseKind::Normal => ("normal", model.contact_name(r.index, r.a, r.b)),
                ImpulseKind::Friction => ("friction", model.contact_name(r.index, r.a, r.b)),
            };
            let _ = writeln!(
                self.line,
                "{},{},{kind},{name},{},{},{},{},{}",
                s.step,
                num(s.t),
                model.party_name(r.a),
                model.party_name(r.b),
                num(r.impulse.x),
                num(r.impulse.y),
                num(r.impulse.z)
            );
        }
        self.impulses.write_all(self.line.as_bytes())
    }

    /// The step report; `shadow` is the largest difference of linear (m/s)
    /// and angular (rad/s) velocities against the other solver, with
    /// `--shadow` (empty columns without).
    pub fn step(&mut self, r: &StepReport, shadow: Option<(f64, f64)>) -> io::Result<()> {
        let t = &r.timings;
        let e = &r.energy;
        let fields = [
            r.step.to_string(),
            num(r.t),
            r.solver.to_string(),
            r.status().to_string(),
            r.pivots.to_string(),
            num(r.residual),
            r.lcp_size.to_string(),
            r.contacts_in_lcp.to_string(),
            r.active_contacts.to_string(),
            r.resolves.to_string(),
            r.regularized.to_string(),
            num(r.max_penetration),
            num(r.max_joint_error),
            num(e.kinetic),
            num(e.potential),
            num(e.total),
            num(e.midpoint),
            num(t.collision),
            num(t.assemble),
            num(t.solve),
            num(t.integrate),
            num(t.measure),
            num(t.total),
            shadow.map_or(String::new(), |s| num(s.0)),
            shadow.map_or(String::new(), |s| num(s.1)),
            r.projected.to_string(),
            r.rung.as_str().to_string(),
            r.refined.to_string(),
            r.fallback.map_or("none", |f| f.as_str()).to_string(),
            num(match r.fallback {
                Some(crate::engine::Fallback::Compliant { eps }) => eps,
                _ => 0.0,
            }),
            u8::from(r.energy_refused).to_string(),
            r.islands.to_string(),
            r.largest_island.to_string(),
            r.sleeping.to_string(),
            r.lemke_islands.to_string(),
            r.pgs_islands.to_string(),
            num(r.max_joint_angle_error),
            r.left_out.to_string(),
            r.smooth_islands.to_string(),
            r.smooth_left.to_string(),
        ];
        writeln!(self.steps, "{}", fields.join(","))
    }

    pub fn flush(&mut self) -> io::Result<()> {
        self.states.flush()?;
        self.joints.flush()?;
        self.impulses.flush()?;
        self.steps.flush()
    }
}

/// The ladder's counts as `summary.json` holds them: steps by the highest
/// rung of Lemke's ladder they needed, refined answers, and the steps that
/// fell back to another formulation (see `engine::solver::fallback`).
/// The energy over a run (J): at the start, after the last step, and the
/// largest rise over one step from the energy before it (the start's,
/// then each step's), so that a step that gains energy is seen whatever
/// gave it (an input, the stabilisation, a projection).
#[derive(Debug, Default, Clone, Copy)]
pub struct EnergyTally {
    pub initial: f64,
    pub last: f64,
    pub max_rise: f64,
    pub max_rise_step: u64,
}

impl EnergyTally {
    /// From the energy of the first state.
    pub fn start(total: f64) -> EnergyTally {
        EnergyTally {
            initial: total,
            last: total,
            ..EnergyTally::default()
        }
    }

    /// After a step: its energy, if it was taken.
    pub fn add(&mut self, r: &StepReport) {
        if r.ok() {
            let rise = r.energy.total - self.last;
            if rise > self.max_rise {
                (self.max_rise, self.max_rise_step) = (rise, r.step);
            }
            self.last = r.energy.total;
        }
    }

    /// The state jumped (a reset, a restore): the next step's rise counts
    /// from `total`, the new state's.
    pub fn jumped(&mut self, total: f64) {
        self.last = total;
    }
}

pub fn ladder_json(c: &crate::engine::LadderCounts) -> serde_json::Value {
    use crate::engine::solver::Rung;
    let mut rungs = serde_json::Map::new();
    for (rung, n) in Rung::LADDER.iter().zip(c.rungs) {
        rungs.insert(rung.as_str().to_string(), n.into());
    }
    serde_json::json!({
        "rungs": rungs,
        "refined": c.refined,
        "relaxed": c.relaxed,
        "compliant": c.compliant,
        "max_compliance": c.max_compliance,
        "energy_refused": c.energy_refused,
    })
}
