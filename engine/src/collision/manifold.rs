//! A contact manifold's polygon: clipped to a reference face's sides and
//! reduced to at most four points (box-box, hull-hull).

use super::segment::Pose;
use super::Geometry;
use crate::model::Counterpart;
use nalgebra::Vector3;

/// The reference face of a face contact between bodies A and B: which
/// side it is on, its outward normal (towards the other body) and a point
/// on it.
pub struct Reference {
    pub is_a: bool,
    pub normal: Vector3<f64>,
    pub on: Vector3<f64>,
}

/// The contacts of a clipped incident polygon against its reference face:
/// reduced to four points (features 0..4 in clipping order, chosen before
/// `within` filters them), each pushed with its gap to the face.
#[allow(clippy::too_many_arguments)]
pub fn push_face_contacts<const N: usize>(
    (a, pa): (usize, &Pose),
    (b, pb): (usize, &Pose),
    poly: &Polygon<N>,
    r: &Reference,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let n_ref = r.normal;
    let depth = |p: &Vector3<f64>| n_ref.dot(&(p - r.on));
    let kept = poly.reduce(&n_ref, depth);
    for (feature, &p) in kept.iter().enumerate() {
        let gap = depth(&p);
        if gap > within {
            continue;
        }
        out.push(face_contact((a, pa), (b, pb), r, p, gap, feature));
    }
}

/// The contact of point `p` of the incident side, `gap` above reference
/// face `r` (its foot on the face the reference side's point).
pub fn face_contact(
    (a, pa): (usize, &Pose),
    (b, pb): (usize, &Pose),
    r: &Reference,
    p: Vector3<f64>,
    gap: f64,
    feature: usize,
) -> Geometry {
    let n_ref = r.normal;
    let on_ref = p - n_ref * gap;
    let (on_a, on_b, normal) = if r.is_a {
        (on_ref, p, -n_ref)
    } else {
        (p, on_ref, n_ref)
    };
    Geometry {
        a,
        b: Counterpart::Body(b),
        feature,
        gap,
        normal,
        point: p - n_ref * (0.5 * gap),
        r_a: on_a - pa.x,
        r_b: on_b - pb.x,
    }
}

/// A convex polygon of at most `N` points on the stack (eight for a
/// quadrilateral clipped by four half-planes; more for a hull's face):
/// points past `N` are dropped.
#[derive(Clone, Copy)]
pub struct Polygon<const N: usize> {
    p: [Vector3<f64>; N],
    n: usize,
}

impl<const N: usize> Default for Polygon<N> {
    fn default() -> Self {
        Polygon {
            p: [Vector3::zeros(); N],
            n: 0,
        }
    }
}

impl<const N: usize> Polygon<N> {
    pub fn push(&mut self, p: Vector3<f64>) {
        if self.n < self.p.len() {
            self.p[self.n] = p;
            self.n += 1;
        }
    }

    pub fn points(&self) -> &[Vector3<f64>] {
        &self.p[..self.n]
    }

    /// The part with `n . p <= offset` (Sutherland-Hodgman).
    pub fn clip(&self, n: &Vector3<f64>, offset: f64) -> Polygon<N> {
        let mut out = Polygon::default();
        let pts = self.points();
        for (k, &p) in pts.iter().enumerate() {
            let q = pts[(k + 1) % pts.len()];
            let (dp, dq) = (n.dot(&p) - offset, n.dot(&q) - offset);
            if dp <= 0.0 {
                out.push(p);
            }
            if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
                out.push(p + (q - p) * (dp / (dp - dq)));
            }
        }
        out
    }

    /// At most four of the points, in their order: all when four or
    /// fewer; else the deepest, the one farthest from it, the one making
    /// the largest triangle with those, and the one adding the most area
    /// outside that triangle (Box2D's and Bullet's manifold reduction).
    pub fn reduce(
        &self,
        normal: &Vector3<f64>,
        depth: impl Fn(&Vector3<f64>) -> f64,
    ) -> Polygon<N> {
        let pts = self.points();
        if pts.len() <= 4 {
            return *self;
        }
        let mut out = Polygon::default();
        for &k in self.reduce_indices(normal, depth).iter() {
            out.push(pts[k]);
        }
        out
    }

    /// The places of the points `reduce` keeps, ascending (all when four
    /// or fewer).
    pub fn reduce_indices(
        &self,
        normal: &Vector3<f64>,
        depth: impl Fn(&Vector3<f64>) -> f64,
    ) -> Vec4 {
        let pts = self.points();
        if pts.len() <= 4 {
            return Vec4 {
                k: [0, 1, 2, 3],
                n: pts.len(),
            };
        }
        // The best-scoring point not yet picked, ties to the first.
        let arg_max = |picked: &[usize], score: &dyn Fn(usize) -> f64| {
            (0..pts.len())
                .filter(|k| !picked.contains(k))
                .max_by(|&x, &y| score(x).total_cmp(&score(y)).then(y.cmp(&x)))
                .expect("more than four points")
        };
        let p0 = arg_max(&[], &|k| -depth(&pts[k]));
        let p1 = arg_max(&[p0], &|k| (pts[k] - pts[p0]).norm_squared());
        let area =
            |x: usize, y: usize, k: usize| (pts[y] - pts[x]).cross(&(pts[k] - pts[x])).dot(normal);
        let p2 = arg_max(&[p0, p1], &|k| area(p0, p1, k).abs());
        // The fourth lies across one of the triangle's sides from its
        // third corner: the largest such triangle.
        let side = area(p0, p1, p2).signum();
        let outside = |k: usize| {
            [(p0, p1), (p1, p2), (p2, p0)]
                .iter()
                .map(|&(x, y)| -side * area(x, y, k))
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let p3 = arg_max(&[p0, p1, p2], &outside);
        let mut keep = [p0, p1, p2, p3];
        keep.sort_unstable();
        Vec4 { k: keep, n: 4 }
    }
}

/// Up to four indices, on the stack.
#[derive(Clone, Copy, Debug)]
pub struct Vec4 {
    k: [usize; 4],
    n: usize,
}

impl std::ops::Deref for Vec4 {
    type Target = [usize];
    fn deref(&self) -> &[usize] {
        &self.k[..self.n]
    }
}

impl<const N: usize> std::ops::Deref for Polygon<N> {
    type Target = [Vector3<f64>];
    fn deref(&self) -> &[Vector3<f64>] {
        self.points()
    }
}
