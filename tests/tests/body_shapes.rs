//! Bodies with several shapes, shapes away from the centre of mass, and
//! bodies with none (issue 45, point 1), against results worked by hand:
//! a shape given by `[[body.shape]]` at the centre is the body's own shape
//! to the bit; a ball hung below its centre of mass falls and bounces as a
//! centred one; a table on four legs rests on them with its weight shared;
//! a body with no shape falls freely through the floor.

use cosim_server::engine::collision::{body_pair, body_plane, Geometry};
use cosim_server::engine::model::Counterpart;
use cosim_server::engine::{Engine, ImpulseKind};
use cosim_tests::*;

const FLOOR: &str = "[[plane]]\nname = \"floor\"\nnormal = [0.0, 0.0, 1.0]\npoint = [0.0, 0.0, 0.0]\nfriction = 0.5\n";

fn engine_of(body: &str, steps: u64) -> Engine {
    engine(&(sim(1e-3, steps, [0.0, 0.0, -G]) + body + FLOOR))
}

/// `[[body.shape]]` at the centre of mass with no offset is the body's
/// own shape: the same contacts, the same bits, step after step.
#[test]
fn a_centred_listed_shape_is_the_bodys_own_to_the_bit() {
    let own = "[[body]]\nname = \"b\"\nmass = 2.0\nposition = [0.0, 0.0, 0.3]\n\
               velocity = [0.4, 0.0, 0.0]\nangular_velocity = [0.0, 3.0, 1.0]\n\
               friction = 0.5\nhalf_extents = [0.1, 0.2, 0.05]\n";
    let listed = "[[body]]\nname = \"b\"\nmass = 2.0\nposition = [0.0, 0.0, 0.3]\n\
               velocity = [0.4, 0.0, 0.0]\nangular_velocity = [0.0, 3.0, 1.0]\n\
               friction = 0.5\n[[body.shape]]\nhalf_extents = [0.1, 0.2, 0.05]\n";
    let (mut a, mut b) = (engine_of(own, 600), engine_of(listed, 600));
    for _ in 0..600 {
        assert!(a.step().ok() && b.step().ok());
        assert_eq!(a.state().bodies[0].x, b.state().bodies[0].x);
        assert_eq!(a.state().bodies[0].q, b.state().bodies[0].q);
    }
}

/// A ball hung 0.3 m below the centre of mass, straight down: the contact
/// force passes through the centre of mass, so the ball falls, lands and
/// rests as a centred ball 0.3 m lower does (to round-off: the lever arm
/// is summed in another order).
#[test]
fn a_ball_below_the_centre_of_mass_lands_as_a_centred_one() {
    let hung = "[[body]]\nname = \"b\"\nmass = 1.0\nposition = [0.0, 0.0, 0.8]\n\
                inertia = [0.01, 0.01, 0.01, 0.0, 0.0, 0.0]\nfriction = 0.5\n\
                [[body.shape]]\nradius = 0.1\nposition = [0.0, 0.0, -0.3]\n";
    let centred = "[[body]]\nname = \"b\"\nmass = 1.0\nposition = [0.0, 0.0, 0.5]\n\
                   inertia = [0.01, 0.01, 0.01, 0.0, 0.0, 0.0]\nfriction = 0.5\n\
                   radius = 0.1\n";
    let (mut a, mut b) = (engine_of(hung, 1000), engine_of(centred, 1000));
    let mut touched = 0;
    for _ in 0..1000 {
        let (ra, rb) = (a.step(), b.step());
        assert!(ra.ok() && rb.ok());
        touched += usize::from(ra.active_contacts > 0);
        let (xa, xb) = (a.state().bodies[0].x, b.state().bodies[0].x);
        assert!((xa.z - 0.3 - xb.z).abs() < 1e-12, "{xa} {xb}");
        assert!(xa.x.abs() < 1e-12 && xa.y.abs() < 1e-12, "{xa}");
        assert!(a.state().bodies[0].w.norm() < 1e-9);
    }
    // It fell 0.4 m (0.29 s) and rests on the floor: its ball touches.
    assert!(touched > 500, "{touched}");
    assert!((a.state().bodies[0].x.z - 0.4).abs() < 1e-4);
}

