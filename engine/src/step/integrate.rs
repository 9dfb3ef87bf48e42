//! The position update from the solved velocities.

use super::Engine;
use crate::integrate;
use crate::measure::report::StepError;
use crate::model::{Attachment, Counterpart};

impl Engine {
    /// The new poses from `nu'` (the trapezoid update keeps Euler's for
    /// the bodies `mark_impulsive` lists); a pose that is not finite fails
    /// the step.
    pub(super) fn integrate(&mut self) -> Result<(), StepError> {
        let _span = tracing::trace_span!("integrate").entered();
        self.mark_impulsive();
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
        .map_err(|body| StepError::NonFinitePose { body })
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
