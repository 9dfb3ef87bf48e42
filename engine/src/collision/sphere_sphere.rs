use super::{Counterpart, Geometry};
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
        gap,
        normal: n,
        point: cb + n * (rb + 0.5 * gap),
        r_a: -n * ra,
        r_b: n * rb,
    }
}
