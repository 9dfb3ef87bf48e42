//! The friction cone's geometry for the iterative solver: projections onto
//! the polyhedral cone's polygon (vertices `mu p_n d_j`), the disc and the
//! second-order cone, and the 2-D tangential impulse written on, and read
//! from, the `n_d` friction directions.
//!
//! [`Polygon`] holds the directions and edge normals of one `n_d` as
//! tables: a friction block's update in a sweep then costs no sine or
//! cosine. Measured on the 1,000-sphere pile: the trigonometry of the
//! direction coefficients was most of a sweep's time. The tables hold the
//! same expressions' values as [`direction`], so both give the same bits.

use crate::constraint::contact::direction_coefficients as direction;

/// The polygon of the polyhedral cone with `n_d` directions, tabulated.
#[derive(Debug, Default, Clone)]
pub struct Polygon {
    nd: usize,
    /// `d_j = (cos, sin)` for `j = 0..=n_d` (`d_nd` closes the polygon).
    dirs: Vec<(f64, f64)>,
    /// The outward normal of edge `j` (from `d_j` to `d_j+1`).
    normals: Vec<(f64, f64)>,
    /// `cos(pi / n_d)`: the apothem of the polygon of unit radius.
    cos_half: f64,
}

impl Polygon {
    /// The tables for `nd` directions (kept when they are for it already).
    pub fn set(&mut self, nd: usize) {
        if self.nd == nd && !self.dirs.is_empty() {
            return;
        }
        self.nd = nd;
        self.dirs.clear();
        self.dirs.extend((0..=nd).map(|j| direction(j, nd)));
        self.normals.clear();
        self.normals.extend((0..nd).map(|j| edge_normal(j, nd)));
        self.cos_half = cos_half(nd);
    }

    /// [`project_polygon`] from the tables.
    #[inline]
    pub fn project(&self, x: [f64; 2], cap: f64) -> [f64; 2] {
        project_with(
            x,
            cap,
            self.nd,
            self.cos_half,
            |j| self.normals[j],
            |j| self.dirs[j],
        )
    }

    /// [`decompose`] from the tables.
    pub fn decompose(&self, p: [f64; 2], out: &mut [f64]) {
        decompose_with(p, self.nd, |j| self.dirs[j], out)
    }

    /// [`tangential`] from the tables.
    pub fn tangential(&self, block: &[f64]) -> [f64; 2] {
        tangential_with(block, |j| self.dirs[j])
    }
}

/// Up to this many directions, [`edge_normal`] and [`cos_half`] are
/// tabled, as `contact::direction_coefficients` is: the warm start clips
/// each contact's friction to its polygon in every step
/// ([`project_polygon`], `pgs::warm_friction`), and computed there they
/// were two to nine cosines and sines per contact (at 10,000 spheres,
/// 24,000 contacts a step). The tables hold the same expressions' values,
/// bit for bit.
const TABLED: usize = 16;

struct Tables {
    normals: [[(f64, f64); TABLED]; TABLED + 1],
    cos_half: [f64; TABLED + 1],
}

fn tables() -> &'static Tables {
    static TABLES: std::sync::OnceLock<Tables> = std::sync::OnceLock::new();
    TABLES.get_or_init(|| {
        let mut t = Tables {
            normals: [[(1.0, 0.0); TABLED]; TABLED + 1],
            cos_half: [1.0; TABLED + 1],
        };
        for nd in 1..=TABLED {
            t.cos_half[nd] = exact_cos_half(nd);
            for j in 0..nd {
                t.normals[nd][j] = exact_edge_normal(j, nd);
            }
        }
        t
    })
}

/// The outward normal of the polygon's edge `j`, at angle `2 pi j / n_d +
/// pi / n_d`.
fn edge_normal(j: usize, nd: usize) -> (f64, f64) {
    match (1..=TABLED).contains(&nd) && j < nd {
        true => tables().normals[nd][j],
        false => exact_edge_normal(j, nd),
    }
}

fn exact_edge_normal(j: usize, nd: usize) -> (f64, f64) {
    let half = std::f64::consts::PI / nd as f64;
    let a = std::f64::consts::TAU * j as f64 / nd as f64 + half;
    (a.cos(), a.sin())
}

