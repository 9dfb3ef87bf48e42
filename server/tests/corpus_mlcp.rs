//! The Siconos mixed-LCP corpus (`../shared/data/mlcp/siconos`, read in
//! place): every problem ends in a typed outcome, never an unverified
//! answer: solved with a verified residual, its singular or ill-conditioned
//! equality block reported, or Lemke's failure reported. The outcomes are
//! printed; at this writing deltasigma_mlcp (156 complementarity rows, an
//! indefinite reduced matrix with entries from 1 to 2.5e4) ends in a
//! numerical breakdown (residual 2e-6), the one problem not yet solved.

use cosim_server::corpus::{read_mlcp, solve_mlcp, MlcpOutcome};
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
            MlcpOutcome::Lemke { error, pivot_ratio } => {
                eprintln!("{name}: NOT SOLVED: {error} (pivot ratio of A {pivot_ratio:.1e})");
                failed += 1;
            }
        }
    }
    eprintln!("{solved} solved, {singular} singular, {failed} failed");
    assert_eq!(solved + singular + failed, 17);
    // The singular circuits are the ones the data README names.
    assert_eq!(
        singular,
        4 + 3,
        "PD, the three diodeBridges and the three Buck problems"
    );
}
