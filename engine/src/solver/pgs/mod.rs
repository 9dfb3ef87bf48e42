//! Projected Gauss-Seidel with a proximal step (prox PGS) on the mixed
//! problem in impulse space (formulation.md): one sweep updates every row
//! `k` by `lambda_k <- proj_K(lambda_k - omega r_k / W_kk)`, `r_k` the row's
//! residual velocity `G_k^T nu + offset_k`, `K` = R for a joint row, R+ for a
//! normal row, and for a contact's friction block the polyhedral cone
//! `{p_f >= 0, sum p_f <= mu p_n}` at its current normal impulse.
//!
//! A friction block is solved as one 2-D tangential impulse: the `n_d`
//! direction rows are strongly coupled (`d_j` and `-d_j` are the same row up
//! to sign), so a row-by-row or Jacobi step over them diverges. The block
//! step removes the tangential slip with the exact 2 x 2 tangential Delassus
//! block, projects the impulse onto the cone's polygon (vertices
//! `mu p_n d_j`) and writes it back on the two directions that bracket it.
//!
//! The slack `s` of the Lemke form (a zero diagonal) never enters: the cone
//! projection replaces it, and `s` is recovered afterwards as the largest
//! sliding speed against a friction direction, `max(0, max_j -v_j)`, so that
//! the answer can be judged by the same natural-map residual as Lemke's.
//!
//! Matrix-free: the velocities are kept up to date (`nu = nu_free + M^-1 G
//! lambda`), so a row costs O(1) and no Delassus matrix is needed.

mod momentum;
mod residual;
mod sweep;

use crate::constraint::applied::InvMass;
use crate::constraint::contact::direction_coefficients as direction;
use crate::constraint::coupling::Tails;
use crate::constraint::rows::Row;
pub use crate::model::params::{
    PgsParams, Stop, DEFAULT_MAX_ITERATIONS, DEFAULT_TOLERANCE, DEFAULT_VELOCITY_TOLERANCE,
};
use crate::solver::cone::{decompose, Polygon};
pub use crate::solver::cone::{project_cone, project_disc, project_polygon};
use crate::solver::island::Groups;
use crate::solver::Lcp;

/// Sweeps between residual evaluations (each costs O(n^2)).
const CHECK_EVERY: usize = 4;

/// The step's problem, as the mLCP stage built it.
pub struct PgsProblem<'a> {
    /// Rows: `nb` joint rows, `nc` normal rows, `nd` per friction block,
    /// then one per motor.
    pub rows: &'a [Row],
    /// The couplings' tails: a joint row with one spans both joints.
    pub tails: Tails<'a>,
    pub offset: &'a [f64],
    /// Each row's constraint-force mixing (compliance, `Mlcp::cfm`): the
    /// row's residual is `G_k^T nu + offset_k + cfm_k lambda_k`.
    pub cfm: &'a [f64],
    pub nb: usize,
    pub nc: usize,
    pub nd: usize,
    /// Friction block `f` belongs to normal row `friction_of[f]`, with `mu[f]`.
    pub friction_of: &'a [usize],
    pub mu: &'a [f64],
    /// Normal rows the joints hold (`mlcp::HELD`; empty for none): they
    /// keep a zero impulse, so their friction has none either.
    pub held: &'a [bool],
    pub minv: &'a [InvMass],
    pub nu_free: &'a [f64],
    /// The reduced LCP's `q` (its matrix may be empty: the residual is
    /// computed matrix-free), for the residual's scale.
    pub lcp: Lcp<'a>,
    /// The isotropic cone `|p_t| <= mu p_n` instead of the polyhedral one.
    pub circular: bool,
    /// The joint and normal rows by island: each island is iterated to its
    /// own stop.
    pub groups: &'a Groups,
    /// The islands to iterate (the others are solved already: their
    /// impulses are part of the warm start and stay).
    pub iterate: &'a [u32],
    /// Islands iterated in plain sweeps, without the momentum step
    /// (`iterative.rs`'s descent from zero impulses); empty: none.
    pub descend: &'a [bool],
    /// Per motor, its joint's first row (its island's) and its bound
    /// `F h`: the box its impulse is projected on (motor.rs).
    pub motor_row: &'a [usize],
    pub motor_cap: &'a [f64],
    /// Per motor, its row's compliance `eps` (`motor::drive`; 0 rigid).
    pub motor_cfm: &'a [f64],
}

