//! What the energy check weighs an answer with (`fallback.rs`): the
//! kinetic energy a solve adds, and the budget the stabilisation, the
//! restitution and the motors may add.

use super::Mlcp;
use crate::constraint::applied::InvMass;
use crate::model::Params;

impl Mlcp {
    /// `K(nu') - K(nu_free)` of the last [`Mlcp::recover`], from the rows
    /// alone: with `M (nu' - nu_free) = G lambda`,
    /// `K(nu') - K(nu_free) = 1/2 (nu' + nu_free)^T M (nu' - nu_free)
    ///                     = 1/2 sum_k lambda_k G_k^T (nu' + nu_free)`
    /// over the basis rows (joint impulses `p_b`, contact impulses on the
    /// basis); no mass matrix needed.
    pub fn kinetic_change(&self, nu_free: &[f64], nu: &[f64]) -> f64 {
        let nb = self.nb;
        self.basis
            .iter()
            .enumerate()
            .map(|(k, row)| {
                let lambda = if k < nb { self.p_b[k] } else { self.zb[k - nb] };
                if lambda == 0.0 {
                    0.0
                } else {
                    0.5 * lambda * (row.velocity(nu) + row.velocity(nu_free))
                }
            })
            .sum()
    }

    /// The kinetic energy the stabilisation may give (J): each row whose
    /// offset asks for a separation speed `v` (a joint's drift term, a
    /// penetrating or bouncing contact's negative `a_n`) gets `v^2 / 2`
    /// over its own Delassus diagonal (its effective inverse mass), the
    /// energy of that row alone moving at `v` (the diagonal of its own
    /// row, the same for both solvers); a compliant row also the energy its
    /// spring holds, `k psi^2 / 2` with `psi = v h / ERP`.
    ///
    /// Why the diagonal: the least energy that meets every row's speed at
    /// once is `1/2 v^T W^-1 v`, unbounded as the rows become dependent. A
    /// jointed chain pressed into a contact is such a case (joint_torques,
    /// step 2069: impulses of 1.7e5 N s, 0.49 J gained in one step without
    /// input): there the rigid answer is the stabilisation's artefact, not
    /// physics, and `engine::fallback` refuses it.
    pub fn stabilisation_budget(&self, p: &Params, minv: &[InvMass]) -> f64 {
        let nb = self.nb;
        let row = |k: usize, spring: Option<crate::model::Compliance>| {
            let v = self.offset[k];
            let d = self.rows[k].coupling(&self.rows[k], minv) + self.cfm[k];
            let kinetic = if d > 0.0 { 0.5 * v * v / d } else { 0.0 };
            let stored = spring.map_or(0.0, |k| {
                let psi = v * p.h / k.erp(p.h);
                0.5 * k.stiffness * psi * psi
            });
            kinetic + stored
        };
        let joints: f64 = (0..nb).map(|k| row(k, p.joint_compliance)).sum();
        let contacts: f64 = (nb..nb + self.nc)
            .filter(|&k| self.offset[k] < 0.0)
            .map(|k| row(k, p.contact_compliance))
            .sum();
        joints + contacts + self.motor_work()
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

    /// [`Mlcp::kinetic_change`] from the iterative solver's impulses
    /// `lambda` on [`Mlcp::rows`] (joint, normal and friction rows).
    pub fn kinetic_change_rows(&self, lambda: &[f64], nu_free: &[f64], nu: &[f64]) -> f64 {
        self.rows
            .iter()
            .zip(lambda)
            .filter(|(_, &l)| l != 0.0)
            .map(|(row, &l)| 0.5 * l * (row.velocity(nu) + row.velocity(nu_free)))
            .sum()
    }

    /// The work the separation-asking offsets `offset` (a copy of
    /// [`Mlcp::offset`] made with [`Offsets::Full`]) would do at the
    /// impulses of the last [`Mlcp::recover`]: `sum |lambda_k| |v_k|` over
    /// joint rows and over normal rows with `a_n < 0` (J).
    pub fn offset_work(&self, offset: &[f64]) -> f64 {
        let nb = self.nb;
        let joints: f64 = (0..nb).map(|k| (self.p_b[k] * offset[k]).abs()).sum();
        let contacts: f64 = (0..self.nc)
            .map(|i| (self.z[i] * offset[nb + i].min(0.0)).abs())
            .sum();
        joints + contacts
    }
}
