//! The Schur complement of the joint block (the derivation is at the top
//! of `mod.rs`): `A_bb = L L^T` factored (plain loops in `small` up to
//! `SMALL_BLOCK` rows, faer above), `Y = L^-1 A_bc`, and the pure LCP's
//! matrix `W = A_cc - Y^T Y` and right-hand side `b` formed from them.

use super::{normal_offset, Mlcp, MlcpError, Offsets, HELD};
use crate::constraint::contact::Contact;
use crate::model::Params;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{
    cholesky_in_place, cholesky_in_place_scratch, LltRegularization,
};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{MatMut, MatRef, Par};

/// A Cholesky pivot below this fraction of the block's largest diagonal
/// entry means dependent joint rows (redundant joints or a closed loop).
const SINGULAR_PIVOT: f64 = 1e-12;

/// Relative diagonal shift of a singular joint block (see `reduce_joints`;
/// the projection's joint block takes it too, `integrate::project`).
pub const JOINT_CFM: f64 = 1e-9;

/// Joint blocks up to this many rows (8 spherical joints) are factored by
/// the plain loops of [`small`], larger ones by faer's blocked kernels: on
/// the reference scene's 6 x 6 block faer's dispatch cost more than the
/// arithmetic (the joint reduction took 0.7 us per build).
pub(super) const SMALL_BLOCK: usize = 24;

/// Cholesky factorisation and triangular solves for small column-major
/// blocks, where plain loops beat any dispatch.
pub mod small {
    /// `A = L L^T` in place (lower triangle, column-major `n x n`); the
    /// index of the first pivot that is not positive on failure.
    pub fn cholesky(a: &mut [f64], n: usize) -> Result<(), usize> {
        for j in 0..n {
            let d = a[j + j * n] - (0..j).map(|k| a[j + k * n] * a[j + k * n]).sum::<f64>();
            if d.is_nan() || d <= 0.0 {
                return Err(j);
            }
            let djj = d.sqrt();
            a[j + j * n] = djj;
            for i in j + 1..n {
                let s: f64 = (0..j).map(|k| a[i + k * n] * a[j + k * n]).sum();
                a[i + j * n] = (a[i + j * n] - s) / djj;
            }
        }
        Ok(())
    }

    /// `X <- L^-1 X` for the columns of `x` (column-major, `n` rows).
    pub fn solve_lower(l: &[f64], n: usize, x: &mut [f64]) {
        for col in x.chunks_exact_mut(n) {
            for i in 0..n {
                let s: f64 = (0..i).map(|k| l[i + k * n] * col[k]).sum();
                col[i] = (col[i] - s) / l[i + i * n];
            }
        }
    }

    /// `x <- L^-T x`.
    pub fn solve_upper_transposed(l: &[f64], n: usize, x: &mut [f64]) {
        for i in (0..n).rev() {
            let s: f64 = (i + 1..n).map(|k| l[k + i * n] * x[k]).sum();
            x[i] = (x[i] - s) / l[i + i * n];
        }
    }
}

/// `X <- L^-1 X` for the `nb x nb` factor `l` (column-major) and the
/// columns of `x` (column-major, `nb` rows): the small-block loops up to
/// [`SMALL_BLOCK`] rows, faer above, as the factor was made.
pub(super) fn solve_lower(l: &[f64], nb: usize, x: &mut [f64]) {
    if nb == 0 || x.is_empty() {
        return;
    }
    if nb <= SMALL_BLOCK {
        small::solve_lower(l, nb, x);
    } else {
        let cols = x.len() / nb;
        solve_lower_triangular_in_place(
            MatRef::from_column_major_slice(l, nb, nb),
            MatMut::from_column_major_slice_mut(x, nb, cols),
            Par::Seq,
        );
    }
}

