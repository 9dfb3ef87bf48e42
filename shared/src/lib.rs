//! Types shared by the server, the clients and the tools: the scene
//! description (a TOML file) with its validation, and the co-simulation
//! contract (service names and wire types, see `docs/protocol.md`).

pub mod scene;
pub mod scenes;
#[cfg(feature = "wire")]
pub mod wire;

/// A float as the shortest text that reads back to the same bits, in plain
/// notation where that stays short and in scientific notation otherwise:
/// every number of a run's CSV files.
pub fn num(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || (1e-4..1e15).contains(&a) || !x.is_finite() {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Header of `states.csv`, written by `run`, `serve` and `cosim record`.
pub const STATES_HEADER: &str = "step,t,body,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz";
/// Header of `joints.csv`, written by the same three: each joint's state
/// beside each state's body rows. `position` and `rate` are a hinge's
/// angle (rad, in (-pi, pi], the joint's `position` at t = 0) and angular rate (rad/s) or a
/// slider's offset (m) and speed (m/s), body b relative to body a about
/// or along the axis; empty for spherical and fixed joints. `anchor_error`
/// (m) and `angle_error` (rad) are what the joint's rows hold to zero
/// (empty in a `cosim record` recording: the frames do not carry them).
pub const JOINTS_HEADER: &str = "step,t,joint,type,position,rate,anchor_error,angle_error";
/// Header of `impulses.csv`, written by the same three.
pub const IMPULSES_HEADER: &str = "step,t,kind,name,body_a,body_b,px,py,pz";

pub use scene::{
    contact_label, BodyDesc, CameraDesc, FrameEntry, FrictionCone, Integrator, JointDesc,
    JointKind, MimicDesc, PgsDesc, PgsStop, PlacedShape, PlaneDesc, PositionUpdate, RobotDesc,
    Scene, SceneError, ServoDesc, ShapeDesc, ShapeEntry, SimDesc, SleepDesc, SolverChoice,
    VisualEntry, VisualKind, DEFAULT_PGS_MAX_ITERATIONS, DEFAULT_PGS_RELATIVE,
    DEFAULT_PGS_TOLERANCE, MAX_FEATURES, WORLD,
};
