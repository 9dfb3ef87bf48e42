//! LCP solvers behind one interface, with one residual measure.
//!
//! The engine reduces each step to the dense LCP `0 <= M z + q  _|_  z >= 0`
//! (formulation.md, "To a pure LCP"). Every solver is judged by the same
//! natural-map residual `||z - max(0, z - w)||` with `w = M z + q`, the
//! measure Siconos uses for its test corpus.

pub mod cone;
pub mod fallback;
pub mod guess;
pub mod island;
pub mod iterative;
pub mod lemke;
pub mod mlcp;
pub mod pgs;
pub mod prune;
pub mod split;

pub use lemke::{Lemke, LemkeError, Rung};
pub use pgs::{Pgs, PgsInfo, PgsParams, PgsProblem};

use crate::constraint::contact::Contact;
use crate::model::Params;
use cosim_shared::SolverChoice;

/// With `solver = "auto"`, LCPs larger than this go to PGS alone. Measured
/// on piles of spheres in a box (h = 5e-3, n_d = 8, 200 steps, this
/// machine), PGS at its default tolerance against Lemke: 9.0 ms against
/// 1.1 ms per step at n = 150, 71 ms against 75 ms at n = 590. Lemke grows
/// like n^3 (the tableau), matrix-free PGS like its sweeps times n: they
/// cross near n = 600.
pub const AUTO_PGS_SIZE: usize = 600;

/// With `solver = "auto"`, an LCP larger than this whose rigid problem
/// Lemke's first rung cannot solve goes to PGS at once instead of down the
/// rest of the ladder (tighter pivot tolerances, regularisation, then the
/// relaxed and compliant fallbacks: each a full Lemke run of the whole
/// problem). Measured on example-robot-data's `alex_psyonic_hands` (a
/// 454-unknown hand on the floor, 500 steps): 124.7 s with 171 fallback
/// steps, against 18.7 s with none (190 steps by PGS), joint error 1.1e-4
/// against 7.1e-5 m. Smaller LCPs climb the ladder as before: it is cheap
/// there, and exact.
pub const AUTO_ESCAPE_SIZE: usize = AUTO_PGS_SIZE / 4;

/// Whether the step's solver works without the reduced LCP's matrix: PGS,
/// and `auto` where it will pick PGS (the LCP's size, `nc + nf (n_d + 1)`,
/// above [`AUTO_PGS_SIZE`]). The dense matrix of a large LCP is what is
/// slow: measured on the 4,000-sphere pile with `auto`, 21 s of assembly
/// for a step of 35,000 unknowns, then 8 ms of PGS.
pub fn matrix_free(p: &Params, contacts: &[Contact]) -> bool {
    match p.solver {
        SolverChoice::Pgs => true,
        SolverChoice::Lemke => false,
        SolverChoice::Auto => mlcp::lcp_size_of(contacts, p) > AUTO_PGS_SIZE,
    }
}

/// A dense LCP `0 <= M z + q _|_ z >= 0`, `M` row-major `n x n`.
#[derive(Debug, Clone, Copy)]
pub struct Lcp<'a> {
    pub n: usize,
    pub m: &'a [f64],
    pub q: &'a [f64],
}

/// What a successful solve reports.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SolveInfo {
    /// Pivots (Lemke) or iterations (iterative solvers).
    pub work: usize,
    /// Which rung of Lemke's ladder gave the answer (`Other` for the
    /// iterative solvers).
    pub rung: lemke::Rung,
    /// The answer came from the final basis factored again (see
    /// `Lemke::refine`), not the tableau.
    pub refined: bool,
    /// Natural-map residual relative to `||q||` (see [`relative_residual`]).
    pub residual: f64,
}

impl SolveInfo {
    /// The answer is of `M + eps I`, not `M` (Lemke's regularised rung).
    pub fn regularized(&self) -> bool {
        self.rung == Rung::Regularized
    }
}

/// `w_i = (M z + q)_i`.
pub fn row_slack(lcp: &Lcp, z: &[f64], i: usize) -> f64 {
    let row = &lcp.m[i * lcp.n..(i + 1) * lcp.n];
    lcp.q[i] + row.iter().zip(z).map(|(a, b)| a * b).sum::<f64>()
}

/// `w = M z + q`.
pub fn slack(lcp: &Lcp, z: &[f64], w: &mut [f64]) {
    for (i, wi) in w.iter_mut().enumerate().take(lcp.n) {
        *wi = row_slack(lcp, z, i);
    }
}

/// `||z - max(0, z - w)||_2 / ||q||_2` (absolute when `q = 0`), with
/// `w = M z + q` computed from the original data, never from a tableau.
/// Infinite when `z` or `w` is not finite.
pub fn relative_residual(lcp: &Lcp, z: &[f64]) -> f64 {
    let mut sum = 0.0;
    for i in 0..lcp.n {
        let w = row_slack(lcp, z, i);
        if !(w.is_finite() && z[i].is_finite()) {
            return f64::INFINITY;
        }
        let r = z[i] - (z[i] - w).max(0.0);
        sum += r * r;
    }
    let qn = lcp.q.iter().map(|x| x * x).sum::<f64>().sqrt();
    if qn > 0.0 {
        sum.sqrt() / qn
    } else {
        sum.sqrt()
    }
}
