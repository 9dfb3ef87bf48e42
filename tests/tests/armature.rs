//! Armature (issue 45, point 4: MJCF joint `armature`; scene `[[joint]]
//! armature`): a rotor of inertia `I_a` on a joint's coordinate, kinetic
//! energy `I_a x'^2 / 2`. On a joint to the world the rotor turns with the
//! body about a fixed axis, so it is exactly inertia added to the body's
//! (`I_a u u^T` for a hinge, `I_a 1` for a spherical joint): the run must
//! match that body's to round-off. Through a chain, MuJoCo's own RK4 (the
//! `mujoco` Python package) on the same file is the reference. Each test
//! runs with the solver `COSIM_TEST_SOLVER` names (Lemke by default;
//! `.ci/run` reruns the file with PGS).

use cosim_import::{mjcf, Options};
use cosim_server::engine::constraint::joint::coordinate;
use cosim_server::engine::measure::energy;
use cosim_server::engine::{Engine, Model};
use cosim_tests::*;

/// How far two runs that are the same motion may part (m, m/s): Lemke's
/// answers are round-off; PGS stops at 1e-6 m/s per row (`sim`), which
/// the two formulations meet differently.
fn same_motion() -> f64 {
    if solver() == "pgs" {
        1e-4
    } else {
        1e-9
    }
}

/// The largest difference of the two engines' body positions and
/// velocities over `n` steps, stepped side by side.
fn parting(a: &mut Engine, b: &mut Engine, n: u64) -> f64 {
    let mut worst = 0.0f64;
    for k in 1..=n {
        for e in [&mut *a, &mut *b] {
            let r = e.step();
            assert!(r.ok(), "step {k}: {:?}", r.error);
        }
        for (x, y) in a.state().bodies.iter().zip(&b.state().bodies) {
            worst = worst
                .max((x.x - y.x).amax())
                .max((x.v - y.v).amax())
                .max((x.w - y.w).amax());
        }
    }
    worst
}

/// A pendulum on a world hinge with a rotor of 0.05 kg m^2 swings as
/// the same pendulum whose bob has 0.05 more inertia about the hinge's
/// axis (the bob's own is 0.4 * 1 * 0.05^2 = 0.001), from level for 2 s;
/// and it swings slower than without the rotor, its half period `2 K(1 /
/// sqrt 2) sqrt(I / (m g l))` with `I = m l^2 + I_bob + I_a` (a rigid
/// pendulum released level), within 1e-4 relative: the first-order
/// step's phase error at h = 1e-3 (6.1e-6 measured; the rotor changes it
/// by 9.5 %).
#[test]
fn a_rotor_on_a_world_hinge_is_inertia_about_its_axis() {
    let (h, n, arm) = (1e-3, 2000, 0.05);
    let mut rotor = level_pendulum(h, n, [0.0, 0.0, -G], 0.0, &format!("armature = {arm}\n"));
    let mut heavier = {
        let mut s = sim(h, n, [0.0, 0.0, -G]);
        s += &sphere("bob", 0.05, 1.0, [0.5, 0.0, 1.0], [0.0; 3], 0.0, 0.0);
        s += &format!(
            "inertia = [0.001, {:e}, 0.001, 0.0, 0.0, 0.0]\n",
            0.001 + arm
        );
        s += &pivot();
        engine(&s)
    };
    let worst = parting(&mut rotor, &mut heavier, n);
    eprintln!("hinge: the two runs part by {worst:e}");
    assert!(
        worst < same_motion(),
        "the rotor's pendulum left the heavier bob's by {worst}"
    );

    // The half period, from the first turning point (the rate's sign
    // change, interpolated) after the release.
    let mut e = level_pendulum(h, 4000, [0.0, 0.0, -G], 0.0, &format!("armature = {arm}\n"));
    let rate = |e: &Engine| {
        coordinate(&e.model().joints[0], e.state())
            .expect("a hinge")
            .1
    };
    let mut before = rate(&e);
    let mut half = None;
    for k in 1..=4000u64 {
        assert!(e.step().ok(), "step {k}");
        let now = rate(&e);
        if k > 10 && before.signum() != now.signum() {
            half = Some((k as f64 - 1.0 + before / (before - now)) * h);
            break;
        }
        before = now;
    }
    let half = half.expect("the pendulum turned back within 4 s");
    let k_of = 1.854_074_677_301_372; // K(1 / sqrt 2)
    let (m, l) = (1.0, 0.5);
    let want = 2.0 * k_of * ((m * l * l + 0.001 + arm) / (m * G * l)).sqrt();
    eprintln!("half period {half} s, want {want} s");
    let without = 2.0 * k_of * ((m * l * l + 0.001) / (m * G * l)).sqrt();
    assert!(
        ((half - want) / want).abs() < 1e-4,
        "half period {half} s against {want} s (without the rotor {without} s)"
    );
}

