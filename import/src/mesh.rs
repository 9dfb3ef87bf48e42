//! Collision meshes (STL, OBJ, COLLADA, read by `mesh-loader`) as the
//! points of their convex hull, as MuJoCo and PyBullet collide a mesh.

use cosim_shared::scene::hull::convex_hull;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A hull's points, or why there are none.
type Points = Result<Vec<[f64; 3]>, String>;

/// The hulls read so far, by file and scale (the scale's bits): robots
/// reuse their meshes.
#[derive(Default)]
pub struct Meshes {
    read: HashMap<(PathBuf, [u64; 3]), Points>,
}

impl Meshes {
    /// The vertices of the convex hull of the mesh in `path`, each scaled
    /// by `scale` per axis; or why not (the file unreadable, the mesh
    /// flat).
    pub fn hull(&mut self, path: &Path, scale: [f64; 3]) -> Result<Vec<[f64; 3]>, String> {
        let key = (path.to_path_buf(), scale.map(f64::to_bits));
        self.read
            .entry(key)
            .or_insert_with(|| read_hull(path, scale))
            .clone()
    }
}

impl Meshes {
    /// The hull's points (as [`Meshes::hull`]) and the volume (as `mass`),
    /// centroid and unit-density inertia of the full convex hull of every
    /// vertex (MuJoCo's `inertia="convex"`), in the mesh's frame.
    pub fn solid(
        &mut self,
        path: &Path,
        scale: [f64; 3],
    ) -> Result<(Vec<[f64; 3]>, Option<crate::mjcf::mass::Mass>), String> {
        let points = self.hull(path, scale)?;
        let all = scaled(path, scale)?;
        let hull = convex_hull(&all).map_err(|e| format!("{}: {e}", path.display()))?;
        let triangles: Vec<[usize; 3]> = hull
            .faces
            .iter()
            .flat_map(|f| (1..f.len().saturating_sub(1)).map(move |k| [f[0], f[k], f[k + 1]]))
            .collect();
        Ok((
            points,
            crate::mjcf::mass::of_solid(&hull.vertices, &triangles),
        ))
    }
}

fn read_hull(path: &Path, scale: [f64; 3]) -> Result<Vec<[f64; 3]>, String> {
    let points = scaled(path, scale)?;
    let few = supports(&points);
    let hull = convex_hull(&few).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(hull.vertices)
}

/// Every vertex of the mesh in `path`, scaled per axis.
fn scaled(path: &Path, scale: [f64; 3]) -> Result<Vec<[f64; 3]>, String> {
    let vertices: Vec<[f32; 3]> = match mesh_loader::Loader::default().load(path) {
        Ok(scene) => scene
            .meshes
            .iter()
            .flat_map(|m| m.vertices.iter().copied())
            .collect(),
        // A binary STL whose header starts with "solid" is read as text
        // and fails (example-robot-data's bolt_foot.stl): its size tells.
        Err(e) => std::fs::read(path)
            .ok()
            .and_then(|b| binary_stl(&b))
            .ok_or_else(|| format!("cannot read {}: {e}", path.display()))?,
    };
    let points: Vec<[f64; 3]> = vertices
        .iter()
        .map(|v| {
            [
                f64::from(v[0]) * scale[0],
                f64::from(v[1]) * scale[1],
                f64::from(v[2]) * scale[2],
            ]
        })
        .collect();
    Ok(points)
}

/// At most this many directions pick a hull's vertices: a CAD mesh's hull
/// has thousands (every vertex of a curved surface), which the separating
/// axes pay for per pair of edges; its support points along evenly spread
/// directions span a hull within 1.5 % of its size of the full one
/// (`tests::a_curved_mesh_keeps_its_hull_within_one_and_a_half_percent`).
pub const DIRECTIONS: usize = 256;

