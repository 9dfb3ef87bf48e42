//! The natural-map residual of an island's rows, matrix-free, as Lemke's
//! answers are judged (`solver::relative_residual`).

use super::{Pgs, PgsProblem};
use crate::solver::cone::project_cone;

/// Squared parts of the residual: absolute, and the scales (the LCP's `q`,
/// the joint rows' free residual velocities).
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct Parts {
    abs2: f64,
    q2: f64,
    joint2: f64,
}

impl Parts {
    /// Relative to `max(||q||, ||joint offsets||)`.
    pub(super) fn relative(self) -> f64 {
        let (abs, scale) = (self.abs2.sqrt(), self.q2.max(self.joint2).sqrt());
        if scale > 0.0 {
            abs / scale
        } else {
            abs
        }
    }
}

/// Motor `k`'s slack `s_m` at its impulse `l` (mlcp.rs, `form_matrix`):
/// `|x' - v*|` on the side its bound pushes, zero inside the box.
fn motor_slack(p: &PgsProblem, k: usize, l: f64, nu: &[f64]) -> f64 {
    let row = p.motor_rows() + k;
    let w = p.rows[row].velocity(nu) + p.offset[row] + p.motor_cfm[k] * l;
    let cap = p.motor_cap[k];
    if l >= cap {
        (-w).max(0.0)
    } else if l <= -cap {
        w.max(0.0)
    } else {
        0.0
    }
}

impl Pgs {
    /// The residual both solvers share: the natural-map residual of the
    /// reduced LCP at `[p_n; p_f; s]` (`s` the largest sliding speed against
    /// a friction direction), with the joint rows' residual velocities
    /// added in quadrature, relative to `max(||q||, ||joint offsets||)`.
    /// Also writes the iterate on every row of `lambda` and leaves `[p_n;
    /// p_f; s]` in `z`.
    pub(super) fn residual(
        &mut self,
        p: &PgsProblem,
        lambda: &mut [f64],
        nu: &[f64],
        z: &mut Vec<f64>,
    ) -> f64 {
        self.scatter(p, lambda);
        let motors = p.motor_rows();
        let m = motors - p.nb + 2 * p.motor_cap.len();
        z.clear();
        z.extend_from_slice(&lambda[p.nb..motors]);
        // A motor's pair `(p+, p-)` (mlcp.rs, `form_matrix`).
        for &l in &lambda[motors..] {
            z.extend([l.max(0.0), (-l).max(0.0)]);
        }
        for f in 0..p.friction_of.len() {
            let base = p.nb + p.nc + f * p.nd;
            let s = (0..p.nd)
                .map(|j| -p.rows[base + j].velocity(nu))
                .fold(0.0f64, f64::max);
            z.push(s);
        }
        for k in 0..p.motor_cap.len() {
            z.push(motor_slack(p, k, lambda[motors + k], nu));
        }
        debug_assert_eq!(z.len(), m + p.friction_of.len() + p.motor_cap.len());
        let mut all = Parts::default();
        for g in 0..p.groups.len() {
            let part = self.residual_of(p, g, nu);
            all.abs2 += part.abs2;
            all.q2 += part.q2;
            all.joint2 += part.joint2;
        }
        all.relative()
    }

