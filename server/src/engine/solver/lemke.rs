//! Lemke's complementary pivoting algorithm with covering vector `e = 1` and
//! start `z0 = 0`, made robust in floating point as formulation.md ("Lemke in
//! floating point") prescribes:
//!
//! 1. `q_i` within `1e-13 max|q|` of zero is snapped to zero, and the first
//!    pivot is chosen exactly among the remaining values.
//! 2. Pivots are accepted only above a tolerance relative to the entering
//!    column's largest entry; tiny negative right-hand sides count as zero in
//!    the ratio test.
//! 3. Ratios within `1e-9` (relative) tie, and ties are broken by the
//!    lexicographic rule (compared exactly), which cannot cycle: it is the ratio test of the
//!    problem with `q` perturbed by `(eps, eps^2, ..., eps^n)`, whose tie
//!    breakers are the columns of the basis inverse, i.e. the tableau's `w`
//!    columns. When the artificial `z0` ties, it leaves (the solution is found).
//!
//! 4. The ratio test reads a slightly negative right-hand side as zero
//!    (rule 2). When the pivot on such a row would divide the residue into a
//!    value beyond round-off (`|b| / d > 1e-13 max|rhs|`), the row's
//!    right-hand side is set to exactly zero first, so that the tableau
//!    agrees with the decision. Left, the residue is amplified:
//!    deltasigma_mlcp's `z0 = -1.6e-11` over a pivot of `1.6e-7` made the
//!    entering variable `-1e-4` and failed the verification; zeroed, it is
//!    solved to `5e-12`. The change is a perturbation of `q` of the residue's
//!    size, which the verification bounds. Residues the pivot keeps at
//!    round-off size (the engine's, typically `1e-17` over a pivot of 2) are
//!    left alone, so ordinary paths keep their bits.
//!
//! Every returned `z` is verified against the original `M, q`.

use super::{relative_residual, Lcp, SolveInfo};

const Q_SNAP: f64 = 1e-13;
const PIVOT_TOL: f64 = 1e-9;
const RHS_SNAP: f64 = 1e-13;
const TIE_TOL: f64 = 1e-9;
/// Relative diagonal shift of the regularised retry (see [`Lemke::solve`]).
/// Smaller shifts leave the problem nearly as degenerate and round-off then
/// spoils the path (seen: 1e-10 and 1e-9 end with residuals of 5e-7 and
/// 1e-6 on a closed loop of joints and contacts; 1e-8 with 2.7e-8 in 20
/// pivots).
pub const REGULARIZATION: f64 = 1e-8;
/// Largest accepted relative residual of a regularised answer: its error
/// is `eps z`, a few `REGULARIZATION`s relative.
pub const REGULARIZED_VERIFY_TOL: f64 = 1e-6;
/// Largest accepted relative residual of a returned solution.
pub const VERIFY_TOL: f64 = 1e-8;

/// `Q_SNAP max |q_i|`: entries of `q` (and values computed from it) at or
/// below this are round-off.
fn q_snap(lcp: &Lcp) -> f64 {
    Q_SNAP * lcp.q.iter().fold(0.0f64, |a, &b| a.max(b.abs()))
}

/// How Lemke's algorithm failed, with the data that shows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LemkeError {
    /// The entering column has no positive entry: the path left along a ray.
    /// For a copositive-plus `M` this proves the LCP infeasible.
    RayTermination { pivots: usize, entering: usize },
    /// More pivots than the limit (which grows with `n`).
    PivotLimit { pivots: usize, limit: usize },
    /// The tableau's answer fails verification against `M, q`.
    NumericalBreakdown { pivots: usize, residual: f64 },
}

impl std::fmt::Display for LemkeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LemkeError::RayTermination { pivots, entering } => write!(
                f,
                "ray termination after {pivots} pivots (entering variable {entering})"
            ),
            LemkeError::PivotLimit { pivots, limit } => {
                write!(f, "pivot limit: {pivots} pivots reached the limit {limit}")
            }
            LemkeError::NumericalBreakdown { pivots, residual } => write!(
                f,
                "numerical breakdown after {pivots} pivots: residual {residual:.3e} fails verification"
            ),
        }
    }
}

