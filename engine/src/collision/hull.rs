//! Convex hulls (a collision mesh's, `model/hull.rs`) against planes,
//! balls, capsules, boxes and hulls. A hull against a plane rests on at
//! most four of its vertices; a ball meets the hull's nearest surface
//! point; a capsule is its end balls and, where a point inside its segment
//! is nearer, the ball there (as `capsule_box`); two hulls (a box taken as
//! its hull) by separating axes (Gregorius, GDC 2013): each hull's face
//! normals and the cross products of the edge pairs that form a face of
//! the Minkowski difference (the Gauss map's arcs cross); on a face axis
//! the other hull's face most against it is clipped to the reference
//! face's sides and reduced to four points, on an edge axis the edges'
//! nearest points. Features: a contact's place among the points listed,
//! in vertex order (plane) or clipping order (hulls), as `box_box`'s.

use super::manifold::{push_face_contacts, Polygon, Reference};
use super::segment::{nearest_between_segments, nearest_on_segment, Pose};
use super::Geometry;
use crate::model::hull::Hull;
use crate::model::{Counterpart, Plane};
use nalgebra::Vector3;

/// How much more separation (m) an axis needs than the best face axis to
/// be taken instead (as `box_box`'s), so that a hull resting on a hull
/// keeps its reference face, and its contacts their features.
const PREFER_FACE: f64 = 1e-6;

/// The signed distance of shape-frame point `p` from the hull's surface,
/// the surface point nearest it and the outward normal there (for a point
/// inside, the nearest face's plane: its first, for ties).
pub fn surface(h: &Hull, p: &Vector3<f64>) -> (f64, Vector3<f64>, Vector3<f64>) {
    let (mut s, mut f) = (f64::NEG_INFINITY, 0);
    for (k, face) in h.faces.iter().enumerate() {
        let d = face.normal.dot(p) - face.offset;
        if d > s {
            (s, f) = (d, k);
        }
    }
    if s <= 0.0 {
        let n = h.faces[f].normal;
        return (s, p - n * s, n);
    }
    // Outside: the nearest point of the faces the point is beyond, on a
    // face's inside or on its rim.
    let mut best = (f64::INFINITY, *p);
    for face in &h.faces {
        let d = face.normal.dot(p) - face.offset;
        if d <= 0.0 {
            continue;
        }
        let q = p - face.normal * d;
        let m = face.verts.len();
        let corner = |k: usize| h.vertices[face.verts[k % m]];
        let inside = (0..m).all(|k| {
            let (a, b) = (corner(k), corner(k + 1));
            (b - a).cross(&(q - a)).dot(&face.normal) >= 0.0
        });
        if inside {
            if d < best.0 {
                best = (d, q);
            }
            continue;
        }
        for k in 0..m {
            let (a, b) = (corner(k), corner(k + 1));
            let c = a + (b - a) * nearest_on_segment(&a, &b, p);
            let dist = (p - c).norm();
            if dist < best.0 {
                best = (dist, c);
            }
        }
    }
    let (dist, q) = best;
    let n = if dist > 0.0 {
        (p - q) / dist
    } else {
        h.faces[f].normal
    };
    (dist, q, n)
}

