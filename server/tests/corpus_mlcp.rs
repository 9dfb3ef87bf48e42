//! The Siconos mixed-LCP corpus (`../shared/data/mlcp/siconos`, read in
//! place): every problem ends in a typed outcome, never an unverified
//! answer: solved with a verified residual, its singular or ill-conditioned
//! equality block reported, or Lemke's failure reported. The outcomes are
//! printed. deltasigma_mlcp (156 complementarity rows, an indefinite reduced
//! matrix with entries from 1 to 2.5e4) is the hard one: it needs Lemke's
//! clamp of negative round-off in the basic values (rule 4 in lemke.rs).

use cosim_server::corpus::{read_mlcp, solve_mlcp, solve_mlcp_with, LcpSolver, MlcpOutcome};
use cosim_server::engine::solver::PgsParams;
use std::path::PathBuf;

#[test]
fn every_mlcp_is_solved_or_its_singular_block_reported() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/mlcp/siconos");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .expect("corpus")
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    assert_eq!(names.len(), 18);
    let (mut solved, mut singular, mut failed) = (0, 0, 0);
    for path in names {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let text = std::fs::read_to_string(&path).unwrap();
        let p = match read_mlcp(&text) {
            Ok(p) => p,
            // A rectangular MLCP (3 rows, 2 unknowns) is outside the
            // formulation; it must be refused clearly, not misread.
            Err(e) if name == "Rectangular_mlcp.dat" => {
                assert!(e.to_string().contains("rectangular"), "{e}");
                eprintln!("{name}: refused: {e}");
                continue;
            }
            Err(e) => panic!("{name}: {e}"),
        };
        match solve_mlcp(&p) {
            MlcpOutcome::Solved {
                pivots,
                residual,
                u,
                v,
                pivot_ratio,
            } => {
                eprintln!("{name}: solved, {pivots} pivots, residual {residual:.1e}, pivot ratio of A {pivot_ratio:.1e}");
                assert!(residual <= 1e-6, "{name}: residual {residual}");
                assert!(u.iter().chain(&v).all(|x| x.is_finite()) && v.iter().all(|x| *x >= 0.0));
                solved += 1;
            }
            MlcpOutcome::SingularEquality { ratio } => {
                eprintln!(
                    "{name}: equality block singular or ill-conditioned (pivot ratio {ratio:.1e})"
                );
                singular += 1;
            }
            MlcpOutcome::Failed {
                failure,
                pivot_ratio,
            } => {
                eprintln!(
                    "{name}: NOT SOLVED: {} (pivot ratio of A {pivot_ratio:.1e})",
                    failure.message
                );
                failed += 1;
            }
        }
    }
    eprintln!("{solved} solved, {singular} singular, {failed} failed");
    assert_eq!((solved, failed), (10, 0), "every regular problem solved");
    // The singular circuits are the ones the data README names.
    assert_eq!(
        singular,
        4 + 3,
        "PD, the three diodeBridges and the three Buck problems"
    );
}

/// The same problems with PGS on the reduced LCP (tolerance 1e-10, cap
/// 20,000 sweeps): a verified answer or `not_converged` with its residual.
/// It solves deltasigma too, an independent check of Lemke's answer there;
/// relay2's reduced matrix has a zero diagonal entry, which PGS cannot step.
#[test]
fn pgs_on_the_reduced_mlcps_is_verified_or_reports_no_convergence() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/mlcp/siconos");
    let params = PgsParams {
        tolerance: 1e-10,
        max_iterations: 20_000,
        ..PgsParams::default()
    };
    let mut solved = Vec::new();
    for name in [
        "deltasigma_mlcp.dat",
        "deltasigma2_mlcp.dat",
        "PDSym_mlcp.dat",
        "RCD_mlcp.dat",
        "relay2_mlcp.dat",
    ] {
        let p = read_mlcp(&std::fs::read_to_string(dir.join(name)).unwrap()).unwrap();
        match solve_mlcp_with(&p, LcpSolver::Pgs(params)) {
            MlcpOutcome::Solved {
                residual,
                pivots,
                v,
                ..
            } => {
                eprintln!("{name}: pgs solved in {pivots} sweeps, residual {residual:.1e}");
                assert!(residual <= 1e-6 && v.iter().all(|x| *x >= 0.0), "{name}");
                solved.push(name);
            }
            MlcpOutcome::Failed { failure, .. } => {
                let (iterations, residual) = (failure.work, failure.residual.unwrap_or(0.0));
                eprintln!("{name}: pgs not converged after {iterations}, residual {residual:.1e}");
                assert_eq!(failure.status, "not_converged", "{name}");
                assert!(iterations == 20_000 && residual > 1e-10, "{name}");
            }
            other => panic!("{name}: {other:?}"),
        }
    }
    assert_eq!(solved.len(), 4, "{solved:?}");
}
