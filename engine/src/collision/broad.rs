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
//! neighbouring cells. Where the bodies' bounding box holds at most a few
//! cells per body (a pile, a robot), the grid is dense: one array over the
//! box, filled by a counting sort, and a body's 27 neighbour cells are
//! nine runs of it found by index (measured on the 1,000 pile: the broad
//! phase went from a fifth of the step to a tenth, the step's pairs the
//! same bits). Else (a body thrown far away) it is sparse: bodies sorted by
//! cell key, each looking its neighbour cells up by binary search. Either
//! way the pairs come out sorted by `(a, b)`: the canonical order, so that
//! a contact's index stays its identity and the LCP's row order is the one
//! of the full enumeration (the pruned and full runs give the same bits).
//!
//! Only pairs with an active body are wanted (a pair of two sleeping
//! bodies is not listed, `sleep.rs`): every body is in the grid, but only
//! the active ones look up their neighbours; with no active body there is
//! no grid, and with at most `FEW_ACTIVE` each is tested against every
//! body instead.
//!
//! Cost: O(N) for the dense grid (N log N for the sparse one's sort and
//! lookups), plus the sort of the pairs; no allocation once the buffers
//! have seen the largest scene. A scene of very unequal spheres (one of
//! 10 m among 1 mm ones) makes the cells coarse and the grid a sweep over
//! many bodies per cell: correct, not fast.

use nalgebra::Vector3;

/// Scratch space of the broad phase, kept from step to step.
#[derive(Debug, Default, Clone)]
pub struct Broad {
    /// Sparse grid: `(cell key, body)`, sorted.
    cells: Vec<(u64, u32)>,
    /// Dense grid: where each cell's bodies start in `order` (one more
    /// entry than cells, the last the end), in cell order.
    starts: Vec<u32>,
    /// Dense grid: the bodies by cell, each cell's in body order, with
    /// what the pair test reads gathered beside them (`Near`).
    order: Vec<Near>,
    /// Both grids: the bodies' `Near`s in body order.
    gathered: Vec<Near>,
    /// The inactive bodies by cell key (cells of `still_size`), kept from
    /// call to call while the caller vouches that they are the same
    /// ([`Still`]: `still_key`), and their largest radius plus reach.
    still: Vec<(u64, Near)>,
    still_key: Option<u64>,
    still_size: f64,
    still_grown: f64,
}

/// The caller's word that the inactive bodies (their centres, radii and
/// reaches) are those of the last call that gave the same `key`, with the
/// active bodies listed (ascending): the pairs are then found from a grid
/// of the inactive bodies kept between calls, at a cost of the active
/// bodies alone (a robot's links beside a sleeping heap: a grid of every
/// body, or a test of each active body against every body, cost O(N) a
/// step).
#[derive(Debug, Clone, Copy)]
pub struct Still<'a> {
    pub key: u64,
    pub active: &'a [u32],
}

/// The kept grid serves while the active bodies are at most this fraction
/// of all (one in `STILL_FRACTION`); with more, a grid of every body is as
/// cheap as their look-ups.
const STILL_FRACTION: usize = 8;

/// An active body whose reach spans more than this many cells of the kept
/// grid is tested against every inactive body instead.
const STILL_CELLS: i64 = 64;