impl PgsProblem<'_> {
    /// Where the motors' rows start in `rows`.
    fn motor_rows(&self) -> usize {
        self.nb + self.nc + self.friction_of.len() * self.nd
    }
}

/// How the iteration ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PgsInfo {
    pub iterations: usize,
    /// Relative residual reached (see [`Pgs::residual`]).
    pub residual: f64,
    /// Whether the tolerance stopped it (else the iteration cap).
    pub converged: bool,
}

/// A warm start for one friction block: the tangential impulse `pt` (in
/// this step's `t1, t2` coordinates) clipped to the cone at the normal
/// impulse's warm start (`cap = mu p_n`) and written on the block's `n_d`
/// directions, as the iteration keeps it.
pub fn warm_friction(pt: [f64; 2], cap: f64, circular: bool, out: &mut [f64]) {
    let nd = out.len();
    let p = if circular {
        project_disc(pt, cap)
    } else {
        project_polygon(pt, cap, nd)
    };
    decompose(p, nd, out);
}

/// Projected Gauss-Seidel on a dense LCP `0 <= M z + q _|_ z >= 0` (the
/// solver corpus' problems, which have no bodies to sweep over):
/// `z_i <- max(0, z_i - omega w_i / M_ii)` from `z = 0`, stopped by the
/// shared [`relative_residual`](super::relative_residual) at
/// `params.tolerance`, or the cap. It converges for symmetric positive
/// semi-definite `M` with a positive diagonal (then it is a coordinate
/// descent on `z^T M z / 2 + q^T z`); on other classes it may not, and says
/// so. Rows with `M_ii <= 0` cannot be stepped and are left at zero.
pub fn solve_dense(lcp: &Lcp, params: &PgsParams, z: &mut [f64]) -> PgsInfo {
    let n = lcp.n;
    z[..n].fill(0.0);
    let mut info = PgsInfo {
        iterations: 0,
        residual: super::relative_residual(lcp, &z[..n]),
        converged: false,
    };
    if info.residual <= params.tolerance {
        info.converged = true;
        return info;
    }
    for it in 1..=params.max_iterations.max(1) {
        for i in 0..n {
            let d = lcp.m[i * n + i];
            if d <= 0.0 {
                continue;
            }
            let w = super::row_slack(lcp, &z[..n], i);
            z[i] = (z[i] - params.relaxation * w / d).max(0.0);
        }
        if it % CHECK_EVERY == 0 || it == params.max_iterations {
            info.iterations = it;
            info.residual = super::relative_residual(lcp, &z[..n]);
            if info.residual <= params.tolerance {
                info.converged = true;
                return info;
            }
        }
    }
    info
}

/// The residual rule's focused sweeps ([`Pgs::focus`]): from the
/// `FOCUS_AFTER`-th sweep of a solve, after a sweep that left at most
/// `FOCUS_MAX` contacts above the tolerance, up to `FOCUS_SWEEPS` sweeps
/// of those contacts alone.
const FOCUS_AFTER: usize = 50;
pub(super) const FOCUS_MAX: usize = 128;
pub(super) const FOCUS_SWEEPS: usize = 20;

/// Sweeps over which the rate of convergence is estimated.
const RATE_WINDOW: usize = 4;

