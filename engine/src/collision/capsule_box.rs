use super::segment::{box_signed_distance, minimise_convex, Pose};
use super::sphere_box::ball_box;
use super::Geometry;
use nalgebra::Vector3;

/// How much nearer (m) than both ends a point inside a capsule's segment
/// must be to the box to be listed besides them.
pub(super) const INTERIOR_NEARER: f64 = 1e-9;

/// A capsule (body A) against a box (B): the ball at each end of the
/// segment (features 0 and 1) and, where a point inside the segment is
/// nearer the box than both ends (a capsule across an edge or a face's
/// rim), the ball about the nearest one (feature 2), each against the
/// box. The segment's signed distance to the box is convex along it, so
/// golden section finds that point. Lying flat on a face, the ends hold
/// the capsule on a line; those with gap at most `within`.
#[allow(clippy::too_many_arguments)]
pub fn capsule_box(
    a: usize,
    pa: &Pose,
    (r, l): (f64, f64),
    b: usize,
    pb: &Pose,
    h: &Vector3<f64>,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let distance = |p: &Vector3<f64>| box_signed_distance(p, h);
    let ball = |c: Vector3<f64>, feature| ball_box(a, c, r, Some(c - pa.x), b, pb, h, feature);
    capsule_against(pa, l, pb, distance, ball, within, out);
}

/// A capsule's segment of half length `l` (its body at `pa`) against a
/// convex body B at `pb` whose signed distance (B's frame) is `distance`:
/// `ball(centre, feature)`'s contact at each end (features 0 and 1) and,
/// where a point inside the segment is nearer than both ends, there
/// (feature 2), those whose gap is at most `within`.
pub fn capsule_against(
    pa: &Pose,
    l: f64,
    pb: &Pose,
    distance: impl Fn(&Vector3<f64>) -> f64,
    ball: impl Fn(Vector3<f64>, usize) -> Geometry,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let ends = pa.segment(l);
    let (e0, e1) = (pb.local(&ends[0]), pb.local(&ends[1]));
    let sd = |t: f64| distance(&(e0 + (e1 - e0) * t));
    let t = minimise_convex(sd);
    let inner = (sd(t) < sd(0.0).min(sd(1.0)) - INTERIOR_NEARER)
        .then(|| pa.point(&Vector3::new(0.0, 0.0, (2.0 * t - 1.0) * l)));
    let mut push = |c: Vector3<f64>, feature: usize| {
        let g = ball(c, feature);
        if g.gap <= within {
            out.push(g);
        }
    };
    push(ends[0], 0);
    push(ends[1], 1);
    if let Some(c) = inner {
        push(c, 2);
    }
}
