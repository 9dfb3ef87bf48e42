//! The rotors' rows (`constraint::armature`) as the energy check and the
//! iterative solver see them: what a rotor's energy did in a step, what
//! its implicit coupling may give, and its rows made exact after a
//! descent stopped short.

use super::Mlcp;
use crate::constraint::applied::InvMass;
use crate::solver::island::Groups;

impl Mlcp {
    /// The kinetic energy change of the rotor of row `k` (0 unless a
    /// rotor's, `constraint::armature`): it turns with the joint, from
    /// `x'_n = -offset` to the rate `end()` the answer gives the joint, so
    /// it changes by `I_a (end^2 - x'_n^2) / 2`, `1 / I_a` the row's
    /// compliance: the energy the measure counts. Solved exactly, this and
    /// the row's share of the bodies' change cancel to the work of the free
    /// motion against the row (second order in `h`); an answer that is
    /// not (PGS at its cap) is charged the rotor's energy as it stands.
    pub(super) fn rotor_change(&self, k: usize, end: impl FnOnce() -> f64) -> f64 {
        if !self.armature().contains(&k) {
            return 0.0;
        }
        let (start, end) = (self.offset[k], end());
        0.5 * (end * end - start * start) / self.cfm[k]
    }

    /// Adds to each island's entry of `out` what its rotors' rows
    /// (`constraint::armature`) may give in a step: a solved row's share
    /// and its rotor's change sum to `lambda (x'_free - x'_n) / 2`, the
    /// free acceleration's work against the implicit coupling (second
    /// order in `h`, and a loss where the joint speeds up as the free
    /// motion would: then nothing is added). It gains where the joint
    /// slows against its free motion (pushed by a torque into a wall: a
    /// random scene's rotor, 7.7e-5 J).
    pub fn add_rotor_work(&self, nu_free: &[f64], groups: &Groups, out: &mut [f64]) {
        for k in self.armature() {
            out[groups.island_of_row(k)] += self.rotor_work(k, nu_free);
        }
    }

    /// Makes the rotors' rows of the islands `of` flags exact, in
    /// Gauss-Seidel passes over them alone (each update a descent of the
    /// energy the iterative solver descends, the rotors' included): a
    /// descent stopped short (the relaxed fallback's cold run) leaves a
    /// rotor's rate, by its impulse, off the joint's, and the energy as
    /// measured (the rotor at the joint's rate) could exceed what the
    /// descent guaranteed (a random scene: 7.7e-5 J). Works on
    /// [`Mlcp::lambda`] (the rows as the iterative solver has them).
    pub fn settle_rotors(
        &mut self,
        minv: &[InvMass],
        nu: &mut [f64],
        groups: &Groups,
        of: &[bool],
    ) {
        const PASSES: usize = 50;
        let rotors = self.armature();
        if rotors.is_empty() {
            return;
        }
        for _ in 0..PASSES {
            let mut worst = 0.0f64;
            for k in rotors.clone() {
                if !of[groups.island_of_row(k)] {
                    continue;
                }
                let row = &self.rows[k];
                let residual = row.velocity(nu) + self.offset[k] + self.cfm[k] * self.lambda[k];
                let d = row.coupling(row, minv) + self.cfm[k];
                let change = -residual / d;
                self.lambda[k] += change;
                row.apply(change, minv, nu);
                worst = worst.max(residual.abs());
            }
            if worst <= 1e-14 {
                break;
            }
        }
    }

    /// [`Mlcp::add_rotor_work`] summed over the islands `of` takes (a
    /// relaxed answer's, whose allowance is otherwise the motors' work).
    pub fn rotor_work_of(
        &self,
        nu_free: &[f64],
        groups: &Groups,
        of: impl Fn(usize) -> bool,
    ) -> f64 {
        self.armature()
            .filter(|&k| of(groups.island_of_row(k)))
            .map(|k| self.rotor_work(k, nu_free))
            .sum()
    }

    /// Rotor row `k`'s share of [`Mlcp::add_rotor_work`].
    fn rotor_work(&self, k: usize, nu_free: &[f64]) -> f64 {
        let free = self.rows[k].velocity(nu_free) + self.offset[k];
        (0.5 * self.p_b[k] * free).max(0.0)
    }
}
