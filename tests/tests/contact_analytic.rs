//! Contact against analytic results: resting, rolling, sliding to rolling,
//! bouncing, head-on collisions (acceptance points 1 to 5 of the engine core).

use cosim_server::engine::ImpulseKind;
use cosim_tests::*;
use nalgebra::Vector3;

/// Acceptance 1: A sphere resting on a floor: the normal impulse of every step is
/// `m g h` (to 1e-9 relative) and nothing moves in 10 s.
#[test]
fn resting_sphere_carries_its_weight_without_drift() {
    let (h, m, r) = (1e-3, 2.5, 0.1);
    let scene = sim(h, 10_000, [0.0, 0.0, -G])
        + &sphere("ball", r, m, [0.3, -0.2, r], [0.0; 3], 0.5, 0.0)
        + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0);
    let mut e = engine(&scene);
    run(&mut e, 10_000, |e, rep| {
        let normal: Vec<_> = e
            .impulses()
            .iter()
            .filter(|i| i.kind == ImpulseKind::Normal)
            .collect();
        assert_eq!(normal.len(), 1, "step {}", rep.step);
        let expected = m * G * h;
        let rel = (normal[0].impulse.z - expected).abs() / expected;
        assert!(
            rel < 1e-9,
            "step {}: p_n {} vs m g h {expected}",
            rep.step,
            normal[0].impulse.z
        );
        assert!(e.impulses().iter().all(|i| i.kind != ImpulseKind::Friction));
    });
    let b = e.state().bodies[0];
    assert!(
        (b.x - Vector3::new(0.3, -0.2, r)).norm() < 1e-12,
        "drifted to {:?}",
        b.x
    );
    assert!(b.v.norm() < 1e-12 && b.w.norm() < 1e-12);
}

/// Distance rolled down a 30 degree incline in 1 s, and the largest slip.
fn roll_down_incline(h: f64, nd: usize) -> (f64, f64) {
    let (r, theta) = (0.1_f64, 30f64.to_radians());
    let n = [theta.sin(), 0.0, theta.cos()];
    let steps = (1.0 / h).round() as u64;
    let scene = sim(h, steps, [0.0, 0.0, -G]).replace(
        "friction_directions = 8",
        &format!("friction_directions = {nd}"),
    ) + &sphere(
        "ball",
        r,
        1.0,
        [n[0] * r, 0.0, n[2] * r],
        [0.0; 3],
        0.5,
        0.0,
    ) + &plane("incline", n, [0.0; 3], 0.5, 0.0);
    let mut e = engine(&scene);
    let normal = Vector3::from(n);
    let mut slip: f64 = 0.0;
    run(&mut e, steps, |e, _| {
        let b = e.state().bodies[0];
        slip = slip.max((b.v + b.w.cross(&(-normal * r))).norm());
    });
    let down = Vector3::new(theta.cos(), 0.0, -theta.sin());
    let b = e.state().bodies[0];
    let start = normal * r;
    assert!(
        (b.x - start).dot(&Vector3::y()).abs() < 1e-12,
        "sideways drift"
    );
    ((b.x - start).dot(&down), slip)
}

/// Acceptance 2: Rolling without slip down 30 degrees, mu = 0.5: `5/7 g sin(theta)`,
/// 1.7518 m in 1 s within 0.5 % at h = 1e-3, error linear in h.
#[test]
fn sphere_rolls_down_incline_without_slip() {
    let exact = 0.5 * 5.0 / 7.0 * G * 0.5; // 1/2 a t^2 at t = 1 s
    assert!((exact - 1.7518).abs() < 1e-4);
    let (d1, slip1) = roll_down_incline(1e-3, 8);
    assert!(slip1 < 1e-6, "slip {slip1} m/s");
    let err1 = (d1 - exact) / exact;
    assert!(err1.abs() < 5e-3, "distance {d1} vs {exact}");
    // Semi-implicit Euler rolls a h^2 n(n+1)/2: the error is a h t / 2,
    // relative h / t; halving h halves it.
    let (d2, slip2) = roll_down_incline(2e-3, 8);
    let (d4, _) = roll_down_incline(4e-3, 8);
    assert!(slip2 < 1e-6);
    let (err2, err4) = ((d2 - exact) / exact, (d4 - exact) / exact);
    eprintln!("incline: {d1:.6} m at h = 1e-3 (error {err1:.2e}, slip {slip1:.1e} m/s), errors at 2h, 4h: {err2:.2e}, {err4:.2e}");
    for (ratio, what) in [(err2 / err1, "2h/h"), (err4 / err2, "4h/2h")] {
        assert!(
            (ratio - 2.0).abs() < 0.05,
            "error ratio {what} = {ratio}: not first order"
        );
    }
    // The polyhedral cone with n_d = 4 still holds the required 0.165 mu.
    let (d, slip) = roll_down_incline(1e-3, 4);
    assert!(slip < 1e-6 && ((d - exact) / exact).abs() < 5e-3);
}

