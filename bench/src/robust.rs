//! `bench robust`: seeded random small scenes built to be hard for the
//! solve (corners and creases, spheres, boxes and capsules exactly touching or overlapping by
//! up to a few mm, joints to the world whose pin may lie inside a friction
//! cone, mu up to 1), each stepped and checked:
//!
//! - no failed step;
//! - the midpoint energy never above its start plus the input's work plus
//!   what the engine declares its stabilisation may add (see
//!   [`Check::energy`]);
//! - no body faster than that energy explains.
//!
//! The tests run 500 scenes of 20 steps (`tests/tests/robust.rs`); the
//! command runs as many as asked.

use crate::text::{joint, plane, sphere};
use cosim_engine::measure::energy;
use cosim_engine::model::state::asleep;
use cosim_engine::{Engine, LadderCounts, Model};
use cosim_shared::{Scene, SolverChoice};

/// xorshift64*: a small deterministic generator, enough for scene sampling.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        // A zero state stays zero: mix the seed first (splitmix64).
        let mut z = seed.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        Rng((z ^ (z >> 31)) | 1)
    }
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    pub fn pick<T: Copy>(&mut self, xs: &[T]) -> T {
        xs[((self.uniform() * xs.len() as f64) as usize).min(xs.len() - 1)]
    }
    pub fn below(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n.saturating_sub(1))
    }
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}

fn along(p: [f64; 3], n: [f64; 3], d: f64) -> [f64; 3] {
    [p[0] + d * n[0], p[1] + d * n[1], p[2] + d * n[2]]
}

/// A plane through the origin region: `(normal, point)`.
type PlaneDesc = ([f64; 3], [f64; 3]);

/// The planes of a scene: a floor, then up to four more chosen among
/// walls (90 deg corners with the floor and each other) and tilted planes
/// (creases of 30 to 150 deg with the floor).
fn planes(rng: &mut Rng) -> Vec<PlaneDesc> {
    let mut out = vec![([0.0, 0.0, 1.0], [0.0, 0.0, 0.0])];
    let extra = rng.below(5);
    let walls = [
        ([1.0, 0.0, 0.0], [-0.2, 0.0, 0.0]),
        ([0.0, 1.0, 0.0], [0.0, -0.2, 0.0]),
        ([-1.0, 0.0, 0.0], [0.2, 0.0, 0.0]),
        ([0.0, -1.0, 0.0], [0.0, 0.2, 0.0]),
    ];
    for k in 0..extra {
        if rng.uniform() < 0.6 {
            out.push(walls[k % 4]);
        } else {
            // A tilted plane through a point on the floor: its normal leans
            // from vertical by 30..80 deg (a crease of 100..150 deg with the
            // floor), towards a random azimuth.
            let tilt = rng.range(30f64.to_radians(), 80f64.to_radians());
            let az = rng.range(0.0, std::f64::consts::TAU);
            let n = unit([tilt.sin() * az.cos(), tilt.sin() * az.sin(), tilt.cos()]);
            let d = rng.range(0.1, 0.25);
            out.push((n, [-d * az.cos(), -d * az.sin(), 0.0]));
        }
    }
    out
}

/// Signed distance of `c` to a plane, less `r`.
fn gap(c: [f64; 3], r: f64, (n, p): &PlaneDesc) -> f64 {
    (c[0] - p[0]) * n[0] + (c[1] - p[1]) * n[1] + (c[2] - p[2]) * n[2] - r
}

/// [`scene`] with sleeping at thresholds its bodies reach within a few
/// steps (`after = 0`, 0.5 m/s, 5 rad/s): bodies asleep beside awake
/// ones (those on joints never sleep), for the tests of sleeping.
pub fn sleeping_scene(seed: u64) -> cosim_shared::Scene {
    let text = scene(seed);
    let at = text.find("\n[[").map_or(text.len(), |k| k + 1);
    let table = "[sim.sleep]\nafter = 0\nlinear_speed = 0.5\nangular_speed = 5\n\n";
    let text = format!("{}{table}{}", &text[..at], &text[at..]);
    cosim_shared::Scene::parse(&text, "<sleeping random scene>")
        .unwrap_or_else(|e| panic!("seed {seed}: the random scene with sleeping is valid: {e}"))
}

