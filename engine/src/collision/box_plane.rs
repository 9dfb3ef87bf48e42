use super::segment::Pose;
use super::Geometry;
use crate::model::Counterpart;
use crate::model::Plane;
use nalgebra::Vector3;

/// The body-frame vertex `k` (0..8) of a box: bit 0 the sign of x, bit 1
/// of y, bit 2 of z (set: +).
pub fn vertex(h: &Vector3<f64>, k: usize) -> Vector3<f64> {
    let s = |bit: usize| if k & bit != 0 { 1.0 } else { -1.0 };
    Vector3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z)
}

/// A box (body A) against a fixed plane: its four vertices lowest along
/// the plane's normal, each a contact of its own (feature: the vertex's
/// number), those whose gap is at most `within`, in ascending feature.
///
/// Four, not eight: a plane supports a box on a face at most, and the
/// upper face's vertices of a thin box would add rows parallel to the
/// lower face's, a singular LCP. Which four is decided before `within`
/// filters them, so that the broad phase's list is a part of the full one
/// with the same ids.
pub fn box_plane(
    body: usize,
    pose: &Pose,
    h: &Vector3<f64>,
    plane_index: usize,
    plane: &Plane,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let n = plane.normal;
    let mut v = [(0.0f64, 0usize, Vector3::zeros()); 8];
    for (k, slot) in v.iter_mut().enumerate() {
        let r = pose.q.transform_vector(&vertex(h, k));
        *slot = (n.dot(&(pose.x + r)) - plane.offset, k, r);
    }
    // Lowest first, ties by vertex number: deterministic.
    v.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let lowest = &mut v[..4];
    lowest.sort_unstable_by_key(|x| x.1);
    for &(gap, k, r) in lowest.iter() {
        if gap <= within {
            out.push(Geometry {
                a: body,
                b: Counterpart::Plane(plane_index),
                feature: k,
                gap,
                normal: n,
                point: pose.x + r - n * (0.5 * gap),
                r_a: r,
                r_b: Vector3::zeros(),
            });
        }
    }
}
