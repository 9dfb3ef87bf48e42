//! Lemke by island (issue 14, point 2): the step's pure LCP cut into the
//! LCPs of its islands ([`Groups`]), each solved on its own.
//!
//! Why it is exact: two islands share no body, so every Delassus entry
//! between their rows is a sum of products with a zero factor, `0.0`
//! exactly, and so is the joint Schur term (the joint block's Cholesky
//! factor is block-diagonal by island too). The LCP is block-diagonal up
//! to a permutation, and `z` solves it if and only if each island's part
//! solves that island's block. Lemke's tableau is `O(n^3)`: islands of
//! sizes `n_g` cost `sum n_g^3`, and an island's answer does not depend on
//! what else is in the scene (`tests/tests/islands.rs`: the same bits with
//! and without a far-away second pile).
//!
//! Each island's block mirrors the whole LCP's layout, `[p_n; p_f; p_m;
//! s; s_m]`: its normal rows in order, then its friction blocks' rows, its
//! motors' pairs (a motor is its joint's island's), then the friction
//! slacks and the motors', so that Lemke's guess and its slack rule read
//! it as they read the whole.
//!
//! Two uses: [`Split::lemke`] cuts the blocks out of the whole LCP's
//! matrix where Lemke solves every island (`solver = "lemke"`, or `auto`
//! on a small step); [`Split::exact_islands`] builds the blocks of the
//! small islands from their rows where the step is large and matrix-free
//! (`auto` above `AUTO_PGS_SIZE`): Lemke solves those exactly and PGS the
//! large ones (Box2D and Rapier iterate every island; ODE's `dWorldStep`
//! is the exact one: here each island gets the one that suits its size).

use crate::constraint::applied::InvMass;
use crate::constraint::rows::Row;
use crate::solver::island::Groups;
use crate::solver::mlcp::Mlcp;
use crate::solver::{Lcp, Lemke, LemkeError, Rung, SolveInfo};

/// With `solver = "auto"` on a step too large for Lemke as a whole
/// ([`crate::AUTO_PGS_SIZE`]), islands whose LCP has at most this many
/// unknowns and no joint are solved by Lemke, the others by PGS: six
/// contacts with friction at n_d = 4. Measured on the piles of `bench
/// pile` (h = 0.01, n_d = 4, PGS to 1 cm/s, 500 steps, this machine, the
/// settings alternated in one run): at 1,000 spheres 5.1-5.6 s in all at
/// 36, 5.4 s at 120, 5.5-6.5 s with PGS for every island (Lemke's tableau
/// grows like n^3; at the loose tolerance PGS is cheap on a mid-sized
/// island); at 100 spheres the kinetic energy left after 5 s was 3.8e-4 J
/// at 36 and 2.9e-2 J with PGS for every island, whose small islands then
/// stop at 1 cm/s of error each.
pub const ISLAND_LEMKE_SIZE: usize = 36;

/// What [`Split::exact_islands`] did: islands solved by Lemke, and their
/// pivots and highest rung.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct Exact {
    pub islands: usize,
    pub pivots: usize,
    pub rung: Rung,
    pub refined: bool,
}

/// Scratch: each island's unknowns and its block.
#[derive(Debug, Default, Clone)]
pub struct Split {
    /// The friction block of each normal row (`u32::MAX`: none).
    block_of: Vec<u32>,
    /// Island `g`'s LCP unknowns are `unknowns[start[g]..start[g + 1]]`.
    unknowns: Vec<u32>,
    start: Vec<u32>,
    /// Island `g`'s normal rows, friction blocks and motors (counts).
    shape: Vec<(u32, u32, u32)>,
    /// Each motor's island.
    motor_island: Vec<u32>,
    m: Vec<f64>,
    q: Vec<f64>,
    z: Vec<f64>,
    guess: Vec<bool>,
    slacks: Vec<(usize, usize, usize)>,
    /// Per island, the local normal index of each of its friction blocks:
    /// `block_normal[bstart[g]..bstart[g + 1]]`.
    block_normal: Vec<u32>,
    bstart: Vec<u32>,
    /// Whether an island has a joint row.
    jointed: Vec<bool>,
    /// The islands left to the iterative solver by `exact_islands`.
    pub rest: Vec<u32>,
    /// Per island, whether the last `lemke` failed on it, and what the
    /// islands it solved took.
    failed: Vec<bool>,
    solved: SolveInfo,
    weighted: Vec<Row>,
}

