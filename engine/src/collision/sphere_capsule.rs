use super::segment::{nearest_on_segment, Pose};
use super::sphere_sphere::balls;
use super::Geometry;
use nalgebra::Vector3;

/// A sphere (body A) against a capsule (B): the sphere against the ball
/// about the point of the capsule's segment nearest its centre.
pub fn sphere_capsule(
    a: usize,
    c: Vector3<f64>,
    r: f64,
    b: usize,
    pose: &Pose,
    radius: f64,
    half_length: f64,
) -> Geometry {
    let [e0, e1] = pose.segment(half_length);
    let t = nearest_on_segment(&e0, &e1, &c);
    let s = e0 + (e1 - e0) * t;
    balls(a, c, r, None, b, s, radius, Some(s - pose.x), 0)
}
