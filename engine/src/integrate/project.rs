//! Recovery stage: contacts that start a step deeper than the [`slop`]
//! ([`PENETRATION_SLOP`], more under PGS's residual rule) (a scene built overlapping, a restored or reset
//! state, a teleport) are pushed apart by a position projection before the
//! step, not by the velocity stabilisation.
//!
//! Why: `beta psi / h` turns a penetration into a separating velocity that
//! the body keeps. A sphere built 5 mm into a corner of three planes left
//! it at 5 sqrt(3) m/s at h = 1e-3 (the stress suite's overlap case) and
//! rolled out of the corner for ever. The projection moves the bodies by
//! the smallest mass-weighted displacement `dx = M^-1 G_n z` that closes
//! every near contact (Bullet's split impulse, done once):
//!
//! ```text
//!   0 <= G_n^T M^-1 G_n z + psi  _|_  z >= 0
//! ```
//!
//! the normal-only Delassus LCP with the gaps as its right-hand side,
//! solved by Lemke (by matrix-free Gauss-Seidel above [`LEMKE_ROWS`]
//! near contacts). Velocities are left alone, so no energy is added; the
//! step report counts the contacts projected. Below the slop the
//! stabilisation acts as before (penetrations of a running simulation are
//! 1e-12 m with Lemke, 1e-6 m with PGS's distance rule, up to `h` times
//! the tolerance under its residual rule: 0.07 mm on the piles at 1e-2
//! m/s), so ordinary steps are unchanged.
//!
//! Bodies on joints move with their joints held (issue 48, point 6):
//! the joint rows of every joint-linked part with a contact deeper than
//! [`JOINTED_SLOP`] enter the projection as equalities, closing their
//! position errors too (`G_b^T dx + psi_b = 0`), and the mixed problem
//! is reduced by the joint block as the step's mLCP is ([`mixed`]); a
//! few Newton steps on the joints alone then close what the turn opened
//! at second order. Before, such bodies stayed, and the velocity
//! stabilisation launched them at `beta depth / h` (a chain lying 2 cm in
//! the floor at 4 m/s). A contact the joints hold (`mlcp::HELD`), or a
//! move out of scale with the depth ([`MOVE_FACTOR`]: one they nearly
//! hold), leaves the jointed bodies where they are, as before: moving
//! them would open the joint, which its stabilisation then closes
//! against the contact, a fight that gave energy (a random scene: two
//! spheres hinged at the midpoint of their 2.3 mm overlap).
//!
//! The same projection holds together the joints of an island whose last
//! step fell back to the relaxed problem (`State::drifted`): that problem
//! has no joint drift term (`solver::fallback`), so the joints are closed
//! at position level before the next step, with the island's contacts
//! kept from closing (issue 48, point 5: a pendulum locked against a plane
//! ended 10 s with 6.4 cm of joint error; now its relaxed steps hold the
//! joints as its rigid steps do).
//!
//! Not with a contact compliance (`[compliance.contact]`): there the
//! penetration is the spring's deflection, which its force removes.

use crate::constraint::applied::InvMass;
use crate::constraint::contact::Contact;
use crate::constraint::rows::Row;
use crate::model::islands::Islands;
use crate::model::state::State;
use crate::model::Params;
use crate::model::{Attachment, Counterpart, Joint};
use crate::solver::mlcp::{small, HELD, JOINT_CFM};
use crate::solver::pgs::{PgsParams, Stop};
use crate::solver::{Lcp, Lemke, LemkeError};
use cosim_shared::SolverChoice;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// Penetration (m) beyond which a contact is projected instead of
/// stabilised.
pub const PENETRATION_SLOP: f64 = 1e-4;

/// The depth beyond which a contact counts as deep in a run with these
/// parameters: [`PENETRATION_SLOP`], or twice what PGS's residual rule
/// itself leaves where a step can be solved by PGS (`auto` or `pgs`): that
/// rule stops with constraint violations up to its velocity tolerance,
/// so a running pile sits up to `h` times it deep (0.3 mm at h = 1e-2 and
/// 3e-2 m/s). A slop below that projected ordinary steps of a pile at rest,
/// a Lemke solve of up to 600 rows each time: on the 100-sphere pile at 3e-2
/// m/s, 80 % of the run's time, 1.7 s of 2.1 s.
/// `pgs` is the engine's iterative solver's parameters (the scene's, or
/// what `Engine::set_pgs_params` set).
pub fn slop(p: &Params, pgs: &PgsParams) -> f64 {
    PENETRATION_SLOP.max(2.0 * p.h * resolution(p, pgs))
}

