//! The NNCG momentum step after each sweep (per island): the impulses per
//! coordinate, the velocities per body, the direction's `M^-1 G d` carried
//! along.

use super::Pgs;

/// NNCG restarts when a sweep changes the impulses by more than this
/// (squared) ratio to the last. Not at 1: where the sweeps walk the
/// impulses along a line (seen on the pile, a redistribution of its load
/// at a constant change per sweep) the ratio is 1 within rounding, and a
/// restart at every other sweep undoes the momentum that would cross the
/// line; `beta` is capped at 1 between 1 and this. Measured on the 100
/// pile (130 steps, 1e-6 m/s): median 57 ms per step at 1, 30 ms at 1.05,
/// with as many steps at the cap (42, 43); over 500 steps 40.0 s in all
/// and 51 steps at the cap, against 68.7 s and 76 at 1.
const RESTART_BETA: f64 = 1.05;

impl Pgs {
    /// The NNCG step after a sweep of island `g` (see [`Pgs::solve`]):
    /// moves its impulses (and `nu` with them) along the momentum direction. Takes and returns
    /// `|g|^2` of the last sweep.
    pub(super) fn momentum(&mut self, g: usize, last_g2: f64, nu: &mut [f64]) -> f64 {
        let (lo, hi) = (
            self.coord_start[g] as usize,
            self.coord_start[g + 1] as usize,
        );
        let span = self.span(g);
        let coords = std::mem::take(&mut self.coords);
        let (g2, beta) = match span {
            Some(r) => self.momentum_over(r, last_g2),
            None => self.momentum_over(coords[lo..hi].iter().map(|&c| c as usize), last_g2),
        };
        self.coords = coords;
        // The velocities follow the impulses: the sweep changed them by
        // `M^-1 G g` (`nu - nu_before`), the step moves them by `beta`
        // times the direction's `M^-1 G d` (linear in `d`, so carried
        // along as `d` is).
        let (lo, hi) = (self.body_start[g] as usize, self.body_start[g + 1] as usize);
        for &b in &self.bodies[lo..hi] {
            let v = 6 * b as usize..6 * b as usize + 6;
            let before = &self.nu_before[v.clone()];
            let dir = &mut self.nu_direction[v.clone()];
            for ((n, d), b) in nu[v].iter_mut().zip(dir).zip(before) {
                let step = beta * *d;
                *d = step + (*n - b);
                *n += step;
            }
        }
        g2
    }

    /// [`Pgs::momentum`]'s step of the impulses over the coordinates
    /// `coords` (ascending): `|g|^2` and the step's `beta` (0 at a
    /// restart).
    fn momentum_over(
        &mut self,
        coords: impl Iterator<Item = usize> + Clone,
        last_g2: f64,
    ) -> (f64, f64) {
        let g2: f64 = coords
            .clone()
            .map(|c| {
                let d = self.x[c] - self.before[c];
                d * d
            })
            .sum();
        let beta = if last_g2 > 0.0 { g2 / last_g2 } else { 0.0 };
        if beta > RESTART_BETA || beta == 0.0 {
            // Restart: the direction is the sweep's change alone.
            for c in coords {
                self.direction[c] = self.x[c] - self.before[c];
            }
            return (g2, 0.0);
        }
        let beta = beta.min(1.0);
        for c in coords {
            let step = beta * self.direction[c];
            self.direction[c] = step + (self.x[c] - self.before[c]);
            self.x[c] += step;
        }
        (g2, beta)
    }

    /// Island `g`'s coordinates as a range where they are one (a scene of
    /// one island: all of `x`), so that the loops over them run on slices.
    pub(super) fn span(&self, g: usize) -> Option<std::ops::Range<usize>> {
        let c = &self.coords[self.coord_start[g] as usize..self.coord_start[g + 1] as usize];
        let (&first, &last) = (c.first()?, c.last()?);
        (last - first + 1 == c.len() as u32).then_some(first as usize..last as usize + 1)
    }
}