impl std::error::Error for LemkeError {}

/// The pivot limit for a problem of size `n`.
pub fn pivot_limit(n: usize) -> usize {
    1000 + 50 * n
}

/// Lemke's solver with its scratch space, reused from call to call so that a
/// step allocates nothing once the largest problem has been seen.
#[derive(Debug, Default, Clone)]
pub struct Lemke {
    /// `n x (2n + 2)` row-major tableau `B^-1 [I, -M, -e, q]`.
    tableau: Vec<f64>,
    /// Variable basic in each row: `w_i = i`, `z_i = n + i`, `z0 = 2n`.
    basis: Vec<usize>,
    ties: Vec<usize>,
    /// A lower pivot cap than [`pivot_limit`] (`Params::lemke_max_pivots`).
    pub max_pivots: Option<usize>,
    /// Scratch of [`Lemke::solve_guess`]: the guessed indices, `M_SS` and
    /// the right-hand side.
    guess: Vec<usize>,
    lu: Vec<f64>,
    rhs: Vec<f64>,
}

impl Lemke {
    pub fn new() -> Lemke {
        Lemke::default()
    }

    /// With a lower pivot cap than [`pivot_limit`] (None: that one).
    pub fn with_max_pivots(max_pivots: Option<usize>) -> Lemke {
        Lemke {
            max_pivots,
            ..Lemke::default()
        }
    }

    /// Solves `0 <= M z + q _|_ z >= 0` into `z`.
    ///
    /// When the pivoting fails, it is repeated once on `M + eps I`,
    /// `eps = REGULARIZATION * max |M_ij|` (a constraint-force mixing, as ODE
    /// calls it). A copositive `M` (every contact LCP of the engine is one)
    /// becomes strictly copositive, for which Lemke's method cannot end on a
    /// ray: the homogeneous solutions that make contact LCPs degenerate (a far
    /// contact's free slack, the indeterminate internal impulses of a closed
    /// loop of joints and contacts) are gone. Its answer solves the original
    /// problem up to `w = -eps z`, so it is verified against the original
    /// `M, q` with the looser [`REGULARIZED_VERIFY_TOL`], and the info says
    /// it was regularised. When it fails too, the first error is returned.
    pub fn solve(&mut self, lcp: &Lcp, z: &mut [f64]) -> Result<SolveInfo, LemkeError> {
        let first = match self.solve_plain(lcp, z) {
            Ok(info) => return Ok(info),
            Err(e) => e,
        };
        let eps = REGULARIZATION * lcp.m.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        match self.solve_shifted(lcp, z, eps, REGULARIZED_VERIFY_TOL) {
            Ok(info) => Ok(SolveInfo {
                regularized: true,
                ..info
            }),
            Err(_) => Err(first),
        }
    }

