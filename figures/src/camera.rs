//! The animation's camera: an orthographic view placed to frame the
//! scene, and where a body's marker and disc fall on the screen.

use super::animation::{HEIGHT, WIDTH};
use super::data::RunData;
use cosim_engine::model::{Model, Shape};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// An orthographic camera: screen x along `right`, y along `up`, depth along
/// `forward`; `scale` pixels per metre about `target`.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    pub target: Vector3<f64>,
    pub right: Vector3<f64>,
    pub up: Vector3<f64>,
    pub forward: Vector3<f64>,
    pub scale: f64,
    /// The image's size in pixels.
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// Pixel coordinates of a world point.
    pub fn project(&self, p: &Vector3<f64>) -> (f64, f64) {
        let d = p - self.target;
        (
            self.width as f64 / 2.0 + self.scale * d.dot(&self.right),
            self.height as f64 / 2.0 - self.scale * d.dot(&self.up),
        )
    }

    /// Distance along the view direction (larger: farther).
    pub fn depth(&self, p: &Vector3<f64>) -> f64 {
        (p - self.target).dot(&self.forward)
    }

    /// The camera of a run at the default size: the scene's `[camera]`
    /// where given, else framed on every position the bodies take.
    pub fn frame(
        model: &Model,
        camera: Option<&cosim_shared::CameraDesc>,
        run: &RunData,
    ) -> Camera {
        Camera::frame_sized(model, camera, run, (WIDTH, HEIGHT))
    }

    /// [`Camera::frame`] for an image of `(width, height)` pixels.
    pub fn frame_sized(
        model: &Model,
        camera: Option<&cosim_shared::CameraDesc>,
        run: &RunData,
        (width, height): (u32, u32),
    ) -> Camera {
        // By default look in from the open side: along the sum of the
        // planes' normals (into a corner or a trough), raised a little.
        let g = model.params.gravity;
        let world_up = if g.norm() > 0.0 {
            -g.normalize()
        } else {
            Vector3::z()
        };
        let open: Vector3<f64> = model.planes.iter().map(|p| p.normal).sum();
        let default = if open.norm() > 1e-6 {
            open.normalize()
        } else {
            Vector3::new(1.0, -1.6, 0.9).normalize()
        };
        let default = {
            let d = default
                + world_up * 0.5
                + cosim_engine::model::kinematics::perpendicular(&world_up) * 0.15;
            d.normalize()
        };
        let dir = camera
            .and_then(|c| c.direction)
            .map(Vector3::from)
            .unwrap_or(default)
            .normalize();
        let forward = -dir;
        let right = {
            let r = forward.cross(&world_up);
            if r.norm() > 1e-9 {
                r.normalize()
            } else {
                cosim_engine::model::kinematics::perpendicular(&forward)
            }
        };
        let up = right.cross(&forward);
        // Bounding box of the bodies over the run, radius included.
        let (mut lo, mut hi) = (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        );
        for (b, track) in model.bodies.iter().zip(&run.bodies) {
            let radius = b.bound;
            for r in &track.rows {
                let x = Vector3::new(r[0], r[1], r[2]);
                lo = lo.inf(&(x - Vector3::repeat(radius)));
                hi = hi.sup(&(x + Vector3::repeat(radius)));
            }
        }
        if !lo.x.is_finite() {
            (lo, hi) = (Vector3::repeat(-1.0), Vector3::repeat(1.0));
        }
        let target = camera
            .and_then(|c| c.target)
            .map(Vector3::from)
            .unwrap_or((lo + hi) / 2.0);
        let scale = match camera.and_then(|c| c.width) {
            Some(w) => width as f64 / w,
            None => {
                // Fit the projected box, with room around it.
                let (mut w, mut h) = (0.0f64, 0.0f64);
                for k in 0..8 {
                    let c = Vector3::new(
                        if k & 1 == 0 { lo.x } else { hi.x },
                        if k & 2 == 0 { lo.y } else { hi.y },
                        if k & 4 == 0 { lo.z } else { hi.z },
                    ) - target;
                    w = w.max(2.0 * c.dot(&right).abs());
                    h = h.max(2.0 * c.dot(&up).abs());
                }
                0.8 * (width as f64 / w.max(1e-6)).min(height as f64 / h.max(1e-6))
            }
        };
        Camera {
            target,
            right,
            up,
            forward,
            scale,
            width,
            height,
        }
    }
}

/// World position of the body-fixed marker of a body of shape `shape` in
/// state row `r`: on its x axis, inside a sphere's or capsule's surface
/// (0.8 of the radius), on a box's +x face.
pub fn marker(shape: &Shape, r: &[f64; 13]) -> Vector3<f64> {
    let q = UnitQuaternion::from_quaternion(Quaternion::new(r[3], r[4], r[5], r[6]));
    let reach = match *shape {
        Shape::Sphere { radius } | Shape::Capsule { radius, .. } => 0.8 * radius,
        Shape::Box { half } => half.x,
        Shape::Hull { bound, .. } => 0.5 * bound,
    };
    Vector3::new(r[0], r[1], r[2]) + q.transform_vector(&Vector3::x()) * reach
}

/// A body's size on screen (pixels) for its shadow, its dot and its
/// name's place: a sphere's or capsule's radius, a box's smallest half
/// extent.
pub(crate) fn screen_radius(shape: &Shape, cam: &Camera) -> i32 {
    let r = match *shape {
        Shape::Sphere { radius } | Shape::Capsule { radius, .. } => radius,
        Shape::Box { half } => half.min(),
        Shape::Hull { bound, .. } => 0.5 * bound,
    };
    (r * cam.scale).round().max(2.0) as i32
}
