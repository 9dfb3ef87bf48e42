//! Types shared by the server, the clients and the tools: the scene
//! description (a TOML file) with its validation, and the co-simulation
//! contract (service names and wire types, see `docs/protocol.md`).

pub mod scene;
pub mod wire;

pub use scene::{
    BodyDesc, CameraDesc, FrictionCone, JointDesc, JointKind, PlaneDesc, Scene, SceneError,
    SimDesc, SolverChoice,
};