/// Whether the iteration is within `tolerance` (m/s) of where it stops,
/// from its last corrections `recent` (newest first, each the largest
/// velocity change of a sweep's updates). A sweep that changes nothing is
/// at the fixed point. Otherwise the last correction `c` must be within
/// the tolerance, and:
///
/// - while the corrections shrink at the rate `rho` (estimated over the
///   window), the distance left is at most `c rho / (1 - rho)`, which must
///   be within the tolerance too: a small correction alone does not say the
///   answer is near (on a pile, sweeps creep at 4e-5 m/s for thousands of
///   iterations, rho = 0.9999, before the impulses settle);
/// - when they no longer shrink (`rho >= 1`), the iterate moves by less
///   than the tolerance per sweep and more sweeps do not bring it closer
///   (a friction block cycling between two faces of its cone, measured at
///   3e-7 m/s on the pile at rest): it stops there.
///
/// With one sweep there is no rate: the correction must be a hundredth of
/// the tolerance.
fn within(recent: &[f64], tolerance: f64) -> bool {
    let c = recent[0];
    if c == 0.0 {
        return true;
    }
    if c > tolerance {
        return false;
    }
    let Some(&old) = recent.get(1..).and_then(|r| r.last()) else {
        return c <= 0.01 * tolerance;
    };
    let rho = (c / old).powf(1.0 / (recent.len() - 1) as f64);
    rho >= 1.0 || c * rho / (1.0 - rho) <= tolerance
}

#[derive(Debug, Default, Clone)]
pub struct Pgs {
    diag: Vec<f64>,
    inv_diag: Vec<f64>,
    /// The impulse response `M^-1 G_k` ([`Row::weighted`]) of each
    /// coordinate of `x`, so that an update adds to the velocities without
    /// the inertia products: the joint and normal rows, then per friction
    /// block its t1 and t2 rows. NOTE: kept, although it doubles the bytes
    /// a sweep reads: rows packed to 104 bytes with the response formed
    /// from each body's inverse mass at every update (the same bits) made
    /// a sweep of the 4,000 pile 7 % slower (1,048 against 980 us): the
    /// sweep waits on its chain of dependent updates, not on memory.
    weighted: Vec<Row>,
    /// The couplings' tails weighted, as `weighted` (`PgsProblem::tails`).
    tails_weighted: Vec<Row>,
    /// Per friction block: rows along t1 and t2 (their weighted rows are
    /// `weighted`'s) and the inverse of their 2 x 2 Delassus block.
    tangent: Vec<Tangent>,
    /// The iterate: joint and normal impulses, then each friction block's
    /// 2-D tangential impulse `(p_t1, p_t2)`, then each motor's impulse. The `n_d` direction impulses
    /// are written from it at the end (and for the residual): a block's
    /// update then reads and writes two numbers, not `n_d`.
    x: Vec<f64>,
    /// The iterate before the sweep, and the momentum direction (NNCG).
    before: Vec<f64>,
    direction: Vec<f64>,
    /// The velocities before the sweep, and the velocity change the
    /// momentum direction makes, `M^-1 G direction` (6 per body): the
    /// momentum step moves `nu` with them, one update per body, instead
    /// of one per coordinate through its weighted row.
    nu_before: Vec<f64>,
    nu_direction: Vec<f64>,
    /// Per island, the bodies its rows touch, ascending:
    /// `bodies[body_start[g]..body_start[g + 1]]`.
    bodies: Vec<u32>,
    body_start: Vec<u32>,
    /// The friction block of each normal row, if it has one.
    block_of: Vec<Option<usize>>,
    polygon: Polygon,
    /// Per island, the coordinates of `x` it owns, ascending:
    /// `coords[coord_start[g]..coord_start[g + 1]]`.
    coords: Vec<u32>,
    coord_start: Vec<u32>,
    /// Scratch of the residual: a block's direction impulses.
    dirs: Vec<f64>,
    /// Per motor, its row's Delassus diagonal; per island, its motors:
    /// `motors[motor_start[g]..motor_start[g + 1]]`.
    motor_diag: Vec<f64>,
    motors: Vec<u32>,
    motor_start: Vec<u32>,
    /// Scratch of [`Pgs::prepare`]: whether a body is listed already.
    listed: Vec<bool>,
    /// The contacts (normal rows) the last sweep changed by more than the
    /// residual rule's tolerance, at most [`FOCUS_MAX`] of them, and how
    /// many there were in all (see [`Pgs::focus`]).
    focus: Vec<u32>,
    focus_count: usize,
    /// Every contact's normal row acts on a body A and at most one other
    /// body B, and its weighted row and its block's rows on the same ones:
    /// the sweep may then hold their velocities (`Held`).
    held: bool,
}