/// A table: a 0.6 x 0.4 m top and four legs at its corners, its centre of
/// mass above the middle. It rests on its four legs' sixteen corners, the
/// floor carries its weight (sum of normal impulses m g h per step) with
/// no moment about the centre of mass, and it stays still.
#[test]
fn a_table_rests_on_its_four_legs_with_its_weight_shared() {
    let mut text = String::from(
        "[[body]]\nname = \"table\"\nmass = 10.0\nposition = [0.0, 0.0, 0.55]\n\
         inertia = [0.4, 0.6, 0.8, 0.0, 0.0, 0.0]\nfriction = 0.8\n\
         [[body.shape]]\nhalf_extents = [0.3, 0.2, 0.02]\nposition = [0.0, 0.0, 0.2]\n",
    );
    for (x, y) in [(0.27, 0.17), (-0.27, 0.17), (0.27, -0.17), (-0.27, -0.17)] {
        text += &format!(
            "[[body.shape]]\nhalf_extents = [0.02, 0.02, 0.25]\nposition = [{x}, {y}, -0.05]\n"
        );
    }
    // The legs' feet at 0.55 - 0.05 - 0.25 = 0.25 m: it falls 0.25 m.
    let mut e = engine_of(&text, 2000);
    let (m, h) = (10.0, 1e-3);
    for _ in 0..2000 {
        assert!(e.step().ok());
    }
    let s = e.state();
    let b = &s.bodies[0];
    assert!((b.x.z - 0.3).abs() < 1e-4, "{}", b.x);
    assert!(b.v.norm() < 1e-6 && b.w.norm() < 1e-6, "{} {}", b.v, b.w);
    // Sixteen contacts, four per leg; the model names each leg's corners
    // apart (the shape's number in the feature).
    let mut found: Vec<Geometry> = Vec::new();
    body_plane(e.model(), s, 0, 0, 1e-6, &mut found);
    assert_eq!(found.len(), 16, "{found:?}");
    let mut per_leg = [0.0; 5];
    let mut moment = nalgebra::Vector3::zeros();
    for g in &found {
        let id = e.model().contact_id(g.a, g.b, g.feature);
        assert_eq!(e.model().contact_bodies(id), (0, Counterpart::Plane(0)));
        // Shape k of A against the plane: features from k * slots * per pair.
        let m = e.model();
        let leg = g.feature / (m.features / m.shape_slots);
        assert!((1..=4).contains(&leg), "{}", g.feature);
        let p: f64 = e
            .impulses()
            .iter()
            .filter(|i| i.kind == ImpulseKind::Normal && i.index == id)
            .map(|i| i.impulse.z)
            .sum();
        per_leg[leg] += p;
        moment += g.r_a.cross(&nalgebra::Vector3::new(0.0, 0.0, p));
    }
    let total: f64 = per_leg.iter().sum();
    assert!((total - m * G * h).abs() < 1e-9 * m * G * h, "{per_leg:?}");
    // How the sixteen corners share it is not unique (the LCP picks a
    // vertex), but at rest the floor's impulses turn the table about its
    // centre of mass no more than round-off.
    assert!(moment.norm() < 1e-9 * total, "{moment} {per_leg:?}");
    // Contacts ascend by id (the canonical order), features distinct.
    let ids: Vec<usize> = found
        .iter()
        .map(|g| e.model().contact_id(g.a, g.b, g.feature))
        .collect();
    assert!(ids.windows(2).all(|w| w[0] < w[1]), "{ids:?}");
}

/// A body with no shape (a frame, a sensor) needs its inertia, touches
/// nothing and falls freely: z_k = z_0 - g h^2 k (k + 1) / 2 (the
/// velocity is updated first).
#[test]
fn a_body_with_no_shape_falls_through_everything() {
    let text = "[[body]]\nname = \"frame\"\nmass = 0.5\nposition = [0.0, 0.0, 0.05]\n\
                inertia = [1e-3, 1e-3, 1e-3, 0.0, 0.0, 0.0]\n\
                [[body]]\nname = \"ball\"\nmass = 1.0\nradius = 0.05\nposition = [0.0, 0.0, -0.2]\n";
    let mut e = engine_of(text, 300);
    let (h, z0) = (1e-3, 0.05);
    for k in 1..=300u32 {
        assert!(e.step().ok());
        let want = z0 - G * h * h * f64::from(k) * f64::from(k + 1) / 2.0;
        assert!((e.state().bodies[0].x.z - want).abs() < 1e-12);
    }
    let mut out = Vec::new();
    body_pair(e.model(), e.state(), 0, 1, f64::INFINITY, &mut out);
    assert!(out.is_empty());
    assert_eq!(e.model().bodies[0].bound, 0.0);
}