/// What the pair test reads of a body, gathered into cell order so that
/// a body's neighbours are read from consecutive memory.
#[derive(Debug, Clone, Copy, Default)]
struct Near {
    x: Vector3<f64>,
    r: f64,
    reach: f64,
    body: u32,
    /// The dense grid's cell index.
    cell: u32,
    active: bool,
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

/// The dense grid is used while the bodies' bounding box holds at most
/// this many cells per body (and `DENSE_EXTRA` more): a pile's box holds
/// about one sphere per cell; a body thrown far away makes the box
/// mostly empty, and the sparse grid takes over.
const DENSE_PER_BODY: usize = 8;
const DENSE_EXTRA: usize = 64;

/// The pair test, the one both grids and the brute force apply: `(a, b)`
/// with `a` active is listed when `b` is within reach (an active partner
/// before `a` listed the pair already).
#[inline]
fn test(na: &Near, nb: &Near, margin: f64, out: &mut Vec<(usize, usize)>) {
    let (a, b) = (na.body as usize, nb.body as usize);
    if b == a || (b < a && nb.active) {
        return;
    }
    let (xa, ra, reach_a) = (na.x, na.r, na.reach);
    // Most candidates are a cell away: dropped on the squared distance,
    // without the root, where it clears the reach by far more than the
    // test's roundings (a few 1e-16 of the sum), so that the test below
    // would drop them too: the same pairs, bit for bit.
    let d = nb.x - xa;
    let within = ra + nb.r + reach_a + nb.reach + margin;
    if d.norm_squared() > (within * (1.0 + 1e-9)).powi(2) {
        return;
    }
    let gap = d.norm() - ra - nb.r;
    if gap <= reach_a + nb.reach + margin {
        out.push((a.min(b), a.max(b)));
    }
}

impl Broad {
    /// Fills `out` with every pair `(a, b)`, `a < b`, of the `n` spheres
    /// (centres `x`, radii `r`) with at least one `active` body whose gap
    /// is at most `reach(a) + reach(b) + margin`, sorted.
    /// With `still` (see [`Still`]), the same pairs from the kept grid.
    #[allow(clippy::too_many_arguments)]
    pub fn pairs(
        &mut self,
        n: usize,
        x: impl Fn(usize) -> Vector3<f64>,
        r: impl Fn(usize) -> f64,
        reach: impl Fn(usize) -> f64,
        margin: f64,
        active: impl Fn(usize) -> bool,
        still: Option<Still>,
        out: &mut Vec<(usize, usize)>,
    ) {
        out.clear();
        let near = |i: usize| Near {
            x: x(i),
            r: r(i),
            reach: reach(i),
            body: i as u32,
            cell: 0,
            active: active(i),
        };
        if let Some(still) = still.filter(|s| STILL_FRACTION * s.active.len() <= n) {
            debug_assert!(still.active.iter().all(|&a| active(a as usize)));
            if self.still_key != Some(still.key) {
                self.keep_still(n, near, margin);
                self.still_key = Some(still.key);
            }
            self.beside_still(still.active, near, margin, out);
            out.sort_unstable();
            out.dedup();
            return;
        }
        // How many look for partners, counted up to one past `FEW_ACTIVE`.
        let looking = (0..n).filter(|&i| active(i)).take(FEW_ACTIVE + 1).count();
        // Nothing to look for: no grid (a sleeping pile's step spent a
        // third of its time making it).
        if n < 2 || looking == 0 {
            return;
        }
        if looking <= FEW_ACTIVE {
            for a in (0..n).filter(|&a| active(a)) {
                let na = near(a);
                for b in 0..n {
                    test(&na, &near(b), margin, out);
                }
            }
            out.sort_unstable();
            return;
        }
        self.gathered.clear();
        self.gathered.extend((0..n).map(near));
        let grown = (self.gathered.iter()).fold(0.0f64, |m, g| m.max(g.r + g.reach));
        let size = (2.0 * grown + margin).max(f64::MIN_POSITIVE);
        if !self.dense(size, margin, out) {
            self.sparse(size, margin, out);
        }
        out.sort_unstable();
        out.dedup();
    }

    /// Makes the kept grid of the inactive bodies among the `n`.
    fn keep_still(&mut self, n: usize, near: impl Fn(usize) -> Near, margin: f64) {
        self.still.clear();
        // Room for every body at once: a later listing with more of them
        // asleep allocates nothing.
        self.still.reserve(n);
        self.still
            .extend((0..n).map(&near).filter(|g| !g.active).map(|g| (0, g)));
        self.still_grown = (self.still.iter()).fold(0.0f64, |m, (_, g)| m.max(g.r + g.reach));
        self.still_size = (2.0 * self.still_grown + margin).max(f64::MIN_POSITIVE);
        let size = self.still_size;
        for (k, g) in &mut self.still {
            *k = key(cell_of(&g.x, size));
        }
        self.still.sort_unstable_by_key(|&(k, g)| (k, g.body));
    }