impl Split {
    /// Lists each island's LCP unknowns in `m` (normal rows of the island's
    /// rows in `groups`, their friction rows, their slacks).
    pub fn index(&mut self, m: &Mlcp, groups: &Groups) {
        let (nb, nc, nd) = (m.nb, m.nc, m.nd);
        let rows = m.contact_rows();
        self.motor_island.clear();
        self.motor_island
            .extend(m.motor_row.iter().map(|&r| groups.island_of_row(r) as u32));
        self.block_of.clear();
        self.block_of.resize(nc, u32::MAX);
        for (f, &i) in m.friction_of.iter().enumerate() {
            self.block_of[i] = f as u32;
        }
        self.unknowns.clear();
        self.start.clear();
        self.shape.clear();
        self.block_normal.clear();
        self.bstart.clear();
        self.jointed.clear();
        self.start.push(0);
        self.bstart.push(0);
        for g in 0..groups.len() {
            let normals = groups.rows_of(g).iter().filter(|&&k| k as usize >= nb);
            self.jointed
                .push(groups.rows_of(g).iter().any(|&k| (k as usize) < nb));
            let first = self.unknowns.len();
            self.unknowns
                .extend(normals.clone().map(|&k| k - nb as u32));
            let nci = self.unknowns.len() - first;
            for (local, &k) in normals.clone().enumerate() {
                if self.block_of[k as usize - nb] != u32::MAX {
                    self.block_normal.push(local as u32);
                }
            }
            self.bstart.push(self.block_normal.len() as u32);
            let blocks = normals
                .clone()
                .map(|&k| self.block_of[k as usize - nb])
                .filter(|&f| f != u32::MAX);
            let mut nfi = 0;
            for f in blocks.clone() {
                let base = nc + f as usize * nd;
                self.unknowns.extend((base..base + nd).map(|u| u as u32));
                nfi += 1;
            }
            let motors = (0..m.nm).filter(|&k| self.motor_island[k] == g as u32);
            for k in motors.clone() {
                let at = m.motor_pair(k) as u32;
                self.unknowns.extend([at, at + 1]);
            }
            self.unknowns
                .extend(blocks.map(|f| (rows + f as usize) as u32));
            self.unknowns
                .extend(motors.clone().map(|k| (rows + m.nf + k) as u32));
            self.start.push(self.unknowns.len() as u32);
            self.shape.push((nci as u32, nfi, motors.count() as u32));
        }
    }

    /// Leaves every one of `islands` islands to the iterative solver (no
    /// [`Split::index`] needed).
    pub fn all_iterative(&mut self, islands: usize) {
        self.rest.clear();
        self.rest.extend(0..islands as u32);
    }

    /// Islands with LCP unknowns (a jointed pair in flight has none, but
    /// for a motor).
    pub fn islands(&self) -> usize {
        self.shape
            .iter()
            .filter(|&&(nc, _, nm)| nc + nm > 0)
            .count()
    }

