//! After a successful solve: the clock advanced, the step's impulses
//! recorded for the outputs and kept, by contact identity, as the next
//! step's warm starts (the sleeping islands' kept beside them).

use super::Engine;
use crate::collision;
use crate::constraint::{joint, motor};
use crate::measure::report::{ImpulseKind, ImpulseRecord, StepReport};
use crate::model::state;
use crate::model::{Attachment, Party};
use nalgebra::Vector3;

impl Engine {
    /// The state's clock advanced, the impulses recorded, and the
    /// report's islands and active contacts.
    pub(super) fn advance(&mut self, report: &mut StepReport) {
        self.state.step += 1;
        self.state.t = self.state.step as f64 * self.model.params.h;
        self.prepared = false;
        self.record_impulses();
        let summary = self.ws.summary;
        report.islands = summary.count;
        report.largest_island = summary.largest;
        report.active_contacts = self
            .ws
            .impulses
            .iter()
            .filter(|r| r.kind == ImpulseKind::Normal)
            .count();
        // The sleeping contacts hold their islands up with the impulses
        // they had when they slept: reported, not solved.
        let ws = &mut self.ws;
        ws.impulses.extend_from_slice(&ws.sleeping_records);
    }

    /// The step's impulses as records, from the solved mLCP; also keeps
    /// them as the next step's warm start.
    fn record_impulses(&mut self) {
        let party = |a: Attachment| match a {
            Attachment::World => Party::World,
            Attachment::Body(i) => Party::Body(i),
        };
        let ws = &mut self.ws;
        let m = &ws.mlcp;
        ws.impulses.clear();
        self.state.warm_joint[..m.nb].copy_from_slice(&m.p_b);
        for (k, &j) in self.model.motors.iter().enumerate() {
            let p = m.motor_impulse(k);
            self.state.warm_joint[m.nb + k] = p;
            if p != 0.0 {
                let joint = &self.model.joints[j];
                ws.impulses.push(ImpulseRecord {
                    kind: ImpulseKind::JointMotor,
                    index: j,
                    a: party(joint.a),
                    b: party(joint.b),
                    impulse: motor::impulse_on_a(&m.motor_axis[k], p),
                });
            }
        }
        self.state.warm_lcp.clear();
        self.state.warm_active.clear();
        self.state
            .warm_active
            .extend(m.z[..m.lcp_size()].iter().map(|&x| x > 0.0));
        // A sleeping island's contacts are not listed: their warm starts
        // stay (ascending id), merged back below, so that a woken island
        // starts from its impulses, not from zero. While no body slept or
        // woke since they were picked, they are the ones picked last step:
        // the last step's listed contacts each had an awake body and still
        // have, the unlisted ones still have none. (Picking them again
        // looked up every contact's bodies: a fifth of the step of a
        // sleeping pile.)
        let listing = ws.awake.refresh(&self.state);
        if ws.sleeping_picked.every_body(listing) {
            // Picked again: the state's list is merged afresh below.
            ws.merged = false;
            ws.sleeping_warm.clear();
            ws.sleeping_records.clear();
            if state::any_asleep(&self.state) {
                let (model, state) = (&self.model, &self.state);
                ws.sleeping_warm
                    .extend(state.warm_contacts.iter().filter(|w| {
                        let (a, b) = model.contact_bodies(w.id);
                        state::unlisted(state, a, b)
                    }));
                for w in &ws.sleeping_warm {
                    let Some(g) =
                        collision::contact_geometry(model, state, w.id, &mut ws.geometries)
                    else {
                        continue;
                    };
                    let b = Party::from(g.b);
                    let record = |kind, impulse| ImpulseRecord {
                        kind,
                        index: w.id,
                        a: Party::Body(g.a),
                        b,
                        impulse,
                    };
                    if w.normal > 0.0 {
                        ws.sleeping_records
                            .push(record(ImpulseKind::Normal, g.normal * w.normal));
                    }
                    if w.friction != Vector3::zeros() {
                        ws.sleeping_records
                            .push(record(ImpulseKind::Friction, w.friction));
                    }
                }
            }
        }
        // Filled below in the LCP's contact order, which is ascending id:
        // the state's list itself when no contact sleeps, else the listed
        // part, then merged with the sleeping one.
        let alone = ws.sleeping_warm.is_empty();
        if alone {
            self.state.warm_contacts.clear();
        }
        ws.listed_warm.clear();
        for (j, joint) in self.model.joints.iter().enumerate() {
            // The anchor's force impulse and, for a joint with rotation
            // rows, their torque impulse.
            let first = self.model.joint_start[j];
            let (p, tau) = joint::impulses_on_a(joint, &m.rows[first..], &m.p_b[first..]);
            let record = |kind, impulse| ImpulseRecord {
                kind,
                index: j,
                a: party(joint.a),
                b: party(joint.b),
                impulse,
            };
            ws.impulses.push(record(ImpulseKind::Joint, p));
            if joint.rows() > joint.anchor_rows() {
                ws.impulses.push(record(ImpulseKind::JointTorque, tau));
            }
        }
        for (i, warm, block) in m.contact_impulses(&ws.contacts) {
            let c = &ws.contacts[m.lcp_contacts[i]];
            let b = Party::from(c.geom.b);
            let record = |kind, impulse| ImpulseRecord {
                kind,
                index: c.id,
                a: Party::Body(c.geom.a),
                b,
                impulse,
            };
            if let Some(limit) = c.limit {
                // The row's first side is A's, or B's when A is the world
                // (limit.rs); on it the row's impulse is the normal times
                // z (a force along an along-row, a couple about a turning
                // one).
                let joint = &self.model.joints[limit.joint];
                let on_a = match joint.a {
                    Attachment::Body(_) => c.geom.normal * m.z[i],
                    Attachment::World => -c.geom.normal * m.z[i],
                };
                if m.z[i] > 0.0 {
                    ws.impulses.push(ImpulseRecord {
                        kind: ImpulseKind::JointLimit,
                        index: limit.joint,
                        a: party(joint.a),
                        b: party(joint.b),
                        impulse: on_a,
                    });
                }
            } else if m.z[i] > 0.0 {
                ws.impulses
                    .push(record(ImpulseKind::Normal, c.geom.normal * m.z[i]));
            }
            self.state.warm_lcp.push((c.id, block));
            if warm.friction != Vector3::zeros() {
                ws.impulses
                    .push(record(ImpulseKind::Friction, warm.friction));
            }
            match alone {
                true => self.state.warm_contacts.push(warm),
                false => ws.listed_warm.push(warm),
            }
        }
        if !alone {
            let list = &mut self.state.warm_contacts;
            let (listed, asleep) = (&ws.listed_warm, &ws.sleeping_warm);
            // The same listed contacts as at the last merge, beside the
            // same sleeping ones: the merge would lay the list out as it
            // is, so the listed entries are written where they stand (a
            // robot beside a sleeping heap copied every sleeping contact's
            // warm start each step).
            let same = ws.merged
                && ws.listed_at.len() == listed.len()
                && (listed.iter().zip(&ws.listed_at))
                    .all(|(w, &k)| list.get(k as usize).is_some_and(|v| v.id == w.id));
            if same {
                for (w, &k) in listed.iter().zip(&ws.listed_at) {
                    list[k as usize] = *w;
                }
            } else {
                // Both ascending, with distinct ids (a listed contact has
                // an awake body): merged.
                list.clear();
                ws.listed_at.clear();
                let (mut i, mut j) = (0, 0);
                while i < listed.len() && j < asleep.len() {
                    if listed[i].id < asleep[j].id {
                        ws.listed_at.push(list.len() as u32);
                        list.push(listed[i]);
                        i += 1;
                    } else {
                        list.push(asleep[j]);
                        j += 1;
                    }
                }
                for w in &listed[i..] {
                    ws.listed_at.push(list.len() as u32);
                    list.push(*w);
                }
                list.extend_from_slice(&asleep[j..]);
                ws.merged = true;
            }
        }
    }
}