/// The constraint velocity (m/s) that a step's answer may leave: PGS's
/// tolerance where its residual rule can solve a step (`auto` or `pgs`),
/// else none (Lemke's answers and the distance rule's are exact to far
/// below what a contact's depth or a body's rest would notice).
pub fn resolution(p: &Params, pgs: &PgsParams) -> f64 {
    let iterative = p.solver != SolverChoice::Lemke && pgs.stop == Stop::Residual;
    match iterative {
        true => pgs.velocity_tolerance,
        false => 0.0,
    }
}

/// What the projection takes of the run's parameters: the depth beyond
/// which a contact is deep, and the gap within which one is near.
#[derive(Debug, Clone, Copy)]
pub struct Depth {
    pub slop: f64,
    pub margin: f64,
}

impl Depth {
    /// `None` with a contact compliance (`[compliance.contact]`): there the
    /// penetration is the spring's deflection, which its force removes.
    pub fn of(p: &Params, pgs: &PgsParams) -> Option<Depth> {
        p.contact_compliance.is_none().then(|| Depth {
            slop: slop(p, pgs),
            margin: p.contact_margin,
        })
    }
}

/// Above this many near contacts the projection's LCP is solved by
/// projected Gauss-Seidel, matrix-free, not by Lemke on its dense matrix:
/// a pile whose contacts all took part (2,000 of them on the 1,000 pile at
/// a loose PGS tolerance) spent 10 s in one projection. The size at which
/// `auto` turns to PGS for the step's LCP.
const LEMKE_ROWS: usize = crate::solver::AUTO_PGS_SIZE;

/// The Gauss-Seidel projection stops when no update moves a contact by
/// more than this (m): a thousandth of the slop.
const GS_TOLERANCE: f64 = 1e-3 * PENETRATION_SLOP;

/// Its sweep cap: what it has not closed by then the velocity
/// stabilisation closes in the step.
const GS_MAX_SWEEPS: usize = 1000;

/// The largest move of a body, relative to the deepest contact plus the
/// sum of the joints' errors, that a projection with joints makes: a
/// contact the joints nearly hold asks for moves far larger than its
/// depth (two spheres jointed near their line of centres, the pair of
/// tests/tests/held_contacts.rs: a 2 mm overlap turned one by a radian
/// and opened the joint by 2.6 cm), and then the jointed bodies stay.
const MOVE_FACTOR: f64 = 4.0;

/// Newton steps on the joints after a projection that moved jointed
/// bodies, and the joint error (m, or rad for a turning row) at which
/// they stop.
const NEWTON_STEPS: usize = 3;
const NEWTON_TOLERANCE: f64 = 1e-12;

/// Penetration (m) beyond which a contact moves the joint-linked part of
/// its bodies (a robot built into the floor, a teleport): below it, the
/// velocity stabilisation removes a running robot's contact depth as
/// before, at no more than `beta` times this over `h`. Measured: the
/// projection at the slop moved Talos (example-robot-data) every step of
/// its landing, as Lemke left its feet 0.1-0.2 mm deep, and the moves
/// (whose contacts are linearised) left it deeper than the velocity
/// stabilisation alone did (1.4 mm against 0.19 mm over 0.3 s).
pub const JOINTED_SLOP: f64 = 1e-3;

