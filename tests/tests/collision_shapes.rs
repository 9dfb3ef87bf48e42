//! The contact generation of boxes and capsules (issue 17, point 2)
//! against geometry worked by hand: where each pair touches, its gap,
//! normal and lever arms, how many points and which features, and the
//! ids that name them back.

use cosim_server::engine::collision::{body_pair, body_plane, Geometry};
use cosim_server::engine::model::Counterpart;
use cosim_server::engine::{Engine, Model};
use cosim_tests::*;
use nalgebra::{UnitQuaternion, Vector3};

const ID: [f64; 4] = [1.0, 0.0, 0.0, 0.0];

/// `[w, x, y, z]` of a turn by `angle` about `axis`.
fn turn(axis: [f64; 3], angle: f64) -> [f64; 4] {
    let q =
        UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(Vector3::from(axis)), angle);
    [q.w, q.i, q.j, q.k]
}

/// A 1 kg box at rest, turned by `q`.
fn block(name: &str, half: [f64; 3], x: [f64; 3], q: [f64; 4]) -> String {
    cuboid(name, half, 1.0, x, q, [0.0; 3], [0.0; 3], 0.5)
}

/// A 1 kg capsule at rest, turned by `q`.
fn pill(name: &str, r: f64, l: f64, x: [f64; 3], q: [f64; 4]) -> String {
    capsule(name, r, l, 1.0, x, q, [0.0; 3], [0.0; 3], 0.5)
}

/// The engine of two bodies (given as scene text) above a floor.
fn two(a: &str, b: &str) -> Engine {
    engine(
        &(sim(1e-3, 1, [0.0, 0.0, -G])
            + a
            + b
            + &plane("floor", [0.0, 0.0, 1.0], [0.0; 3], 0.5, 0.0)),
    )
}

fn pair(e: &Engine) -> Vec<Geometry> {
    let mut out = Vec::new();
    body_pair(e.model(), e.state(), 0, 1, f64::INFINITY, &mut out);
    out
}

/// Each contact's two surface points, rebuilt from its lever arms, lie
/// `gap` apart along its normal (from B towards A), and its `point` midway.
fn consistent(e: &Engine, g: &Geometry) {
    let x = |i: usize| e.state().bodies[i].x;
    let on_a = x(g.a) + g.r_a;
    let on_b = match g.b {
        Counterpart::Body(j) => x(j) + g.r_b,
        _ => return,
    };
    let d = on_a - on_b;
    assert!((d.dot(&g.normal) - g.gap).abs() < 1e-12, "{g:?}");
    assert!((d - g.normal * g.gap).norm() < 1e-12, "{g:?}");
    assert!((g.point - (on_a + on_b) / 2.0).norm() < 1e-12, "{g:?}");
    assert!((g.normal.norm() - 1.0).abs() < 1e-12);
}

/// A 0.2 m cube resting on a 1 m wide slab, 1 mm above it: four contacts
/// at the cube's lower corners, each 1 mm apart, normal up (B, the slab,
/// towards A, the cube: the slab is body 1 here, so the pair is flipped).
#[test]
fn a_box_on_a_box_touches_at_its_four_corners() {
    let e = two(
        &block("cube", [0.1; 3], [0.3, 0.2, 0.301], ID),
        &block("slab", [0.5, 0.5, 0.1], [0.0, 0.0, 0.1], ID),
    );
    let g = pair(&e);
    assert_eq!(g.len(), 4, "{g:?}");
    let features: Vec<usize> = g.iter().map(|c| c.feature).collect();
    assert_eq!(features, [0, 1, 2, 3]);
    for c in &g {
        consistent(&e, c);
        assert_eq!((c.a, c.b), (0, Counterpart::Body(1)));
        assert!((c.gap - 1e-3).abs() < 1e-12, "{c:?}");
        assert!((c.normal - Vector3::z()).norm() < 1e-12);
        let corner = e.state().bodies[0].x + c.r_a;
        assert!((corner.x - 0.3).abs() - 0.1 < 1e-12 && (corner.z - 0.201).abs() < 1e-12);
    }
    // The four distinct corners.
    let mut corners: Vec<(i64, i64)> = g
        .iter()
        .map(|c| {
            let p = e.state().bodies[0].x + c.r_a;
            ((p.x * 1e6).round() as i64, (p.y * 1e6).round() as i64)
        })
        .collect();
    corners.sort_unstable();
    corners.dedup();
    assert_eq!(corners.len(), 4);
}

