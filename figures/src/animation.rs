//! The animation: an orthographic view of the scene as a GIF that plays at
//! real time (frames skipped as needed), the simulated time in a corner.
//! Planes are shaded patches, spheres shaded discs with a body-fixed dot (so
//! rolling and spinning show: solid on the near half, a ring on the far
//! half), each with a shadow and a drop line to the floor (so height reads)
//! and its name, over a grid on the floor; joints dark links from each body's centre to the anchor;
//! contact forces red arrows pushing at the contact point (length by
//! decades of newtons); a failed run's frames after the failure carry a
//! banner.

use super::camera::screen_radius;
pub use super::camera::{marker, Camera};
use super::data::RunData;
use super::gif::GifWriter;
use super::text::Kerned;
use super::{color, PlotError, FONT};
use cosim_engine::model::{Attachment, Model, Shape};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use plotters::prelude::*;
use std::path::Path;

/// The animation's default size in pixels (`--gif-size` sets another).
pub const WIDTH: u32 = 640;
pub const HEIGHT: u32 = 480;
/// Contact force arrows and the failure banner.
const ARROW_RED: [u8; 3] = [210, 30, 30];
const BANNER_RED: [u8; 3] = [200, 0, 0];
/// Frames per second of simulated time at real-time playback.
pub const FPS: f64 = 25.0;
/// Most frames in one GIF; longer runs show fewer frames per second, each
/// held longer, so playback stays at real time.
pub const MAX_FRAMES: usize = 750;

/// Which recorded state each frame shows, and the delay per frame (ms),
/// at [`FPS`].
pub fn frames(run: &RunData) -> (Vec<usize>, u32) {
    frames_at(run, FPS)
}

/// [`frames`] at `fps` frames per simulated second.
pub fn frames_at(run: &RunData, fps: f64) -> (Vec<usize>, u32) {
    let t_end = run.t.last().copied().unwrap_or(0.0);
    let mut interval = 1.0 / fps.clamp(0.1, 100.0);
    while t_end / interval > MAX_FRAMES as f64 {
        interval *= 2.0;
    }
    let mut out = Vec::new();
    let mut k = 0usize;
    let mut i = 0usize;
    loop {
        let t = k as f64 * interval;
        if t > t_end + 1e-12 {
            break;
        }
        while i + 1 < run.t.len() && run.t[i + 1] <= t + 1e-12 {
            i += 1;
        }
        out.push(i);
        k += 1;
    }
    (out, (interval * 1000.0).round() as u32)
}

/// A shaded ball of radius `radius` (m) about `c` with a highlight towards
/// the upper left: a sphere, or a capsule's end.
fn draw_ball<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    cam: &Camera,
    c: &Vector3<f64>,
    radius: f64,
    base: RGBColor,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (x, y) = cam.project(c);
    let (x, y) = (x.round() as i32, y.round() as i32);
    let rp = (radius * cam.scale).round().max(2.0) as i32;
    area.draw(&Circle::new((x, y), rp, shade(base, 0.7).filled()))?;
    area.draw(&Circle::new(
        (x, y),
        (rp as f64 * 0.9) as i32,
        base.filled(),
    ))?;
    // Highlight towards the upper left, clear of the centre.
    let off = (0.45 * rp as f64) as i32;
    area.draw(&Circle::new(
        (x - off, y - off),
        (0.3 * rp as f64) as i32,
        lighten(base, 0.45).filled(),
    ))?;
    Ok(())
}

/// Length of a force arrow per decade of newtons (pixels), beyond a first
/// decade's: 5 N draws 25 pixels, 10^5 N 84, whatever the zoom.
const ARROW_PER_DECADE: f64 = 14.0;

fn shade(c: RGBColor, f: f64) -> RGBColor {
    let m = |x: u8| ((x as f64) * f).round().clamp(0.0, 255.0) as u8;
    RGBColor(m(c.0), m(c.1), m(c.2))
}

fn lighten(c: RGBColor, f: f64) -> RGBColor {
    let m = |x: u8| (x as f64 + (255.0 - x as f64) * f).round() as u8;
    RGBColor(m(c.0), m(c.1), m(c.2))
}

