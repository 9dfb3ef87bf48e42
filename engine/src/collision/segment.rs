//! Closest points on segments and the signed distance to a box: the
//! pieces the capsule and box pairs share (Ericson, Real-Time Collision
//! Detection, 5.1).

use nalgebra::{UnitQuaternion, Vector3};

/// A body's pose: centre of mass and orientation.
#[derive(Debug, Clone, Copy)]
pub struct Pose {
    pub x: Vector3<f64>,
    pub q: UnitQuaternion<f64>,
}

impl Pose {
    /// A body-frame point in the world.
    pub fn point(&self, local: &Vector3<f64>) -> Vector3<f64> {
        self.x + self.q.transform_vector(local)
    }

    /// A world point in the body frame.
    pub fn local(&self, world: &Vector3<f64>) -> Vector3<f64> {
        self.q.inverse_transform_vector(&(world - self.x))
    }

    /// The ends of a capsule's segment of half length `l` along the body's
    /// z axis: feature 0 at -l, 1 at +l.
    pub fn segment(&self, l: f64) -> [Vector3<f64>; 2] {
        let half = self.q.transform_vector(&Vector3::new(0.0, 0.0, l));
        [self.x - half, self.x + half]
    }
}

/// The parameter in [0, 1] of the point of segment `p0 p1` nearest to `c`.
pub fn nearest_on_segment(p0: &Vector3<f64>, p1: &Vector3<f64>, c: &Vector3<f64>) -> f64 {
    let d = p1 - p0;
    let dd = d.norm_squared();
    if dd <= f64::MIN_POSITIVE {
        return 0.0;
    }
    ((c - p0).dot(&d) / dd).clamp(0.0, 1.0)
}

/// Parameters `(s, t)` of the nearest points of segments `p0 p1` and
/// `q0 q1` (Ericson 5.1.9). Parallel segments have many; this picks the
/// one with `s` nearest 0 (the callers list parallel overlaps apart).
pub fn nearest_between_segments(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> (f64, f64) {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.norm_squared(), d2.norm_squared(), d2.dot(&r));
    let tiny = f64::MIN_POSITIVE;
    if a <= tiny && e <= tiny {
        return (0.0, 0.0);
    }
    if a <= tiny {
        return (0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = d1.dot(&r);
    if e <= tiny {
        return ((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = d1.dot(&d2);
    let denom = a * e - b * b;
    let mut s = if denom > 1e-12 * a * e {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (s, t)
}

/// Signed distance of body-frame point `p` to the box of half extents
/// `h`: the distance outside, minus the distance to the nearest face
/// inside. Convex in `p`, as any convex set's is.
pub fn box_signed_distance(p: &Vector3<f64>, h: &Vector3<f64>) -> f64 {
    let q = p.abs() - h;
    let outside = q.sup(&Vector3::zeros()).norm();
    let inside = q.max().min(0.0);
    outside + inside
}

/// The box's surface point nearest to body-frame point `p` and the
/// outward unit normal there (body frame): for a point inside, the
/// nearest face's (the first of the nearest, so that ties are
/// deterministic).
pub fn box_surface(p: &Vector3<f64>, h: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let clamped = Vector3::new(
        p.x.clamp(-h.x, h.x),
        p.y.clamp(-h.y, h.y),
        p.z.clamp(-h.z, h.z),
    );
    let d = p - clamped;
    let dist = d.norm();
    if dist > 0.0 {
        return (clamped, d / dist);
    }
    // Inside (or on the surface): the face the point is nearest.
    let q = p.abs() - h;
    let i = if q.x >= q.y && q.x >= q.z {
        0
    } else if q.y >= q.z {
        1
    } else {
        2
    };
    let sign = if p[i] < 0.0 { -1.0 } else { 1.0 };
    let mut s = *p;
    s[i] = sign * h[i];
    let mut n = Vector3::zeros();
    n[i] = sign;
    (s, n)
}

/// The `t` in [0, 1] minimising the convex `f` (golden section), to
/// within 1e-12 of the interval: deterministic, a fixed count of
/// evaluations.
pub fn minimise_convex(f: impl Fn(f64) -> f64) -> f64 {
    const INV_PHI: f64 = 0.618_033_988_749_894_9;
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let mut c = hi - INV_PHI * (hi - lo);
    let mut d = lo + INV_PHI * (hi - lo);
    let (mut fc, mut fd) = (f(c), f(d));
    // 0.618^58 < 1e-12.
    for _ in 0..58 {
        if fc <= fd {
            hi = d;
            d = c;
            fd = fc;
            c = hi - INV_PHI * (hi - lo);
            fc = f(c);
        } else {
            lo = c;
            c = d;
            fc = fd;
            d = lo + INV_PHI * (hi - lo);
            fd = f(d);
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_segments_meet_at_their_crossing() {
        let (s, t) = nearest_between_segments(
            &Vector3::new(-1.0, 0.0, 0.0),
            &Vector3::new(1.0, 0.0, 0.0),
            &Vector3::new(0.5, -1.0, 1.0),
            &Vector3::new(0.5, 1.0, 1.0),
        );
        assert!(
            (s - 0.75).abs() < 1e-15 && (t - 0.5).abs() < 1e-15,
            "{s} {t}"
        );
    }

    #[test]
    fn the_box_distance_is_signed_and_the_surface_point_is_nearest() {
        let h = Vector3::new(1.0, 2.0, 3.0);
        assert_eq!(box_signed_distance(&Vector3::new(2.0, 0.0, 0.0), &h), 1.0);
        assert_eq!(box_signed_distance(&Vector3::new(0.0, 1.5, 0.0), &h), -0.5);
        let d = box_signed_distance(&Vector3::new(2.0, 3.0, 0.0), &h);
        assert!((d - 2f64.sqrt()).abs() < 1e-15);
        let (s, n) = box_surface(&Vector3::new(0.0, 1.5, 0.2), &h);
        assert_eq!((s, n), (Vector3::new(0.0, 2.0, 0.2), Vector3::y()));
    }

    #[test]
    fn golden_section_finds_a_convex_minimum() {
        let t = minimise_convex(|t| (t - 0.3).abs());
        assert!((t - 0.3).abs() < 1e-11, "{t}");
        assert!(minimise_convex(|t| t) < 1e-11);
    }
}
