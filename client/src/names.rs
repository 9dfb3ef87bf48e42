//! `Names`: the scene's bodies and joints by name, for a controller that
//! addresses them so (issue 45, point 6; the Python client's `Names`):
//! `names.joint("panda/panda_joint4")?` is the index a torque or motor
//! target takes. Indices follow the scene's order, as the frames do.

use crate::*;

/// A scene's body and joint names, in its order.
#[derive(Debug, Clone, PartialEq)]
pub struct Names {
    bodies: Vec<String>,
    joints: Vec<String>,
}

impl Names {
    /// The names of `scene`.
    pub fn of_scene(scene: &cosim_shared::Scene) -> Names {
        Names {
            bodies: scene.bodies.iter().map(|b| b.name.clone()).collect(),
            joints: scene.joints.iter().map(|j| j.name.clone()).collect(),
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
}
