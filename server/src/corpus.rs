//! Readers of the Siconos test problems (`../shared/data/`, see its
//! README): LCPs and mixed LCPs, dense or sparse-block stored. Matrices come
//! out dense and row-major.

use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub struct FormatError(pub String);

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for FormatError {}

/// Whitespace-separated tokens with positions for the error messages.
struct Tokens<'a> {
    it: std::str::SplitAsciiWhitespace<'a>,
    read: usize,
}

impl<'a> Tokens<'a> {
    fn new(text: &'a str) -> Tokens<'a> {
        Tokens {
            it: text.split_ascii_whitespace(),
            read: 0,
        }
    }

    fn number(&mut self, what: &str) -> Result<f64, FormatError> {
        self.read += 1;
        let t = self
            .it
            .next()
            .ok_or_else(|| FormatError(format!("token {}: {what}: the file ends", self.read)))?;
        t.parse::<f64>().map_err(|_| {
            FormatError(format!(
                "token {}: {what}: {t:?} is not a number",
                self.read
            ))
        })
    }

    fn count(&mut self, what: &str) -> Result<usize, FormatError> {
        let x = self.number(what)?;
        if x >= 0.0 && x.fract() == 0.0 && x < 1e8 {
            Ok(x as usize)
        } else {
            Err(FormatError(format!(
                "token {}: {what}: {x} is not a count",
                self.read
            )))
        }
    }

    fn vector(&mut self, n: usize, what: &str) -> Result<Vec<f64>, FormatError> {
        (0..n).map(|_| self.number(what)).collect()
    }
}

/// A dense matrix, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Dense {
    pub rows: usize,
    pub cols: usize,
    pub data: Vec<f64>,
}

impl Dense {
    pub fn at(&self, i: usize, j: usize) -> f64 {
        self.data[i * self.cols + j]
    }
}

/// A Siconos `NumericsMatrix`: storage 0 (dense, column-major values) or 1
/// (sparse block).
fn numerics_matrix(t: &mut Tokens) -> Result<Dense, FormatError> {
    let storage = t.count("storage type")?;
    let rows = t.count("size0")?;
    let cols = t.count("size1")?;
    let mut m = Dense {
        rows,
        cols,
        data: vec![0.0; rows * cols],
    };
    match storage {
        0 => {
            let (r2, c2) = (t.count("size0 (again)")?, t.count("size1 (again)")?);
            if (r2, c2) != (rows, cols) {
                return Err(FormatError(format!(
                    "dense sizes {rows}x{cols} then {r2}x{c2}"
                )));
            }
            // Column-major: each text line is one column.
            for j in 0..cols {
                for i in 0..rows {
                    m.data[i * cols + j] = t.number("matrix entry")?;
                }
            }
        }
        1 => {
            let nblocks = t.count("nbblocks")?;
            let (bn0, bn1) = (t.count("blocknumber0")?, t.count("blocknumber1")?);
            let rowcum: Vec<usize> = (0..bn0)
                .map(|_| t.count("row block size"))
                .collect::<Result<_, _>>()?;
            let colcum: Vec<usize> = (0..bn1)
                .map(|_| t.count("column block size"))
                .collect::<Result<_, _>>()?;
            let filled1 = t.count("filled1")?;
            let filled2 = t.count("filled2")?;
            let rowptr: Vec<usize> = (0..filled1)
                .map(|_| t.count("row pointer"))
                .collect::<Result<_, _>>()?;
            let colidx: Vec<usize> = (0..filled2)
                .map(|_| t.count("column index"))
                .collect::<Result<_, _>>()?;
            if filled2 != nblocks || filled1 != bn0 + 1 {
                return Err(FormatError(format!(
                    "sparse block: {nblocks} blocks but {filled2} column indices, {bn0} block rows but {filled1} row pointers"
                )));
            }
            let start = |cum: &[usize], k: usize| if k == 0 { 0 } else { cum[k - 1] };
            for bi in 0..bn0 {
                for b in rowptr[bi]..rowptr[bi + 1] {
                    let bj = *colidx
                        .get(b)
                        .filter(|&&j| j < bn1)
                        .ok_or_else(|| FormatError(format!("block {b}: bad column index")))?;
                    let number = t.count("block number")?;
                    if number != b {
                        return Err(FormatError(format!("block {b} is numbered {number}")));
                    }
                    let (r0, r1) = (start(&rowcum, bi), rowcum[bi]);
                    let (c0, c1) = (start(&colcum, bj), colcum[bj]);
                    if r1 > rows || c1 > cols {
                        return Err(FormatError(format!(
                            "block {b} lies outside the {rows}x{cols} matrix"
                        )));
                    }
                    for j in c0..c1 {
                        for i in r0..r1 {
                            m.data[i * cols + j] = t.number("block entry")?;
                        }
                    }
                }
            }
        }
        other => {
            return Err(FormatError(format!(
                "storage type {other} is not read (0 dense, 1 sparse block)"
            )))
        }
    }
    Ok(m)
}

