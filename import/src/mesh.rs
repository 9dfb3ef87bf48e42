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

fn read_hull(path: &Path, scale: [f64; 3]) -> Result<Vec<[f64; 3]>, String> {
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
    let hull = convex_hull(&points).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(hull.vertices)
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
