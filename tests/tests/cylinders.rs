//! Cylinders (issue 45, point 2): exact against planes, balls and
//! capsules, and on a box's or hull's face; elsewhere against boxes, hulls
//! and cylinders their prism (`Hull::cylinder`, 32 sides).

use cosim_server::engine::{ImpulseKind, Party};
use cosim_tests::*;
use nalgebra::{UnitQuaternion, Vector3};

const FLOOR: &str = "[[plane]]\nname = \"floor\"\nnormal = [0.0, 0.0, 1.0]\npoint = [0.0, 0.0, 0.0]\nfriction = 0.5\n\n";

/// A body of one cylinder (radius `r`, half length `l`) at `position`,
/// turned by `orientation` (scalar first), moving at `v`, spinning at `w`.
fn cylinder(
    name: &str,
    (r, l): (f64, f64),
    position: [f64; 3],
    orientation: [f64; 4],
    (v, w): ([f64; 3], [f64; 3]),
) -> String {
    format!(
        "[[body]]\nname = \"{name}\"\nmass = 1.0\nposition = {position:?}\norientation = {orientation:?}\n\
         velocity = {v:?}\nangular_velocity = {w:?}\nfriction = 0.5\n\
         [[body.shape]]\ntype = \"cylinder\"\nradius = {r:?}\nhalf_length = {l:?}\n\n"
    )
}

/// A cylinder at rest standing on an end, its centre `z` above the origin.
fn standing(name: &str, (r, l): (f64, f64), z: f64) -> String {
    cylinder(
        name,
        (r, l),
        [0.0, 0.0, z],
        [1.0, 0.0, 0.0, 0.0],
        ([0.0; 3], [0.0; 3]),
    )
}

/// Standing on an end it rests on its rim, still: the centre at l above
/// the floor to the solver's tolerance, no speed left, its inertia the
/// solid cylinder's (m r^2 / 2 about the axis, m (3 r^2 + 4 l^2) / 12
/// across).
#[test]
fn a_standing_cylinder_rests_on_its_rim() {
    let (r, l) = (0.1, 0.2);
    let s = sim(1e-3, 1000, [0.0, 0.0, -G]) + FLOOR + &standing("can", (r, l), l);
    let mut e = engine(&s);
    let i = e.model().bodies[0].inertia;
    assert!((i[(2, 2)] - 0.5 * r * r).abs() < 1e-15);
    assert!((i[(0, 0)] - (3.0 * r * r + 4.0 * l * l) / 12.0).abs() < 1e-15);
    let mut most = 0;
    run(&mut e, 1000, |_, r| most = most.max(r.active_contacts));
    let b = e.state().bodies[0];
    assert!((b.x.z - l).abs() < 1e-6, "z = {}", b.x.z);
    assert!(b.v.norm() < 1e-9 && b.w.norm() < 1e-9, "{} {}", b.v, b.w);
    assert!(most >= 3, "rests on {most} rim points");
}

/// Lying on its side and rolling (v = w r along the floor) it keeps its
/// height and its speed: the round side, not a prism's flats (a prism of
/// 32 sides would lift the centre by r (1 - cos(pi / 32)) = 4.8e-4 m
/// each thirty-second of a turn).
#[test]
fn a_cylinder_rolls_on_its_round_side() {
    let (r, l) = (0.1, 0.05);
    // Axis along world y: a quarter turn about x.
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let (v, w) = (1.0, 1.0 / r);
    let s = sim(1e-3, 2000, [0.0, 0.0, -G])
        + FLOOR
        + &cylinder(
            "wheel",
            (r, l),
            [0.0, 0.0, r],
            [h, h, 0.0, 0.0],
            ([v, 0.0, 0.0], [0.0, w, 0.0]),
        );
    let mut e = engine(&s);
    let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
    run(&mut e, 2000, |e, _| {
        let z = e.state().bodies[0].x.z;
        (low, high) = (low.min(z), high.max(z));
    });
    let b = e.state().bodies[0];
    assert!(
        high - low < 1e-5,
        "the centre moved between {low} and {high}"
    );
    assert!((b.v.x - v).abs() < 1e-3, "v = {}", b.v);
    // Two seconds at 1 m/s: five turns and more.
    assert!(b.x.x > 1.9, "x = {}", b.x.x);
}

