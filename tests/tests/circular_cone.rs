//! The circular friction cone of prox PGS: isotropic friction, so a sliding
//! sphere slows along its slip at exactly `mu g` in any direction, and the
//! friction impulse sits on the cone's boundary while it slides.

use cosim_server::engine::ImpulseKind;
use cosim_tests::*;
use nalgebra::Vector3;

#[test]
fn sliding_sphere_on_the_circular_cone() {
    let (h, r, mu, v0) = (1e-3, 0.1, 0.3, 2.0);
    let t_roll = 2.0 * v0 / (7.0 * mu * G);
    for deg in [0.0, 30.0, 111.0, 250.0] {
        let a = f64::to_radians(deg);
        let dir = Vector3::new(a.cos(), a.sin(), 0.0);
        let scene = sim(h, 1000, [0.0, 0.0, -G])
            .replace(
                &format!("solver = \"{}\"", solver()),
                "solver = \"pgs\"\nfriction_cone = \"circular\"",
            )
            .replace("friction_directions = 8", "friction_directions = 6")
            + &sphere(
                "ball",
                r,
                1.0,
                [0.0, 0.0, r],
                [v0 * dir.x, v0 * dir.y, 0.0],
                mu,
                0.0,
            )
            + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], mu, 0.0);
        assert!(scene.contains("circular"));
        let mut e = engine(&scene);
        let mut rolling_at = None;
        run(&mut e, 1000, |e, rep| {
            assert!(
                !rep.not_converged,
                "step {}: PGS did not converge",
                rep.step
            );
            let b = e.state().bodies[0];
            let slip = (b.v + b.w.cross(&Vector3::new(0.0, 0.0, -r))).norm();
            if slip < 1e-9 && rolling_at.is_none() {
                rolling_at = Some(rep.t);
            }
            if rolling_at.is_none() && slip > 1e-3 {
                // Sliding: |p_f| = mu p_n, opposite the slip.
                let pn = e
                    .impulses()
                    .iter()
                    .find(|i| i.kind == ImpulseKind::Normal)
                    .map(|i| i.impulse.norm());
                let pf = e
                    .impulses()
                    .iter()
                    .find(|i| i.kind == ImpulseKind::Friction)
                    .map(|i| i.impulse);
                if let (Some(pn), Some(pf)) = (pn, pf) {
                    assert!(
                        (pf.norm() - mu * pn).abs() < 1e-9 * pn,
                        "{deg} deg: |p_f| {} vs mu p_n {}",
                        pf.norm(),
                        mu * pn
                    );
                    assert!(
                        pf.normalize().dot(&dir) < -1.0 + 1e-9,
                        "{deg} deg: friction not against the slip"
                    );
                }
            }
        });
        let t = rolling_at.expect("never rolls");
        assert!(
            (t - t_roll).abs() <= 2.0 * h,
            "{deg} deg: rolls at {t}, expected {t_roll}"
        );
        let b = e.state().bodies[0];
        assert!(
            (b.v - dir * b.v.dot(&dir)).norm() < 1e-9,
            "{deg} deg: sideways velocity {:?}",
            b.v
        );
        assert!(((b.v.dot(&dir) - 5.0 / 7.0 * v0) / v0).abs() < 5e-3);
    }
}