/// Scratch space of the projection (used only when it runs).
#[derive(Default)]
pub struct Projection {
    /// `M^-1 G_k` of each row, and its diagonal (Gauss-Seidel only).
    weighted: Vec<Row>,
    diag: Vec<f64>,
    /// The joint rows first (`joint_rows` of them: equalities), then the
    /// contacts' normal rows; `q` their position errors and gaps.
    rows: Vec<Row>,
    joint_rows: usize,
    w: Vec<f64>,
    q: Vec<f64>,
    z: Vec<f64>,
    dx: Vec<f64>,
    /// The joint block's factor, `Y = L^-1 A_bn`, `L^-1 psi_b`, the
    /// reduced matrix and right-hand side (the mixed problem only).
    chol: Vec<f64>,
    y: Vec<f64>,
    yb: Vec<f64>,
    s: Vec<f64>,
    qs: Vec<f64>,
    zs: Vec<f64>,
    /// Per contact row, whether it takes part (not held by the joints),
    /// and the indices of those that do.
    kept: Vec<bool>,
    index: Vec<usize>,
    /// The inverse masses of the projection: zero for a body that stays.
    minv: Vec<InvMass>,
    /// The bodies' joint-linked parts, and which of them move.
    parts: Islands,
    moving: Vec<bool>,
}

/// The bodies of the projection: their inverse masses, which are on a
/// joint, and which had their joints' drift left uncorrected by the last
/// step (its island fell back to the relaxed problem, which has no drift
/// term).
#[derive(Clone, Copy)]
pub struct Bodies<'a> {
    pub minv: &'a [InvMass],
    pub jointed: &'a [bool],
    pub drifted: &'a [bool],
}

/// What a projection did: the contacts deeper than the slop, and the
/// joint rows it held or closed (0 and 0: nothing moved).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Projected {
    pub contacts: usize,
    pub joint_rows: usize,
}

/// Projects the bodies out of deep penetration, and the drifted joints
/// back together; see the module notes.
pub fn deep_penetration(
    contacts: &[Contact],
    bodies: Bodies,
    joints: &[Joint],
    depth: Depth,
    state: &mut State,
    lemke: &mut Lemke,
    ws: &mut Projection,
) -> Result<Projected, LemkeError> {
    let Bodies {
        minv,
        jointed,
        drifted,
    } = bodies;
    // A body with no inverse mass (asleep) stays.
    let awake = |i: usize| minv[i].inv_m > 0.0;
    let drifted = |i: usize| drifted.get(i).copied().unwrap_or(false);
    let on = |c: &Contact, f: &dyn Fn(usize) -> bool| {
        f(c.geom.a) || matches!(c.geom.b, Counterpart::Body(j) if f(j))
    };
    // A joint limit's bodies are on its joint, and its gap is no distance.
    // A contact is deep for a free body past the slop, for a jointed part
    // past `JOINTED_SLOP` too (see there).
    let free = |i: usize| awake(i) && !jointed[i];
    let jointed_deep = |c: &Contact| c.geom.gap < -depth.slop.max(JOINTED_SLOP) && on(c, &awake);
    let deep = |c: &&Contact| {
        c.limit.is_none() && c.geom.gap < -depth.slop && (on(c, &free) || jointed_deep(c))
    };
    let deep_count = contacts.iter().filter(deep).count();
    let drift = (0..minv.len()).any(|i| drifted(i) && awake(i));
    if deep_count == 0 && !drift {
        return Ok(Projected::default());
    }
    // The joint-linked parts that move: those with a deep contact or a
    // drifted body. A part moves whole, its joints held.
    let n_bodies = minv.len();
    ws.moving.clear();
    ws.moving.resize(n_bodies, false);
    if jointed.contains(&true) {
        let links = joints.iter().filter_map(|j| match (j.a, j.b) {
            (Attachment::Body(a), Attachment::Body(b)) => Some((a, Counterpart::Body(b))),
            (Attachment::Body(a), Attachment::World) | (Attachment::World, Attachment::Body(a)) => {
                Some((a, Counterpart::World))
            }
            _ => None,
        });
        ws.parts.partition(n_bodies, links);
        for i in (0..n_bodies).filter(|&i| jointed[i] && drifted(i) && awake(i)) {
            let r = ws.parts.root_of(i);
            ws.moving[r] = true;
        }
        for c in contacts.iter().filter(deep).filter(|c| jointed_deep(c)) {
            let b = match c.geom.b {
                Counterpart::Body(j) => Some(j),
                _ => None,
            };
            for i in [Some(c.geom.a), b].into_iter().flatten() {
                if jointed[i] && awake(i) {
                    let r = ws.parts.root_of(i);
                    ws.moving[r] = true;
                }
            }
        }
    }
    let moving_parts = ws.moving.contains(&true);
    set_masses(minv, jointed, moving_parts, ws);
    let parts_drifted = (0..n_bodies).any(|i| jointed[i] && drifted(i) && awake(i));
    match project(contacts, joints, parts_drifted, depth, state, lemke, ws) {
        Ok(Some(done)) => return Ok(done),
        Err(e) if !moving_parts => return Err(e),
        _ => {}
    }
    // The move the joints asked for was out of scale (a contact they
    // nearly hold), or had no answer (a part its joints keep inside):
    // the jointed bodies stay, as they would without it.
    set_masses(minv, jointed, false, ws);
    Ok(project(contacts, joints, false, depth, state, lemke, ws)?.unwrap_or_default())
}

