//! Contact and joint compliance (`[compliance]` in the scene file): the
//! spring's static deflection, convergence to the rigid answers as the
//! stiffness grows, and bounded impulses where the rigid chain locks.

use cosim_server::engine::{Engine, ImpulseKind, Model};
use cosim_shared::Scene;
use cosim_tests::*;

fn model(text: &str) -> Model {
    let scene = Scene::parse(text, "<compliance test>").unwrap_or_else(|e| panic!("{e}\n{text}"));
    Model::from_scene(&scene)
}

fn compliance(contact: Option<(f64, f64)>, joint: Option<(f64, f64)>) -> String {
    let mut s = String::new();
    if let Some((k, c)) = contact {
        s += &format!("[compliance.contact]\nstiffness = {k:e}\ndamping = {c:e}\n");
    }
    if let Some((k, c)) = joint {
        s += &format!("[compliance.joint]\nstiffness = {k:e}\ndamping = {c:e}\n");
    }
    s
}

/// A 2 kg sphere resting on a floor of stiffness k sinks to the static
/// deflection `m g / k`: at rest `v' = 0`, so the row reads
/// `ERP psi / h + CFM p = 0` with `p = m g h`, i.e. `psi = -m g / k`
/// exactly (model.rs, `Compliance`); the damper only settles it.
#[test]
fn a_resting_sphere_sinks_to_the_springs_static_deflection() {
    let (m, k) = (2.0f64, 2.0e4f64);
    let c = 2.0 * (k * m).sqrt(); // critical damping
    let text = sim(1e-3, 3000, [0.0, 0.0, -G])
        + &sphere("ball", 0.1, m, [0.0, 0.0, 0.1], [0.0; 3], 0.5, 0.0)
        + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0)
        + &compliance(Some((k, c)), None);
    let mut e = Engine::new(model(&text));
    run(&mut e, 3000, |_, _| {});
    let z = e.state().bodies[0].x.z;
    let deflection = 0.1 - z;
    let expected = m * G / k;
    assert!(
        (deflection - expected).abs() < 1e-3 * expected,
        "deflection {deflection:e} m against m g / k = {expected:e} m"
    );
    assert!(e.state().bodies[0].v.norm() < 1e-6);
}

/// As the stiffness grows (damping ratio fixed), a sliding, bouncing
/// sphere's trajectory converges to the rigid one (beta = 1, the limit of
/// ERP): each tenfold stiffer floor lands closer, the stiffest within
/// 0.1 mm over 1 s.
#[test]
fn stiffer_contact_converges_to_the_rigid_answer() {
    let body = sphere("ball", 0.1, 1.0, [0.0, 0.0, 0.3], [1.0, 0.0, 0.0], 0.3, 0.0)
        + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.3, 0.0);
    let steps = 1000;
    let trajectory = |extra: &str| {
        let mut e = Engine::new(model(&(sim(1e-3, steps, [0.0, 0.0, -G]) + &body + extra)));
        let mut xs = Vec::new();
        run(&mut e, steps, |e, _| xs.push(e.state().bodies[0].x));
        xs
    };
    let rigid = trajectory("");
    let mut last = f64::INFINITY;
    for k in [1e4, 1e5, 1e6, 1e7, 1e8] {
        let c = 2.0 * (k * 1.0f64).sqrt();
        let soft = trajectory(&compliance(Some((k, c)), None));
        let d = rigid
            .iter()
            .zip(&soft)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        eprintln!("k = {k:e}: largest distance to the rigid trajectory {d:e} m");
        assert!(d < last, "k = {k:e}: {d:e} m, not closer than {last:e}");
        last = d;
    }
    assert!(last < 1e-4, "stiffest {last:e} m");
}