/// Sutherland-Hodgman: the part of a convex polygon with `n . x >= offset`.
fn clip(poly: &[Vector3<f64>], n: &Vector3<f64>, offset: f64) -> Vec<Vector3<f64>> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, a) in poly.iter().enumerate() {
        let b = &poly[(i + 1) % poly.len()];
        let (da, db) = (n.dot(a) - offset, n.dot(b) - offset);
        if da >= 0.0 {
            out.push(*a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

/// The part of the segment from `a` to `b` (pixels) inside the camera's
/// image (Liang-Barsky), rounded to pixels.
fn inside_image(a: (f64, f64), b: (f64, f64), cam: &Camera) -> Option<((i32, i32), (i32, i32))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let (w, h) = (cam.width as f64 - 1.0, cam.height as f64 - 1.0);
    for (p, q) in [(-dx, a.0), (dx, w - a.0), (-dy, a.1), (dy, h - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: f64| ((a.0 + t * dx).round() as i32, (a.1 + t * dy).round() as i32);
    Some((at(t0), at(t1)))
}

/// The part of a convex polygon (pixels) inside the camera's image
/// (Sutherland-Hodgman against its four sides), rounded to pixels.
fn polygon_in_image(poly: &[(f64, f64)], cam: &Camera) -> Vec<(i32, i32)> {
    let (w, h) = (cam.width as f64 - 1.0, cam.height as f64 - 1.0);
    // Each side: how far inside a point is (keep where >= 0), as
    // (sign of x, sign of y, offset): s_x x + s_y y + offset.
    let sides = [
        (1.0, 0.0, 0.0),
        (-1.0, 0.0, w),
        (0.0, 1.0, 0.0),
        (0.0, -1.0, h),
    ];
    let mut out = poly.to_vec();
    for (sx, sy, offset) in sides {
        let f = |p: &(f64, f64)| sx * p.0 + sy * p.1 + offset;
        let input = std::mem::take(&mut out);
        for k in 0..input.len() {
            let (a, b) = (input[k], input[(k + 1) % input.len()]);
            let (fa, fb) = (f(&a), f(&b));
            if fa >= 0.0 {
                out.push(a);
            }
            if (fa >= 0.0) != (fb >= 0.0) {
                let t = fa / (fa - fb);
                out.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
            }
        }
    }
    out.iter()
        .map(|p| (p.0.round() as i32, p.1.round() as i32))
        .collect()
}

/// Points whose cast outlines a shape's shadow: a box's corners, a hull's
/// vertices, a sphere's rim seen along `up` (24 points), a capsule's two
/// end rims.
fn outline_points(
    model: &Model,
    shape: &Shape,
    c: &Vector3<f64>,
    q: &UnitQuaternion<f64>,
    up: &Vector3<f64>,
) -> Vec<Vector3<f64>> {
    let t1 = cosim_engine::model::kinematics::perpendicular(up);
    let t2 = up.cross(&t1);
    let rim = |at: Vector3<f64>, r: f64| {
        (0..24).map(move |k| {
            let a = k as f64 * std::f64::consts::TAU / 24.0;
            at + (t1 * a.cos() + t2 * a.sin()) * r
        })
    };
    match *shape {
        Shape::Sphere { radius } => rim(*c, radius).collect(),
        Shape::Capsule {
            radius,
            half_length,
        } => {
            let axis = q.transform_vector(&Vector3::new(0.0, 0.0, half_length));
            rim(c - axis, radius).chain(rim(c + axis, radius)).collect()
        }
        Shape::Box { half } => (0..8)
            .map(|k| {
                let s = |bit: usize| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
                c + q.transform_vector(&Vector3::new(s(0) * half.x, s(1) * half.y, s(2) * half.z))
            })
            .collect(),
        Shape::Hull { index, .. } => model.hulls[index]
            .vertices
            .iter()
            .map(|v| c + q.transform_vector(v))
            .collect(),
    }
}

/// The convex hull of points on the image (Andrew's monotone chain),
/// rounded to pixels, counter-clockwise.
fn convex_outline(mut p: Vec<(f64, f64)>) -> Vec<(i32, i32)> {
    p.retain(|a| a.0.is_finite() && a.1.is_finite());
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    p.dedup();
    if p.len() < 3 {
        return p
            .iter()
            .map(|a| (a.0.round() as i32, a.1.round() as i32))
            .collect();
    }
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let points: Box<dyn Iterator<Item = &(f64, f64)>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &x in points {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], x) <= 0.0
            {
                hull.pop();
            }
            hull.push(x);
        }
        hull.pop();
    }
    hull.iter()
        .map(|a| (a.0.round() as i32, a.1.round() as i32))
        .collect()
}

/// A "nice" grid spacing (1, 2 or 5 times a power of ten) near `span`.
fn nice(span: f64) -> f64 {
    let p = 10f64.powf(span.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|s| *s >= span)
        .unwrap_or(10.0 * p)
}

/// The floor's grid lines in the patch around the view's target (half
/// side `half`), about twelve across, at multiples of a nice spacing from
/// the world origin's foot on the plane (so the grid stays put as bodies
/// move), each cut to the side of every other plane the bodies are on.
fn floor_grid(
    model: &Model,
    floor: &cosim_engine::model::Plane,
    cam: &Camera,
    half: f64,
) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    let n = floor.normal;
    let p0 = cam.target - n * (n.dot(&cam.target) - floor.offset);
    let origin = n * floor.offset;
    // Along the world's x where the floor allows (its grid then reads as
    // metres of x and y), else any direction in the plane.
    let x = Vector3::x() - n * n.x;
    let t1 = if x.norm() > 0.1 {
        x.normalize()
    } else {
        cosim_engine::model::kinematics::perpendicular(&n)
    };
    let t2 = n.cross(&t1);
    let spacing = nice(2.0 * half / 12.0);
    let mut lines = Vec::new();
    for (along, across) in [(t1, t2), (t2, t1)] {
        let c = (p0 - origin).dot(&along);
        let d = (p0 - origin).dot(&across);
        let first = ((c - half) / spacing).ceil() as i64;
        let last = ((c + half) / spacing).floor() as i64;
        for k in first..=last {
            let base = origin + along * (k as f64 * spacing);
            let mut seg = Some((base + across * (d - half), base + across * (d + half)));
            for other in &model.planes {
                if std::ptr::eq(other, floor) {
                    continue;
                }
                seg = seg.and_then(|(a, b)| {
                    let (fa, fb) = (
                        other.normal.dot(&a) - other.offset,
                        other.normal.dot(&b) - other.offset,
                    );
                    match (fa >= 0.0, fb >= 0.0) {
                        (true, true) => Some((a, b)),
                        (false, false) => None,
                        (true, false) => Some((a, a + (b - a) * (fa / (fa - fb)))),
                        (false, true) => Some((a + (b - a) * (fa / (fa - fb)), b)),
                    }
                });
            }
            lines.extend(seg);
        }
    }
    lines
}

