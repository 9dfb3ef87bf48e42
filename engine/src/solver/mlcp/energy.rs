//! What the energy check weighs an answer with (`fallback.rs`): the
//! kinetic energy a solve adds, and the budget the stabilisation, the
//! restitution and the motors may add.

use super::Mlcp;
use crate::constraint::applied::InvMass;
use crate::model::Params;
use crate::solver::island::Groups;

impl Mlcp {
    /// `K(nu') - K(nu_free)` of the last [`Mlcp::recover`] island by island
    /// into `out` (one entry per island of `groups`), from the rows alone:
    /// with `M (nu' - nu_free) = G lambda`,
    /// `K(nu') - K(nu_free) = 1/2 (nu' + nu_free)^T M (nu' - nu_free)
    ///                     = 1/2 sum_k lambda_k G_k^T (nu' + nu_free)`
    /// over the basis rows (joint impulses `p_b`, contact impulses on the
    /// basis); no mass matrix needed. A rotor's row (`constraint::armature`)
    /// adds its rotor's change (`rotors.rs`): the bodies and the rotors
    /// are one system, whose energy the measure counts. The rows' terms
    /// are summed per island in row order, so an island's sum does not
    /// depend on the others.
    pub fn kinetic_change_by_island(
        &self,
        groups: &Groups,
        nu_free: &[f64],
        nu: &[f64],
        out: &mut Vec<f64>,
    ) {
        out.clear();
        out.resize(groups.len(), 0.0);
        let nb = self.nb;
        for (k, row) in self.basis.iter().enumerate() {
            let lambda = if k < nb { self.p_b[k] } else { self.zb[k - nb] };
            if let Some(change) = self.row_change(k, row, lambda, nu_free, nu) {
                out[self.basis_island(groups, k)] += change;
            }
        }
    }

    /// [`Mlcp::kinetic_change_by_island`] from the iterative solver's
    /// impulses `lambda` on [`Mlcp::rows`] (joint, normal and friction
    /// rows).
    pub fn kinetic_change_rows_by_island(
        &self,
        groups: &Groups,
        lambda: &[f64],
        nu_free: &[f64],
        nu: &[f64],
        out: &mut Vec<f64>,
    ) {
        out.clear();
        out.resize(groups.len(), 0.0);
        for (k, (row, &l)) in self.rows.iter().zip(lambda).enumerate() {
            if let Some(change) = self.row_change(k, row, l, nu_free, nu) {
                out[self.row_island(groups, k)] += change;
            }
        }
    }

    /// Row `k`'s term of the kinetic change at impulse `lambda`,
    /// `lambda G_k^T (nu' + nu_free) / 2` (its tail's too), with its
    /// rotor's change if it is a rotor's; `None` where both are zero (the
    /// sum skips it, as it did before rotors).
    fn row_change(
        &self,
        k: usize,
        row: &crate::constraint::rows::Row,
        lambda: f64,
        nu_free: &[f64],
        nu: &[f64],
    ) -> Option<f64> {
        let tails = self.tails();
        let rotor = self.rotor_change(k, || tails.velocity(k, row, nu));
        (lambda != 0.0 || rotor != 0.0).then(|| {
            0.5 * lambda * (tails.velocity(k, row, nu) + tails.velocity(k, row, nu_free)) + rotor
        })
    }

    /// The kinetic energy the stabilisation may give (J), island by island
    /// into `out`: each row whose offset asks for a separation speed `v` (a
    /// joint's drift term, a penetrating or bouncing contact's negative
    /// `a_n`) gets `v^2 / 2` over its own Delassus diagonal (its effective
    /// inverse mass), the energy of that row alone moving at `v` (the
    /// diagonal of its own row, the same for both solvers); a compliant row
    /// also the energy its spring holds, `k psi^2 / 2` with
    /// `psi = v h / ERP`; and the motors' work ([`Mlcp::motor_work`]).
    ///
    /// Why the diagonal: the least energy that meets every row's speed at
    /// once is `1/2 v^T W^-1 v`, unbounded as the rows become dependent. A
    /// jointed chain pressed into a contact is such a case (joint_torques,
    /// step 2069: impulses of 1.7e5 N s, 0.49 J gained in one step without
    /// input): there the rigid answer is the stabilisation's artefact, not
    /// physics, and `engine::fallback` refuses it.
    pub fn stabilisation_budget_by_island(
        &self,
        p: &Params,
        minv: &[InvMass],
        groups: &Groups,
        out: &mut Vec<f64>,
    ) {
        out.clear();
        out.resize(groups.len(), 0.0);
        let nb = self.nb;
        for k in 0..nb + self.nc {
            let (joint, v) = (k < nb, self.offset[k]);
            if self.drifts(k) || (!joint && v < 0.0) {
                let spring = if joint {
                    p.joint_compliance
                } else {
                    p.contact_compliance
                };
                out[groups.island_of_row(k)] += self.row_budget(p, minv, k, spring);
            }
        }
        self.add_motor_work(groups, out);
    }

