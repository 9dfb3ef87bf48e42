//! A scene file with its robots placed (issue 45, point 5): each
//! `[[robot]]`'s file read by its importer, its bodies and joints named
//! `robot/link` and `robot/joint`, set at the robot's pose and written into
//! the scene, which is then checked as any scene is.

use crate::urdf;
use cosim_shared::{RobotDesc, Scene, SceneError, WORLD};
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion, Vector3};
use std::path::Path;

/// Reads a scene file and places its robots, whose files are found
/// relative to the scene's folder.
pub fn load(path: &Path) -> Result<urdf::Imported, SceneError> {
    let file = path.display().to_string();
    let text = cosim_shared::scene::read_file(path)?;
    let mut scene = Scene::read(&text, &file)?;
    if scene.sim.name.is_none() {
        scene.sim.name = path.file_stem().map(|s| s.to_string_lossy().into_owned());
    }
    place(scene, path.parent(), &file)
}

/// Places `scene`'s robots (their files relative to `dir`) and checks the
/// whole; every robot's problems are said at once.
pub fn place(
    mut scene: Scene,
    dir: Option<&Path>,
    file: &str,
) -> Result<urdf::Imported, SceneError> {
    let robots = std::mem::take(&mut scene.robots);
    let mut notes = Vec::new();
    let mut problems: Vec<String> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for (k, r) in robots.iter().enumerate() {
        let name = r.name.clone().unwrap_or_else(|| {
            Path::new(&r.file)
                .file_stem()
                .map_or("robot".into(), |s| s.to_string_lossy().into_owned())
        });
        let what = format!("robot[{k}] {name:?}");
        if name.is_empty() || name.contains('/') || name == WORLD {
            problems.push(format!(
                "{what}.name: a robot's name is a prefix: not empty, no '/', not \"world\""
            ));
            continue;
        }
        if names.contains(&name) {
            problems.push(format!(
                "{what}: a second robot of this name: give each its own `name`"
            ));
            continue;
        }
        names.push(name.clone());
        let Some(pose) = pose(r) else {
            problems.push(format!(
                "{what}: position {:?} and orientation {:?} must be finite, the orientation not zero",
                r.position, r.orientation
            ));
            continue;
        };
        let path = dir.map_or_else(|| Path::new(&r.file).to_path_buf(), |d| d.join(&r.file));
        if !crate::is_robot(&path) {
            problems.push(format!(
                "{what}.file = {:?}: not a robot description: .urdf (URDF) or .xml (MJCF)",
                r.file
            ));
            continue;
        }
        let options = urdf::Options {
            fixed_base: r.fixed_base,
            floor: false,
            self_collision: r.self_collision,
            positions: r.joints.clone(),
            servo: r.servo,
            keyframe: r.keyframe.clone(),
        };
        match crate::load(&path, options) {
            Ok(robot) => {
                notes.extend(
                    robot
                        .notes
                        .iter()
                        .map(|n| format!("robot {name:?} ({}): {n}", r.file)),
                );
                add(&mut scene, robot.scene, &name, &pose);
            }
            Err(e) => problems.push(format!("{what}: {e}")),
        }
    }
    if !problems.is_empty() {
        return Err(SceneError {
            file: file.into(),
            location: None,
            field: String::new(),
            message: if let [one] = &problems[..] {
                one.clone()
            } else {
                format!("{} problems:\n  {}", problems.len(), problems.join("\n  "))
            },
        });
    }
    scene.validate(file)?;
    Ok(urdf::Imported { scene, notes })
}

/// The robot's pose, if its numbers make one.
fn pose(r: &RobotDesc) -> Option<Isometry3<f64>> {
    let [w, x, y, z] = r.orientation;
    let q = Quaternion::new(w, x, y, z);
    let finite = r
        .position
        .iter()
        .chain(&r.orientation)
        .all(|v| v.is_finite());
    (finite && q.norm() > 1e-9).then(|| {
        Isometry3::from_parts(
            Translation3::from(Vector3::from(r.position)),
            UnitQuaternion::from_quaternion(q),
        )
    })
}

/// Writes `robot`'s bodies and joints into `scene`, named `name/...`, at
/// `pose`; its bodies form the group `name` when its links stay apart.
fn add(scene: &mut Scene, robot: Scene, name: &str, pose: &Isometry3<f64>) {
    let named = |n: &str| {
        if n == WORLD {
            n.to_string()
        } else {
            format!("{name}/{n}")
        }
    };
    let turn = |v: [f64; 3]| -> [f64; 3] { (pose.rotation * Vector3::from(v)).into() };
    let at = |p: [f64; 3]| -> [f64; 3] { (pose * Point3::from(p)).coords.into() };
    for mut b in robot.bodies {
        b.name = named(&b.name);
        b.group = b.group.map(|_| name.to_string());
        b.position = at(b.position);
        let [w, x, y, z] = b.orientation;
        let q = pose.rotation * UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
        b.orientation = [q.w, q.i, q.j, q.k];
        b.velocity = turn(b.velocity);
        b.angular_velocity = turn(b.angular_velocity);
        b.force = turn(b.force);
        for f in &mut b.frame {
            f.name = named(&f.name);
        }
        scene.bodies.push(b);
    }
    for mut j in robot.joints {
        j.name = named(&j.name);
        j.body_a = named(&j.body_a);
        j.body_b = named(&j.body_b);
        j.anchor = at(j.anchor);
        j.axis = j.axis.map(turn);
        j.torque = turn(j.torque);
        j.force = j.force.map(turn);
        if let Some(m) = &mut j.mimic {
            m.joint = named(&m.joint);
        }
        scene.joints.push(j);
    }
}
