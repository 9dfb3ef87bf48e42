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

/// Fills `out` with the potential contacts of the scene, in canonical
/// order: every sphere against every plane, then the sphere pairs. With
/// `within = None` every contact (the notes' enumeration, and `full`); with
/// `Some((reach, margin))` only the pairs whose gap is at most `reach[a] +
/// reach[b] + margin` (the broad phase, `broad.rs`) and the sphere-plane
/// contacts whose gap is at most `reach[a] + margin`: the others cannot
/// close within a step in which no body travels farther than its reach. With
/// `sphere_contacts = false` there are no pairs; they come last in the
/// order, so the other contacts keep their identities.
pub fn detect(
    model: &Model,
    state: &State,
    within: Option<(&[f64], f64)>,
    scratch: &mut Scratch,
    out: &mut Vec<Geometry>,
) {
    out.clear();
    for (i, body) in model.bodies.iter().enumerate() {
        let Shape::Sphere { radius } = body.shape;
        for (p, plane) in model.planes.iter().enumerate() {
            let g = sphere_plane(i, state.bodies[i].x, radius, p, plane);
            // A plane is static: the sphere alone must cover the gap (its
            // normal speed against the plane is at most its speed).
            if within.is_none_or(|(reach, margin)| g.gap <= reach[i] + margin) {
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
    match within {
        None => {
            for i in 0..n {
                out.extend((i + 1..n).map(|j| pair((i, j))));
            }
        }
        Some((reach, margin)) => {
            let Scratch { broad, pairs } = scratch;
            broad.pairs(|i| state.bodies[i].x, radius, reach, margin, pairs);
            out.extend(pairs.iter().map(|&p| pair(p)));
        }
    }
}