/// `0 <= M z + q _|_ z >= 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct LcpProblem {
    pub m: Dense,
    pub q: Vec<f64>,
}

/// Reads a Siconos LCP file (`lcp/siconos/*.dat`).
pub fn read_lcp(text: &str) -> Result<LcpProblem, FormatError> {
    let mut t = Tokens::new(text);
    let n = t.count("n")?;
    let m = numerics_matrix(&mut t)?;
    if (m.rows, m.cols) != (n, n) {
        return Err(FormatError(format!(
            "n = {n} but M is {}x{}",
            m.rows, m.cols
        )));
    }
    let q = t.vector(n, "q")?;
    Ok(LcpProblem { m, q })
}

/// Writes an LCP (`m` row-major `n x n`) in the Siconos dense form that
/// [`read_lcp`] reads: a failed step's problem, to be solved again with
/// `cosim-server lcp FILE` or any Siconos solver. Rust prints an `f64` with
/// the fewest digits that read back to the same bits, so nothing is lost.
pub fn write_lcp(n: usize, m: &[f64], q: &[f64]) -> String {
    let mut out = format!("{n}\n0\n{n} {n}\n{n} {n}\n");
    // Column-major: each line one column.
    for j in 0..n {
        let col: Vec<String> = (0..n).map(|i| format!("{}", m[i * n + j])).collect();
        out.push_str(&col.join(" "));
        out.push('\n');
    }
    let q: Vec<String> = q.iter().map(|x| format!("{x}")).collect();
    out.push_str(&q.join(" "));
    out.push('\n');
    out
}

/// `A u + C v + a = 0,  0 <= D u + B v + b _|_ v >= 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct MlcpProblem {
    pub a_mat: Dense,
    pub b_mat: Dense,
    pub c_mat: Dense,
    pub d_mat: Dense,
    pub a: Vec<f64>,
    pub b: Vec<f64>,
}

fn row_major(t: &mut Tokens, rows: usize, cols: usize, what: &str) -> Result<Dense, FormatError> {
    Ok(Dense {
        rows,
        cols,
        data: t.vector(rows * cols, what)?,
    })
}

/// Reads a Siconos mixed LCP file (`mlcp/siconos/*_mlcp.dat`) from its
/// second (block) form; the first form is read past.
pub fn read_mlcp(text: &str) -> Result<MlcpProblem, FormatError> {
    let mut t = Tokens::new(text);
    let type1 = t.count("isStorageType1")?;
    let type2 = t.count("isStorageType2")?;
    let n = t.count("n")?;
    let m = t.count("m")?;
    if type1 == 1 {
        // Block row starts from 0 up to n + m, then a flag per block.
        let mut blocks = 0;
        while t.count("block row start")? < n + m {
            blocks += 1;
            if blocks > n + m {
                return Err(FormatError("block row starts never reach n + m".into()));
            }
        }
        for _ in 0..blocks {
            t.count("block flag")?;
        }
        let whole = numerics_matrix(&mut t)?;
        if (whole.rows, whole.cols) != (n + m, n + m) {
            return Err(FormatError(format!(
                "rectangular mixed LCP: M is {}x{} for n + m = {}; only square problems are read",
                whole.rows,
                whole.cols,
                n + m
            )));
        }
        t.vector(whole.rows, "q")?;
    }
    if type2 != 1 {
        return Err(FormatError(
            "only files with the block form (isStorageType2 = 1) are read".into(),
        ));
    }
    Ok(MlcpProblem {
        a_mat: row_major(&mut t, n, n, "A")?,
        b_mat: row_major(&mut t, m, m, "B")?,
        c_mat: row_major(&mut t, n, m, "C")?,
        d_mat: row_major(&mut t, m, n, "D")?,
        a: t.vector(n, "a")?,
        b: t.vector(m, "b")?,
    })
}

