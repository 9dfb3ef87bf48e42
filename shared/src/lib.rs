//! Types shared by the server, the clients and the tools: the scene
//! description (a TOML file) with its validation. Wire types and service
//! names for the co-simulation join them here.

pub mod scene;

pub use scene::{
    BodyDesc, CameraDesc, FrictionCone, JointDesc, JointKind, PlaneDesc, Scene, SceneError,
    SimDesc, SolverChoice,
};