/// A spherical joint to the world with a rotor of 0.02 kg m^2 on each
/// axis: a bob on a 0.4 m arm, released sideways and spinning about all
/// three axes, tumbles as the bob with `0.02 * 1` added to its inertia,
/// for 1 s; and the total energy, the rotor's included, stays within the
/// step's first-order allowance.
#[test]
fn a_rotor_on_a_ball_joint_is_inertia_about_every_axis() {
    let (h, n, arm) = (1e-3, 1000, 0.02);
    let bob = |extra: &str| {
        let mut s = sim(h, n, [0.0, 0.0, -G]);
        s += &sphere("bob", 0.05, 1.0, [0.4, 0.0, 1.0], [0.0; 3], 0.0, 0.0);
        s += "angular_velocity = [3.0, -2.0, 5.0]\n";
        s += extra;
        s
    };
    let ball = joint_of("spherical", "ball", "world", "bob", [0.0, 0.0, 1.0], None);
    let mut rotor = engine(&(bob("") + &ball + &format!("armature = {arm}\n")));
    let i = 0.001 + arm;
    let mut heavier =
        engine(&(bob(&format!("inertia = [{i:e}, {i:e}, {i:e}, 0.0, 0.0, 0.0]\n")) + &ball));
    let e0 = energy(rotor.model(), rotor.state()).total;
    let e_heavier = energy(heavier.model(), heavier.state()).total;
    assert!(
        (e0 - e_heavier).abs() < 1e-12,
        "the rotor's energy at the start {e0} against the heavier bob's {e_heavier}"
    );
    let worst = parting(&mut rotor, &mut heavier, n);
    eprintln!("ball: the two runs part by {worst:e}");
    assert!(
        worst < same_motion(),
        "the rotor's bob left the heavier bob's by {worst}"
    );
    let (a, b) = (
        energy(rotor.model(), rotor.state()).total,
        energy(heavier.model(), heavier.state()).total,
    );
    assert!(
        (a - b).abs() < 1e3 * same_motion(),
        "energy with the rotor {a} J, the heavier bob's {b} J"
    );
}

/// A slider's rotor is mass on the slide: a 1 kg block on a world slider
/// along x with a rotor of 3 kg, pushed by 2 N along the axis, moves at
/// `n h F / (m + I_a)` after `n` steps (the velocity-level step is exact
/// for a constant force), a quarter of what the block alone would.
#[test]
fn a_rotor_on_a_slider_is_mass_on_the_slide() {
    let (h, n, f, arm) = (1e-3, 500u64, 2.0, 3.0);
    let mut s = sim(h, n, [0.0; 3]);
    s += &sphere("block", 0.1, 1.0, [0.0; 3], [0.0; 3], 0.0, 0.0);
    s += &joint_of(
        "prismatic",
        "slide",
        "world",
        "block",
        [0.0; 3],
        Some([1.0, 0.0, 0.0]),
    );
    s += &format!("force = [{f:e}, 0.0, 0.0]\narmature = {arm}\n");
    let mut e = engine(&s);
    let mut worst = 0.0f64;
    let tol = if solver() == "pgs" { 1e-5 } else { 1e-12 };
    run(&mut e, n, |e, r| {
        let v = e.state().bodies[0].v.x;
        worst = worst.max((v - r.step as f64 * h * f / (1.0 + arm)).abs());
    });
    eprintln!("slider: speed off by {worst:e}");
    assert!(worst < tol, "the block's speed off by {worst} m/s");
    let v = e.state().bodies[0].v.x;
    assert!((v - 0.25).abs() < 1e-3, "{v} m/s after 0.5 s, not 0.25");
}