/// One random scene as TOML text, deterministic in `seed`.
pub fn scene(seed: u64) -> String {
    let mut rng = Rng::new(seed);
    let h = rng.pick(&[1e-3, 2e-3, 5e-3, 1e-2]);
    let mut s = format!(
        "[sim]\nname = \"robust-{seed}\"\ndt = {h:e}\nsteps = 20\ngravity = [0.0, 0.0, -9.81]\nfriction_directions = {}\nsolver = \"lemke\"\n",
        rng.pick(&[4, 8])
    );
    let planes = planes(&mut rng);
    let nb = 1 + rng.below(3);
    let mut centres: Vec<([f64; 3], f64)> = Vec::new();
    let mut tries = 0;
    while centres.len() < nb && tries < 200 {
        tries += 1;
        let r = rng.range(0.03, 0.08);
        // Start near a plane or a corner of two: the deepest contacts are
        // the hard ones. The sphere is put at distance `d` from one or two
        // planes, `d` exactly r (touching), r minus up to 3 mm (overlap),
        // or a little more (a gap the step may close).
        let k = rng.below(planes.len());
        let mut c = [
            rng.range(-0.1, 0.1),
            rng.range(-0.1, 0.1),
            rng.range(0.0, 0.15),
        ];
        let place = |c: &mut [f64; 3], pl: &PlaneDesc, rng: &mut Rng| {
            let d = match rng.below(3) {
                0 => r,
                1 => r - rng.range(0.0, 3e-3),
                _ => r + rng.range(0.0, 5e-3),
            };
            let g = gap(*c, 0.0, pl);
            *c = along(*c, pl.0, d - g);
        };
        place(&mut c, &planes[k], &mut rng);
        if planes.len() > 1 && rng.uniform() < 0.5 {
            let k2 = (k + 1 + rng.below(planes.len() - 1)) % planes.len();
            place(&mut c, &planes[k2], &mut rng);
        }
        // Deeper than 5 mm into any plane: too far from the intent.
        if planes.iter().any(|pl| gap(c, r, pl) < -5e-3) {
            continue;
        }
        // Apart from the others, or touching / overlapping one a little.
        let ok = centres.iter().all(|(o, ro)| {
            let d = ((o[0] - c[0]).powi(2) + (o[1] - c[1]).powi(2) + (o[2] - c[2]).powi(2)).sqrt();
            d >= r + ro - 3e-3
        });
        if ok {
            centres.push((c, r));
        }
    }
    let shapes = shaped(seed, &planes, &mut centres);
    let mus = [0.0, 0.3, 1.0];
    for (i, &(c, r)) in centres.iter().enumerate() {
        let v = if rng.uniform() < 0.4 {
            [0.0; 3]
        } else {
            [
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 0.5),
            ]
        };
        let body = sphere(
            &format!("s{i}"),
            r,
            rng.range(0.2, 3.0),
            c,
            v,
            rng.pick(&mus),
            rng.pick(&[0.0, 0.5]),
        );
        s += &match &shapes[i] {
            None => body,
            Some(lines) => body.replacen(&format!("radius = {r:e}\n"), lines, 1),
        };
    }
    for (k, (n, p)) in planes.iter().enumerate() {
        s += &plane(
            &format!("p{k}"),
            *n,
            *p,
            rng.pick(&mus),
            rng.pick(&[0.0, 0.5]),
        );
    }
    // 0..3 joints: to the world at an anchor near a sphere (its pin
    // direction anywhere, inside a friction cone too), or between two
    // spheres at their midpoint; spherical, revolute or prismatic (a
    // random axis, half of them limited, a third with a motor) or fixed;
    // some with a constant torque, some with `collide = false`, a quarter
    // of those that move with a rotor (`armature`).
    let n = centres.len();
    // The kind of each joint comes from a stream of its own, so that every
    // other draw (and so every scene of spherical joints before kinds were
    // drawn) keeps its value.
    let mut kinds = Rng::new(seed ^ 0x6a6f_696e_7473);
    // A rotor (`armature`) on a quarter of the joints that turn or slide,
    // from a stream of its own too.
    let mut rotors = Rng::new(seed ^ 0x726f_746f_7273);
    for j in 0..rng.below(4) {
        let a = rng.below(n);
        let mut text = if rng.uniform() < 0.5 || n < 2 {
            let (c, r) = centres[a];
            let dir = unit([
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-0.2, 1.0),
            ]);
            joint(
                &format!("j{j}"),
                "world",
                &format!("s{a}"),
                along(c, dir, r + rng.range(0.0, 0.1)),
            )
        } else {
            let b = (a + 1 + rng.below(n - 1)) % n;
            let ((ca, _), (cb, _)) = (centres[a], centres[b]);
            let mid = [
                (ca[0] + cb[0]) / 2.0,
                (ca[1] + cb[1]) / 2.0,
                (ca[2] + cb[2]) / 2.0,
            ];
            joint(&format!("j{j}"), &format!("s{a}"), &format!("s{b}"), mid)
        };
        let kind = kinds.below(4);
        match kind {
            0 => {}
            1 | 2 => {
                let axis = [
                    kinds.range(-1.0, 1.0),
                    kinds.range(-1.0, 1.0),
                    kinds.range(-1.0, 1.0),
                ];
                let norm = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
                let axis = if norm < 0.1 {
                    [0.0, 0.0, 1.0]
                } else {
                    unit(axis)
                };
                let to = if kind == 1 { "revolute" } else { "prismatic" };
                text = text.replacen("\"spherical\"", &format!("{to:?}"), 1);
                text += &format!("axis = [{:e}, {:e}, {:e}]\n", axis[0], axis[1], axis[2]);
                // Half of them limited (rad or m; the coordinate is 0 at
                // the start), a third of those with a bouncing limit.
                if kinds.uniform() < 0.5 {
                    let (lo, hi) = (-kinds.range(0.01, 1.0), kinds.range(0.01, 1.0));
                    text += &format!("range = [{lo:e}, {hi:e}]\n");
                    if kinds.uniform() < 0.3 {
                        text += "limit_restitution = 0.5\n";
                    }
                }
                // A third with a motor (rad/s or m/s; N m or N).
                if kinds.uniform() < 0.3 {
                    text += &format!(
                        "motor = {{ speed = {:e}, max_effort = {:e} }}\n",
                        kinds.range(-2.0, 2.0),
                        kinds.range(0.05, 2.0)
                    );
                }
            }
            _ => text = text.replacen("type = \"spherical\"", "type = \"fixed\"", 1),
        }
        if kind != 3 && rotors.uniform() < 0.25 {
            // kg m^2 (kg on a slider): from a tenth of a small sphere's
            // inertia to several times a large one's.
            text += &format!("armature = {:e}\n", rotors.range(1e-4, 0.05));
        }
        if kinds.uniform() < 0.25 {
            text += "collide = false\n";
        }
        if rng.uniform() < 0.3 {
            // A slider's effort is a force (N).
            let effort = if kind == 2 { "force" } else { "torque" };
            text += &format!(
                "{effort} = [{:e}, {:e}, {:e}]\n",
                rng.range(-0.5, 0.5),
                rng.range(-0.5, 0.5),
                rng.range(-0.5, 0.5)
            );
        }
        s += &text;
    }
    s
}

