//! LCPs on which Lemke once failed, taken from the engine's own steps
//! (`tests/data/`; `#` lines are comments, then `n`, `M` row by row, `q`).

use cosim_server::engine::solver::{relative_residual, Lcp, Lemke, SolveInfo};

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
    assert!(!info.regularized, "needed the regularised retry");
    assert!(residual < 1e-12, "residual {residual}");
}

/// A closed loop of joints and contacts: the regularised retry solves it
/// and says so, with a residual of the order of its shift.
#[test]
fn closed_loop_of_joints_and_contacts_is_solved_regularised() {
    let (info, residual) = solve("lcp_closed_loop.txt");
    assert!(info.regularized);
    assert!(
        residual <= 1e-6 && residual == info.residual,
        "residual {residual}"
    );
}
