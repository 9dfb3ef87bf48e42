//! Islands (issue 14, point 2): the bodies that the step's constraints tie
//! together. Two bodies are in one island when a joint or a contact in the
//! LCP links them, directly or through others; a plane is static and links
//! nothing, so a pile on a floor splits where no sphere touches another.
//!
//! The step reports how many islands it had and the bodies of the largest
//! (`StepReport::islands`, `largest_island`); a body that no constraint
//! touches (in flight) is in none. [`Islands::group`] sorts the step's
//! rows by island ([`Groups`]), and the solve stage solves each island on
//! its own (`split.rs`): their problems share no body, so the step's LCP
//! is block-diagonal by island and the islands' answers together are the
//! whole problem's.
//!
//! Union-find with path halving and union by size: O(N + C) per step, no
//! allocation once the buffers have seen the largest scene.

use crate::collision::Counterpart;
use crate::rows::Row;

/// The step's joint and normal rows sorted by island (compressed rows):
/// island `g`'s rows are [`Groups::rows_of`]`(g)`, ascending, so that a
/// solver visits them in the whole problem's order. Islands are numbered
/// by their first row.
#[derive(Debug, Default, Clone)]
pub struct Groups {
    start: Vec<u32>,
    rows: Vec<u32>,
    /// Per row, its island (scratch of [`Islands::group`]).
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

    /// The island of row `k` of the last [`Islands::group`].
    pub fn island_of_row(&self, k: usize) -> usize {
        self.of_row[k] as usize
    }

    /// The rows of island `g` (indices into the problem's rows).
    pub fn rows_of(&self, g: usize) -> &[u32] {
        &self.rows[self.start[g] as usize..self.start[g + 1] as usize]
    }
}

/// The partition's scratch space and its last result.
#[derive(Debug, Default, Clone)]
pub struct Islands {
    parent: Vec<u32>,
    size: Vec<u32>,
    /// Whether a constraint touches the body (it is in an island).
    tied: Vec<bool>,
    /// Per root: the least of a per-body count over its island (sleeping).
    least: Vec<u32>,
}

/// How many islands, and the bodies of the largest.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Summary {
    pub count: usize,
    pub largest: usize,
}

impl Islands {
    /// Every body its own root, untied.
    fn reset(&mut self, bodies: usize) {
        self.parent.clear();
        self.parent.extend(0..bodies as u32);
        self.size.clear();
        self.size.resize(bodies, 1);
        self.tied.clear();
        self.tied.resize(bodies, false);
    }

    /// The root of body `i`'s island in the last partition (a body in
    /// none is its own root).
    pub fn root_of(&mut self, i: usize) -> usize {
        self.root(i)
    }

    fn root(&mut self, mut i: usize) -> usize {
        while self.parent[i] as usize != i {
            let up = self.parent[self.parent[i] as usize];
            self.parent[i] = up;
            i = up as usize;
        }
        i
    }

    fn union(&mut self, a: usize, b: usize) {
        let (mut ra, mut rb) = (self.root(a), self.root(b));
        if ra == rb {
            return;
        }
        if self.size[ra] < self.size[rb] {
            std::mem::swap(&mut ra, &mut rb);
        }
        self.parent[rb] = ra as u32;
        self.size[ra] += self.size[rb];
    }

    /// The islands of `bodies` bodies under the links `links`: `(a, b)` for
    /// a constraint between body `a` and `b` (a plane, or the world, links
    /// `a` to nothing but puts it in an island).
    pub fn partition(
        &mut self,
        bodies: usize,
        links: impl Iterator<Item = (usize, Counterpart)>,
    ) -> Summary {
        self.reset(bodies);
        for (a, b) in links {
            self.tied[a] = true;
            if let Counterpart::Body(j) = b {
                self.tied[j] = true;
                self.union(a, j);
            }
        }
        let mut out = Summary::default();
        for i in 0..bodies {
            if self.tied[i] && self.root(i) == i {
                out.count += 1;
                out.largest = out.largest.max(self.size[i] as usize);
            }
        }
        out
    }

    /// Sorts `rows` (the joint and normal rows of the step's problem) by
    /// island into `out`: two rows are in one island when a chain of rows
    /// links their bodies. A row on no body (a joint of the world to
    /// itself) is an island of its own. Returns the partition's summary
    /// (bodies tied by the rows; [`Islands::partition`] of their links).
    pub fn group(&mut self, bodies: usize, rows: &[Row], out: &mut Groups) -> Summary {
        // A row on one body ties it to something static, as a plane does.
        let links = rows.iter().filter_map(|row| match (row.a, row.b) {
            (Some(a), Some(b)) => Some((a.body, Counterpart::Body(b.body))),
            (Some(j), None) | (None, Some(j)) => Some((j.body, Counterpart::World)),
            (None, None) => None,
        });
        let summary = self.partition(bodies, links);
        out.of_root.clear();
        out.of_root.resize(bodies, u32::MAX);
        out.of_row.clear();
        out.start.clear();
        let mut islands = 0u32;
        for row in rows {
            let g = match row.a.or(row.b) {
                Some(j) => {
                    let r = self.root(j.body);
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

    /// Keeps, for each island of the last partition (a body in none is an
    /// island of its own), the least `count` of its bodies whose `tag` is
    /// `only` (`sleep.rs`: the steps at rest of the awake bodies).
    pub fn least_rest(&mut self, count: &[u32], tag: &[u32], only: u32) {
        let n = self.parent.len();
        self.least.clear();
        self.least.resize(n, u32::MAX);
        for i in 0..n {
            if tag[i] == only {
                let r = self.root(i);
                self.least[r] = self.least[r].min(count[i]);
            }
        }
    }

    /// The root of body `i`'s island and the least count kept for it.
    pub fn least_of(&mut self, i: usize) -> (usize, u32) {
        let r = self.root(i);
        (r, self.least[r])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Counterpart::{Body, Plane};

    #[test]
    fn links_make_islands_and_planes_link_nothing() {
        let mut islands = Islands::default();
        // 0 on the floor alone; 1-2-3 a chain; 4 in flight; 5-6 and 6-5.
        let links = [
            (0, Plane(0)),
            (1, Body(2)),
            (3, Body(2)),
            (3, Plane(1)),
            (5, Body(6)),
            (6, Body(5)),
        ];
        let s = islands.partition(7, links.into_iter());
        assert_eq!(
            s,
            Summary {
                count: 3,
                largest: 3
            }
        );
        assert_eq!(islands.partition(7, std::iter::empty()), Summary::default());
        // Rows: a joint 1-2, a contact 3-plane, a contact 2-3, a contact
        // 0-plane, a row on no body: islands {1, 2, 3} (rows 0, 1, 2),
        // {0} (row 3), the bodiless row 4; numbered by their first row.
        use crate::rows::Row;
        use nalgebra::Vector3;
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
        let s = islands.group(4, &rows, &mut groups);
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
        islands.group(4, &[], &mut groups);
        assert!(groups.is_empty());
        // Everything on one floor: still one island each.
        let s = islands.partition(3, (0..3).map(|i| (i, Plane(0))));
        assert_eq!(
            s,
            Summary {
                count: 3,
                largest: 1
            }
        );
    }
}