/// Turns some of the spheres placed by [`scene`] into boxes and capsules
/// (from a stream of its own, so that every other draw keeps its value):
/// per body, `None` (a sphere) or its shape's and orientation's lines.
/// A turned body keeps the gap its sphere had to each plane it was placed
/// against (within 5 mm), its centre moved out along that plane's normal
/// by its extent's excess over the radius; one that would then sink more
/// than 5 mm into a plane, or overlap another body's bounding sphere by
/// more than 3 mm, stays a sphere.
fn shaped(seed: u64, planes: &[PlaneDesc], centres: &mut [([f64; 3], f64)]) -> Vec<Option<String>> {
    use cosim_engine::model::Shape;
    use nalgebra::{Quaternion, UnitQuaternion, Vector3};
    let mut rng = Rng::new(seed ^ 0x7368_6170_6573);
    let mut out = vec![None; centres.len()];
    let mut bound: Vec<f64> = centres.iter().map(|c| c.1).collect();
    for i in 0..centres.len() {
        let (c, r) = centres[i];
        let kind = rng.uniform();
        let raw = Quaternion::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let q = if raw.norm() > 0.1 {
            UnitQuaternion::from_quaternion(raw)
        } else {
            UnitQuaternion::identity()
        };
        let (shape, lines) = if kind < 0.3 {
            let half = Vector3::new(
                r * rng.range(0.5, 1.2),
                r * rng.range(0.5, 1.2),
                r * rng.range(0.5, 1.2),
            );
            let lines = format!(
                "half_extents = [{:e}, {:e}, {:e}]\n",
                half.x, half.y, half.z
            );
            (Shape::Box { half }, lines)
        } else if kind < 0.55 {
            let (radius, half_length) = (r * rng.range(0.5, 0.9), r * rng.range(0.3, 1.5));
            let lines = format!("radius = {radius:e}\nhalf_length = {half_length:e}\n");
            (
                Shape::Capsule {
                    radius,
                    half_length,
                },
                lines,
            )
        } else {
            continue;
        };
        let mut x = Vector3::from(c);
        for (n, p) in planes {
            let n = Vector3::from(*n);
            let sphere_gap = (x - Vector3::from(*p)).dot(&n) - r;
            if sphere_gap < 5e-3 {
                x += n * (shape.extent(&q, &n) - r);
            }
        }
        let sinks = planes.iter().any(|(n, p)| {
            let n = Vector3::from(*n);
            (x - Vector3::from(*p)).dot(&n) - shape.extent(&q, &n) < -5e-3
        });
        let radius = shape.bounding_radius();
        let overlaps = (0..centres.len())
            .filter(|&k| k != i)
            .any(|k| (Vector3::from(centres[k].0) - x).norm() < radius + bound[k] - 3e-3);
        if sinks || overlaps {
            continue;
        }
        centres[i].0 = x.into();
        bound[i] = radius;
        out[i] = Some(format!(
            "{lines}orientation = [{:e}, {:e}, {:e}, {:e}]\n",
            q.w, q.i, q.j, q.k
        ));
    }
    out
}

