use super::Geometry;
use crate::model::Counterpart;
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
    ball_plane(body, centre, radius, None, plane_index, plane, 0)
}

/// A ball of centre `c` and radius `radius`, part of body A (a sphere's
/// whole, offset `None`; a capsule's end, offset from the centre of mass:
/// `sphere_sphere::lever`), against a fixed plane.
pub fn ball_plane(
    body: usize,
    c: Vector3<f64>,
    radius: f64,
    offset: Option<Vector3<f64>>,
    plane_index: usize,
    plane: &Plane,
    feature: usize,
) -> Geometry {
    let n = plane.normal;
    let gap = n.dot(&c) - plane.offset - radius;
    Geometry {
        a: body,
        b: Counterpart::Plane(plane_index),
        feature,
        gap,
        normal: n,
        point: c - n * (radius + 0.5 * gap),
        r_a: super::sphere_sphere::lever(offset, -n * radius),
        r_b: Vector3::zeros(),
    }
}
