//! Fuzzing on stable Rust (issue 15, point 12): seeded, deterministic, no
//! extra crate. Two targets, each run case by case under `catch_unwind`:
//!
//! - **scenes**: shipped scene files mutated (numbers replaced by NaN,
//!   infinities, denormals and huge values; tokens inserted, lines deleted,
//!   duplicated and swapped) and generated texts (deep nesting, huge arrays,
//!   thousands of bodies, unknown types and keys). A text must parse or be
//!   refused with an error that names its field or its line; a scene that
//!   parses must build a model, step, and survive its own `to_toml` round
//!   trip (that text is what the server streams to clients).
//! - **inputs**: input frames with every field drawn from the values that
//!   break decoders (random bytes, counts past the arrays, indices past the
//!   scene, NaN, infinities, 1e308, denormals), checked as the server checks
//!   them and, when taken, applied to an engine that then steps. Nothing may
//!   panic, and a taken input may not make the state non-finite without the
//!   step saying so.
//!
//! `cosim-server bench fuzz` runs many cases; the tests run a few thousand.

use crate::serve::controllers::{self, Limits, Slot};
use cosim_bench::robust::Rng;
use cosim_engine::{Engine, Model};
use cosim_shared::wire::{
    input_words, ControlRequest, InputFrame, InputHeader, CMD_JOIN, CMD_SHUTDOWN, IMPULSE_WORDS,
    PROTOCOL_VERSION, ROLE_CONTROLLER, TORQUE_WORDS,
};
use cosim_shared::Scene;
use nalgebra::Vector3;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// The shipped scenes, the seeds of the mutations.
const SEEDS: [&str; 6] = [
    include_str!("../../examples/scenes/reference.toml"),
    include_str!("../../examples/scenes/friction.toml"),
    include_str!("../../examples/scenes/frictionless.toml"),
    include_str!("../../examples/scenes/joint_torques.toml"),
    include_str!("../../examples/scenes/joints.toml"),
    include_str!("../../examples/scenes/restitution.toml"),
];

/// Numbers that break parsers and physics.
const NUMBERS: [&str; 16] = [
    "nan",
    "inf",
    "-inf",
    "+nan",
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "5e-324",
    "1e-310",
    "-0.0",
    "0",
    "0.0",
    "-1",
    "99999999999999999999999999",
    "1e-300",
    "1e30",
];

/// Tokens that break TOML structure or the scene's schema.
const TOKENS: [&str; 20] = [
    "[[body]]",
    "[[plane]]",
    "[[joint]]",
    "[sim]",
    "[compliance.contact]",
    "[[capsule]]",
    "type = \"hinge\"",
    "solver = \"magic\"",
    "friction_cone = \"circular\"",
    "name = \"\"",
    "name = \"upper\"",
    "body_a = \"nobody\"",
    "=",
    "[",
    "]",
    "{",
    "\"",
    "'''",
    "\u{feff}",
    "é",
];

/// What a fuzz run found.
#[derive(Debug, Default, Clone)]
pub struct Counts {
    pub cases: u64,
    /// Texts that parsed (scenes) or inputs that were taken (inputs).
    pub accepted: u64,
    /// Refused with a clear error (scenes) or rejected by reason (inputs).
    pub refused: u64,
    /// Accepted scenes that were stepped (small enough to step here).
    pub stepped: u64,
    /// Steps that reported a failure (allowed: the step says how).
    pub failed_steps: u64,
    /// Defects: a panic, an error that names nothing, a round trip that
    /// breaks, a state made non-finite by a step that said it was fine.
    pub defects: Vec<String>,
}

impl Counts {
    pub fn line(&self, what: &str) -> String {
        format!(
            "{what}: {} cases, {} accepted, {} refused with a clear error, {} stepped ({} failed steps, each reported), {} defects",
            self.cases,
            self.accepted,
            self.refused,
            self.stepped,
            self.failed_steps,
            self.defects.len()
        )
    }
}