#[derive(Debug, Clone, Copy)]
struct Tangent {
    t1: Row,
    t2: Row,
    inv: [[f64; 2]; 2],
    /// The largest eigenvalue of the 2 x 2 block: turns an impulse change
    /// into the velocity change it makes (m/s) for the stopping rule.
    scale: f64,
}

impl Pgs {
    /// Iterates from the warm start in `lambda` (all rows); leaves the
    /// impulses in `lambda`, the velocities in `nu` and the LCP unknowns
    /// `[p_n; p_f; s]` in `z`.
    ///
    /// Island by island (`PgsProblem::iterate`): two islands share no
    /// body, so each is iterated alone to its own stop, with its own
    /// momentum, and a settled island is not swept again while another
    /// settles; the islands not listed keep their impulses (Lemke's, see
    /// `split.rs`). `PgsInfo::iterations` is the largest island's sweeps;
    /// `converged` holds when every island stopped on its tolerance.
    ///
    /// Each iteration is one sweep followed by a nonsmooth nonlinear
    /// conjugate gradient step (NNCG, Silcowitz, Niebe and Erleben 2010):
    /// the sweep's change `g_k = lambda_k+1 - lambda_k` is taken as the
    /// (preconditioned) descent direction, and the impulses move on along
    /// `d_k = g_k + beta d_k-1`, `beta = |g_k|^2 / |g_k-1|^2` (Fletcher-
    /// Reeves), restarted (`d = g`) when `beta > RESTART_BETA`, i.e. when
    /// the sweeps grow. The next sweep projects whatever the step left
    /// outside the cones. Measured on the 100-sphere pile at rest: plain
    /// sweeps need 1,500-5,000 iterations to 1e-6 m/s, this a few hundred
    /// (`bench pile`); on small scenes it changes little.
    ///
    /// It stops when the relative residual reaches `params.tolerance` or
    /// when the sweeps' changes say the answer is within
    /// `params.velocity_tolerance` (m/s, [`within`]): a physical rule, an
    /// error of at most that speed on any contact or joint direction (`h`
    /// times it in position per step), with the impulse error it implies,
    /// `1 / W_kk` times it in N s. NOTE: not the natural-map residual in
    /// m/s (each row's Jacobi update at the current impulses), although it
    /// is the measure of "every constraint holds to the tolerance": tried,
    /// it halved the steps at the cap on the 100 pile at 1e-5 m/s (31 to
    /// 15 of 130), but at 1e-9 m/s it stopped the reference scene 1.5e-6
    /// m/s from Lemke's velocities (its joint chain is ill-conditioned: a
    /// small residual is not a small error).
    pub fn solve(
        &mut self,
        p: &PgsProblem,
        params: &PgsParams,
        lambda: &mut [f64],
        nu: &mut Vec<f64>,
        z: &mut Vec<f64>,
    ) -> PgsInfo {
        self.prepare(p);
        self.gather(p, lambda);
        nu.clear();
        nu.extend_from_slice(p.nu_free);
        for (w, &x) in self.weighted.iter().zip(&self.x) {
            if x != 0.0 {
                w.add_to(x, nu);
            }
        }
        for (w, &x) in self.tails_weighted.iter().zip(&self.x[p.tails.first..]) {
            if x != 0.0 {
                w.add_to(x, nu);
            }
        }
        let n = self.x.len();
        self.direction.clear();
        self.direction.resize(n, 0.0);
        self.before.clear();
        self.before.resize(n, 0.0);
        // No clearing needed beyond the size: a restart (every island's
        // first momentum step) writes the direction before it is read.
        self.nu_before.resize(nu.len(), 0.0);
        self.nu_direction.resize(nu.len(), 0.0);
        let mut info = PgsInfo {
            iterations: 0,
            residual: f64::INFINITY,
            converged: true,
        };
        let plain = PgsParams {
            momentum: false,
            ..*params
        };
        for &g in p.iterate {
            let descend = p.descend.get(g as usize).copied().unwrap_or(false);
            let params = if descend { &plain } else { params };
            let (iterations, converged) = self.iterate(p, params, g as usize, nu);
            info.iterations = info.iterations.max(iterations);
            info.converged &= converged;
        }
        info.residual = self.residual(p, lambda, nu, z);
        info
    }

