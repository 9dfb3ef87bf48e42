//! The joined controllers, the checks on their inputs and the miss policy.
//! Pure: no iceoryx2 here, so every rule has a unit test.

use cosim_shared::wire::*;

/// What to do when a controller's input has not arrived by the deadline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Default)]
pub enum MissPolicy {
    /// Keep the controller's last torques and motor targets (impulses
    /// are never repeated).
    #[default]
    Hold,
    /// Set the controller's torques and motor targets to zero.
    Zero,
    /// Pause the simulation until `cosim resume`.
    Pause,
    /// Stop the run (outputs are written).
    Abort,
}

/// What a step that fails does to the run (`serve --on-failure`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Default)]
pub enum FailurePolicy {
    /// Steps where the rigid LCP has no solution go on with the engine's
    /// fallback formulations (relaxed, then compliant; reported, status bit
    /// `STATUS_FELL_BACK`). A step that no formulation solves pauses the
    /// run at that state (nothing but a command or a reset can change it):
    /// it is never re-run in a loop.
    #[default]
    Continue,
    /// Rigid answers only: a step whose rigid LCP fails is not taken, and
    /// the run pauses at the state before it (`STATUS_SOLVER_FAILED` and
    /// `STATUS_PAUSED`) until `cosim resume`, `step`, `reset` or `restore`.
    Pause,
    /// Rigid answers only: the run stops at the first failed step; its
    /// files hold every step before it.
    Abort,
}

impl FailurePolicy {
    pub fn as_str(self) -> &'static str {
        match self {
            FailurePolicy::Continue => "continue",
            FailurePolicy::Pause => "pause",
            FailurePolicy::Abort => "abort",
        }
    }
}

impl MissPolicy {
    /// The input a rejected answer gets: the policy's, except that pause
    /// and abort (which are about silence) hold.
    pub fn for_rejected(self) -> MissPolicy {
        match self {
            MissPolicy::Zero => MissPolicy::Zero,
            _ => MissPolicy::Hold,
        }
    }

    pub fn as_str(self) -> &'static str {
        match self {
            MissPolicy::Hold => "hold",
            MissPolicy::Zero => "zero",
            MissPolicy::Pause => "pause",
            MissPolicy::Abort => "abort",
        }
    }
}

/// One joined controller.
#[derive(Debug, Clone)]
pub struct Slot {
    pub id: u32,
    /// Its iceoryx2 node, to tell dead from slow.
    pub node_id: u128,
    /// The input publisher this slot takes inputs from: the first one of
    /// its node that sent with its id (see [`owns`]).
    pub publisher: Option<u128>,
    pub pid: u64,
    /// Torques this controller holds, by joint (None: never set); sized
    /// to the model's joints when it joins.
    pub held: Vec<Option<[f64; 3]>>,
    /// Motor targets it holds, by joint, likewise.
    pub held_motor: Vec<Option<f64>>,
    /// Impulses for the coming step.
    pub impulses: Vec<BodyImpulse>,
    /// The step it answered last.
    pub answered: Option<u64>,
    pub misses: u32,
    /// `REJECT_*` bits of this step.
    pub rejected: u32,
    /// `REJECT_*` bits already logged (each reason is logged once).
    pub logged: u32,
    pub missed_now: bool,
    /// Left after answering the coming step: removed once it is taken.
    pub leaving: bool,
    /// Departure checks in a row that found it gone (`drop_departed`).
    pub gone_checks: u8,
}

impl Slot {
    /// A slot for a scene of `joints` joints.
    pub fn new(id: u32, node_id: u128, pid: u64, joints: usize) -> Slot {
        Slot {
            id,
            node_id,
            publisher: None,
            pid,
            held: vec![None; joints],
            held_motor: vec![None; joints],
            impulses: Vec::new(),
            answered: None,
            misses: 0,
            rejected: 0,
            logged: 0,
            missed_now: false,
            leaving: false,
            gone_checks: 0,
        }
    }

    /// The miss policy's input for this controller.
    pub fn apply_miss(&mut self, policy: MissPolicy) {
        self.impulses.clear();
        if policy == MissPolicy::Zero {
            for h in self.held.iter_mut().flatten() {
                *h = [0.0; 3];
            }
            for m in self.held_motor.iter_mut().flatten() {
                *m = 0.0;
            }
        }
    }
}

