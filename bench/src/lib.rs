//! `cosim-bench`: benchmarks of the engine, with no IPC: the work-precision
//! cases and their scorer (`bench accuracy`), the stress suite, the skips,
//! the seeded random scenes (`bench robust`) and the piles (`bench pile`),
//! and the scene text they are written in. `cosim-server bench` runs them;
//! the IPC benchmark lives with the server (`serve/bench.rs`), and so does
//! `bench fuzz`, which feeds the server's own input checks.

pub mod accuracy;
pub mod cases;
pub mod pile;
pub mod robust;
pub mod skips;
pub mod stress;
pub mod text;

/// Largest distance between corresponding points of two lists of positions
/// (the bodies of one frame of two runs).
pub fn farthest(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter().zip(b).fold(0.0, |d, (p, q)| {
        d.max(((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt())
    })
}
