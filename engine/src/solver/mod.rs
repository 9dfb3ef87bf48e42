//! LCP solvers behind one interface, with one residual measure.
//!
//! The engine reduces each step to the dense LCP `0 <= M z + q  _|_  z >= 0`
//! (formulation.md, "To a pure LCP"). Every solver is judged by the same
//! natural-map residual `||z - max(0, z - w)||` with `w = M z + q`, the
//! measure Siconos uses for its test corpus.

pub mod cone;
pub mod lemke;
pub mod pgs;

pub use lemke::{Lemke, LemkeError, Rung};
pub use pgs::{Pgs, PgsInfo, PgsParams, PgsProblem};

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
