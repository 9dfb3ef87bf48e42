use super::segment::{box_surface, Pose};
use super::Geometry;
use crate::model::Counterpart;
use nalgebra::Vector3;

/// A ball (centre `c`, radius `r`; part of body A at lever offset
/// `offset`, `sphere_sphere::lever`) against a box (body B): the box's
/// surface point nearest the centre, the normal from it to the centre
/// (for a centre inside the box, the nearest face's normal).
#[allow(clippy::too_many_arguments)]
pub fn ball_box(
    a: usize,
    c: Vector3<f64>,
    r: f64,
    offset: Option<Vector3<f64>>,
    b: usize,
    pose: &Pose,
    h: &Vector3<f64>,
    feature: usize,
) -> Geometry {
    let p = pose.local(&c);
    let (s, n_local) = box_surface(&p, h);
    // Signed distance of the centre from the surface along the normal.
    let depth = (p - s).dot(&n_local);
    ball_on_surface((a, r, offset), b, pose, (depth, s, n_local), feature)
}

/// A ball of radius `r` (part of body A at lever offset `offset`) whose
/// centre lies `depth` from body B's surface along the outward normal
/// `n_local` at surface point `s` (both in B's frame, B at `pose`).
pub fn ball_on_surface(
    (a, r, offset): (usize, f64, Option<Vector3<f64>>),
    b: usize,
    pose: &Pose,
    (depth, s, n_local): (f64, Vector3<f64>, Vector3<f64>),
    feature: usize,
) -> Geometry {
    let n = pose.q.transform_vector(&n_local);
    let gap = depth - r;
    let on_b = pose.point(&s);
    Geometry {
        a,
        b: Counterpart::Body(b),
        feature,
        gap,
        normal: n,
        point: on_b + n * (0.5 * gap),
        r_a: super::sphere_sphere::lever(offset, -n * r),
        r_b: on_b - pose.x,
    }
}