/// A ball on a standing cylinder's top end rests there, and one against
/// its side meets the round side: the ball's centre stays r + R from the
/// axis (the exact surface, not a prism's).
#[test]
fn a_ball_meets_a_cylinders_true_surface() {
    let (r, l, rb) = (0.1, 0.2, 0.05);
    let ball = |x: [f64; 3]| sphere("ball", rb, 1.0, x, [0.0; 3], 0.5, 0.0);
    // On the top end.
    let s = sim(1e-3, 500, [0.0, 0.0, -G])
        + FLOOR
        + &standing("can", (r, l), l)
        + &ball([0.03, 0.0, 2.0 * l + rb]);
    let mut e = engine(&s);
    run(&mut e, 500, |_, _| {});
    let z = e.state().bodies[1].x.z;
    assert!((z - (2.0 * l + rb)).abs() < 1e-6, "the ball at {z}");
    // Against the side, in zero gravity: pressed towards the axis at an
    // angle between two of the prism's corners, it stops at r + R.
    let t = 0.5 * std::f64::consts::TAU / 32.0;
    let dir = Vector3::new(t.cos(), t.sin(), 0.0);
    let start = dir * (r + rb + 0.01);
    let s = sim(1e-3, 300, [0.0; 3])
        + &standing("post", (r, l), 0.0)
        + &sphere("ball", rb, 1.0, start.into(), (-dir * 0.1).into(), 0.0, 0.0);
    let mut e = engine(&s);
    let mut closest = f64::INFINITY;
    run(&mut e, 300, |e, _| {
        let s = e.state();
        let d = (s.bodies[1].x - s.bodies[0].x).xy().norm();
        closest = closest.min(d);
    });
    assert!((closest - (r + rb)).abs() < 1e-6, "closest {closest}");
}

/// A capsule meets the true surface too (its balls against the
/// cylinder's, not a prism's): lying on a standing cylinder's top end it
/// rests on both end balls at `2 l + rc`; pressed (zero gravity) against a
/// post's side between two of the prism's corners, upright beside it or
/// crossing it, it stops with its axis `r + rc` from the post's (the
/// prism: up to r (1 - cos(pi / 32)) = 4.8e-4 m nearer).
#[test]
fn a_capsule_meets_a_cylinders_true_surface() {
    let (r, l, rc, lc) = (0.1, 0.2, 0.03, 0.05);
    let half = std::f64::consts::FRAC_1_SQRT_2;
    let lying = [half, 0.0, half, 0.0]; // its axis along x
    let s = sim(1e-3, 500, [0.0, 0.0, -G])
        + FLOOR
        + &standing("can", (r, l), l)
        + &capsule(
            "pill",
            rc,
            lc,
            1.0,
            [0.02, 0.0, 2.0 * l + rc],
            lying,
            [0.0; 3],
            [0.0; 3],
            0.5,
        );
    let mut e = engine(&s);
    let mut touches = 0;
    run(&mut e, 500, |e, _| {
        touches = e
            .impulses()
            .iter()
            .filter(|i| {
                i.kind == ImpulseKind::Normal && (i.a == Party::Body(1) || i.b == Party::Body(1))
            })
            .count();
    });
    let z = e.state().bodies[1].x.z;
    assert!((z - (2.0 * l + rc)).abs() < 1e-6, "the capsule at {z}");
    assert!(touches >= 2, "on {touches} points of the can's end");
    let t = 0.5 * std::f64::consts::TAU / 32.0;
    let dir = Vector3::new(t.cos(), t.sin(), 0.0);
    let across = Vector3::z().cross(&dir);
    // Upright (axis along z), then crossing (axis level, across `dir`).
    let crossing = UnitQuaternion::rotation_between(&Vector3::z(), &across).expect("a turn");
    let crossing = [crossing.w, crossing.i, crossing.j, crossing.k];
    for q in [[1.0, 0.0, 0.0, 0.0], crossing] {
        let start = dir * (r + rc + 0.01);
        let s = sim(1e-3, 300, [0.0; 3])
            + &standing("post", (r, l), 0.0)
            + &capsule(
                "pill",
                rc,
                lc,
                1.0,
                start.into(),
                q,
                (-dir * 0.1).into(),
                [0.0; 3],
                0.0,
            );
        let mut e = engine(&s);
        let mut closest = f64::INFINITY;
        run(&mut e, 300, |e, _| {
            let s = e.state();
            closest = closest.min((s.bodies[1].x - s.bodies[0].x).xy().norm());
        });
        assert!(
            (closest - (r + rc)).abs() < 1e-6,
            "{q:?}: closest {closest}"
        );
    }
}

