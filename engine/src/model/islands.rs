//! Islands: the bodies that links tie together, directly or through
//! others (a plane or the world ties nothing). Union-find with path halving
//! and union by size: O(N + C) per partition, no allocation once the
//! buffers have seen the largest scene. The model's weld groups, the
//! solve's islands (`solver/island.rs`) and sleeping use it.

use super::Counterpart;

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

    pub(crate) fn root(&mut self, mut i: usize) -> usize {
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
