//! Contact-set stage: coefficients, start-of-step normal speed and the
//! friction basis of every potential contact.

use crate::collision::Geometry;
use crate::model::kinematics::{perpendicular, point_velocity};
use crate::model::state::State;
use crate::model::Counterpart;
use crate::model::{mix_friction, mix_restitution, Model};
use nalgebra::Vector3;

/// Tangential speed (m/s) above which a contact counts as sliding at the start
/// of the step, and its friction basis is aligned with the slip.
///
/// Above the iterative solver's error (1e-6 m/s by default): a contact at
/// rest keeps a slip of that order, and a basis that followed it would turn
/// the polyhedral cone a random angle every step, so that a sticking
/// impulse near the cone's edge is clipped by the turned polygon and the
/// pile creeps. Measured on the 100-sphere pile (PGS, 1e-5 m/s, 300 steps):
/// at 1e-9 m/s the pile at rest needed 1,400-1,900 sweeps a step and kept
/// 3.7e-4 J of motion; at 1e-4 m/s, 4-16 sweeps and 3e-9 J. A real slide
/// passes below 1e-4 m/s within one step (it decelerates by mu g h), so
/// Lemke's answers keep their exact slip direction.
pub const SLIDING_SPEED: f64 = 1e-4;

#[derive(Debug, Clone, Copy)]
pub struct Contact {
    /// Index in the canonical enumeration of potential contacts
    /// (`Model::contact_id`): its identity from step to step.
    pub id: usize,
    pub geom: Geometry,
    pub mu: f64,
    pub e: f64,
    /// Tangent basis: the friction directions are
    /// `d_j = cos(2 pi j / n_d) t1 + sin(2 pi j / n_d) t2`.
    pub t1: Vector3<f64>,
    pub t2: Vector3<f64>,
    /// Normal relative velocity at the start of the step (< 0: approaching).
    pub v_n: f64,
    /// Whether the contact has rows in this step's LCP.
    pub in_lcp: bool,
    /// A joint's limit rather than a touch of two shapes (`joint::limits`).
    pub limit: Option<Limit>,
}

/// A joint limit as a contact: one unilateral row, no friction, the
/// coordinate's distance to the limit as its gap (joint.rs, `limits`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limit {
    pub joint: usize,
    /// The upper limit (else the lower).
    pub upper: bool,
    /// A hinge's: the row turns about the normal (`Row::contact`).
    pub angular: bool,
}

/// `(cos, sin)` of friction direction `j` of `n_d`: `d_j = cos t1 + sin t2`.
/// The one definition the rows, the LCP's expansion and PGS share.
pub fn direction_coefficients(j: usize, nd: usize) -> (f64, f64) {
    // Tabled up to `TABLED` directions: the rows, the LCP and PGS ask for
    // them per contact and step (a twentieth of a pile's step went to
    // `sincos`). The table holds the same expression's values, bit for bit.
    const TABLED: usize = 16;
    static TABLE: std::sync::OnceLock<[[(f64, f64); TABLED + 1]; TABLED + 1]> =
        std::sync::OnceLock::new();
    let exact = |j: usize, nd: usize| {
        let angle = std::f64::consts::TAU * j as f64 / nd as f64;
        (angle.cos(), angle.sin())
    };
    if nd == 0 || nd > TABLED || j > nd {
        return exact(j, nd);
    }
    let table = TABLE.get_or_init(|| {
        let mut t = [[(1.0, 0.0); TABLED + 1]; TABLED + 1];
        for (nd, row) in t.iter_mut().enumerate().skip(1) {
            for (j, d) in row.iter_mut().enumerate().take(nd + 1) {
                *d = exact(j, nd);
            }
        }
        t
    });
    table[nd][j]
}

impl Contact {
    /// Friction direction `j` of `n_d`.
    pub fn direction(&self, j: usize, nd: usize) -> Vector3<f64> {
        let (c, s) = direction_coefficients(j, nd);
        self.t1 * c + self.t2 * s
    }

    pub fn has_friction(&self) -> bool {
        self.mu > 0.0
    }
}

/// Relative velocity of A's contact point against B's.
pub fn relative_velocity(state: &State, g: &Geometry) -> Vector3<f64> {
    let va = point_velocity(&state.bodies[g.a], &g.r_a);
    let vb = match g.b {
        Counterpart::Plane(_) | Counterpart::World => Vector3::zeros(),
        Counterpart::Body(j) => point_velocity(&state.bodies[j], &g.r_b),
    };
    va - vb
}

/// Builds the contact set from the geometry of every potential contact.
pub fn build(model: &Model, state: &State, geoms: &[Geometry], out: &mut Vec<Contact>) {
    out.clear();
    for g in geoms {
        let id = model.contact_id(g.a, g.b, g.feature);
        let a = &model.bodies[g.a];
        let (mu_b, e_b) = match g.b {
            Counterpart::Plane(p) => (model.planes[p].friction, model.planes[p].restitution),
            Counterpart::Body(j) => (model.bodies[j].friction, model.bodies[j].restitution),
            // Collision lists no contact with the world itself.
            Counterpart::World => (0.0, 0.0),
        };
        let v_rel = relative_velocity(state, g);
        let v_n = v_rel.dot(&g.normal);
        let v_t = v_rel - g.normal * v_n;
        let slip = v_t.norm();
        // A sliding contact gets t1 along its slip, so that d_0 and (for even
        // n_d) d_{n_d/2} = -t1 lie exactly along and against it: the friction
        // impulse then opposes the slip exactly, where a fixed basis would let
        // the polyhedral cone steer the body sideways.
        let t1 = if slip > SLIDING_SPEED {
            v_t / slip
        } else {
            perpendicular(&g.normal)
        };
        let t2 = g.normal.cross(&t1);
        out.push(Contact {
            id,
            geom: *g,
            mu: mix_friction(a.friction, mu_b),
            e: mix_restitution(a.restitution, e_b),
            t1,
            t2,
            v_n,
            in_lcp: false,
            limit: None,
        });
    }
}
