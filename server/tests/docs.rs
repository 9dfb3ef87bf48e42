//! The docs' `cosim-server` synopses name subcommands and options the
//! program has (issue 46, point 1); the `cosim` ones are checked by the
//! client's tests with the same reader.

#[path = "common/synopsis.rs"]
mod synopsis;

use std::path::Path;

#[test]
fn every_cosim_server_synopsis_in_the_docs_is_true() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let (problems, checked) =
        synopsis::check(&root, "cosim-server", env!("CARGO_BIN_EXE_cosim-server"));
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    // run, plot, lcp, fc3d, serve, demo, replay, summarize, bench ipc,
    // robust, fuzz, accuracy, stress, skips: a reader that found none
    // would pass anything.
    assert!(checked >= 14, "only {checked} synopses found");
}

#[test]
fn a_synopsis_naming_a_missing_option_is_caught() {
    let dir = std::env::temp_dir().join(format!("cosim-synopsis-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("docs")).expect("dir");
    std::fs::create_dir_all(dir.join("python")).expect("dir");
    std::fs::write(
        dir.join("README.md"),
        "```\ncosim-server run [--plot]\n                 [--no-such-option]\n```\n",
    )
    .expect("write");
    std::fs::write(dir.join("python/README.md"), "").expect("write");
    std::fs::write(
        dir.join("docs/a.md"),
        "```sh\ncosim-server nosuchcommand DIR\n```\n",
    )
    .expect("write");
    let (problems, _) = synopsis::check(&dir, "cosim-server", env!("CARGO_BIN_EXE_cosim-server"));
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(problems.len(), 2, "{problems:?}");
    assert!(
        problems[0].contains("README.md:2") && problems[0].contains("--no-such-option"),
        "{problems:?}"
    );
    assert!(
        problems[1].contains("nosuchcommand --help` failed"),
        "{problems:?}"
    );
}

/// The docs' commands that no other test runs, at their smallest: each
/// exits 0 and prints what the docs say it prints (`bench accuracy` is run
/// by bench_accuracy.rs, `demo` by cosim/examples.rs, `serve`, `replay`
/// and `summarize` by cosim/, `run` and `plot` by cli.rs and plots.rs,
/// `lcp` by corpus_lcp.rs).
#[test]
fn the_docs_benchmarks_and_solvers_run_at_their_smallest() {
    let fc3d = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/fc/siconos/FC3D_Example1.dat");
    let fc3d = fc3d.to_string_lossy();
    let cases: [(&[&str], &str); 7] = [
        (
            &["bench", "robust", "--scenes", "20", "--steps", "5"],
            "failed steps",
        ),
        (
            &["bench", "fuzz", "--scenes", "50", "--inputs", "200"],
            "0 defects",
        ),
        (
            &["bench", "pile", "--n", "50", "--steps", "20"],
            "| 50 | 20 | 0 |",
        ),
        (
            &["bench", "stress", "--solver", "auto", "--long-steps", "200"],
            "reference scene, 200 steps",
        ),
        (&["bench", "skips", "--steps", "20"], "PGS warm start"),
        (&["bench", "ipc", "--quick", "--steps", "200"], "| spin |"),
        (&["fc3d", &fc3d], "residual"),
    ];
    let mut problems = Vec::new();
    for (args, expect) in cases {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_cosim-server"))
            .args(args)
            .output()
            .expect("run cosim-server");
        let text = String::from_utf8_lossy(&out.stdout);
        if !out.status.success() || !text.contains(expect) {
            problems.push(format!(
                "cosim-server {}: {}, no {expect:?} in\n{text}{}",
                args.join(" "),
                out.status,
                String::from_utf8_lossy(&out.stderr)
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The scene file of docs/scenes.md, as printed, is a scene: every key it
/// shows is one the reader takes, every value a valid one.
#[test]
fn the_scene_file_in_the_docs_reads() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let text = std::fs::read_to_string(root.join("docs/scenes.md")).expect("docs/scenes.md");
    let start = text.find("```toml\n").expect("a toml block") + "```toml\n".len();
    let block = &text[start..start + text[start..].find("```").expect("its end")];
    let scene =
        cosim_shared::Scene::parse(block, "docs/scenes.md").unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.bodies.iter().any(|b| b.shape.len() == 2), "the table");
    // The `[[robot]]` block, added to it, places the arm as written (its
    // file relative to examples/scenes/).
    let at = text.find("```toml\n[[robot]]").expect("the robot block") + "```toml\n".len();
    let robot = &text[at..at + text[at..].find("```").expect("its end")];
    let with = cosim_shared::Scene::read(&format!("{block}\n{robot}"), "docs/scenes.md")
        .unwrap_or_else(|e| panic!("{e}"));
    let placed =
        cosim_import::scene::place(with, Some(&root.join("examples/scenes")), "docs/scenes.md")
            .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        placed.scene.bodies.iter().any(|b| b.name == "right/upper"),
        "the arm placed"
    );
}
