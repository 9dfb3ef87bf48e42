use super::{Counterpart, Geometry};
use crate::model::Plane;
use nalgebra::Vector3;

/// A sphere (body A) against a fixed plane (B): the normal is the plane's,
/// the gap the centre's height above the plane less the radius.
pub fn sphere_plane(
    body: usize,
    centre: Vector3<f64>,
    radius: f64,
    plane_index: usize,
    plane: &Plane,
) -> Geometry {
    let n = plane.normal;
    let gap = n.dot(&centre) - plane.offset - radius;
    Geometry {
        a: body,
        b: Counterpart::Plane(plane_index),
        gap,
        normal: n,
        point: centre - n * (radius + 0.5 * gap),
        r_a: -n * radius,
        r_b: Vector3::zeros(),
    }
}