    /// Island `g` iterated to its stop (see [`Pgs::solve`]): its sweeps,
    /// and whether a tolerance stopped it (else the cap).
    fn iterate(
        &mut self,
        p: &PgsProblem,
        params: &PgsParams,
        g: usize,
        nu: &mut [f64],
    ) -> (usize, bool) {
        let tolerance = match params.stop {
            Stop::Residual if params.relative > 0.0 => params
                .velocity_tolerance
                .max(params.relative * self.fastest_approach(p, g)),
            _ => params.velocity_tolerance,
        };
        let params = &PgsParams {
            velocity_tolerance: tolerance,
            ..*params
        };
        let mut last_g2 = 0.0;
        let mut recent = [f64::INFINITY; RATE_WINDOW + 1];
        let cap = params.max_iterations.max(1);
        // Which contacts the sweeps list for `focus`: none under the
        // distance rule.
        let focus_above = match params.stop {
            Stop::Residual => params.velocity_tolerance,
            Stop::Distance => f64::INFINITY,
        };
        for it in 1..=cap {
            if params.momentum {
                match self.span(g) {
                    Some(r) => self.before[r.clone()].copy_from_slice(&self.x[r]),
                    None => {
                        let (lo, hi) = (
                            self.coord_start[g] as usize,
                            self.coord_start[g + 1] as usize,
                        );
                        for &c in &self.coords[lo..hi] {
                            self.before[c as usize] = self.x[c as usize];
                        }
                    }
                }
                let (lo, hi) = (self.body_start[g] as usize, self.body_start[g + 1] as usize);
                for &b in &self.bodies[lo..hi] {
                    let v = 6 * b as usize..6 * b as usize + 6;
                    self.nu_before[v.clone()].copy_from_slice(&nu[v]);
                }
            }
            let correction = self.sweep(p, g, params.relaxation, focus_above, nu);
            recent.rotate_right(1);
            recent[0] = correction;
            let done = match params.stop {
                Stop::Distance => {
                    within(&recent[..it.min(recent.len())], params.velocity_tolerance)
                }
                Stop::Residual => correction <= params.velocity_tolerance,
            };
            if done {
                return (it, true);
            }
            if it >= FOCUS_AFTER && self.focus_count <= FOCUS_MAX {
                self.focus(p, params, nu);
            }
            if params.momentum {
                last_g2 = self.momentum(g, last_g2, nu);
            }
            // The relative residual as a second exit of the distance rule
            // (a pass over the island's rows: not with the residual rule,
            // whose few sweeps on a pile it would slow by a tenth).
            if params.stop == Stop::Distance
                && it % CHECK_EVERY == 0
                && self.residual_of(p, g, nu).relative() <= params.tolerance
            {
                return (it, true);
            }
        }
        (cap, false)
    }