/// How a mixed LCP ended.
#[derive(Debug, Clone, PartialEq)]
pub enum MlcpOutcome {
    /// Solved: `u`, `v`, the Lemke pivots (PGS sweeps with PGS) and the
    /// residual (see [`solve_mlcp`]).
    Solved {
        u: Vec<f64>,
        v: Vec<f64>,
        pivots: usize,
        residual: f64,
        pivot_ratio: f64,
    },
    /// The equality block `A` is singular or too ill-conditioned for the
    /// Schur reduction: `ratio` is the largest over the smallest pivot of
    /// its fully pivoted LU (infinite when a pivot is zero).
    SingularEquality { ratio: f64 },
    /// The reduced LCP's solver failed (`pivot_ratio` of `A` as above):
    /// Lemke's ray, pivot limit or breakdown, or PGS at its iteration cap.
    Failed {
        failure: LcpFailure,
        pivot_ratio: f64,
    },
}

/// The solver of a corpus LCP (or of a mixed LCP's reduced LCP).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LcpSolver {
    /// [`Lemke::solve_plain`](crate::engine::solver::Lemke::solve_plain):
    /// one run, the textbook method with its floating-point care.
    Lemke,
    /// [`Lemke::solve`](crate::engine::solver::Lemke::solve): the engine's
    /// ladder of pivot tolerances, refinement and regularisation.
    LemkeLadder,
    /// [`pgs::solve_dense`](crate::engine::solver::pgs::solve_dense).
    Pgs(crate::engine::solver::PgsParams),
}

/// How an LCP solve by either solver ended: `Ok` with `(work, residual)`
/// (pivots or sweeps), or the failure in the words of `lcp --json`.
pub fn solve_lcp(
    solver: LcpSolver,
    lcp: &crate::engine::solver::Lcp,
    z: &mut [f64],
) -> Result<(usize, f64), LcpFailure> {
    use crate::engine::solver::{pgs, Lemke, LemkeError};
    match solver {
        LcpSolver::Lemke | LcpSolver::LemkeLadder => match if solver == LcpSolver::Lemke {
            Lemke::new().solve_plain(lcp, z)
        } else {
            Lemke::new().solve(lcp, z)
        } {
            Ok(info) => Ok((info.work, info.residual)),
            Err(e) => {
                let (status, work, residual) = match e {
                    LemkeError::RayTermination { pivots, .. } => ("ray_termination", pivots, None),
                    LemkeError::PivotLimit { pivots, .. } => ("pivot_limit", pivots, None),
                    LemkeError::NumericalBreakdown { pivots, residual } => {
                        ("not_converged", pivots, Some(residual))
                    }
                };
                Err(LcpFailure {
                    status,
                    work,
                    residual,
                    message: e.to_string(),
                })
            }
        },
        LcpSolver::Pgs(params) => {
            let info = pgs::solve_dense(lcp, &params, z);
            if info.converged {
                Ok((info.iterations, info.residual))
            } else {
                Err(LcpFailure {
                    status: "not_converged",
                    work: info.iterations,
                    residual: Some(info.residual),
                    message: format!(
                        "no convergence: residual {:.3e} after {} sweeps (tolerance {:.1e})",
                        info.residual, info.iterations, params.tolerance
                    ),
                })
            }
        }
    }
}

/// A failed LCP solve: `status` as `lcp --json` prints it (`ray_termination`,
/// `pivot_limit`, `not_converged`), pivots or sweeps done, the residual
/// reached where there is one (not on a ray), and the message.
#[derive(Debug, Clone, PartialEq)]
pub struct LcpFailure {
    pub status: &'static str,
    pub work: usize,
    pub residual: Option<f64>,
    pub message: String,
}

/// Largest accepted ratio of LU pivots of the equality block: beyond it the
/// reduction loses more than 12 of the 16 digits.
pub const MAX_PIVOT_RATIO: f64 = 1e12;

/// Solves a mixed LCP by the Schur complement of `A`
/// (`u = -A^-1 (C v + a)`, LCP in `v` with `B - D A^-1 C`, `b - D A^-1 a`),
/// then Lemke. The residual is the larger of `||A u + C v + a|| / max(1,
/// ||a||)` and the natural-map residual of the complementarity part
/// relative to `max(1, ||b||)`.
pub fn solve_mlcp(p: &MlcpProblem) -> MlcpOutcome {
    solve_mlcp_with(p, LcpSolver::Lemke)
}

