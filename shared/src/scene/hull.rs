//! The convex hull of a point cloud (a collision mesh's vertices, as
//! MuJoCo and PyBullet take a mesh's hull): its vertices and its faces,
//! each a convex polygon, counter-clockwise seen from outside, coplanar
//! triangles merged. Incremental (beneath-beyond): each point that lies
//! beyond some face by more than a tolerance replaces the faces it sees by
//! a fan from their horizon. Shared by the importers (which keep only the
//! hull's vertices in a scene) and the engine (which builds the faces
//! again from them).

type V = [f64; 3];

fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V, b: V) -> V {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: V) -> f64 {
    dot(a, a).sqrt()
}

/// A convex hull: its vertices and faces (indices into `vertices`).
#[derive(Debug, Clone, PartialEq)]
pub struct Hull {
    pub vertices: Vec<V>,
    /// Each face's vertex loop, counter-clockwise seen from outside.
    pub faces: Vec<Vec<usize>>,
}

#[derive(Clone, Copy)]
struct Tri {
    v: [usize; 3],
    n: V,
    d: f64,
    alive: bool,
}

fn tri(points: &[V], v: [usize; 3]) -> Tri {
    let [a, b, c] = v.map(|k| points[k]);
    let n = cross(sub(b, a), sub(c, a));
    let l = norm(n);
    let n = if l > 0.0 { n.map(|x| x / l) } else { n };
    Tri {
        v,
        n,
        d: dot(n, a),
        alive: true,
    }
}

/// The hull of `points`, or why there is none (fewer than four points not
/// on one plane, a number not finite).
pub fn convex_hull(points: &[V]) -> Result<Hull, String> {
    if points.iter().flatten().any(|x| !x.is_finite()) {
        return Err("a point is not finite".into());
    }
    // A mesh lists each vertex once per triangle: the distinct ones.
    let mut unique: Vec<V> = points.to_vec();
    unique.sort_unstable_by(|a, b| a.map(f64::to_bits).cmp(&b.map(f64::to_bits)));
    unique.dedup();
    let points = &unique[..];
    if points.len() < 4 {
        return Err(format!("{} points: a solid needs at least 4", points.len()));
    }
    let (lo, hi) = points.iter().fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1]), lo[2].min(p[2])],
                [hi[0].max(p[0]), hi[1].max(p[1]), hi[2].max(p[2])],
            )
        },
    );
    let size = norm(sub(hi, lo));
    // Distances below this are round-off: a point this near a face's plane
    // lies on it.
    let eps = 1e-9 * size.max(f64::MIN_POSITIVE);
    // The first simplex: two extreme points, the farthest from their line,
    // the farthest from their plane.
    let far = |score: &dyn Fn(V) -> f64| {
        (0..points.len())
            .max_by(|&i, &j| {
                score(points[i])
                    .total_cmp(&score(points[j]))
                    .then(j.cmp(&i))
            })
            .unwrap_or(0)
    };
    let i0 = far(&|p| -p[0]);
    let i1 = far(&|p| norm(sub(p, points[i0])));
    let line = sub(points[i1], points[i0]);
    let i2 = far(&|p| norm(cross(line, sub(p, points[i0]))));
    let normal = cross(line, sub(points[i2], points[i0]));
    let i3 = far(&|p| dot(normal, sub(p, points[i0])).abs());
    let height = dot(normal, sub(points[i3], points[i0])) / norm(normal).max(f64::MIN_POSITIVE);
    if norm(line) <= eps || norm(normal) <= eps * norm(line) || height.abs() <= eps {
        return Err("the points lie on one plane (or line): no solid".into());
    }
    let mut tris: Vec<Tri> = Vec::new();
    let base = if height > 0.0 {
        [i0, i2, i1]
    } else {
        [i0, i1, i2]
    };
    tris.push(tri(points, base));
    for (a, b) in [(base[0], base[1]), (base[1], base[2]), (base[2], base[0])] {
        // The base's edges walked the other way, closed at the apex.
        tris.push(tri(points, [b, a, i3]));
    }
    // Quickhull's conflict lists: each point beyond some face is listed
    // with the first such face; a face's farthest point is added next, and
    // the points of the faces it replaces go to the new faces.
    let mut outside: Vec<Vec<usize>> = vec![Vec::new(); tris.len()];
    let beyond = |t: &Tri, x: V| dot(t.n, x) - t.d > eps;
    for (p, &x) in points.iter().enumerate() {
        if let Some(k) = (0..tris.len()).find(|&k| beyond(&tris[k], x)) {
            outside[k].push(p);
        }
    }
    let mut seen: std::collections::HashSet<(usize, usize)> = Default::default();
    let mut orphans: Vec<usize> = Vec::new();
    // The faces alive, so that a step scans those only.
    let mut alive: Vec<usize> = (0..tris.len()).collect();
    while let Some(f) = alive.iter().copied().find(|&k| !outside[k].is_empty()) {
        let t = tris[f];
        let p = *outside[f]
            .iter()
            .max_by(|&&i, &&j| {
                (dot(t.n, points[i]) - t.d)
                    .total_cmp(&(dot(t.n, points[j]) - t.d))
                    .then(j.cmp(&i))
            })
            .unwrap_or(&outside[f][0]);
        let x = points[p];
        seen.clear();
        orphans.clear();
        for &k in &alive {
            if beyond(&tris[k], x) {
                tris[k].alive = false;
                let v = tris[k].v;
                seen.extend([(v[0], v[1]), (v[1], v[2]), (v[2], v[0])]);
                orphans.append(&mut outside[k]);
            }
        }
        // The horizon: the edges of the faces seen whose other face was not.
        let first = tris.len();
        let mut horizon: Vec<(usize, usize)> = seen
            .iter()
            .copied()
            .filter(|&(a, b)| !seen.contains(&(b, a)))
            .collect();
        horizon.sort_unstable();
        alive.retain(|&k| tris[k].alive);
        for (a, b) in horizon {
            alive.push(tris.len());
            tris.push(tri(points, [a, b, p]));
            outside.push(Vec::new());
        }
        for &q in orphans.iter().filter(|&&q| q != p) {
            if let Some(k) = (first..tris.len()).find(|&k| beyond(&tris[k], points[q])) {
                outside[k].push(q);
            }
        }
    }
    tris.retain(|t| t.alive);
    Ok(merge(points, &tris, eps))
}

