//! The collision stage: the contact set of the state, the sleeping islands
//! an awake body touches woken, and contacts projected out of deep
//! penetration; once per state.

use super::Engine;
use crate::integrate::project;
use crate::measure::report::Lap;
use crate::sleep;

impl Engine {
    /// Collision, contact set and inverse masses (and the projection out of
    /// deep penetration), once per state: `None` when done already, else
    /// the clock at its end.
    pub(super) fn prepare_contacts(&mut self) -> Option<Lap> {
        if self.prepared {
            return None;
        }
        let mut lap = Lap::start();
        self.ws.mlcp.invalidate();
        self.early_assembly = 0.0;
        let _span = tracing::trace_span!("collision").entered();
        let ws = &mut self.ws;
        ws.contact_set(&self.model, &self.state);
        // Islands an awake body touches wake; their own contacts were left
        // out, so the set is listed again (each round can reach another
        // sleeping island; at most one round per island).
        if self.model.params.sleep.is_some() {
            let reach = sleep::Reach::of(&self.model, &self.pgs_params);
            while sleep::wake_touched(&mut self.state, &ws.contacts, reach) {
                ws.contact_set(&self.model, &self.state);
            }
        }
        let depth = project::Depth::of(&self.model.params, &self.pgs_params);
        let state = &mut self.state;
        let drifted = std::mem::take(&mut state.drifted);
        let projected = depth.map(|depth| {
            let bodies = project::Bodies {
                minv: &ws.minv,
                jointed: &self.model.jointed,
                drifted: &drifted,
            };
            project::deep_penetration(
                &ws.contacts,
                bodies,
                &self.model.joints,
                depth,
                state,
                &mut self.lemke,
                &mut ws.projection,
            )
        });
        // Held for the next restore's sake: a vector of falses again.
        state.drifted = drifted;
        state.drifted.fill(false);
        let projected = match projected {
            None => project::Projected::default(),
            Some(Ok(p)) => p,
            Some(Err(e)) => {
                // The velocity stabilisation still acts on the contacts.
                tracing::warn!("projection out of deep penetration failed: {e}");
                project::Projected::default()
            }
        };
        self.projected = projected.contacts;
        if projected != project::Projected::default() {
            // The bodies moved: their contacts are those of the new positions.
            ws.contact_set(&self.model, &self.state);
        }
        self.collision_time = lap.lap();
        self.prepared = true;
        Some(lap)
    }
}
