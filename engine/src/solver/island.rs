//! Islands (issue 14, point 2): the bodies that the step's constraints tie
//! together. Two bodies are in one island when a joint or a contact in the
//! LCP links them, directly or through others; a plane is static and links
//! nothing, so a pile on a floor splits where no sphere touches another.
//!
//! The step reports how many islands it had and the bodies of the largest
//! (`StepReport::islands`, `largest_island`); a body that no constraint
//! touches (in flight) is in none. [`group`] sorts the step's
//! rows by island ([`Groups`]), and the solve stage solves each island on
//! its own (`split.rs`): their problems share no body, so the step's LCP
//! is block-diagonal by island and the islands' answers together are the
//! whole problem's.
//!
//! The partition itself is `model::islands`' union-find.

use crate::constraint::coupling::Tails;
use crate::constraint::rows::Row;
use crate::model::islands::{Islands, Summary};
use crate::model::Counterpart;

/// The step's joint and normal rows sorted by island (compressed rows):
/// island `g`'s rows are [`Groups::rows_of`]`(g)`, ascending, so that a
/// solver visits them in the whole problem's order. Islands are numbered
/// by their first row.
#[derive(Debug, Default, Clone)]
pub struct Groups {
    start: Vec<u32>,
    rows: Vec<u32>,
    /// Per row, its island (scratch of [`group`]).
    of_row: Vec<u32>,
    /// Per union-find root, its island (`u32::MAX`: none yet).
    of_root: Vec<u32>,
}

impl Groups {
    /// Islands (0 when there are no rows).
    pub fn len(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The island of row `k` of the last [`group`].
    pub fn island_of_row(&self, k: usize) -> usize {
        self.of_row[k] as usize
    }

    /// The rows of island `g` (indices into the problem's rows).
    pub fn rows_of(&self, g: usize) -> &[u32] {
        &self.rows[self.start[g] as usize..self.start[g + 1] as usize]
    }
}

/// Sorts `rows` (the joint and normal rows of the step's problem) by
/// island into `out`: two rows are in one island when a chain of rows
/// links their bodies; a coupling's row (with a tail in `tails`) links
/// its head's bodies to its tail's. A row on no body (a joint of the
/// world to itself) is an island of its own. Returns the partition's
/// summary (bodies tied by the rows; [`Islands::partition`] of their
/// links).
pub fn group(
    partition: &mut Islands,
    bodies: usize,
    rows: &[Row],
    tails: Tails,
    out: &mut Groups,
) -> Summary {
    // A row on one body ties it to something static, as a plane does.
    let link = |row: &Row| match (row.a, row.b) {
        (Some(a), Some(b)) => Some((a.body, Counterpart::Body(b.body))),
        (Some(j), None) | (None, Some(j)) => Some((j.body, Counterpart::World)),
        (None, None) => None,
    };
    let heads = &rows[tails.first.min(rows.len())..];
    let couplings = crate::constraint::coupling::links(tails.rows, heads)
        .map(|(a, b)| (a, Counterpart::Body(b)));
    let links = rows
        .iter()
        .filter_map(link)
        .chain(tails.rows.iter().filter_map(link))
        .chain(couplings);
    let summary = partition.partition(bodies, links);
    out.of_root.clear();
    out.of_root.resize(bodies, u32::MAX);
    out.of_row.clear();
    out.start.clear();
    let mut islands = 0u32;
    for row in rows {
        let g = match row.a.or(row.b) {
            Some(j) => {
                let r = partition.root(j.body);
                if out.of_root[r] == u32::MAX {
                    out.of_root[r] = islands;
                    islands += 1;
                }
                out.of_root[r]
            }
            None => {
                islands += 1;
                islands - 1
            }
        };
        out.of_row.push(g);
    }
    // Counting sort: sizes, then starts, then the rows in order.
    out.start.resize(islands as usize + 1, 0);
    for &g in &out.of_row {
        out.start[g as usize + 1] += 1;
    }
    for g in 0..islands as usize {
        out.start[g + 1] += out.start[g];
    }
    out.rows.clear();
    out.rows.resize(rows.len(), 0);
    for (k, &g) in out.of_row.iter().enumerate() {
        let slot = out.start[g as usize] as usize;
        out.rows[slot] = k as u32;
        out.start[g as usize] += 1;
    }
    // The starts moved to the ends: shift them back.
    for g in (1..=islands as usize).rev() {
        out.start[g] = out.start[g - 1];
    }
    if let Some(first) = out.start.first_mut() {
        *first = 0;
    }
    summary
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::constraint::rows::Row;
    use nalgebra::Vector3;

    #[test]
    fn rows_are_grouped_by_island_in_order() {
        let mut islands = Islands::default();
        // Rows: a joint 1-2, a contact 3-plane, a contact 2-3, a contact
        // 0-plane, a row on no body: islands {1, 2, 3} (rows 0, 1, 2),
        // {0} (row 3), the bodiless row 4; numbered by their first row.
        let on = |i: usize| Some((i, Vector3::zeros()));
        let x = Vector3::x();
        let rows = [
            Row::along(x, on(1), on(2)),
            Row::along(x, on(3), None),
            Row::along(x, on(2), on(3)),
            Row::along(x, on(0), None),
            Row::along(x, None, None),
        ];
        let mut groups = Groups::default();
        let s = group(&mut islands, 4, &rows, Tails::NONE, &mut groups);
        assert_eq!(
            s,
            Summary {
                count: 2,
                largest: 3
            }
        );
        assert_eq!(groups.len(), 3);
        assert_eq!(groups.rows_of(0), [0, 1, 2]);
        assert_eq!(groups.rows_of(1), [3]);
        assert_eq!(groups.rows_of(2), [4]);
        group(&mut islands, 4, &[], Tails::NONE, &mut groups);
        assert!(groups.is_empty());
    }
}