/// A hull (body A, at `pose`) against a fixed plane: at most four of its
/// vertices, chosen among those within 2 % of its bound of the lowest (the lowest, the farthest from it, the largest triangle, the
/// largest area beyond: a face resting on the plane is held at its rim),
/// numbered in vertex order; then up to four more of those, the ones
/// farthest below the rim's plane ([`below_rim`]), features 4 to 7; those
/// whose gap is at most `within`. Which ones is decided before `within`
/// filters them, so that the broad phase's list is a part of the full
/// one, with the same ids.
pub fn hull_plane(
    body: usize,
    pose: &Pose,
    h: &Hull,
    plane_index: usize,
    plane: &Plane,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let n = plane.normal;
    let gap = |v: &Vector3<f64>| n.dot(&pose.point(v)) - plane.offset;
    let lowest = h.vertices.iter().map(gap).fold(f64::INFINITY, f64::min);
    // The vertices near the lowest: a face resting on the plane, or an
    // edge or vertex about to touch; not the far side of a thin hull.
    let band = lowest + 0.02 * h.bound;
    let mut near = Polygon::<64>::default();
    let mut index = [0usize; 64];
    for (k, v) in h.vertices.iter().enumerate() {
        if gap(v) <= band && near.len() < 64 {
            index[near.len()] = k;
            near.push(*v);
        }
    }
    let local_n = pose.q.inverse_transform_vector(&n);
    let kept = near.reduce_indices(&local_n, |p| local_n.dot(p));
    let mut chosen = [usize::MAX; 8];
    for (slot, &k) in kept.iter().enumerate() {
        chosen[slot] = index[k];
    }
    below_rim(&near, &index, &kept, &local_n, &mut chosen[4..]);
    for (feature, &k) in chosen.iter().enumerate() {
        let Some(&v) = h.vertices.get(k) else {
            continue;
        };
        let g = gap(&v);
        let p = pose.point(&v);
        if g <= within {
            out.push(Geometry {
                a: body,
                b: Counterpart::Plane(plane_index),
                feature,
                gap: g,
                normal: n,
                point: p - n * (0.5 * g),
                r_a: p - pose.x,
                r_b: Vector3::zeros(),
            });
        }
    }
}

/// How far (m) a vertex may lie below the kept vertices' lower surface
/// before it is a contact of its own: a turn can take it at most this deep
/// while the kept ones hold. Not less: a rounded foot's mesh (Solo's in
/// example-robot-data) has vertices up to a quarter of the band below its
/// kept ones, which only a turn of tenths of a radian in one step brings
/// down, and at 1e-4 m they took a third more rows into every step.
const BELOW: f64 = 5e-4;

/// Into `out`, the vertices of `near` (hull indices `index`) deepest below
/// the lower surface of the `kept` ones (the lowest of the triangles of
/// three of them over the vertex, heights along `n`), by more than
/// [`BELOW`], deepest first, as many as fit. A vertex over no such
/// triangle is measured against the plane of the first three.
///
/// Why: a rigid turn moves every point of the hull along `n` by an affine
/// function of its place across the plane, so while the kept vertices stay
/// out of the plane, a vertex over a triangle of theirs ends at most as
/// deep as it lies below that triangle. A sole that bulges (Talos's, in
/// example-robot-data) had a vertex 1.9 mm below its four kept corners,
/// which went 1.35 mm into the floor in one step as the foot rocked at
/// 8.7 rad/s.
fn below_rim(
    near: &Polygon<64>,
    index: &[usize; 64],
    kept: &[usize],
    n: &Vector3<f64>,
    out: &mut [usize],
) {
    if kept.len() < 3 {
        return;
    }
    // Coordinates across the plane (u, v) and the height along n.
    let u1 = crate::model::kinematics::perpendicular(n);
    let u2 = n.cross(&u1);
    let flat = |p: &Vector3<f64>| (p.dot(&u1), p.dot(&u2), p.dot(n));
    let k = |i: usize| flat(&near[kept[i]]);
    // The height over (x, y) of the plane of triangle (a, b, c), and
    // whether (x, y) is within the triangle; `None` if it stands on edge.
    let over = |t: [usize; 3], x: f64, y: f64| {
        let [a, b, c] = t.map(k);
        let det = (b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1);
        if det.abs() <= 1e-18 {
            return None;
        }
        let l1 = ((x - a.0) * (c.1 - a.1) - (c.0 - a.0) * (y - a.1)) / det;
        let l2 = ((b.0 - a.0) * (y - a.1) - (x - a.0) * (b.1 - a.1)) / det;
        let inside = l1 >= -1e-12 && l2 >= -1e-12 && l1 + l2 <= 1.0 + 1e-12;
        Some((inside, a.2 + l1 * (b.2 - a.2) + l2 * (c.2 - a.2)))
    };
    let triangles: &[[usize; 3]] = match kept.len() {
        3 => &[[0, 1, 2]],
        _ => &[[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]],
    };
    let mut found = [(0.0f64, usize::MAX); 64];
    let mut count = 0;
    for (i, p) in near.iter().enumerate() {
        if kept.contains(&i) {
            continue;
        }
        let (x, y, z) = flat(p);
        let lowest = triangles
            .iter()
            .filter_map(|&t| over(t, x, y).filter(|o| o.0).map(|o| o.1))
            .reduce(f64::min)
            .unwrap_or_else(|| over([0, 1, 2], x, y).map_or(f64::INFINITY, |o| o.1));
        let depth = z - lowest;
        if depth < -BELOW {
            found[count] = (depth, index[i]);
            count += 1;
        }
    }
    let found = &mut found[..count];
    found.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    for (slot, &(_, k)) in out.iter_mut().zip(found.iter()) {
        *slot = k;
    }
}

