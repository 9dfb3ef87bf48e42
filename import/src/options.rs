//! What an importer is asked to add, and what it gives back: the options
//! and results every robot format shares.

use cosim_shared::Scene;
use std::collections::BTreeMap;

/// What the importer adds that the file does not say.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Options {
    /// Weld a root with mass to the world (a fixed-base arm described
    /// without a `world` link). Default: it floats.
    pub fixed_base: bool,
    /// A floor plane under the robot's lowest point. Default: none.
    pub floor: bool,
    /// The robot's links touch each other (but a joint's two links).
    /// Default: they do not, as in PyBullet unless asked.
    pub self_collision: bool,
    /// Initial coordinates of joints by name (rad or m); the others start
    /// at zero, or at the nearer limit where the limits exclude it.
    pub positions: BTreeMap<String, f64>,
    /// A position servo on every hinge and slider, holding its initial
    /// coordinate until a controller sets another; default: passive.
    pub servo: Option<cosim_shared::ServoDesc>,
    /// An MJCF `<key>` by name whose `qpos` is the initial state (MuJoCo
    /// resets to `qpos0`, the bodies as written; so does the importer
    /// unless asked). Not for URDF, which has none.
    pub keyframe: Option<String>,
}

/// A scene read from a robot description, and what the reading has to say about it.
#[derive(Debug, Clone)]
pub struct Imported {
    pub scene: Scene,
    /// What was approximated, merged or left out, one line each.
    pub notes: Vec<String>,
}
