//! Client library for controllers and monitors of a `cosim-server`.
//!
//! The co-simulation services arrive with the iceoryx2 issue; until then this
//! crate only re-exports the shared scene and wire definitions so that
//! clients build against one source of truth.

pub use cosim_shared as shared;