/// The points, or where there are more than `DIRECTIONS`, the farthest
/// along each of `DIRECTIONS` directions spread over the sphere (a
/// Fibonacci lattice) and the 26 of the cube's faces, edges and corners.
fn supports(points: &[[f64; 3]]) -> Vec<[f64; 3]> {
    if points.len() <= DIRECTIONS {
        return points.to_vec();
    }
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut dirs: Vec<[f64; 3]> = (0..DIRECTIONS)
        .map(|k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / DIRECTIONS as f64;
            let r = (1.0 - z * z).sqrt();
            let a = golden * k as f64;
            [r * a.cos(), r * a.sin(), z]
        })
        .collect();
    for x in [-1.0, 0.0, 1.0] {
        for y in [-1.0, 0.0, 1.0] {
            for z in [-1.0, 0.0, 1.0] {
                if (x, y, z) != (0.0, 0.0, 0.0) {
                    dirs.push([x, y, z]);
                }
            }
        }
    }
    let mut picked: Vec<usize> = dirs
        .iter()
        .map(|d| {
            (0..points.len())
                .max_by(|&i, &j| {
                    let f = |p: &[f64; 3]| p[0] * d[0] + p[1] * d[1] + p[2] * d[2];
                    f(&points[i]).total_cmp(&f(&points[j])).then(j.cmp(&i))
                })
                .unwrap_or(0)
        })
        .collect();
    picked.sort_unstable();
    picked.dedup();
    picked.into_iter().map(|k| points[k]).collect()
}

/// The vertices of a binary STL (an 80-byte header, a triangle count,
/// then 50 bytes per triangle: normal, three vertices, attribute), when
/// its size is that of its count.
fn binary_stl(bytes: &[u8]) -> Option<Vec<[f32; 3]>> {
    let count = u32::from_le_bytes(bytes.get(80..84)?.try_into().ok()?) as usize;
    if bytes.len() != 84 + 50 * count {
        return None;
    }
    let float =
        |at: usize| f32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    Some(
        (0..count)
            .flat_map(|t| (0..3).map(move |k| 84 + 50 * t + 12 + 12 * k))
            .map(|at| [float(at), float(at + 4), float(at + 8)])
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere sampled at 20,000 points: its hull from the support points
    /// has at most 256 + 26 vertices, and every sample lies within 1 % of
    /// the radius of it (the inner approximation's error: 1.4 % measured).
    #[test]
    fn a_curved_mesh_keeps_its_hull_within_one_and_a_half_percent() {
        let n = 20_000;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let pts: Vec<[f64; 3]> = (0..n)
            .map(|k| {
                let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).sqrt();
                // Not the directions' own lattice: turned by a third.
                let a = golden * k as f64 + 1.0 / 3.0;
                [r * a.cos(), r * a.sin(), z]
            })
            .collect();
        let few = supports(&pts);
        assert!(few.len() <= DIRECTIONS + 26, "{}", few.len());
        let hull = convex_hull(&few).expect("a hull");
        let mut worst: f64 = 0.0;
        for p in &pts {
            for f in &hull.faces {
                let [a, b, c] = [f[0], f[1], f[2]].map(|k| hull.vertices[k]);
                let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                let n = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                let d = (n[0] * (p[0] - a[0]) + n[1] * (p[1] - a[1]) + n[2] * (p[2] - a[2])) / l;
                worst = worst.max(d);
            }
        }
        assert!(worst < 0.015, "{worst}");
    }

    /// A binary STL whose header begins with "solid" (as some exporters
    /// write it) is read by its size.
    #[test]
    fn a_binary_stl_that_says_solid_is_read() {
        let mut b = b"solid exported by a CAD tool".to_vec();
        b.resize(80, b' ');
        let tris: [[[f32; 3]; 3]; 4] = [
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
            [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]],
        ];
        b.extend(4u32.to_le_bytes());
        for t in tris {
            b.extend([0u8; 12]);
            for v in t {
                for x in v {
                    b.extend(x.to_le_bytes());
                }
            }
            b.extend([0u8; 2]);
        }
        let dir = std::env::temp_dir().join(format!("cosim-stl-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("tetra.stl");
        std::fs::write(&path, &b).unwrap();
        let hull = Meshes::default().hull(&path, [2.0, 1.0, 1.0]);
        let _ = std::fs::remove_dir_all(&dir);
        let hull = hull.expect("read by its size");
        assert_eq!(hull.len(), 4);
        assert!(hull.contains(&[2.0, 0.0, 0.0]), "{hull:?}");
    }
}
