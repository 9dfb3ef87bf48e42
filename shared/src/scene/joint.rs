//! `[[joint]]`: what a joint leaves free, its limits and motor.

use serde::{Deserialize, Serialize};

use super::sim::default_true;

/// What a joint leaves free between its two sides.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum JointKind {
    /// The anchor points stay together; every rotation is free (3 rows).
    Spherical,
    /// A hinge: the anchors stay together and the bodies turn only about
    /// `axis` (5 rows).
    Revolute,
    /// The two sides move as one (6 rows).
    Fixed,
    /// A slider: no relative rotation, and the anchors move apart only
    /// along `axis` (5 rows).
    Prismatic,
}

/// `[[joint]]`: a bilateral joint between two bodies or a body and the world.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct JointDesc {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: JointKind,
    /// `"world"` or a body name.
    pub body_a: String,
    pub body_b: String,
    /// World point at t = 0, fixed in both bodies from then on.
    pub anchor: [f64; 3],
    /// `revolute`: the hinge axis, a world direction at t = 0, fixed in
    /// both bodies from then on; `prismatic`: the sliding direction at
    /// t = 0, fixed in body_a (any length but zero). Only for these two.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// Constant joint torque: `+torque` on body_b, `-torque` on body_a.
    /// Not for a prismatic joint, whose effort is a force.
    #[serde(default)]
    pub torque: [f64; 3],
    /// `prismatic` only: constant force (N, world frame) on body_b at its
    /// anchor, its opposite on body_a at the same point; its part along
    /// the axis drives the slider (the joint holds the rest).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force: Option<[f64; 3]>,
    /// Whether the two bodies' shapes touch each other. MuJoCo and Drake
    /// leave a joint's two bodies out of contact (links overlap at their
    /// hinges); here the default is true, since the notes' scene has
    /// jointed spheres that collide. With the world as one side it changes
    /// nothing: the planes are not the world's body.
    #[serde(default = "default_true")]
    pub collide: bool,
    /// `revolute` and `prismatic` only: the coordinate at t = 0 (rad or m;
    /// default 0), as the bodies are placed: body_b stands turned by it
    /// about the axis (hinge), or its anchor lies `position` along the axis
    /// from `anchor` (slider), from where the coordinate is zero. Within
    /// `range`; a hinge's within [-pi, pi] (MuJoCo's `qpos0`, a URDF
    /// joint's zero beside its start).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<f64>,
    /// `revolute` and `prismatic` only: the coordinate's limits `[lower,
    /// upper]` (rad for a hinge, within [-pi, pi]; m for a slider), with
    /// `lower < upper` (MuJoCo's `range`, URDF's `<limit lower upper>`).
    /// Held by unilateral rows, each with its own stabilisation, as
    /// contacts are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<[f64; 2]>,
    /// Newton restitution of a limit hit, in [0, 1] (0: the coordinate
    /// stops at the limit); only with `range`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit_restitution: Option<f64>,
    /// `revolute` and `prismatic` only: a motor (actuator): a velocity
    /// motor (Rapier's and ODE's joint motor), a velocity actuator with a
    /// gain, or a position servo (MuJoCo's velocity and position
    /// actuators with a force range), implicit in the step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motor: Option<MotorDesc>,
    /// The largest effort of the joint's held input (N m, or N for a
    /// slider), > 0: a controller's torque and the scene's `torque` or
    /// `force` are clamped to it at each step (a hinge's or slider's part
    /// along the axis, a spherical joint's length), and each clamped step
    /// is counted (a URDF's `<limit effort>`, MuJoCo's actuator
    /// `forcerange` and `ctrlrange`). Not for a fixed joint. Default: no
    /// bound.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_effort: Option<f64>,
    /// `revolute` and `prismatic` only: this joint's coordinate follows
    /// another's, `q = multiplier q_leader + offset` (a URDF `<mimic>`,
    /// an MJCF `<equality><joint>` with a linear `polycoef`), held by one
    /// bilateral row across the two joints' bodies, so that the follower
    /// pushes back on the leader as a gear train does.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mimic: Option<MimicDesc>,
    /// Not for a fixed joint: the inertia of a rotor geared to the joint
    /// (kg m^2 for a hinge, each of a spherical joint's three axes; kg for
    /// a slider), >= 0: kinetic energy `armature x'^2 / 2` on the
    /// coordinate's rate, MuJoCo's joint `armature` (a motor's reflected
    /// inertia). Default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub armature: Option<f64>,
}

/// A coupling of a joint's coordinate to another's (`JointDesc::mimic`).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MimicDesc {
    /// The leader: a revolute or prismatic joint's name (not this one).
    pub joint: String,
    /// Default 1 (URDF's).
    #[serde(default = "one")]
    pub multiplier: f64,
    /// Rad or m, the follower's units; default 0.
    #[serde(default)]
    pub offset: f64,
}

fn one() -> f64 {
    1.0
}

/// A joint motor with an effort of at most `max_effort`, one bounded row
/// (`|p| <= max_effort h`), of one of three kinds:
/// - `speed` alone: the coordinate's rate held at `speed` (rigid);
/// - `speed` and `kv`: the effort `kv (speed - x')` (a velocity actuator;
///   `speed = 0` is a viscous damper);
/// - `position` and `kp` (and `kd`): the effort `kp (position - x) - kd
///   x'` (a position servo, PD), evaluated at the step's end so that stiff
///   gains hold at any step.
///
/// A controller changes the target: the rate, or the servo's position.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MotorDesc {
    /// The target rate (rad/s for a hinge, m/s for a slider); 0 if absent.
    #[serde(default)]
    pub speed: f64,
    /// A position servo's target coordinate (rad or m), with `kp`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<f64>,
    /// A servo's stiffness (N m/rad or N/m), > 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kp: Option<f64>,
    /// A servo's damping (N m s/rad or N s/m), >= 0; default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kd: Option<f64>,
    /// A velocity actuator's gain (N m s/rad or N s/m), > 0; absent, the
    /// rate is held rigidly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kv: Option<f64>,
    /// The largest torque (N m) or force (N) the motor gives, > 0.
    pub max_effort: f64,
}

impl JointKind {
    pub fn as_str(self) -> &'static str {
        match self {
            JointKind::Spherical => "spherical",
            JointKind::Revolute => "revolute",
            JointKind::Fixed => "fixed",
            JointKind::Prismatic => "prismatic",
        }
    }
}
