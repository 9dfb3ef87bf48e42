//! `Names`: the scene's bodies and joints by name, for a controller that
//! addresses them so (issue 45, point 6; the Python client's `Names`):
//! `names.joint("panda/panda_joint4")?` is the index a torque or motor
//! target takes. Indices follow the scene's order, as the frames do.

use crate::*;

/// A scene's body and joint names, in its order, and its named frames.
#[derive(Debug, Clone, PartialEq)]
pub struct Names {
    bodies: Vec<String>,
    joints: Vec<String>,
    frames: Vec<(String, Frame)>,
}

/// A named frame fixed in a body (`[[body.frame]]`: a robot's link merged
/// into its parent by a fixed joint), or a body's own frame: its body's
/// index and its pose in that body's frame (the centre of mass's; `state`
/// gives the body's pose in the world).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub body: u32,
    pub position: [f64; 3],
    /// Unit quaternion, scalar first.
    pub orientation: [f64; 4],
}

impl Names {
    /// The names of `scene`.
    pub fn of_scene(scene: &cosim_shared::Scene) -> Names {
        Names {
            bodies: scene.bodies.iter().map(|b| b.name.clone()).collect(),
            joints: scene.joints.iter().map(|j| j.name.clone()).collect(),
            frames: scene
                .frames()
                .map(|(k, f)| {
                    let frame = Frame {
                        body: k as u32,
                        position: f.position,
                        orientation: f.orientation,
                    };
                    (f.name.clone(), frame)
                })
                .collect(),
        }
    }

    /// The names of the scene `conn`'s server runs.
    pub fn fetch(conn: &Connection) -> Result<Names, ClientError> {
        let text = conn.scene_toml()?;
        let scene = cosim_shared::Scene::parse(&text, "<server scene>")
            .map_err(|e| ClientError::BadScene(e.to_string()))?;
        Ok(Names::of_scene(&scene))
    }

    pub fn bodies(&self) -> &[String] {
        &self.bodies
    }

    pub fn joints(&self) -> &[String] {
        &self.joints
    }

    /// The index of body `name`.
    pub fn body(&self, name: &str) -> Result<u32, ClientError> {
        find(&self.bodies, name, "body")
    }

    /// Frame `name`: a body's own (at its centre of mass) or a named
    /// frame fixed in one.
    pub fn frame(&self, name: &str) -> Result<Frame, ClientError> {
        if let Ok(body) = self.body(name) {
            return Ok(Frame {
                body,
                position: [0.0; 3],
                orientation: [1.0, 0.0, 0.0, 0.0],
            });
        }
        match self.frames.iter().find(|(n, _)| n == name) {
            Some((_, f)) => Ok(*f),
            None => Err(ClientError::UnknownName {
                kind: "frame",
                name: name.into(),
                known: self
                    .bodies
                    .iter()
                    .chain(self.frames.iter().map(|(n, _)| n))
                    .cloned()
                    .collect(),
            }),
        }
    }

    /// The index of joint `name`.
    pub fn joint(&self, name: &str) -> Result<u32, ClientError> {
        find(&self.joints, name, "joint")
    }
}

fn find(names: &[String], name: &str, kind: &'static str) -> Result<u32, ClientError> {
    names
        .iter()
        .position(|n| n == name)
        .map(|i| i as u32)
        .ok_or_else(|| ClientError::UnknownName {
            kind,
            name: name.into(),
            known: names.to_vec(),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names read back as their indices; an unknown one is refused with
    /// the known ones listed.
    #[test]
    fn names_are_indices_and_an_unknown_one_is_named() {
        let scene = cosim_shared::scenes::reference().expect("the reference scene");
        let names = Names::of_scene(&scene);
        for (k, b) in scene.bodies.iter().enumerate() {
            assert_eq!(names.body(&b.name).expect("known"), k as u32);
        }
        for (k, j) in scene.joints.iter().enumerate() {
            assert_eq!(names.joint(&j.name).expect("known"), k as u32);
        }
        let e = names.joint("elbow_typo").expect_err("unknown").to_string();
        assert!(e.starts_with("no joint named \"elbow_typo\""), "{e}");
        assert!(e.contains(&format!("{:?}", scene.joints[0].name)), "{e}");
    }

    /// A named frame reads back as its body and pose; a body's name as
    /// the body at its centre; an unknown one lists bodies and frames.
    #[test]
    fn a_frame_is_its_body_and_its_pose_there() {
        let mut scene = cosim_shared::scenes::reference().expect("the reference scene");
        scene.bodies[1].frame.push(cosim_shared::FrameEntry {
            name: "tip".into(),
            position: [0.0, 0.0, 0.1],
            orientation: [0.0, 1.0, 0.0, 0.0],
        });
        scene.validate("reference").expect("a valid frame");
        let names = Names::of_scene(&scene);
        let tip = names.frame("tip").expect("known");
        assert_eq!(tip.body, 1);
        assert_eq!(tip.position, [0.0, 0.0, 0.1]);
        assert_eq!(tip.orientation, [0.0, 1.0, 0.0, 0.0]);
        let own = names.frame(&scene.bodies[0].name).expect("a body");
        assert_eq!((own.body, own.position), (0, [0.0; 3]));
        let e = names.frame("tap").expect_err("unknown").to_string();
        assert!(e.starts_with("no frame named \"tap\""), "{e}");
        assert!(e.contains("\"tip\""), "{e}");
        // A frame's name is one of the scene's: a body's is refused.
        scene.bodies[1].frame[0].name = scene.bodies[0].name.clone();
        let e = scene
            .validate("reference")
            .expect_err("a clash")
            .to_string();
        assert!(
            e.contains("frame[0].name") && e.contains("duplicate name"),
            "{e}"
        );
    }
}