/// The projection's inverse masses: zero for a body that stays (asleep,
/// or on a joint of a part that does not move; with `parts` false, every
/// jointed body).
fn set_masses(minv: &[InvMass], jointed: &[bool], parts: bool, ws: &mut Projection) {
    ws.minv.clear();
    for i in 0..minv.len() {
        let held = jointed[i] && !(parts && ws.moving[ws.parts.root_of(i)]);
        let stays = minv[i].inv_m <= 0.0 || held;
        ws.minv.push(match stays {
            true => InvMass {
                inv_m: 0.0,
                inv_i: Matrix3::zeros(),
            },
            false => minv[i],
        });
    }
}

/// The projection on the bodies `ws.minv` moves; `None` (nothing moved)
/// when the move is out of scale (some body would move by more than
/// [`MOVE_FACTOR`] times the deepest contact plus the joints' errors), or
/// when jointed parts would move for contacts their joints all hold
/// (unless `drift`: their joints are to be closed).
fn project(
    contacts: &[Contact],
    joints: &[Joint],
    drift: bool,
    depth: Depth,
    state: &mut State,
    lemke: &mut Lemke,
    ws: &mut Projection,
) -> Result<Option<Projected>, LemkeError> {
    // The moving parts' joints, held at position level (their errors
    // closed: `G^T dx + psi = 0`), then every near contact, so that
    // pushing one out cannot push a body into another.
    push_joint_rows(joints, state, ws);
    let moves = |i: usize| ws.minv[i].inv_m > 0.0;
    let on = |c: &Contact| moves(c.geom.a) || matches!(c.geom.b, Counterpart::Body(j) if moves(j));
    for c in contacts
        .iter()
        .filter(|c| c.limit.is_none() && c.geom.gap < depth.margin && on(c))
    {
        ws.rows.push(Row::contact(c, c.geom.normal));
        ws.q.push(c.geom.gap);
    }
    // Every row counts until the joints are found to hold it (`mixed`).
    ws.kept.clear();
    ws.kept.resize(ws.rows.len() - ws.joint_rows, true);
    let n = ws.rows.len();
    ws.dx.clear();
    ws.dx.resize(6 * state.bodies.len(), 0.0);
    if n > LEMKE_ROWS {
        gauss_seidel(ws);
    } else if ws.joint_rows > 0 {
        mixed(lemke, ws)?;
    } else {
        ws.w.clear();
        for k in 0..n {
            for l in 0..n {
                ws.w.push(ws.rows[k].coupling(&ws.rows[l], &ws.minv));
            }
        }
        ws.z.clear();
        ws.z.resize(n, 0.0);
        lemke.solve(
            &Lcp {
                n,
                m: &ws.w,
                q: &ws.q,
            },
            &mut ws.z,
        )?;
        for (row, &z) in ws.rows.iter().zip(&ws.z) {
            row.apply(z, &ws.minv, &mut ws.dx);
        }
    }
    let nb = ws.joint_rows;
    let deepest = (ws.q[nb..].iter()).fold(0.0f64, |a, &gap| a.max(-gap));
    let errors: f64 = ws.q[..nb].iter().map(|q| q.abs()).sum();
    let largest = (ws.dx.chunks_exact(6)).fold(0.0f64, |a, d| a.max(d[0].hypot(d[1]).hypot(d[2])));
    // The deep contacts that move: those of the rows kept.
    let contacts = (ws.q[nb..].iter().zip(&ws.kept))
        .filter(|&(&gap, &kept)| kept && gap < -depth.slop)
        .count();
    // Parts moved for their contacts whose joints hold every deep one
    // stay too: they would only close their joints' errors.
    let idle = nb > 0 && !drift && contacts == 0;
    if idle || (nb > 0 && largest > MOVE_FACTOR * (deepest + errors)) {
        return Ok(None);
    }
    apply(&ws.dx, state);
    // The joints' rows are linear in the move: a part that turned opened
    // them at second order (a pendulum pushed 1.5 mm aside on a 0.25 m
    // arm: 4.4e-6 m). Newton steps on the joints alone close that.
    for _ in 0..NEWTON_STEPS {
        push_joint_rows(joints, state, ws);
        if ws.q.iter().all(|q| q.abs() <= NEWTON_TOLERANCE) {
            break;
        }
        ws.kept.clear();
        ws.dx.fill(0.0);
        mixed(lemke, ws)?;
        apply(&ws.dx, state);
    }
    Ok(Some(Projected {
        contacts,
        joint_rows: nb,
    }))
}