/// Draws frame showing state `i` of the run.
fn draw_frame<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    model: &Model,
    run: &RunData,
    cam: &Camera,
    i: usize,
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    area.fill(&RGBColor(250, 250, 248)).map_err(e)?;
    let pix = |p: &Vector3<f64>| {
        let (x, y) = cam.project(p);
        (x.round() as i32, y.round() as i32)
    };
    let centre = |b: usize| {
        let r = &run.bodies[b].rows[i];
        Vector3::new(r[0], r[1], r[2])
    };
    let orientation = |b: usize| {
        let r = &run.bodies[b].rows[i];
        UnitQuaternion::from_quaternion(Quaternion::new(r[3], r[4], r[5], r[6]))
    };

    // Planes: a square patch around the point nearest the view's target,
    // cut to the side of every other plane that the bodies are on (so a
    // corner shows as a corner), farthest first, shaded by how squarely it
    // faces the camera.
    let half = (cam.width.max(cam.height) as f64) / cam.scale;
    let mut patches: Vec<(f64, u8, Vec<Vector3<f64>>)> = Vec::new();
    for (k, p) in model.planes.iter().enumerate() {
        let p0 = cam.target - p.normal * (p.normal.dot(&cam.target) - p.offset);
        let t1 = cosim_engine::model::kinematics::perpendicular(&p.normal);
        let t2 = p.normal.cross(&t1);
        let mut poly: Vec<Vector3<f64>> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .iter()
            .map(|(a, b)| p0 + t1 * (a * half) + t2 * (b * half))
            .collect();
        for (l, other) in model.planes.iter().enumerate() {
            if l != k {
                poly = clip(&poly, &other.normal, other.offset);
            }
        }
        if poly.len() >= 3 {
            let centroid = poly.iter().sum::<Vector3<f64>>() / poly.len() as f64;
            let facing = p.normal.dot(&-cam.forward).abs();
            patches.push((cam.depth(&centroid), (175.0 + 60.0 * facing) as u8, poly));
        }
    }
    patches.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (_, grey, poly) in &patches {
        // Cut to the image (plotters would move the corners outside it
        // onto its border, changing the patch's shape); the outline only
        // along the patch's own edges, not the image's border.
        let projected: Vec<(f64, f64)> = poly.iter().map(|p| cam.project(p)).collect();
        let corners = polygon_in_image(&projected, cam);
        if corners.len() < 3 {
            continue;
        }
        area.draw(&Polygon::new(
            corners.clone(),
            RGBColor(*grey, *grey, grey - 8).filled(),
        ))
        .map_err(e)?;
        for k in 0..projected.len() {
            let (a, b) = (projected[k], projected[(k + 1) % projected.len()]);
            if let Some((a, b)) = inside_image(a, b, cam) {
                area.draw(&PathElement::new(
                    vec![a, b],
                    RGBColor(150, 150, 145).stroke_width(1),
                ))
                .map_err(e)?;
            }
        }
    }

    // Shadows and drop lines on the floor: the plane that faces up the
    // most (against gravity), straight below each centre.
    let g = model.params.gravity;
    let up = if g.norm() > 0.0 {
        -g.normalize()
    } else {
        Vector3::z()
    };
    let floor = model
        .planes
        .iter()
        .filter(|p| p.normal.dot(&up) > 0.5)
        .max_by(|a, b| a.normal.dot(&up).total_cmp(&b.normal.dot(&up)));
    if let Some(f) = floor {
        for (a, b) in floor_grid(model, f, cam, half) {
            // Cut to the image first: plotters moves an end outside the
            // image onto its border, which turns the line.
            let Some((a, b)) = inside_image(cam.project(&a), cam.project(&b), cam) else {
                continue;
            };
            area.draw(&PathElement::new(
                vec![a, b],
                RGBColor(140, 140, 135).mix(0.6).stroke_width(1),
            ))
            .map_err(e)?;
        }
    }
    // Every shape of every body at its pose: (body, its shape, centre,
    // orientation).
    let pieces: Vec<(usize, usize, Vector3<f64>, UnitQuaternion<f64>)> = (0..model.bodies.len())
        .flat_map(|b| {
            let (c, q) = (centre(b), orientation(b));
            model.bodies[b]
                .shapes
                .iter()
                .enumerate()
                .map(move |(k, g)| match g.offset {
                    None => (b, k, c, q),
                    Some(o) => (b, k, c + q.transform_vector(&o.x), q * o.q),
                })
        })
        .collect();
    if let Some(f) = floor {
        for &(b, k, c, q) in &pieces {
            let shape = &model.bodies[b].shapes[k].shape;
            let height = f.normal.dot(&c) - f.offset;
            if height <= shape.extent(&q, &f.normal) * 1.001 {
                continue;
            }
            // Along gravity to the plane.
            let foot = c - up * (height / f.normal.dot(&up));
            let (fx, fy) = pix(&foot);
            // The shape's outline cast along gravity onto the plane.
            let cast: Vec<(f64, f64)> = outline_points(model, shape, &c, &q, &up)
                .iter()
                .map(|p| {
                    cam.project(&(p - up * ((f.normal.dot(p) - f.offset) / f.normal.dot(&up))))
                })
                .collect();
            let outline = convex_outline(cast);
            if outline.len() >= 3 {
                area.draw(&Polygon::new(
                    outline,
                    RGBColor(120, 120, 115).mix(0.45).filled(),
                ))
                .map_err(e)?;
            }
            area.draw(&PathElement::new(
                vec![pix(&c), (fx, fy)],
                RGBColor(110, 110, 110).stroke_width(1),
            ))
            .map_err(e)?;
        }
    }

    // Shapes, farthest first.
    let mut order = pieces;
    order.sort_by(|a, b| cam.depth(&b.2).total_cmp(&cam.depth(&a.2)));
    for (b, k, c, q) in order {
        let geom = &model.bodies[b].shapes[k];
        let shape = &geom.shape;
        let base = color(b);
        match *shape {
            Shape::Sphere { radius } => draw_ball(area, cam, &c, radius, base).map_err(e)?,
            Shape::Capsule {
                radius,
                half_length,
            } => {
                let axis = q.transform_vector(&Vector3::new(0.0, 0.0, half_length));
                let ends = [c - axis, c + axis];
                let (ex, ey) = (pix(&ends[0]), pix(&ends[1]));
                // The body between the end balls: the segment's screen
                // outline widened by the radius either side.
                let (dx, dy) = ((ey.0 - ex.0) as f64, (ey.1 - ex.1) as f64);
                let len = (dx * dx + dy * dy).sqrt().max(1e-9);
                let rp = radius * cam.scale;
                let (nx, ny) = (-dy / len * rp, dx / len * rp);
                let side = |p: (i32, i32), s: f64| {
                    (
                        (p.0 as f64 + s * nx).round() as i32,
                        (p.1 as f64 + s * ny).round() as i32,
                    )
                };
                let far = usize::from(cam.depth(&ends[1]) > cam.depth(&ends[0]));
                draw_ball(area, cam, &ends[far], radius, base).map_err(e)?;
                let outline = vec![side(ex, 1.0), side(ey, 1.0), side(ey, -1.0), side(ex, -1.0)];
                area.draw(&Polygon::new(outline, shade(base, 0.7).filled()))
                    .map_err(e)?;
                let inner: Vec<(i32, i32)> = [(ex, 0.9), (ey, 0.9), (ey, -0.9), (ex, -0.9)]
                    .iter()
                    .map(|&(p, s)| side(p, s))
                    .collect();
                area.draw(&Polygon::new(inner, base.filled())).map_err(e)?;
                draw_ball(area, cam, &ends[1 - far], radius, base).map_err(e)?;
            }
            Shape::Hull { index, .. } => {
                // As a box's: the faces turned towards the camera.
                let h = &model.hulls[index];
                for face in &h.faces {
                    let facing = q.transform_vector(&face.normal).dot(&-cam.forward);
                    if facing <= 1e-9 {
                        continue;
                    }
                    let outline: Vec<(i32, i32)> = face
                        .verts
                        .iter()
                        .map(|&k| pix(&(c + q.transform_vector(&h.vertices[k]))))
                        .collect();
                    let fill = shade(base, 0.6 + 0.4 * facing);
                    area.draw(&Polygon::new(outline.clone(), fill.filled()))
                        .map_err(e)?;
                    let mut edge = outline;
                    edge.push(edge[0]);
                    area.draw(&PathElement::new(edge, shade(base, 0.45).stroke_width(1)))
                        .map_err(e)?;
                }
            }
            Shape::Box { half } => {
                // The faces turned towards the camera (a convex body's do
                // not overlap), each shaded by how squarely it faces it.
                for (axis, sign) in (0..3).flat_map(|k| [(k, 1.0), (k, -1.0)]) {
                    let mut n = Vector3::zeros();
                    n[axis] = sign;
                    let facing = q.transform_vector(&n).dot(&-cam.forward);
                    if facing <= 1e-9 {
                        continue;
                    }
                    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                    let corner = |su: f64, sv: f64| {
                        let mut p = n * half[axis];
                        p[u] = su * half[u];
                        p[v] = sv * half[v];
                        pix(&(c + q.transform_vector(&p)))
                    };
                    let face = vec![
                        corner(1.0, 1.0),
                        corner(-1.0, 1.0),
                        corner(-1.0, -1.0),
                        corner(1.0, -1.0),
                    ];
                    let fill = shade(base, 0.6 + 0.4 * facing);
                    area.draw(&Polygon::new(face.clone(), fill.filled()))
                        .map_err(e)?;
                    let mut edge = face;
                    edge.push(edge[0]);
                    area.draw(&PathElement::new(edge, shade(base, 0.45).stroke_width(1)))
                        .map_err(e)?;
                }
            }
        }
        // The body-fixed dot: solid on the near half, a ring on the far
        // half, so that a turn shows from every side (on a body's one
        // shape at its centre of mass; shapes away from it show the turn).
        if geom.offset.is_some() {
            continue;
        }
        let rp = screen_radius(shape, cam);
        let m = marker(shape, &run.bodies[b].rows[i]);
        let (mx, my) = pix(&m);
        let size = (0.14 * rp as f64).max(2.0) as i32;
        if cam.depth(&m) < cam.depth(&c) {
            area.draw(&Circle::new((mx, my), size, RGBColor(20, 20, 20).filled()))
                .map_err(e)?;
        } else {
            area.draw(&Circle::new(
                (mx, my),
                size,
                RGBColor(20, 20, 20).stroke_width(1),
            ))
            .map_err(e)?;
        }
    }
    // Names after every body, so that a nearer body does not cover a
    // farther one's name.
    if model.bodies.len() <= 12 {
        for b in 0..model.bodies.len() {
            let (x, y) = pix(&centre(b));
            // Beside the disc's edge at 45 degrees up and right (the text's
            // top-left corner is its position; 13 px tall): the corner of
            // the bounding square left a gap of 0.4 radii on a large body.
            let rp = (model.bodies[b].bound * cam.scale).max(2.0);
            let edge = (0.71 * rp).round() as i32;
            area.draw(&Text::new(
                model.bodies[b].name.clone(),
                (x + edge + 2, y - edge - 11),
                (FONT, 13).into_font().color(&RGBColor(40, 40, 40)),
            ))
            .map_err(e)?;
        }
    }

    // Joints: links from each body's centre to the anchor, over the
    // spheres (a skeleton, as robot viewers draw one).
    for j in &model.joints {
        let anchor = match j.a {
            Attachment::World => j.local_a,
            Attachment::Body(a) => {
                let r = &run.bodies[a].rows[i];
                let q = UnitQuaternion::from_quaternion(Quaternion::new(r[3], r[4], r[5], r[6]));
                centre(a) + q.transform_vector(&j.local_a)
            }
        };
        let mut path = Vec::new();
        if let Attachment::Body(a) = j.a {
            path.push(pix(&centre(a)));
        }
        path.push(pix(&anchor));
        if let Attachment::Body(b) = j.b {
            path.push(pix(&centre(b)));
        }
        super::thick_path(area, &path, RGBColor(60, 60, 60), 2).map_err(e)?;
        let (ax, ay) = pix(&anchor);
        area.draw(&Circle::new((ax, ay), 4, RGBColor(40, 40, 40).filled()))
            .map_err(e)?;
    }

    // Contact forces of the step that ended in this state: an arrow that
    // pushes at the contact point, from outside the body it acts on.
    if i > 0 {
        if let Some(h) = run.h() {
            let mut state = cosim_engine::State::initial(model);
            super::pose_state(run, i, &mut state);
            for ((kind, name), series) in &run.impulses {
                let Some(Some(p)) = series.get(i - 1) else {
                    continue;
                };
                if kind != "normal" {
                    continue;
                }
                let Some(at) = super::contact_point(model, &state, name) else {
                    continue;
                };
                let f = Vector3::from(*p) / h;
                let size = f.norm();
                if size <= 0.0 {
                    continue;
                }
                let dir = f / size;
                let length = ARROW_PER_DECADE * (1.0 + (1.0 + size).log10());
                let (hx, hy) = pix(&at);
                // The direction on screen; a force along the view is a dot.
                let (sx, sy) = (dir.dot(&cam.right), -dir.dot(&cam.up));
                let on_screen = (sx * sx + sy * sy).sqrt();
                let (tx, ty) = (
                    hx - (length * sx).round() as i32,
                    hy - (length * sy).round() as i32,
                );
                if on_screen < 1e-3 {
                    continue;
                }
                let red = RGBColor(ARROW_RED[0], ARROW_RED[1], ARROW_RED[2]);
                super::thick_path(area, &[(tx, ty), (hx, hy)], red, 2).map_err(e)?;
                // The head: two short strokes back from the tip.
                let (dx, dy) = ((hx - tx) as f64, (hy - ty) as f64);
                let n = (dx * dx + dy * dy).sqrt().max(1e-9);
                let (ux, uy) = (dx / n, dy / n);
                for side in [-1.0, 1.0] {
                    let bx = hx as f64 - 7.0 * ux + side * 4.0 * uy;
                    let by = hy as f64 - 7.0 * uy - side * 4.0 * ux;
                    super::thick_path(
                        area,
                        &[(bx.round() as i32, by.round() as i32), (hx, hy)],
                        red,
                        2,
                    )
                    .map_err(e)?;
                }
            }
        }
    }
    if let Some((t, step, status)) = &run.first_failure {
        if run.t[i] >= *t {
            area.draw(&Rectangle::new(
                [
                    (0, cam.height as i32 - 34),
                    (cam.width as i32, cam.height as i32),
                ],
                RGBColor(BANNER_RED[0], BANNER_RED[1], BANNER_RED[2]).filled(),
            ))
            .map_err(e)?;
            area.draw(&Text::new(
                format!("step {step} failed: {status}; the state stays as it was"),
                (12, cam.height as i32 - 28),
                (FONT, 18).into_font().color(&WHITE),
            ))
            .map_err(e)?;
        }
    }
    area.draw(&Text::new(
        format!("t = {:.3} s", run.t[i]),
        (12, 10),
        (FONT, 20).into_font().color(&BLACK),
    ))
    .map_err(e)?;
    Ok(())
}