    /// Row `k`'s share of [`Mlcp::stabilisation_budget_by_island`].
    fn row_budget(
        &self,
        p: &Params,
        minv: &[InvMass],
        k: usize,
        spring: Option<crate::model::Compliance>,
    ) -> f64 {
        let v = self.offset[k];
        let d = self.tails().diagonal(k, &self.rows[k], minv) + self.cfm[k];
        let kinetic = if d > 0.0 { 0.5 * v * v / d } else { 0.0 };
        let stored = spring.map_or(0.0, |k| {
            let psi = v * p.h / k.erp(p.h);
            0.5 * k.stiffness * psi * psi
        });
        kinetic + stored
    }

    /// The most work the motors can do in a step (J): a motor's row gives
    /// `p x'` with `|p| <= F h`, and the box makes `p x' <= F h |v*|`
    /// (interior: `x' = v*`; at `p = F h`, `x' <= v*`; at `-F h`, `x' >=
    /// v*`). With `K(nu') - K(nu_free) <= p^T G^T nu'` (see `Offsets`),
    /// this bounds what they add, in every formulation.
    pub fn motor_work(&self) -> f64 {
        self.motor_cap
            .iter()
            .zip(&self.motor_speed)
            .map(|(cap, v)| cap * v.abs())
            .sum()
    }

    /// [`Mlcp::motor_work`] island by island into `out`.
    pub fn motor_work_by_island(&self, groups: &Groups, out: &mut Vec<f64>) {
        out.clear();
        out.resize(groups.len(), 0.0);
        self.add_motor_work(groups, out);
    }

    /// Adds each motor's [`Mlcp::motor_work`] to its island's entry.
    fn add_motor_work(&self, groups: &Groups, out: &mut [f64]) {
        for (k, (cap, v)) in self.motor_cap.iter().zip(&self.motor_speed).enumerate() {
            out[groups.island_of_row(self.motor_row[k])] += cap * v.abs();
        }
    }

    /// The work the separation-asking offsets `offset` (a copy of
    /// [`Mlcp::offset`] made with [`Offsets::Full`]) would do at the
    /// impulses of the last [`Mlcp::recover`], island by island into
    /// `out`: `sum |lambda_k| |v_k|` over joint rows and over normal rows
    /// with `a_n < 0` (J).
    pub fn offset_work_by_island(&self, offset: &[f64], groups: &Groups, out: &mut Vec<f64>) {
        out.clear();
        out.resize(groups.len(), 0.0);
        let nb = self.nb;
        for k in (0..nb).filter(|&k| self.drifts(k)) {
            out[groups.island_of_row(k)] += (self.p_b[k] * offset[k]).abs();
        }
        for i in 0..self.nc {
            out[groups.island_of_row(nb + i)] += (self.z[i] * offset[nb + i].min(0.0)).abs();
        }
    }

    /// The island (of `groups`) of basis row `k` (`[G_b, G_n, G_t1,
    /// G_t2, G_m]`): a friction row's is its normal row's, a motor's its
    /// joint's.
    pub fn basis_island(&self, groups: &Groups, k: usize) -> usize {
        let (nb, nc, nf) = (self.nb, self.nc, self.nf);
        let row = if k < nb + nc {
            k
        } else if k < nb + nc + 2 * nf {
            nb + self.friction_of[(k - nb - nc) / 2]
        } else {
            self.motor_row[k - nb - nc - 2 * nf]
        };
        groups.island_of_row(row)
    }

    /// The island of row `k` of [`Mlcp::rows`] as the iterative solver
    /// has them (joint, normal, `n_d` friction rows per block, motors).
    pub fn row_island(&self, groups: &Groups, k: usize) -> usize {
        let (nb, nc) = (self.nb, self.nc);
        let motors = self.motor_rows();
        let row = if k < nb + nc {
            k
        } else if k < motors {
            nb + self.friction_of[(k - nb - nc) / self.nd]
        } else {
            self.motor_row[k - motors]
        };
        groups.island_of_row(row)
    }
}