/// A two-link chain from MJCF with a rotor of 0.05 kg m^2 on each hinge
/// (the shoulder to the world, the elbow between the links), released
/// level, against MuJoCo's RK4 at h = 1e-4 on the same file (converged:
/// it agrees with h = 1e-5 to 1e-14 rad). Ours is first order: at h =
/// 1e-4 the joint angles at t = 0.5 s and 1 s are within 5e-4 rad of
/// MuJoCo's (2.7e-4 measured), and the error halves with h (the ratio of
/// h = 2e-4's to 1e-4's between 1.5 and 2.5; 2.0 measured). Without the rotors MuJoCo's elbow is 0.83 rad elsewhere
/// at 0.5 s: the rotors are what is being matched.
#[test]
fn a_chain_with_rotors_moves_as_mujoco_says() {
    let xml = |arm: f64, h: f64| {
        format!(
            r#"<mujoco model="rotor_chain">
  <option timestep="{h:e}" integrator="RK4" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="upper" pos="0 0 2">
      <joint name="shoulder" type="hinge" axis="0 1 0" armature="{arm}"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.04" mass="1"/>
      <body name="lower" pos="0.5 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0" armature="{arm}"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.04" mass="0.5"/>
      </body>
    </body>
  </worldbody>
</mujoco>"#
        )
    };
    let times = [0.5, 1.0];
    // MuJoCo's joint angles at the two times.
    let reference = |arm: f64| -> Vec<[f64; 2]> {
        let script = format!(
            "import mujoco\nm = mujoco.MjModel.from_xml_string('''{}''')\nd = mujoco.MjData(m)\nfor t in (0.5, 1.0):\n    while d.time < t - 5e-5:\n        mujoco.mj_step(m, d)\n    print(repr(float(d.qpos[0])), repr(float(d.qpos[1])))\n",
            xml(arm, 1e-4)
        );
        mujoco_python(["-c", &script])
            .lines()
            .map(|l| {
                let v: Vec<f64> = l
                    .split_whitespace()
                    .map(|x| x.parse().expect("a number"))
                    .collect();
                [v[0], v[1]]
            })
            .collect()
    };
    let mj = reference(0.05);
    let mj_bare = reference(0.0);
    assert!(
        (mj[0][1] - mj_bare[0][1]).abs() > 0.5,
        "the rotors should matter: {mj:?} against {mj_bare:?}"
    );
    let ours = |h: f64| -> Vec<[f64; 2]> {
        let imported = mjcf::import(
            &xml(0.05, h),
            "rotor_chain.xml",
            "rotor_chain",
            None,
            Options::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        for j in &imported.scene.joints {
            assert_eq!(j.armature, Some(0.05), "joint {:?}", j.name);
        }
        let mut e = Engine::new(Model::from_scene(&imported.scene));
        let angle = |e: &Engine, name: &str| coordinate_of(e, name).0;
        times
            .iter()
            .map(|&t| {
                while e.state().t < t - h / 2.0 {
                    let r = e.step();
                    assert!(r.ok(), "t = {}: {:?}", e.state().t, r.error);
                }
                [angle(&e, "shoulder"), angle(&e, "elbow")]
            })
            .collect()
    };
    let error = |got: &[[f64; 2]]| -> f64 {
        got.iter()
            .zip(&mj)
            .flat_map(|(a, b)| [(a[0] - b[0]).abs(), (a[1] - b[1]).abs()])
            .fold(0.0, f64::max)
    };
    let (coarse, fine) = (error(&ours(2e-4)), error(&ours(1e-4)));
    assert!(
        fine < 5e-4,
        "off MuJoCo's angles by {coarse} rad (h = 2e-4) and {fine} rad (h = 1e-4)"
    );
    let ratio = coarse / fine;
    eprintln!("chain: off MuJoCo by {coarse:e} (h = 2e-4), {fine:e} (h = 1e-4)");
    assert!(
        (1.5..2.5).contains(&ratio),
        "error {coarse} at h = 2e-4 and {fine} at 1e-4: not first order ({ratio})"
    );
}

/// What the scene refuses, by field: a rotor on a fixed joint (no
/// coordinate to turn with) and a negative one.
#[test]
fn a_bad_armature_is_refused_by_name() {
    for (kind, axis, value, says) in [
        ("fixed", None, "0.1", "a fixed joint has no coordinate"),
        (
            "revolute",
            Some([0.0, 0.0, 1.0]),
            "-0.1",
            "must be a finite number >= 0",
        ),
    ] {
        let mut s = sim(1e-3, 10, [0.0; 3]);
        s += &sphere("a", 0.1, 1.0, [0.0; 3], [0.0; 3], 0.0, 0.0);
        s += &joint_of(kind, "j", "world", "a", [0.0; 3], axis);
        s += &format!("armature = {value}\n");
        let text = cosim_shared::Scene::parse(&s, "t.toml")
            .expect_err(says)
            .to_string();
        assert!(
            text.contains("\"j\".armature") && text.contains(says),
            "{text}"
        );
    }
}