/// What checking one scene found.
#[derive(Debug, Clone, Default)]
pub struct Check {
    pub steps: u64,
    /// Failed steps (the run stops at the first).
    pub failures: u64,
    pub first_failure: Option<String>,
    pub ladder: LadderCounts,
    /// Largest excess over their bounds (<= 0 where they hold) of: a step's
    /// kinetic energy over its free motion's plus the declared allowance
    /// (J), the midpoint energy over its start plus inputs and allowances
    /// (J), a body's speed over what the kinetic bound explains (m/s).
    pub kinetic: f64,
    pub energy: f64,
    pub speed: f64,
    /// The energy the projection out of deep penetration gave (J): the
    /// overlaps the scene was built with, removed at the position level.
    pub projection_energy: f64,
}

/// Steps the scene `text` `steps` times with `solver` and checks it.
///
/// The bounds, from the states alone (the engine's own numbers enter only
/// as the allowance it declares):
///
/// - **Kinetic**: `K(nu') <= K(nu_free) + allowance`, with
///   `nu_free = nu + h M^-1 (F_ext + tau)` computed here (gravity, body
///   forces, joint torques, the gyroscopic term; kinetic energies with the
///   start's world inertia) and the
///   allowance `StepReport::energy_allowance`, what the energy check let the
///   stabilisation give (penetrations under 0.1 mm, joint drift). A
///   constraint impulse that adds energy beyond it fails here.
/// - **Speed**: no body faster than that kinetic bound allows it alone:
///   `|v_i'| <= sqrt(2 (K(nu_free) + allowance) / m_i)`.
/// - **Midpoint energy** (formulation.md, "Energy, measured honestly"):
///   over a step, exactly `dE_mid = dK_c + dK_in - (h/2) sum_i m_i g . dv_c,i`
///   with `dK_c = K(nu') - K(nu_free)`, `dK_in = K(nu_free) - K(nu) - (work
///   of gravity)` the inputs' part and `dv_c` the constraint impulses'
///   velocity change. The run's midpoint energy must stay below its start
///   plus the sum of `dK_in`, the allowances and the last term's positive
///   part (a support holding a body against gravity: `(h/2) m |g|^2 h`).
///   The projection out of deep penetration moves positions before a step:
///   its change of the energy is measured and added (the scene's overlap,
///   removed; reported as `projection_energy`).
pub fn check(text: &str, steps: u64, solver: SolverChoice) -> Result<Check, String> {
    use nalgebra::Vector3;
    let scene = Scene::parse(text, "<robust>").map_err(|e| e.to_string())?;
    let mut model = Model::from_scene(&scene);
    model.params.solver = solver;
    let mut engine = Engine::new(model);
    let m = engine.model().clone();
    let (h, g) = (m.params.h, m.params.gravity);
    let mut out = Check {
        kinetic: f64::NEG_INFINITY,
        energy: f64::NEG_INFINITY,
        speed: f64::NEG_INFINITY,
        ..Check::default()
    };
    let mut allowed = energy(&m, engine.state()).midpoint;
    // Kinetic energy with each body's world inertia `j` (a box's or
    // capsule's turns with it: the step's bounds take the start's).
    let kinetic = |v: &[(Vector3<f64>, Vector3<f64>)], j: &[nalgebra::Matrix3<f64>]| -> f64 {
        m.bodies
            .iter()
            .zip(v.iter().zip(j))
            .map(|(b, ((v, w), j))| 0.5 * b.mass * v.norm_squared() + 0.5 * w.dot(&(j * w)))
            .sum()
    };
    let world = |inertia: &nalgebra::Matrix3<f64>, q: &nalgebra::UnitQuaternion<f64>| {
        let r = q.to_rotation_matrix();
        r.matrix() * inertia * r.matrix().transpose()
    };
    let mut free = Vec::new();
    let mut now = Vec::new();
    let (mut rotor_rows, mut rotor_rates, mut rotor_inertia) = (Vec::new(), Vec::new(), Vec::new());
    let (mut j_start, mut j_inv, mut j_end) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..steps {
        let before = energy(&m, engine.state()).midpoint;
        engine.prepare();
        let projected = energy(&m, engine.state()).midpoint - before;
        if projected > 0.0 {
            out.projection_energy += projected;
            allowed += projected;
        }
        // The free motion of this step, from the state the step starts at,
        // with the gyroscopic term `-h w x J w` (none for a sphere), as
        // `applied::free_velocity` has it.
        j_start.clear();
        j_inv.clear();
        for (b, s) in m.bodies.iter().zip(&engine.state().bodies) {
            j_start.push(world(&b.inertia, &s.q));
            j_inv.push(world(&b.inv_inertia, &s.q));
        }
        free.clear();
        free.extend(
            m.bodies
                .iter()
                .zip(&engine.state().bodies)
                .enumerate()
                .map(|(i, (b, s))| {
                    let gyro = -h * s.w.cross(&(j_start[i] * s.w));
                    (s.v + h * (g + b.force * b.inv_mass), s.w + j_inv[i] * gyro)
                }),
        );
        for j in &m.joints {
            use cosim_engine::Attachment;
            // A slider's effort is a force at B's anchor, on both sides.
            let at = j.slide.map(|_| {
                cosim_engine::model::kinematics::anchor(j.b, &j.local_b, engine.state()).0
            });
            for (att, sign) in [(j.a, -1.0), (j.b, 1.0)] {
                if let Attachment::Body(i) = att {
                    let (b, s) = (&m.bodies[i], &engine.state().bodies[i]);
                    let p = sign * h * j.effort;
                    match at {
                        Some(at) => {
                            free[i].0 += p * b.inv_mass;
                            free[i].1 += j_inv[i] * (at - s.x).cross(&p);
                        }
                        None => free[i].1 += j_inv[i] * p,
                    }
                }
            }
        }
        // The rotors (`armature`) are bodies of the system too: their rows
        // at the step's start, their energy there (their rate is the
        // joint's) and in the free motion (nothing turns them but their
        // rows), then at the solve's velocities.
        rotor_rows.clear();
        rotor_rates.clear();
        rotor_inertia.clear();
        for j in &m.joints {
            let before = rotor_rows.len();
            cosim_engine::constraint::armature::push_rows(
                j,
                engine.state(),
                &mut rotor_rows,
                &mut rotor_rates,
            );
            rotor_inertia.extend(std::iter::repeat_n(j.armature, rotor_rows.len() - before));
        }
        let rotors_start: f64 = rotor_rates
            .iter()
            .zip(&rotor_inertia)
            .map(|(x, i)| 0.5 * i * x * x)
            .sum();
        let k_start: f64 = kinetic(
            &engine
                .state()
                .bodies
                .iter()
                .map(|s| (s.v, s.w))
                .collect::<Vec<_>>(),
            &j_start,
        ) + rotors_start;
        let k_free = kinetic(&free, &j_start) + rotors_start;
        // The inputs' part of the free motion's kinetic change: all of it
        // but gravity's work `h m g . v + h^2 m |g|^2 / 2`, which the
        // midpoint energy's potential balances exactly.
        let gravity_work: f64 = m
            .bodies
            .iter()
            .zip(&engine.state().bodies)
            .map(|(b, s)| h * b.mass * g.dot(&s.v) + 0.5 * h * h * b.mass * g.norm_squared())
            .sum();
        // And the inputs' part of the midpoint energy's offset: per step
        // `dE_mid = (K' - K_free) + (K_free - K) - (h/2) sum m g . (v_free
        // + v) - (h/2) sum m g . dv` (dv the constraints' change, `support`
        // below); with `v_free = v + h g + a`, the free part is `k_in -
        // (h/2) sum m g . a`, `a` the inputs' linear change (a slider's
        // force has one; found when a motor pushed a slider force's body
        // below its free motion, seed 9682: 8.9e-7 J over the bound).
        let input_offset: f64 = m
            .bodies
            .iter()
            .zip(engine.state().bodies.iter().zip(&free))
            .map(|(b, (s, (vf, _)))| -0.5 * h * b.mass * g.dot(&(vf - s.v - h * g)))
            .sum();
        let k_in = k_free - k_start - gravity_work + input_offset;
        let r = engine.step();
        out.steps += 1;
        out.ladder.add(&r);
        if let Some(e) = r.error {
            out.failures += 1;
            out.first_failure = Some(format!("step {}: {e}", r.step + 1));
            break;
        }
        // The solve's velocities: an island the step put to sleep has them
        // set to zero afterwards (accounted for below).
        now.clear();
        now.extend(engine.solved_velocities().chunks_exact(6).map(|c| {
            (
                Vector3::new(c[0], c[1], c[2]),
                Vector3::new(c[3], c[4], c[5]),
            )
        }));
        let nu = engine.solved_velocities();
        let rotors_end: f64 = rotor_rows
            .iter()
            .zip(&rotor_inertia)
            .map(|(row, i)| 0.5 * i * row.velocity(nu).powi(2))
            .sum();
        let k_end = kinetic(&now, &j_start) + rotors_end;
        let tol = 1e-12 * (k_free.abs() + allowed.abs() + 1.0);
        let bound = k_free + r.energy_allowance;
        out.kinetic = out.kinetic.max(k_end - bound - tol);
        for (b, (v, _)) in m.bodies.iter().zip(&now) {
            out.speed = out
                .speed
                .max(v.norm() - (2.0 * (bound + tol) / b.mass).sqrt());
        }
        let support: f64 = m
            .bodies
            .iter()
            .zip(now.iter().zip(&free))
            .map(|(b, ((v, _), (vf, _)))| (-0.5 * h * b.mass * g.dot(&(v - vf))).max(0.0))
            .sum();
        // An island that falls asleep has its velocities set to zero after
        // the position update, outside the step's dynamics: the midpoint
        // energy changes by `(h/2) m (-g) . v' - K(v')` per body (its offset
        // term goes with v'); the positive part is added (zero for a body
        // that slept through the step: its v' is zero).
        let put_to_sleep: f64 = m
            .bodies
            .iter()
            .zip(&now)
            .enumerate()
            .filter(|&(i, _)| asleep(engine.state(), i))
            .map(|(i, (b, (v, w)))| {
                let j = world(&b.inertia, &engine.state().bodies[i].q);
                let k = 0.5 * b.mass * v.norm_squared() + 0.5 * w.dot(&(j * w));
                (0.5 * h * b.mass * (-g).dot(v) - k).max(0.0)
            })
            .sum();
        // The position update turns a box's or capsule's inertia under its
        // new angular velocity: the midpoint energy measures `w' . J(q')
        // w' / 2` where the step's bounds had `J(q)`. That change is the
        // explicit rotation update's own (a free tumbling body's energy
        // is not kept exactly); its positive part is added. Zero for a
        // sphere.
        j_end.clear();
        j_end.extend(
            m.bodies
                .iter()
                .zip(&engine.state().bodies)
                .map(|(b, s)| world(&b.inertia, &s.q)),
        );
        let turned = (kinetic(&now, &j_end) + rotors_end - k_end).max(0.0);
        allowed += k_in.max(0.0) + r.energy_allowance + support + put_to_sleep + turned;
        out.energy = out.energy.max(r.energy.midpoint - allowed - tol);
    }
    Ok(out)
}