/// Stiffer joints converge to the rigid joint too: a pendulum on a soft
/// spherical joint stretches by about `m (g + v^2 / l) / k` at most, and
/// its joint error falls at least fivefold with each tenfold stiffness.
#[test]
fn stiffer_joints_converge_to_the_rigid_joint() {
    let body = sphere("bob", 0.05, 1.0, [0.5, 0.0, 1.0], [0.0; 3], 0.0, 0.0)
        + &joint("pin", "world", "bob", [0.0, 0.0, 1.0]);
    // The rigid joint's own error (its stabilisation lags a step behind).
    let mut e = Engine::new(model(&(sim(1e-3, 2000, [0.0, 0.0, -G]) + &body)));
    let mut rigid = 0.0f64;
    run(&mut e, 2000, |_, r| rigid = rigid.max(r.max_joint_error));
    let mut errors = Vec::new();
    for k in [1e4, 1e5, 1e6] {
        let c = 2.0 * (k * 1.0f64).sqrt();
        let text = sim(1e-3, 2000, [0.0, 0.0, -G]) + &body + &compliance(None, Some((k, c)));
        let mut e = Engine::new(model(&text));
        let mut worst = 0.0f64;
        run(&mut e, 2000, |_, r| worst = worst.max(r.max_joint_error));
        // The bob swings through the bottom at v^2 = 2 g l: the joint's
        // pull is m (g + v^2 / l) = 3 m g.
        let bound = 3.0 * 1.0 * G / k;
        eprintln!("joint k = {k:e}: largest joint error {worst:e} m (bound {bound:e})");
        // 1.5: the dynamic overshoot of a loaded, critically damped spring
        // stays under it. Plus the rigid joint's own error (the position
        // update's drift, which the rigid row removes in one step), which
        // the damped spring removes at the rate ERP = h k / (h k + c).
        let erp = 1e-3 * k / (1e-3 * k + c);
        let limit = 1.5 * bound + rigid / erp;
        assert!(
            worst <= limit,
            "k = {k:e}: {worst:e} m, limit {limit:e} (rigid {rigid:e})"
        );
        errors.push(worst);
    }
    assert!(errors.windows(2).all(|w| w[1] < 0.2 * w[0]), "{errors:?}");
}

/// joint_torques without the fallback (rigid answers only): the rigid
/// chain locks against a plane at step 2069 with normal impulses of
/// 1.7e5 N s; with a contact compliance of 1e5 N/m the same scene's
/// impulses stay under 10 N s for its whole 3 s.
#[test]
fn a_locking_chain_keeps_bounded_impulses_with_compliance() {
    let largest = |extra: &str| {
        let mut m = model(&(shipped_scene("joint_torques.toml") + extra));
        m.params.fallback = false;
        let mut e = Engine::new(m);
        let mut worst = 0.0f64;
        run(&mut e, 3000, |e, _| {
            for r in e.impulses() {
                if r.kind == ImpulseKind::Normal {
                    worst = worst.max(r.impulse.norm());
                }
            }
        });
        worst
    };
    let rigid = largest("");
    let soft = largest(&compliance(Some((1e5, 600.0)), None));
    eprintln!("largest normal impulse: rigid {rigid:e} N s, compliant {soft:e} N s");
    assert!(rigid > 1e4, "the rigid chain no longer locks: {rigid:e}");
    assert!(soft < 10.0, "compliant {soft:e} N s");
}

/// Both solvers agree on a compliant step: the resting sphere's deflection
/// is the same with PGS.
#[test]
fn pgs_applies_the_same_compliance() {
    let (m, k) = (2.0f64, 2.0e4f64);
    let c = 2.0 * (k * m).sqrt();
    let text = sim(1e-3, 3000, [0.0, 0.0, -G]).replace("solver = \"lemke\"", "solver = \"pgs\"")
        + &sphere("ball", 0.1, m, [0.0, 0.0, 0.1], [0.0; 3], 0.5, 0.0)
        + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0)
        + &compliance(Some((k, c)), None);
    let mut e = Engine::new(model(&text));
    run(&mut e, 3000, |_, _| {});
    let deflection = 0.1 - e.state().bodies[0].x.z;
    let expected = m * G / k;
    assert!(
        (deflection - expected).abs() < 1e-3 * expected,
        "PGS deflection {deflection:e} m against {expected:e} m"
    );
}

/// Bad values are refused with the field named.
#[test]
fn a_bad_compliance_names_its_field() {
    let text = sim(1e-3, 10, [0.0, 0.0, -G])
        + &sphere("ball", 0.1, 1.0, [0.0, 0.0, 0.1], [0.0; 3], 0.5, 0.0)
        + "[compliance.contact]\nstiffness = -5.0\n";
    let e = Scene::parse(&text, "bad.toml").unwrap_err().to_string();
    assert!(
        e.contains("compliance.contact.stiffness") && e.contains("-5"),
        "{e}"
    );
    let text = sim(1e-3, 10, [0.0, 0.0, -G]) + "[compliance.joint]\nstiffness = 1e5\nspring = 3\n";
    let e = Scene::parse(&text, "bad.toml").unwrap_err().to_string();
    assert!(e.contains("spring"), "{e}");
}
