//! `cosim-server`: the edges around the engine (the `cosim-engine` crate, a
//! pure library, re-exported here as `engine`): the built-in scenes, the
//! output writers, the services and the command line.

pub mod bench;
pub mod cli;
pub mod corpus;
pub mod mcap;
pub use cosim_engine as engine;
pub mod output;
pub mod plot;
pub mod scenes;
pub mod serve;
pub mod urdf;
