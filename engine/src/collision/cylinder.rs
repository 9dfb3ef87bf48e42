//! A cylinder (about its shape's z axis, radius `r`, flat ends at `+-l`)
//! against a plane, a ball and a capsule, in closed form (a capsule as
//! balls along its segment, [`capsule_cylinder`]); against boxes, hulls
//! and cylinders its prism (`model/hull.rs`, `Hull::cylinder`) finds
//! where they meet, as `hull.rs` takes any hull; against a box or hull
//! the contacts are then the cylinder's true ones: where a face of the
//! other carries it ([`on_face`]), its rim points on the face's plane, as
//! on a plane, so that a can standing or lying on a table's box rests at
//! its true height; elsewhere ([`on_edges`]) the other's edges and
//! corners against its true surface (the prism's flat sides lie
//! `r (1 - cos(pi / 32))` inside the cylinder, 0.5 % of the radius). Two
//! cylinders touch side by side or crossed as two capsules would
//! ([`cylinder_cylinder`]); where a rim or an end is in the contact, their
//! prisms.
//!
//! Against a plane, each end's rim offers four points a quarter turn
//! apart, the first the rim's lowest (towards the plane: the part of the
//! plane's normal across the axis; where there is none, the cylinder
//! standing on an end, the shape's x axis): standing it rests on four
//! points of the rim, lying on its side on one line (an end's lowest
//! point each), tipped on a rim point. Features: end (0 at -l, 1 at +l)
//! times 4 plus the point's place.

use super::manifold::{face_contact, Reference};
use super::segment::Pose;
use super::Geometry;
use crate::model::hull::Hull;
use crate::model::{Counterpart, Plane};
use nalgebra::Vector3;

/// The rim points a cylinder (`pose`, `(r, l)`) offers a plane of outward
/// normal `n` (see the module): per end (0 at `-l`, 1 at `+l`), four
/// points a quarter turn apart, the first the lowest along `n`.
fn rim(pose: &Pose, (r, l): (f64, f64), n: &Vector3<f64>) -> [[Vector3<f64>; 4]; 2] {
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
    [-l, l].map(|z| {
        let c = pose.x + u * z;
        [d1, d2, -d1, -d2].map(|d| c + d * r)
    })
}

/// The cosine within which a hull's face counts as carrying a cylinder
/// whose prism's contact normal is near it: the prism's own angular
/// resolution (its sides a 32nd of a turn apart).
const FACE_COS: f64 = 0.995_184_726_672_196_9; // cos(pi / 32)

/// How far inside the cylinder its prism's flat sides lie: a pair with a
/// cylinder is tested as its prism within this much more, so that the
/// true rim is found before the prism touches.
pub fn prism_slack((r, _): (f64, f64)) -> f64 {
    r * (1.0 - FACE_COS)
}

/// Where the prism of a cylinder met a hull (`hull::hull_hull` left its
/// contacts in `out[start..]`) and the hull's face nearest the contact
/// normal carries the cylinder: those contacts replaced by the cylinder's
/// exact rim points (as [`cylinder_plane`]'s) on the face's plane, within
/// the face's outline and `within`. Otherwise (an edge or a vertex of the
/// hull, the cylinder's end or side as the reference, or no rim point over
/// the face) the prism's contacts stand. `cylinder_is_a`: which side of
/// the pair the cylinder is (the normal points from B towards A).
#[allow(clippy::too_many_arguments)]
pub fn on_face(
    cylinder_is_a: bool,
    cylinder: &Pose,
    rl: (f64, f64),
    other: &Pose,
    hull: &Hull,
    within: f64,
    start: usize,
    out: &mut Vec<Geometry>,
) {
    // No face of the hull carries the cylinder: its edges and vertices
    // against the cylinder's true surface.
    let prism = |out: &mut Vec<Geometry>| {
        on_edges(cylinder_is_a, cylinder, rl, other, hull, within, start, out)
    };
    let Some(first) = out.get(start) else {
        return;
    };
    let (a, b) = (first.a, first.b);
    // The hull's outward direction towards the cylinder.
    let towards = if cylinder_is_a {
        first.normal
    } else {
        -first.normal
    };
    let Some((f, n)) = (0..hull.faces.len())
        .map(|f| (f, other.q.transform_vector(&hull.faces[f].normal)))
        .max_by(|x, y| x.1.dot(&towards).total_cmp(&y.1.dot(&towards)))
    else {
        return prism(out);
    };
    if n.dot(&towards) < FACE_COS {
        return prism(out);
    }
    let face = &hull.faces[f];
    let on = other.point(&hull.vertices[face.verts[0]]);
    let offset = n.dot(&on);
    // Inside the face's outline: on the inner side of every edge (the loop
    // is counter-clockwise seen from outside), to a round-off's slack.
    let slack = 1e-9 * hull.bound.max(1e-9);
    let over_face = |p: &Vector3<f64>| {
        let m = face.verts.len();
        (0..m).all(|k| {
            let v0 = other.point(&hull.vertices[face.verts[k]]);
            let v1 = other.point(&hull.vertices[face.verts[(k + 1) % m]]);
            let side = (v1 - v0).cross(&n);
            let len = side.norm();
            len == 0.0 || (p - v0).dot(&side) / len <= slack
        })
    };
    let points = rim(cylinder, rl, &n);
    let mut kept = [(0usize, Vector3::zeros(), 0.0); 8];
    let mut count = 0;
    for (end, ring) in points.iter().enumerate() {
        for (k, p) in ring.iter().enumerate() {
            let gap = n.dot(p) - offset;
            let foot = p - n * gap;
            if gap <= within && over_face(&foot) {
                kept[count] = (4 * end + k, *p, gap);
                count += 1;
            }
        }
    }
    let (Counterpart::Body(b), true) = (b, count > 0) else {
        return prism(out);
    };
    out.truncate(start);
    // The hull's face is the reference: its outward normal towards the
    // cylinder, from B towards A when the hull is B.
    let reference = Reference {
        is_a: !cylinder_is_a,
        normal: n,
        on,
    };
    let (pa, pb) = match cylinder_is_a {
        true => (cylinder, other),
        false => (other, cylinder),
    };
    for &(feature, p, gap) in &kept[..count] {
        out.push(face_contact((a, pa), (b, pb), &reference, p, gap, feature));
    }
}

