//! Collision stage: the signed gap, normal and lever arms of every potential
//! contact, in a canonical order (each sphere against each plane, body-major,
//! then each pair of spheres) so that a contact's index is its identity from
//! step to step. One file per shape pair.

mod sphere_plane;
mod sphere_sphere;

use super::model::{Model, Shape};
use super::state::State;
use nalgebra::Vector3;

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

/// Fills `out` with every potential contact of the scene, in canonical order.
/// With `sphere_contacts = false` the sphere pairs are not potential
/// contacts at all; they come last in the order, so the other contacts keep
/// their identities.
pub fn detect(model: &Model, state: &State, out: &mut Vec<Geometry>) {
    out.clear();
    for (i, body) in model.bodies.iter().enumerate() {
        let Shape::Sphere { radius } = body.shape;
        for (p, plane) in model.planes.iter().enumerate() {
            out.push(sphere_plane(i, state.bodies[i].x, radius, p, plane));
        }
    }
    if !model.params.sphere_contacts {
        return;
    }
    for i in 0..model.bodies.len() {
        for j in i + 1..model.bodies.len() {
            let (Shape::Sphere { radius: ra }, Shape::Sphere { radius: rb }) =
                (model.bodies[i].shape, model.bodies[j].shape);
            out.push(sphere_sphere(
                i,
                state.bodies[i].x,
                ra,
                j,
                state.bodies[j].x,
                rb,
            ));
        }
    }
}
