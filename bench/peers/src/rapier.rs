//! Rapier (rapier3d-f64) on the cases: the scene built as a Rapier user
//! would, with Rapier's default integration parameters.

use cosim_bench::accuracy::{median_run_time, no_figure, Point, Trajectory};
use cosim_bench::cases::{CaseId, Pose, Sample, Scorer};
use cosim_shared::{JointKind, Scene, ShapeDesc};
use rapier3d_f64::na::Unit;
use rapier3d_f64::prelude::*;
use std::time::Instant;

pub const VERSION: &str = "0.36";

fn vec3(a: [f64; 3]) -> Vector {
    Vector::new(a[0], a[1], a[2])
}

/// Our `[w, x, y, z]` orientation as Rapier's rotation.
fn rotation(q: [f64; 4]) -> Rotation {
    Rotation::from_xyzw(q[1], q[2], q[3], q[0])
}

pub(crate) struct World {
    pub(crate) world: PhysicsWorld,
    pub(crate) bodies: Vec<(RigidBodyHandle, ColliderHandle)>,
    planes: Vec<ColliderHandle>,
    names: Vec<String>,
    plane_names: Vec<String>,
}

/// The scene as a Rapier user would build it; `sleep`: Rapier's own
/// sleeping (its default) on every body, else off.
pub(crate) fn build(scene: &Scene, sleep: bool) -> World {
    let mut world = PhysicsWorld {
        gravity: vec3(scene.sim.gravity),
        ..PhysicsWorld::default()
    };
    world.integration_parameters.dt = scene.sim.dt;
    // Spheres collide with planes (group 2) and, unless the scene says
    // otherwise, with each other (group 1).
    let sphere_groups = if scene.sim.sphere_contacts {
        InteractionGroups::all()
    } else {
        InteractionGroups::new(Group::GROUP_1, Group::GROUP_2, InteractionTestMode::And)
    };
    let mut planes = Vec::new();
    for p in &scene.planes {
        let n = vec3(p.normal).normalize();
        let body = world.insert_body(RigidBodyBuilder::fixed().translation(vec3(p.point)));
        let c = ColliderBuilder::halfspace(Unit::new_unchecked(n))
            .friction(p.friction)
            .restitution(p.restitution)
            .friction_combine_rule(CoefficientCombineRule::Min)
            .restitution_combine_rule(CoefficientCombineRule::Max)
            .collision_groups(InteractionGroups::new(
                Group::GROUP_2,
                Group::ALL,
                InteractionTestMode::And,
            ));
        planes.push(world.insert_collider(c, Some(body)));
    }
    let mut bodies = Vec::new();
    for b in &scene.bodies {
        let q = b.orientation;
        let rb = RigidBodyBuilder::dynamic()
            .translation(vec3(b.position))
            .rotation(rotation(q).to_scaled_axis())
            .linvel(vec3(b.velocity))
            .angvel(vec3(b.angular_velocity))
            .can_sleep(sleep);
        let c = match b.shape() {
            ShapeDesc::Sphere { radius } => ColliderBuilder::ball(radius),
            // Rapier's capsule along z, as ours: half its segment, radius.
            ShapeDesc::Capsule {
                radius,
                half_length,
            } => ColliderBuilder::capsule_z(half_length, radius),
            ShapeDesc::Box { half_extents: h } => ColliderBuilder::cuboid(h[0], h[1], h[2]),
            // A body's own fields give no hull (only `[[body.shape]]`).
            ShapeDesc::Hull { .. } | ShapeDesc::Cylinder { .. } => {
                unreachable!("a body's own shape is never a hull or a cylinder")
            }
        }
        .mass(b.mass)
        .friction(b.friction)
        .restitution(b.restitution)
        .friction_combine_rule(CoefficientCombineRule::Min)
        .restitution_combine_rule(CoefficientCombineRule::Max)
        .collision_groups(sphere_groups);
        let (h, ch) = world.insert(rb, c);
        world.bodies[h].add_force(vec3(b.force), true);
        bodies.push((h, ch));
    }
    let ground = world.insert_body(RigidBodyBuilder::fixed());
    let find = |n: &str| scene.bodies.iter().position(|b| b.name == n);
    for j in &scene.joints {
        let anchor = vec3(j.anchor);
        // A world vector in body i's frame (the world's: itself).
        let into = |i: Option<usize>, v: Vector| match i {
            Some(i) => rotation(scene.bodies[i].orientation).inverse() * v,
            None => v,
        };
        let local = |i: Option<usize>| {
            let origin = i.map_or(Vector::ZERO, |i| vec3(scene.bodies[i].position));
            into(i, anchor - origin)
        };
        let (a, b) = (find(&j.body_a), find(&j.body_b));
        let ha = a.map_or(ground, |i| bodies[i].0);
        let hb = b.map_or(ground, |i| bodies[i].0);
        match (j.kind, j.axis) {
            (JointKind::Revolute, Some(axis)) => {
                // A hinge: Rapier's revolute axes locked, its free
                // rotation about each body's local x set to our axis.
                let axis = vec3(axis).normalize();
                let joint = GenericJointBuilder::new(JointAxesMask::LOCKED_REVOLUTE_AXES)
                    .local_anchor1(local(a))
                    .local_anchor2(local(b))
                    .local_axis1(into(a, axis))
                    .local_axis2(into(b, axis))
                    .contacts_enabled(j.collide);
                world.impulse_joints.insert(ha, hb, joint, true);
            }
            (JointKind::Spherical, _) => {
                let joint = SphericalJointBuilder::new()
                    .local_anchor1(local(a))
                    .local_anchor2(local(b))
                    .contacts_enabled(j.collide);
                world.impulse_joints.insert(ha, hb, joint, true);
            }
            (kind, _) => panic!("the peers' cases have no {kind:?} joint"),
        }
        // Joint torque: +torque on body_b, -torque on body_a, held.
        let tau = vec3(j.torque);
        world.bodies[hb].add_torque(tau, true);
        if a.is_some() {
            world.bodies[ha].add_torque(-tau, true);
        }
    }
    World {
        world,
        bodies,
        planes,
        names: scene.bodies.iter().map(|b| b.name.clone()).collect(),
        plane_names: scene.planes.iter().map(|p| p.name.clone()).collect(),
    }
}

