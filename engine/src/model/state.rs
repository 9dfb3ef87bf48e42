//! The state: small, `Clone`, complete. A snapshot is a copy of it, so
//! rollback and bit-exact replay need nothing else.

use super::{Counterpart, Model};
use nalgebra::{UnitQuaternion, Vector3};

/// Pose and twist of one body; velocities in the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyState {
    pub x: Vector3<f64>,
    pub q: UnitQuaternion<f64>,
    pub v: Vector3<f64>,
    pub w: Vector3<f64>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Steps taken since the initial state.
    pub step: u64,
    /// Simulated time (s): `step * h`, kept as a product so it never drifts.
    pub t: f64,
    pub bodies: Vec<BodyState>,
    /// Warm start of the iterative solver, part of the state so that a
    /// snapshot is complete and a restored PGS run repeats its bits: the
    /// last step's impulses of the contacts in its final LCP, sorted by
    /// contact id (a contact not listed had none), and joint impulses (a
    /// joint's rows: `Model::joint_start`; then each motor's, in
    /// `Model::motors`' order). Sparse: a list of every
    /// potential contact held N P + N (N - 1) / 2 entries, 16 MB per
    /// state at 1,000 spheres and 1.6 GB at 10,000 (issue 14, point 5).
    pub warm_contacts: Vec<WarmContact>,
    pub warm_joint: Vec<f64>,
    /// Lemke's guess: the last step's final LCP layout (contact id, whether
    /// it had friction rows, per normal row) and which unknowns were
    /// positive. Part of the state for the same reason as the impulses.
    pub warm_lcp: Vec<(usize, bool)>,
    pub warm_active: Vec<bool>,
    /// Sleeping (`sleep.rs`): per body, the steps it has been at rest, and
    /// the tag of its sleeping island (`sleep::AWAKE` when awake).
    pub rest: Vec<u32>,
    pub sleep_tag: Vec<u32>,
    /// Per body: the last step solved its island by a fallback, whose
    /// relaxed problem has no joint drift term, so its joints are held
    /// together at position level before the next step
    /// (`integrate::project`). Part of the state so that a restore repeats
    /// the next step's bits.
    pub drifted: Vec<bool>,
}

/// One contact's impulses of the last step, by its identity
/// (`Model::contact_id`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WarmContact {
    pub id: usize,
    /// Normal impulse (N s).
    pub normal: f64,
    /// Friction impulse as a world vector (N s): the tangent basis turns
    /// with the slip from step to step, the world vector does not.
    pub friction: Vector3<f64>,
}

impl WarmContact {
    /// Contact `id`'s entry in `list` (ascending id).
    pub fn find(list: &[WarmContact], id: usize) -> Option<&WarmContact> {
        list.binary_search_by_key(&id, |w| w.id)
            .ok()
            .map(|k| &list[k])
    }
}

/// [`WarmContact::find`] for queries that come in ascending id order, as
/// a step's contacts do (canonical order): a walk forward from the last
/// query, i.e. a merge of the two lists, where a binary search per query
/// cost about fifteen scattered reads of the 10,000 pile's 24,000 entries
/// (2 % of its step). A query behind the last one, or far ahead, is
/// searched for: the same answers in any order.
pub struct WarmCursor<'a> {
    list: &'a [WarmContact],
    /// The first entry with an id at least the last query's.
    at: std::cell::Cell<usize>,
}

impl<'a> WarmCursor<'a> {
    /// Entries walked past before a query is searched for instead.
    const WALK: usize = 8;

    pub fn new(list: &'a [WarmContact]) -> WarmCursor<'a> {
        WarmCursor {
            list,
            at: std::cell::Cell::new(0),
        }
    }

    pub fn find(&self, id: usize) -> Option<&'a WarmContact> {
        let list = self.list;
        let mut k = self.at.get();
        let behind = k > 0 && list[k - 1].id >= id;
        let end = (k + Self::WALK).min(list.len());
        while k < end && list[k].id < id {
            k += 1;
        }
        if behind || (k == end && k < list.len() && list[k].id < id) {
            k = list.partition_point(|w| w.id < id);
        }
        self.at.set(k);
        list.get(k).filter(|w| w.id == id)
    }
}