impl Mlcp {
    /// Factors `A_bb` and forms `Y = L^-1 A_bc`.
    pub(super) fn reduce_joints(&mut self) -> Result<(), MlcpError> {
        let (nb, r) = (self.nb, self.basis.len());
        let m = r - nb;
        self.chol.clear();
        self.y.clear();
        self.joint_regularized = false;
        if nb == 0 {
            return Ok(());
        }
        for j in 0..m {
            for i in 0..nb {
                self.y.push(self.w[i * r + nb + j]);
            }
        }
        // Over the rigid rows: a rotor's row (`constraint::armature`) is
        // never singular (its compliance), and its diagonal, a light
        // link's inverse inertia, would scale the shift up a thousandfold
        // (a box held by three ball joints then no longer held its
        // contacts, `HELD`, and PGS fought the joints for them).
        let rotors = self.armature();
        let max_diag = (0..nb)
            .filter(|i| !rotors.contains(i))
            .fold(0.0f64, |a, i| a.max(self.w[i * r + i]));

        if nb > SMALL_BLOCK && self.mem.as_ref().is_none_or(|(cap, _)| *cap < nb) {
            let req = cholesky_in_place_scratch::<f64>(nb, Par::Seq, Default::default());
            self.mem = Some((nb, MemBuffer::new(req)));
        }
        // NOTE: redundant joints (two joints on one pair, some closed loops)
        // make A_bb singular: their impulses are indeterminate although the
        // motion is not. Then A_bb + eps max(diag) I is factored instead
        // (ODE's constraint force mixing): among the impulses that give the
        // motion it picks one of small norm, and it leaves a joint velocity
        // error of order eps |p_b| / m, far below the stabilisation's reach.
        // The step report counts it in `regularized`.
        let mut failure = None;
        for shift in [0.0, JOINT_CFM * max_diag] {
            self.chol.clear();
            for j in 0..nb {
                for i in 0..nb {
                    self.chol
                        .push(self.w[i * r + j] + if i == j { shift + self.cfm[i] } else { 0.0 });
                }
            }
            let factored = if nb <= SMALL_BLOCK {
                small::cholesky(&mut self.chol, nb)
            } else {
                let Some((_, mem)) = self.mem.as_mut() else {
                    unreachable!("scratch allocated above")
                };
                let stack = MemStack::new(mem);
                let a = MatMut::from_column_major_slice_mut(&mut self.chol, nb, nb);
                cholesky_in_place(
                    a,
                    LltRegularization::default(),
                    Par::Seq,
                    stack,
                    Default::default(),
                )
                .map(|_| ())
                .map_err(|e| match e {
                    faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
                        index
                    }
                })
            };
            failure = match factored {
                Err(index) => Some(MlcpError::SingularJointBlock {
                    row: index,
                    pivot: 0.0,
                }),
                Ok(()) => (0..nb).find_map(|i| {
                    let d = self.chol[i * nb + i];
                    (d * d < SINGULAR_PIVOT * max_diag).then_some(MlcpError::SingularJointBlock {
                        row: i,
                        pivot: d * d,
                    })
                }),
            };
            if failure.is_none() {
                self.joint_regularized = shift > 0.0;
                break;
            }
        }
        if let Some(e) = failure {
            return Err(e);
        }
        solve_lower(&self.chol, nb, &mut self.y);
        Ok(())
    }

    /// The pure LCP's right-hand side `q` alone (no matrix): what the
    /// iterative solver needs for its normal offsets and residual scale.
    /// Formed on the basis contact rows (in `self.qb`), then expanded.
    pub(super) fn form_rhs(&mut self, contacts: &[Contact], p: &Params, offsets: Offsets) {
        let (nb, r) = (self.nb, self.basis.len());
        let mb = r - nb;
        let n = self.lcp_size();
        self.qb.clear();
        for i in 0..mb {
            let yi = &self.y[i * nb..(i + 1) * nb];
            let schur: f64 = yi.iter().zip(&self.yb).map(|(a, b)| a * b).sum();
            self.qb.push(self.b[nb + i] - schur);
        }
        self.lcp_q.clear();
        self.lcp_q.resize(n, 0.0);
        for (q, &(k1, c1, k2, c2)) in self.lcp_q.iter_mut().zip(&self.coeffs) {
            *q = c1 * self.qb[k1] + c2 * self.qb[k2];
        }
        // Gap terms: the free normal velocity includes the joints' response.
        for i in 0..self.nc {
            let c = &contacts[self.lcp_contacts[i]];
            let held = self.held.get(i).copied().unwrap_or(false);
            let a_n = if !held && !self.relaxes(offsets, nb + i) {
                normal_offset(c, self.lcp_q[i], p)
            } else {
                normal_offset(c, self.lcp_q[i], p).max(0.0)
            };
            self.lcp_q[i] += a_n;
            if held {
                // Its row is `w = z + q` (form_matrix): z = 0.
                self.lcp_q[i] = self.lcp_q[i].max(0.0);
            }
            self.offset[nb + i] = a_n;
        }
        // Motors (see form_matrix): `w+ = x' - v* + s_m`, `w- = -(x' - v*)
        // + s_m`, `w_s = F h - p+ - p-`. The target is no position error:
        // the relaxed problem keeps it (its bounded rows leave the
        // homogeneous problem's `x = 0` on the pairs, see `Offsets`).
        let (rows, nf) = (self.contact_rows(), self.nf);
        let motor_rows = self.motor_rows();
        for k in 0..self.nm {
            let (at, v) = (self.motor_pair(k), self.motor_speed[k]);
            self.lcp_q[at] -= v;
            self.lcp_q[at + 1] += v;
            self.lcp_q[rows + nf + k] = self.motor_cap[k];
            // The iterative solver's row (matrix-free: after the friction
            // rows) reads `x' - v*`.
            if let Some(o) = self.offset.get_mut(motor_rows + k) {
                *o = -v;
            }
        }
    }

    /// Forms the pure LCP's matrix from `W - Y^T Y` on the basis (in
    /// `self.sb`), expanded, with `E`, `-E^T` and `U`.
    pub(super) fn form_matrix(&mut self) {
        let (nb, r) = (self.nb, self.basis.len());
        let mb = r - nb;
        let m = self.contact_rows();
        let n = self.lcp_size();
        self.sb.clear();
        self.sb.resize(mb * mb, 0.0);
        for i in 0..mb {
            let yi = &self.y[i * nb..(i + 1) * nb];
            for j in i..mb {
                let yj = &self.y[j * nb..(j + 1) * nb];
                let schur: f64 = yi.iter().zip(yj).map(|(a, b)| a * b).sum();
                let v = self.w[(nb + i) * r + nb + j] - schur;
                self.sb[i * mb + j] = v;
                self.sb[j * mb + i] = v;
            }
        }
        // M_cc = C^T S C in two passes: T = S C (mb x m), then each LCP row
        // is a combination of two rows of T (contiguous, so it vectorises).
        self.sc.clear();
        self.sc.resize(mb * m, 0.0);
        for (k, t) in self.sc.chunks_exact_mut(m.max(1)).enumerate() {
            let sk = &self.sb[k * mb..][..mb];
            for (out, &(kj1, cj1, kj2, cj2)) in t.iter_mut().zip(&self.coeffs) {
                *out = cj1 * sk[kj1] + cj2 * sk[kj2];
            }
        }
        self.lcp_m.clear();
        self.lcp_m.resize(n * n, 0.0);
        for (i, &(ki1, ci1, ki2, ci2)) in self.coeffs.iter().enumerate() {
            let (t1, t2) = (&self.sc[ki1 * m..][..m], &self.sc[ki2 * m..][..m]);
            for ((out, a), b) in self.lcp_m[i * n..i * n + m].iter_mut().zip(t1).zip(t2) {
                *out = ci1 * a + ci2 * b;
            }
        }
        self.held.clear();
        self.held.extend((0..self.nc).map(|i| {
            let unreduced = self.w[(nb + i) * r + nb + i];
            self.sb[i * mb + i] <= HELD * unreduced
        }));
        // A held row leaves the problem: `w_i = W_nn z_i + q_i` alone, with
        // `q_i >= 0` (form_rhs), so `z_i = 0`. Its round-off couplings
        // would otherwise be pivoted on. Its slack row keeps `mu z_i`.
        for i in 0..self.nc {
            if self.held[i] {
                for j in 0..m {
                    self.lcp_m[i * n + j] = 0.0;
                    self.lcp_m[j * n + i] = 0.0;
                }
                self.lcp_m[i * n + i] = self.w[(nb + i) * r + nb + i];
            }
        }
        // Compliant normal rows (model.rs, `Compliance`).
        for i in 0..self.nc {
            self.lcp_m[i * n + i] += self.cfm[self.nb + i];
        }
        // E and its transpose, U: friction rows of contact f sit at
        // nc + f nd ..; its slack s_f at m + f.
        for (f, (&i, &mu)) in self.friction_of.iter().zip(&self.mu).enumerate() {
            let s = m + f;
            for j in 0..self.nd {
                let row = self.nc + f * self.nd + j;
                self.lcp_m[row * n + s] = 1.0;
                self.lcp_m[s * n + row] = -1.0;
            }
            self.lcp_m[s * n + i] = mu;
        }
        // Motors, a bounded row as a friction block of two directions
        // (motor.rs): with `p = p+ - p-`, `p+-, s_m >= 0` and `w` the
        // row's `x' - v*`,
        //   w+  =  w + s_m >= 0  _|_  p+ >= 0
        //   w-  = -w + s_m >= 0  _|_  p- >= 0
        //   w_s = F h - p+ - p- >= 0  _|_  s_m >= 0.
        // If s_m = 0: w+ = w and w- = -w are both >= 0, so w = 0 (x' =
        // v*) with p+ + p- <= F h, |p| <= F h. If s_m > 0: w_s = 0, p+ +
        // p- = F h; p+ and p- cannot both be positive (then w+ = w- = 0
        // and s_m = (w+ + w-) / 2 = 0), so either p = F h with w = -s_m
        // < 0 (x' < v*: full push forward) or p = -F h with w = s_m > 0.
        // That is the box of motor.rs, and `s_m = |x' - v*|` when the
        // bound holds, as friction's slack is the slip. The pair's rows
        // are +- the motor's basis row (fill_coeffs); `E` enters their
        // slack column, `-E^T` the slack row, whose constant `F h` is in
        // `q` (form_rhs).
        // A compliant motor's row reads `w + eps p` (motor.rs): `eps` on
        // the pair's block as `[[eps, -eps], [-eps, eps]]`.
        for k in 0..self.nm {
            let (at, s) = (self.motor_pair(k), m + self.nf + k);
            for row in [at, at + 1] {
                self.lcp_m[row * n + s] = 1.0;
                self.lcp_m[s * n + row] = -1.0;
            }
            let eps = self.motor_cfm[k];
            if eps != 0.0 {
                self.lcp_m[at * n + at] += eps;
                self.lcp_m[at * n + at + 1] -= eps;
                self.lcp_m[(at + 1) * n + at] -= eps;
                self.lcp_m[(at + 1) * n + at + 1] += eps;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::small;

    /// The small-block loops against the definition: `L L^T = A`,
    /// `L (L^-1 b) = b`, `L^T (L^-T b) = b`, and a singular block refused at
    /// its dependent row.
    #[test]
    fn small_cholesky_and_solves() {
        let n = 5;
        // A = B B^T + I, B with entries from a fixed sequence.
        let b: Vec<f64> = (0..n * n)
            .map(|k| ((k * 37 % 11) as f64 - 5.0) / 3.0)
            .collect();
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                a[i + j * n] = (0..n).map(|k| b[i + k * n] * b[j + k * n]).sum::<f64>()
                    + if i == j { 1.0 } else { 0.0 };
            }
        }
        let mut l = a.clone();
        small::cholesky(&mut l, n).unwrap();
        for i in 0..n {
            for j in 0..=i {
                let llt: f64 = (0..=j).map(|k| l[i + k * n] * l[j + k * n]).sum();
                assert!((llt - a[i + j * n]).abs() < 1e-12 * a[i + i * n], "{i} {j}");
            }
        }
        let rhs: Vec<f64> = (0..n).map(|i| i as f64 - 1.5).collect();
        let mut x = rhs.clone();
        small::solve_lower(&l, n, &mut x);
        for i in 0..n {
            let lx: f64 = (0..=i).map(|k| l[i + k * n] * x[k]).sum();
            assert!((lx - rhs[i]).abs() < 1e-12);
        }
        let mut x = rhs.clone();
        small::solve_upper_transposed(&l, n, &mut x);
        for i in 0..n {
            let ltx: f64 = (i..n).map(|k| l[k + i * n] * x[k]).sum();
            assert!((ltx - rhs[i]).abs() < 1e-12);
        }
        // Two equal rows: the second pivot is zero.
        let mut s = vec![1.0, 1.0, 1.0, 1.0];
        assert_eq!(small::cholesky(&mut s, 2), Err(1));
    }
}
