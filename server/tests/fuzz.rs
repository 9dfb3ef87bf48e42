//! Fuzzing in the tests (issue 15, point 12): a short seeded run of each
//! target (`cosim-server bench fuzz` runs long ones), and the defects the
//! fuzzer found, kept as regressions.

use cosim_server::engine::{Engine, Model};
use cosim_server::fuzz;
use nalgebra::Vector3;

#[test]
fn mutated_and_generated_scenes_parse_or_name_their_fault() {
    let c = fuzz::scenes(1, 1500);
    assert!(c.defects.is_empty(), "{}", c.defects.join("\n"));
    // The run reached both sides: texts refused and texts stepped.
    assert!(c.refused > 1000 && c.stepped > 50, "{}", c.line("scenes"));
}

#[test]
fn random_input_frames_are_checked_and_no_taken_one_breaks_a_step() {
    let c = fuzz::inputs(1, 20_000);
    assert!(c.defects.is_empty(), "{}", c.defects.join("\n"));
    assert!(
        c.accepted > 5000 && c.refused > 5000,
        "{}",
        c.line("inputs")
    );
    // Taken inputs with 1e308 in them fail their step, and say so.
    assert!(c.failed_steps > 0, "{}", c.line("inputs"));
}

/// Found by the fuzzer: a torque of 1e308 N m passed the checks (it is
/// finite) and the step said ok while leaving infinite positions. The step
/// now fails with the state as it was.
#[test]
fn an_overflowing_input_fails_the_step_and_keeps_the_state() {
    let scene = cosim_shared::scenes::reference().unwrap();
    let mut e = Engine::new(Model::from_scene(&scene));
    for _ in 0..10 {
        assert!(e.step().ok());
    }
    let before = e.state().clone();
    e.set_joint_torque(0, Vector3::new(1e308, 0.0, 0.0))
        .unwrap();
    let r = e.step();
    // Lemke breaks down on it here (a free body fails at the pose check,
    // `non_finite_pose`, as the next test shows); either way it says so.
    assert!(!r.ok(), "{r:?}");
    assert_eq!(e.state(), &before);
    // With the torque taken back the run goes on.
    e.set_joint_torque(0, Vector3::zeros()).unwrap();
    assert!(e.step().ok());
    assert_eq!(e.state().step, 11);
}

/// Found by the fuzzer (scene case 484): a scene spun at 1e308 rad/s.
#[test]
fn an_overflowing_scene_fails_its_first_step_with_a_reason() {
    let text = fuzz::scene_text(484);
    assert!(text.contains("-1e308"), "{text}");
    let scene = cosim_shared::Scene::parse(&text, "<case 484>").unwrap();
    let mut e = Engine::new(Model::from_scene(&scene));
    let r = e.step();
    assert!(!r.ok());
    assert!(r.error.unwrap().to_string().contains("not finite"), "{r:?}");
    assert_eq!(e.state().step, 0);
}
