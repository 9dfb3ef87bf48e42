//! From the LCP's answer back to the step's: velocities and joint
//! impulses (`recover`), and each contact's impulses as the outputs and
//! the warm starts take them.

use super::schur::{small, SMALL_BLOCK};
use super::Mlcp;
use crate::constraint::contact::Contact;
use crate::model::WarmContact;
use faer::linalg::triangular_solve::solve_upper_triangular_in_place;
use faer::{MatMut, MatRef, Par};
use nalgebra::Vector3;

impl Mlcp {
    /// From the LCP solution in `self.z`: joint impulses
    /// `p_b = -L^-T (y_b + Y lambda)` and `nu' = nu_free + M^-1 G [p_b; lambda]`.
    pub fn recover(&mut self, nu_free: &[f64], nu: &mut Vec<f64>) {
        debug_assert_eq!(self.weighted.len(), self.basis.len(), "a formed matrix");
        let (nb, m) = (self.nb, self.contact_rows());
        let mb = self.basis.len() - nb;
        // lambda on the basis: C lambda (normal impulses as they are, each
        // friction block summed onto t1 and t2), since G_f p_f = B C p_f.
        self.zb.clear();
        self.zb.resize(mb, 0.0);
        for (&zi, &(k1, c1, k2, c2)) in self.z[..m].iter().zip(&self.coeffs) {
            self.zb[k1] += c1 * zi;
            self.zb[k2] += c2 * zi;
        }
        self.p_b.clear();
        if nb > 0 {
            for k in 0..nb {
                let yk: f64 = (0..mb).map(|j| self.y[j * nb + k] * self.zb[j]).sum();
                self.p_b.push(-(self.yb[k] + yk));
            }
            if nb <= SMALL_BLOCK {
                small::solve_upper_transposed(&self.chol, nb, &mut self.p_b);
            } else {
                let l = MatRef::from_column_major_slice(&self.chol, nb, nb);
                solve_upper_triangular_in_place(
                    l.transpose(),
                    MatMut::from_column_major_slice_mut(&mut self.p_b, nb, 1),
                    Par::Seq,
                );
            }
        }
        nu.clear();
        nu.extend_from_slice(nu_free);
        for (k, row) in self.weighted.iter().enumerate() {
            let impulse = if k < nb { self.p_b[k] } else { self.zb[k - nb] };
            if impulse != 0.0 {
                if k < nb {
                    self.add_joint_impulse(k, impulse, nu);
                } else {
                    row.add_to(impulse, nu);
                }
            }
        }
    }

    /// Each LCP contact's impulses in the answer `z` as a warm start keeps
    /// them (`contacts` indexed by `lcp_contacts`), in the LCP's order,
    /// which ascends by id: its normal row `i`, the impulses, and whether
    /// it has a friction block (else its friction is zero).
    pub fn contact_impulses<'a>(
        &'a self,
        contacts: &'a [Contact],
    ) -> impl Iterator<Item = (usize, WarmContact, bool)> + 'a {
        let mut friction = self.friction_of.iter().enumerate().peekable();
        self.lcp_contacts.iter().enumerate().map(move |(i, &ci)| {
            let c = &contacts[ci];
            let block = friction.next_if(|(_, &row)| row == i).map(|(f, _)| f);
            let warm = WarmContact {
                id: c.id,
                normal: self.z[i],
                friction: block.map_or(Vector3::zeros(), |f| self.friction_impulse(f, c)),
            };
            (i, warm, block.is_some())
        })
    }

    /// Friction block `f`'s impulse in the answer `z` as a world vector on
    /// contact `c`'s tangent plane (`c` the block's contact).
    pub(super) fn friction_impulse(&self, f: usize, c: &Contact) -> Vector3<f64> {
        let base = self.nc + f * self.nd;
        (0..self.nd)
            .map(|j| {
                let (cs, sn) = self.dirs[j];
                (c.t1 * cs + c.t2 * sn) * self.z[base + j]
            })
            .sum()
    }
}
