//! The `cosim` command without a server: clear errors, exit code 1.

use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_cosim");

#[test]
fn commands_against_a_missing_server_name_it_and_fail() {
    let name = format!("no-such-server-{}", std::process::id());
    for cmd in [
        &["info"][..],
        &["pause"],
        &["step", "3"],
        &["monitor", "--seconds", "1"],
        &["view", "--listen", "127.0.0.1:0", "--seconds", "1"],
    ] {
        let out = Command::new(EXE)
            .args(["--name", &name])
            .args(cmd)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{cmd:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(&format!("no cosim server named '{name}' is running")),
            "{cmd:?}: {err}"
        );
    }
}

#[test]
fn a_bad_torque_file_names_the_line_and_field() {
    let dir = std::env::temp_dir().join(format!("cosim-play-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("torques.csv");
    std::fs::write(&file, "step,joint,tx,ty,tz\n0,0,0,0,0\n5,1,0,abc,0\n").unwrap();
    let out = Command::new(EXE)
        .args(["--name", "unused", "play"])
        .arg(&file)
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("torques.csv:3: torque = \"abc\" is not a number"),
        "{err}"
    );
}

#[test]
fn a_view_rate_that_is_not_positive_is_refused_by_name() {
    for rate in ["0", "-5", "NaN"] {
        let out = Command::new(EXE)
            .args(["view", "--rate", rate])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{rate}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("--rate must be a positive"), "{rate}: {err}");
    }
}

#[path = "../../server/tests/common/synopsis.rs"]
mod synopsis;

/// The docs' `cosim` synopses name subcommands and options it has (issue
/// 46, point 1).
#[test]
fn every_cosim_synopsis_in_the_docs_is_true() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let (problems, checked) = synopsis::check(&root, "cosim", EXE);
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    // --name, then list ... play: fourteen alternatives in docs/cosim.md.
    assert!(checked >= 14, "only {checked} synopses found");
}
