//! 3-D frictional-contact problems of the Siconos corpus
//! (`../shared/data/fc/siconos`, read in place), solved by projected
//! Gauss-Seidel on the circular cone. The residual is the natural-map
//! Coulomb residual (De Saxce) divided by `max(||q||, 1)`.

use cosim_server::corpus::{read_fc3d, solve_fc3d};
use std::path::PathBuf;
use std::time::Instant;

/// Iteration budget: 20,000 sweeps.
const BUDGET: usize = 20_000;

#[test]
fn fc3d_problems_reach_1e_minus_6() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/fc/siconos");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .expect("corpus")
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| {
            n.starts_with("FC3D_Example1.")
                || n.starts_with("FrictionContact3D_1c")
                || n.starts_with("Capsules")
                || n.starts_with("NESpheres")
        })
        .collect();
    names.sort();
    assert_eq!(names.len(), 9);
    let mut failed = Vec::new();
    for name in &names {
        let text = std::fs::read_to_string(dir.join(name)).unwrap();
        let p = read_fc3d(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
        let t0 = Instant::now();
        let out = solve_fc3d(&p, 1e-6, BUDGET);
        eprintln!(
            "{name}: {} contacts, {} iterations, residual {:.2e}, {:.3} s{}",
            p.nc,
            out.iterations,
            out.residual,
            t0.elapsed().as_secs_f64(),
            if out.converged { "" } else { "  NOT CONVERGED" }
        );
        assert!(out.r.iter().all(|x| x.is_finite()));
        if !out.converged {
            failed.push(name.clone());
        }
    }
    assert!(
        failed.is_empty(),
        "not converged within {BUDGET} sweeps: {failed:?}"
    );
}