    /// The largest normal speed (m/s) of island `g`'s contacts at the
    /// free velocity: how fast its bodies come together this step.
    fn fastest_approach(&self, p: &PgsProblem, g: usize) -> f64 {
        let normals = p.nb..p.nb + p.nc;
        p.groups
            .rows_of(g)
            .iter()
            .filter(|&&k| normals.contains(&(k as usize)))
            .map(|&k| p.rows[k as usize].velocity(p.nu_free).abs())
            .fold(0.0, f64::max)
    }

    /// The iterate `x` from the impulses `lambda` of every row.
    fn gather(&mut self, p: &PgsProblem, lambda: &[f64]) {
        let rows = p.nb + p.nc;
        self.x.clear();
        self.x.extend_from_slice(&lambda[..rows]);
        for f in 0..p.friction_of.len() {
            let base = rows + f * p.nd;
            let pt = self.polygon.tangential(&lambda[base..base + p.nd]);
            self.x.extend_from_slice(&pt);
        }
        let motors = p.motor_rows();
        self.x
            .extend_from_slice(&lambda[motors..motors + p.motor_cap.len()]);
    }

    /// Where motor `k`'s impulse is in `x`.
    fn motor_at(p: &PgsProblem, k: usize) -> usize {
        p.nb + p.nc + 2 * p.friction_of.len() + k
    }

    /// The impulses `lambda` of every row from the iterate `x`: each
    /// friction block's tangential impulse on the two directions that
    /// bracket it.
    fn scatter(&self, p: &PgsProblem, lambda: &mut [f64]) {
        let rows = p.nb + p.nc;
        lambda[..rows].copy_from_slice(&self.x[..rows]);
        for f in 0..p.friction_of.len() {
            let base = rows + f * p.nd;
            let pt = [self.x[rows + 2 * f], self.x[rows + 2 * f + 1]];
            self.polygon.decompose(pt, &mut lambda[base..base + p.nd]);
        }
        let (motors, nm) = (p.motor_rows(), p.motor_cap.len());
        let at = Self::motor_at(p, 0);
        lambda[motors..motors + nm].copy_from_slice(&self.x[at..at + nm]);
    }