/// A box's edge meets the true surface too (issue 45, point 2): pressed
/// (zero gravity) against a post's side between two of the prism's
/// corners, with a vertical edge first, then a level edge across the
/// post, it stops with its centre `r + a sqrt 2` from the post's axis (a
/// cube of half side `a` turned 45 degrees about that edge); the prism
/// stopped it up to r (1 - cos(pi / 32)) = 4.8e-4 m nearer. The box's
/// corner on the post's end keeps the flat end's exact height.
#[test]
fn a_boxs_edge_meets_a_cylinders_true_surface() {
    use nalgebra::{Matrix3, Rotation3};
    let (r, l, a) = (0.1, 0.2, 0.03);
    let t = 0.5 * std::f64::consts::TAU / 32.0;
    let dir = Vector3::new(t.cos(), t.sin(), 0.0);
    let across = Vector3::z().cross(&dir);
    // The vertical edge at the cube's local (a, a) towards the post.
    let upright = UnitQuaternion::from_axis_angle(
        &Vector3::z_axis(),
        t + std::f64::consts::PI - std::f64::consts::FRAC_PI_4,
    );
    // The level edge along `across`: local x to `across`, local
    // (0, 1, 1) / sqrt 2 to `-dir`.
    let w = across.cross(&-dir);
    let (ey, ez) = ((-dir - w) / 2f64.sqrt(), (-dir + w) / 2f64.sqrt());
    let crossing = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
        Matrix3::from_columns(&[across, ey, ez]),
    ));
    for (what, q) in [("upright", upright), ("crossing", crossing)] {
        let edge = q * Vector3::new(a, a, 0.0);
        let edge = if what == "upright" {
            edge
        } else {
            q * Vector3::new(0.0, a, a)
        };
        assert!(
            (edge.normalize() + dir).norm() < 1e-12,
            "{what}: the edge faces the post"
        );
        let start = dir * (r + a * 2f64.sqrt() + 0.01);
        let s = sim(1e-3, 300, [0.0; 3])
            + &standing("post", (r, l), 0.0)
            + &cuboid(
                "block",
                [a; 3],
                1.0,
                start.into(),
                [q.w, q.i, q.j, q.k],
                (-dir * 0.1).into(),
                [0.0; 3],
                0.0,
            );
        let mut e = engine(&s);
        let mut closest = f64::INFINITY;
        run(&mut e, 300, |e, r| {
            assert!(r.error.is_none(), "{what}: {:?}", r.error);
            let s = e.state();
            closest = closest.min((s.bodies[1].x - s.bodies[0].x).xy().norm());
        });
        let want = r + a * 2f64.sqrt();
        assert!(
            (closest - want).abs() < 1e-6,
            "{what}: closest {closest}, {want} wanted"
        );
    }
    // A cube on a standing can's end, turned so that no rim point lies
    // over its bottom face's outline... its corners on the flat end.
    let s = sim(1e-3, 1000, [0.0, 0.0, -G])
        + FLOOR
        + &standing("can", (r, l), l)
        + &cuboid(
            "block",
            [a; 3],
            1.0,
            [0.0, 0.0, 2.0 * l + a],
            [1.0, 0.0, 0.0, 0.0],
            [0.0; 3],
            [0.0; 3],
            0.5,
        );
    let mut e = engine(&s);
    run(&mut e, 1000, |_, r| {
        assert!(r.error.is_none(), "{:?}", r.error)
    });
    let z = e.state().bodies[1].x.z;
    assert!((z - (2.0 * l + a)).abs() < 1e-6, "the cube at {z}");
}

