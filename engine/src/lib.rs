//! The physics engine: a pure library. No files, no sockets, no iceoryx2;
//! bad numbers are reported in the [`StepReport`], never panicked on.
//!
//! A folder per stage of the step, in layers: a module imports only from
//! the layers below it (`tests/layers.rs` checks it).
//!
//! ```text
//! step        Engine: the step as its stage list (step/mod.rs)
//! measure     energy, penetration, joint error; StepReport
//! sleep       islands at rest put to sleep, woken by touch
//! integrate   positions from velocities; projection out of deep penetration
//! solver      mLCP, islands, Lemke, PGS, cone, fallback ladder, pruning
//! constraint  contact, joint, limit and motor rows; applied impulses
//! collision   broad phase, one file per shape pair
//! model       compiled scene, parameters, state, shared kinematics
//! ```

pub mod collision;
pub mod constraint;
pub mod integrate;
pub mod measure;
pub mod model;
pub mod sleep;
pub mod solver;
pub mod step;
#[cfg(test)]
mod testing;

pub use constraint::applied::{InputError, Inputs};
pub use measure::report::{
    ImpulseKind, ImpulseRecord, LadderCounts, Lap, StepError, StepReport, Timings,
};
pub use model::{Attachment, Model, Party, Skips, Turning};
pub use model::{BodyState, State, WarmContact};
pub use solver::fallback::Fallback;
pub use solver::AUTO_PGS_SIZE;
pub use step::Engine;