    /// The residual's parts over `rows` (an island's joint and normal
    /// rows), from the iterate `x` and the velocities `nu`:
    ///
    /// - a joint row: its residual velocity `G_k^T nu + offset_k + cfm_k
    ///   lambda_k`, and for the scale the same at `nu_free` without the
    ///   impulse;
    /// - a normal row and its friction block, polyhedral cone: the natural
    ///   map `z - max(0, z - w)` of the reduced LCP's rows (normal
    ///   `G_n^T nu + a_n`, friction `G_f^T nu + E s`, slack
    ///   `mu p_n - E^T p_f`, with `s` the largest sliding speed against a
    ///   direction, `max(0, max_j -v_j)`): Lemke's measure when the joint
    ///   rows are solved exactly;
    /// - circular cone: the natural-map Coulomb residual with De Saxce's
    ///   change of variable (as for the corpus' 3-D problems),
    ///   `r - proj_K(r - (u + mu |u_T| e_N))`, `r = [p_n, p_t]`,
    ///   `u = [v_n + a_n, v_t]`;
    ///
    /// - a motor: the natural map of its box, `p - clamp(p - w, -F h, F h)`
    ///   with `w = x' - v*` (Lemke's measure on its pair and slack where
    ///   the rest holds);
    ///
    /// and the squares of the LCP's `q` over the rows' unknowns. Over
    /// island `g`'s rows and motors.
    pub(super) fn residual_of(&mut self, p: &PgsProblem, g: usize, nu: &[f64]) -> Parts {
        let rows = p.groups.rows_of(g);
        let term = |zi: f64, wi: f64| {
            let r = zi - (zi - wi).max(0.0);
            r * r
        };
        let nd = p.nd;
        let m = p.motor_rows() - p.nb + 2 * p.motor_cap.len();
        let mut out = Parts::default();
        let mut dirs = std::mem::take(&mut self.dirs);
        dirs.resize(nd, 0.0);
        let x = &self.x;
        for &k in rows {
            let k = k as usize;
            let Some(i) = k.checked_sub(p.nb) else {
                let v = p.tails.velocity(k, &p.rows[k], nu) + p.offset[k] + p.cfm[k] * x[k];
                let free = p.tails.velocity(k, &p.rows[k], p.nu_free) + p.offset[k];
                out.abs2 += v * v;
                out.joint2 += free * free;
                continue;
            };
            if p.held.get(i) == Some(&true) {
                continue;
            }
            let pn = x[k];
            let un = p.rows[k].velocity(nu) + p.offset[k] + p.cfm[k] * pn;
            out.q2 += p.lcp.q[i] * p.lcp.q[i];
            let Some(f) = self.block_of[i] else {
                out.abs2 += term(pn, un);
                continue;
            };
            let at = p.nb + p.nc + 2 * f;
            let pt = [x[at], x[at + 1]];
            let base = p.nc + f * nd;
            out.q2 += p.lcp.q[base..base + nd].iter().map(|q| q * q).sum::<f64>()
                + p.lcp.q[m + f] * p.lcp.q[m + f];
            let mu = p.mu[f];
            if p.circular {
                let tg = &self.tangent[f];
                let ut = [tg.t1.velocity(nu), tg.t2.velocity(nu)];
                let un_hat = un + mu * (ut[0] * ut[0] + ut[1] * ut[1]).sqrt();
                let y = project_cone([pn - un_hat, pt[0] - ut[0], pt[1] - ut[1]], mu);
                out.abs2 += (pn - y[0]).powi(2) + (pt[0] - y[1]).powi(2) + (pt[1] - y[2]).powi(2);
                continue;
            }
            out.abs2 += term(pn, un);
            self.polygon.decompose(pt, &mut dirs);
            let rows_f = &p.rows[p.nb + base..p.nb + base + nd];
            let s = rows_f
                .iter()
                .map(|r| -r.velocity(nu))
                .fold(0.0f64, f64::max);
            let mut total = 0.0;
            for (d, r) in dirs.iter().zip(rows_f) {
                total += d;
                out.abs2 += term(*d, r.velocity(nu) + s);
            }
            out.abs2 += term(s, mu * pn - total);
        }
        self.dirs = dirs;
        let (lo, hi) = (
            self.motor_start[g] as usize,
            self.motor_start[g + 1] as usize,
        );
        let nf = p.friction_of.len();
        for t in lo..hi {
            let k = self.motors[t] as usize;
            let row = p.motor_rows() + k;
            let (l, cap) = (x[Self::motor_at(p, k)], p.motor_cap[k]);
            let w = p.rows[row].velocity(nu) + p.offset[row] + p.motor_cfm[k] * l;
            let r = l - (l - w).clamp(-cap, cap);
            out.abs2 += r * r;
            let at = p.nc + nf * nd + 2 * k;
            out.q2 += p.lcp.q[at].powi(2) + p.lcp.q[at + 1].powi(2) + p.lcp.q[m + nf + k].powi(2);
        }
        out
    }
}
