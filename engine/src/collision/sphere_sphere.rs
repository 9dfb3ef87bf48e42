use super::Geometry;
use crate::model::Counterpart;
use nalgebra::Vector3;

/// Two spheres: the normal joins the centres, from B towards A.
pub fn sphere_sphere(
    a: usize,
    ca: Vector3<f64>,
    ra: f64,
    b: usize,
    cb: Vector3<f64>,
    rb: f64,
) -> Geometry {
    balls(a, ca, ra, None, b, cb, rb, None, 0)
}

/// Two balls of centres `ca`, `cb` and radii `ra`, `rb` that are parts of
/// bodies A and B: a sphere's whole (offset `None`), a capsule's around
/// its segment's nearest point (offset: the ball's centre less the body's
/// centre of mass; `None` keeps a sphere's lever arm `-n r` to the bit,
/// signed zeros included). The normal joins the centres, from B towards A.
#[allow(clippy::too_many_arguments)]
pub fn balls(
    a: usize,
    ca: Vector3<f64>,
    ra: f64,
    off_a: Option<Vector3<f64>>,
    b: usize,
    cb: Vector3<f64>,
    rb: f64,
    off_b: Option<Vector3<f64>>,
    feature: usize,
) -> Geometry {
    let d = ca - cb;
    let dist = d.norm();
    // Coincident centres have no normal; any unit vector is as good as another
    // and a fixed one keeps the step deterministic.
    let n = if dist > 1e-300 {
        d / dist
    } else {
        Vector3::z()
    };
    let gap = dist - ra - rb;
    Geometry {
        a,
        b: Counterpart::Body(b),
        feature,
        gap,
        normal: n,
        point: cb + n * (rb + 0.5 * gap),
        r_a: lever(off_a, -n * ra),
        r_b: lever(off_b, n * rb),
    }
}

/// A ball's lever arm: its surface point `s` from its centre, offset to the
/// body's centre of mass where the ball is not the whole body.
pub fn lever(offset: Option<Vector3<f64>>, s: Vector3<f64>) -> Vector3<f64> {
    match offset {
        None => s,
        Some(o) => o + s,
    }
}
