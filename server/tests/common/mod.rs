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
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/read_mcap.py");
    let read = std::process::Command::new("python3")
        .arg(script)
        .arg(path)
        .arg(log_time.to_string())
        .arg(contact)
        .output()
        .expect("python3");
    assert!(
        read.status.success(),
        "{}",
        String::from_utf8_lossy(&read.stderr)
    );
    serde_json::from_slice(&read.stdout).expect("read_mcap.py prints JSON")
}