/// The rows of the joints on a moving body (`ws.minv` positive) and
/// their position errors, into `ws.rows` and `ws.q` (cleared first).
fn push_joint_rows(joints: &[Joint], state: &State, ws: &mut Projection) {
    let minv = &ws.minv;
    let moves = |a: Attachment| match a {
        Attachment::Body(i) => minv[i].inv_m > 0.0,
        Attachment::World => false,
    };
    let moving = joints.iter().filter(|j| moves(j.a) || moves(j.b));
    crate::constraint::joint::position_rows(moving, state, &mut ws.rows, &mut ws.q);
    ws.joint_rows = ws.rows.len();
}

/// Moves the bodies by `dx` (6 per body). A body that stays keeps its
/// bits: its orientation is not normalised again (a sleeping body, a far
/// island).
fn apply(dx: &[f64], state: &mut State) {
    for (b, d) in state.bodies.iter_mut().zip(dx.chunks_exact(6)) {
        if d.iter().all(|&x| x == 0.0) {
            continue;
        }
        b.x += Vector3::new(d[0], d[1], d[2]);
        let q = UnitQuaternion::from_scaled_axis(Vector3::new(d[3], d[4], d[5])) * b.q;
        b.q = UnitQuaternion::new_normalize(q.into_inner());
    }
}