/// Two cylinders' round sides meet at their true radii (issue 45, point
/// 2): a can pressed (zero gravity) against a post between two of the
/// prisms' corners, crossed (lying across) and side by side (upright, on
/// two points: the ends of the sides' overlap), stops with its axis
/// `r + r2` from the post's (the prisms: up to 4.8e-4 + 2.4e-4 m nearer);
/// a can stacked on another's end still rests on its rim at `2 l + l2`,
/// also when started sunk 50 um into it.
#[test]
fn two_cylinders_meet_at_their_true_sides() {
    let (r, l, r2, l2) = (0.1, 0.2, 0.05, 0.08);
    let t = 0.5 * std::f64::consts::TAU / 32.0;
    let dir = Vector3::new(t.cos(), t.sin(), 0.0);
    let across = Vector3::z().cross(&dir);
    let lying = UnitQuaternion::rotation_between(&Vector3::z(), &across).expect("a turn");
    for (what, q) in [
        ("crossed", lying),
        ("side by side", UnitQuaternion::identity()),
    ] {
        let start = dir * (r + r2 + 0.01);
        let s = sim(1e-3, 300, [0.0; 3])
            + &standing("post", (r, l), 0.0)
            + &cylinder(
                "can",
                (r2, l2),
                start.into(),
                [q.w, q.i, q.j, q.k],
                ((-dir * 0.1).into(), [0.0; 3]),
            );
        let mut e = engine(&s);
        let (mut closest, mut points) = (f64::INFINITY, 0);
        run(&mut e, 300, |e, r| {
            assert!(r.error.is_none(), "{what}: {:?}", r.error);
            let s = e.state();
            closest = closest.min((s.bodies[1].x - s.bodies[0].x).xy().norm());
            points = points.max(
                e.impulses()
                    .iter()
                    .filter(|i| i.kind == ImpulseKind::Normal)
                    .count(),
            );
        });
        assert!(
            (closest - (r + r2)).abs() < 1e-6,
            "{what}: closest {closest}, {} wanted",
            r + r2
        );
        let want = if what == "crossed" { 1 } else { 2 };
        assert_eq!(points, want, "{what}: touching on {points} points");
    }
    // Started on the end, and sunk 50 um into it (its axis then inside
    // the other's span: the sides must not be taken for the contact).
    for sunk in [0.0, 5e-5] {
        let s = sim(1e-3, 1000, [0.0, 0.0, -G])
            + FLOOR
            + &standing("can", (r, l), l)
            + &standing("top", (r2, l2), 2.0 * l + l2 - sunk);
        let mut e = engine(&s);
        run(&mut e, 1000, |_, r| {
            assert!(r.error.is_none(), "{:?}", r.error)
        });
        let z = e.state().bodies[1].x.z;
        assert!(
            (z - (2.0 * l + l2)).abs() < 1e-6,
            "sunk {sunk}: the top can at {z}"
        );
    }
}

/// A box 0.6 x 0.6 x 0.2 on the floor, its top at z = 0.2: a table.
fn table() -> String {
    cuboid(
        "table",
        [0.3, 0.3, 0.1],
        10.0,
        [0.0, 0.0, 0.1],
        [1.0, 0.0, 0.0, 0.0],
        [0.0; 3],
        [0.0; 3],
        0.5,
    )
}

