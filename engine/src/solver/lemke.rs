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
/// The pivot tolerances of the ladder's first rungs, relative to the
/// entering column's largest entry (rule 2): each rung is a whole new run
/// of the algorithm, verified on its own.
///
/// Why a ladder and not one value: 1e-9 guards against pivoting on
/// round-off in large degenerate problems (the Siconos corpus needs it),
/// but it rejected the right pivot (1.18e-7, 5.0e-10 of its column's
/// largest entry) at pivot 21 of a 20-unknown LCP of the reference scene
/// (step 154,952; numerical rank 8 of 20), whose path then ended on a ray.
/// 1e-10 .. 1e-14 solve it in 22 pivots; a tolerance of 0 breaks the
/// corpus's `tobenna`. So the loose value goes first and the tight ones
/// only where it failed.
pub const PIVOT_TOLS: [f64; 3] = [1e-9, 1e-11, 1e-13];
const RHS_SNAP: f64 = 1e-13;
const TIE_TOL: f64 = 1e-9;
/// Relative diagonal shift of the regularised rung (see [`Lemke::solve`]).
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
/// A pivoted answer with a residual above this is refined: the final basis
/// is factored again from the original data (see [`Lemke::refine`]).
/// Below it, the tableau's answer is as good as a refactorisation's, and
/// the common path costs nothing more.
const REFINE_ABOVE: f64 = 1e-12;

/// `Q_SNAP max |q_i|`: entries of `q` (and values computed from it) at or
/// below this are round-off.
fn q_snap(lcp: &Lcp) -> f64 {
    Q_SNAP * lcp.q.iter().fold(0.0f64, |a, &b| a.max(b.abs()))
}

/// Which rung of [`Lemke::solve`]'s ladder gave the answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Rung {
    /// The last step's support (see [`Lemke::solve_guess`]): no pivoting.
    Guess,
    /// A pivoted run with pivot tolerance `PIVOT_TOLS[k]` (`z = 0` when
    /// `q >= 0` counts as `Pivoted(0)` with no pivot).
    Pivoted(u8),
    /// A pivoted run on `M + eps I` (see [`REGULARIZATION`]).
    Regularized,
    /// Not from Lemke (an iterative solver's answer).
    #[default]
    Other,
}

