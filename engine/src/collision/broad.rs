//! Broad phase (issue 14): the sphere pairs that can touch within a step,
//! in O(N log N) instead of every pair.
//!
//! A pair can close within the step only if its gap is at most
//! `reach_a + reach_b + margin`, where `reach_i` bounds the distance body i
//! travels in the step. For spheres that bound is exact in what it keeps:
//! the normal velocity at a sphere contact is `(v_a - v_b) . n` (the lever
//! arm is along the normal, so spin adds nothing), hence `|v_n| <= |v_a| +
//! |v_b|` and a pair with `gap > h (|v_a| + |v_b|) + margin` is one that
//! `prune::select` and `prune::check_left_out` would leave out anyway.
//!
//! The grid: cubic cells of side `2 max_i (r_i + reach_i) + margin`, so
//! that any two bodies whose grown spheres overlap sit in the same or
//! neighbouring cells. Bodies are sorted by cell key; each body looks up its
//! 27 neighbour cells by binary search and keeps the partners after it.
//! The pairs come out sorted by `(a, b)`: the canonical order, so that a
//! contact's index stays its identity and the LCP's row order is the one of
//! the full enumeration (the pruned and full runs give the same bits).
//!
//! Only pairs with an active body are wanted (a pair of two sleeping
//! bodies is not listed, `sleep.rs`): every body is in the grid, but only
//! the active ones look up their neighbours; with no active body there is
//! no grid, and with at most `FEW_ACTIVE` each is tested against every
//! body instead.
//!
//! Cost: sorting N keys and 9 lookups per active body; no allocation once
//! the buffers have seen the largest scene. A scene of very unequal spheres (one of
//! 10 m among 1 mm ones) makes the cells coarse and the grid a sweep over
//! many bodies per cell: correct, not fast.

use nalgebra::Vector3;

/// Scratch space of the broad phase, kept from step to step.
#[derive(Debug, Default, Clone)]
pub struct Broad {
    /// `(cell key, body)`, sorted.
    cells: Vec<(u64, u32)>,
}

/// Packs cell coordinates into a key. Coordinates are wrapped to 21 bits;
/// two far cells may then share a key, which only adds candidates (the
/// exact test below drops them), never loses one.
fn key(c: [i64; 3]) -> u64 {
    let w = |x: i64| (x as u64) & 0x1f_ffff;
    (w(c[0]) << 42) | (w(c[1]) << 21) | w(c[2])
}

fn cell_of(x: &Vector3<f64>, size: f64) -> [i64; 3] {
    // `as` saturates: a non-finite or huge coordinate lands in an extreme
    // cell, which is still a cell (the step fails elsewhere on such a state).
    [
        (x.x / size).floor() as i64,
        (x.y / size).floor() as i64,
        (x.z / size).floor() as i64,
    ]
}

/// Up to this many active bodies, each is tested against every body
/// instead of making the grid: `A n` distance tests against the grid's
/// key per body and sort, for the same pairs (the same test decides). A
/// world asleep but for a few bodies (a falling one, a robot's links)
/// then pays no sort.
const FEW_ACTIVE: usize = 8;

