//! Benchmarks of accuracy and robustness (issue #6): the work-precision
//! cases and their scorer, the sweep of our engine, the stress suite.
//! The IPC benchmark lives with the server (`serve::bench`).

pub mod accuracy;
pub mod cases;
pub mod skips;
pub mod stress;
