//! `cosim-server`: the engine (a pure library) and the edges around it: the
//! built-in scenes, the output writers and the command line.

pub mod engine;
pub mod scenes;
