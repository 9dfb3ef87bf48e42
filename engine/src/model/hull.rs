//! A convex hull as the collision stage reads it: vertices, faces with
//! their planes, and edges with the two faces they join (the Gauss map's
//! arcs, for the separating-axis test of `collision/hull.rs`), in the
//! shape's frame.

use nalgebra::Vector3;

/// The sides of the prism a cylinder is against boxes, capsules, hulls
/// and cylinders (but on a box's or hull's face: `collision::cylinder`):
/// its flat sides lie within r (1 - cos(pi / 32)), 0.5 % of its radius,
/// of the round one.
pub const CYLINDER_SIDES: usize = 32;

#[derive(Debug, Clone, PartialEq)]
pub struct Face {
    /// Outward unit normal; `normal . x = offset` on the face.
    pub normal: Vector3<f64>,
    pub offset: f64,
    /// The vertex loop, counter-clockwise seen from outside.
    pub verts: Vec<usize>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    pub a: usize,
    pub b: usize,
    /// The faces on either side (`a -> b` runs counter-clockwise in
    /// `left`).
    pub left: usize,
    pub right: usize,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Hull {
    pub vertices: Vec<Vector3<f64>>,
    pub faces: Vec<Face>,
    pub edges: Vec<Edge>,
    /// A point inside (the vertices' mean).
    pub centre: Vector3<f64>,
    /// The farthest vertex's distance from the shape's origin.
    pub bound: f64,
}

impl Hull {
    /// The hull of `points` (validated by the scene: a solid).
    pub fn new(points: &[[f64; 3]]) -> Hull {
        let h = cosim_shared::scene::hull::convex_hull(points).unwrap_or_else(|_| {
            // Unreachable for a validated scene: a tiny tetrahedron.
            cosim_shared::scene::hull::convex_hull(&[
                [0.0; 3],
                [1e-6, 0.0, 0.0],
                [0.0, 1e-6, 0.0],
                [0.0, 0.0, 1e-6],
            ])
            .expect("a tetrahedron")
        });
        Hull::from_mesh(&h)
    }

    /// The prism of [`CYLINDER_SIDES`] sides inscribed in a cylinder of
    /// radius `r` and half length `l` about z (a cylinder against a box,
    /// capsule, hull or cylinder).
    pub fn cylinder(r: f64, l: f64) -> Hull {
        let rims: Vec<[f64; 3]> = (0..CYLINDER_SIDES)
            .flat_map(|k| {
                let t = k as f64 * std::f64::consts::TAU / CYLINDER_SIDES as f64;
                [-l, l].map(|z| [r * t.cos(), r * t.sin(), z])
            })
            .collect();
        Hull::new(&rims)
    }

    /// The hull of a box of half extents `h` (for a box against a hull).
    pub fn cuboid(h: &Vector3<f64>) -> Hull {
        let corners: Vec<[f64; 3]> = (0..8)
            .map(|k| {
                let s = |bit: usize| if k & bit != 0 { 1.0 } else { -1.0 };
                [s(1) * h.x, s(2) * h.y, s(4) * h.z]
            })
            .collect();
        Hull::new(&corners)
    }

    fn from_mesh(h: &cosim_shared::scene::hull::Hull) -> Hull {
        let vertices: Vec<Vector3<f64>> = h.vertices.iter().map(|&v| Vector3::from(v)).collect();
        let centre = vertices.iter().sum::<Vector3<f64>>() / vertices.len().max(1) as f64;
        let faces: Vec<Face> = h
            .faces
            .iter()
            .map(|loop_| {
                // Newell's normal: robust for a polygon of many vertices.
                let mut n = Vector3::zeros();
                for k in 0..loop_.len() {
                    let (p, q) = (vertices[loop_[k]], vertices[loop_[(k + 1) % loop_.len()]]);
                    n += p.cross(&q);
                }
                let n = n.normalize();
                let mean =
                    loop_.iter().map(|&k| vertices[k]).sum::<Vector3<f64>>() / loop_.len() as f64;
                Face {
                    normal: n,
                    offset: n.dot(&mean),
                    verts: loop_.clone(),
                }
            })
            .collect();
        let mut edges = Vec::new();
        for (f, face) in faces.iter().enumerate() {
            for k in 0..face.verts.len() {
                let (a, b) = (face.verts[k], face.verts[(k + 1) % face.verts.len()]);
                if a < b {
                    let right = faces
                        .iter()
                        .position(|g| {
                            (0..g.verts.len())
                                .any(|j| g.verts[j] == b && g.verts[(j + 1) % g.verts.len()] == a)
                        })
                        .unwrap_or(f);
                    edges.push(Edge {
                        a,
                        b,
                        left: f,
                        right,
                    });
                }
            }
        }
        let bound = vertices.iter().map(|v| v.norm()).fold(0.0, f64::max);
        Hull {
            vertices,
            faces,
            edges,
            centre,
            bound,
        }
    }
}
