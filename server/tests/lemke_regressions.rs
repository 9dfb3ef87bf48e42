//! LCPs on which Lemke once failed, taken from the engine's own steps
//! (`tests/data/`; `#` lines are comments, then `n`, `M` row by row, `q`).

use cosim_server::engine::solver::{relative_residual, Lcp, Lemke, LemkeError, Rung, SolveInfo};

fn read(name: &str) -> (usize, Vec<f64>, Vec<f64>) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    let text = std::fs::read_to_string(&path).expect("fixture");
    let mut numbers = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .flat_map(str::split_whitespace)
        .map(|x| x.parse::<f64>().expect("number"));
    let n = numbers.next().expect("n") as usize;
    let m: Vec<f64> = numbers.by_ref().take(n * n).collect();
    let q: Vec<f64> = numbers.take(n).collect();
    assert_eq!((m.len(), q.len()), (n * n, n));
    (n, m, q)
}

fn solve(name: &str) -> (SolveInfo, f64) {
    let (n, m, q) = read(name);
    let lcp = Lcp { n, m: &m, q: &q };
    let mut z = vec![0.0; n];
    let info = Lemke::new()
        .solve(&lcp, &mut z)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    assert!(z.iter().all(|x| *x >= 0.0));
    (info, relative_residual(&lcp, &z))
}

/// Two rows equal but for 1e-16 in their right-hand side, one of them z0's:
/// z0 must leave, exactly, without regularisation.
#[test]
fn z0_leaves_when_it_ties_with_a_degenerate_twin() {
    let (info, residual) = solve("lcp_z0_tie_twin.txt");
    assert!(!info.regularized(), "needed the regularised retry");
    assert!(residual < 1e-12, "residual {residual}");
}

/// A closed loop of joints and contacts: the first rung ends on round-off,
/// a later one solves it (a tighter pivot tolerance to the rigid
/// residual, or the regularised rung to the order of its shift) and says
/// which.
#[test]
fn closed_loop_of_joints_and_contacts_is_solved_by_a_later_rung() {
    let (info, residual) = solve("lcp_closed_loop.txt");
    assert_ne!(info.rung, Rung::Pivoted(0), "{info:?}");
    let limit = if info.regularized() { 1e-6 } else { 1e-8 };
    assert!(
        residual <= limit && residual == info.residual,
        "residual {residual} ({info:?})"
    );
}

/// The LCP of the reference scene's step 154,952 with Lemke alone
/// (`run --steps 160000 --solver lemke` wrote it as failed_lcp.dat): n = 20,
/// numerical rank 8, condition 2.2e19. The first rung's pivot tolerance
/// (1e-9 of the column) rejects the right pivot, 1.18e-7, at pivot 21 and
/// the path ends on a ray; the tighter rung solves it. Exact rational
/// Lemke gives normal impulses 5.5935 N s (lower/floor) and 13.3821 N s
/// (upper/lower), the same in all 34 feasible complementary bases; the
/// support's system `M_SS z_S = -q_S` solved in exact rationals (Python's
/// `fractions`, from the file's f64 values) gives 5.593511857113 and
/// 13.382136639171, which the answer must match to 1e-6 relative (the
/// problem's condition, 2.2e19, leaves no more digits to the data).
#[test]
fn reference_step_154952_is_solved_by_a_tighter_pivot_tolerance() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/reference_step_154952_lcp.dat");
    let text = std::fs::read_to_string(&path).expect("fixture");
    let p = cosim_server::corpus::read_lcp(&text).expect("Siconos dense LCP");
    let n = p.q.len();
    let lcp = Lcp {
        n,
        m: &p.m.data,
        q: &p.q,
    };
    let mut z = vec![0.0; n];
    let first = Lemke::new().solve_plain(&lcp, &mut z).unwrap_err();
    assert!(
        matches!(first, LemkeError::RayTermination { .. }),
        "the first rung alone: {first}"
    );
    let info = Lemke::new()
        .solve(&lcp, &mut z)
        .expect("the ladder solves it");
    assert!(matches!(info.rung, Rung::Pivoted(k) if k > 0), "{info:?}");
    let residual = relative_residual(&lcp, &z);
    assert!(residual <= 1e-12, "residual {residual:e}");
    assert!(z.iter().all(|x| *x >= 0.0));
    for (got, exact, what) in [
        (z[0], 5.593511857113, "lower/floor"),
        (z[1], 13.382136639171, "upper/lower"),
    ] {
        assert!(
            (got - exact).abs() <= 1e-6 * exact,
            "{what}: {got} against {exact}"
        );
    }
}