/// A hull's vertices and edges against a cylinder's true surface, where
/// the cylinder's prism met the hull (its contacts in `out[start..]`) and
/// no face of the hull carries the cylinder: a box's edge across or along
/// the cylinder's side, a corner on it or on its rim. Each vertex within
/// `within` of the surface, and each edge's nearest interior point where
/// it is nearer than both ends (the signed distance to a convex body is
/// convex along a segment), as a ball of radius 0 against the surface
/// ([`ball_cylinder`]); the eight deepest, numbered in the hull's order
/// (vertices, then edges). Before, the prism's flat sides, which lie up to
/// `r (1 - cos(pi / 32))` inside the cylinder, stopped a box's edge short.
#[allow(clippy::too_many_arguments)]
fn on_edges(
    cylinder_is_a: bool,
    cylinder: &Pose,
    (r, l): (f64, f64),
    other: &Pose,
    hull: &Hull,
    within: f64,
    start: usize,
    out: &mut Vec<Geometry>,
) {
    let Some(first) = out.get(start) else {
        return;
    };
    let Counterpart::Body(b) = first.b else {
        return;
    };
    let (hull_body, cylinder_body) = match cylinder_is_a {
        true => (b, first.a),
        false => (first.a, b),
    };
    out.truncate(start);
    let distance = |p: &Vector3<f64>| surface(r, l, &cylinder.local(p)).0;
    // The deepest eight: (gap, place in the hull's order, point).
    let mut kept = [(0.0, 0usize, Vector3::zeros()); 8];
    let mut count = 0;
    let mut keep = |gap: f64, place: usize, p: Vector3<f64>| {
        if gap > within {
            return;
        }
        if count < kept.len() {
            kept[count] = (gap, place, p);
            count += 1;
        } else if let Some(worst) = (0..kept.len()).max_by(|&x, &y| kept[x].0.total_cmp(&kept[y].0))
        {
            if gap < kept[worst].0 {
                kept[worst] = (gap, place, p);
            }
        }
    };
    for (i, v) in hull.vertices.iter().enumerate() {
        let p = other.point(v);
        keep(distance(&p), i, p);
    }
    for (e, edge) in hull.edges.iter().enumerate() {
        let (p0, p1) = (
            other.point(&hull.vertices[edge.a]),
            other.point(&hull.vertices[edge.b]),
        );
        let along = |t: f64| distance(&(p0 + (p1 - p0) * t));
        let t = super::segment::minimise_convex(along);
        let d = along(t);
        if d < along(0.0).min(along(1.0)) - super::capsule_box::INTERIOR_NEARER {
            keep(d, hull.vertices.len() + e, p0 + (p1 - p0) * t);
        }
    }
    let kept = &mut kept[..count];
    kept.sort_by_key(|k| k.1);
    for (feature, &(_, _, p)) in kept.iter().enumerate() {
        let g = ball_cylinder(
            hull_body,
            p,
            0.0,
            Some(p - other.x),
            cylinder_body,
            cylinder,
            (r, l),
            feature,
        );
        out.push(if cylinder_is_a { g.flipped() } else { g });
    }
}