/// `cos(pi / n_d)`: the apothem of the polygon of unit radius.
fn cos_half(nd: usize) -> f64 {
    match (1..=TABLED).contains(&nd) {
        true => tables().cos_half[nd],
        false => exact_cos_half(nd),
    }
}

fn exact_cos_half(nd: usize) -> f64 {
    (std::f64::consts::PI / nd as f64).cos()
}

/// The point of the polygon with vertices `cap d_j` (the polyhedral cone at
/// normal impulse `cap / mu`) nearest to `x`, in tangent-plane coordinates.
pub fn project_polygon(x: [f64; 2], cap: f64, nd: usize) -> [f64; 2] {
    project_with(
        x,
        cap,
        nd,
        cos_half(nd),
        |j| edge_normal(j, nd),
        |j| direction(j, nd),
    )
}

fn project_with(
    x: [f64; 2],
    cap: f64,
    nd: usize,
    cos_half: f64,
    normal: impl Fn(usize) -> (f64, f64),
    dir: impl Fn(usize) -> (f64, f64),
) -> [f64; 2] {
    if cap <= 0.0 {
        return [0.0, 0.0];
    }
    // Inside: within every edge's supporting line.
    let apothem = cap * cos_half;
    let inside = (0..nd).all(|j| {
        let (c, s) = normal(j);
        c * x[0] + s * x[1] <= apothem
    });
    if inside {
        return x;
    }
    // Else the nearest point of the nearest edge.
    let mut best = [0.0, 0.0];
    let mut best_d = f64::INFINITY;
    for j in 0..nd {
        let (c0, s0) = dir(j);
        let (c1, s1) = dir(j + 1);
        let (p0, p1) = ([cap * c0, cap * s0], [cap * c1, cap * s1]);
        let e = [p1[0] - p0[0], p1[1] - p0[1]];
        let t = (((x[0] - p0[0]) * e[0] + (x[1] - p0[1]) * e[1]) / (e[0] * e[0] + e[1] * e[1]))
            .clamp(0.0, 1.0);
        let q = [p0[0] + t * e[0], p0[1] + t * e[1]];
        let d = (q[0] - x[0]).powi(2) + (q[1] - x[1]).powi(2);
        if d < best_d {
            best_d = d;
            best = q;
        }
    }
    best
}

/// The 2-D tangential impulse of a friction block: `sum_j p_j d_j`.
pub fn tangential(block: &[f64]) -> [f64; 2] {
    let nd = block.len();
    tangential_with(block, |j| direction(j, nd))
}

fn tangential_with(block: &[f64], dir: impl Fn(usize) -> (f64, f64)) -> [f64; 2] {
    let mut pt = [0.0, 0.0];
    for (j, p) in block.iter().enumerate() {
        let (c, s) = dir(j);
        pt[0] += p * c;
        pt[1] += p * s;
    }
    pt
}

/// Writes the 2-D tangential impulse `p` as nonnegative impulses on the two
/// friction directions that bracket it (the others zero).
pub fn decompose(p: [f64; 2], nd: usize, out: &mut [f64]) {
    decompose_with(p, nd, |j| direction(j, nd), out)
}

fn decompose_with(p: [f64; 2], nd: usize, dir: impl Fn(usize) -> (f64, f64), out: &mut [f64]) {
    out.fill(0.0);
    if p == [0.0, 0.0] {
        return;
    }
    let j = sector(p, nd, &dir);
    let (c0, s0) = dir(j);
    let (c1, s1) = dir(j + 1);
    // p = a d_j + b d_j+1.
    let det = c0 * s1 - s0 * c1;
    let a = (p[0] * s1 - p[1] * c1) / det;
    let b = (c0 * p[1] - s0 * p[0]) / det;
    out[j] = a.max(0.0);
    out[(j + 1) % nd] += b.max(0.0);
}

