//! `[[robot]]`: a robot description placed in the scene (issue 45, point
//! 5). The scene file names the robot's file; the importer
//! (`cosim_import::scene`) reads it and writes its bodies and joints into
//! the scene before the scene is checked, so the engine never sees one.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

use super::body::identity_quaternion;

/// `[[robot]]`: a URDF or MJCF model placed at a pose, its base floating or fixed, its
/// joints at their initial coordinates.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RobotDesc {
    /// The robot's file (`.urdf`, or `.xml`: MJCF), relative to the scene
    /// file's folder.
    pub file: String,
    /// The robot's bodies and joints are named `name/link` and
    /// `name/joint`; default: the file's stem. Two robots need two names.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Where the file's root frame stands in the world (m).
    #[serde(default)]
    pub position: [f64; 3],
    /// The root frame's orientation, a unit quaternion, scalar first.
    #[serde(default = "identity_quaternion")]
    pub orientation: [f64; 4],
    /// Weld the root link to the world (an arm on a table); default: a
    /// root with mass floats (a legged or mobile base), as the importer's
    /// `--fixed-base` says.
    #[serde(default)]
    pub fixed_base: bool,
    /// The robot's links touch each other (but a joint's two links);
    /// default: they do not, as in PyBullet unless asked.
    #[serde(default)]
    pub self_collision: bool,
    /// Initial joint coordinates by the file's joint names (rad for a
    /// hinge, m for a slider); a joint not named starts at its zero, or at
    /// its nearer limit where the limits exclude zero.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub joints: BTreeMap<String, f64>,
    /// A position servo on every hinge and slider (a joint `motor` with
    /// `position`, `kp`, `kd`), holding its initial coordinate until a
    /// controller sets another; default: the joints are passive.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub servo: Option<ServoDesc>,
    /// MJCF only: the `<key>` whose `qpos` is the initial state; default:
    /// the bodies as written (MuJoCo's `qpos0`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub keyframe: Option<String>,
}

/// `servo = { kp, kd, max_effort }`: the gains of a robot's servos.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ServoDesc {
    /// Stiffness (N m/rad or N/m), > 0.
    pub kp: f64,
    /// Damping (N m s/rad or N s/m), >= 0.
    #[serde(default)]
    pub kd: f64,
    /// The effort bound of every servo (N m or N); default: each joint's
    /// `<limit effort>`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_effort: Option<f64>,
}
