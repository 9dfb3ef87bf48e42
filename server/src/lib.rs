//! `cosim-server`: the engine (a pure library) and the edges around it: the
//! built-in scenes, the output writers and the command line.

pub mod bench;
pub mod cli;
pub mod corpus;
pub mod engine;
pub mod output;
pub mod plot;
pub mod scenes;
pub mod serve;
