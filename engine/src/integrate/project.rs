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
//! Bodies on joints do not move in the projection: it knows nothing of
//! the joints, and moving one would open its joint, which the joint's
//! stabilisation then closes against the contact that the projection
//! opened, a fight that gave energy (a random scene: two spheres hinged
//! at the midpoint of their 2.3 mm overlap). They count as fixed, like
//! the planes: a free body is pushed out of them, and their own deep
//! contacts are left to the velocity stabilisation (as every contact was
//! before this stage existed).
//!
//! Not with a contact compliance (`[compliance.contact]`): there the
//! penetration is the spring's deflection, which its force removes.

use crate::constraint::applied::InvMass;
use crate::constraint::contact::Contact;
use crate::constraint::rows::Row;
use crate::model::state::State;
use crate::model::Counterpart;
use crate::model::Params;
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

/// Scratch space of the projection (used only when it runs).
#[derive(Default)]
pub struct Projection {
    /// `M^-1 G_k` of each row, and its diagonal (Gauss-Seidel only).
    weighted: Vec<Row>,
    diag: Vec<f64>,
    rows: Vec<Row>,
    w: Vec<f64>,
    q: Vec<f64>,
    z: Vec<f64>,
    dx: Vec<f64>,
    /// The inverse masses of the projection: zero for a body on a joint.
    minv: Vec<InvMass>,
}

/// Projects the bodies out of deep penetration; returns how many contacts
/// were deeper than the slop (0: nothing done).
pub fn deep_penetration(
    contacts: &[Contact],
    minv: &[InvMass],
    jointed: &[bool],
    depth: Depth,
    state: &mut State,
    lemke: &mut Lemke,
    ws: &mut Projection,
) -> Result<usize, LemkeError> {
    // A body moves here unless a joint holds it or it has no inverse
    // mass (asleep).
    let moves = |i: usize| !jointed[i] && minv[i].inv_m > 0.0;
    // A joint limit's bodies are on its joint, and its gap is no distance.
    let movable = |c: &Contact| {
        c.limit.is_none()
            && (moves(c.geom.a) || matches!(c.geom.b, Counterpart::Body(j) if moves(j)))
    };
    let deep = contacts
        .iter()
        .filter(|c| c.geom.gap < -depth.slop && movable(c))
        .count();
    if deep == 0 {
        return Ok(0);
    }
    ws.minv.clear();
    ws.minv.extend(
        minv.iter()
            .zip(jointed)
            .map(|(&m, &on_joint)| match on_joint {
                true => InvMass {
                    inv_m: 0.0,
                    inv_i: Matrix3::zeros(),
                },
                false => m,
            }),
    );
    // Every near contact takes part, so that pushing one out cannot push
    // a body into another.
    ws.rows.clear();
    ws.q.clear();
    for c in contacts
        .iter()
        .filter(|c| c.geom.gap < depth.margin && movable(c))
    {
        ws.rows.push(Row::contact(c, c.geom.normal));
        ws.q.push(c.geom.gap);
    }
    let n = ws.rows.len();
    ws.dx.clear();
    ws.dx.resize(6 * state.bodies.len(), 0.0);
    if n > LEMKE_ROWS {
        gauss_seidel(ws);
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
    for i in 0..state.bodies.len() {
        // A sleeping body is static for the step (zero inverse mass, so a
        // zero move), to the bit: its orientation is not normalised again.
        if crate::model::state::asleep(state, i) {
            continue;
        }
        let b = &mut state.bodies[i];
        let d = &ws.dx[6 * i..6 * i + 6];
        b.x += Vector3::new(d[0], d[1], d[2]);
        let q = UnitQuaternion::from_scaled_axis(Vector3::new(d[3], d[4], d[5])) * b.q;
        b.q = UnitQuaternion::new_normalize(q.into_inner());
    }
    Ok(deep)
}

/// The projection's LCP `0 <= G^T M^-1 G z + psi _|_ z >= 0` by projected
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
            let new = (ws.z[k] - r / d).max(0.0);
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
