//! Coupling rows: a joint's coordinate tied to another's,
//! `q_F = r q_L + o` (a URDF `<mimic>`, an MJCF `<equality><joint>`).
//!
//! The row is the rate of `psi = q_F - r q_L - o`: the follower's rate row
//! (`motor::rate_row`, `G_F^T nu = q_F'`) less `r` times the leader's. The
//! two rate rows span up to four bodies (two of them shared when both
//! joints hang from one parent, as a gripper's fingers do), so a coupling
//! is a *head* row, the follower's, stored with the joint rows, and a
//! *tail* row, the leader's times `-r`, beside it ([`Tails`]); every
//! reader of the joint block adds the tail where there is one. Its offset
//! `factor psi / h` gives `psi' = -factor psi / h`, the joints' rule. Its
//! impulse turns both joints (a gear train's reaction: the follower's
//! load reaches the leader), which a follower merely servoed to its
//! leader would not.

use crate::constraint::applied::InvMass;
use crate::constraint::joint::coordinate;
use crate::constraint::motor::rate_row;
use crate::constraint::rows::Row;
use crate::model::state::State;
use crate::model::{Coupling, Joint};

/// The tail rows of the joint block's couplings: the block's rows
/// `first..first + rows.len()` are couplings, row `first + i` with tail
/// `rows[i]`.
#[derive(Debug, Clone, Copy)]
pub struct Tails<'a> {
    pub first: usize,
    pub rows: &'a [Row],
}

impl<'a> Tails<'a> {
    /// No coupling.
    pub const NONE: Tails<'static> = Tails {
        first: 0,
        rows: &[],
    };

    /// Row `k`'s tail, if it is a coupling's.
    #[inline]
    pub fn get(&self, k: usize) -> Option<&'a Row> {
        k.checked_sub(self.first).and_then(|i| self.rows.get(i))
    }

    /// Row `k`'s Delassus diagonal `G_k^T M^-1 G_k` (`row` its head) with
    /// its tail.
    pub fn diagonal(&self, k: usize, row: &Row, minv: &[InvMass]) -> f64 {
        let d = row.coupling(row, minv);
        match self.get(k) {
            Some(t) => d + 2.0 * row.coupling(t, minv) + t.coupling(t, minv),
            None => d,
        }
    }

    /// `G_k^T nu` of row `k` (`row` its head) with its tail.
    #[inline]
    pub fn velocity(&self, k: usize, row: &Row, nu: &[f64]) -> f64 {
        let v = row.velocity(nu);
        match self.get(k) {
            Some(t) => v + t.velocity(nu),
            None => v,
        }
    }
}

/// The follower's position error `psi = q_F - r q_L - o`, a hinge's taken
/// the short way round (as a servo's, `motor::drive`).
pub fn error(c: &Coupling, joints: &[Joint], state: &State) -> f64 {
    let follower = &joints[c.follower];
    let q = |j: &Joint| coordinate(j, state).map_or(0.0, |(q, _)| q);
    let e = q(follower) - c.ratio * q(&joints[c.leader]) - c.offset;
    if follower.slide.is_none() {
        use std::f64::consts::{PI, TAU};
        (e + PI).rem_euclid(TAU) - PI
    } else {
        e
    }
}

/// Coupling `c`'s head row, tail row and offset (`factor` and `h` as
/// `joint::push_rows` takes them).
pub fn rows(c: &Coupling, joints: &[Joint], state: &State, factor: f64, h: f64) -> (Row, Row, f64) {
    // Validated: both joints are hinges or sliders, which have rate rows.
    let none = Row { a: None, b: None };
    let head = rate_row(&joints[c.follower], state).unwrap_or(none);
    let tail = rate_row(&joints[c.leader], state).unwrap_or(none);
    (
        head,
        Row::combine(&tail, -c.ratio, &tail, 0.0),
        factor * error(c, joints, state) / h,
    )
}

/// The bodies a coupling's rows touch (its tail's), as `(body, body)`
/// links for the islands: a coupling ties its two joints' islands.
pub fn links<'a>(tails: &'a [Row], heads: &'a [Row]) -> impl Iterator<Item = (usize, usize)> + 'a {
    heads.iter().zip(tails).filter_map(|(h, t)| {
        let head = h.a.or(h.b)?.body;
        let tail = t.a.or(t.b)?.body;
        Some((head, tail))
    })
}
