//! Jacobian stage: one row per constraint direction, each touching at most
//! two bodies. A row's velocity is `lin . v + ang . w` summed over its bodies;
//! the same row, transposed, maps its impulse to the bodies.

use crate::constraint::applied::InvMass;
use crate::constraint::contact::Contact;
use crate::model::state::State;
use crate::model::Counterpart;
use nalgebra::Vector3;

/// The part of a row on one body.
#[derive(Debug, Clone, Copy)]
pub struct BodyJac {
    pub body: usize,
    pub lin: Vector3<f64>,
    pub ang: Vector3<f64>,
}

// The two functions below are the inner loop of PGS (a sweep is one
// `velocity` and one `add_to` per row): inlined, and with one bounds check
// per body instead of six. Measured: `add_to` was a fifth of a pile's time.
impl BodyJac {
    #[inline]
    fn velocity(&self, nu: &[f64]) -> f64 {
        self.velocity_of(&nu[6 * self.body..6 * self.body + 6])
    }

    #[inline]
    fn add_to(&self, impulse: f64, nu: &mut [f64]) {
        self.add_impulse(impulse, &mut nu[6 * self.body..6 * self.body + 6]);
    }

    /// `lin . v + ang . w` with `v` this body's six velocities.
    #[inline]
    pub fn velocity_of(&self, v: &[f64]) -> f64 {
        self.lin.x * v[0]
            + self.lin.y * v[1]
            + self.lin.z * v[2]
            + self.ang.x * v[3]
            + self.ang.y * v[4]
            + self.ang.z * v[5]
    }

    /// `v += impulse * [lin; ang]` with `v` this body's six velocities.
    #[inline]
    pub fn add_impulse(&self, impulse: f64, v: &mut [f64]) {
        v[0] += self.lin.x * impulse;
        v[1] += self.lin.y * impulse;
        v[2] += self.lin.z * impulse;
        v[3] += self.ang.x * impulse;
        v[4] += self.ang.y * impulse;
        v[5] += self.ang.z * impulse;
    }
}

/// One constraint row: `G^T nu` restricted to this direction.
#[derive(Debug, Clone, Copy)]
pub struct Row {
    pub a: Option<BodyJac>,
    pub b: Option<BodyJac>,
}

impl Row {
    /// A row between A (lever arm `r_a`) and B (`r_b`) along the world
    /// direction `dir`: `[dir ; r_A x dir]` on A and `-[dir ; r_B x dir]` on B,
    /// the columns of `G_n`, `G_f` and `G_b` in formulation.md.
    pub fn along(
        dir: Vector3<f64>,
        a: Option<(usize, Vector3<f64>)>,
        b: Option<(usize, Vector3<f64>)>,
    ) -> Row {
        Row {
            a: a.map(|(body, r)| BodyJac {
                body,
                lin: dir,
                ang: r.cross(&dir),
            }),
            b: b.map(|(body, r)| BodyJac {
                body,
                lin: -dir,
                ang: -r.cross(&dir),
            }),
        }
    }

    /// A rotation row along the world direction `dir`: `[0 ; dir]` on A
    /// and `-[0 ; dir]` on B, the relative angular velocity along `dir`
    /// (a hinge's or a fixed joint's, joint.rs).
    pub fn turning(dir: Vector3<f64>, a: Option<usize>, b: Option<usize>) -> Row {
        let zero = Vector3::zeros();
        Row {
            a: a.map(|body| BodyJac {
                body,
                lin: zero,
                ang: dir,
            }),
            b: b.map(|body| BodyJac {
                body,
                lin: zero,
                ang: -dir,
            }),
        }
    }

    /// A contact row along `dir` (the normal or a friction direction); a
    /// hinge limit's is the turning row about `dir` (limit.rs).
    pub fn contact(c: &Contact, dir: Vector3<f64>) -> Row {
        let g = &c.geom;
        let b = match g.b {
            Counterpart::Plane(_) | Counterpart::World => None,
            Counterpart::Body(j) => Some((j, g.r_b)),
        };
        if c.limit.is_some_and(|l| l.angular) {
            return Row::turning(dir, Some(g.a), b.map(|(j, _)| j));
        }
        Row::along(dir, Some((g.a, g.r_a)), b)
    }

