//! The scene description: what a `.toml` scene file holds, and its validation.
//!
//! Parsing is strict (unknown fields are refused) so that a typo never turns
//! into a silently ignored setting. Every error names the file, the field (as a
//! path such as `body[1].mass` or `body "ball".mass`), the offending value and,
//! for syntax errors, the line and column that TOML reports.

mod body;
pub mod hull;
mod joint;
mod robot;
mod sim;
mod validate;
mod visual;

pub use body::*;
pub use joint::*;
pub use robot::*;
pub use sim::*;
pub use validate::MIN_MOMENT;
pub use visual::*;

use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;

/// A whole scene file.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    pub sim: SimDesc,
    #[serde(default, rename = "body")]
    pub bodies: Vec<BodyDesc>,
    #[serde(default, rename = "plane")]
    pub planes: Vec<PlaneDesc>,
    #[serde(default, rename = "joint")]
    pub joints: Vec<JointDesc>,
    /// `[[robot]]`: robot files to place; the importer writes their bodies
    /// and joints into the scene and empties this list (`Scene::parse`
    /// refuses a scene that still has one).
    #[serde(default, rename = "robot", skip_serializing_if = "Vec::is_empty")]
    pub robots: Vec<RobotDesc>,
    /// The animation's camera; framed automatically when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<CameraDesc>,
    /// Contact and joint compliance; rigid (the default) where absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compliance: Option<ComplianceDesc>,
}

/// The name a joint uses for the fixed world.
pub const WORLD: &str = "world";

/// A scene that cannot be used, with everything needed to fix it.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    /// The file (or `<built-in>` for embedded scenes).
    pub file: String,
    /// Line and column (1-based), where TOML reports them.
    pub location: Option<(usize, usize)>,
    /// The field at fault, e.g. `body "ball".mass`; empty when TOML gives none.
    pub field: String,
    /// What is wrong, with the offending value.
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some((line, col)) = self.location {
            write!(f, ":{line}:{col}")?;
        }
        if self.field.is_empty() {
            write!(f, ": {}", self.message)
        } else if self.message.starts_with("= ") {
            // "body \"ball\".mass = -1: must be ..."
            write!(f, ": {} {}", self.field, self.message)
        } else {
            write!(f, ": {}: {}", self.field, self.message)
        }
    }
}

impl std::error::Error for SceneError {}

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let file = path.display().to_string();
        let text = read_file(path)?;
        let mut scene = Scene::parse(&text, &file)?;
        if scene.sim.name.is_none() {
            scene.sim.name = path.file_stem().map(|s| s.to_string_lossy().into_owned());
        }
        Ok(scene)
    }

    /// The scene as TOML text (with every default written out).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// Parses and validates scene text; `file` only labels the errors.
    pub fn parse(text: &str, file: &str) -> Result<Scene, SceneError> {
        let scene = Scene::read(text, file)?;
        scene.validate(file)?;
        Ok(scene)
    }

    /// Parses scene text without the checks, for a reader that completes
    /// the scene first (`cosim_import::scene` places its robots).
    pub fn read(text: &str, file: &str) -> Result<Scene, SceneError> {
        toml::from_str(text).map_err(|e| toml_error(&e, text, file))
    }

    /// The scene's name, used for the output folder.
    pub fn name(&self) -> &str {
        self.sim.name.as_deref().unwrap_or("scene")
    }

    /// Number of steps `run` takes: `steps`, or `duration / dt` rounded.
    pub fn step_count(&self) -> u64 {
        match (self.sim.steps, self.sim.duration) {
            (Some(n), _) => n,
            (None, Some(t)) => (t / self.sim.dt).round() as u64,
            (None, None) => 0,
        }
    }

    /// Every named frame (`[[body.frame]]`) with its body's index.
    pub fn frames(&self) -> impl Iterator<Item = (usize, &FrameEntry)> {
        self.bodies
            .iter()
            .enumerate()
            .flat_map(|(k, b)| b.frame.iter().map(move |f| (k, f)))
    }

    /// Contact ids per pair of bodies (the engine's `Model::features`):
    /// per pair of their shapes, 1 in a scene of spheres, which touch at
    /// one point, else [`MAX_FEATURES`]; times the square of the most
    /// shapes a body has. A contact's id is `pair * features + feature`.
    pub fn contact_features(&self) -> usize {
        let per_pair = if self
            .bodies
            .iter()
            .flat_map(|b| b.shapes())
            .all(|p| matches!(p.shape, ShapeDesc::Sphere { .. }))
        {
            1
        } else {
            MAX_FEATURES
        };
        let most = self.most_shapes();
        per_pair * most * most
    }

    /// The most shapes a body has, at least 1 (the engine's
    /// `Model::shape_slots`).
    pub fn most_shapes(&self) -> usize {
        self.bodies
            .iter()
            .map(|b| b.shapes().len())
            .max()
            .unwrap_or(1)
            .max(1)
    }
}

/// A scene's (or robot's) file as text, or the error that names it.
pub fn read_file(path: &Path) -> Result<String, SceneError> {
    std::fs::read_to_string(path).map_err(|e| SceneError {
        file: path.display().to_string(),
        location: None,
        field: String::new(),
        message: format!("cannot read the file: {e}"),
    })
}

/// Turns a TOML error into a `SceneError` with the line and column of its span
/// and, where the message names it, the field at fault.
fn toml_error(e: &toml::de::Error, text: &str, file: &str) -> SceneError {
    let location = e.span().map(|span| line_col(text, span.start));
    let message = e.message().trim().to_string();
    // The field: the key on the offending line, when the span points into one.
    let field = e
        .span()
        .and_then(|span| key_at(text, span.start))
        .unwrap_or_default();
    SceneError {
        file: file.to_string(),
        location,
        field,
        message,
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// The dotted path `table.key` of the key on the line holding `offset`,
/// e.g. `body.radius`, or `None` when that line holds no `key =`.
fn key_at(text: &str, offset: usize) -> Option<String> {
    let offset = offset.min(text.len());
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
    let line = &text[line_start..line_end];
    let key = line.split('=').next()?.trim();
    if key.is_empty() || key.starts_with('[') || !line.contains('=') {
        return None;
    }
    // The nearest table header above the line; for an array of tables
    // (`[[body]]`) also its index, counting the same headers above it.
    let above: Vec<&str> = text[..line_start].lines().map(str::trim).collect();
    let header = above.iter().rev().find(|l| l.starts_with('['));
    Some(match header {
        Some(h) if h.starts_with("[[") => {
            let name = h.trim_matches(|c| c == '[' || c == ']').trim();
            let index = above.iter().filter(|l| *l == h).count() - 1;
            format!("{name}[{index}].{key}")
        }
        Some(h) => format!("{}.{key}", h.trim_matches(|c| c == '[' || c == ']').trim()),
        None => key.to_string(),
    })
}

#[cfg(test)]
mod tests;