/// Two dumbbells (two balls on a bar, the bar's own shape a capsule)
/// crossing: each pair of shapes has ids of its own, and the lever arms
/// reach each contact from its body's centre of mass.
#[test]
fn the_contacts_of_two_bodies_of_several_shapes_name_their_shapes() {
    let bell = |name: &str, z: f64, turn: &str| {
        format!(
            "[[body]]\nname = \"{name}\"\nmass = 1.0\nposition = [0.0, 0.0, {z}]\n\
             orientation = {turn}\ninertia = [0.1, 0.1, 0.01, 0.0, 0.0, 0.0]\n\
             [[body.shape]]\nradius = 0.1\nposition = [0.0, 0.0, 0.3]\n\
             [[body.shape]]\nradius = 0.1\nposition = [0.0, 0.0, -0.3]\n\
             [[body.shape]]\nradius = 0.02\nhalf_length = 0.3\n"
        )
    };
    // A along z, B lying along x 0.45 m above A's centre: B's bar and its
    // two balls against A's upper ball.
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let text =
        bell("a", 1.0, "[1.0, 0.0, 0.0, 0.0]") + &bell("b", 1.45, &format!("[{h}, 0.0, {h}, 0.0]"));
    let e = engine_of(&text, 1);
    let mut out = Vec::new();
    body_pair(e.model(), e.state(), 0, 1, 0.05, &mut out);
    // A's upper ball (shape 0) reaches 1.4, B's bar (shape 2) is at 1.45
    // with radius 0.02: gap 0.03. Nothing else is within 5 cm.
    assert_eq!(out.len(), 1, "{out:?}");
    let g = &out[0];
    let slots = e.model().shape_slots;
    assert_eq!(slots, 3);
    let per_pair = e.model().features / (slots * slots);
    assert_eq!(g.feature / per_pair, 2);
    assert!((g.gap - 0.03).abs() < 1e-12, "{g:?}");
    let x = |i: usize| e.state().bodies[i].x;
    assert!((x(0) + g.r_a - nalgebra::Vector3::new(0.0, 0.0, 1.4)).norm() < 1e-12);
    assert!((x(1) + g.r_b - nalgebra::Vector3::new(0.0, 0.0, 1.43)).norm() < 1e-12);
    let id = e.model().contact_id(0, Counterpart::Body(1), g.feature);
    assert_eq!(e.model().contact_feature(id), g.feature);
}

/// The scene as run (`scene.toml` of every run) keeps the shapes: written
/// and read back, the same scene.
#[test]
fn a_scene_of_listed_shapes_writes_and_reads_back() {
    let text = sim(1e-3, 10, [0.0, 0.0, -G])
        + "[[body]]\nname = \"b\"\nmass = 1.0\nposition = [0.0, 0.0, 1.0]\n\
           inertia = [0.1, 0.1, 0.1, 0.0, 0.0, 0.0]\n\
           [[body.shape]]\nradius = 0.1\nposition = [0.0, 0.0, 0.3]\n\
           [[body.shape]]\nhalf_extents = [0.1, 0.1, 0.1]\norientation = [0.0, 1.0, 0.0, 0.0]\n"
        + FLOOR;
    let scene = cosim_shared::Scene::parse(&text, "t.toml").expect("parses");
    let back = toml::to_string(&scene).expect("writes");
    let again = cosim_shared::Scene::parse(&back, "back.toml").expect("reads back");
    assert_eq!(scene, again);
    assert_eq!(again.bodies[0].shape.len(), 2);
}

/// What a body's shapes may not be, each refused with the field named.
#[test]
fn bad_shape_lists_are_refused_by_field() {
    let body = |extra: &str| {
        sim(1e-3, 10, [0.0, 0.0, -G])
            + "[[body]]\nname = \"b\"\nmass = 1.0\nposition = [0.0, 0.0, 1.0]\n"
            + extra
    };
    for (extra, field, words) in [
        (
            "radius = 0.1\n[[body.shape]]\nradius = 0.1\n",
            "body \"b\".shape",
            "not both",
        ),
        (
            "[[body.shape]]\nradius = 0.1\nposition = [0.0, 0.0, 0.2]\n",
            "body \"b\".inertia",
            "is missing",
        ),
        ("", "body \"b\".radius", "is missing"),
        (
            "inertia = [0.1, 0.1, 0.1, 0.0, 0.0, 0.0]\n[[body.shape]]\nradius = 0.1\n[[body.shape]]\nhalf_length = 0.1\n",
            "body \"b\".shape[1].radius",
            "capsule",
        ),
        (
            "inertia = [0.1, 0.1, 0.1, 0.0, 0.0, 0.0]\n[[body.shape]]\nradius = 0.1\norientation = [2.0, 0.0, 0.0, 0.0]\n",
            "body \"b\".shape[0].orientation",
            "",
        ),
    ] {
        let e = cosim_shared::Scene::parse(&body(extra), "t.toml").expect_err(extra);
        assert_eq!(e.field, field, "{extra}: {e}");
        assert!(e.message.contains(words), "{extra}: {e}");
    }
}