/// The sector `j` of the polygon that holds `p` (between `d_j` and
/// `d_j+1`): `floor(angle(p) / (2 pi / n_d))`.
///
/// By the signs of `d_j x p` and `p x d_j+1` where both clear `SECTOR_MARGIN`
/// of `|p|`, else by the angle itself. Why both: `atan2` was a thirtieth of
/// a pile's step (PGS decomposes every friction block it updates); the
/// cross products decide alike wherever `p` is more than `SECTOR_MARGIN`
/// radians from a sector's edge (the angle's rounding, a few 1e-16, and the
/// table's cannot move it across), and on an edge the angle decides as it
/// always did, so the decomposition keeps its bits.
fn sector(p: [f64; 2], nd: usize, dir: &impl Fn(usize) -> (f64, f64)) -> usize {
    let clear = SECTOR_MARGIN * p[0].abs().max(p[1].abs());
    for j in 0..nd {
        let ((c0, s0), (c1, s1)) = (dir(j), dir(j + 1));
        if c0 * p[1] - s0 * p[0] > clear && p[0] * s1 - p[1] * c1 > clear {
            return j;
        }
    }
    sector_by_angle(p, nd)
}

/// How far (relative to `|p|`, in radians) from a sector's edge the cross
/// products decide [`sector`].
const SECTOR_MARGIN: f64 = 1e-9;

fn sector_by_angle(p: [f64; 2], nd: usize) -> usize {
    let step = std::f64::consts::TAU / nd as f64;
    let angle = p[1].atan2(p[0]).rem_euclid(std::f64::consts::TAU);
    ((angle / step) as usize).min(nd - 1)
}

/// Projection onto the second-order cone `||r_T|| <= mu r_N`, `r = [r_N,
/// r_T1, r_T2]`.
pub fn project_cone(r: [f64; 3], mu: f64) -> [f64; 3] {
    let (rn, rt) = (r[0], (r[1] * r[1] + r[2] * r[2]).sqrt());
    if rt <= mu * rn {
        r
    } else if mu * rt <= -rn {
        [0.0; 3]
    } else {
        let a = (mu * rt + rn) / (1.0 + mu * mu);
        [a, mu * a * r[1] / rt, mu * a * r[2] / rt]
    }
}