/// Writes `animation.gif`; returns the number of frames.
pub fn gif(
    model: &Model,
    camera: Option<&cosim_shared::CameraDesc>,
    run: &RunData,
    path: &Path,
) -> Result<usize, PlotError> {
    gif_at(model, camera, run, path, FPS, (WIDTH, HEIGHT))
}

/// [`gif`] at `fps` frames per simulated second, `size` pixels.
pub fn gif_at(
    model: &Model,
    camera: Option<&cosim_shared::CameraDesc>,
    run: &RunData,
    path: &Path,
    fps: f64,
    size: (u32, u32),
) -> Result<usize, PlotError> {
    let cam = Camera::frame_sized(model, camera, run, size);
    let (frames, delay) = frames_at(run, fps);
    let fail = |m: String| PlotError::Draw(format!("{}: {m}", path.display()));
    let mut rgb = vec![0u8; 3 * size.0 as usize * size.1 as usize];
    let render = |i: usize, rgb: &mut Vec<u8>| -> Result<(), PlotError> {
        let area = Kerned::new(BitMapBackend::with_buffer(rgb, size)).into_drawing_area();
        draw_frame(&area, model, run, &cam, i).map_err(fail)?;
        area.present().map_err(|e| fail(e.to_string()))
    };
    // The palette from up to eight frames spread over the run (the
    // first, with every plane and body, among them).
    let mut samples = Vec::new();
    let picks = frames.len().min(8);
    for k in 0..picks {
        let i = frames[k * (frames.len() - 1) / picks.saturating_sub(1).max(1)];
        render(i, &mut rgb)?;
        samples.push(rgb.clone());
    }
    // Colours drawn exactly: the background, text, the arrows' and the
    // banner's reds, and the bodies' own.
    let mut fixed = vec![
        [250, 250, 248],
        [0, 0, 0],
        [255, 255, 255],
        ARROW_RED,
        BANNER_RED,
    ];
    fixed.extend((0..model.bodies.len().min(10)).map(|b| {
        let c = color(b);
        [c.0, c.1, c.2]
    }));
    let mut out = GifWriter::create(path, size, delay, &fixed, &samples).map_err(fail)?;
    for &i in &frames {
        render(i, &mut rgb)?;
        out.frame(&rgb).map_err(fail)?;
    }
    Ok(frames.len())
}

