//! `/visuals`: how the bodies look (`[[body.visual]]`: a robot's visual
//! meshes and primitives), one `foxglove.SceneUpdate` whose entities are
//! locked to the bodies' frames (`/tf` moves them), so it is sent once:
//! at the start of a recording, to each new subscriber of the live view.
//! Mesh files go as they are (`foxglove.ModelPrimitive` with the file's
//! bytes and its media type: Foxglove's 3-D panel reads STL, OBJ, COLLADA
//! and glTF), so their own colours and detail show.

use crate::draw::{self, color, pose, quaternion, time, vec3};
use cosim_shared::{Scene, VisualKind};
use nalgebra::Vector3;
use serde_json::{json, Value};
use std::collections::HashMap;
use std::path::Path;

/// The media type Foxglove knows a mesh file by, from its extension.
pub fn media_type(path: &str) -> Option<&'static str> {
    let ext = Path::new(path).extension()?.to_str()?.to_ascii_lowercase();
    Some(match ext.as_str() {
        "stl" => "model/stl",
        "obj" => "model/obj",
        "dae" => "model/vnd.collada+xml",
        "glb" => "model/gltf-binary",
        "gltf" => "model/gltf+json",
        _ => return None,
    })
}

/// The bodies' looks as one message, and what could not be drawn (a mesh
/// file unreadable or of a kind Foxglove does not read), each named.
#[derive(Debug, Clone)]
pub struct Visuals {
    /// `None` when no body has a visual.
    pub message: Option<Value>,
    pub not_drawn: Vec<String>,
}

fn rgba(c: [f64; 4]) -> Value {
    json!({ "r": c[0], "g": c[1], "b": c[2], "a": c[3] })
}

/// Each body's visuals as an entity in the body's frame.
pub fn visuals(scene: &Scene) -> Visuals {
    let mut files: HashMap<&str, Result<String, String>> = HashMap::new();
    let mut not_drawn = Vec::new();
    let mut entities = Vec::new();
    let stamp = time(0.0);
    for (b, body) in scene.bodies.iter().enumerate() {
        if body.visual.is_empty() {
            continue;
        }
        let (mut models, mut cubes, mut spheres, mut cylinders) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (k, v) in body.visual.iter().enumerate() {
            let q = quaternion(&v.orientation);
            let x = Vector3::from(v.position);
            let pose = |x: &Vector3<f64>| pose(x, &q);
            let color = v.color.map_or_else(|| color(b, 1.0), rgba);
            let s = &v.size;
            match v.kind {
                VisualKind::Mesh => {
                    let Some(file) = v.mesh.as_deref() else {
                        continue;
                    };
                    let Some(media) = media_type(file) else {
                        not_drawn.push(format!(
                            "body {:?} visual {}: {file}: not a kind Foxglove reads (STL, OBJ, COLLADA, glTF)",
                            body.name,
                            k + 1
                        ));
                        continue;
                    };
                    let data = files.entry(file).or_insert_with(|| {
                        std::fs::read(file)
                            .map(|d| data_encoding::BASE64.encode(&d))
                            .map_err(|e| e.to_string())
                    });
                    match data {
                        Ok(data) => {
                            // COLLADA and glTF carry their own materials,
                            // which RViz and Foxglove show; STL and OBJ
                            // take the given colour.
                            let own_colours = matches!(
                                media,
                                "model/vnd.collada+xml" | "model/gltf-binary" | "model/gltf+json"
                            );
                            models.push(json!({
                                "pose": pose(&x), "scale": vec3(&Vector3::from(v.scale)),
                                "color": color, "override_color": !own_colours,
                                "url": "", "media_type": media, "data": data,
                            }));
                        }
                        Err(e) => not_drawn.push(format!(
                            "body {:?} visual {}: cannot read {file}: {e}",
                            body.name,
                            k + 1
                        )),
                    }
                }
                VisualKind::Box => cubes.push(json!({ "pose": pose(&x),
                    "size": vec3(&(Vector3::new(s[0], s[1], s[2]) * 2.0)), "color": color })),
                VisualKind::Sphere => spheres.push(json!({ "pose": pose(&x),
                    "size": vec3(&Vector3::repeat(2.0 * s[0])), "color": color })),
                VisualKind::Ellipsoid => spheres.push(json!({ "pose": pose(&x),
                    "size": vec3(&(Vector3::new(s[0], s[1], s[2]) * 2.0)), "color": color })),
                VisualKind::Cylinder | VisualKind::Capsule => {
                    cylinders.push(json!({ "pose": pose(&x),
                        "size": vec3(&Vector3::new(2.0 * s[0], 2.0 * s[0], 2.0 * s[1])),
                        "bottom_scale": 1.0, "top_scale": 1.0, "color": color }));
                    if v.kind == VisualKind::Capsule {
                        let axis = q * Vector3::new(0.0, 0.0, s[1]);
                        for end in [x - axis, x + axis] {
                            spheres.push(json!({ "pose": pose(&end),
                                "size": vec3(&Vector3::repeat(2.0 * s[0])), "color": color }));
                        }
                    }
                }
            }
        }
        entities.push(draw::locked_entity(
            &stamp,
            &format!("visual/{}", body.name),
            &body.name,
            &[
                ("models", Value::Array(models)),
                ("cubes", Value::Array(cubes)),
                ("spheres", Value::Array(spheres)),
                ("cylinders", Value::Array(cylinders)),
            ],
        ));
    }
    Visuals {
        message: (!entities.is_empty()).then(|| json!({ "deletions": [], "entities": entities })),
        not_drawn,
    }
}

/// What a recording or a new subscriber gets once, locked to the bodies'
/// frames: `/shapes` (the hull shapes) and `/visuals`, where the scene has
/// them; and what could not be drawn.
pub fn sent_once(
    scene: &Scene,
    drawing: &crate::Drawing,
) -> (Vec<(&'static str, Value)>, Vec<String>) {
    let looks = visuals(scene);
    let list = [
        ("/shapes", drawing.hulls_update()),
        ("/visuals", looks.message),
    ]
    .into_iter()
    .filter_map(|(topic, m)| m.map(|m| (topic, m)))
    .collect();
    (list, looks.not_drawn)
}