/// The point of the disc of radius `cap` nearest to `x`.
pub fn project_disc(x: [f64; 2], cap: f64) -> [f64; 2] {
    let r = (x[0] * x[0] + x[1] * x[1]).sqrt();
    if r <= cap.max(0.0) {
        x
    } else if cap <= 0.0 {
        [0.0, 0.0]
    } else {
        [x[0] * cap / r, x[1] * cap / r]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tabled_edge_normals_are_the_computed_ones_to_the_bit() {
        for nd in 1..=TABLED + 2 {
            assert_eq!(cos_half(nd).to_bits(), exact_cos_half(nd).to_bits(), "{nd}");
            for j in 0..nd + 1 {
                let (t, e) = (edge_normal(j, nd), exact_edge_normal(j, nd));
                assert_eq!(
                    (t.0.to_bits(), t.1.to_bits()),
                    (e.0.to_bits(), e.1.to_bits())
                );
            }
        }
    }

    #[test]
    fn the_sector_by_cross_products_is_the_sector_by_angle() {
        // Points all around, and on and a hair beside every sector edge.
        let mut rng = crate::testing::Xorshift::new(0x9e37_79b9_7f4a_7c15);
        let mut next = || rng.next_f64();
        for nd in [1, 2, 3, 4, 5, 6, 8, 12, 16, 17] {
            let dir = |j: usize| direction(j, nd);
            let mut points = Vec::new();
            for _ in 0..2000 {
                let (a, r) = (
                    std::f64::consts::TAU * next(),
                    10f64.powf(6.0 * next() - 3.0),
                );
                points.push([r * a.cos(), r * a.sin()]);
            }
            for j in 0..=nd {
                let (c, s) = dir(j);
                for eps in [0.0, 1e-15, -1e-15, 1e-10, -1e-10, 1e-8, -1e-8] {
                    points.push([c - eps * s, s + eps * c]);
                }
            }
            for p in points {
                assert_eq!(sector(p, nd, &dir), sector_by_angle(p, nd), "{p:?} nd {nd}");
            }
        }
    }

    #[test]
    fn polygon_projection_and_decomposition() {
        // Square cone (n_d = 4), cap 1: vertices (1,0), (0,1), (-1,0), (0,-1).
        assert_eq!(project_polygon([0.2, 0.1], 1.0, 4), [0.2, 0.1]);
        let p = project_polygon([2.0, 0.0], 1.0, 4);
        assert!((p[0] - 1.0).abs() < 1e-15 && p[1].abs() < 1e-15);
        let p = project_polygon([1.0, 1.0], 1.0, 4);
        assert!((p[0] - 0.5).abs() < 1e-15 && (p[1] - 0.5).abs() < 1e-15);
        assert_eq!(project_polygon([1.0, 1.0], 0.0, 4), [0.0, 0.0]);
        let mut out = [0.0; 4];
        decompose([0.5, 0.5], 4, &mut out);
        assert!((out[0] - 0.5).abs() < 1e-15 && (out[1] - 0.5).abs() < 1e-15 && out[2] == 0.0);
        decompose([0.0, -0.3], 4, &mut out);
        assert!((out[3] - 0.3).abs() < 1e-15 && out.iter().sum::<f64>() - 0.3 < 1e-15);
    }

    #[test]
    fn the_projection_is_the_nearest_point_of_every_edge() {
        // Against a search of every edge, at points around each polygon
        // (inside, beyond an edge, beyond a vertex). NOTE: a search of the
        // crossed edges only (where the nearest point lies) made a sweep
        // faster, but its rounding sent the reference scene's PGS run
        // (10,000 steps) from its near-singular step 5,031 into 1,000
        // steps at the sweep cap and relaxed, 11 times the sweeps: kept out.
        for nd in [3, 4, 5, 8, 16] {
            for k in 0..400 {
                let a = 0.173 * k as f64;
                let r = 0.004 * (k % 97) as f64;
                let x = [r * a.cos(), r * a.sin()];
                let cap = 0.2;
                let mut best = (f64::INFINITY, [0.0; 2]);
                for j in 0..nd {
                    let (c0, s0) = direction(j, nd);
                    let (c1, s1) = direction(j + 1, nd);
                    let (p0, e) = ([cap * c0, cap * s0], [cap * (c1 - c0), cap * (s1 - s0)]);
                    let t = (((x[0] - p0[0]) * e[0] + (x[1] - p0[1]) * e[1])
                        / (e[0] * e[0] + e[1] * e[1]))
                        .clamp(0.0, 1.0);
                    let q = [p0[0] + t * e[0], p0[1] + t * e[1]];
                    let d = (q[0] - x[0]).hypot(q[1] - x[1]);
                    if d < best.0 {
                        best = (d, q);
                    }
                }
                let inside = (0..nd).all(|j| {
                    let (c, s) = edge_normal(j, nd);
                    c * x[0] + s * x[1] <= cap * (std::f64::consts::PI / nd as f64).cos()
                });
                let want = if inside { x } else { best.1 };
                let got = project_polygon(x, cap, nd);
                assert!(
                    (got[0] - want[0]).abs() < 1e-15 && (got[1] - want[1]).abs() < 1e-15,
                    "n_d {nd}, x {x:?}: {got:?} against {want:?}"
                );
            }
        }
    }

    #[test]
    fn the_tables_give_the_bits_of_the_formulas() {
        let mut poly = Polygon::default();
        for nd in [3, 4, 5, 8, 16] {
            poly.set(nd);
            for k in 0..200 {
                let a = 0.37 * k as f64;
                let r = 0.01 * (k % 23) as f64;
                let x = [r * a.cos(), r * a.sin()];
                for cap in [0.0, 0.05, 0.1, 0.3] {
                    assert_eq!(poly.project(x, cap), project_polygon(x, cap, nd));
                }
                let (mut u, mut v) = (vec![0.0; nd], vec![0.0; nd]);
                poly.decompose(x, &mut u);
                decompose(x, nd, &mut v);
                assert_eq!(u, v);
                assert_eq!(poly.tangential(&u), tangential(&u));
            }
        }
    }
}