/// The sizes inputs are checked against, and which joints have a motor.
#[derive(Debug, Clone, Copy)]
pub struct Limits<'a> {
    pub joints: usize,
    pub bodies: usize,
    pub motored: &'a [bool],
}

/// Why an input was not taken, with the reason bit; `answered` says
/// whether it still counts as the controller's answer to the step (its
/// step was right, so the server need not wait for the deadline).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rejection {
    pub reason: u32,
    pub answered: bool,
}

/// Checks an input for step `step` from the controller in `slot`;
/// `well_formed` says whether its words matched its header's counts.
pub fn check(
    input: &InputFrame,
    well_formed: bool,
    slot: Option<&Slot>,
    step: u64,
    lim: Limits<'_>,
) -> Result<(), Rejection> {
    let reject = |reason, answered| Err(Rejection { reason, answered });
    if input.version != PROTOCOL_VERSION {
        return reject(REJECT_VERSION, false);
    }
    let Some(slot) = slot else {
        return reject(REJECT_UNKNOWN_CONTROLLER, false);
    };
    // A second answer to the step this controller answered last is a
    // duplicate whenever it is read: in the same wait, or in the next
    // step's, where it used to count as a wrong step (issue 15: the
    // reason depended on timing). Any other step is a wrong step.
    if slot.answered == Some(input.step) {
        return reject(REJECT_DUPLICATE, false);
    }
    if input.step != step {
        return reject(REJECT_WRONG_STEP, false);
    }
    if !well_formed {
        return reject(REJECT_BAD_COUNT, true);
    }
    let torques = &input.torques[..];
    let impulses = &input.impulses[..];
    let motors = &input.motors[..];
    // A motor target names a joint with a motor (an index of no motor is
    // unknown, as an index of no joint is).
    if torques.iter().any(|t| t.joint as usize >= lim.joints)
        || impulses.iter().any(|b| b.body as usize >= lim.bodies)
        || motors
            .iter()
            .any(|m| !lim.motored.get(m.joint as usize).copied().unwrap_or(false))
    {
        return reject(REJECT_UNKNOWN_INDEX, true);
    }
    for (i, t) in torques.iter().enumerate() {
        if torques[..i].iter().any(|u| u.joint == t.joint) {
            return reject(REJECT_DUPLICATE, true);
        }
    }
    for (i, m) in motors.iter().enumerate() {
        if motors[..i].iter().any(|u| u.joint == m.joint) {
            return reject(REJECT_DUPLICATE, true);
        }
    }
    let finite = torques
        .iter()
        .all(|t| t.torque.iter().all(|x| x.is_finite()))
        && impulses
            .iter()
            .all(|b| b.linear.iter().chain(&b.angular).all(|x| x.is_finite()))
        && motors.iter().all(|m| m.speed.is_finite());
    if !finite {
        return reject(REJECT_NON_FINITE, true);
    }
    Ok(())
}

/// Whether an input that publisher `origin` sent with this slot's id comes
/// from the process that joined (issue 15, defect 4: inputs were taken on
/// their `controller_id` alone). The slot is bound to the first publisher
/// whose node (`node_of`, read from the input service's ports) is the one
/// that joined; from then on only that publisher's inputs are its own.
pub fn owns(slot: &mut Slot, origin: u128, node_of: impl FnOnce(u128) -> Option<u128>) -> bool {
    match slot.publisher {
        Some(p) => p == origin,
        None if node_of(origin) == Some(slot.node_id) => {
            slot.publisher = Some(origin);
            true
        }
        None => false,
    }
}

/// Takes a checked input into the slot.
pub fn accept(input: &InputFrame, slot: &mut Slot, step: u64) {
    for t in &input.torques {
        if let Some(h) = slot.held.get_mut(t.joint as usize) {
            *h = Some(t.torque);
        }
    }
    for m in &input.motors {
        if let Some(h) = slot.held_motor.get_mut(m.joint as usize) {
            *h = Some(m.speed);
        }
    }
    slot.impulses.clear();
    slot.impulses.extend_from_slice(&input.impulses);
    slot.answered = Some(step);
    slot.misses = 0;
}

