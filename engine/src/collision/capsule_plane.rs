use super::segment::Pose;
use super::sphere_plane::ball_plane;
use super::Geometry;
use crate::model::Plane;

/// A capsule (body A) against a fixed plane: the ball at each end of its
/// segment (feature 0 at -l, 1 at +l), those whose gap is at most
/// `within`. A capsule lying on the plane rests on both; its segment's
/// nearest point is always an end.
pub fn capsule_plane(
    body: usize,
    pose: &Pose,
    (radius, half_length): (f64, f64),
    plane_index: usize,
    plane: &Plane,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    for (k, end) in pose.segment(half_length).into_iter().enumerate() {
        let g = ball_plane(body, end, radius, Some(end - pose.x), plane_index, plane, k);
        if g.gap <= within {
            out.push(g);
        }
    }
}