/// [`solve_mlcp`] with the reduced LCP solved by `solver`.
pub fn solve_mlcp_with(p: &MlcpProblem, solver: LcpSolver) -> MlcpOutcome {
    use crate::engine::solver::Lcp;
    use faer::Mat;
    let (n, m) = (p.a.len(), p.b.len());
    let mut pivot_ratio = 1.0;
    let (x_mat, x_vec) = if n > 0 {
        let a = Mat::from_fn(n, n, |i, j| p.a_mat.at(i, j));
        let lu = a.full_piv_lu();
        let diag: Vec<f64> = (0..n).map(|i| lu.U()[(i, i)].abs()).collect();
        let (lo, hi) = diag.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &d| {
            (lo.min(d), hi.max(d))
        });
        let ratio = if lo > 0.0 { hi / lo } else { f64::INFINITY };
        if ratio > MAX_PIVOT_RATIO {
            return MlcpOutcome::SingularEquality { ratio };
        }
        pivot_ratio = ratio;
        let rhs = Mat::from_fn(
            n,
            m + 1,
            |i, j| if j < m { p.c_mat.at(i, j) } else { p.a[i] },
        );
        let sol = faer::linalg::solvers::Solve::solve(&lu, &rhs);
        let x_mat: Vec<f64> = (0..n * m).map(|k| sol[(k / m, k % m)]).collect();
        let x_vec: Vec<f64> = (0..n).map(|i| sol[(i, m)]).collect();
        (x_mat, x_vec)
    } else {
        (Vec::new(), Vec::new())
    };
    // Reduced LCP: M = B - D X, q = b - D x.
    let mut mm = vec![0.0; m * m];
    let mut q = vec![0.0; m];
    for i in 0..m {
        for j in 0..m {
            mm[i * m + j] = p.b_mat.at(i, j)
                - (0..n)
                    .map(|k| p.d_mat.at(i, k) * x_mat[k * m + j])
                    .sum::<f64>();
        }
        q[i] = p.b[i] - (0..n).map(|k| p.d_mat.at(i, k) * x_vec[k]).sum::<f64>();
    }
    let mut v = vec![0.0; m];
    let lcp = Lcp {
        n: m,
        m: &mm,
        q: &q,
    };
    let work = match solve_lcp(solver, &lcp, &mut v) {
        Ok((work, _)) => work,
        Err(failure) => {
            return MlcpOutcome::Failed {
                failure,
                pivot_ratio,
            }
        }
    };
    let u: Vec<f64> = (0..n)
        .map(|i| -(x_vec[i] + (0..m).map(|j| x_mat[i * m + j] * v[j]).sum::<f64>()))
        .collect();
    // Residual against the original data.
    let norm = |x: &[f64]| x.iter().map(|a| a * a).sum::<f64>().sqrt();
    let eq: Vec<f64> = (0..n)
        .map(|i| {
            (0..n).map(|j| p.a_mat.at(i, j) * u[j]).sum::<f64>()
                + (0..m).map(|j| p.c_mat.at(i, j) * v[j]).sum::<f64>()
                + p.a[i]
        })
        .collect();
    let comp: Vec<f64> = (0..m)
        .map(|i| {
            let w = (0..n).map(|j| p.d_mat.at(i, j) * u[j]).sum::<f64>()
                + (0..m).map(|j| p.b_mat.at(i, j) * v[j]).sum::<f64>()
                + p.b[i];
            v[i] - (v[i] - w).max(0.0)
        })
        .collect();
    let residual = (norm(&eq) / norm(&p.a).max(1.0)).max(norm(&comp) / norm(&p.b).max(1.0));
    MlcpOutcome::Solved {
        u,
        v,
        pivots: work,
        residual,
        pivot_ratio,
    }
}

/// A 3-D frictional-contact problem in local form: find `r` with
/// `u = W r + q` and Coulomb's law at each contact, `r_i = [r_N, r_T1,
/// r_T2]`, coefficient `mu_i`.
#[derive(Debug, Clone, PartialEq)]
pub struct FcProblem {
    pub nc: usize,
    pub w: Dense,
    pub q: Vec<f64>,
    pub mu: Vec<f64>,
}

