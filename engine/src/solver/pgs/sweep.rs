//! One sweep: each contact's normal row then its friction block, each
//! motor after its island's rows, projected on their cones and boxes; and
//! the focused sweeps of the few contacts left above the tolerance.

use super::{Pgs, PgsParams, PgsProblem, FOCUS_MAX, FOCUS_SWEEPS};
use crate::constraint::rows::Row;
use crate::solver::cone::project_disc;

/// Where a sweep's updates read and write the bodies' velocities: all of
/// `nu`, or a contact's two bodies held apart ([`Held`]).
trait Velocities {
    /// `G_k^T nu` for row `k`.
    fn velocity(&self, row: &Row) -> f64;
    /// `nu += impulse * weighted`, for a [`Row::weighted`] row.
    fn add(&mut self, weighted: &Row, impulse: f64);
}

impl Velocities for [f64] {
    #[inline]
    fn velocity(&self, row: &Row) -> f64 {
        row.velocity(self)
    }
    #[inline]
    fn add(&mut self, weighted: &Row, impulse: f64) {
        weighted.add_to(impulse, self);
    }
}

/// One contact's two bodies' velocities, held while its normal row and its
/// friction block update: each body is loaded once and stored once per
/// contact, instead of read by each of its three rows and written by each
/// of its three updates, and the updates chain through registers instead
/// of through stores and the loads that wait on them. The same products
/// and sums in the same order as [`Row::velocity`] and [`Row::add_to`]:
/// the same bits. Every row it is given acts on its bodies (A, and B or
/// none: `Pgs::contacts_on_two_bodies`).
struct Held {
    a: usize,
    b: Option<usize>,
    va: [f64; 6],
    vb: [f64; 6],
}

impl Held {
    #[inline]
    fn load(row: &Row, nu: &[f64]) -> Held {
        let a = row.a.map_or(0, |j| j.body);
        let b = row.b.map(|j| j.body);
        let mut held = Held {
            a,
            b,
            va: [0.0; 6],
            vb: [0.0; 6],
        };
        held.va.copy_from_slice(&nu[6 * a..6 * a + 6]);
        if let Some(b) = b {
            held.vb.copy_from_slice(&nu[6 * b..6 * b + 6]);
        }
        held
    }

    #[inline]
    fn store(&self, nu: &mut [f64]) {
        nu[6 * self.a..6 * self.a + 6].copy_from_slice(&self.va);
        if let Some(b) = self.b {
            nu[6 * b..6 * b + 6].copy_from_slice(&self.vb);
        }
    }
}

impl Velocities for Held {
    #[inline]
    fn velocity(&self, row: &Row) -> f64 {
        row.a.map_or(0.0, |j| j.velocity_of(&self.va))
            + row.b.map_or(0.0, |j| j.velocity_of(&self.vb))
    }
    #[inline]
    fn add(&mut self, weighted: &Row, impulse: f64) {
        if let Some(j) = &weighted.a {
            j.add_impulse(impulse, &mut self.va);
        }
        if let Some(j) = &weighted.b {
            j.add_impulse(impulse, &mut self.vb);
        }
    }
}

/// All of `nu`, for a coupling's row (`constraint::coupling`): its tail
/// read and written beside the row it is given.
struct WithTail<'a> {
    nu: &'a mut [f64],
    tail: &'a Row,
    weighted: &'a Row,
}

impl Velocities for WithTail<'_> {
    #[inline]
    fn velocity(&self, row: &Row) -> f64 {
        row.velocity(self.nu) + self.tail.velocity(self.nu)
    }
    #[inline]
    fn add(&mut self, weighted: &Row, impulse: f64) {
        weighted.add_to(impulse, self.nu);
        self.weighted.add_to(impulse, self.nu);
    }
}