/// A ball (centre `c`, radius `r`; part of body A at lever offset `offset`,
/// `sphere_sphere::lever`) against a hull (body B): the hull's surface
/// point nearest the centre, the normal from it to the centre.
#[allow(clippy::too_many_arguments)]
pub fn ball_hull(
    a: usize,
    c: Vector3<f64>,
    r: f64,
    offset: Option<Vector3<f64>>,
    b: usize,
    pose: &Pose,
    h: &Hull,
    feature: usize,
) -> Geometry {
    let found = surface(h, &pose.local(&c));
    super::sphere_box::ball_on_surface((a, r, offset), b, pose, found, feature)
}

/// A capsule (body A) against a hull (B): the ball at each end (features 0
/// and 1) and, where a point inside the segment is nearer the hull than
/// both ends, the ball there (feature 2); the signed distance is convex
/// along the segment, so golden section finds that point.
#[allow(clippy::too_many_arguments)]
pub fn capsule_hull(
    a: usize,
    pa: &Pose,
    (r, l): (f64, f64),
    b: usize,
    pb: &Pose,
    h: &Hull,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let distance = |p: &Vector3<f64>| surface(h, p).0;
    let ball = |c: Vector3<f64>, feature| ball_hull(a, c, r, Some(c - pa.x), b, pb, h, feature);
    super::capsule_box::capsule_against(pa, l, pb, distance, ball, within, out);
}

/// One side of a hull pair: its pose and hull.
struct Side<'a> {
    pose: &'a Pose,
    hull: &'a Hull,
}

impl Side<'_> {
    fn vertex(&self, k: usize) -> Vector3<f64> {
        self.pose.point(&self.hull.vertices[k])
    }

    fn normal(&self, f: usize) -> Vector3<f64> {
        self.pose.q.transform_vector(&self.hull.faces[f].normal)
    }

    /// The least `n . x` over the hull's vertices (world `n`).
    fn lowest(&self, n: &Vector3<f64>) -> f64 {
        let local = self.pose.q.inverse_transform_vector(n);
        let k = (0..self.hull.vertices.len())
            .min_by(|&x, &y| {
                self.hull.vertices[x]
                    .dot(&local)
                    .total_cmp(&self.hull.vertices[y].dot(&local))
            })
            .unwrap_or(0);
        n.dot(&self.vertex(k))
    }

    /// The best face axis: its separation of `other` and the face.
    fn face_query(&self, other: &Side) -> (f64, usize) {
        let mut best = (f64::NEG_INFINITY, 0);
        for f in 0..self.hull.faces.len() {
            let n = self.normal(f);
            let on = n.dot(&self.vertex(self.hull.faces[f].verts[0]));
            let s = other.lowest(&n) - on;
            if s > best.0 {
                best = (s, f);
            }
        }
        best
    }
}

/// Whether edges with face normals (`a`, `b`) on one hull and (`c`, `d`)
/// on the other (negated) form a face of the Minkowski difference: their
/// arcs on the Gauss map cross.
fn minkowski_face(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>, d: &Vector3<f64>) -> bool {
    let bxa = b.cross(a);
    let dxc = d.cross(c);
    let (cba, dba, adc, bdc) = (c.dot(&bxa), d.dot(&bxa), a.dot(&dxc), b.dot(&dxc));
    cba * dba < 0.0 && adc * bdc < 0.0 && cba * bdc > 0.0
}

