//! Measurements of a state: energy, penetration, joint error.

pub mod report;

use crate::collision::{detect, Geometry, Keep, Listing, Scratch};
use crate::model::state;
use crate::model::state::State;
use crate::model::Model;
use nalgebra::{UnitQuaternion, Vector3};

/// Energy of a state (J).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Energy {
    pub kinetic: f64,
    /// Gravitational potential `-m g . x`.
    pub potential: f64,
    /// `kinetic + potential`, sampled at the end of the step.
    pub total: f64,
    /// The total with the potential taken at the middle of the step,
    /// `E_k - (h/2) sum_i m_i (-g) . v_i`: positions advance with the
    /// end-of-step velocity, so the end-of-step total carries an offset that
    /// rises whenever bodies accelerate upwards, although the scheme never
    /// adds energy (formulation.md, "Energy, measured honestly"). This is the
    /// figure that must never grow without input.
    pub midpoint: f64,
}

pub fn energy(model: &Model, state: &State) -> Energy {
    let g = model.params.gravity;
    let h = model.params.h;
    let (mut kinetic, mut potential, mut offset) = (0.0, 0.0, 0.0);
    for (i, (b, s)) in model.bodies.iter().zip(&state.bodies).enumerate() {
        potential -= b.mass * g.dot(&s.x);
        // A body at rest adds exactly zero to the other two (a sleeping
        // pile's step spent a tenth of its time here); a sleeping one is
        // at rest, and its tag is read faster than its velocities.
        if state::asleep(state, i) || (s.v == Vector3::zeros() && s.w == Vector3::zeros()) {
            continue;
        }
        let r = s.q.to_rotation_matrix();
        let j_world = r.matrix() * b.inertia * r.matrix().transpose();
        kinetic += 0.5 * b.mass * s.v.norm_squared() + 0.5 * s.w.dot(&(j_world * s.w));
        offset += 0.5 * h * b.mass * (-g).dot(&s.v);
    }
    // The rotors' (`constraint::armature`): theirs is the bodies' energy
    // their rows took or gave.
    kinetic += model
        .joints
        .iter()
        .map(|j| crate::constraint::armature::energy(j, state))
        .sum::<f64>();
    let total = kinetic + potential;
    Energy {
        kinetic,
        potential,
        total,
        midpoint: total - offset,
    }
}

/// The deepest penetration among the contacts with no awake body, kept
/// while the sleeping bodies and their poses stay what they were: a
/// sleeping pile's overlaps do not change, and measuring them every step
/// cost more than the rest of its step (1,000 spheres asleep: 0.8 ms of
/// about 1 ms). Measured again when a body sleeps or wakes or a sleeping
/// body's pose differs (a restored snapshot).
#[derive(Debug, Clone, Default)]
pub struct Asleep {
    /// Every body's sleep tag and each sleeping body's pose, as measured.
    tags: Vec<u32>,
    poses: Vec<(Vector3<f64>, UnitQuaternion<f64>)>,
    depth: f64,
    /// The caller's `sleep::Awake` listing it was measured or compared at.
    vouched: Option<u64>,
}

impl Asleep {
    /// The sleeping bodies' poses, in body order.
    fn poses(state: &State) -> impl Iterator<Item = (Vector3<f64>, UnitQuaternion<f64>)> + '_ {
        (state.bodies.iter().enumerate())
            .filter(|&(i, _)| state::asleep(state, i))
            .map(|(_, b)| (b.x, b.q))
    }

    fn unchanged(&self, state: &State) -> bool {
        self.tags == state.sleep_tag && self.poses.iter().copied().eq(Asleep::poses(state))
    }

    /// The deepest penetration among the contacts with no awake body (m,
    /// at least 0), measured again only when the sleeping bodies or their
    /// poses changed (`scratch` then holds their geometry). `vouched`, the
    /// engine's `sleep::Awake` listing of `state`, vouches while it stands
    /// that neither did since the last call: it moves when a body sleeps
    /// or wakes or a state is restored, and a step moves no sleeping body.
    /// Without it the tags and poses are compared.
    pub fn deepest(
        &mut self,
        model: &Model,
        state: &State,
        vouched: Option<u64>,
        collision: &mut Scratch,
        scratch: &mut Vec<Geometry>,
    ) -> f64 {
        if vouched.is_some() && vouched == self.vouched {
            return self.depth;
        }
        self.vouched = vouched;
        if !state::any_asleep(state) {
            // The key no state with a sleeping body matches.
            self.tags.clear();
            self.depth = 0.0;
        } else if !self.unchanged(state) {
            detect(
                model,
                state,
                listing(model),
                Keep::Asleep,
                collision,
                scratch,
            );
            self.depth = deepest(scratch);
            self.tags.clear();
            self.tags.extend_from_slice(&state.sleep_tag);
            self.poses.clear();
            self.poses.extend(Asleep::poses(state));
        }
        self.depth
    }
}

/// What [`max_penetration`] lists: only overlapping contacts can have a
/// penetration, and the broad phase lists just those (every contact
/// without it, as the step does).
fn listing(model: &Model) -> Listing<'static> {
    if model.params.broad_phase() {
        Listing::Overlapping
    } else {
        Listing::All
    }
}

/// The deepest penetration among `geoms` (m, >= 0): any list that holds
/// every overlapping contact gives the same figure, to the bit (a
/// contact's gap is its pair's formula, whatever else is listed).
pub fn deepest(geoms: &[Geometry]) -> f64 {
    geoms.iter().fold(0.0f64, |a, g| a.max(-g.gap))
}

/// Deepest penetration over every potential contact (m, >= 0). Those with
/// no awake body come from `asleep` while it holds.
pub fn max_penetration(
    model: &Model,
    state: &State,
    collision: &mut Scratch,
    scratch: &mut Vec<Geometry>,
    asleep: &mut Asleep,
) -> f64 {
    let sleeping = asleep.deepest(model, state, None, collision, scratch);
    detect(
        model,
        state,
        listing(model),
        Keep::Awake,
        collision,
        scratch,
    );
    deepest(scratch).max(sleeping)
}

/// Largest rotation error of the hinges, sliders and fixed joints (rad).
pub fn max_joint_angle_error(model: &Model, state: &State) -> f64 {
    model.joints.iter().fold(0.0f64, |a, j| {
        a.max(crate::constraint::joint::angle_error(j, state))
    })
}

/// Largest joint error `|psi_b|` (m; a slider's off its axis).
pub fn max_joint_error(model: &Model, state: &State) -> f64 {
    model.joints.iter().fold(0.0f64, |a, j| {
        a.max(crate::constraint::joint::anchor_error(j, state))
    })
}