/// Acceptance 3: A sphere sliding at 2 m/s on a floor with mu = 0.3 starts rolling at
/// `2 v0 / (7 mu g)` = 0.1942 s and rolls on at `5/7 v0` = 1.4286 m/s, in a
/// straight line whatever the direction.
#[test]
fn sliding_sphere_starts_rolling_at_the_analytic_time() {
    let (h, r, mu, v0) = (1e-3, 0.1, 0.3, 2.0);
    let t_roll = 2.0 * v0 / (7.0 * mu * G);
    let v_roll = 5.0 / 7.0 * v0;
    assert!((t_roll - 0.1942).abs() < 1e-4 && (v_roll - 1.4286).abs() < 1e-4);
    for deg in [0.0, 17.0, 45.0, 90.0, 133.0, 200.0, 271.0, 333.3] {
        let a = f64::to_radians(deg);
        let dir = Vector3::new(a.cos(), a.sin(), 0.0);
        let scene = sim(h, 1000, [0.0, 0.0, -G])
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
        let mut e = engine(&scene);
        let mut rolling_at = None;
        let mut lateral: f64 = 0.0;
        run(&mut e, 1000, |e, rep| {
            let b = e.state().bodies[0];
            let slip = (b.v + b.w.cross(&Vector3::new(0.0, 0.0, -r))).norm();
            if slip < 1e-9 && rolling_at.is_none() {
                rolling_at = Some(rep.t);
            }
            lateral = lateral.max(b.x.dot(&Vector3::new(-dir.y, dir.x, 0.0)).abs());
        });
        let t = rolling_at.expect("never rolls");
        eprintln!("slide at {deg} deg: rolls at {t:.4} s (exact {t_roll:.4}), lateral drift {lateral:.1e} m");
        assert!(
            (t - t_roll).abs() <= 2.0 * h,
            "{deg} deg: rolls at {t}, expected {t_roll}"
        );
        let b = e.state().bodies[0];
        let v = b.v.dot(&dir);
        assert!(
            ((v - v_roll) / v_roll).abs() < 5e-3,
            "{deg} deg: speed {v} vs {v_roll}"
        );
        assert!(lateral < 1e-12, "{deg} deg: sideways drift {lateral} m");
        assert!(
            (b.v - dir * v).norm() < 1e-12,
            "{deg} deg: sideways velocity"
        );
    }
}

/// Acceptance 4: A drop from 1 m (lowest point 1 m above the plane) with e = 0.5:
/// first apex `e^2 h` = 0.25 m within 1 %.
#[test]
fn dropped_sphere_rebounds_to_e_squared_h() {
    for h in [1e-3, 1e-4] {
        let r = 0.1;
        let steps = (1.5 / h) as u64;
        let scene = sim(h, steps, [0.0, 0.0, -G])
            + &sphere("ball", r, 1.0, [0.0, 0.0, 1.0 + r], [0.0; 3], 0.0, 0.5)
            + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.0, 0.0);
        let mut e = engine(&scene);
        let (mut bounced, mut apex) = (false, 0.0f64);
        run(&mut e, steps, |e, _| {
            let b = e.state().bodies[0];
            if b.v.z > 0.0 {
                bounced = true;
            }
            if bounced && b.v.z >= -1e-12 {
                apex = apex.max(b.x.z - r);
            }
        });
        assert!(bounced);
        eprintln!("drop: h = {h}: first apex {apex:.5} m");
        assert!((apex - 0.25).abs() < 0.0025, "h = {h}: apex {apex} m");
    }
}

/// Acceptance 5: Two spheres head-on, no friction, unequal masses: momentum conserved
/// to 1e-12 relative and the velocities of Newton's law of restitution.
#[test]
fn head_on_collision_obeys_newton_restitution() {
    let (m1, m2, u1, u2) = (1.0, 3.0, 2.0, -1.0);
    for e_rest in [1.0, 0.0, 0.5] {
        let scene = sim(1e-3, 400, [0.0; 3])
            + &sphere("a", 0.1, m1, [-0.3, 0.0, 0.0], [u1, 0.0, 0.0], 0.0, e_rest)
            + &sphere("b", 0.15, m2, [0.2, 0.0, 0.0], [u2, 0.0, 0.0], 0.0, e_rest);
        let mut e = engine(&scene);
        let p0 = m1 * u1 + m2 * u2;
        run(&mut e, 400, |e, rep| {
            let s = e.state();
            let p = s.bodies[0].v * m1 + s.bodies[1].v * m2;
            assert!(
                ((p.x - p0) / p0).abs() < 1e-12,
                "step {}: momentum {}",
                rep.step,
                p.x
            );
            assert!(p.y == 0.0 && p.z == 0.0);
        });
        let s = e.state();
        let v1 = (m1 * u1 + m2 * u2 - m2 * e_rest * (u1 - u2)) / (m1 + m2);
        let v2 = (m1 * u1 + m2 * u2 + m1 * e_rest * (u1 - u2)) / (m1 + m2);
        assert!(
            (s.bodies[0].v.x - v1).abs() < 1e-6,
            "e = {e_rest}: v1 {} vs {v1}",
            s.bodies[0].v.x
        );
        assert!(
            (s.bodies[1].v.x - v2).abs() < 1e-6,
            "e = {e_rest}: v2 {} vs {v2}",
            s.bodies[1].v.x
        );
    }
}