/// Two hulls (bodies A and B) by separating axes: the contacts whose gap is
/// at most `within`, the points chosen before `within` filters them.
#[allow(clippy::too_many_arguments)]
pub fn hull_hull(
    a: usize,
    pa: &Pose,
    ha: &Hull,
    b: usize,
    pb: &Pose,
    hb: &Hull,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let (sa, sb) = (Side { pose: pa, hull: ha }, Side { pose: pb, hull: hb });
    let (s_a, f_a) = sa.face_query(&sb);
    if s_a > within {
        return;
    }
    let (s_b, f_b) = sb.face_query(&sa);
    if s_b > within {
        return;
    }
    // Edge pairs that form a face of the Minkowski difference.
    let centre_a = pa.point(&ha.centre);
    let mut edge: Option<(f64, Vector3<f64>, usize, usize)> = None;
    for (i, ea) in ha.edges.iter().enumerate() {
        let (na, nb) = (sa.normal(ea.left), sa.normal(ea.right));
        let (p0, p1) = (sa.vertex(ea.a), sa.vertex(ea.b));
        for (j, eb) in hb.edges.iter().enumerate() {
            let (nc, nd) = (-sb.normal(eb.left), -sb.normal(eb.right));
            if !minkowski_face(&na, &nb, &nc, &nd) {
                continue;
            }
            let (q0, q1) = (sb.vertex(eb.a), sb.vertex(eb.b));
            let c = (p1 - p0).cross(&(q1 - q0));
            let len = c.norm();
            // Near-parallel edges: their faces' axes cover the pair.
            if len < 1e-9 * (p1 - p0).norm() * (q1 - q0).norm() {
                continue;
            }
            let mut l = c / len;
            if l.dot(&(p0 - centre_a)) < 0.0 {
                l = -l;
            }
            // From A towards B: B's edge beyond A's.
            let s = l.dot(&(q0 - p0));
            if edge.is_none_or(|e| s > e.0) {
                edge = Some((s, l, i, j));
            }
        }
    }
    let face_sep = s_a.max(s_b);
    if let Some((s_e, l, i, j)) = edge {
        if s_e > within {
            return;
        }
        if s_e > face_sep + PREFER_FACE {
            let (ea, eb) = (ha.edges[i], hb.edges[j]);
            let (p0, p1) = (sa.vertex(ea.a), sa.vertex(ea.b));
            let (q0, q1) = (sb.vertex(eb.a), sb.vertex(eb.b));
            let (s, t) = nearest_between_segments(&p0, &p1, &q0, &q1);
            let on_a = p0 + (p1 - p0) * s;
            let on_b = q0 + (q1 - q0) * t;
            // The normal from B towards A.
            let normal = -l;
            let gap = (on_a - on_b).dot(&normal);
            if gap <= within {
                out.push(Geometry {
                    a,
                    b: Counterpart::Body(b),
                    feature: 0,
                    gap,
                    normal,
                    point: (on_a + on_b) * 0.5,
                    r_a: on_a - pa.x,
                    r_b: on_b - pb.x,
                });
            }
            return;
        }
    }
    // Reference face: A's unless B's separates clearly more; n_ref points
    // out of the reference hull towards the incident one.
    let reference_is_a = s_b <= s_a + PREFER_FACE;
    let (r, i, f) = if reference_is_a {
        (&sa, &sb, f_a)
    } else {
        (&sb, &sa, f_b)
    };
    let n_ref = r.normal(f);
    let face = &r.hull.faces[f];
    let on_ref = r.vertex(face.verts[0]);
    // The incident face: the one most against n_ref.
    let g = (0..i.hull.faces.len())
        .min_by(|&x, &y| i.normal(x).dot(&n_ref).total_cmp(&i.normal(y).dot(&n_ref)))
        .unwrap_or(0);
    let mut poly = Polygon::<64>::default();
    for &k in &i.hull.faces[g].verts {
        poly.push(i.vertex(k));
    }
    // Clip to the reference face's sides: each edge crossed with the
    // normal points out of the face.
    let m = face.verts.len();
    for k in 0..m {
        let (v0, v1) = (r.vertex(face.verts[k]), r.vertex(face.verts[(k + 1) % m]));
        let side = (v1 - v0).cross(&n_ref);
        let len = side.norm();
        if len > 0.0 {
            let side = side / len;
            poly = poly.clip(&side, side.dot(&v0));
        }
    }
    let reference = Reference {
        is_a: reference_is_a,
        normal: n_ref,
        on: on_ref,
    };
    push_face_contacts((a, pa), (b, pb), &poly, &reference, within, out);
}
