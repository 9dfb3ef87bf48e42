//! Scenes built into the tools: the reference scene, which `run` steps
//! without a scene file and the benchmarks and tests share.

use crate::{Scene, SceneError};

/// The reference scene, run when no scene is given.
pub const REFERENCE: &str = include_str!("../../examples/scenes/reference.toml");

/// Parses the built-in reference scene.
pub fn reference() -> Result<Scene, SceneError> {
    let mut s = Scene::parse(REFERENCE, "<built-in reference.toml>")?;
    if s.sim.name.is_none() {
        s.sim.name = Some("reference".into());
    }
    Ok(s)
}