/// A cylinder standing on a box (its prism against the box) rests still,
/// and one tipped over lies on its side on the floor: it ends with its
/// axis level and its centre r above the floor (within the prism's 0.5 %
/// only where it touches the box, not the floor).
#[test]
fn a_cylinder_stands_on_a_box_and_a_tipped_one_lies_on_the_floor() {
    let (r, l) = (0.05, 0.1);
    let table = table();
    let tipped = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 1.2);
    let q = [tipped.w, tipped.i, tipped.j, tipped.k];
    let s = sim(1e-3, 3000, [0.0, 0.0, -G])
        + FLOOR
        + &table
        + &standing("can", (r, l), 0.2 + l)
        + &cylinder("log", (r, l), [1.0, 0.0, l + 0.01], q, ([0.0; 3], [0.0; 3]));
    let mut e = engine(&s);
    run(&mut e, 3000, |_, _| {});
    let st = e.state();
    let can = st.bodies[1];
    assert!((can.x.z - (0.2 + l)).abs() < 1e-4, "the can at {}", can.x.z);
    assert!(can.v.norm() < 1e-6, "the can moves at {}", can.v);
    let log = st.bodies[2];
    let axis = log.q * Vector3::z();
    assert!(axis.z.abs() < 1e-6, "the log's axis {axis}");
    assert!((log.x.z - r).abs() < 1e-6, "the log at {}", log.x.z);
}

/// Lying on a box (a table) it rests on its true side, not its prism's:
/// the centre r above the table to the solver's tolerance, where the
/// prism would settle on a flat r (1 - cos(pi / 32)) = 2.4e-4 m lower (or
/// on an edge between). Turned about its own axis by a little, so that no
/// flat of the prism is level. And standing on a convex hull's face (a
/// slab given by its corners) it rests at l above it.
#[test]
fn a_cylinder_lies_on_a_box_and_stands_on_a_hull_at_its_true_size() {
    let (r, l) = (0.05, 0.1);
    let table = table();
    // Axis along world y (a quarter turn about x), then 0.05 rad about it.
    let lying = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.05)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2);
    let q = [lying.w, lying.i, lying.j, lying.k];
    // A slab 0.6 x 0.6 x 0.1 as a hull of its corners (inertia given: a
    // hull needs one).
    let slab = "[[body]]\nname = \"slab\"\nmass = 10.0\ninertia = [0.3083, 0.3083, 0.6, 0.0, 0.0, 0.0]\n\
        position = [1.0, 0.0, 0.05]\nfriction = 0.5\n[[body.shape]]\nhull = [[-0.3, -0.3, -0.05], \
        [0.3, -0.3, -0.05], [0.3, 0.3, -0.05], [-0.3, 0.3, -0.05], [-0.3, -0.3, 0.05], [0.3, -0.3, 0.05], \
        [0.3, 0.3, 0.05], [-0.3, 0.3, 0.05]]\n\n";
    let s = sim(1e-3, 2000, [0.0, 0.0, -G])
        + FLOOR
        + &table
        + &cylinder("log", (r, l), [0.0, 0.0, 0.2 + r], q, ([0.0; 3], [0.0; 3]))
        + slab
        + &cylinder(
            "can",
            (r, l),
            [1.0, 0.0, 0.1 + l],
            [1.0, 0.0, 0.0, 0.0],
            ([0.0; 3], [0.0; 3]),
        );
    let mut e = engine(&s);
    let mut most = [0usize; 2];
    run(&mut e, 2000, |e, _| {
        for (k, body) in [1usize, 3].into_iter().enumerate() {
            let n = e
                .impulses()
                .iter()
                .filter(|i| i.kind == ImpulseKind::Normal)
                .filter(|i| i.a == Party::Body(body) || i.b == Party::Body(body))
                .count();
            most[k] = most[k].max(n);
        }
    });
    let st = e.state();
    let log = st.bodies[1];
    let axis = log.q * Vector3::z();
    assert!(axis.z.abs() < 1e-6, "the log's axis {axis}");
    assert!((log.x.z - (0.2 + r)).abs() < 1e-6, "the log at {}", log.x.z);
    assert!(log.v.norm() < 1e-6, "the log moves at {}", log.v);
    let can = st.bodies[3];
    assert!((can.x.z - (0.1 + l)).abs() < 1e-6, "the can at {}", can.x.z);
    assert!(can.v.norm() < 1e-6, "the can moves at {}", can.v);
    // Each on two points or more with an impulse: the log on its side's
    // line (one point per end), the can on its rim (two opposite points
    // already carry it; Lemke's answer may leave the others at zero).
    assert!(most[0] >= 2 && most[1] >= 2, "contacts {most:?}");
}