/// Two long bars crossed at right angles, each turned 45 degrees about its
/// own length so that an edge faces the other: they touch edge to edge at
/// one point, the gap the centres' distance less each bar's half
/// diagonal.
#[test]
fn crossed_boxes_touch_edge_to_edge() {
    let (s, h) = (0.05f64, 0.5);
    let reach = s * 2f64.sqrt();
    let gap = 0.01;
    let e = two(
        &block(
            "upper",
            [h, s, s],
            [0.0, 0.0, 1.0 + 2.0 * reach + gap],
            turn([1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_4),
        ),
        &block(
            "lower",
            [s, h, s],
            [0.0, 0.0, 1.0],
            turn([0.0, 1.0, 0.0], std::f64::consts::FRAC_PI_4),
        ),
    );
    let g = pair(&e);
    assert_eq!(g.len(), 1, "{g:?}");
    consistent(&e, &g[0]);
    assert!((g[0].gap - gap).abs() < 1e-12, "{:?}", g[0]);
    assert!((g[0].normal - Vector3::z()).norm() < 1e-12);
    assert!((g[0].point - Vector3::new(0.0, 0.0, 1.0 + reach + gap / 2.0)).norm() < 1e-12);
}

/// Capsules: lying along each other they touch along a line (its two
/// ends, features 0 and 1, where the shorter's segment ends); crossed,
/// at one point, the segments' distance less both radii.
#[test]
fn capsules_touch_along_a_line_or_at_a_point() {
    let lying = turn([0.0, 1.0, 0.0], std::f64::consts::FRAC_PI_2);
    let long = pill("long", 0.05, 0.5, [0.0, 0.0, 0.05], lying);
    let e = two(&long, &pill("short", 0.04, 0.2, [0.1, 0.0, 0.139], lying));
    let g = pair(&e);
    assert_eq!(g.iter().map(|c| c.feature).collect::<Vec<_>>(), [0, 1]);
    for c in &g {
        consistent(&e, c);
        assert!((c.gap - (0.089 - 0.09)).abs() < 1e-12, "{c:?}");
        // A = long below, so the normal points down, from B to A.
        assert!((c.normal + Vector3::z()).norm() < 1e-12);
    }
    let xs: Vec<f64> = g.iter().map(|c| c.point.x).collect();
    assert!(
        (xs[0] + 0.1).abs() < 1e-12 && (xs[1] - 0.3).abs() < 1e-12,
        "{xs:?}"
    );

    let across = turn([1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_2);
    let e = two(&long, &pill("cross", 0.04, 0.2, [0.2, 0.05, 0.2], across));
    let g = pair(&e);
    assert_eq!(g.len(), 1, "{g:?}");
    consistent(&e, &g[0]);
    assert!((g[0].gap - (0.15 - 0.09)).abs() < 1e-12, "{:?}", g[0]);
    assert!((g[0].point - Vector3::new(0.2, 0.0, 0.05 + 0.05 + 0.03)).norm() < 1e-12);
}

/// A capsule lying on a box's top face rests on both its ends (features
/// 0 and 1); laid across the box's edge, tilted down past it, it touches
/// the edge at a point inside its segment (feature 2) too.
#[test]
fn a_capsule_on_a_box_rests_on_its_ends_or_on_an_edge() {
    let slab = block("slab", [0.2, 0.2, 0.1], [0.0, 0.0, 0.1], ID);
    let lying = turn([0.0, 1.0, 0.0], std::f64::consts::FRAC_PI_2);
    let e = two(&pill("pill", 0.05, 0.1, [0.0, 0.0, 0.25], lying), &slab);
    let g = pair(&e);
    assert_eq!(g.iter().map(|c| c.feature).collect::<Vec<_>>(), [0, 1]);
    for c in &g {
        consistent(&e, c);
        assert!((c.gap - 0.0).abs() < 1e-12 && (c.normal - Vector3::z()).norm() < 1e-12);
    }
    // Over the edge at x = 0.2, its axis tilted 0.3 rad down towards +x
    // and passing 0.06 m above the edge there.
    let tilt = 0.3f64;
    let q = turn([0.0, 1.0, 0.0], std::f64::consts::FRAC_PI_2 + tilt);
    let at = Vector3::new(0.2, 0.0, 0.2) + Vector3::new(tilt.sin(), 0.0, tilt.cos()) * 0.06;
    let e = two(&pill("pill", 0.05, 0.2, at.into(), q), &slab);
    let g = pair(&e);
    let edge = g
        .iter()
        .find(|c| c.feature == 2)
        .expect("the edge's contact");
    consistent(&e, edge);
    assert!((edge.gap - 0.01).abs() < 1e-9, "{edge:?}");
    let on_b = e.state().bodies[1].x + edge.r_b;
    assert!(
        (on_b - Vector3::new(0.2, 0.0, 0.2)).norm() < 1e-9,
        "{on_b:?}"
    );
}

/// A sphere whose centre sank inside a box is pushed out through the
/// nearest face, its gap the depth less its radius; a sphere beside a
/// box's corner touches the corner.
#[test]
fn a_sphere_meets_a_box_at_its_nearest_surface_point() {
    let slab = block("slab", [0.2, 0.3, 0.1], [0.0, 0.0, 0.1], ID);
    let e = two(
        &sphere("ball", 0.05, 1.0, [0.1, 0.0, 0.18], [0.0; 3], 0.5, 0.0),
        &slab,
    );
    let g = pair(&e);
    assert_eq!(g.len(), 1);
    consistent(&e, &g[0]);
    assert!((g[0].gap - (-0.02 - 0.05)).abs() < 1e-12, "{:?}", g[0]);
    assert!((g[0].normal - Vector3::z()).norm() < 1e-12);
    let d = 0.03 / 3f64.sqrt();
    let e = two(
        &sphere(
            "ball",
            0.01,
            1.0,
            [0.2 + d, 0.3 + d, 0.2 + d],
            [0.0; 3],
            0.5,
            0.0,
        ),
        &slab,
    );
    let g = pair(&e);
    consistent(&e, &g[0]);
    assert!((g[0].gap - 0.02).abs() < 1e-12, "{:?}", g[0]);
    assert!((g[0].normal - Vector3::repeat(1.0 / 3f64.sqrt())).norm() < 1e-12);
}

/// A box on a plane lists its four lowest vertices (features: their
/// numbers), a capsule its two ends; the ids name pair and feature back,
/// and ascend.
#[test]
fn plane_contacts_are_the_lowest_vertices_and_ids_name_them_back() {
    let tilted = turn([1.0, 1.0, 0.0], 0.1);
    let e = two(
        &block("box", [0.1, 0.2, 0.3], [0.0, 0.0, 0.5], tilted),
        &pill("pill", 0.05, 0.2, [1.0, 0.0, 0.5], ID),
    );
    let (m, s): (&Model, _) = (e.model(), e.state());
    let mut out = Vec::new();
    body_plane(m, s, 0, 0, f64::INFINITY, &mut out);
    assert_eq!(out.len(), 4);
    let low = |g: &Geometry| s.bodies[0].x.z + g.r_a.z;
    let highest_listed = out.iter().map(low).fold(f64::MIN, f64::max);
    for k in 0..8 {
        let v = s.bodies[0].x.z
            + s.bodies[0]
                .q
                .transform_vector(&cosim_server::engine::collision::vertex(
                    &Vector3::new(0.1, 0.2, 0.3),
                    k,
                ))
                .z;
        let listed = out.iter().any(|g| g.feature == k);
        assert!(listed || v >= highest_listed, "vertex {k} at {v} left out");
        if let Some(g) = out.iter().find(|g| g.feature == k) {
            assert!((g.gap - v).abs() < 1e-12);
        }
    }
    body_plane(m, s, 1, 0, f64::INFINITY, &mut out);
    let pill: Vec<&Geometry> = out.iter().filter(|g| g.a == 1).collect();
    assert_eq!(pill.iter().map(|g| g.feature).collect::<Vec<_>>(), [0, 1]);
    assert!((pill[0].gap - (0.5 - 0.2 - 0.05)).abs() < 1e-12);
    assert!((pill[1].gap - (0.5 + 0.2 - 0.05)).abs() < 1e-12);
    let mut last = None;
    for g in &out {
        let id = m.contact_id(g.a, g.b, g.feature);
        assert_eq!(
            (m.contact_bodies(id), m.contact_feature(id)),
            ((g.a, g.b), g.feature)
        );
        assert!(last < Some(id), "ids ascend");
        last = Some(id);
    }
    assert_eq!(m.features, cosim_shared::MAX_FEATURES);
    assert_eq!(m.potential_contacts(), (2 + 1) * m.features);
}
