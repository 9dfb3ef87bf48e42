//! `[[body.visual]]`: what a body looks like, apart from what it collides
//! with (a robot's visual meshes, URDF's `<visual>`, MJCF's geoms). Drawn
//! by the recordings and the live view; the physics never reads it.

use serde::{Deserialize, Serialize};

/// One look of a body, at `position` and `orientation` in the body's frame
/// (whose origin is the centre of mass): a mesh file or a primitive, as
/// MJCF's geom gives it (`type` and `size`).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VisualEntry {
    #[serde(rename = "type")]
    pub kind: VisualKind,
    /// The mesh file (STL, OBJ, COLLADA, glTF), absolute or relative to
    /// where the program runs; `type = "mesh"` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<String>,
    /// The mesh's scale per axis.
    #[serde(default = "unit_scale")]
    pub scale: [f64; 3],
    /// Per type: `box` half extents (3), `sphere` radius (1), `cylinder`
    /// and `capsule` radius and half length along z (2), `ellipsoid` radii
    /// (3); none for a mesh.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub size: Vec<f64>,
    #[serde(default)]
    pub position: [f64; 3],
    /// Unit quaternion, scalar first.
    #[serde(default = "super::body::identity_quaternion")]
    pub orientation: [f64; 4],
    /// `[r, g, b, a]` in 0..1; absent: the mesh's own colours, or the
    /// body's colour in the palette.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub color: Option<[f64; 4]>,
}

#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum VisualKind {
    Mesh,
    Box,
    Sphere,
    Cylinder,
    Capsule,
    Ellipsoid,
}

fn unit_scale() -> [f64; 3] {
    [1.0; 3]
}

impl VisualEntry {
    /// What is wrong with it, as (field, message): a mesh without its file,
    /// a size of the wrong length or not positive, a colour out of 0..1.
    pub fn problem(&self) -> Option<(&'static str, String)> {
        let want = match self.kind {
            VisualKind::Mesh => 0,
            VisualKind::Sphere => 1,
            VisualKind::Cylinder | VisualKind::Capsule => 2,
            VisualKind::Box | VisualKind::Ellipsoid => 3,
        };
        if self.kind == VisualKind::Mesh {
            if self.mesh.as_deref().is_none_or(|m| m.trim().is_empty()) {
                return Some((
                    "mesh",
                    "is missing: a visual of type \"mesh\" names its file".into(),
                ));
            }
            if !self.scale.iter().all(|s| s.is_finite() && *s != 0.0) {
                return Some((
                    "scale",
                    format!("= {:?}: each factor must be finite and not 0", self.scale),
                ));
            }
        } else if self.mesh.is_some() {
            return Some((
                "mesh",
                format!("with type {:?}: only a mesh has a file", self.kind),
            ));
        }
        if self.size.len() != want || !self.size.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Some((
                "size",
                format!(
                    "= {:?}: a {:?} visual takes {want} positive numbers{}",
                    self.size,
                    self.kind,
                    match self.kind {
                        VisualKind::Mesh => " (its size is the file's, times scale)",
                        VisualKind::Sphere => " (the radius)",
                        VisualKind::Cylinder | VisualKind::Capsule =>
                            " (radius and half length along z)",
                        VisualKind::Box => " (half extents)",
                        VisualKind::Ellipsoid => " (radii)",
                    }
                ),
            ));
        }
        if let Some(c) = self.color {
            if !c.iter().all(|x| (0.0..=1.0).contains(x)) {
                return Some(("color", format!("= {c:?}: [r, g, b, a], each in 0..1")));
            }
        }
        None
    }
}