/// Two cylinders (A at `pa`, B at `pb`; their prisms' contacts in
/// `out[start..]`): where the nearest points of their axes lie inside both
/// segments, or the axes are parallel with overlapping spans, their round
/// sides touch there, exactly as two capsules' would (every point of a
/// cylinder lies within its radius of its axis segment, and the sides
/// reach that bound there): [`capsule_capsule`]'s contacts replace the
/// prisms'. Where an end is nearer (a rim or a flat end in the contact),
/// the prisms' stand: their flat ends and rim corners are the cylinders'
/// own.
///
/// [`capsule_capsule`]: super::capsule_capsule::capsule_capsule
#[allow(clippy::too_many_arguments)]
pub fn cylinder_cylinder(
    a: usize,
    pa: &Pose,
    (ra, la): (f64, f64),
    b: usize,
    pb: &Pose,
    (rb, lb): (f64, f64),
    within: f64,
    start: usize,
    out: &mut Vec<Geometry>,
) {
    use super::segment::{nearest_between_segments, nearest_on_segment};
    let [p0, p1] = pa.segment(la);
    let [q0, q1] = pb.segment(lb);
    let (d1, d2) = (p1 - p0, q1 - q0);
    // Inside by more than round-off: a can stacked on another's end has
    // its axis's end on the other's, and a rounding that put it a hair
    // inside made the two coaxial sides touch 0.15 m deep (found with
    // PGS: the top can thrown 11 m up).
    const MARGIN: f64 = 1e-9;
    let inside = |x: f64| x > MARGIN && x < 1.0 - MARGIN;
    let sine2 = d1.cross(&d2).norm_squared() / (d1.norm_squared() * d2.norm_squared());
    let (s, t) = nearest_between_segments(&p0, &p1, &q0, &q1);
    let sides = if sine2 < super::capsule_capsule::PARALLEL_SINE.powi(2) {
        let (sa, sb) = (
            nearest_on_segment(&p0, &p1, &q0),
            nearest_on_segment(&p0, &p1, &q1),
        );
        sa.max(sb) > sa.min(sb) + MARGIN
    } else {
        inside(s) && inside(t)
    };
    // Sunk into each other, the sides' depth must be the shallowest way
    // out: a can sunk a little into another's end has its axis inside the
    // other's span, but its sides 0.15 m "deep"; the prisms, whose ends
    // are the cylinders' own, see the true depth there.
    let side_gap = ((p0 + d1 * s) - (q0 + d2 * t)).norm() - ra - rb;
    let prisms = out[start..]
        .iter()
        .map(|g| g.gap)
        .fold(f64::INFINITY, f64::min);
    let slack = prism_slack((ra, la)) + prism_slack((rb, lb));
    let sides = sides && side_gap >= prisms.min(0.0) - slack - MARGIN;
    if sides {
        out.truncate(start);
        super::capsule_capsule::capsule_capsule(a, pa, (ra, la), b, pb, (rb, lb), within, out);
        return;
    }
    // The prisms' contacts, within the caller's reach (they were tested
    // both prisms' slack further).
    let mut k = start;
    while k < out.len() {
        if out[k].gap > within {
            out.remove(k);
        } else {
            k += 1;
        }
    }
}

/// A cylinder (body A, at `pose`) against a fixed plane: the rim points
/// (see the module) whose gap is at most `within`.
pub fn cylinder_plane(
    body: usize,
    pose: &Pose,
    rl: (f64, f64),
    plane_index: usize,
    plane: &Plane,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let n = plane.normal;
    for (end, ring) in rim(pose, rl, &n).iter().enumerate() {
        for (k, &p) in ring.iter().enumerate() {
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

/// A capsule (body A at `pa`, radius `rc`, half length `lc`) against a
/// cylinder (body B at `pb`): its end balls and, where a point inside its
/// segment is nearer, the ball there, each against the cylinder's true
/// surface (`capsule_box::capsule_against`: the signed distance to a
/// convex body is convex along the segment). Lying on an end or along the
/// side, the two end balls hold it on a line; crossed, the inner ball.
#[allow(clippy::too_many_arguments)]
pub fn capsule_cylinder(
    a: usize,
    pa: &Pose,
    (rc, lc): (f64, f64),
    b: usize,
    pb: &Pose,
    (r, l): (f64, f64),
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let distance = |p: &Vector3<f64>| surface(r, l, p).0;
    let ball =
        |c: Vector3<f64>, feature| ball_cylinder(a, c, rc, Some(c - pa.x), b, pb, (r, l), feature);
    super::capsule_box::capsule_against(pa, lc, pb, distance, ball, within, out);
}
