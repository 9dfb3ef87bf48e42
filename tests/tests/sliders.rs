//! Prismatic (slider) joints (issue 17, point 1): a body on a rail falls
//! along it at the analytic rate, and a slider on a spinning body keeps
//! the angular momentum (which fails if the rows' lever arm misses the
//! slide's travel: joint.rs).

use cosim_server::engine::constraint::joint::{angle_error, coordinate};
use cosim_server::engine::Engine;
use cosim_shared::DEFAULT_PGS_TOLERANCE;
use cosim_tests::*;
use nalgebra::Vector3;

const R: f64 = 0.05;

/// The slider's offset and rate after `steps` steps of `h` from speed
/// `v0` along it at constant acceleration `a`, as the symplectic Euler
/// step gives them: `v_n = v0 + n h a`, `x_n = sum h v_k = n h v0 + h^2 a
/// n (n + 1) / 2`. PGS stops within DEFAULT_PGS_TOLERANCE (m/s) of the
/// answer; its error can add up over the run's time (Lemke's is
/// round-off).
fn assert_accelerates(e: &Engine, v0: f64, a: f64, h: f64, steps: u64) {
    let n = steps as f64;
    let (x, v) = (n * h * v0 + h * h * a * n * (n + 1.0) / 2.0, v0 + n * h * a);
    let joint = &e.model().joints[0];
    let (offset, rate) = coordinate(joint, e.state()).expect("a slider has a coordinate");
    assert!(
        (rate - v).abs() < DEFAULT_PGS_TOLERANCE,
        "rate {rate}, analytic {v}"
    );
    assert!(
        (offset - x).abs() < DEFAULT_PGS_TOLERANCE * n * h,
        "offset {offset}, analytic {x}"
    );
}

/// A frictionless sphere on a rail from the world, tilted 30 degrees down
/// from the horizontal, thrown with a speed that has parts along the rail
/// and across it (which the slider takes away in the first step).
#[test]
fn a_body_on_a_rail_slides_down_it_at_g_sin_30() {
    let (h, steps) = (1e-3, 1000u64);
    let u = Vector3::new(30f64.to_radians().cos(), 0.0, -30f64.to_radians().sin());
    let v0 = [0.4, 0.7, 0.2];
    let mut s = sim(h, steps, [0.0, 0.0, -G]);
    s += &sphere("slider", R, 2.0, [0.0, 0.0, 1.0], v0, 0.0, 0.0);
    s += &joint_of(
        "prismatic",
        "rail",
        "world",
        "slider",
        [0.0, 0.0, 1.0],
        Some(u.into()),
    );
    let mut e = engine(&s);
    let joint = e.model().joints[0].clone();
    let (mut off_axis, mut turned) = (0.0f64, 0.0f64);
    run(&mut e, steps, |e, r| {
        off_axis = off_axis.max(r.max_joint_error);
        turned = turned.max(angle_error(&joint, e.state()));
    });
    // From the speed along the rail, at a = g sin 30.
    assert_accelerates(&e, Vector3::from(v0).dot(&u), G * 0.5, h, steps);
    assert!(off_axis < 1e-9, "left the rail by {off_axis} m");
    assert!(turned < 1e-9, "turned by {turned} rad");
}

/// A heavy sphere spinning at 2 rad/s in zero gravity with a light one on
/// a slider along x: the light one slides out. The joint's impulses are
/// internal and, with the lever arm at B's anchor, have no moment about
/// any point, so the linear and angular momenta are those of the start to
/// round-off whatever the solver's error.
#[test]
fn a_slider_on_a_spinning_body_keeps_the_momenta_and_slides_out() {
    let (h, steps) = (1e-3, 2000u64);
    let w = [0.0, 0.0, 2.0];
    let mut s = sim(h, steps, [0.0; 3]);
    s += &sphere("hub", R, 2.0, [0.0; 3], [0.0; 3], 0.0, 0.0);
    s += &format!("angular_velocity = {w:?}\n");
    s += &sphere("bead", R, 1.0, [0.15, 0.0, 0.0], [0.0, 0.3, 0.0], 0.0, 0.0);
    s += &format!("angular_velocity = {w:?}\n");
    s += &joint_of(
        "prismatic",
        "spoke",
        "hub",
        "bead",
        [0.15, 0.0, 0.0],
        Some([1.0, 0.0, 0.0]),
    );
    let mut e = engine(&s);
    let momenta = Momenta::of;
    let (p0, l0) = momenta(&e);
    let joint = e.model().joints[0].clone();
    let (mut dp, mut dl, mut off_axis, mut turned) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    run(&mut e, steps, |e, r| {
        let (p, l) = momenta(e);
        dp = dp.max((p - p0).norm());
        dl = dl.max((l - l0).norm());
        off_axis = off_axis.max(r.max_joint_error);
        turned = turned.max(angle_error(&joint, e.state()));
    });
    // Round-off: 2,000 steps of sums of terms of order |L| = 0.05.
    assert!(dp < 1e-12, "linear momentum changed by {dp}");
    assert!(
        dl < 1e-12 * l0.norm().max(1.0),
        "angular momentum changed by {dl}"
    );
    let (offset, rate) = coordinate(&joint, e.state()).expect("a slider has a coordinate");
    assert!(
        offset > 0.1 && rate > 0.0,
        "slid out by {offset} m at {rate} m/s"
    );
    // The stabilisation holds the drift to its velocity error's scale.
    assert!(off_axis < 1e-6, "left the spoke by {off_axis} m");
    assert!(turned < 1e-6, "the bead turned on the hub by {turned} rad");
}

/// A slider's effort is a force at B's anchor (its opposite on A there):
/// between two free spheres in zero gravity, a force with parts along the
/// axis and across it drives them apart at `f_u (1/m_A + 1/m_B)` and does
/// nothing else. The pair starts at rest, so the momenta stay zero.
#[test]
fn a_slider_force_drives_the_slide_and_nothing_else() {
    let (h, steps) = (1e-3, 500u64);
    let (ma, mb, f) = (2.0, 1.0, [3.0, 0.5, -0.2]);
    let mut s = sim(h, steps, [0.0; 3]);
    s += &sphere("a", R, ma, [0.0; 3], [0.0; 3], 0.0, 0.0);
    s += &sphere("b", R, mb, [0.2, 0.0, 0.0], [0.0; 3], 0.0, 0.0);
    s += &joint_of(
        "prismatic",
        "push",
        "a",
        "b",
        [0.1, 0.0, 0.0],
        Some([1.0, 0.0, 0.0]),
    );
    s += &format!("force = [{:e}, {:e}, {:e}]\n", f[0], f[1], f[2]);
    let mut e = engine(&s);
    let (mut momentum, mut spin) = (0.0f64, 0.0f64);
    run(&mut e, steps, |e, _| {
        let b = &e.state().bodies;
        let p = b[0].v * ma + b[1].v * mb;
        let l = b[0].x.cross(&(b[0].v * ma)) + b[1].x.cross(&(b[1].v * mb));
        momentum = momentum.max(p.norm()).max(l.norm());
        spin = spin.max(b[0].w.norm()).max(b[1].w.norm());
    });
    assert_accelerates(&e, 0.0, f[0] * (1.0 / ma + 1.0 / mb), h, steps);
    // Internal impulses: round-off on momenta of order 1 N s.
    assert!(momentum < 1e-12, "momenta moved by {momentum}");
    assert!(
        spin < DEFAULT_PGS_TOLERANCE,
        "the pair turned at {spin} rad/s"
    );
    let y = e.state().bodies[1].x.y.abs();
    assert!(y < 1e-9, "the sideways force moved b by {y} m");
}