    /// Tries a guess of the solution's support before any pivoting: with
    /// `S = {i : active[i]}`, solves `M_SS z_S = -q_S` (Gaussian elimination
    /// with partial pivoting), `z = 0` elsewhere, and accepts `z` only when
    /// it is nonnegative and passes the same verification as a pivoted
    /// answer (`VERIFY_TOL` against `M, q`: `w_S = 0` and `w >= 0` elsewhere
    /// up to it). `None` when the guess fails; then nothing is claimed and
    /// the caller pivots.
    ///
    /// Why: a resting or steadily sliding contact keeps its support from
    /// step to step, and Lemke's path from `z = 0` walks to it again every
    /// step (about 11 pivots on a 20-unknown resting step); the guess costs
    /// one small factorisation. A different but valid solution is possible
    /// only where the LCP's solution is not unique, and it is verified.
    ///
    /// `slacks` lists the friction blocks of a contact LCP as `(s, first,
    /// count)`: the slack `s` enters only its block's friction rows (`E`),
    /// so when the guess leaves it out it is set to what those rows need,
    /// `s = max(0, max_j -w_j)`, the sliding speed. That is the answer for a
    /// contact without impulse that slides: its `s` is the only positive
    /// unknown of its block, and `M_ss = 0` keeps it out of the system.
    pub fn solve_guess(
        &mut self,
        lcp: &Lcp,
        active: &[bool],
        slacks: &[(usize, usize, usize)],
        z: &mut [f64],
    ) -> Option<SolveInfo> {
        let n = lcp.n;
        if active.len() != n {
            return None;
        }
        self.guess.clear();
        self.guess.extend((0..n).filter(|&i| active[i]));
        let s = self.guess.len();
        if s == 0 {
            return None;
        }
        self.lu.clear();
        self.rhs.clear();
        for &i in &self.guess {
            self.rhs.push(-lcp.q[i]);
            for &j in &self.guess {
                self.lu.push(lcp.m[i * n + j]);
            }
        }
        let scale = self.lu.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        let (a, b) = (&mut self.lu, &mut self.rhs);
        for k in 0..s {
            let p = (k..s)
                .max_by(|&x, &y| a[x * s + k].abs().total_cmp(&a[y * s + k].abs()))
                .unwrap_or(k);
            if a[p * s + k].abs() <= PIVOT_TOL * scale {
                return None;
            }
            if p != k {
                for c in 0..s {
                    a.swap(k * s + c, p * s + c);
                }
                b.swap(k, p);
            }
            for r in k + 1..s {
                let f = a[r * s + k] / a[k * s + k];
                if f != 0.0 {
                    for c in k..s {
                        a[r * s + c] -= f * a[k * s + c];
                    }
                    b[r] -= f * b[k];
                }
            }
        }
        for k in (0..s).rev() {
            let t: f64 = (k + 1..s).map(|c| a[k * s + c] * b[c]).sum();
            b[k] = (b[k] - t) / a[k * s + k];
        }
        z[..n].fill(0.0);
        for (t, &i) in self.guess.iter().enumerate() {
            if b[t].is_nan() || b[t] < 0.0 {
                return None;
            }
            z[i] = b[t];
        }
        // A sliding speed at the round-off of the data is a sticking
        // contact: filled in as 1e-19 it marks the slack active, the next
        // step's guess then carries the wrong support and fails (measured on
        // the reference scene: every other resting step fell back to a full
        // Lemke run of 11-13 pivots). Lemke snaps `q` at the same bound.
        let snap = q_snap(lcp);
        for &(si, first, count) in slacks {
            if active.get(si) != Some(&false) || first + count > n {
                continue;
            }
            let mut s = 0.0f64;
            for j in first..first + count {
                s = s.max(-super::row_slack(lcp, &z[..n], j));
            }
            z[si] = if s > snap { s } else { 0.0 };
        }
        let residual = relative_residual(lcp, &z[..n]);
        (residual <= VERIFY_TOL).then_some(SolveInfo {
            work: 0,
            regularized: false,
            residual,
        })
    }

    /// Lemke's method as the textbook has it (with the floating-point care
    /// above), without the regularised retry: what the solver corpus checks.
    pub fn solve_plain(&mut self, lcp: &Lcp, z: &mut [f64]) -> Result<SolveInfo, LemkeError> {
        self.solve_shifted(lcp, z, 0.0, VERIFY_TOL)
    }