    /// `ca a + cb b` for two rows on the same bodies (rows are linear in
    /// their direction: `lin = dir`, `ang = r x dir`).
    pub fn combine(a: &Row, ca: f64, b: &Row, cb: f64) -> Row {
        let mix = |x: Option<BodyJac>, y: Option<BodyJac>| match (x, y) {
            (Some(x), Some(y)) => Some(BodyJac {
                body: x.body,
                lin: x.lin * ca + y.lin * cb,
                ang: x.ang * ca + y.ang * cb,
            }),
            _ => None,
        };
        Row {
            a: mix(a.a, b.a),
            b: mix(a.b, b.b),
        }
    }

    /// The row's velocity at the bodies' velocities in `state`.
    pub fn state_velocity(&self, state: &State) -> f64 {
        [self.a, self.b]
            .into_iter()
            .flatten()
            .map(|j| {
                let b = &state.bodies[j.body];
                j.lin.dot(&b.v) + j.ang.dot(&b.w)
            })
            .sum()
    }

    /// The row's velocity `G_k^T nu`.
    #[inline]
    pub fn velocity(&self, nu: &[f64]) -> f64 {
        self.a.map_or(0.0, |j| j.velocity(nu)) + self.b.map_or(0.0, |j| j.velocity(nu))
    }

    /// `nu += M^-1 G_k impulse`.
    pub fn apply(&self, impulse: f64, minv: &[InvMass], nu: &mut [f64]) {
        for j in [self.a, self.b].into_iter().flatten() {
            let m = &minv[j.body];
            let dv = j.lin * (m.inv_m * impulse);
            let dw = m.inv_i * j.ang * impulse;
            let k = 6 * j.body;
            for d in 0..3 {
                nu[k + d] += dv[d];
                nu[k + 3 + d] += dw[d];
            }
        }
    }

    /// `nu += impulse * self`, for a [`Row::weighted`] row: the bodies'
    /// velocity change from the row's impulse.
    #[inline]
    pub fn add_to(&self, impulse: f64, nu: &mut [f64]) {
        if let Some(j) = &self.a {
            j.add_to(impulse, nu);
        }
        if let Some(j) = &self.b {
            j.add_to(impulse, nu);
        }
    }

    /// Delassus entry `G_k^T M^-1 G_l`: nonzero only where the rows share a body.
    pub fn coupling(&self, other: &Row, minv: &[InvMass]) -> f64 {
        self.dot(&other.weighted(minv))
    }

    /// The row's impulse response `M^-1 G_k` on each of its bodies, as a
    /// row (`lin / m`, `I^-1 ang`): with it, a Delassus entry is a plain
    /// [`Row::dot`], and a matrix of couplings weighs each row once instead
    /// of once per entry.
    pub fn weighted(&self, minv: &[InvMass]) -> Row {
        let w = |j: Option<BodyJac>| {
            j.map(|j| {
                let m = &minv[j.body];
                BodyJac {
                    body: j.body,
                    lin: j.lin * m.inv_m,
                    ang: m.inv_i * j.ang,
                }
            })
        };
        Row {
            a: w(self.a),
            b: w(self.b),
        }
    }

    /// `sum over shared bodies of lin . lin' + ang . ang'`: with `other`
    /// [`Row::weighted`], the Delassus entry.
    pub fn dot(&self, other: &Row) -> f64 {
        let part = |j: &Option<BodyJac>, k: &Option<BodyJac>| match (j, k) {
            (Some(j), Some(k)) if j.body == k.body => j.lin.dot(&k.lin) + j.ang.dot(&k.ang),
            _ => 0.0,
        };
        part(&self.a, &other.a)
            + part(&self.a, &other.b)
            + part(&self.b, &other.a)
            + part(&self.b, &other.b)
    }
}
