//! Conserved quantities: energy that never grows without input (acceptance
//! 8) and unit quaternions (acceptance 7).

use cosim_tests::*;
use nalgebra::{UnitQuaternion, Vector3};

/// Steps a scene and checks that the midpoint energy never rises from one
/// step to the next by more than 1e-9 of its initial value. The midpoint
/// energy is the figure the scheme conserves in free flight exactly
/// (formulation.md, "Energy, measured honestly"); contact impulses and the
/// velocity projection only remove energy. Returns the initial and final
/// midpoint energy.
fn energy_never_grows(scene: &str, steps: u64) -> (f64, f64) {
    let mut e = engine(scene);
    let e0 = cosim_server::engine::measure::energy(e.model(), e.state()).midpoint;
    let mut prev = e0;
    run(&mut e, steps, |_, r| {
        let now = r.energy.midpoint;
        assert!(
            now - prev <= 1e-9 * e0.abs(),
            "step {}: midpoint energy rose from {prev} to {now} J",
            r.step
        );
        prev = now;
    });
    (e0, prev)
}

fn with_restitution(scene: &str, e: f64) -> String {
    scene.replace("restitution = 0.0", &format!("restitution = {e}"))
}

#[test]
fn frictionless_scenes_never_gain_energy() {
    let base = shipped_scene("frictionless.toml");
    for e in [0.0, 0.5, 1.0] {
        for h in [1e-3, 1e-2] {
            let scene = with_restitution(&base, e).replace("dt = 0.001", &format!("dt = {h}"));
            let steps = (3.0 / h) as u64;
            let (e0, e1) = energy_never_grows(&scene, steps);
            eprintln!("e = {e}, h = {h}: midpoint energy {e0:.6} -> {e1:.6} J");
            if e < 1.0 {
                assert!(
                    e1 < 0.5 * e0,
                    "inelastic collisions should dissipate: {e0} -> {e1} J"
                );
            }
        }
    }
}

#[test]
fn head_on_collisions_never_gain_energy() {
    for e in [0.0, 0.5, 1.0] {
        let scene = sim(1e-3, 400, [0.0; 3])
            + &sphere("a", 0.1, 1.0, [-0.3, 0.0, 0.0], [2.0, 0.0, 0.0], 0.0, e)
            + &sphere("b", 0.15, 3.0, [0.2, 0.0, 0.0], [-1.0, 0.0, 0.0], 0.0, e);
        energy_never_grows(&scene, 400);
    }
}

/// A sphere spinning freely about a tilted axis for 1e5 steps: its
/// quaternion stays unit to 1e-12 and matches the exact rotation
/// `exp(t w / 2) q0` (a sphere's angular velocity is constant without
/// torque), within round-off accumulated over the steps.
#[test]
fn quaternions_stay_unit_over_1e5_steps() {
    let (h, steps) = (1e-3, 100_000u64);
    let w = Vector3::new(3.0, -7.0, 11.0);
    let scene = sim(h, steps, [0.0; 3])
        + &sphere("top", 0.1, 1.0, [0.0; 3], [0.0; 3], 0.0, 0.0).replace(
            "velocity = [0e0, 0e0, 0e0]",
            &format!(
                "velocity = [0.0, 0.0, 0.0]\nangular_velocity = [{}, {}, {}]",
                w.x, w.y, w.z
            ),
        );
    let mut e = engine(&scene);
    let mut worst: f64 = 0.0;
    run(&mut e, steps, |e, _| {
        let q = e.state().bodies[0].q;
        worst = worst.max((q.quaternion().norm() - 1.0).abs());
    });
    assert!(worst < 1e-12, "quaternion norm off by {worst}");
    let q = e.state().bodies[0].q;
    let exact = UnitQuaternion::from_scaled_axis(w * (h * steps as f64));
    let angle = q.angle_to(&exact);
    assert!(
        angle < 1e-9,
        "orientation off the exact rotation by {angle} rad"
    );
}