    /// Lemke on `M + shift I`, verified against the original `M, q` to the
    /// relative residual `tol`.
    fn solve_shifted(
        &mut self,
        lcp: &Lcp,
        z: &mut [f64],
        shift: f64,
        tol: f64,
    ) -> Result<SolveInfo, LemkeError> {
        let n = lcp.n;
        z[..n].fill(0.0);
        let snap = q_snap(lcp);
        // The trivial case costs nothing: z = 0 solves it when q >= 0.
        if shift == 0.0 && lcp.q.iter().all(|&qi| qi >= -snap) {
            return Ok(SolveInfo {
                work: 0,
                regularized: false,
                residual: relative_residual(lcp, &z[..n]),
            });
        }

        let width = 2 * n + 2;
        let (z0, rhs) = (2 * n, 2 * n + 1);
        self.tableau.clear();
        self.tableau.resize(n * width, 0.0);
        self.basis.clear();
        for i in 0..n {
            let row = &mut self.tableau[i * width..(i + 1) * width];
            row[i] = 1.0;
            for j in 0..n {
                row[n + j] = -lcp.m[i * n + j];
            }
            row[n + i] -= shift;
            row[z0] = -1.0;
            row[rhs] = if lcp.q[i].abs() <= snap {
                0.0
            } else {
                lcp.q[i]
            };
            self.basis.push(i);
        }

        // First pivot: z0 enters and the most negative q_i leaves. Among equal
        // minima the perturbed problem picks the largest index (its eps^i is
        // the smallest).
        let mut r = 0;
        for i in 0..n {
            if self.tableau[i * width + rhs] <= self.tableau[r * width + rhs] {
                r = i;
            }
        }
        self.pivot(n, r, z0);
        let mut leaving = std::mem::replace(&mut self.basis[r], z0);
        let mut pivots = 1;
        let limit = self
            .max_pivots
            .map_or(pivot_limit(n), |cap| cap.min(pivot_limit(n)));

        while leaving != z0 {
            if pivots >= limit {
                return Err(LemkeError::PivotLimit { pivots, limit });
            }
            let entering = if leaving < n {
                leaving + n
            } else {
                leaving - n
            };
            let r = match self.ratio_test(n, entering) {
                Some(r) => r,
                None => return Err(LemkeError::RayTermination { pivots, entering }),
            };
            // Rule 4 of the module notes: a negative residue that this
            // pivot would amplify beyond round-off is the zero the ratio
            // test took it for.
            let b = self.tableau[r * width + rhs];
            if b < 0.0 {
                let rmax = (0..n).fold(0.0f64, |a, i| a.max(self.tableau[i * width + rhs].abs()));
                if -b / self.tableau[r * width + entering] > RHS_SNAP * rmax {
                    self.tableau[r * width + rhs] = 0.0;
                }
            }
            self.pivot(n, r, entering);
            leaving = std::mem::replace(&mut self.basis[r], entering);
            pivots += 1;
        }

        for (i, &var) in self.basis.iter().enumerate() {
            if (n..2 * n).contains(&var) {
                z[var - n] = self.tableau[i * width + rhs].max(0.0);
            }
        }
        let residual = relative_residual(lcp, &z[..n]);
        if residual <= tol {
            Ok(SolveInfo {
                work: pivots,
                regularized: false,
                residual,
            })
        } else {
            Err(LemkeError::NumericalBreakdown { pivots, residual })
        }
    }

    /// The row that leaves when column `col` enters, or `None` on a ray.
    fn ratio_test(&mut self, n: usize, col: usize) -> Option<usize> {
        let width = 2 * n + 2;
        let rhs = width - 1;
        let t = &self.tableau;
        let dmax = (0..n).fold(0.0f64, |a, i| a.max(t[i * width + col].abs()));
        if dmax == 0.0 || !dmax.is_finite() {
            return None;
        }
        let rmax = (0..n).fold(0.0f64, |a, i| a.max(t[i * width + rhs].abs()));
        let ratio = |i: usize| {
            let b = t[i * width + rhs];
            let b = if b <= RHS_SNAP * rmax { 0.0 } else { b };
            b / t[i * width + col]
        };
        let mut theta = f64::INFINITY;
        for i in 0..n {
            if t[i * width + col] > PIVOT_TOL * dmax {
                theta = theta.min(ratio(i));
            }
        }
        if !theta.is_finite() {
            return None;
        }
        self.ties.clear();
        for i in 0..n {
            // A tie: the ratio within tie_tol of the minimum, or a
            // right-hand side that differs from the minimum's by no more than
            // round-off on the column's scale (two rows that are equal but for
            // round-off, e.g. z0's and a degenerate twin, must tie).
            let d = t[i * width + col];
            if d > PIVOT_TOL * dmax && ratio(i) <= theta * (1.0 + TIE_TOL) + RHS_SNAP * rmax / d {
                self.ties.push(i);
            }
        }
        // The artificial variable leaving ends the path at a solution.
        if let Some(&i) = self.ties.iter().find(|&&i| self.basis[i] == 2 * n) {
            return Some(i);
        }
        // Lexicographic rule over the columns of B^-1 (the w columns). Its
        // comparisons are exact: a tolerance there merges distinct entries
        // and the rule stops being a rule (tobenna, 40 x 40 with 32 zeros in
        // q, then cycles to the pivot limit; exact, it solves in 179 pivots).
        for k in 0..n {
            if self.ties.len() <= 1 {
                break;
            }
            let v = |i: usize| t[i * width + k] / t[i * width + col];
            let vmin = self
                .ties
                .iter()
                .map(|&i| v(i))
                .fold(f64::INFINITY, f64::min);
            self.ties.retain(|&i| v(i) <= vmin);
        }
        self.ties.first().copied()
    }

