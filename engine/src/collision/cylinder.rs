//! A cylinder (about its shape's z axis, radius `r`, flat ends at `+-l`)
//! against a plane and a ball, in closed form; against boxes, capsules,
//! hulls and cylinders it is its prism (`model/hull.rs`,
//! `Hull::cylinder`), as `hull.rs` takes any hull.
//!
//! Against a plane, each end's rim offers four points a quarter turn
//! apart, the first the rim's lowest (towards the plane: the part of the
//! plane's normal across the axis; where there is none, the cylinder
//! standing on an end, the shape's x axis): standing it rests on four
//! points of the rim, lying on its side on one line (an end's lowest
//! point each), tipped on a rim point. Features: end (0 at -l, 1 at +l)
//! times 4 plus the point's place.

use super::segment::Pose;
use super::Geometry;
use crate::model::{Counterpart, Plane};
use nalgebra::Vector3;

/// A cylinder (body A, at `pose`) against a fixed plane: the rim points
/// (see the module) whose gap is at most `within`.
pub fn cylinder_plane(
    body: usize,
    pose: &Pose,
    (r, l): (f64, f64),
    plane_index: usize,
    plane: &Plane,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let n = plane.normal;
    let u = pose.q.transform_vector(&Vector3::z());
    let across = n - u * n.dot(&u);
    // The rim's lowest direction; standing on an end (the normal along
    // the axis to round-off), the shape's x axis.
    let d1 = if across.norm() > 1e-12 {
        -across.normalize()
    } else {
        pose.q.transform_vector(&Vector3::x())
    };
    let d2 = u.cross(&d1);
    for (end, z) in [-l, l].into_iter().enumerate() {
        let c = pose.x + u * z;
        for (k, d) in [d1, d2, -d1, -d2].into_iter().enumerate() {
            let p = c + d * r;
            let gap = n.dot(&p) - plane.offset;
            if gap <= within {
                out.push(Geometry {
                    a: body,
                    b: Counterpart::Plane(plane_index),
                    feature: 4 * end + k,
                    gap,
                    normal: n,
                    point: p - n * (0.5 * gap),
                    r_a: p - pose.x,
                    r_b: Vector3::zeros(),
                });
            }
        }
    }
}

/// The signed distance of shape-frame point `p` from the surface of a
/// cylinder of radius `r` and half length `l` about z, the surface point
/// nearest it and the outward normal there (inside: the nearer of the
/// side and the nearer end), as `hull::surface` gives a hull's.
pub fn surface(r: f64, l: f64, p: &Vector3<f64>) -> (f64, Vector3<f64>, Vector3<f64>) {
    let rho = p.x.hypot(p.y);
    let radial = if rho > 0.0 {
        Vector3::new(p.x / rho, p.y / rho, 0.0)
    } else {
        Vector3::x()
    };
    let end = Vector3::new(0.0, 0.0, if p.z < 0.0 { -1.0 } else { 1.0 });
    if rho <= r && p.z.abs() <= l {
        let (side, cap) = (r - rho, l - p.z.abs());
        return if side <= cap {
            (-side, p + radial * side, radial)
        } else {
            (-cap, p + end * cap, end)
        };
    }
    let q = radial * rho.min(r) + Vector3::new(0.0, 0.0, p.z.clamp(-l, l));
    let d = (p - q).norm();
    (d, q, (p - q) / d)
}

/// A ball (centre `c`, radius `radius`, part of body A at lever offset
/// `offset`) against a cylinder (body B at `pose`): the cylinder's surface
/// point nearest the centre, the normal from it to the centre.
#[allow(clippy::too_many_arguments)]
pub fn ball_cylinder(
    a: usize,
    c: Vector3<f64>,
    radius: f64,
    offset: Option<Vector3<f64>>,
    b: usize,
    pose: &Pose,
    (r, l): (f64, f64),
    feature: usize,
) -> Geometry {
    let found = surface(r, l, &pose.local(&c));
    super::sphere_box::ball_on_surface((a, radius, offset), b, pose, found, feature)
}
