//! Helpers shared by the binary's tests.

use std::path::{Path, PathBuf};

/// A folder of its own for one test, removed when dropped (also on panic).
pub struct TempDir(PathBuf);

impl TempDir {
    pub fn new(name: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("cosim-test-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        TempDir(dir)
    }

    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// An MCAP recording read with the format's reference reader (the Python
/// `mcap` package, through `read_mcap.py`): per topic its schema,
/// encodings and message count, the `/scene` entities at `log_time` (ns)
/// and the `/forces/normal/CONTACT` message then.
// Not every test binary that shares this module reads recordings.
#[allow(dead_code)]
pub fn read_mcap(path: &Path, log_time: u64, contact: &str) -> serde_json::Value {
    python_json(
        "read_mcap.py",
        &[
            path.as_os_str(),
            log_time.to_string().as_ref(),
            contact.as_ref(),
        ],
    )
}

/// What `server/tests/SCRIPT ARGS...` prints, as JSON.
// Not every test binary that shares this module runs a script.
#[allow(dead_code)]
pub fn python_json(script: &str, args: &[&std::ffi::OsStr]) -> serde_json::Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join(script);
    let read = std::process::Command::new("python3")
        .arg(&script)
        .args(args)
        .output()
        .expect("python3");
    assert!(
        read.status.success(),
        "{}: {}",
        script.display(),
        String::from_utf8_lossy(&read.stderr)
    );
    serde_json::from_slice(&read.stdout).expect("the script prints JSON")
}

/// example-robot-data's robots folder (scripts/robot-data.sh downloads the
/// package once into target/robot-data).
// Not every test binary that shares this module runs robots.
#[allow(dead_code)]
pub fn robot_data() -> std::path::PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let fetched = std::process::Command::new("bash")
        .arg(root.join("scripts/robot-data.sh"))
        .output()
        .expect("bash scripts/robot-data.sh");
    assert!(
        fetched.status.success(),
        "{}",
        String::from_utf8_lossy(&fetched.stderr)
    );
    std::path::PathBuf::from(String::from_utf8_lossy(&fetched.stdout).trim())
}