/// Writes `count` frames, evenly spread over the run, as PNG stills
/// `<stem>_<k>.png` (for documentation).
pub fn stills(
    model: &Model,
    camera: Option<&cosim_shared::CameraDesc>,
    run: &RunData,
    dir: &Path,
    stem: &str,
    count: usize,
    size: (u32, u32),
) -> Result<Vec<std::path::PathBuf>, PlotError> {
    let cam = Camera::frame_sized(model, camera, run, size);
    let (frames, _) = frames(run);
    let mut out = Vec::new();
    for k in 0..count {
        let i = frames[(k * (frames.len() - 1)) / count.saturating_sub(1).max(1)];
        let path = dir.join(format!("{stem}_{k}.png"));
        {
            let area = Kerned::new(BitMapBackend::new(&path, size)).into_drawing_area();
            let fail = |m: String| PlotError::Draw(format!("{}: {m}", path.display()));
            draw_frame(&area, model, run, &cam, i).map_err(fail)?;
            area.present().map_err(|e| fail(e.to_string()))?;
        }
        out.push(path);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera {
            target: Vector3::zeros(),
            right: Vector3::x(),
            up: Vector3::z(),
            forward: Vector3::y(),
            scale: 100.0,
            width: 200,
            height: 100,
        }
    }

    /// Twice the area of a polygon (shoelace).
    fn area2(p: &[(i32, i32)]) -> f64 {
        (0..p.len())
            .map(|k| {
                let (a, b) = (p[k], p[(k + 1) % p.len()]);
                (a.0 as f64) * (b.1 as f64) - (b.0 as f64) * (a.1 as f64)
            })
            .sum::<f64>()
            .abs()
    }

    /// A shadow has its shape's outline: a box turned about the vertical
    /// casts its footprint (a rectangle of its area, not a disc), a capsule
    /// lying flat a stadium as long as it is.
    #[test]
    fn a_shadow_is_the_outline_of_its_shape() {
        let model = Model::from_scene(
            &cosim_shared::Scene::parse(
                "[sim]\ndt = 0.01\nduration = 1.0\n[[body]]\nname = \"a\"\nhalf_extents = [0.3, 0.1, 0.05]\nmass = 1.0\nposition = [0.0, 0.0, 1.0]\n",
                "test",
            )
            .expect("a scene"),
        );
        // Looking straight down: screen x is world x, screen y world -y.
        let cam = Camera {
            target: Vector3::zeros(),
            right: Vector3::x(),
            up: Vector3::y(),
            forward: -Vector3::z(),
            scale: 100.0,
            width: 400,
            height: 400,
        };
        let up = Vector3::z();
        let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5);
        let shape = model.bodies[0].shapes[0].shape;
        let cast: Vec<(f64, f64)> =
            outline_points(&model, &shape, &Vector3::new(0.0, 0.0, 1.0), &q, &up)
                .iter()
                .map(|p| cam.project(&Vector3::new(p.x, p.y, 0.0)))
                .collect();
        let outline = convex_outline(cast);
        assert_eq!(outline.len(), 4, "{outline:?}");
        // 0.6 m by 0.2 m at 100 px/m: 1200 px^2 (rounding to pixels).
        let area = area2(&outline) / 2.0;
        assert!((area - 1200.0).abs() < 40.0, "{area}");
        let capsule = Shape::Capsule {
            radius: 0.1,
            half_length: 0.5,
        };
        let flat = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2);
        let cast: Vec<(f64, f64)> = outline_points(&model, &capsule, &Vector3::zeros(), &flat, &up)
            .iter()
            .map(|p| cam.project(&Vector3::new(p.x, p.y, 0.0)))
            .collect();
        let outline = convex_outline(cast);
        let xs: Vec<i32> = outline.iter().map(|p| p.0).collect();
        let width = xs.iter().max().unwrap_or(&0) - xs.iter().min().unwrap_or(&0);
        // 1.2 m end to end.
        assert!((width - 120).abs() <= 2, "{width}");
        // A stadium: 1 m x 0.2 m plus a disc of 0.1 m, 2314 px^2.
        let area = area2(&outline) / 2.0;
        assert!((area - 2314.0).abs() < 60.0, "{area}");
    }

    #[test]
    fn a_line_cut_to_the_image_keeps_its_direction() {
        // From far left-below to far right-above, slope -1/2 in pixels.
        let (a, b) = inside_image((-1000.0, 600.0), (1000.0, -400.0), &camera()).unwrap();
        let slope = (b.1 - a.1) as f64 / (b.0 - a.0) as f64;
        assert!((slope + 0.5).abs() < 0.02, "{a:?} {b:?}");
        assert!(a.0 >= 0 && b.0 <= 199 && a.1 <= 99 && b.1 >= 0);
        // Wholly outside: nothing.
        assert!(inside_image((-10.0, -10.0), (300.0, -5.0), &camera()).is_none());
    }

    #[test]
    fn a_polygon_cut_to_the_image_keeps_its_edges() {
        // A triangle with a corner far outside: the cut polygon's points
        // lie on its edges or the image's border, never at a clamped corner.
        let tri = [(50.0, 50.0), (5000.0, 50.0), (50.0, -5000.0)];
        let cut = polygon_in_image(&tri, &camera());
        assert!(cut.len() >= 3);
        for &(x, y) in &cut {
            let on_border = x == 0 || x == 199 || y == 0 || y == 99;
            let on_edge = y == 50 || x == 50;
            assert!(on_border || on_edge, "({x}, {y})");
            // Inside the triangle: right of x = 50, above y = 50.
            assert!(x >= 50 && y <= 50, "({x}, {y})");
        }
        assert!(cut.contains(&(199, 50)) && cut.contains(&(50, 0)));
    }

    #[test]
    fn grid_spacings_are_one_two_or_five_times_a_power_of_ten() {
        assert_eq!(nice(0.13), 0.2);
        assert_eq!(nice(0.3), 0.5);
        assert_eq!(nice(0.7), 1.0);
        assert!((nice(0.017) - 0.02).abs() < 1e-15);
    }
}
