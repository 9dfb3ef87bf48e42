//! Where a mesh named in a robot file is: `package://PKG/path` as ROS and
//! PyBullet resolve it (the folders of `ROS_PACKAGE_PATH`, then the
//! robot file's own folder and those above it, for a folder named `PKG`
//! or holding one), `file://` and absolute paths as they are, relative
//! paths from the robot file's folder.

use std::path::{Path, PathBuf};

/// The file `uri` names, or why it was not found (what was tried).
pub fn resolve(uri: &str, dir: Option<&Path>) -> Result<PathBuf, String> {
    let found = |p: PathBuf| -> Result<PathBuf, String> {
        if p.is_file() {
            Ok(p)
        } else {
            Err(format!("no file {}", p.display()))
        }
    };
    if let Some(rest) = uri.strip_prefix("package://") {
        let Some((package, path)) = rest.split_once('/') else {
            return Err(format!("{uri:?} names no file inside its package"));
        };
        let mut roots: Vec<PathBuf> = std::env::var_os("ROS_PACKAGE_PATH")
            .map(|v| std::env::split_paths(&v).collect())
            .unwrap_or_default();
        if let Some(d) = dir {
            roots.extend(d.ancestors().map(Path::to_path_buf));
        }
        for root in &roots {
            // The folder is the package, or holds it.
            let candidates = [
                (root.file_name().is_some_and(|n| n == package)).then(|| root.join(path)),
                Some(root.join(package).join(path)),
            ];
            if let Some(p) = candidates.into_iter().flatten().find(|p| p.is_file()) {
                return Ok(p);
            }
        }
        return Err(format!(
            "package {package:?} not found in ROS_PACKAGE_PATH nor in the robot file's folder or above"
        ));
    }
    let path = uri.strip_prefix("file://").unwrap_or(uri);
    let p = Path::new(path);
    if p.is_absolute() {
        return found(p.to_path_buf());
    }
    match dir {
        Some(d) => found(d.join(p)),
        None => Err(format!(
            "{uri:?} is relative and the robot file's folder is unknown"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A package found as the robot file's ancestor and as a folder beside
    /// one; a relative path from the file's folder; what was not found.
    #[test]
    fn package_and_relative_paths_resolve_as_ros_does() {
        let root = std::env::temp_dir().join(format!("cosim-package-{}", std::process::id()));
        let urdf = root.join("robots/my_robot/urdf");
        let meshes = root.join("robots/my_robot/meshes");
        let other = root.join("robots/other_pkg/meshes");
        for d in [&urdf, &meshes, &other] {
            std::fs::create_dir_all(d).unwrap();
        }
        std::fs::write(meshes.join("a.stl"), "").unwrap();
        std::fs::write(other.join("b.stl"), "").unwrap();
        let dir = Some(urdf.as_path());
        let ok = |uri: &str| resolve(uri, dir);
        assert_eq!(
            ok("package://my_robot/meshes/a.stl"),
            Ok(meshes.join("a.stl"))
        );
        assert_eq!(
            ok("package://other_pkg/meshes/b.stl"),
            Ok(other.join("b.stl"))
        );
        assert_eq!(ok("../meshes/a.stl"), Ok(urdf.join("../meshes/a.stl")));
        let abs = meshes.join("a.stl");
        assert_eq!(ok(&format!("file://{}", abs.display())), Ok(abs.clone()));
        let e = ok("package://nowhere/a.stl").unwrap_err();
        assert!(e.contains("package \"nowhere\" not found"), "{e}");
        let e = ok("meshes/missing.stl").unwrap_err();
        assert!(e.contains("no file"), "{e}");
        let _ = std::fs::remove_dir_all(&root);
    }
}
