//! Benchmarks of accuracy and robustness (issue #6): the work-precision
//! cases and their scorer, the sweep of our engine, the stress suite.
//! The IPC benchmark lives with the server (`serve::bench`).

pub mod accuracy;
pub mod cases;
pub mod fuzz;
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