fn sample(w: &World, t: f64, out: &mut Sample) {
    out.t = t;
    out.bodies.clear();
    for (h, _) in &w.bodies {
        let b = &w.world.bodies[*h];
        let (x, q, v, om) = (b.translation(), b.rotation(), b.linvel(), b.angvel());
        out.bodies.push(Pose {
            x: [x.x, x.y, x.z],
            q: [q.w, q.x, q.y, q.z],
            v: [v.x, v.y, v.z],
            w: [om.x, om.y, om.z],
        });
    }
    out.forces.clear();
    let dt = w.world.integration_parameters.dt;
    for (i, (_, ci)) in w.bodies.iter().enumerate() {
        for (p, cp) in w.planes.iter().enumerate() {
            if let Some(pair) = w.world.narrow_phase.contact_pair(*ci, *cp) {
                let f = pair.total_impulse().length() / dt;
                if f > 0.0 {
                    out.forces
                        .push((format!("{}/{}", w.names[i], w.plane_names[p]), f));
                }
            }
        }
        for (j, (_, cj)) in w.bodies.iter().enumerate().skip(i + 1) {
            if let Some(pair) = w.world.narrow_phase.contact_pair(*ci, *cj) {
                let f = pair.total_impulse().length() / dt;
                if f > 0.0 {
                    out.forces
                        .push((format!("{}/{}", w.names[i], w.names[j]), f));
                }
            }
        }
    }
}

/// Rapier's points for `case` at step `h` (one setting: the defaults).
pub fn run(case: CaseId, h: f64, reference: Option<&Trajectory>) -> Vec<Point> {
    let scene = match case.scene(h, 8) {
        Ok(s) => s,
        Err(e) => panic!("case scene: {e}"),
    };
    let steps = scene.step_count();
    let mut scorer = Scorer::new(case, &scene, reference.cloned());
    let mut w = build(&scene, false);
    let mut s = Sample::default();
    let mut elapsed = 0.0;
    let mut failure = None;
    for k in 0..steps {
        let t0 = Instant::now();
        w.world.step();
        elapsed += t0.elapsed().as_secs_f64();
        sample(&w, (k + 1) as f64 * h, &mut s);
        if !s.bodies.iter().all(|b| b.x.iter().all(|x| x.is_finite())) {
            failure = Some(format!("step {}: non-finite state", k + 1));
            break;
        }
        scorer.observe(&s);
    }
    let wall = if failure.is_some() {
        elapsed
    } else {
        median_run_time(elapsed, || {
            let mut w = build(&scene, false);
            let t0 = Instant::now();
            for _ in 0..steps {
                w.world.step();
            }
            t0.elapsed().as_secs_f64()
        })
    };
    let score = scorer.finish();
    let failure = no_figure(failure, &score);
    vec![Point {
        engine: "rapier".into(),
        setting: "default (4 iterations)".into(),
        case,
        h,
        steps,
        wall_per_sim_s: wall / case.duration(),
        score,
        failure,
    }]
}