/// The whole suite's result.
#[derive(Debug, Clone, Default)]
pub struct Summary {
    pub scenes: u64,
    pub steps: u64,
    pub failures: u64,
    /// The seed and message of the first failing scene.
    pub first_failure: Option<(u64, String)>,
    pub ladder: LadderCounts,
    pub worst_kinetic: (f64, u64),
    pub worst_energy: (f64, u64),
    pub worst_speed: (f64, u64),
    pub projection_energy: f64,
}

/// Runs scenes `seed0 .. seed0 + scenes`, `steps` steps each.
pub fn run(scenes: u64, steps: u64, seed0: u64, solver: SolverChoice) -> Result<Summary, String> {
    let mut sum = Summary {
        worst_kinetic: (f64::NEG_INFINITY, 0),
        worst_energy: (f64::NEG_INFINITY, 0),
        worst_speed: (f64::NEG_INFINITY, 0),
        ..Summary::default()
    };
    for seed in seed0..seed0 + scenes {
        let text = scene(seed);
        let c = check(&text, steps, solver).map_err(|e| format!("seed {seed}: {e}\n{text}"))?;
        sum.scenes += 1;
        sum.steps += c.steps;
        sum.failures += c.failures;
        if let (None, Some(f)) = (&sum.first_failure, c.first_failure) {
            sum.first_failure = Some((seed, f));
        }
        sum.ladder.merge(&c.ladder);
        if c.kinetic > sum.worst_kinetic.0 {
            sum.worst_kinetic = (c.kinetic, seed);
        }
        if c.energy > sum.worst_energy.0 {
            sum.worst_energy = (c.energy, seed);
        }
        if c.speed > sum.worst_speed.0 {
            sum.worst_speed = (c.speed, seed);
        }
        sum.projection_energy += c.projection_energy;
    }
    Ok(sum)
}