    /// Solves `m`'s LCP island by island into `m.z` (sized already): each
    /// island's block from `guess` (the last step's support, by contact
    /// identity; see [`Lemke::solve_guess`]) where one is given, else by
    /// Lemke's ladder; with `only`, just the islands it flags (the others'
    /// unknowns keep their values). One island is the whole LCP, solved in
    /// place. Every island is tried: one that fails has zeros for its
    /// unknowns and is flagged in [`Split::failed`]; the error is the
    /// first failure's, the info the solved islands' together.
    pub fn lemke(
        &mut self,
        lemke: &mut Lemke,
        m: &mut Mlcp,
        guess: Option<&[bool]>,
        only: Option<&[bool]>,
    ) -> Result<SolveInfo, LemkeError> {
        let (n, nd) = (m.lcp_size(), m.nd);
        self.failed.clear();
        self.failed.resize(self.shape.len(), false);
        self.solved = SolveInfo::default();
        let take = |g: usize| only.is_none_or(|o| o[g]);
        if self.islands() <= 1 {
            // The one island with unknowns (if any) is the whole LCP.
            let Some(g) = (0..self.shape.len()).find(|&g| self.start[g + 1] > self.start[g]) else {
                return Ok(SolveInfo::default());
            };
            if !take(g) {
                return Ok(SolveInfo::default());
            }
            let lcp = Lcp {
                n,
                m: &m.lcp_m,
                q: &m.lcp_q,
            };
            let layout = (m.nc, m.nf, m.nd, m.nm);
            let solved = guess_or_solve(lemke, &lcp, guess, layout, &mut self.slacks, &mut m.z);
            self.solved = solved.unwrap_or_default();
            if solved.is_err() {
                self.failed[g] = true;
                m.z.fill(0.0);
            }
            return solved;
        }
        let mut total = SolveInfo {
            rung: Rung::Other,
            ..SolveInfo::default()
        };
        let mut first_error = None;
        for g in 0..self.shape.len() {
            let u = &self.unknowns[self.start[g] as usize..self.start[g + 1] as usize];
            let k = u.len();
            if k == 0 || !take(g) {
                continue;
            }
            self.m.clear();
            for &a in u {
                let row = &m.lcp_m[a as usize * n..][..n];
                self.m.extend(u.iter().map(|&b| row[b as usize]));
            }
            let solved = self.solve_block(lemke, g, nd, &m.lcp_q, guess);
            let u = &self.unknowns[self.start[g] as usize..self.start[g + 1] as usize];
            match solved {
                Ok(info) => {
                    for (&a, &x) in u.iter().zip(&self.z) {
                        m.z[a as usize] = x;
                    }
                    total.work += info.work;
                    total.rung = total.rung.max_by_ladder(info.rung);
                    total.refined |= info.refined;
                    total.residual = total.residual.max(info.residual);
                }
                Err(e) => {
                    for &a in u {
                        m.z[a as usize] = 0.0;
                    }
                    self.failed[g] = true;
                    first_error.get_or_insert(e);
                }
            }
        }
        self.solved = total;
        match first_error {
            Some(e) => Err(e),
            None => Ok(total),
        }
    }

    /// What the islands that the last [`Split::lemke`] solved took (all
    /// of them when it returned `Ok`).
    pub fn solved(&self) -> SolveInfo {
        self.solved
    }

    /// Per island, whether the last [`Split::lemke`] failed on it.
    pub fn failed(&self) -> &[bool] {
        &self.failed
    }

    /// Island `g`'s LCP unknowns (indices into the whole LCP's).
    pub fn unknowns_of(&self, g: usize) -> &[u32] {
        &self.unknowns[self.start[g] as usize..self.start[g + 1] as usize]
    }

    /// Island `g`'s block, in `self.m` already, solved into `self.z`: its
    /// `q` cut from the whole LCP's, from the last support in `guess`
    /// (the whole LCP's flags) where one is given, else by Lemke's ladder.
    fn solve_block(
        &mut self,
        lemke: &mut Lemke,
        g: usize,
        nd: usize,
        q: &[f64],
        guess: Option<&[bool]>,
    ) -> Result<SolveInfo, LemkeError> {
        let u = &self.unknowns[self.start[g] as usize..self.start[g + 1] as usize];
        let k = u.len();
        self.q.clear();
        self.q.extend(u.iter().map(|&a| q[a as usize]));
        self.z.clear();
        self.z.resize(k, 0.0);
        let lcp = Lcp {
            n: k,
            m: &self.m,
            q: &self.q,
        };
        let guess = guess.map(|guess| {
            self.guess.clear();
            self.guess.extend(u.iter().map(|&a| guess[a as usize]));
            &self.guess[..]
        });
        let (nc, nf, nm) = self.shape[g];
        let layout = (nc as usize, nf as usize, nd, nm as usize);
        guess_or_solve(lemke, &lcp, guess, layout, &mut self.slacks, &mut self.z)
    }

