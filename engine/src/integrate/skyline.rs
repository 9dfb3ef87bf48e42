//! The joint block `G M^-1 G^T` of an island, formed and factored within
//! its envelope (skyline): row `i` couples only to the rows that share a
//! body with it, and the Cholesky factor of a matrix has no entry left of
//! a row's first nonzero. A chain's joints listed in order couple to their
//! neighbours only, so its block is banded: RATTLE's factor and its solves
//! (`rattle.rs`, one factor per stage and two solves per Newton step) cost
//! O(n) instead of O(n^3) and O(n^2). Any other order is correct, only
//! wider.

use crate::constraint::applied::InvMass;
use crate::constraint::rows::Row;

/// The factor `L` of an island's joint block, row-major (`l[i * n + j]`,
/// read for `first[i] <= j <= i`), and each row's first column.
#[derive(Debug, Default)]
pub struct Skyline {
    n: usize,
    first: Vec<usize>,
    l: Vec<f64>,
    /// Per body, the first row on it (scratch).
    body_first: Vec<usize>,
    weighted: Vec<Row>,
}

impl Skyline {
    /// Forms `G M^-1 G^T` of `rows` within its envelope and factors it;
    /// the pivot row where it is not positive definite.
    pub fn factor(&mut self, rows: &[Row], minv: &[InvMass]) -> Result<(), usize> {
        let n = rows.len();
        self.n = n;
        self.body_first.clear();
        self.body_first.resize(minv.len(), usize::MAX);
        for (i, row) in rows.iter().enumerate() {
            for j in [row.a, row.b].into_iter().flatten() {
                let f = &mut self.body_first[j.body];
                *f = (*f).min(i);
            }
        }
        self.first.clear();
        self.first.extend(rows.iter().enumerate().map(|(i, row)| {
            [row.a, row.b]
                .into_iter()
                .flatten()
                .map(|j| self.body_first[j.body])
                .fold(i, usize::min)
        }));
        self.weighted.clear();
        self.weighted.extend(rows.iter().map(|r| r.weighted(minv)));
        self.l.clear();
        self.l.resize(n * n, 0.0);
        for (i, row) in rows.iter().enumerate() {
            for j in self.first[i]..=i {
                self.l[i * n + j] = row.dot(&self.weighted[j]);
            }
        }
        let (l, first) = (&mut self.l, &self.first);
        for i in 0..n {
            for j in first[i]..=i {
                let from = first[i].max(first[j]);
                let s: f64 = (from..j).map(|k| l[i * n + k] * l[j * n + k]).sum();
                let v = l[i * n + j] - s;
                if i == j {
                    if v.is_nan() || v <= 0.0 {
                        return Err(i);
                    }
                    l[i * n + i] = v.sqrt();
                } else {
                    l[i * n + j] = v / l[j * n + j];
                }
            }
        }
        Ok(())
    }

    /// `x <- A^-1 x` for the factored block `A = L L^T`.
    pub fn solve(&self, x: &mut [f64]) {
        let (n, l, first) = (self.n, &self.l, &self.first);
        for i in 0..n {
            let s: f64 = (first[i]..i).map(|k| l[i * n + k] * x[k]).sum();
            x[i] = (x[i] - s) / l[i * n + i];
        }
        for i in (0..n).rev() {
            x[i] /= l[i * n + i];
            let xi = x[i];
            for k in first[i]..i {
                x[k] -= l[i * n + k] * xi;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    /// A chain of four bodies on spherical joints (12 rows, banded) and a
    /// row coupling its ends (the envelope then spans the block): the
    /// solve agrees with the dense one to round-off.
    #[test]
    fn the_envelope_solve_is_the_dense_solve() {
        let minv: Vec<InvMass> = (0..4)
            .map(|i| InvMass {
                inv_m: 1.0 / (1.0 + i as f64),
                inv_i: Matrix3::from_diagonal(&Vector3::new(2.0, 3.0 + i as f64, 4.0)),
            })
            .collect();
        let lever = |k: f64| Vector3::new(0.1 * k, -0.2, 0.05 * k);
        let mut rows = Vec::new();
        for b in 0..4usize {
            for d in 0..3 {
                let a = (b > 0).then(|| (b - 1, lever(b as f64)));
                rows.push(Row::along(
                    Vector3::ith(d, 1.0),
                    a,
                    Some((b, -lever(1.0 + b as f64))),
                ));
            }
        }
        for wide in [false, true] {
            let mut rows = rows.clone();
            if wide {
                rows.push(Row::along(
                    Vector3::new(0.6, 0.0, 0.8),
                    Some((0, lever(0.5))),
                    Some((3, lever(2.0))),
                ));
            }
            let n = rows.len();
            let mut sky = Skyline::default();
            sky.factor(&rows, &minv).expect("positive definite");
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
            let mut x = b.clone();
            sky.solve(&mut x);
            // A x = b, with A formed densely.
            for i in 0..n {
                let ax: f64 = (0..n)
                    .map(|j| rows[i].coupling(&rows[j], &minv) * x[j])
                    .sum();
                assert!((ax - b[i]).abs() < 1e-12, "row {i}: {ax} against {}", b[i]);
            }
        }
    }
}