/// The summary as the command prints it.
pub fn table(s: &Summary, steps: u64, seed0: u64, solver: SolverChoice) -> String {
    format!(
        "# Robustness: seeded random scenes\n\n\
         {} scenes (seeds {seed0}..{}), {steps} steps each, solver {}: {} steps.\n\n\
         | measure | value |\n|---|---|\n\
         | failed steps | {} |\n\
         | first failure | {} |\n\
         | ladder | {} |\n\
         | worst kinetic energy over the free motion's plus the allowance (J, <= 0 holds) | {:.3e} (seed {}) |\n\
         | worst midpoint energy excess over the bound (J, <= 0 holds) | {:.3e} (seed {}) |\n\
         | worst speed excess over the bound (m/s, <= 0 holds) | {:.3e} (seed {}) |\n\
         | energy of the projections out of initial overlaps (J) | {:.3e} |\n",
        s.scenes,
        seed0 + s.scenes,
        solver.as_str(),
        s.steps,
        s.failures,
        s.first_failure
            .as_ref()
            .map_or("none".to_string(), |(seed, m)| format!("seed {seed}: {m}")),
        s.ladder,
        s.worst_kinetic.0,
        s.worst_kinetic.1,
        s.worst_energy.0,
        s.worst_energy.1,
        s.worst_speed.0,
        s.worst_speed.1,
        s.projection_energy,
    )
}