/// Reads a Siconos frictional-contact file (`fc/siconos/*.dat`), 3-D only.
pub fn read_fc3d(text: &str) -> Result<FcProblem, FormatError> {
    let mut t = Tokens::new(text);
    let dim = t.count("dim")?;
    if dim != 3 {
        return Err(FormatError(format!(
            "dim = {dim}: only 3-D problems are read"
        )));
    }
    let nc = t.count("nc")?;
    let w = numerics_matrix(&mut t)?;
    if (w.rows, w.cols) != (3 * nc, 3 * nc) {
        return Err(FormatError(format!(
            "nc = {nc} but W is {}x{}",
            w.rows, w.cols
        )));
    }
    let q = t.vector(3 * nc, "q")?;
    let mu = t.vector(nc, "mu")?;
    Ok(FcProblem { nc, w, q, mu })
}

pub use crate::engine::solver::pgs::project_cone;

/// How a frictional-contact solve ended.
#[derive(Debug, Clone, PartialEq)]
pub struct FcOutcome {
    pub r: Vec<f64>,
    pub iterations: usize,
    /// Natural-map Coulomb residual, normalised by `max(||q||, 1)`.
    pub residual: f64,
    pub converged: bool,
}

/// The natural-map Coulomb residual with the De Saxce change of variable:
/// per contact `r_i - proj_K(r_i - (u_i + mu ||u_T|| e_N))`, its norm over
/// all contacts divided by `max(||q||, 1)`.
pub fn fc3d_residual(p: &FcProblem, r: &[f64]) -> f64 {
    let n = 3 * p.nc;
    let mut sum = 0.0;
    for i in 0..p.nc {
        let mut u = [0.0; 3];
        for (a, ua) in u.iter_mut().enumerate() {
            let row = 3 * i + a;
            *ua = p.q[row] + (0..n).map(|j| p.w.at(row, j) * r[j]).sum::<f64>();
        }
        let ut = (u[1] * u[1] + u[2] * u[2]).sqrt();
        let ri = [r[3 * i], r[3 * i + 1], r[3 * i + 2]];
        let x = project_cone(
            [ri[0] - (u[0] + p.mu[i] * ut), ri[1] - u[1], ri[2] - u[2]],
            p.mu[i],
        );
        sum += (0..3).map(|a| (ri[a] - x[a]).powi(2)).sum::<f64>();
    }
    let qn = p.q.iter().map(|x| x * x).sum::<f64>().sqrt();
    sum.sqrt() / qn.max(1.0)
}

/// Projected Gauss-Seidel on the circular cone: per contact
/// `r_i <- proj_K(r_i - rho_i (u_i + mu ||u_T|| e_N))`, `rho_i` the inverse
/// of the mean diagonal of the contact's 3 x 3 block of `W`; stops once the
/// residual (checked every 10 sweeps) is below `tolerance`.
pub fn solve_fc3d(p: &FcProblem, tolerance: f64, max_iterations: usize) -> FcOutcome {
    let n = 3 * p.nc;
    let mut r = vec![0.0; n];
    let mut u = vec![0.0; n];
    let rho: Vec<f64> = (0..p.nc)
        .map(|i| {
            let tr = (0..3).map(|a| p.w.at(3 * i + a, 3 * i + a)).sum::<f64>();
            if tr > 0.0 {
                3.0 / tr
            } else {
                1.0
            }
        })
        .collect();
    let mut out = FcOutcome {
        r: Vec::new(),
        iterations: 0,
        residual: f64::INFINITY,
        converged: false,
    };
    for it in 1..=max_iterations {
        for i in 0..p.nc {
            for a in 0..3 {
                let row = 3 * i + a;
                u[row] = p.q[row] + (0..n).map(|j| p.w.at(row, j) * r[j]).sum::<f64>();
            }
            let ut = (u[3 * i + 1].powi(2) + u[3 * i + 2].powi(2)).sqrt();
            let x = [
                r[3 * i] - rho[i] * (u[3 * i] + p.mu[i] * ut),
                r[3 * i + 1] - rho[i] * u[3 * i + 1],
                r[3 * i + 2] - rho[i] * u[3 * i + 2],
            ];
            let y = project_cone(x, p.mu[i]);
            r[3 * i..3 * i + 3].copy_from_slice(&y);
        }
        if it % 10 == 0 || it == max_iterations {
            out.iterations = it;
            out.residual = fc3d_residual(p, &r);
            if out.residual <= tolerance {
                out.converged = true;
                break;
            }
        }
    }
    out.r = r;
    out
}