/// A char boundary of `s` at or below `i`.
fn floor_boundary(s: &str, mut i: usize) -> usize {
    i = i.min(s.len());
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// The byte ranges of the numbers in `s` (digits with sign, dot, exponent).
fn numbers(s: &str) -> Vec<(usize, usize)> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit()
            || (matches!(b[i], b'-' | b'+') && b.get(i + 1).is_some_and(u8::is_ascii_digit));
        if starts && (i == 0 || !b[i - 1].is_ascii_alphanumeric() && b[i - 1] != b'_') {
            let mut j = i + 1;
            while j < b.len()
                && (b[j].is_ascii_digit()
                    || matches!(b[j], b'.' | b'e' | b'E' | b'_')
                    || (matches!(b[j], b'-' | b'+') && matches!(b[j - 1], b'e' | b'E')))
            {
                j += 1;
            }
            out.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

/// One mutation of `text`.
fn mutate(rng: &mut Rng, text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    match rng.below(7) {
        // A number replaced.
        0 | 1 => {
            let nums = numbers(text);
            if nums.is_empty() {
                return text.to_string();
            }
            let (a, b) = nums[rng.below(nums.len())];
            format!("{}{}{}", &text[..a], rng.pick(&NUMBERS), &text[b..])
        }
        // A token inserted anywhere.
        2 => {
            let at = floor_boundary(text, rng.below(text.len() + 1));
            let sep = if rng.uniform() < 0.5 { "\n" } else { "" };
            format!(
                "{}{sep}{}{sep}{}",
                &text[..at],
                rng.pick(&TOKENS),
                &text[at..]
            )
        }
        // A span deleted.
        3 => {
            let a = floor_boundary(text, rng.below(text.len() + 1));
            let b = floor_boundary(text, a + rng.below(64));
            format!("{}{}", &text[..a], &text[b..])
        }
        // A line duplicated, or deleted.
        4 | 5 if !lines.is_empty() => {
            let k = rng.below(lines.len());
            let mut out: Vec<&str> = lines.clone();
            if rng.uniform() < 0.5 {
                out.insert(k, lines[k]);
            } else {
                out.remove(k);
            }
            out.join("\n")
        }
        // Two lines swapped.
        _ if lines.len() >= 2 => {
            let mut out = lines.clone();
            let (a, b) = (rng.below(lines.len()), rng.below(lines.len()));
            out.swap(a, b);
            out.join("\n")
        }
        _ => text.to_string(),
    }
}

/// A generated text that stresses the parser's limits.
fn generated(rng: &mut Rng) -> String {
    let sim = "[sim]\nname = \"fuzz\"\ndt = 0.001\nsteps = 3\n";
    let body = |i: usize, x: f64| {
        format!(
            "\n[[body]]\nname = \"b{i}\"\nradius = 0.1\nmass = 1.0\nposition = [{x}, 0.0, 1.0]\n"
        )
    };
    match rng.below(6) {
        0 => {
            let depth = rng.pick(&[10usize, 100, 1000, 10_000]);
            format!("{sim}x = {}{}\n", "[".repeat(depth), "]".repeat(depth))
        }
        1 => {
            let depth = rng.pick(&[10usize, 100, 1000, 10_000]);
            format!("{sim}x = {}1{}\n", "{a = ".repeat(depth), "}".repeat(depth))
        }
        2 => {
            let n = rng.pick(&[1000usize, 100_000]);
            let values = vec!["1.0"; n].join(", ");
            format!("{sim}{}position = [{values}]\n", body(0, 0.0))
        }
        3 => {
            let n = rng.pick(&[33usize, 1000, 5000]);
            let mut s = sim.to_string();
            for i in 0..n {
                s += &body(i, 0.3 * i as f64);
            }
            s
        }
        4 => format!(
            "{sim}{}\n[[{}]]\nname = \"x\"\n",
            body(0, 0.0),
            rng.pick(&["capsule", "box", "mesh", "joint", "plane", "sim"])
        ),
        _ => {
            let key = rng.pick(&["colour", "radius", "mass", "sim", "type", "bodies"]);
            format!("{sim}{key} = {}\n{}", rng.pick(&NUMBERS), body(0, 0.0))
        }
    }
}

/// Whether an error names where it is: a field or a line.
fn clear(e: &cosim_shared::SceneError) -> bool {
    (!e.field.is_empty() || e.location.is_some()) && !e.message.trim().is_empty()
}

/// Bodies and joints up to which an accepted scene is also stepped.
const STEP_LIMIT: usize = 40;

/// One scene case: parse, and for what parses, build, step, round-trip.
fn scene_case(text: &str, counts: &mut Counts) {
    let label = || {
        let mut t: String = text.chars().take(160).collect();
        if t.len() < text.len() {
            t += "...";
        }
        t
    };
    let parsed = catch_unwind(|| Scene::parse(text, "<fuzz>"));
    let scene = match parsed {
        Err(_) => {
            counts
                .defects
                .push(format!("parse panicked on: {}", label()));
            return;
        }
        Ok(Err(e)) => {
            if clear(&e) {
                counts.refused += 1;
            } else {
                counts.defects.push(format!(
                    "an error that names nothing ({e}) for: {}",
                    label()
                ));
            }
            return;
        }
        Ok(Ok(s)) => s,
    };
    counts.accepted += 1;
    match Scene::parse(&scene.to_toml(), "<to_toml>") {
        Ok(back) if back == scene => {}
        Ok(_) => counts
            .defects
            .push(format!("to_toml does not read back the same: {}", label())),
        Err(e) => counts
            .defects
            .push(format!("to_toml does not parse ({e}): {}", label())),
    }
    if scene.bodies.len() > STEP_LIMIT || scene.joints.len() > STEP_LIMIT {
        return;
    }
    let stepped = catch_unwind(AssertUnwindSafe(|| {
        let mut e = Engine::new(Model::from_scene(&scene));
        let mut failed = 0u64;
        for _ in 0..3 {
            let r = e.step();
            if !r.ok() {
                failed += 1;
                break;
            }
            if !finite_state(&e) {
                return Err("a step said ok and left a non-finite state".to_string());
            }
        }
        Ok(failed)
    }));
    match stepped {
        Err(_) => counts
            .defects
            .push(format!("stepping panicked on: {}", label())),
        Ok(Err(m)) => counts.defects.push(format!("{m}: {}", label())),
        Ok(Ok(failed)) => {
            counts.stepped += 1;
            counts.failed_steps += failed;
        }
    }
}

fn finite_state(e: &Engine) -> bool {
    e.state().bodies.iter().all(|b| {
        b.x.iter()
            .chain(b.v.iter())
            .chain(b.w.iter())
            .chain(b.q.coords.iter())
            .all(|x| x.is_finite())
    })
}

/// The text of scene case `case`: generated for every third case, else one
/// to five mutations of a shipped scene.
pub fn scene_text(case: u64) -> String {
    let mut rng = Rng::new(case);
    if case % 3 == 2 {
        return generated(&mut rng);
    }
    let mut t = rng.pick(&SEEDS).to_string();
    for _ in 0..1 + rng.below(5) {
        t = mutate(&mut rng, &t);
    }
    t
}

/// `n` scene cases from `seed`: two mutated texts (one to five mutations
/// of a shipped scene) for each generated one.
pub fn scenes(seed: u64, n: u64) -> Counts {
    let mut counts = Counts::default();
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    for k in 0..n {
        let case = seed.wrapping_add(k);
        counts.cases += 1;
        let before = counts.defects.len();
        scene_case(&scene_text(case), &mut counts);
        for d in &mut counts.defects[before..] {
            *d = format!("scene case {case} (`bench fuzz --print-scene {case}`): {d}");
        }
    }
    std::panic::set_hook(hook);
    counts
}

/// A float drawn from the values that break things, or an ordinary one.
fn float(rng: &mut Rng) -> f64 {
    match rng.below(10) {
        0 => f64::NAN,
        1 => rng.pick(&[f64::INFINITY, f64::NEG_INFINITY]),
        2 => rng.pick(&[1e308, -1e308, f64::MAX, f64::MIN]),
        3 => rng.pick(&[5e-324, 1e-310, -0.0]),
        4 => f64::from_bits((rng.uniform() * u64::MAX as f64) as u64),
        _ => rng.range(-10.0, 10.0),
    }
}

/// A finite float: mostly ordinary, sometimes huge or denormal.
fn finite(rng: &mut Rng) -> f64 {
    match rng.below(10) {
        0 => rng.pick(&[1e308, -1e308, f64::MAX, 1e30, -1e15]),
        1 => rng.pick(&[5e-324, 1e-310, -0.0]),
        _ => rng.range(-10.0, 10.0),
    }
}

/// A u32 that is mostly in range `0..n`, sometimes anything.
fn index(rng: &mut Rng, n: usize) -> u32 {
    match rng.below(8) {
        0 => u32::MAX,
        1 => (rng.uniform() * u32::MAX as f64) as u32,
        2 => n as u32,
        _ => rng.below(n.max(1)) as u32,
    }
}

/// A random input message for step `step` from controller `id`: its
/// header and payload words, as a client could send them.
pub fn input_frame(
    rng: &mut Rng,
    id: u32,
    step: u64,
    joints: usize,
    bodies: usize,
) -> (InputHeader, Vec<u64>) {
    // Half the frames are well formed but for their values (finite, some
    // huge or denormal): the ones that reach the engine.
    if rng.uniform() < 0.5 {
        let mut f = InputFrame {
            controller_id: id,
            step,
            ..Default::default()
        };
        for _ in 0..rng.below(joints + 1) {
            let j = rng.below(joints) as u32;
            if f.torques.iter().all(|t| t.joint != j) {
                let t = [finite(rng), finite(rng), finite(rng)];
                f.push_torque(j, t);
            }
        }
        for _ in 0..rng.below(3) {
            let l = [finite(rng), finite(rng), finite(rng)];
            let a = [finite(rng), finite(rng), finite(rng)];
            f.push_impulse(rng.below(bodies) as u32, l, a);
        }
        // Motor targets, for any joint (one without a motor is refused).
        for _ in 0..rng.below(2).min(joints) {
            f.push_motor(rng.below(joints) as u32, finite(rng));
        }
        let mut words = Vec::new();
        f.encode(&mut words);
        return (f.header(), words);
    }
    let header = InputHeader {
        version: if rng.uniform() < 0.9 {
            PROTOCOL_VERSION
        } else {
            index(rng, 3)
        },
        controller_id: if rng.uniform() < 0.9 {
            id
        } else {
            index(rng, 3)
        },
        step: if rng.uniform() < 0.9 {
            step
        } else {
            (rng.uniform() * u64::MAX as f64) as u64
        },
        sequence: (rng.uniform() * u64::MAX as f64) as u64,
        torque_count: index(rng, joints + 1),
        impulse_count: index(rng, bodies + 1),
        motor_count: index(rng, joints + 1),
        _pad: 0,
    };
    // Mostly as many words as the counts say, else a few more or fewer:
    // a decoder must refuse a mismatch and read nothing past the words.
    let exact = input_words(
        (header.torque_count as usize).min(64),
        (header.impulse_count as usize).min(64),
        (header.motor_count as usize).min(64),
    );
    let len = match rng.below(4) {
        0 => rng.below(exact + 8),
        _ => exact,
    };
    let mut words = Vec::with_capacity(len);
    for i in 0..len {
        // The first word of an entry holds an index, the rest numbers.
        let torques = TORQUE_WORDS * header.torque_count as usize;
        let first = if i < torques {
            i.is_multiple_of(TORQUE_WORDS)
        } else {
            (i - torques).is_multiple_of(IMPULSE_WORDS)
        };
        words.push(if first {
            u64::from(index(rng, joints.max(bodies)))
        } else {
            float(rng).to_bits()
        });
    }
    (header, words)
}

/// A random control request: every field drawn from small, boundary and
/// random values. Two are left out, being requests a client may make and
/// not faults: a shutdown (it ends the run) and a join as a controller (the
/// server then waits for its answers).
pub fn control_request(rng: &mut Rng) -> ControlRequest {
    let mut r = ControlRequest {
        version: if rng.uniform() < 0.8 {
            PROTOCOL_VERSION
        } else {
            index(rng, 3)
        },
        command: index(rng, 14),
        role: index(rng, 4),
        controller_id: index(rng, 4),
        count: match rng.below(4) {
            0 => u64::MAX,
            1 => (rng.uniform() * u64::MAX as f64) as u64,
            _ => rng.below(5) as u64,
        },
        node_id_lo: (rng.uniform() * u64::MAX as f64) as u64,
        node_id_hi: (rng.uniform() * u64::MAX as f64) as u64,
        pid: (rng.uniform() * u64::MAX as f64) as u64,
    };
    if r.command == CMD_SHUTDOWN || (r.command == CMD_JOIN && r.role == ROLE_CONTROLLER) {
        r.command = 0;
    }
    r
}

/// `n` input cases from `seed` on the reference scene: each frame checked
/// as the server checks it; a taken one applied and stepped. One engine
/// runs through all the cases, so an input that poisons the state shows
/// in the next step.
pub fn inputs(seed: u64, n: u64) -> Counts {
    let mut counts = Counts::default();
    let scene = match cosim_shared::scenes::reference() {
        Ok(s) => s,
        Err(e) => {
            counts.defects.push(format!("the reference scene: {e}"));
            return counts;
        }
    };
    let mut engine = Engine::new(Model::from_scene(&scene));
    let initial = engine.state().clone();
    // The reference scene has no motor: every motor target is refused.
    let motored = engine.model().motored();
    let lim = Limits {
        joints: engine.model().joints.len(),
        bodies: engine.model().bodies.len(),
        motored: &motored,
    };
    let mut slot = Slot::new(1, 7, 0, lim.joints);
    let mut rng = Rng::new(seed);
    let mut f = InputFrame::default();
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    for _ in 0..n {
        counts.cases += 1;
        let k = engine.state().step;
        let (header, words) = input_frame(&mut rng, 1, k, lim.joints, lim.bodies);
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            let well_formed = f.read(&header, &words).is_ok();
            match controllers::check(&f, well_formed, Some(&slot), k, lim) {
                Err(_) => return Ok(false),
                Ok(()) => controllers::accept(&f, &mut slot, k),
            }
            for j in 0..lim.joints {
                let t = controllers::net_torque(std::slice::from_ref(&slot), j, [0.0; 3]);
                engine
                    .set_joint_torque(j, Vector3::from(t))
                    .map_err(|e| format!("a checked torque was refused: {e}"))?;
                if lim.motored[j] {
                    let v = controllers::net_motor(std::slice::from_ref(&slot), j, 0.0);
                    engine
                        .set_motor_speed(j, v)
                        .map_err(|e| format!("a checked motor target was refused: {e}"))?;
                }
            }
            for b in &slot.impulses {
                engine
                    .add_body_impulse(
                        b.body as usize,
                        Vector3::from(b.linear),
                        Vector3::from(b.angular),
                    )
                    .map_err(|e| format!("a checked impulse was refused: {e}"))?;
            }
            Ok(true)
        }));
        match outcome {
            Err(_) => {
                counts
                    .defects
                    .push(format!("checking panicked on {header:?} {words:?}"));
                continue;
            }
            Ok(Err(m)) => {
                counts.defects.push(m);
                continue;
            }
            Ok(Ok(false)) => {
                counts.refused += 1;
                continue;
            }
            Ok(Ok(true)) => counts.accepted += 1,
        }
        let stepped = catch_unwind(AssertUnwindSafe(|| {
            let r = engine.step();
            (r.ok(), finite_state(&engine))
        }));
        counts.stepped += 1;
        let ok = match stepped {
            Err(_) => {
                counts.defects.push("a step panicked after an input".into());
                false
            }
            Ok((true, true)) => true,
            Ok((false, _)) => {
                counts.failed_steps += 1;
                false
            }
            Ok((true, false)) => {
                counts.defects.push(format!(
                    "a step said ok and left a non-finite state after {f:?}"
                ));
                false
            }
        };
        // A failed step, or now and then any, starts over from the scene's
        // state: the next inputs test the decoder, not a state already lost.
        if !ok || rng.uniform() < 0.01 {
            engine.set_state(initial.clone());
            slot = Slot::new(1, 7, 0, lim.joints);
        }
    }
    std::panic::set_hook(hook);
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_found_where_they_stand() {
        let s = "a = 1.5\nb = [-2e-3, x1]\nc_2 = 3";
        let found: Vec<&str> = numbers(s).iter().map(|&(a, b)| &s[a..b]).collect();
        assert_eq!(found, ["1.5", "-2e-3", "3"]);
    }
}
