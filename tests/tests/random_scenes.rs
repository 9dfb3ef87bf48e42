//! Seeded property test: random sphere configurations (contacts, joints,
//! friction, restitution) give Lemke a verified solution or a typed failure,
//! never an unverified answer, and prox PGS at a tight tolerance agrees with
//! Lemke's velocities.

use cosim_server::engine::solver::PgsParams;
use cosim_server::engine::{Engine, Model};
use cosim_shared::{Scene, SolverChoice};
use cosim_tests::*;

/// xorshift64*: a small deterministic generator, enough for scene sampling.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    fn pick<T: Copy>(&mut self, xs: &[T]) -> T {
        xs[((self.next() * xs.len() as f64) as usize).min(xs.len() - 1)]
    }
}

/// Spheres dropped into a box of floor and two or three walls, some joined.
fn random_scene(rng: &mut Rng) -> String {
    let h = rng.pick(&[1e-3, 5e-3, 1e-2]);
    let mut s = sim(h, 100, [0.0, 0.0, -G]).replace("solver = \"pgs\"", "solver = \"lemke\"");
    let n = 2 + (rng.next() * 3.0) as usize;
    let mut centres: Vec<[f64; 3]> = Vec::new();
    while centres.len() < n {
        let c = [
            rng.range(-0.3, 0.3),
            rng.range(-0.3, 0.3),
            rng.range(0.1, 0.5),
        ];
        // Start apart (overlap is the stress suite's business).
        if centres
            .iter()
            .all(|o| (0..3).map(|k| (o[k] - c[k]).powi(2)).sum::<f64>().sqrt() > 0.21)
        {
            centres.push(c);
        }
    }
    for (i, c) in centres.iter().enumerate() {
        let v = [
            rng.range(-2.0, 2.0),
            rng.range(-2.0, 2.0),
            rng.range(-2.0, 1.0),
        ];
        let mu = rng.pick(&[0.0, 0.3, 0.8]);
        let e = rng.pick(&[0.0, 0.0, 0.5]);
        s += &sphere(
            &format!("s{i}"),
            rng.range(0.05, 0.1),
            rng.range(0.2, 3.0),
            *c,
            v,
            mu,
            e,
        );
    }
    s += &plane(
        "floor",
        [0.0, 0.0, 1.0],
        [0.0; 3],
        rng.pick(&[0.0, 0.5, 1.0]),
        0.0,
    );
    s += &plane("wx", [1.0, 0.0, 0.0], [-0.45, 0.0, 0.0], 0.5, 0.0);
    s += &plane("wy", [0.0, 1.0, 0.0], [0.0, -0.45, 0.0], 0.5, 0.0);
    if rng.next() < 0.5 {
        s += &plane("wx2", [-1.0, 0.0, 0.0], [0.45, 0.0, 0.0], 0.5, 0.0);
    }
    // Up to two joints: to the world above a sphere, or between two spheres.
    for j in 0..(rng.next() * 3.0) as usize {
        let a = (rng.next() * n as f64) as usize % n;
        if rng.next() < 0.5 {
            let c = centres[a];
            s += &joint(
                &format!("j{j}"),
                "world",
                &format!("s{a}"),
                [c[0], c[1], c[2] + 0.2],
            );
        } else {
            let b = (a + 1) % n;
            let (ca, cb) = (centres[a], centres[b]);
            let mid = [
                (ca[0] + cb[0]) / 2.0,
                (ca[1] + cb[1]) / 2.0,
                (ca[2] + cb[2]) / 2.0,
            ];
            s += &joint(&format!("j{j}"), &format!("s{a}"), &format!("s{b}"), mid);
        }
    }
    s
}

#[test]
fn random_scenes_give_verified_answers_and_pgs_agrees() {
    let mut rng = Rng(0x5eed_cafe_f00d_0001);
    let (mut steps, mut failures, mut compared, mut worst) = (0usize, 0usize, 0usize, 0.0f64);
    for _ in 0..150 {
        let text = random_scene(&mut rng);
        let scene = Scene::parse(&text, "<random>").unwrap_or_else(|e| panic!("{e}\n{text}"));
        let mut lemke = Engine::new(Model::from_scene(&scene));
        let mut model = Model::from_scene(&scene);
        model.params.solver = SolverChoice::Pgs;
        let mut pgs = Engine::new(model);
        pgs.set_pgs_params(PgsParams {
            tolerance: 1e-12,
            max_iterations: 20_000,
            // The relative residual alone: this compares answers, not
            // physics to a tolerance in m/s.
            ..PgsParams::distance(0.0)
        });
        for _ in 0..60 {
            let before = lemke.state().clone();
            let r = lemke.step();
            steps += 1;
            match r.error {
                // A typed failure leaves the state as it was.
                Some(e) => {
                    eprintln!("typed failure: {e}");
                    failures += 1;
                    assert_eq!(lemke.state(), &before);
                    break;
                }
                None => {
                    let limit = if r.regularized > 0 { 1e-6 } else { 1e-8 };
                    assert!(
                        r.residual <= limit,
                        "unverified answer: residual {}",
                        r.residual
                    );
                    assert!(lemke.state().bodies.iter().all(|b| b
                        .v
                        .iter()
                        .chain(b.w.iter())
                        .all(|x| x.is_finite())));
                }
            }
            pgs.set_state(before);
            let p = pgs.step();
            if p.ok() && !p.not_converged && r.regularized == 0 {
                for (a, b) in lemke.state().bodies.iter().zip(&pgs.state().bodies) {
                    worst = worst.max((a.v - b.v).norm());
                }
                compared += 1;
            }
        }
    }
    eprintln!("{steps} steps, {failures} typed failures, {compared} compared with PGS, largest velocity difference {worst:e} m/s");
    assert!(
        compared * 10 >= steps * 9,
        "PGS converged in too few steps: {compared} of {steps}"
    );
    assert!(
        worst < 1e-6,
        "PGS and Lemke velocities differ by {worst} m/s"
    );
}