    /// Gauss-Jordan pivot on `(r, col)`.
    fn pivot(&mut self, n: usize, r: usize, col: usize) {
        let width = 2 * n + 2;
        let (before, rest) = self.tableau.split_at_mut(r * width);
        let (prow, after) = rest.split_at_mut(width);
        let inv = 1.0 / prow[col];
        prow.iter_mut().for_each(|x| *x *= inv);
        prow[col] = 1.0;
        for row in before
            .chunks_exact_mut(width)
            .chain(after.chunks_exact_mut(width))
        {
            let f = row[col];
            if f != 0.0 {
                row.iter_mut()
                    .zip(prow.iter())
                    .for_each(|(x, p)| *x -= f * p);
                row[col] = 0.0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn solve(n: usize, m: &[f64], q: &[f64]) -> Result<(Vec<f64>, SolveInfo), LemkeError> {
        let mut z = vec![0.0; n];
        let info = Lemke::new().solve(&Lcp { n, m, q }, &mut z)?;
        Ok((z, info))
    }

    #[test]
    fn trivial_case_takes_no_pivot() {
        let (z, info) = solve(2, &[2.0, 1.0, 1.0, 2.0], &[1.0, 0.0]).unwrap();
        assert_eq!(z, vec![0.0, 0.0]);
        assert_eq!(info.work, 0);
    }

    #[test]
    fn spd_problem_is_solved_exactly() {
        // M = [[2,1],[1,2]], q = [-5,-6]: both active, z = M^-1 (-q) = [4/3, 7/3].
        let (z, _) = solve(2, &[2.0, 1.0, 1.0, 2.0], &[-5.0, -6.0]).unwrap();
        assert!((z[0] - 4.0 / 3.0).abs() < 1e-14 && (z[1] - 7.0 / 3.0).abs() < 1e-14);
    }

    #[test]
    fn infeasible_problem_ends_on_a_ray() {
        // 0 <= -z - 1 has no solution with z >= 0.
        let e = solve(1, &[-1.0], &[-1.0]).unwrap_err();
        assert!(matches!(e, LemkeError::RayTermination { .. }), "{e}");
    }

    #[test]
    fn a_right_guess_solves_without_pivots_and_a_wrong_one_is_refused() {
        // M = [[2,1],[1,2]], q = [-5, 1]: z = [2.5, 0], w = [0, 3.5].
        let (m, q) = ([2.0, 1.0, 1.0, 2.0], [-5.0, 1.0]);
        let lcp = Lcp { n: 2, m: &m, q: &q };
        let mut lemke = Lemke::new();
        let mut z = [0.0; 2];
        let info = lemke
            .solve_guess(&lcp, &[true, false], &[], &mut z)
            .unwrap();
        assert_eq!((z, info.work), ([2.5, 0.0], 0));
        // Both active: z = M^-1 (-q) = [11/3, -7/3] < 0, refused.
        assert!(lemke
            .solve_guess(&lcp, &[true, true], &[], &mut z)
            .is_none());
        // Only the second: z_2 = -1/2 < 0, refused.
        assert!(lemke
            .solve_guess(&lcp, &[false, true], &[], &mut z)
            .is_none());
    }

    #[test]
    fn degenerate_ties_do_not_cycle() {
        // Three equal rows of q: every ratio ties at every pivot.
        let m = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let (z, _) = solve(3, &m, &[-1.0, -1.0, -1.0]).unwrap();
        assert_eq!(z, vec![1.0, 1.0, 1.0]);
    }
}
