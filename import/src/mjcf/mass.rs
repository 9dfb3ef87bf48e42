//! Mass properties as MuJoCo's compiler makes them: each geom's from its
//! volume and density (or its `mass`), a body's from its geoms or its
//! `<inertial>`, bodies welded together combined.

use super::read::{Geom, GeomKind};
use nalgebra::{Isometry3, Matrix3, Vector3};
use std::f64::consts::PI;

/// A mass at a centre with its inertia about that centre, in one frame.
#[derive(Debug, Clone, Copy)]
pub struct Mass {
    pub mass: f64,
    pub com: Vector3<f64>,
    pub inertia: Matrix3<f64>,
}

impl Mass {
    pub fn zero() -> Mass {
        Mass {
            mass: 0.0,
            com: Vector3::zeros(),
            inertia: Matrix3::zeros(),
        }
    }

    /// The same mass seen from the frame in which `pose` is `self`'s frame.
    pub fn moved(&self, pose: &Isometry3<f64>) -> Mass {
        let r = pose.rotation.to_rotation_matrix();
        Mass {
            mass: self.mass,
            com: (pose * nalgebra::Point3::from(self.com)).coords,
            inertia: r.matrix() * self.inertia * r.matrix().transpose(),
        }
    }

    /// The two as one body (centres and inertias combined by the parallel
    /// axis theorem).
    pub fn add(&self, o: &Mass) -> Mass {
        let mass = self.mass + o.mass;
        if mass <= 0.0 {
            return Mass::zero();
        }
        let com = (self.com * self.mass + o.com * o.mass) / mass;
        let shift = |m: &Mass| {
            let d = m.com - com;
            m.inertia + m.mass * (Matrix3::identity() * d.dot(&d) - d * d.transpose())
        };
        Mass {
            mass,
            com,
            inertia: shift(self) + shift(o),
        }
    }

    pub fn scaled(&self, f: f64) -> Mass {
        Mass {
            mass: self.mass * f,
            com: self.com,
            inertia: self.inertia * f,
        }
    }
}

/// A geom's volume and principal moments per unit mass about its own
/// origin in its own axes; `None` for a geom without volume (a plane), or
/// a mesh (`mesh` gives its hull's).
fn unit(g: &Geom, mesh: Option<&Mass>) -> Option<(f64, Vector3<f64>, Matrix3<f64>)> {
    let [a, b, c] = g.size;
    let diag = |x: f64, y: f64, z: f64| Matrix3::from_diagonal(&Vector3::new(x, y, z));
    let zero = Vector3::zeros();
    Some(match g.kind {
        GeomKind::Sphere => (
            4.0 / 3.0 * PI * a.powi(3),
            zero,
            diag(1.0, 1.0, 1.0) * 0.4 * a * a,
        ),
        GeomKind::Capsule => {
            let (r, h) = (a, 2.0 * b);
            let vs = 4.0 / 3.0 * PI * r.powi(3);
            let vc = PI * r * r * h;
            let v = vs + vc;
            let (fs, fc) = (vs / v, vc / v);
            let side = fc * (3.0 * r * r + h * h) / 12.0
                + fs * (2.0 * r * r / 5.0 + h * h / 4.0 + 3.0 * h * r / 8.0);
            let axial = fc * r * r / 2.0 + fs * 2.0 * r * r / 5.0;
            (v, zero, diag(side, side, axial))
        }
        GeomKind::Cylinder => {
            let (r, h) = (a, 2.0 * b);
            let side = (3.0 * r * r + h * h) / 12.0;
            (PI * r * r * h, zero, diag(side, side, r * r / 2.0))
        }
        GeomKind::Box => (
            8.0 * a * b * c,
            zero,
            diag(b * b + c * c, a * a + c * c, a * a + b * b) / 3.0,
        ),
        GeomKind::Ellipsoid => (
            4.0 / 3.0 * PI * a * b * c,
            zero,
            diag(b * b + c * c, a * a + c * c, a * a + b * b) / 5.0,
        ),
        GeomKind::Mesh(_) => {
            let m = mesh?;
            (m.mass, m.com, m.inertia / m.mass)
        }
        GeomKind::Plane | GeomKind::Other(_) => return None,
    })
}

/// The geom's mass properties in its body's frame, or `None` when it has
/// no volume.
pub fn of_geom(g: &Geom, mesh: Option<&Mass>) -> Option<Mass> {
    let (volume, com, per_mass) = unit(g, mesh)?;
    let mass = g.mass.unwrap_or(g.density * volume);
    Some(
        Mass {
            mass,
            com,
            inertia: per_mass * mass,
        }
        .moved(&g.pose),
    )
}

/// The volume (as `mass`), centroid and inertia at unit density of the
/// solid a closed outward-wound triangle list bounds (signed tetrahedra
/// from the origin).
pub fn of_solid(vertices: &[[f64; 3]], triangles: &[[usize; 3]]) -> Option<Mass> {
    let mut volume = 0.0;
    let mut first = Vector3::zeros();
    let mut second = Matrix3::zeros(); // integral of x x^T
    for t in triangles {
        let [a, b, c] = t.map(|k| Vector3::from(vertices[k]));
        let v = a.dot(&b.cross(&c)) / 6.0;
        volume += v;
        first += v * (a + b + c) / 4.0;
        let s = a + b + c;
        second += v / 20.0
            * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
    }
    if volume.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let com = first / volume;
    let about_com = second - volume * com * com.transpose();
    let inertia = Matrix3::identity() * about_com.trace() - about_com;
    Some(Mass {
        mass: volume,
        com,
        inertia,
    })
}