    /// The diagonal, the weighted rows and the friction blocks of `p`.
    fn prepare(&mut self, p: &PgsProblem) {
        // Its full size once: no allocation in a sweep after warm-up.
        self.focus.clear();
        self.focus.reserve(FOCUS_MAX);
        self.polygon.set(p.nd);
        let rows = p.nb + p.nc;
        self.weighted.clear();
        self.weighted
            .extend(p.rows[..rows].iter().map(|row| row.weighted(p.minv)));
        self.diag.clear();
        self.diag.extend(
            p.rows[..rows]
                .iter()
                .zip(&self.weighted)
                .zip(p.cfm)
                .map(|((row, w), cfm)| row.dot(w) + cfm),
        );
        self.tails_weighted.clear();
        self.tails_weighted
            .extend(p.tails.rows.iter().map(|row| row.weighted(p.minv)));
        for (i, _) in p.tails.rows.iter().enumerate() {
            let k = p.tails.first + i;
            self.diag[k] = p.tails.diagonal(k, &p.rows[k], p.minv) + p.cfm[k];
        }
        // A zero diagonal is a row the updates leave alone.
        for (i, _) in p.held.iter().enumerate().filter(|(_, &h)| h) {
            self.diag[p.nb + i] = 0.0;
        }
        self.inv_diag.clear();
        self.inv_diag.extend(self.diag.iter().map(|&d| 1.0 / d));
        self.block_of.clear();
        self.block_of.resize(p.nc, None);
        for (f, &i) in p.friction_of.iter().enumerate() {
            self.block_of[i] = Some(f);
        }
        self.coords.clear();
        self.coord_start.clear();
        self.coord_start.push(0);
        self.motors.clear();
        self.motor_start.clear();
        self.motor_start.push(0);
        // Ascending, as `x` is laid out (rows, then the blocks in the order
        // of their normal rows): one island's momentum then sums in the
        // same order as the whole iterate's did, and a scene of one island
        // keeps its bits (the order of a sum is round-off, and a
        // near-singular step amplifies it: the reference scene's PGS run
        // took another path at step 5,031 of 10,000 with the rows and
        // blocks interleaved, and needed 12 times the sweeps after it).
        for g in 0..p.groups.len() {
            let rows_g = p.groups.rows_of(g);
            self.coords.extend_from_slice(rows_g);
            for &k in rows_g {
                if let Some(f) = (k as usize)
                    .checked_sub(p.nb)
                    .and_then(|i| self.block_of[i])
                {
                    let at = (rows + 2 * f) as u32;
                    self.coords.extend([at, at + 1]);
                }
            }
            // Its motors (an island's by its joint's rows), after every
            // block in `x`: the list stays ascending.
            for (k, &r) in p.motor_row.iter().enumerate() {
                if p.groups.island_of_row(r) == g {
                    self.motors.push(k as u32);
                    self.coords.push(Self::motor_at(p, k) as u32);
                }
            }
            self.motor_start.push(self.motors.len() as u32);
            self.coord_start.push(self.coords.len() as u32);
        }
        // Each island's bodies (a motor and a friction block move the
        // bodies of their joint's or contact's rows).
        self.listed.clear();
        self.listed.resize(p.nu_free.len() / 6, false);
        self.bodies.clear();
        self.body_start.clear();
        self.body_start.push(0);
        for g in 0..p.groups.len() {
            let first = self.bodies.len();
            for &k in p.groups.rows_of(g) {
                let row = &p.rows[k as usize];
                for j in [row.a, row.b].into_iter().flatten() {
                    if !std::mem::replace(&mut self.listed[j.body], true) {
                        self.bodies.push(j.body as u32);
                    }
                }
            }
            self.bodies[first..].sort_unstable();
            self.body_start.push(self.bodies.len() as u32);
        }
        self.tangent.clear();
        for f in 0..p.friction_of.len() {
            let base = p.nb + p.nc + f * p.nd;
            // d_0 = t1; t2 from d_1 = cos(a) t1 + sin(a) t2.
            let (c, s) = direction(1, p.nd);
            let t1 = p.rows[base];
            let t2 = Row::combine(&p.rows[base + 1], 1.0 / s, &t1, -c / s);
            let (w1, w2) = (t1.weighted(p.minv), t2.weighted(p.minv));
            let (a, b, d) = (t1.dot(&w1), t1.dot(&w2), t2.dot(&w2));
            let det = a * d - b * b;
            let scale = 0.5 * (a + d) + (0.25 * (a - d).powi(2) + b * b).sqrt();
            // The block's step: its inverse where the block is a multiple
            // of the identity (a sphere's contact: a point's mass and a
            // lever along the normal), else 1 / its largest eigenvalue.
            // Why: the sweep's fixed point `p = proj(p - S v)` with a
            // Euclidean projection onto the cone's polygon is the friction
            // of maximal dissipation (`-v` in the polygon's normal cone at
            // `p`) only when S is a scalar; with the full inverse of an
            // anisotropic block (a box's vertex, whose lever has a
            // tangential part) it is another point, and PGS slid a box on
            // an incline with 0.71 of its friction (tests/shapes.rs).
            let isotropic = b.abs() <= 1e-9 * (a + d) && (a - d).abs() <= 1e-9 * (a + d);
            let inv = if det <= 1e-14 * (a * d).max(f64::MIN_POSITIVE) {
                [[0.0; 2]; 2]
            } else if isotropic {
                [[d / det, -b / det], [-b / det, a / det]]
            } else {
                [[1.0 / scale, 0.0], [0.0, 1.0 / scale]]
            };
            self.weighted.push(w1);
            self.weighted.push(w2);
            self.tangent.push(Tangent { t1, t2, inv, scale });
        }
        self.held = self.contacts_on_two_bodies(p);
        // The motors' rows, after the blocks in `x` (and so after every
        // island's other coordinates: each island's list stays ascending).
        self.motor_diag.clear();
        for (row, eps) in p.rows[p.motor_rows()..].iter().zip(p.motor_cfm) {
            let w = row.weighted(p.minv);
            self.motor_diag.push(row.dot(&w) + eps);
            self.weighted.push(w);
        }
    }

