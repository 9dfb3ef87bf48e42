//! `cosim-server`: the command line and the lockstep server around the
//! engine (the `cosim-engine` crate, a pure library, re-exported here as
//! `engine`): the output writers, the co-simulation services, the Siconos
//! corpus readers of `lcp`, and `bench fuzz`, which feeds the server's own
//! input checks. Figures and recordings are `cosim-figures`, benchmarks
//! `cosim-bench`, importers `cosim-import`.

pub mod cli;
pub mod corpus;
pub use cosim_engine as engine;
pub mod fuzz;
pub mod output;
pub mod progress;
pub mod serve;