impl State {
    /// Bytes the state holds on the heap: what a snapshot or a restore
    /// copies. O(bodies + joints + contacts in the last LCP).
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.bodies.capacity() * size_of::<BodyState>()
            + self.warm_contacts.capacity() * size_of::<WarmContact>()
            + self.warm_joint.capacity() * size_of::<f64>()
            + self.warm_lcp.capacity() * size_of::<(usize, bool)>()
            + self.warm_active.capacity() * size_of::<bool>()
            + (self.rest.capacity() + self.sleep_tag.capacity()) * size_of::<u32>()
            + self.drifted.capacity() * size_of::<bool>()
    }

    /// The last step's impulses of contact `id`, if it was in the LCP.
    pub fn warm(&self, id: usize) -> Option<&WarmContact> {
        WarmContact::find(&self.warm_contacts, id)
    }

    pub fn initial(model: &Model) -> State {
        State {
            step: 0,
            t: 0.0,
            bodies: model
                .initial
                .iter()
                .map(|b| BodyState {
                    x: b.position,
                    q: b.orientation,
                    v: b.velocity,
                    w: b.angular_velocity,
                })
                .collect(),
            warm_contacts: Vec::new(),
            warm_joint: vec![0.0; model.joint_rows() + model.motors.len()],
            warm_lcp: Vec::new(),
            warm_active: Vec::new(),
            rest: vec![0; model.bodies.len()],
            sleep_tag: vec![AWAKE; model.bodies.len()],
            drifted: vec![false; model.bodies.len()],
        }
    }
}

/// The tag of an awake body.
pub const AWAKE: u32 = u32::MAX;

/// Whether body `i` is asleep.
pub fn asleep(state: &State, i: usize) -> bool {
    state.sleep_tag.get(i).is_some_and(|&t| t != AWAKE)
}

/// Whether any body is asleep (the step's filters are skipped otherwise).
pub fn any_asleep(state: &State) -> bool {
    state.sleep_tag.iter().any(|&t| t != AWAKE)
}

/// How many bodies are asleep.
pub fn asleep_count(state: &State) -> usize {
    state.sleep_tag.iter().filter(|&&t| t != AWAKE).count()
}

/// Whether the contact of body `a` with `b` has no awake body (between two
/// sleeping bodies, or a sleeping body and a plane): it is not listed.
pub fn unlisted(state: &State, a: usize, b: Counterpart) -> bool {
    asleep(state, a)
        && match b {
            Counterpart::Body(j) => asleep(state, j),
            Counterpart::Plane(_) | Counterpart::World => true,
        }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cursor finds what the binary search finds, for queries in
    /// ascending order with gaps of every size, going back, and past the
    /// end.
    #[test]
    fn the_cursor_finds_what_the_search_finds() {
        let mut rng = crate::testing::Xorshift::new(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.next_u64();
        for _ in 0..200 {
            let mut id = 0;
            let list: Vec<WarmContact> = (0..(next() % 60) as usize)
                .map(|_| {
                    id += 1 + (next() % 5) as usize;
                    WarmContact {
                        id,
                        normal: id as f64,
                        friction: Vector3::zeros(),
                    }
                })
                .collect();
            let cursor = WarmCursor::new(&list);
            let mut q = 0usize;
            for _ in 0..100 {
                q = match next() % 10 {
                    0 => q.saturating_sub((next() % 40) as usize),
                    1 => q + (next() % 100) as usize,
                    _ => q + (next() % 3) as usize,
                };
                let want = WarmContact::find(&list, q).map(|w| w.id);
                assert_eq!(cursor.find(q).map(|w| w.id), want, "query {q}");
            }
        }
    }
}