    /// The pairs of each of the `active` bodies with the kept inactive
    /// ones within its reach, and with each other (unsorted).
    fn beside_still(
        &mut self,
        active: &[u32],
        near: impl Fn(usize) -> Near,
        margin: f64,
        out: &mut Vec<(usize, usize)>,
    ) {
        for (k, &a) in active.iter().enumerate() {
            let na = near(a as usize);
            for &b in &active[k + 1..] {
                test(&na, &near(b as usize), margin, out);
            }
            // Every inactive body whose pair `test` can list has its
            // centre within `r_a + reach_a + margin` plus its own radius
            // and reach of A's on each axis (a little more, for the
            // test's roundings).
            let range = (na.r + na.reach + margin + self.still_grown) * (1.0 + 1e-9) + 1e-12;
            let size = self.still_size;
            let lo = cell_of(&na.x.add_scalar(-range), size);
            let hi = cell_of(&na.x.add_scalar(range), size);
            let span = |k: usize| hi[k].saturating_sub(lo[k]).saturating_add(1);
            let cells = span(0).saturating_mul(span(1)).saturating_mul(span(2));
            if !(1..=STILL_CELLS).contains(&cells) {
                for (_, nb) in &self.still {
                    test(&na, nb, margin, out);
                }
                continue;
            }
            for cx in lo[0]..=hi[0] {
                for cy in lo[1]..=hi[1] {
                    for cz in lo[2]..=hi[2] {
                        let k = key([cx, cy, cz]);
                        let start = self.still.partition_point(|&(ck, _)| ck < k);
                        for (_, nb) in self.still[start..].iter().take_while(|(ck, _)| *ck == k) {
                            test(&na, nb, margin, out);
                        }
                    }
                }
            }
        }
    }

    /// The dense grid: the bounding box of the bodies' cells as one array
    /// of cells, filled by a counting sort (O(N), no comparisons); each
    /// active body reads the runs of its 3 x 3 columns' three cells. False
    /// (nothing listed) when the box has too many cells for the bodies.
    fn dense(&mut self, size: f64, margin: f64, out: &mut Vec<(usize, usize)>) -> bool {
        let n = self.gathered.len();
        let (mut lo, mut hi) = ([i64::MAX; 3], [i64::MIN; 3]);
        for g in &self.gathered {
            let c = cell_of(&g.x, size);
            for k in 0..3 {
                lo[k] = lo[k].min(c[k]);
                hi[k] = hi[k].max(c[k]);
            }
        }
        // Cells per axis, with one empty layer either side so that a
        // neighbour's index is never out of the box.
        let cap = DENSE_PER_BODY * n + DENSE_EXTRA;
        let mut dims = [0usize; 3];
        for k in 0..3 {
            let span = (hi[k] as i128) - (lo[k] as i128) + 3;
            if span > cap as i128 {
                return false;
            }
            dims[k] = span as usize;
        }
        let Some(cells) = dims[0]
            .checked_mul(dims[1])
            .and_then(|c| c.checked_mul(dims[2]))
            .filter(|&c| c <= cap)
        else {
            return false;
        };
        let index = |c: [i64; 3]| {
            let at = |k: usize| (c[k] - lo[k] + 1) as usize;
            ((at(0) * dims[1] + at(1)) * dims[2] + at(2)) as u32
        };
        // Counting sort by cell, stable: each cell's bodies in body order.
        self.starts.clear();
        self.starts.resize(cells + 1, 0);
        for g in &mut self.gathered {
            g.cell = index(cell_of(&g.x, size));
            self.starts[g.cell as usize + 1] += 1;
        }
        for k in 0..cells {
            self.starts[k + 1] += self.starts[k];
        }
        // `starts[c]` runs through cell c's slots as they fill, ending at
        // the next cell's start; shifted back after.
        self.order.clear();
        self.order.resize(n, Near::default());
        for g in &self.gathered {
            let c = g.cell as usize;
            self.order[self.starts[c] as usize] = *g;
            self.starts[c] += 1;
        }
        for k in (1..=cells).rev() {
            self.starts[k] = self.starts[k - 1];
        }
        self.starts[0] = 0;
        // Each active body in cell order: its neighbours' runs are near
        // its own in `order`.
        let (rows, column) = (dims[1] * dims[2], dims[2]);
        for na in self.order.iter().filter(|g| g.active) {
            let c = na.cell as usize;
            for dx in [c - rows, c, c + rows] {
                for dxy in [dx - column, dx, dx + column] {
                    // The three cells along z are consecutive.
                    let from = self.starts[dxy - 1] as usize;
                    let to = self.starts[dxy + 2] as usize;
                    for nb in &self.order[from..to] {
                        test(na, nb, margin, out);
                    }
                }
            }
        }
        true
    }

