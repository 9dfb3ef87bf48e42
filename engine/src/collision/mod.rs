//! Collision stage: the signed gap, normal and lever arms of every potential
//! contact, in a canonical order (each sphere against each plane, body-major,
//! then each pair of spheres) so that a contact's canonical index
//! (`Model::contact_id`) is its identity from step to step. One file per
//! shape pair; `broad.rs` finds the sphere pairs within reach.

mod broad;
mod sphere_plane;
mod sphere_sphere;

use super::model::{Model, Shape};
use super::state::State;
use nalgebra::Vector3;

pub use broad::Broad;
pub use sphere_plane::sphere_plane;
pub use sphere_sphere::sphere_sphere;

/// What body A of a contact touches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Counterpart {
    Plane(usize),
    Body(usize),
    /// The fixed world: a joint limit's other side when the joint holds a
    /// body to the world (`joint::limits`).
    World,
}

/// The geometry of one potential contact between body `a` and `b`.
#[derive(Debug, Clone, Copy)]
pub struct Geometry {
    pub a: usize,
    pub b: Counterpart,
    /// Signed gap: >= 0 when separated.
    pub gap: f64,
    /// Unit normal pointing from B towards A.
    pub normal: Vector3<f64>,
    /// Contact point (world), midway between the surfaces.
    pub point: Vector3<f64>,
    /// Lever arms from each centre of mass to its own surface point.
    pub r_a: Vector3<f64>,
    pub r_b: Vector3<f64>,
}

/// Scratch space of the collision stage.
#[derive(Debug, Default, Clone)]
pub struct Scratch {
    broad: Broad,
    pairs: Vec<(usize, usize)>,
}

/// Which potential contacts [`detect`] lists.
#[derive(Debug, Clone, Copy)]
pub enum Listing<'a> {
    /// Every one: the notes' enumeration, `full`, and the broad phase off.
    All,
    /// The broad phase: a pair whose gap is at most `reach[a] + reach[b] +
    /// margin`, a sphere-plane contact whose gap is at most `reach[a] +
    /// margin` (a plane is static: the sphere alone must cover the gap, its
    /// normal speed against the plane being at most its speed). The others
    /// cannot close within a step in which no body travels farther than its
    /// reach (m).
    Within { reach: &'a [f64], margin: f64 },
    /// Those that overlap (`Within` with no reach and no margin): all that
    /// a penetration can be measured on.
    Overlapping,
}

impl Listing<'_> {
    /// Body `i`'s reach (m); none outside the broad phase's listing.
    fn reach(&self, i: usize) -> f64 {
        match self {
            Listing::Within { reach, .. } => reach[i],
            Listing::All | Listing::Overlapping => 0.0,
        }
    }

    fn margin(&self) -> f64 {
        match self {
            Listing::Within { margin, .. } => *margin,
            Listing::All | Listing::Overlapping => 0.0,
        }
    }
}

/// Fills `out` with the potential contacts of the scene that `listing`
/// names, in canonical order: every sphere against every plane, then the
/// sphere pairs. With `sphere_contacts = false` there are no pairs; they
/// come last in the order, so the other contacts keep their identities.
pub fn detect(
    model: &Model,
    state: &State,
    listing: Listing,
    scratch: &mut Scratch,
    out: &mut Vec<Geometry>,
) {
    out.clear();
    let all = matches!(listing, Listing::All);
    for (i, body) in model.bodies.iter().enumerate() {
        let Shape::Sphere { radius } = body.shape;
        // A body welded to the world is the world's (`Model::weld`).
        if model.weld[i] == crate::model::WELDED_TO_WORLD {
            continue;
        }
        for (p, plane) in model.planes.iter().enumerate() {
            let g = sphere_plane(i, state.bodies[i].x, radius, p, plane);
            if all || g.gap <= listing.reach(i) + listing.margin() {
                out.push(g);
            }
        }
    }
    if !model.params.sphere_contacts {
        return;
    }
    let radius = |i: usize| {
        let Shape::Sphere { radius } = model.bodies[i].shape;
        radius
    };
    let pair = |(i, j): (usize, usize)| {
        sphere_sphere(
            i,
            state.bodies[i].x,
            radius(i),
            j,
            state.bodies[j].x,
            radius(j),
        )
    };
    let n = model.bodies.len();
    let apart = |&(i, j): &(usize, usize)| model.may_touch(i, j);
    if all {
        for i in 0..n {
            out.extend((i + 1..n).map(|j| (i, j)).filter(apart).map(pair));
        }
        return;
    }
    let Scratch { broad, pairs } = scratch;
    let reach = |i| listing.reach(i);
    broad.pairs(
        n,
        |i| state.bodies[i].x,
        radius,
        reach,
        listing.margin(),
        pairs,
    );
    out.extend(pairs.iter().filter(|p| apart(p)).map(|&p| pair(p)));
}
