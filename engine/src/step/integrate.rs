//! The position update from the solved velocities.

use super::Engine;
use crate::integrate;
use crate::integrate::rattle;
use crate::measure::report::StepError;
use crate::measure::report::StepReport;
use crate::model::{Attachment, Counterpart};
use cosim_shared::Integrator;

impl Engine {
    /// The new poses from `nu'` (the trapezoid update keeps Euler's for
    /// the bodies `mark_impulsive` lists); a pose that is not finite fails
    /// the step.
    pub(super) fn integrate(&mut self, report: &mut StepReport) -> Result<(), StepError> {
        let _span = tracing::trace_span!("integrate").entered();
        self.mark_impulsive();
        // The smooth islands' RATTLE step, from the step's start.
        self.smooth_islands(report);
        let p = &self.model.params;
        let ws = &mut self.ws;
        ws.awake.refresh(&self.state);
        integrate::positions(
            &mut self.state,
            &ws.nu,
            p.h,
            p.position_update,
            &ws.impulsive,
            ws.awake.bodies(),
            &mut ws.poses,
        )
        .map_err(|body| StepError::NonFinitePose { body })?;
        let smooth = &ws.smooth;
        for (&i, b) in smooth.bodies.iter().zip(&smooth.states) {
            self.state.bodies[i as usize] = *b;
        }
        Ok(())
    }

    /// With `integrator = "rattle"` or `"rattle4"`, the islands with
    /// joints and no contact (no listed contact or limit on any of their
    /// bodies: none within reach of the step), no motor and no joint
    /// compliance, stepped by RATTLE (`integrate::rattle`) from the step's
    /// start into `ws.smooth`; the step's own answer for them is replaced
    /// after the position update. An island whose RATTLE iteration fails
    /// keeps the step's answer and is counted.
    fn smooth_islands(&mut self, report: &mut StepReport) {
        let (model, ws) = (&self.model, &mut self.ws);
        let smooth = &mut ws.smooth;
        smooth.bodies.clear();
        smooth.states.clear();
        let p = &model.params;
        if p.integrator == Integrator::Euler
            || p.joint_compliance.is_some()
            || model.joints.is_empty()
        {
            return;
        }
        let groups = &ws.groups;
        let nb = ws.mlcp.nb;
        // Per island: whether it may take RATTLE (only joint rows, no
        // motor, every body awake and in no listed contact).
        smooth.ok.clear();
        smooth.ok.resize(groups.len(), true);
        for g in 0..groups.len() {
            if groups.rows_of(g).iter().any(|&k| k as usize >= nb) {
                smooth.ok[g] = false;
            }
        }
        for &j in &model.motors {
            smooth.ok[groups.island_of_row(model.joint_start[j])] = false;
        }
        // RATTLE holds the joints, not the rotors or the couplings.
        for k in ws.mlcp.armature().start..nb {
            smooth.ok[groups.island_of_row(k)] = false;
        }
        smooth.island_of.clear();
        smooth.island_of.resize(model.bodies.len(), u32::MAX);
        for (k, row) in ws.mlcp.rows[..nb].iter().enumerate() {
            for j in [row.a, row.b].into_iter().flatten() {
                smooth.island_of[j.body] = groups.island_of_row(k) as u32;
            }
        }
        let mut off = |i: usize| {
            if let Some(&g) = smooth.island_of.get(i).filter(|&&g| g != u32::MAX) {
                smooth.ok[g as usize] = false;
            }
        };
        for c in &ws.contacts {
            off(c.geom.a);
            if let crate::model::Counterpart::Body(j) = c.geom.b {
                off(j);
            }
        }
        for i in 0..model.bodies.len() {
            if crate::model::state::asleep(&self.state, i) {
                off(i);
            }
        }
        // Each island's bodies and joints, ascending, in one pass each.
        let joint_island = |j: usize| groups.island_of_row(model.joint_start[j]) as u32;
        bucket(
            groups.len(),
            (0..model.bodies.len()).map(|i| smooth.island_of[i]),
            &mut smooth.body_start,
            &mut smooth.island_bodies,
        );
        bucket(
            groups.len(),
            (0..model.joints.len()).map(joint_island),
            &mut smooth.joint_start,
            &mut smooth.island_joints,
        );
        for g in 0..groups.len() {
            if !smooth.ok[g] || groups.rows_of(g).is_empty() {
                continue;
            }
            let span = |start: &[u32]| start[g] as usize..start[g + 1] as usize;
            let bodies = &smooth.island_bodies[span(&smooth.body_start)];
            let island = rattle::Island {
                bodies,
                joints: &smooth.island_joints[span(&smooth.joint_start)],
            };
            let stepped = rattle::step(
                model,
                &self.state,
                &self.inputs,
                island,
                p.integrator,
                &mut smooth.rattle,
                &mut smooth.out,
            );
            match stepped {
                Ok(()) => {
                    report.smooth_islands += 1;
                    smooth.bodies.extend_from_slice(bodies);
                    smooth.states.extend_from_slice(&smooth.out);
                }
                Err(e) => {
                    report.smooth_left += 1;
                    tracing::debug!("island {g} left to the step: {e:?}");
                }
            }
        }
    }

    /// For the trapezoid update, the bodies that keep the Euler update: the
    /// bodies of every contact that carried an impulse while approaching
    /// faster than the restitution threshold (an impact), and every body on
    /// a joint.
    fn mark_impulsive(&mut self) {
        let ws = &mut self.ws;
        ws.impulsive.clear();
        ws.impulsive.resize(self.model.bodies.len(), false);
        if self.model.params.position_update != cosim_shared::PositionUpdate::Trapezoid {
            return;
        }
        let m = &ws.mlcp;
        for (i, &ci) in m.lcp_contacts.iter().enumerate() {
            let c = &ws.contacts[ci];
            if m.z[i] > 0.0 && c.v_n < -self.model.params.restitution_threshold {
                ws.impulsive[c.geom.a] = true;
                if let Counterpart::Body(j) = c.geom.b {
                    ws.impulsive[j] = true;
                }
            }
        }
        // Jointed bodies keep the Euler update: the joint rows constrain v'
        // at the start-of-step positions, and the mean with v (which met
        // them at the previous positions) drifts off the joint manifold.
        // Measured: the S4 chain gained energy without bound.
        for j in &self.model.joints {
            for a in [j.a, j.b] {
                if let Attachment::Body(i) = a {
                    ws.impulsive[i] = true;
                }
            }
        }
    }
}

/// Counting sort of the items `0..` by their island (`u32::MAX`: none):
/// island `g`'s items, ascending, are `items[start[g]..start[g + 1]]`.
fn bucket(
    islands: usize,
    island_of: impl Iterator<Item = u32> + Clone,
    start: &mut Vec<u32>,
    items: &mut Vec<u32>,
) {
    start.clear();
    start.resize(islands + 1, 0);
    for g in island_of.clone().filter(|&g| g != u32::MAX) {
        start[g as usize + 1] += 1;
    }
    for g in 0..islands {
        start[g + 1] += start[g];
    }
    items.clear();
    items.resize(start[islands] as usize, 0);
    // Each start serves as its island's cursor, then moves back.
    for (i, g) in island_of.enumerate().filter(|&(_, g)| g != u32::MAX) {
        items[start[g as usize] as usize] = i as u32;
        start[g as usize] += 1;
    }
    for g in (1..=islands).rev() {
        start[g] = start[g - 1];
    }
    start[0] = 0;
}