    /// The sparse grid: bodies sorted by cell key; each active body looks
    /// up its neighbour cells by binary search.
    fn sparse(&mut self, size: f64, margin: f64, out: &mut Vec<(usize, usize)>) {
        self.cells.clear();
        (self.cells).extend((self.gathered.iter()).map(|g| (key(cell_of(&g.x, size)), g.body)));
        self.cells.sort_unstable();
        for na in self.gathered.iter().filter(|g| g.active) {
            let c = cell_of(&na.x, size);
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
                            test(na, &self.gathered[b as usize], margin, out);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator for the test's points.
    fn points(n: usize, seed: u64) -> Vec<Vector3<f64>> {
        let mut rng = crate::testing::Xorshift::new(seed);
        let mut next = || rng.next_f64();
        (0..n)
            .map(|_| Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 2.0)
            .collect()
    }

    #[test]
    fn the_grid_finds_exactly_the_pairs_of_the_brute_force() {
        let mut got = Vec::new();
        // The points in a cube (the dense grid), then one of them thrown
        // far away (the sparse grid: the box would hold too many cells).
        for (seed, far) in (1..20u64).flat_map(|s| [(s, false), (s, true)]) {
            let mut x = points(300, seed);
            if far {
                x[7] = Vector3::new(1e5, -3.0, 0.5);
            }
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
                let mut broad = Broad::default();
                broad.pairs(
                    300,
                    |i| x[i],
                    |i| r[i],
                    |i| reach[i],
                    margin,
                    active,
                    None,
                    &mut got,
                );
                let want = brute(&x, &r, &reach, margin, active);
                assert_eq!(got, want, "seed {seed}, far {far}");
                assert!(!want.is_empty());
                // Which grid listed them (none for `FEW_ACTIVE`).
                let few = (0..300).filter(|&i| active(i)).count() <= FEW_ACTIVE;
                assert_eq!(broad.cells.is_empty(), !far || few, "seed {seed}");
                assert_eq!(broad.order.is_empty(), far || few, "seed {seed}");
            }
        }
    }

    /// The brute force's pairs of `x` with at least one `active` body.
    fn brute(
        x: &[Vector3<f64>],
        r: &[f64],
        reach: &[f64],
        margin: f64,
        active: impl Fn(usize) -> bool,
    ) -> Vec<(usize, usize)> {
        let mut want = Vec::new();
        for a in 0..x.len() {
            for b in a + 1..x.len() {
                let near = (x[b] - x[a]).norm() - r[a] - r[b] <= reach[a] + reach[b] + margin;
                if near && (active(a) || active(b)) {
                    want.push((a, b));
                }
            }
        }
        want
    }

    /// The grid of the inactive bodies kept from call to call (`Still`)
    /// gives the brute force's pairs, also after the active bodies moved
    /// and while the same key vouches for the others; a new key makes it
    /// again (the inactive bodies moved too). Some active bodies reach
    /// far (more cells than `STILL_CELLS`: tested against every one).
    #[test]
    fn the_kept_grid_of_still_bodies_finds_exactly_the_pairs_of_the_brute_force() {
        let mut got = Vec::new();
        let margin = 1e-3;
        let mut tested = 0;
        for seed in 1..20u64 {
            let mut x = points(400, seed);
            let r: Vec<f64> = (0..400)
                .map(|i| 0.02 + 0.03 * ((i * 7) % 5) as f64 / 5.0)
                .collect();
            let mut reach: Vec<f64> = (0..400)
                .map(|i| if i % 11 == 0 { 0.1 } else { 0.001 })
                .collect();
            // 20 active bodies, one of them fast.
            let active: Vec<u32> = (0..400).filter(|i| i % 20 == (seed % 20) as u32).collect();
            reach[active[3] as usize] = 5.0;
            let is = |i: usize| active.contains(&(i as u32));
            let mut broad = Broad::default();
            for (call, key) in [(0, 7), (1, 7), (2, 8)] {
                if call > 0 {
                    // The active bodies move (and, for the new key, the
                    // others too).
                    let shift = points(400, seed + 100 * call);
                    for i in 0..400 {
                        if is(i) || key == 8 {
                            x[i] += 0.1 * shift[i];
                        }
                    }
                }
                let still = Some(Still {
                    key,
                    active: &active,
                });
                broad.pairs(
                    400,
                    |i| x[i],
                    |i| r[i],
                    |i| reach[i],
                    margin,
                    is,
                    still,
                    &mut got,
                );
                let want = brute(&x, &r, &reach, margin, is);
                assert_eq!(got, want, "seed {seed}, call {call}");
                assert!(!want.is_empty());
                tested += 1;
            }
            assert_eq!(broad.still.len(), 380);
        }
        assert_eq!(tested, 57);
    }
}