/// The torque of joint `j`: the sum over the controllers that set it, or
/// the scene's own torque when none did.
pub fn net_torque(slots: &[Slot], j: usize, scene: [f64; 3]) -> [f64; 3] {
    let mut any = false;
    let mut sum = [0.0; 3];
    for s in slots {
        if let Some(&Some(t)) = s.held.get(j) {
            any = true;
            for k in 0..3 {
                sum[k] += t[k];
            }
        }
    }
    if any {
        sum
    } else {
        scene
    }
}

/// The motor target of joint `j`: the one the lowest controller id holds
/// (a sum of targets means nothing; the choice is deterministic), or the
/// scene's when none does.
pub fn net_motor(slots: &[Slot], j: usize, scene: f64) -> f64 {
    slots
        .iter()
        .filter_map(|s| s.held_motor.get(j).copied().flatten().map(|v| (s.id, v)))
        .min_by_key(|&(id, _)| id)
        .map_or(scene, |(_, v)| v)
}

/// The name of a reason bit.
pub fn reason_name(bit: u32) -> &'static str {
    REJECT_REASONS
        .iter()
        .find(|(b, _)| *b == bit)
        .map_or("unknown", |(_, n)| n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slot_takes_inputs_from_the_publisher_of_the_node_that_joined() {
        let mut slot = Slot::new(1, 77, 0, 2);
        // A publisher of another node is refused and binds nothing.
        assert!(!owns(&mut slot, 5, |_| Some(78)));
        assert!(!owns(&mut slot, 5, |_| None));
        assert_eq!(slot.publisher, None);
        // The first publisher of node 77 binds the slot ...
        assert!(owns(&mut slot, 6, |p| (p == 6).then_some(77)));
        assert_eq!(slot.publisher, Some(6));
        assert!(owns(&mut slot, 6, |_| unreachable!()));
        // ... and a second one of the same node no longer matches.
        assert!(!owns(&mut slot, 7, |_| Some(77)));
    }

    /// Joint 0 has a motor, joint 1 none.
    const LIM: Limits = Limits {
        joints: 2,
        bodies: 2,
        motored: &[true, false],
    };

    fn input(step: u64) -> InputFrame {
        let mut i = InputFrame {
            controller_id: 1,
            step,
            ..Default::default()
        };
        i.push_torque(0, [1.0, 2.0, 3.0]);
        i.push_impulse(1, [0.0, 0.0, 1.0], [0.0; 3]);
        i
    }

    fn reason(r: Result<(), Rejection>) -> u32 {
        r.err().map_or(0, |r| r.reason)
    }

    #[test]
    fn each_bad_input_is_rejected_with_its_reason() {
        let slot = Slot::new(1, 0, 0, 2);
        assert_eq!(check(&input(5), true, Some(&slot), 5, LIM), Ok(()));
        assert_eq!(
            reason(check(&input(5), true, None, 5, LIM)),
            REJECT_UNKNOWN_CONTROLLER
        );
        assert_eq!(
            reason(check(&input(4), true, Some(&slot), 5, LIM)),
            REJECT_WRONG_STEP
        );
        let mut v = input(5);
        v.version = 99;
        assert_eq!(reason(check(&v, true, Some(&slot), 5, LIM)), REJECT_VERSION);
        let mut nan = input(5);
        nan.torques[0].torque[1] = f64::NAN;
        assert_eq!(
            reason(check(&nan, true, Some(&slot), 5, LIM)),
            REJECT_NON_FINITE
        );
        let mut inf = input(5);
        inf.impulses[0].angular[2] = f64::INFINITY;
        assert_eq!(
            reason(check(&inf, true, Some(&slot), 5, LIM)),
            REJECT_NON_FINITE
        );
        let mut joint = input(5);
        joint.torques[0].joint = 2;
        assert_eq!(
            reason(check(&joint, true, Some(&slot), 5, LIM)),
            REJECT_UNKNOWN_INDEX
        );
        let mut body = input(5);
        body.impulses[0].body = 7;
        assert_eq!(
            reason(check(&body, true, Some(&slot), 5, LIM)),
            REJECT_UNKNOWN_INDEX
        );
        let mut twice = input(5);
        twice.push_torque(0, [0.0; 3]);
        assert_eq!(
            reason(check(&twice, true, Some(&slot), 5, LIM)),
            REJECT_DUPLICATE
        );
        let count = input(5);
        assert_eq!(
            reason(check(&count, false, Some(&slot), 5, LIM)),
            REJECT_BAD_COUNT
        );
        // Motor targets: for a joint with a motor, once, finite.
        let mut motor = input(5);
        motor.push_motor(0, 1.5);
        assert_eq!(check(&motor, true, Some(&slot), 5, LIM), Ok(()));
        for (joint, speed, expect) in [
            (1, 1.0, REJECT_UNKNOWN_INDEX),
            (2, 1.0, REJECT_UNKNOWN_INDEX),
            (0, 2.0, REJECT_DUPLICATE),
        ] {
            let mut bad = motor.clone();
            bad.push_motor(joint, speed);
            assert_eq!(reason(check(&bad, true, Some(&slot), 5, LIM)), expect);
        }
        motor.motors[0].speed = f64::NAN;
        assert_eq!(
            reason(check(&motor, true, Some(&slot), 5, LIM)),
            REJECT_NON_FINITE
        );
    }

    /// A motor target is held; the lowest controller id's applies where
    /// several hold one, the scene's where none does; the zero policy
    /// stops it.
    #[test]
    fn motor_targets_are_held_and_the_lowest_id_applies() {
        let (mut a, mut b) = (Slot::new(2, 0, 0, 2), Slot::new(1, 0, 0, 2));
        let mut fa = InputFrame::default();
        fa.push_motor(0, 3.0);
        accept(&fa, &mut a, 0);
        assert_eq!(net_motor(&[a.clone(), b.clone()], 0, 9.0), 3.0);
        let mut fb = InputFrame::default();
        fb.push_motor(0, -1.0);
        accept(&fb, &mut b, 0);
        accept(&InputFrame::default(), &mut a, 1);
        let slots = [a, b];
        assert_eq!(net_motor(&slots, 0, 9.0), -1.0);
        assert_eq!(net_motor(&slots, 1, 9.0), 9.0);
        let mut z = slots[0].clone();
        z.apply_miss(MissPolicy::Zero);
        assert_eq!(z.held_motor[0], Some(0.0));
    }

    #[test]
    fn a_second_answer_to_a_step_is_a_duplicate() {
        let mut slot = Slot::new(1, 0, 0, 2);
        accept(&input(5), &mut slot, 5);
        assert_eq!(
            reason(check(&input(5), true, Some(&slot), 5, LIM)),
            REJECT_DUPLICATE
        );
        assert_eq!(check(&input(6), true, Some(&slot), 6, LIM), Ok(()));
        // Read in the next step's wait: still a duplicate, not a wrong step.
        assert_eq!(
            reason(check(&input(5), true, Some(&slot), 6, LIM)),
            REJECT_DUPLICATE
        );
        // A step it never answered: a wrong step.
        assert_eq!(
            reason(check(&input(3), true, Some(&slot), 6, LIM)),
            REJECT_WRONG_STEP
        );
    }

    #[test]
    fn torques_are_held_summed_and_fall_back_to_the_scene() {
        let mut a = Slot::new(1, 0, 0, 2);
        let mut b = Slot::new(2, 0, 0, 2);
        accept(&input(0), &mut a, 0);
        let mut other = InputFrame::default();
        other.push_torque(0, [0.5, 0.0, 0.0]);
        accept(&other, &mut b, 0);
        let slots = [a, b];
        assert_eq!(net_torque(&slots, 0, [9.0; 3]), [1.5, 2.0, 3.0]);
        assert_eq!(net_torque(&slots, 1, [9.0; 3]), [9.0; 3]);
    }

    #[test]
    fn the_zero_policy_zeroes_and_hold_keeps() {
        let mut s = Slot::new(1, 0, 0, 2);
        accept(&input(0), &mut s, 0);
        s.apply_miss(MissPolicy::Hold);
        assert_eq!(s.held[0], Some([1.0, 2.0, 3.0]));
        assert!(s.impulses.is_empty(), "impulses are never repeated");
        s.apply_miss(MissPolicy::Zero);
        assert_eq!(s.held[0], Some([0.0; 3]));
        assert_eq!(s.held[1], None);
    }
}