/// Coplanar neighbours merged into one face each, the vertices numbered
/// anew (those of the hull only, in first use).
fn merge(points: &[V], tris: &[Tri], eps: f64) -> Hull {
    let n = tris.len();
    // Union-find over triangles sharing an edge in one plane.
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let edges = |t: &Tri| [(t.v[0], t.v[1]), (t.v[1], t.v[2]), (t.v[2], t.v[0])];
    let mut owner: std::collections::HashMap<(usize, usize), usize> = Default::default();
    for (i, t) in tris.iter().enumerate() {
        for e in edges(t) {
            owner.insert(e, i);
        }
    }
    for (i, t) in tris.iter().enumerate() {
        for (a, b) in edges(t) {
            if let Some(&j) = owner.get(&(b, a)) {
                let u = &tris[j];
                // Coplanar: the far vertex of each within round-off of the
                // other's plane.
                let off = |t: &Tri, u: &Tri| {
                    u.v.iter()
                        .map(|&k| (dot(t.n, points[k]) - t.d).abs())
                        .fold(0.0, f64::max)
                };
                if dot(t.n, u.n) > 0.0 && off(t, u) <= eps && off(u, t) <= eps {
                    let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                    parent[ri.max(rj)] = ri.min(rj);
                }
            }
        }
    }
    let mut groups: Vec<(usize, Vec<usize>)> = Vec::new();
    for i in 0..n {
        let r = root(&mut parent, i);
        match groups.iter_mut().find(|g| g.0 == r) {
            Some(g) => g.1.push(i),
            None => groups.push((r, vec![i])),
        }
    }
    let mut index: Vec<Option<usize>> = vec![None; points.len()];
    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for (_, members) in groups {
        let inside: Vec<(usize, usize)> = members.iter().flat_map(|&i| edges(&tris[i])).collect();
        let boundary: Vec<(usize, usize)> = inside
            .iter()
            .copied()
            .filter(|&(a, b)| !inside.contains(&(b, a)))
            .collect();
        // Walk the boundary from its first edge.
        let Some(&(start, mut next)) = boundary.first() else {
            continue;
        };
        let mut lp = vec![start];
        while next != start && lp.len() <= boundary.len() {
            lp.push(next);
            match boundary.iter().find(|e| e.0 == next) {
                Some(&(_, b)) => next = b,
                None => break,
            }
        }
        let face: Vec<usize> = lp
            .into_iter()
            .map(|k| {
                *index[k].get_or_insert_with(|| {
                    vertices.push(points[k]);
                    vertices.len() - 1
                })
            })
            .collect();
        faces.push(face);
    }
    Hull { vertices, faces }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube's eight corners and points inside and on its faces: eight
    /// vertices, six square faces, each normal outward.
    #[test]
    fn a_cube_with_points_inside_and_on_faces_is_six_squares() {
        let mut pts = Vec::new();
        for k in 0..8 {
            let s = |bit: usize| if k & bit != 0 { 1.0 } else { -1.0 };
            pts.push([s(1), s(2), s(4)]);
        }
        pts.extend([
            [0.0, 0.0, 0.0],
            [0.5, 0.2, 1.0],
            [1.0, 0.0, 0.0],
            [0.3, -0.3, 0.1],
        ]);
        let h = convex_hull(&pts).expect("a hull");
        assert_eq!(h.vertices.len(), 8);
        assert_eq!(h.faces.len(), 6);
        for f in &h.faces {
            assert_eq!(f.len(), 4, "{f:?}");
            let [a, b, c] = [f[0], f[1], f[2]].map(|k| h.vertices[k]);
            let n = cross(sub(b, a), sub(c, a));
            // Outward: the centre (origin) behind the face.
            assert!(dot(n, a) > 0.0);
        }
    }

    /// A sphere's sampled points: every point inside or on the hull, the
    /// hull's faces closed (each edge in two faces, once each way), and
    /// Euler's V - E + F = 2.
    #[test]
    fn a_sampled_sphere_gives_a_closed_hull() {
        let mut pts = Vec::new();
        for i in 0..20 {
            for j in 0..40 {
                let (t, p) = (
                    std::f64::consts::PI * (i as f64 + 0.5) / 20.0,
                    2.0 * std::f64::consts::PI * j as f64 / 40.0,
                );
                pts.push([t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]);
            }
        }
        let h = convex_hull(&pts).expect("a hull");
        let mut edges = Vec::new();
        for f in &h.faces {
            for k in 0..f.len() {
                edges.push((f[k], f[(k + 1) % f.len()]));
            }
        }
        for &(a, b) in &edges {
            assert!(edges.contains(&(b, a)), "edge {a}-{b} has one face");
        }
        let (v, e, f) = (
            h.vertices.len() as i64,
            edges.len() as i64 / 2,
            h.faces.len() as i64,
        );
        assert_eq!(v - e + f, 2);
        assert_eq!(v, 800);
        for p in &pts {
            for face in &h.faces {
                let [a, b, c] = [face[0], face[1], face[2]].map(|k| h.vertices[k]);
                let n = cross(sub(b, a), sub(c, a));
                assert!(dot(n, sub(*p, a)) <= 1e-9, "a point outside");
            }
        }
    }

    #[test]
    fn flat_or_few_points_have_no_hull() {
        assert!(convex_hull(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]).is_err());
        let flat: Vec<V> = (0..10).map(|k| [k as f64, (k * k) as f64, 0.0]).collect();
        assert!(convex_hull(&flat).unwrap_err().contains("one plane"));
    }
}
