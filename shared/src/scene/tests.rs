use super::*;

const MINIMAL: &str = r#"
[sim]
dt = 0.001
duration = 1.0

[[body]]
name = "ball"
radius = 0.1
mass = 1.0
position = [0.0, 0.0, 0.5]
"#;

#[test]
fn minimal_scene_loads_with_defaults() {
    let s = Scene::parse(MINIMAL, "t.toml").expect("valid");
    assert_eq!(s.sim.friction_directions, 8);
    assert_eq!(s.sim.gravity, [0.0, 0.0, -9.81]);
    assert_eq!(s.bodies[0].orientation, [1.0, 0.0, 0.0, 0.0]);
    assert_eq!(s.step_count(), 1000);
    // Written out and read back, it is the same scene.
    assert_eq!(Scene::parse(&s.to_toml(), "again.toml"), Ok(s));
}

#[test]
fn pgs_stopping_rule_is_read_and_checked() {
    let with =
        |table: &str| MINIMAL.replace("\n[[body]]", &format!("\n[sim.pgs]\n{table}\n\n[[body]]"));
    let s = Scene::parse(&with("stop = \"residual\"\ntolerance = 0.01"), "t.toml").expect("valid");
    let pgs = s.sim.pgs.expect("read");
    assert_eq!((pgs.stop, pgs.tolerance), (PgsStop::Residual, 0.01));
    assert_eq!(pgs.max_iterations, 5000);
    assert_eq!(pgs.relative, crate::DEFAULT_PGS_RELATIVE);
    assert_eq!(Scene::parse(&s.to_toml(), "again.toml"), Ok(s));
    let s = Scene::parse(&with("relative = 0.0"), "t.toml").expect("valid");
    assert_eq!(s.sim.pgs.map(|p| p.relative), Some(0.0));
    for bad in ["relative = 1.0", "relative = -0.1"] {
        let e = Scene::parse(&with(bad), "t.toml").unwrap_err();
        assert_eq!(e.field, "sim.pgs.relative", "{e}");
    }
    let e = Scene::parse(&with("tolerance = -1.0"), "t.toml").unwrap_err();
    assert_eq!(e.field, "sim.pgs.tolerance", "{e}");
    let e = Scene::parse(&with("max_iterations = 0"), "t.toml").unwrap_err();
    assert_eq!(e.field, "sim.pgs.max_iterations", "{e}");
    let e = Scene::parse(&with("stop = \"sometimes\""), "t.toml").unwrap_err();
    assert!(e.to_string().contains("sometimes"), "{e}");
}

#[test]
fn circular_cone_needs_pgs() {
    let text = MINIMAL.replace(
        "duration = 1.0",
        "duration = 1.0\nfriction_cone = \"circular\"",
    );
    let e = Scene::parse(&text, "t.toml").unwrap_err();
    assert_eq!(e.field, "sim.friction_cone", "{e}");
    let ok = text.replace("friction_cone", "solver = \"pgs\"\nfriction_cone");
    assert!(Scene::parse(&ok, "t.toml").is_ok());
}

#[test]
fn syntax_error_has_line_and_field() {
    let text = MINIMAL.replace("mass = 1.0", "mass = 1.0.0");
    let e = Scene::parse(&text, "t.toml").unwrap_err();
    assert_eq!(e.location.map(|l| l.0), Some(9), "{e}");
    assert_eq!(e.field, "body[0].mass", "{e}");
}

#[test]
fn unknown_field_is_named() {
    let text = MINIMAL.replace("mass = 1.0", "mass = 1.0\nmas = 2.0");
    let e = Scene::parse(&text, "t.toml").unwrap_err();
    assert!(e.to_string().contains("mas"), "{e}");
    assert_eq!(e.location.map(|l| l.0), Some(10), "{e}");
    assert_eq!(e.field, "body[0].mas", "{e}");
}

/// The smallest principal moment: diag(1, 2, 3) turned 45 degrees about z
/// has 1; iCub's `r_ankle_1` inertia (1e-20 under 0.75 kg), which makes
/// the solver hold no joint, is refused by name.
#[test]
fn an_inertia_with_a_vanishing_moment_is_refused() {
    let least = super::validate::smallest_moment([1.5, 1.5, 3.0, -0.5, 0.0, 0.0]);
    assert!((least - 1.0).abs() < 1e-14, "{least}");
    let least = super::validate::smallest_moment([2.0, 3.0, 1.0, 0.0, 0.0, 0.0]);
    assert_eq!(least, 1.0);
    let icub =
        "inertia = [2.71051e-20, 5.42101e-20, 1.35525e-20, -1.69407e-21, 1.35525e-20, 3.38813e-21]";
    let text = MINIMAL.replace("mass = 1.0", &format!("mass = 0.746\n{icub}"));
    let e = Scene::parse(&text, "t.toml")
        .expect_err("refused")
        .to_string();
    assert!(
        e.contains("body \"ball\".inertia") && e.contains("smallest principal moment"),
        "{e}"
    );
    let fine = MINIMAL.replace(
        "mass = 1.0",
        "mass = 0.001\ninertia = [1e-8, 1e-8, 1e-8, 0.0, 0.0, 0.0]",
    );
    Scene::parse(&fine, "t.toml").expect("a 1 g part's inertia");
}

/// A body's looks are checked and named like its shapes: a mesh needs its
/// file, a size its count of positive numbers, a colour 0..1; a good one
/// reads back as written.
#[test]
fn a_visuals_problems_are_named() {
    let with = |v: &str| format!("{MINIMAL}[[body.visual]]\n{v}\n");
    let cases = [
        ("type = \"mesh\"", "body \"ball\".visual[0].mesh"),
        (
            "type = \"box\"\nsize = [0.1, 0.2]",
            "body \"ball\".visual[0].size",
        ),
        (
            "type = \"sphere\"\nsize = [-1.0]",
            "body \"ball\".visual[0].size",
        ),
        (
            "type = \"sphere\"\nsize = [0.1]\ncolor = [2.0, 0.0, 0.0, 1.0]",
            "body \"ball\".visual[0].color",
        ),
        (
            "type = \"sphere\"\nsize = [0.1]\norientation = [2.0, 0.0, 0.0, 0.0]",
            "body \"ball\".visual[0].orientation",
        ),
    ];
    for (v, field) in cases {
        let e = Scene::parse(&with(v), "t.toml").unwrap_err();
        assert_eq!(e.field, field, "{v}: {e}");
    }
    let ok = Scene::parse(
        &with("type = \"mesh\"\nmesh = \"a.stl\"\nscale = [0.001, 0.001, 0.001]"),
        "t.toml",
    )
    .expect("a mesh visual");
    let v = &ok.bodies[0].visual[0];
    assert_eq!(v.kind, super::VisualKind::Mesh);
    assert_eq!(v.mesh.as_deref(), Some("a.stl"));
    assert_eq!(v.scale, [0.001; 3]);
}