    /// Whether every contact's rows with a friction block (its normal
    /// row, that row's weighted row, the block's `t1`, `t2` and their
    /// weighted rows) act on the same body A and the same other body B or
    /// none, A and B distinct: the condition of [`Held`].
    fn contacts_on_two_bodies(&self, p: &PgsProblem) -> bool {
        let bodies = |r: &Row| (r.a.map(|j| j.body), r.b.map(|j| j.body));
        p.friction_of.iter().enumerate().all(|(f, &i)| {
            let k = p.nb + i;
            let at = p.nb + p.nc + 2 * f;
            let tg = &self.tangent[f];
            let ab = bodies(&p.rows[k]);
            ab.0.is_some()
                && ab.0 != ab.1
                && [
                    &self.weighted[k],
                    &tg.t1,
                    &tg.t2,
                    &self.weighted[at],
                    &self.weighted[at + 1],
                ]
                .into_iter()
                .all(|r| bodies(r) == ab)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_pgs_solves_a_spd_lcp_and_reports_a_cap() {
        // M = [[2,1],[1,2]], q = [-5,-6]: z = [4/3, 7/3].
        let (m, q) = ([2.0, 1.0, 1.0, 2.0], [-5.0, -6.0]);
        let lcp = Lcp { n: 2, m: &m, q: &q };
        let mut z = [0.0; 2];
        let info = solve_dense(&lcp, &PgsParams::default(), &mut z);
        assert!(info.converged && info.residual <= 1e-10, "{info:?}");
        assert!((z[0] - 4.0 / 3.0).abs() < 1e-9 && (z[1] - 7.0 / 3.0).abs() < 1e-9);
        // A zero diagonal cannot be stepped: the cap is reached and said.
        let (m, q) = ([0.0, 1.0, -1.0, 0.0], [-1.0, 1.0]);
        let lcp = Lcp { n: 2, m: &m, q: &q };
        let params = PgsParams {
            max_iterations: 40,
            ..PgsParams::default()
        };
        let info = solve_dense(&lcp, &params, &mut z);
        assert!(
            !info.converged && info.iterations == 40 && info.residual > 0.1,
            "{info:?}"
        );
    }

    #[test]
    fn the_stopping_rule_asks_for_a_rate_where_the_sweeps_creep() {
        let tol = 1e-6;
        // One sweep: a hundredth of the tolerance.
        assert!(within(&[5e-9], tol) && !within(&[5e-7], tol));
        // Shrinking tenfold a sweep: 5e-7 * 0.1 / 0.9 is within.
        assert!(within(&[5e-7, 5e-6, 5e-5, 5e-4, 5e-3], tol));
        // Creeping at rho = 0.9999: 5e-7 * 1e4 is far from within.
        let creep: Vec<f64> = (0..5).map(|k| 5e-7 / 0.9999f64.powi(k)).collect();
        assert!(!within(&creep, tol));
        // A plateau (a cycle) below the tolerance: more sweeps do not help.
        assert!(within(&[3e-7, 3e-7, 3e-7, 3e-7, 3e-7], tol));
        // Above the tolerance: never; nothing changed: always.
        assert!(!within(&[2e-6, 4e-6, 8e-6, 1.6e-5, 3.2e-5], tol));
        assert!(within(&[0.0, 1.0], tol));
    }
}