impl Rung {
    /// A short name for step reports and summaries.
    pub fn as_str(self) -> &'static str {
        match self {
            Rung::Guess => "guess",
            Rung::Pivoted(0) => "pivot_1e-9",
            Rung::Pivoted(1) => "pivot_1e-11",
            Rung::Pivoted(_) => "pivot_1e-13",
            Rung::Regularized => "regularized",
            Rung::Other => "other",
        }
    }

    /// Every rung Lemke reports, in ladder order: the keys of the per-run
    /// counts.
    pub const LADDER: [Rung; 5] = [
        Rung::Guess,
        Rung::Pivoted(0),
        Rung::Pivoted(1),
        Rung::Pivoted(2),
        Rung::Regularized,
    ];

    /// The higher of two rungs on the ladder (`Other` is below all).
    pub fn max_by_ladder(self, other: Rung) -> Rung {
        if other.index() > self.index() {
            other
        } else {
            self
        }
    }

    /// Index into [`Rung::LADDER`] (None for `Other`).
    pub fn index(self) -> Option<usize> {
        match self {
            Rung::Guess => Some(0),
            Rung::Pivoted(k) => Some(1 + usize::from(k.min(2))),
            Rung::Regularized => Some(4),
            Rung::Other => None,
        }
    }
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
    /// Only the ladder's first rung (`auto`, where a failure goes to PGS
    /// instead: `fallback::Step::escape`).
    pub first_rung_only: bool,
    /// Scratch of [`Lemke::solve_support`]: the support, `M_SS` and its LU
    /// factors with their row order, the solution and the refinement's
    /// residual.
    support: Vec<usize>,
    a: Vec<f64>,
    lu: Vec<f64>,
    perm: Vec<usize>,
    x: Vec<f64>,
    res: Vec<f64>,
    dx: Vec<f64>,
    /// Scratch of [`Lemke::independent_support`]: which of the support's
    /// indices repeat the ones before them.
    dependent: Vec<bool>,
    /// The refined candidate.
    zr: Vec<f64>,
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

    /// Solves `0 <= M z + q _|_ z >= 0` into `z`, climbing a ladder of
    /// attempts, each a full run verified against the original `M, q`:
    ///
    /// 1. pivot tolerance `PIVOT_TOLS[0]`, then the tighter ones (see
    ///    [`PIVOT_TOLS`]); every pivoted answer whose residual is above
    ///    round-off is refined from its final basis ([`Lemke::refine`]);
    /// 2. `M + eps I`, `eps = REGULARIZATION * max |M_ij|` (a constraint-force
    ///    mixing, as ODE calls it). A copositive `M` (every contact LCP of the
    ///    engine is one) becomes strictly copositive, for which Lemke's method
    ///    cannot end on a ray: the homogeneous solutions that make contact
    ///    LCPs degenerate (a far contact's free slack, the indeterminate
    ///    internal impulses of a closed loop of joints and contacts) are gone.
    ///    Its answer solves the original problem up to `w = -eps z`, so it is
    ///    verified against the original `M, q` with the looser
    ///    [`REGULARIZED_VERIFY_TOL`], and the rung says it was regularised.
    ///
    /// When every rung fails, the first rung's error is returned (the
    /// others' are of the same problem with other settings).
    pub fn solve(&mut self, lcp: &Lcp, z: &mut [f64]) -> Result<SolveInfo, LemkeError> {
        let mut first = None;
        for (k, &tol) in PIVOT_TOLS.iter().enumerate() {
            match self.run(lcp, z, 0.0, tol, VERIFY_TOL) {
                Ok(info) => {
                    return Ok(SolveInfo {
                        rung: Rung::Pivoted(k as u8),
                        ..info
                    })
                }
                Err(e) if self.first_rung_only => return Err(e),
                Err(e) => {
                    first.get_or_insert(e);
                }
            }
        }
        let eps = REGULARIZATION * lcp.m.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        match self.run(lcp, z, eps, PIVOT_TOLS[0], REGULARIZED_VERIFY_TOL) {
            Ok(info) => Ok(SolveInfo {
                rung: Rung::Regularized,
                ..info
            }),
            Err(e) => Err(first.unwrap_or(e)),
        }
    }

    /// Lemke on `M + shift I` with pivot tolerance `pivot_tol`, its answer
    /// refined when it is not at round-off, and verified against `M, q`
    /// to the relative residual `tol` (the rung is left for the caller).
    fn run(
        &mut self,
        lcp: &Lcp,
        z: &mut [f64],
        shift: f64,
        pivot_tol: f64,
        tol: f64,
    ) -> Result<SolveInfo, LemkeError> {
        let pivots = self.pivoting(lcp, z, shift, pivot_tol)?;
        let mut residual = relative_residual(lcp, &z[..lcp.n]);
        let mut refined = false;
        if residual > REFINE_ABOVE {
            if let Some(r) = self.refine(lcp, z, shift, residual) {
                residual = r;
                refined = true;
            }
        }
        if residual <= tol {
            Ok(SolveInfo {
                work: pivots,
                rung: Rung::Other,
                refined,
                residual,
            })
        } else {
            Err(LemkeError::NumericalBreakdown { pivots, residual })
        }
    }

    /// The final basis factored again from the original data: with `S` the
    /// `z` basic at the end of the path, solves `(M + shift I)_SS z_S = -q_S`
    /// by LU with partial pivoting and one step of iterative refinement.
    /// The tableau carries every pivot's round-off (a path of 20 pivots
    /// through a matrix of condition 1e19 loses most digits); the basis it
    /// found is usually right even where its numbers are not. Replaces `z`
    /// and returns the new residual when that is smaller than `residual`.
    fn refine(&mut self, lcp: &Lcp, z: &mut [f64], shift: f64, residual: f64) -> Option<f64> {
        let n = lcp.n;
        self.support.clear();
        self.support.extend(
            self.basis
                .iter()
                .filter(|&&v| (n..2 * n).contains(&v))
                .map(|&v| v - n),
        );
        self.support.sort_unstable();
        let mut zr = std::mem::take(&mut self.zr);
        zr.clear();
        zr.resize(n, 0.0);
        let better = self.solve_support(lcp, shift, &mut zr) && {
            zr.iter_mut().for_each(|x| *x = x.max(0.0));
            relative_residual(lcp, &zr) < residual
        };
        let out = better.then(|| {
            z[..n].copy_from_slice(&zr);
            relative_residual(lcp, &zr)
        });
        self.zr = zr;
        out
    }

    /// Keeps in the support a maximal part of it, in its order, whose block
    /// `M_SS` is nonsingular; true when it dropped an index. Elimination on
    /// `M_SS` with the diagonal as pivots: index `k`'s pivot is then the
    /// Schur complement of the kept ones before it, and `k` is dropped
    /// (not used as a pivot) where that is below the LU's own singularity
    /// bound, `PIVOT_TOLS[0]` of the block's largest entry.
    ///
    /// Why: a support carried from the last step can hold rows that repeat
    /// others: a box's four vertices on a plane (three normal rows span its
    /// support), a capsule's two ends held along its axis (the same
    /// friction row twice). LU refuses that block as singular, and the
    /// guess failed on most steps of boxes and capsules (172 of 3,000 held
    /// on shapes.toml). The answer with the repeated indices at zero is
    /// the vertex of the indeterminate support that the first indices
    /// carry, the same one from step to step; it is verified like any.
    fn independent_support(&mut self, lcp: &Lcp) -> bool {
        let n = lcp.n;
        let s = self.support.len();
        self.lu.clear();
        for &i in &self.support {
            self.lu
                .extend(self.support.iter().map(|&j| lcp.m[i * n + j]));
        }
        let scale = self.lu.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        self.dependent.clear();
        self.dependent.resize(s, false);
        let a = &mut self.lu;
        for k in 0..s {
            let d = a[k * s + k];
            if d.is_nan() || d.abs() <= PIVOT_TOLS[0] * scale {
                self.dependent[k] = true;
                continue;
            }
            for r in k + 1..s {
                let f = a[r * s + k] / d;
                if f != 0.0 {
                    for c in k + 1..s {
                        a[r * s + c] -= f * a[k * s + c];
                    }
                }
            }
        }
        let mut k = 0;
        let dependent = &self.dependent;
        self.support.retain(|_| {
            k += 1;
            !dependent[k - 1]
        });
        self.support.len() < s && !self.support.is_empty()
    }

    /// `(M + shift I)_SS z_S = -q_S` for `S = self.support` into `z` (zero
    /// elsewhere): LU with partial pivoting, then one step of iterative
    /// refinement with the residual formed from the original data. False
    /// when a pivot is below round-off of the block's scale, a value is not
    /// finite or an entry of `z_S` is negative (the support is not a
    /// solution's).
    fn solve_support(&mut self, lcp: &Lcp, shift: f64, z: &mut [f64]) -> bool {
        let n = lcp.n;
        let s = self.support.len();
        z[..n].fill(0.0);
        if s == 0 {
            return true;
        }
        self.a.clear();
        for (r, &i) in self.support.iter().enumerate() {
            for (c, &j) in self.support.iter().enumerate() {
                self.a
                    .push(lcp.m[i * n + j] + if r == c { shift } else { 0.0 });
            }
        }
        self.lu.clear();
        self.lu.extend_from_slice(&self.a);
        if !lu_factor(&mut self.lu, s, &mut self.perm) {
            return false;
        }
        // x = A^-1 b with b = -q_S, then x += A^-1 (b - A x), the residual
        // from the original rows.
        self.res.clear();
        self.res.extend(self.support.iter().map(|&i| -lcp.q[i]));
        lu_solve(&self.lu, s, &self.perm, &self.res, &mut self.x);
        for t in 0..s {
            let row = &self.a[t * s..(t + 1) * s];
            let ax: f64 = row.iter().zip(&self.x).map(|(a, b)| a * b).sum();
            self.res[t] -= ax;
        }
        lu_solve(&self.lu, s, &self.perm, &self.res, &mut self.dx);
        for (t, &i) in self.support.iter().enumerate() {
            let v = self.x[t] + self.dx[t];
            if v.is_nan() || v < 0.0 {
                return false;
            }
            z[i] = v;
        }
        true
    }

    /// Tries a guess of the solution's support before any pivoting: with
    /// `S = {i : active[i]}`, solves `M_SS z_S = -q_S` (see
    /// [`Lemke::solve_support`]), `z = 0` elsewhere, and accepts `z` only
    /// when it is nonnegative and passes the same verification as a pivoted
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
        self.support.clear();
        self.support.extend((0..n).filter(|&i| active[i]));
        if self.support.is_empty() {
            return None;
        }
        // A support whose block is singular still has an answer with the
        // repeated indices at zero, where the LCP has one at all.
        let solved = self.solve_support(lcp, 0.0, z)
            || (self.independent_support(lcp) && self.solve_support(lcp, 0.0, z));
        if !solved {
            return None;
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
            rung: Rung::Guess,
            refined: false,
            residual,
        })
    }

    /// Lemke's method as the textbook has it (with the floating-point care
    /// above and the first rung's pivot tolerance), without the rest of the
    /// ladder: what the solver corpus checks.
    pub fn solve_plain(&mut self, lcp: &Lcp, z: &mut [f64]) -> Result<SolveInfo, LemkeError> {
        self.run(lcp, z, 0.0, PIVOT_TOLS[0], VERIFY_TOL)
            .map(|info| SolveInfo {
                rung: Rung::Pivoted(0),
                ..info
            })
    }

    /// The pivoting itself on `M + shift I`: the tableau's `z` into `z`
    /// and the number of pivots, unverified.
    fn pivoting(
        &mut self,
        lcp: &Lcp,
        z: &mut [f64],
        shift: f64,
        pivot_tol: f64,
    ) -> Result<usize, LemkeError> {
        let n = lcp.n;
        z[..n].fill(0.0);
        self.basis.clear();
        let snap = q_snap(lcp);
        // The trivial case costs nothing: z = 0 solves it when q >= 0.
        if shift == 0.0 && lcp.q.iter().all(|&qi| qi >= -snap) {
            self.basis.extend(0..n);
            return Ok(0);
        }

        let width = 2 * n + 2;
        let (z0, rhs) = (2 * n, 2 * n + 1);
        self.tableau.clear();
        self.tableau.resize(n * width, 0.0);
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
            let r = match self.ratio_test(n, entering, pivot_tol) {
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
        Ok(pivots)
    }

    /// The row that leaves when column `col` enters, or `None` on a ray.
    fn ratio_test(&mut self, n: usize, col: usize, pivot_tol: f64) -> Option<usize> {
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
            if t[i * width + col] > pivot_tol * dmax {
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
            if d > pivot_tol * dmax && ratio(i) <= theta * (1.0 + TIE_TOL) + RHS_SNAP * rmax / d {
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

/// `A = P^-1 L U` in place (row-major `s x s`, unit lower `L` below the
/// diagonal), partial pivoting; `perm[k]` is the original row now at `k`.
/// False when a pivot is at or below `PIVOT_TOLS[0]` of the largest entry
/// (a singular block at this precision) or not finite.
fn lu_factor(lu: &mut [f64], s: usize, perm: &mut Vec<usize>) -> bool {
    let scale = lu.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    perm.clear();
    perm.extend(0..s);
    for k in 0..s {
        let p = (k..s)
            .max_by(|&x, &y| lu[x * s + k].abs().total_cmp(&lu[y * s + k].abs()))
            .unwrap_or(k);
        let d = lu[p * s + k];
        if d.is_nan() || d.abs() <= PIVOT_TOLS[0] * scale || !d.is_finite() {
            return false;
        }
        if p != k {
            for c in 0..s {
                lu.swap(k * s + c, p * s + c);
            }
            perm.swap(k, p);
        }
        for r in k + 1..s {
            let f = lu[r * s + k] / d;
            lu[r * s + k] = f;
            if f != 0.0 {
                for c in k + 1..s {
                    lu[r * s + c] -= f * lu[k * s + c];
                }
            }
        }
    }
    true
}

/// `x = A^-1 b` with the factors of [`lu_factor`].
fn lu_solve(lu: &[f64], s: usize, perm: &[usize], b: &[f64], x: &mut Vec<f64>) {
    x.clear();
    x.extend(perm.iter().map(|&p| b[p]));
    for i in 0..s {
        let t: f64 = (0..i).map(|k| lu[i * s + k] * x[k]).sum();
        x[i] -= t;
    }
    for i in (0..s).rev() {
        let t: f64 = (i + 1..s).map(|k| lu[i * s + k] * x[k]).sum();
        x[i] = (x[i] - t) / lu[i * s + i];
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

    /// Two copies of one constraint (`z1 + z2 >= 1`, as a box's repeated
    /// vertex rows): the guess of both is a singular block; its first index
    /// alone carries the answer, `z = (1, 0)`, which verifies.
    #[test]
    fn a_guess_with_a_repeated_row_keeps_the_first_and_solves() {
        let m = [1.0, 1.0, 1.0, 1.0];
        let q = [-1.0, -1.0];
        let lcp = Lcp { n: 2, m: &m, q: &q };
        let mut z = [0.0; 2];
        let info = Lemke::new()
            .solve_guess(&lcp, &[true, true], &[], &mut z)
            .expect("the first row carries it");
        assert_eq!(info.rung, Rung::Guess);
        assert_eq!(z, [1.0, 0.0]);
        // Three copies, the last not in the guess: still the first.
        let m = [2.0; 9];
        let q = [-1.0; 3];
        let lcp = Lcp { n: 3, m: &m, q: &q };
        let mut z = [0.0; 3];
        Lemke::new()
            .solve_guess(&lcp, &[false, true, true], &[], &mut z)
            .expect("the second row carries it");
        assert_eq!(z, [0.0, 0.5, 0.0]);
    }

    #[test]
    fn degenerate_ties_do_not_cycle() {
        // Three equal rows of q: every ratio ties at every pivot.
        let m = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let (z, _) = solve(3, &m, &[-1.0, -1.0, -1.0]).unwrap();
        assert_eq!(z, vec![1.0, 1.0, 1.0]);
    }
}