    /// The small islands without joints solved by Lemke on blocks built
    /// from their rows (the step is matrix-free: there is no whole LCP
    /// matrix to cut from), their impulses written into `m.lambda` (normal
    /// and friction rows; the slack is the iterative solver's to recover);
    /// the other islands, and any whose Lemke run failed, listed in
    /// [`Split::rest`] for the iterative solver. Needs [`Split::index`]
    /// and the friction rows (`Mlcp::add_friction_rows`).
    ///
    /// The block of island `g`: the Delassus entries `G_a^T M^-1 G_b` of
    /// its normal and friction direction rows (plus the normal rows'
    /// compliance), `E` and `-E^T` between each block's directions and its
    /// slack, `mu` from the slack to its normal: the reduced LCP of
    /// formulation.md restricted to the island, which without joints has
    /// no Schur term. `q` is the whole LCP's, formed already.
    pub fn exact_islands(
        &mut self,
        lemke: &mut Lemke,
        m: &mut Mlcp,
        minv: &[InvMass],
        guess: Option<&[bool]>,
    ) -> Exact {
        let (nb, nd, rows) = (m.nb, m.nd, m.contact_rows());
        let mut exact = Exact::default();
        self.rest.clear();
        for g in 0..self.shape.len() {
            let u = &self.unknowns[self.start[g] as usize..self.start[g + 1] as usize];
            let k = u.len();
            if self.jointed[g] || k > ISLAND_LEMKE_SIZE || k == 0 {
                if k > 0 || self.jointed[g] {
                    self.rest.push(g as u32);
                }
                continue;
            }
            // Without joints, so without motors.
            let (nci, nfi) = (self.shape[g].0 as usize, self.shape[g].1 as usize);
            let direct = nci + nfi * nd;
            self.weighted.clear();
            self.weighted.extend(
                u[..direct]
                    .iter()
                    .map(|&a| m.rows[nb + a as usize].weighted(minv)),
            );
            self.m.clear();
            self.m.resize(k * k, 0.0);
            for (a, &ua) in u[..direct].iter().enumerate() {
                let row = &m.rows[nb + ua as usize];
                for b in a..direct {
                    let v = row.dot(&self.weighted[b]);
                    self.m[a * k + b] = v;
                    self.m[b * k + a] = v;
                }
            }
            for (a, &ua) in u[..nci].iter().enumerate() {
                self.m[a * k + a] += m.cfm[nb + ua as usize];
            }
            let normals = &self.block_normal[self.bstart[g] as usize..self.bstart[g + 1] as usize];
            for (j, &local) in normals.iter().enumerate() {
                let s = direct + j;
                for d in 0..nd {
                    let r = nci + j * nd + d;
                    self.m[r * k + s] = 1.0;
                    self.m[s * k + r] = -1.0;
                }
                // Its first direction row is nc + f n_d in the whole LCP.
                let f = (u[nci + j * nd] as usize - m.nc) / nd;
                self.m[s * k + local as usize] = m.mu[f];
            }
            let solved = self.solve_block(lemke, g, nd, &m.lcp_q, guess);
            let Ok(info) = solved else {
                self.rest.push(g as u32);
                continue;
            };
            let u = &self.unknowns[self.start[g] as usize..self.start[g + 1] as usize];
            for (&a, &x) in u[..direct].iter().zip(&self.z) {
                m.lambda[nb + a as usize] = x;
            }
            debug_assert!(u[direct..].iter().all(|&a| a as usize >= rows));
            exact.islands += 1;
            exact.pivots += info.work;
            exact.rung = exact.rung.max_by_ladder(info.rung);
            exact.refined |= info.refined;
        }
        exact
    }
}

/// Lemke on `lcp` into `z`: from the support `guess` where one is given
/// and its answer verifies ([`Lemke::solve_guess`]), else by the ladder.
/// `(nc, nf, nd, nm)` is the LCP's layout `[p_n; p_f; p_m; s; s_m]`
/// (normal rows, friction blocks, directions, motors), whose slacks the
/// guess fills (a motor's over its pair); `slacks` is scratch.
fn guess_or_solve(
    lemke: &mut Lemke,
    lcp: &Lcp,
    guess: Option<&[bool]>,
    (nc, nf, nd, nm): (usize, usize, usize, usize),
    slacks: &mut Vec<(usize, usize, usize)>,
    z: &mut [f64],
) -> Result<SolveInfo, LemkeError> {
    if let Some(guess) = guess {
        let rows = nc + nf * nd + 2 * nm;
        slacks.clear();
        slacks.extend((0..nf).map(|f| (rows + f, nc + f * nd, nd)));
        slacks.extend((0..nm).map(|k| (rows + nf + k, nc + nf * nd + 2 * k, 2)));
        if let Some(info) = lemke.solve_guess(lcp, guess, slacks, z) {
            return Ok(info);
        }
    }
    lemke.solve(lcp, z)
}