/// The projection with joints, dense: the joint rows' impulses `p` free,
/// the contacts' `z >= 0`,
///
/// ```text
///   A_bb p + A_bn z + psi_b  = 0
///   A_nb p + A_nn z + psi_n >= 0  _|_  z >= 0,     A = G^T M^-1 G
/// ```
///
/// reduced by the joint block's Cholesky factor `L` as the step's mLCP is
/// (`solver::mlcp`): with `Y = L^-1 A_bn` and `y = L^-1 psi_b`, the LCP
/// `(A_nn - Y^T Y) z + (psi_n - Y^T y)`, then `p = -L^-T (y + Y z)`.
/// Redundant joints (a closed loop) get a small diagonal shift. Leaves
/// `dx = M^-1 (G_b p + G_n z)` in `ws.dx`.
fn mixed(lemke: &mut Lemke, ws: &mut Projection) -> Result<(), LemkeError> {
    let (nb, n) = (ws.joint_rows, ws.rows.len());
    let nc = n - nb;
    let minv = &ws.minv;
    let coupling = |k: usize, l: usize| ws.rows[k].coupling(&ws.rows[l], minv);
    ws.chol.clear();
    for l in 0..nb {
        ws.chol.extend((0..nb).map(|k| coupling(k, l)));
    }
    // Tried on a copy first (`s` is free until the reduced matrix).
    ws.s.clone_from(&ws.chol);
    if small::cholesky(&mut ws.s, nb).is_err() {
        let shift = JOINT_CFM * (0..nb).fold(0.0f64, |a, k| a.max(ws.chol[k * nb + k]));
        for k in 0..nb {
            ws.chol[k * nb + k] += shift;
        }
    }
    if let Err(row) = small::cholesky(&mut ws.chol, nb) {
        return Err(LemkeError::NumericalBreakdown {
            pivots: row,
            residual: f64::INFINITY,
        });
    }
    ws.y.clear();
    for j in nb..n {
        ws.y.extend((0..nb).map(|k| coupling(k, j)));
    }
    small::solve_lower(&ws.chol, nb, &mut ws.y);
    ws.yb.clear();
    ws.yb.extend_from_slice(&ws.q[..nb]);
    small::solve_lower(&ws.chol, nb, &mut ws.yb);
    let col = |j: usize| &ws.y[j * nb..(j + 1) * nb];
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    // A contact the joints hold (its reduced diagonal under `HELD` of its
    // own, as the step's `mlcp::HELD`) can move nothing the joints do not
    // undo: it is left out (`z = 0`), its gap to the velocity
    // stabilisation, which the step's held rows leave alone too.
    for j in 0..nc {
        let own = coupling(nb + j, nb + j);
        ws.kept[j] = own - dot(col(j), col(j)) > HELD * own;
    }
    ws.index.clear();
    ws.index.extend((0..nc).filter(|&j| ws.kept[j]));
    let m = ws.index.len();
    ws.s.clear();
    for &j in &ws.index {
        for &k in &ws.index {
            ws.s.push(coupling(nb + j, nb + k) - dot(col(j), col(k)));
        }
    }
    ws.qs.clear();
    ws.qs
        .extend(ws.index.iter().map(|&j| ws.q[nb + j] - dot(col(j), &ws.yb)));
    ws.zs.clear();
    ws.zs.resize(m, 0.0);
    if m > 0 {
        lemke.solve(
            &Lcp {
                n: m,
                m: &ws.s,
                q: &ws.qs,
            },
            &mut ws.zs,
        )?;
    }
    ws.z.clear();
    ws.z.resize(n, 0.0);
    for (&j, &z) in ws.index.iter().zip(&ws.zs) {
        ws.z[nb + j] = z;
    }
    // p = -L^-T (y + Y z), into z's first nb entries.
    for k in 0..nb {
        let yz: f64 = (0..nc).map(|j| ws.y[j * nb + k] * ws.z[nb + j]).sum();
        ws.z[k] = ws.yb[k] + yz;
    }
    small::solve_upper_transposed(&ws.chol, nb, &mut ws.z[..nb]);
    for p in &mut ws.z[..nb] {
        *p = -*p;
    }
    for (row, &z) in ws.rows.iter().zip(&ws.z) {
        row.apply(z, &ws.minv, &mut ws.dx);
    }
    Ok(())
}

/// The projection's LCP `0 <= G^T M^-1 G z + psi _|_ z >= 0` (the joint
/// rows, first, as equalities with `z` free) by projected
/// Gauss-Seidel with the displacement `dx = M^-1 G z` kept up to date, so
/// that no matrix is formed: each row `z_k <- max(0, z_k - (G_k^T dx +
/// psi_k) / W_kk)`. Leaves `dx` in `ws.dx`.
fn gauss_seidel(ws: &mut Projection) {
    ws.weighted.clear();
    ws.weighted
        .extend(ws.rows.iter().map(|r| r.weighted(&ws.minv)));
    ws.diag.clear();
    ws.diag
        .extend(ws.rows.iter().zip(&ws.weighted).map(|(r, w)| r.dot(w)));
    ws.z.clear();
    ws.z.resize(ws.rows.len(), 0.0);
    for _ in 0..GS_MAX_SWEEPS {
        let mut largest = 0.0f64;
        for k in 0..ws.rows.len() {
            let d = ws.diag[k];
            if d <= 0.0 {
                continue;
            }
            let r = ws.rows[k].velocity(&ws.dx) + ws.q[k];
            let new = match k < ws.joint_rows {
                true => ws.z[k] - r / d,
                false => (ws.z[k] - r / d).max(0.0),
            };
            let delta = new - ws.z[k];
            if delta != 0.0 {
                ws.z[k] = new;
                ws.weighted[k].add_to(delta, &mut ws.dx);
                largest = largest.max(delta.abs() * d);
            }
        }
        if largest <= GS_TOLERANCE {
            return;
        }
    }
}