impl Pgs {
    /// One Gauss-Seidel sweep of island `g`: its joint rows, then each
    /// contact's normal row followed at once by its friction block, so that the block's cone
    /// is the one its normal impulse just set. Returns the largest velocity
    /// change an update made (m/s); lists in `focus` the contacts whose
    /// update changed one by more than `focus_above`. Measured on the 100-sphere pile (300
    /// steps, 1e-5 m/s): all normal rows before all friction blocks, 172 ms
    /// per step (median) and 67 steps at the cap; this order, 57 ms and 30;
    /// every other sweep in reverse (symmetric Gauss-Seidel), 133 ms and 46.
    pub(super) fn sweep(
        &mut self,
        p: &PgsProblem,
        g: usize,
        omega: f64,
        focus_above: f64,
        nu: &mut [f64],
    ) -> f64 {
        self.focus.clear();
        self.focus_count = 0;
        let mut x = std::mem::take(&mut self.x);
        let mut largest = 0.0f64;
        for &k in p.groups.rows_of(g) {
            let k = k as usize;
            let Some(i) = k.checked_sub(p.nb) else {
                let change = match p.tails.get(k) {
                    // A coupling: its tail on the velocities and the impulse.
                    Some(tail) => {
                        let mut with = WithTail {
                            nu: &mut *nu,
                            tail,
                            weighted: &self.tails_weighted[k - p.tails.first],
                        };
                        self.update_row(p, k, omega, false, &mut x, &mut with)
                    }
                    None => self.update_row(p, k, omega, false, &mut x, nu),
                };
                largest = largest.max(change);
                continue;
            };
            let change = self.update_contact(p, i, omega, &mut x, nu);
            if change > focus_above {
                self.focus_count += 1;
                if self.focus.len() < FOCUS_MAX {
                    self.focus.push(k as u32);
                }
            }
            largest = largest.max(change);
        }
        let (lo, hi) = (
            self.motor_start[g] as usize,
            self.motor_start[g + 1] as usize,
        );
        for t in lo..hi {
            let k = self.motors[t] as usize;
            largest = largest.max(self.update_motor(p, k, omega, &mut x, nu));
        }
        self.x = x;
        largest
    }

    /// Sweeps of the contacts the last sweep left above the tolerance
    /// (`focus`), alone, until none changes by more than half of it or
    /// `FOCUS_SWEEPS` have run; the next sweep of the whole island then
    /// judges the iterate as before (the rule still stops on a full sweep
    /// with no update above the tolerance; only the residual rule focuses:
    /// the distance rule's rate estimate is over whole sweeps).
    ///
    /// Why: late in a landing step of a pile, a few contacts hold the
    /// sweeps up. Measured on the 4,000 pile's step 44 (793 sweeps): after
    /// 300 sweeps fewer than 30 of about 12,000 contacts changed by more
    /// than 1 cm/s a sweep, and the last 200 sweeps were for one to five
    /// friction blocks. With these sweeps (`bench pile --n 4000 --steps
    /// 70`, two runs of each alternated): 16.75 and 16.78 s against 20.01
    /// and 19.71 s, the most sweeps of a step 998 against 1,080; the 1,000
    /// pile's first 800 steps, seeds 1-3: 17.6 s against 19.8 s.
    ///
    /// Only from the `FOCUS_AFTER`-th sweep, i.e. in the long steps of a
    /// landing: focused from the first sweep, the settled 100 pile kept
    /// 1.8 times the kinetic energy at rest (mean of seeds 1-6 after 1,500
    /// steps, 1.2e-3 against 6.8e-4 J; the focus leaves the rest of the
    /// pile less converged when it stops) and slept at step 1,228 instead
    /// of 478. A settled pile's steps take 2 to 20 sweeps, so they keep
    /// their bits. 512 contacts instead of 128 did no better.
    pub(super) fn focus(&mut self, p: &PgsProblem, params: &PgsParams, nu: &mut [f64]) {
        if self.focus.is_empty() {
            return;
        }
        let mut x = std::mem::take(&mut self.x);
        let focus = std::mem::take(&mut self.focus);
        for _ in 0..FOCUS_SWEEPS {
            let mut largest = 0.0f64;
            for &k in &focus {
                let i = k as usize - p.nb;
                largest = largest.max(self.update_contact(p, i, params.relaxation, &mut x, nu));
            }
            if largest <= 0.5 * params.velocity_tolerance {
                break;
            }
        }
        self.focus = focus;
        self.x = x;
    }

