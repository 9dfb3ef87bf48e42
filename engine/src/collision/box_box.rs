use super::manifold::{push_face_contacts, Polygon, Reference};
use super::segment::{nearest_between_segments, Pose};
use super::Geometry;
use crate::model::Counterpart;
use nalgebra::Vector3;

/// How much more separation (m) an axis needs than the best face axis to
/// be taken instead: B's face before A's, an edge pair before a face,
/// only when clearly better, so that a box resting on a box keeps its
/// reference face, and its contacts their features, from step to step.
const PREFER_FACE: f64 = 1e-6;

/// Two boxes (bodies A and B) by separating axes (Gottschalk; ODE's
/// `dBoxBox`): of the fifteen axes (each box's three face normals, the
/// nine edge pairs' cross products) the one of largest separation. On a
/// face axis, the other box's face most against it is clipped to the
/// reference face's sides (Sutherland-Hodgman), its points at most four
/// (deepest first, then those spanning the largest area) and listed as
/// features 0..4 in clipping order; on an edge axis, the edges' nearest
/// points, feature 0. Which points is decided before `within` filters
/// them (as in `box_plane`).
#[allow(clippy::too_many_arguments)]
pub fn box_box(
    a: usize,
    pa: &Pose,
    ha: &Vector3<f64>,
    b: usize,
    pb: &Pose,
    hb: &Vector3<f64>,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let axes = |p: &Pose| {
        let m = p.q.to_rotation_matrix().into_inner();
        [
            m.column(0).into_owned(),
            m.column(1).into_owned(),
            m.column(2).into_owned(),
        ]
    };
    let (aa, ab) = (axes(pa), axes(pb));
    let d = pa.x - pb.x;
    let extent = |ax: &[Vector3<f64>; 3], h: &Vector3<f64>, l: &Vector3<f64>| {
        (0..3).map(|k| h[k] * ax[k].dot(l).abs()).sum::<f64>()
    };
    // Separation along unit axis `l`, turned to point from B to A.
    let sep = |l: Vector3<f64>| {
        let l = if l.dot(&d) < 0.0 { -l } else { l };
        (l.dot(&d) - extent(&aa, ha, &l) - extent(&ab, hb, &l), l)
    };
    // The face axis of largest separation, ties to the first.
    let best_of = |ax: &[Vector3<f64>; 3]| {
        let mut best = (sep(ax[0]), 0);
        for (i, a) in ax.iter().enumerate().skip(1) {
            let s = sep(*a);
            if s.0 > best.0 .0 {
                best = (s, i);
            }
        }
        best
    };
    let ((s_a, l_a), i_a) = best_of(&aa);
    let ((s_b, l_b), i_b) = best_of(&ab);
    let mut edge: Option<(f64, Vector3<f64>, usize, usize)> = None;
    for (i, ea) in aa.iter().enumerate() {
        for (j, eb) in ab.iter().enumerate() {
            let c = ea.cross(eb);
            let len = c.norm();
            // Near-parallel edges: their face axes cover the pair.
            if len < 1e-6 {
                continue;
            }
            let (s, l) = sep(c / len);
            if edge.is_none_or(|e| s > e.0) {
                edge = Some((s, l, i, j));
            }
        }
    }
    let face_sep = s_a.max(s_b);
    if face_sep.max(edge.map_or(f64::NEG_INFINITY, |e| e.0)) > within {
        return;
    }
    if let Some((s_e, l, i, j)) = edge {
        if s_e > face_sep + PREFER_FACE {
            edge_contact(a, pa, (&aa, ha, i), b, pb, (&ab, hb, j), l, within, out);
            return;
        }
    }
    // Reference face: A's unless B's separates clearly more. n_ref points
    // out of the reference box towards the incident one.
    let (reference_is_a, r_pose, r_axes, r_h, r_i, n_ref) = if s_b > s_a + PREFER_FACE {
        (false, pb, &ab, hb, i_b, l_b)
    } else {
        (true, pa, &aa, ha, i_a, -l_a)
    };
    let (i_pose, i_axes, i_h) = if reference_is_a {
        (pb, &ab, hb)
    } else {
        (pa, &aa, ha)
    };
    let centre = r_pose.x + n_ref * r_h[r_i];
    // The incident face: the incident box's face most against n_ref.
    let k = (0..3)
        .max_by(|&x, &y| {
            i_axes[x]
                .dot(&n_ref)
                .abs()
                .total_cmp(&i_axes[y].dot(&n_ref).abs())
                .then(y.cmp(&x))
        })
        .expect("three axes");
    let s = if i_axes[k].dot(&n_ref) > 0.0 {
        -1.0
    } else {
        1.0
    };
    let fc = i_pose.x + i_axes[k] * (s * i_h[k]);
    let (u, v) = ((k + 1) % 3, (k + 2) % 3);
    let (du, dv) = (i_axes[u] * i_h[u], i_axes[v] * i_h[v]);
    let mut poly = Polygon::<8>::default();
    for p in [fc + du + dv, fc - du + dv, fc - du - dv, fc + du - dv] {
        poly.push(p);
    }
    // Clip to the reference face's four sides.
    for j in [(r_i + 1) % 3, (r_i + 2) % 3] {
        for sign in [1.0, -1.0] {
            let n = r_axes[j] * sign;
            let offset = n.dot(&r_pose.x) + r_h[j];
            poly = poly.clip(&n, offset);
        }
    }
    let reference = Reference {
        is_a: reference_is_a,
        normal: n_ref,
        on: centre,
    };
    push_face_contacts((a, pa), (b, pb), &poly, &reference, within, out);
}

/// The contact of an edge pair: A's edge `i` nearest B along `-l` and
/// B's edge `j` nearest A along `l`; their segments' nearest points.
#[allow(clippy::too_many_arguments)]
fn edge_contact(
    a: usize,
    pa: &Pose,
    (aa, ha, i): (&[Vector3<f64>; 3], &Vector3<f64>, usize),
    b: usize,
    pb: &Pose,
    (ab, hb, j): (&[Vector3<f64>; 3], &Vector3<f64>, usize),
    l: Vector3<f64>,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let support = |p: &Pose, ax: &[Vector3<f64>; 3], h: &Vector3<f64>, skip: usize, dir| {
        (0..3).filter(|&k| k != skip).fold(p.x, |c, k| {
            let s = if ax[k].dot(&dir) >= 0.0 { 1.0 } else { -1.0 };
            c + ax[k] * (s * h[k])
        })
    };
    let ca = support(pa, aa, ha, i, -l);
    let cb = support(pb, ab, hb, j, l);
    let (ea, eb) = (aa[i] * ha[i], ab[j] * hb[j]);
    let (s, t) = nearest_between_segments(&(ca - ea), &(ca + ea), &(cb - eb), &(cb + eb));
    let on_a = ca - ea + ea * (2.0 * s);
    let on_b = cb - eb + eb * (2.0 * t);
    let gap = (on_a - on_b).dot(&l);
    if gap <= within {
        out.push(Geometry {
            a,
            b: Counterpart::Body(b),
            feature: 0,
            gap,
            normal: l,
            point: (on_a + on_b) * 0.5,
            r_a: on_a - pa.x,
            r_b: on_b - pb.x,
        });
    }
}
