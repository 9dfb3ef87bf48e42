//! `cosim-import`: robot descriptions of other formats written as our
//! scene, checked as a scene file is. Pure: no IPC, no plotting, no
//! engine; files are read and nothing is written. URDF and MJCF, and scene
//! files that place robots.

pub mod mesh;
pub mod mjcf;
pub mod options;
pub mod problems;
pub mod scene;
pub mod urdf;

pub use options::{Imported, Options};

/// The largest effort of a drive the file leaves unbounded (a spring, a
/// damper, an actuator without `forcerange`): bounds no real robot meets.
pub const UNBOUNDED: f64 = 1e9;

use cosim_shared::SceneError;
use std::path::Path;

/// An importer of a format's text: (text, file, name, folder, options).
type Import = fn(&str, &str, &str, Option<&Path>, Options) -> Result<Imported, SceneError>;

/// Reads the file at `path` and imports its text with `import`, the scene
/// named after the file, paths in it relative to its folder.
fn read_with(path: &Path, options: Options, import: Import) -> Result<Imported, SceneError> {
    let file = path.display().to_string();
    let text = cosim_shared::scene::read_file(path)?;
    let name = path
        .file_stem()
        .map_or("robot".into(), |s| s.to_string_lossy().into_owned());
    import(&text, &file, &name, path.parent(), options)
}

/// The robot formats read, by file extension.
pub fn is_robot(path: &Path) -> bool {
    format(path).is_some()
}

#[derive(Clone, Copy)]
enum Format {
    Urdf,
    Mjcf,
}

fn format(path: &Path) -> Option<Format> {
    let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
    match ext.as_str() {
        "urdf" => Some(Format::Urdf),
        "xml" | "mjcf" => Some(Format::Mjcf),
        _ => None,
    }
}

/// Reads a robot description (`.urdf`; `.xml` or `.mjcf`: MJCF) as a
/// scene of its own.
pub fn load(path: &Path, options: Options) -> Result<Imported, SceneError> {
    match format(path) {
        Some(Format::Urdf) => urdf::load(path, options),
        Some(Format::Mjcf) => mjcf::load(path, options),
        None => Err(SceneError {
            file: path.display().to_string(),
            location: None,
            field: String::new(),
            message: "not a robot description: .urdf (URDF) or .xml (MJCF) expected".into(),
        }),
    }
}