    /// Contact `i`'s update: its normal row, then at once its friction
    /// block (whose cone is the one the normal impulse just set); the
    /// larger velocity change of the two (m/s).
    #[inline]
    fn update_contact(
        &self,
        p: &PgsProblem,
        i: usize,
        omega: f64,
        x: &mut [f64],
        nu: &mut [f64],
    ) -> f64 {
        let k = p.nb + i;
        match self.block_of[i] {
            // The two bodies' velocities held through the normal row's and
            // the block's updates (see `Held`).
            Some(f) if self.held => {
                let mut held = Held::load(&p.rows[k], nu);
                let change = self.update_row(p, k, omega, true, x, &mut held);
                let change = change.max(self.update_block(p, f, i, omega, x, &mut held));
                held.store(nu);
                change
            }
            Some(f) => {
                let change = self.update_row(p, k, omega, true, x, nu);
                change.max(self.update_block(p, f, i, omega, x, nu))
            }
            None => self.update_row(p, k, omega, true, x, nu),
        }
    }

    /// Motor `k`'s update, projected on its box `[-F h, F h]`; its
    /// velocity change (m/s or rad/s).
    fn update_motor(
        &self,
        p: &PgsProblem,
        k: usize,
        omega: f64,
        x: &mut [f64],
        nu: &mut [f64],
    ) -> f64 {
        let d = self.motor_diag[k];
        if d <= 0.0 {
            return 0.0;
        }
        let (at, row) = (Self::motor_at(p, k), p.motor_rows() + k);
        let lam = x[at];
        let res = p.rows[row].velocity(nu) + p.offset[row] + p.motor_cfm[k] * lam;
        let cap = p.motor_cap[k];
        let new = (lam - omega * res / d).clamp(-cap, cap);
        let delta = new - lam;
        if delta == 0.0 {
            return 0.0;
        }
        x[at] = new;
        self.weighted[at].add_to(delta, nu);
        delta.abs() * d
    }

    /// A joint (`unilateral` false) or normal row's update; its velocity
    /// change (m/s).
    fn update_row<V: Velocities + ?Sized>(
        &self,
        p: &PgsProblem,
        k: usize,
        omega: f64,
        unilateral: bool,
        x: &mut [f64],
        nu: &mut V,
    ) -> f64 {
        let d = self.diag[k];
        if d <= 0.0 {
            return 0.0;
        }
        let lam = x[k];
        let res = nu.velocity(&p.rows[k]) + p.offset[k] + p.cfm[k] * lam;
        // The inverse, not a division: the division's latency was on the
        // sweep's chain of dependent updates.
        let mut new = lam - omega * res * self.inv_diag[k];
        if unilateral {
            new = new.max(0.0);
        }
        let delta = new - lam;
        if delta == 0.0 {
            return 0.0;
        }
        x[k] = new;
        nu.add(&self.weighted[k], delta);
        delta.abs() * d
    }

    /// Friction block `f` of normal row `i`: a 2-D block step, then the
    /// cone's polygon; its velocity change (m/s).
    fn update_block<V: Velocities + ?Sized>(
        &self,
        p: &PgsProblem,
        f: usize,
        i: usize,
        omega: f64,
        x: &mut [f64],
        nu: &mut V,
    ) -> f64 {
        let at = p.nb + p.nc + 2 * f;
        let tg = &self.tangent[f];
        let pt = [x[at], x[at + 1]];
        let v = [nu.velocity(&tg.t1), nu.velocity(&tg.t2)];
        let inv = &tg.inv;
        let target = [
            pt[0] - omega * (inv[0][0] * v[0] + inv[0][1] * v[1]),
            pt[1] - omega * (inv[1][0] * v[0] + inv[1][1] * v[1]),
        ];
        let cap = p.mu[f] * x[p.nb + i];
        let new = if p.circular {
            project_disc(target, cap)
        } else {
            self.polygon.project(target, cap)
        };
        let delta = [new[0] - pt[0], new[1] - pt[1]];
        if delta == [0.0, 0.0] {
            return 0.0;
        }
        nu.add(&self.weighted[at], delta[0]);
        nu.add(&self.weighted[at + 1], delta[1]);
        x[at] = new[0];
        x[at + 1] = new[1];
        // Not `hypot`: libm's was 8 % of a pile's sweep time; no overflow here.
        tg.scale * (delta[0] * delta[0] + delta[1] * delta[1]).sqrt()
    }
}