impl Broad {
    /// Fills `out` with every pair `(a, b)`, `a < b`, of the `n` spheres
    /// (centres `x`, radii `r`) with at least one `active` body whose gap
    /// is at most `reach(a) + reach(b) + margin`, sorted.
    #[allow(clippy::too_many_arguments)]
    pub fn pairs(
        &mut self,
        n: usize,
        x: impl Fn(usize) -> Vector3<f64>,
        r: impl Fn(usize) -> f64,
        reach: impl Fn(usize) -> f64,
        margin: f64,
        active: impl Fn(usize) -> bool,
        out: &mut Vec<(usize, usize)>,
    ) {
        out.clear();
        // How many look for partners, counted up to one past `FEW_ACTIVE`.
        let looking = (0..n).filter(|&i| active(i)).take(FEW_ACTIVE + 1).count();
        // Nothing to look for: no grid (a sleeping pile's step spent a
        // third of its time making it).
        if n < 2 || looking == 0 {
            return;
        }
        // Lists `(a, b)` for active `a` at `xa` when `b` is within reach:
        // the one test of both ways to find candidates.
        let test = |a: usize, xa: &Vector3<f64>, b: usize, out: &mut Vec<(usize, usize)>| {
            // An active partner before `a` listed the pair.
            if b == a || (b < a && active(b)) {
                return;
            }
            let gap = (x(b) - xa).norm() - r(a) - r(b);
            if gap <= reach(a) + reach(b) + margin {
                out.push((a.min(b), a.max(b)));
            }
        };
        if looking <= FEW_ACTIVE {
            for a in (0..n).filter(|&a| active(a)) {
                let xa = x(a);
                for b in 0..n {
                    test(a, &xa, b, out);
                }
            }
            out.sort_unstable();
            return;
        }
        let grown = (0..n).fold(0.0f64, |m, i| m.max(r(i) + reach(i)));
        let size = (2.0 * grown + margin).max(f64::MIN_POSITIVE);
        self.cells.clear();
        self.cells
            .extend((0..n).map(|i| (key(cell_of(&x(i), size)), i as u32)));
        self.cells.sort_unstable();
        for a in (0..n).filter(|&a| active(a)) {
            let xa = x(a);
            let c = cell_of(&xa, size);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    // The three cells along z are one run of keys (z is the
                    // key's low field) unless the field wraps there: one
                    // search for the three, not three.
                    let (lo, hi) = (
                        key([c[0] + dx, c[1] + dy, c[2] - 1]),
                        key([c[0] + dx, c[1] + dy, c[2] + 1]),
                    );
                    let mid = key([c[0] + dx, c[1] + dy, c[2]]);
                    let split = [(lo, lo), (mid, mid), (hi, hi)];
                    let runs = if hi.wrapping_sub(lo) == 2 {
                        &[(lo, hi)][..]
                    } else {
                        &split[..]
                    };
                    for &(from, to) in runs {
                        let start = self.cells.partition_point(|&(ck, _)| ck < from);
                        for &(ck, b) in &self.cells[start..] {
                            if ck > to {
                                break;
                            }
                            test(a, &xa, b as usize, out);
                        }
                    }
                }
            }
        }
        // Wrapped keys can list one cell twice among the 27: drop repeats.
        out.sort_unstable();
        out.dedup();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator for the test's points.
    fn points(n: usize, seed: u64) -> Vec<Vector3<f64>> {
        let mut s = seed | 1;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 2.0)
            .collect()
    }

    #[test]
    fn the_grid_finds_exactly_the_pairs_of_the_brute_force() {
        let mut broad = Broad::default();
        let mut got = Vec::new();
        for seed in 1..20u64 {
            let x = points(300, seed);
            let r: Vec<f64> = (0..300)
                .map(|i| 0.02 + 0.03 * ((i * 7) % 5) as f64 / 5.0)
                .collect();
            let reach: Vec<f64> = (0..300)
                .map(|i| if i % 11 == 0 { 0.2 } else { 0.001 })
                .collect();
            let margin = 1e-3;
            // Every body active, then about a third of them (pairs of two
            // inactive bodies are not wanted), then six: fewer than
            // `FEW_ACTIVE`, each tested against every body.
            for active in [
                |_: usize| true,
                |i: usize| i % 3 == 1,
                |i: usize| i.is_multiple_of(50),
            ] {
                broad.pairs(
                    300,
                    |i| x[i],
                    |i| r[i],
                    |i| reach[i],
                    margin,
                    active,
                    &mut got,
                );
                let mut want = Vec::new();
                for a in 0..300 {
                    for b in a + 1..300 {
                        let near =
                            (x[b] - x[a]).norm() - r[a] - r[b] <= reach[a] + reach[b] + margin;
                        if near && (active(a) || active(b)) {
                            want.push((a, b));
                        }
                    }
                }
                assert_eq!(got, want, "seed {seed}");
                assert!(!want.is_empty());
            }
        }
    }
}
