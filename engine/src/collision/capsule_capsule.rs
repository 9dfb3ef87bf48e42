use super::segment::{nearest_between_segments, nearest_on_segment, Pose};
use super::sphere_sphere::balls;
use super::Geometry;

/// Segments closer to parallel than this (the sine of their angle) touch
/// along an overlap, listed as its two ends.
pub(super) const PARALLEL_SINE: f64 = 1e-3;

/// Two capsules (bodies A and B): the balls about the nearest points of
/// their segments (feature 0). Segments within [`PARALLEL_SINE`] of
/// parallel whose projections overlap touch along the overlap: both its
/// ends are listed (features 0 and 1), so that a capsule lying along
/// another rests on a line, not a point. Those with gap at most `within`.
#[allow(clippy::too_many_arguments)]
pub fn capsule_capsule(
    a: usize,
    pa: &Pose,
    (ra, la): (f64, f64),
    b: usize,
    pb: &Pose,
    (rb, lb): (f64, f64),
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let [p0, p1] = pa.segment(la);
    let [q0, q1] = pb.segment(lb);
    let (d1, d2) = (p1 - p0, q1 - q0);
    let ball = |s: f64, t: f64, feature: usize| {
        let (ca, cb) = (p0 + d1 * s, q0 + d2 * t);
        balls(
            a,
            ca,
            ra,
            Some(ca - pa.x),
            b,
            cb,
            rb,
            Some(cb - pb.x),
            feature,
        )
    };
    let sine2 = d1.cross(&d2).norm_squared() / (d1.norm_squared() * d2.norm_squared());
    if sine2 < PARALLEL_SINE * PARALLEL_SINE {
        // B's ends projected on A's segment; their overlap with [0, 1].
        let (sa, sb) = (
            nearest_on_segment(&p0, &p1, &q0),
            nearest_on_segment(&p0, &p1, &q1),
        );
        let (lo, hi) = (sa.min(sb), sa.max(sb));
        if hi > lo {
            for (k, s) in [lo, hi].into_iter().enumerate() {
                let t = nearest_on_segment(&q0, &q1, &(p0 + d1 * s));
                let g = ball(s, t, k);
                if g.gap <= within {
                    out.push(g);
                }
            }
            return;
        }
    }
    let (s, t) = nearest_between_segments(&p0, &p1, &q0, &q1);
    let g = ball(s, t, 0);
    if g.gap <= within {
        out.push(g);
    }
}
