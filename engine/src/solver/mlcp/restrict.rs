//! The problem cut down or grown in place: the canonical re-solve's LCP cut
//! out of the first one (`restrict`), and PGS's friction rows added to a
//! matrix-free problem.

use super::schur::SMALL_BLOCK;
use super::Mlcp;
use crate::constraint::contact::Contact;
use crate::constraint::rows::Row;

impl Mlcp {
    /// Cuts the problem down to the contacts still marked `in_lcp` (the
    /// canonical re-solve of prune.rs drops those without impulse), keeping
    /// what was computed for the rest: rows, `M^-1 B`, the Delassus entries,
    /// the joint factor and the columns of `Y`. Every kept number is computed
    /// from its own rows alone (a dot of two rows, one triangular solve per
    /// column), so the result is bit for bit what `build_matrix` gives on the
    /// same contacts; then the LCP's matrix is formed again. False (nothing
    /// changed: build afresh) where that does not hold: joint blocks factored
    /// by faer's blocked kernels, or friction rows already added for PGS.
    pub(super) fn restrict(&mut self, contacts: &[Contact]) -> bool {
        let (nb, nc) = (self.nb, self.nc);
        if nb > SMALL_BLOCK || self.rows.len() != nb + nc || self.lcp_m.is_empty() {
            return false;
        }
        let r = self.basis.len();
        let mb = r - nb;
        // The new index of each normal row (usize::MAX: dropped).
        self.new_index.clear();
        let mut t = 0;
        for &ci in &self.lcp_contacts {
            self.new_index
                .push(if contacts[ci].in_lcp { t } else { usize::MAX });
            t += usize::from(contacts[ci].in_lcp);
        }
        let new_nc = t;
        let keep = |i: usize| self.new_index[i] != usize::MAX;
        // Kept basis contact rows, in order: normals, then (t1, t2) pairs.
        self.kept.clear();
        self.kept.extend((0..nc).filter(|&i| keep(i)));
        for (f, &i) in self.friction_of.iter().enumerate() {
            if keep(i) {
                self.kept.push(nc + 2 * f);
                self.kept.push(nc + 2 * f + 1);
            }
        }
        // Every motor stays, last.
        let motors = nc + 2 * self.friction_of.len();
        self.kept.extend(motors..motors + self.nm);
        // Basis-level arrays: joint part as it is, contact part selected.
        let select = |v: &mut Vec<Row>, kept: &[usize]| {
            for (t, &k) in kept.iter().enumerate() {
                v[nb + t] = v[nb + k];
            }
            v.truncate(nb + kept.len());
        };
        select(&mut self.basis, &self.kept);
        select(&mut self.weighted, &self.kept);
        let new_r = nb + self.kept.len();
        let old = |i: usize| if i < nb { i } else { nb + self.kept[i - nb] };
        // The buffers swap roles below, so each is grown to the other's
        // capacity: whichever is `w` next can then hold the largest matrix
        // seen, and a step after warm-up allocates nothing (without this a
        // second pass over the same run reallocated `w` once, found with
        // the broad phase's gas scene in tests/tests/no_allocation.rs).
        self.w_cut.clear();
        self.w_cut.reserve(self.w.capacity());
        for i in 0..new_r {
            for j in 0..new_r {
                self.w_cut.push(self.w[old(i) * r + old(j)]);
            }
        }
        std::mem::swap(&mut self.w, &mut self.w_cut);
        self.y_cut.clear();
        self.y_cut.reserve(self.y.capacity());
        if nb > 0 {
            for &k in &self.kept {
                self.y_cut.extend_from_slice(&self.y[k * nb..(k + 1) * nb]);
            }
        }
        std::mem::swap(&mut self.y, &mut self.y_cut);
        debug_assert!(mb >= self.kept.len());
        // Contact lists and rows.
        for i in 0..nc {
            let t = self.new_index[i];
            if t != usize::MAX {
                self.lcp_contacts[t] = self.lcp_contacts[i];
                self.rows[nb + t] = self.rows[nb + i];
                self.cfm[nb + t] = self.cfm[nb + i];
            }
        }
        self.lcp_contacts.truncate(new_nc);
        self.rows.truncate(nb + new_nc);
        self.cfm.truncate(nb + new_nc);
        let mut g = 0;
        for f in 0..self.friction_of.len() {
            let t = self.new_index[self.friction_of[f]];
            if t != usize::MAX {
                self.friction_of[g] = t;
                self.mu[g] = self.mu[f];
                g += 1;
            }
        }
        self.friction_of.truncate(g);
        self.mu.truncate(g);
        self.nc = new_nc;
        self.nf = g;
        self.offset.truncate(nb);
        self.offset.resize(self.rows.len(), 0.0);
        self.fill_coeffs();
        self.form_matrix();
        true
    }

    /// The friction rows of every block, one per direction, after the
    /// normal rows in [`Mlcp::rows`]: what the iterative solver sweeps.
    /// Lemke's path works on the basis alone, so `build` leaves them out
    /// unless asked for the matrix-free problem.
    pub fn add_friction_rows(&mut self, contacts: &[Contact]) {
        if self.rows.len() > self.nb + self.nc {
            return;
        }
        for &i in &self.friction_of {
            let c = &contacts[self.lcp_contacts[i]];
            for &(cs, sn) in &self.dirs {
                self.rows.push(Row::contact(c, c.t1 * cs + c.t2 * sn));
            }
        }
        // The motors' rows: the basis's last (their offsets `-v*` are
        // form_rhs's).
        let motors = self.basis.len() - self.nm;
        self.rows.extend_from_slice(&self.basis[motors..]);
        self.offset.resize(self.rows.len(), 0.0);
        self.cfm.resize(self.rows.len(), 0.0);
    }
}
