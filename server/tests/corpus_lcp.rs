//! The Siconos LCP corpus (`../shared/data/lcp/siconos`, read in place):
//! every problem gives the outcome of the data README's table.

use cosim_server::corpus::{read_lcp, solve_lcp, LcpProblem, LcpSolver};
use cosim_server::engine::solver::{
    relative_residual, Lcp, Lemke, LemkeError, PgsParams, SolveInfo,
};
use std::path::PathBuf;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/lcp/siconos")
        .join(name)
}

fn load(name: &str) -> LcpProblem {
    let text = std::fs::read_to_string(data(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    read_lcp(&text).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Every problem file of the corpus, sorted.
fn corpus_names() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(data(""))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn check_lcp(name: &str) -> Result<(SolveInfo, Vec<f64>), LemkeError> {
    let p = load(name);
    let n = p.q.len();
    let lcp = Lcp {
        n,
        m: &p.m.data,
        q: &p.q,
    };
    let mut z = vec![0.0; n];
    let info = Lemke::new().solve_plain(&lcp, &mut z)?;
    // The data README's criterion, recomputed here from M and q.
    assert!(relative_residual(&lcp, &z) <= 1e-6, "{name}: residual");
    assert!(z.iter().all(|x| x.is_finite() && *x >= 0.0));
    Ok((info, z))
}

#[test]
fn block_stored_twins_decode_to_the_same_matrix() {
    for (dense, block) in [
        ("lcp_ortiz.dat", "lcp_ortiz_block.dat"),
        ("lcp_trivial.dat", "lcp_trivial_block.dat"),
        ("lcp_deudeu.dat", "lcp_deudeu_block.dat"),
    ] {
        assert_eq!(load(dense), load(block), "{dense} vs {block}");
    }
}

#[test]
fn every_lcp_gives_the_expected_outcome() {
    let solvable = [
        "lcp_CPS_1.dat",
        "lcp_CPS_2.dat",
        "lcp_CPS_4.dat",
        "lcp_CPS_4bis.dat",
        "lcp_CPS_5.dat",
        "lcp_Pang_isolated_sol.dat",
        "lcp_deudeu.dat",
        "lcp_deudeu_block.dat",
        "lcp_ortiz.dat",
        "lcp_ortiz_block.dat",
        "lcp_trivial.dat",
        "lcp_trivial_block.dat",
        "lcp_enum_fails.dat",
        "lcp_exp_murty.dat",
        "lcp_exp_murty2.dat",
        "lcp_inf_sol_perturbed.dat",
        "lcp_mmc.dat",
        "lcp_tobenna.dat",
    ];
    for name in solvable {
        let (info, _) = check_lcp(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        eprintln!(
            "{name}: solved in {} pivots, residual {:.1e}",
            info.work, info.residual
        );
        match name {
            "lcp_exp_murty.dat" => assert_eq!(info.work, 2, "{name}"),
            "lcp_exp_murty2.dat" => assert_eq!(info.work, 64, "{name}"),
            _ => {}
        }
    }
    for name in ["lcp_CPS_3.dat", "lcp_Pang_isolated_sol_perturbed.dat"] {
        match check_lcp(name) {
            Err(LemkeError::RayTermination { pivots, .. }) => {
                eprintln!("{name}: ray termination after {pivots} pivots")
            }
            other => panic!("{name}: expected ray termination, got {other:?}"),
        }
    }
    // CPS_3 ends on a ray at the first pivot.
    assert!(matches!(
        check_lcp("lcp_CPS_3.dat"),
        Err(LemkeError::RayTermination { pivots: 1, .. })
    ));
}

#[test]
fn lcp_command_prints_the_outcome_as_json() {
    let bin = env!("CARGO_BIN_EXE_cosim-server");
    for (name, status, code) in [
        ("lcp_exp_murty2.dat", "solved", 0),
        ("lcp_Pang_isolated_sol_perturbed.dat", "ray_termination", 1),
    ] {
        let out = std::process::Command::new(bin)
            .arg("lcp")
            .arg(data(name))
            .arg("--json")
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(code), "{name}");
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
        assert_eq!(v["status"], status, "{name}");
        assert_eq!(v["solver"], "lemke");
        assert!(v["pivots"].is_u64());
        if status == "solved" {
            assert_eq!(v["pivots"], 64);
            assert_eq!(v["z"].as_array().map(Vec::len), Some(6));
        }
    }
}

/// PGS on the same corpus: it converges where `M` is symmetric positive
/// semi-definite with a positive diagonal (coordinate descent on a convex
/// quadratic) and says `not_converged` with its residual elsewhere; it never
/// calls an unverified answer solved. Tolerance 1e-10, cap 20,000 sweeps.
#[test]
fn pgs_solves_the_symmetric_psd_problems_and_reports_the_rest() {
    let params = PgsParams {
        tolerance: 1e-10,
        max_iterations: 20_000,
        ..PgsParams::default()
    };
    let names = corpus_names();
    assert_eq!(names.len(), 20);
    let mut solved = Vec::new();
    for name in &names {
        let p = load(name);
        let n = p.q.len();
        let lcp = Lcp {
            n,
            m: &p.m.data,
            q: &p.q,
        };
        let symmetric_pos_diag = (0..n).all(|i| {
            p.m.data[i * n + i] > 0.0
                && (0..n).all(|j| {
                    (p.m.data[i * n + j] - p.m.data[j * n + i]).abs()
                        <= 1e-12 * p.m.data[i * n + j].abs().max(1.0)
                })
        });
        let mut z = vec![0.0; n];
        match solve_lcp(LcpSolver::Pgs(params), &lcp, &mut z) {
            Ok((sweeps, residual)) => {
                eprintln!("{name}: pgs solved in {sweeps} sweeps, residual {residual:.1e}");
                assert!(relative_residual(&lcp, &z) <= 1e-10, "{name}");
                assert!(z.iter().all(|x| x.is_finite() && *x >= 0.0), "{name}");
                solved.push(name.as_str());
            }
            Err(f) => {
                eprintln!("{name}: pgs {} ({})", f.status, f.message);
                assert_eq!(f.status, "not_converged", "{name}");
                assert_eq!(f.work, 20_000, "{name}");
                assert!(f.residual.is_some_and(|r| r > 1e-10), "{name}");
                // Where PGS is guaranteed to converge, it must.
                assert!(
                    !symmetric_pos_diag,
                    "{name}: symmetric, positive diagonal, not solved"
                );
            }
        }
    }
    // The unsolvable one stays unsolved by PGS too.
    assert!(!solved.contains(&"lcp_Pang_isolated_sol_perturbed.dat"));
    assert!(solved.len() >= 10, "{solved:?}");
}

#[test]
fn lcp_command_takes_the_pgs_solver() {
    let bin = env!("CARGO_BIN_EXE_cosim-server");
    for (name, status, code) in [
        ("lcp_mmc.dat", "solved", 0),
        ("lcp_tobenna.dat", "not_converged", 1),
    ] {
        let out = std::process::Command::new(bin)
            .args([
                "lcp",
                "--solver",
                "pgs",
                "--max-iterations",
                "5000",
                "--json",
            ])
            .arg(data(name))
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(code), "{name}");
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
        assert_eq!(v["status"], status, "{name}");
        assert_eq!(v["solver"], "pgs");
        assert!(v["iterations"].is_u64() && v["residual"].is_f64(), "{v}");
    }
    let out = std::process::Command::new(bin)
        .args(["lcp", "--solver", "newton"])
        .arg(data("lcp_mmc.dat"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--solver"));
}

/// A failed step's LCP is written for `cosim-server lcp` (`run` does it):
/// writer and reader agree to the bit, on corpus problems (a block-stored
/// one too) and on LCPs of the reference scene's steps.
#[test]
fn written_lcps_read_back_to_the_bit() {
    use cosim_server::corpus::write_lcp;
    use cosim_server::engine::{Engine, Model};
    let mut problems: Vec<LcpProblem> = ["lcp_ortiz_block.dat", "lcp_tobenna.dat", "lcp_CPS_4.dat"]
        .iter()
        .map(|n| load(n))
        .collect();
    let scene = cosim_shared::scenes::reference().expect("built-in scene");
    let mut e = Engine::new(Model::from_scene(&scene));
    for _ in 0..1500 {
        e.step();
        if matches!(e.state().step, 300 | 700 | 1500) {
            let (n, m, q) = e.last_lcp();
            assert!(n > 0, "contacts at step {}", e.state().step);
            let text = write_lcp(n, m, q);
            problems.push(read_lcp(&text).expect("written LCP reads"));
            assert_eq!(
                (
                    problems.last().unwrap().m.data.as_slice(),
                    problems.last().unwrap().q.as_slice()
                ),
                (m, q)
            );
        }
    }
    for p in &problems {
        let n = p.q.len();
        let again = read_lcp(&write_lcp(n, &p.m.data, &p.q)).expect("reads");
        assert_eq!(&again, p);
    }
}

/// The engine's ladder (`Lemke::solve`: tighter pivot tolerances,
/// refinement, the regularised rung) on the same corpus changes no
/// outcome: every problem the single run solves it solves, with the same
/// pivots where the first rung holds, and the two infeasible ones still end
/// on a ray.
#[test]
fn the_ladder_keeps_every_corpus_outcome() {
    let names = corpus_names();
    for name in names {
        let p = load(&name);
        let n = p.q.len();
        let lcp = Lcp {
            n,
            m: &p.m.data,
            q: &p.q,
        };
        let mut z = vec![0.0; n];
        let plain = Lemke::new().solve_plain(&lcp, &mut z);
        let ladder = Lemke::new().solve(&lcp, &mut z);
        match (plain, ladder) {
            (Ok(a), Ok(b)) => {
                assert_eq!(a.work, b.work, "{name}: the first rung is the single run");
                assert!(relative_residual(&lcp, &z) <= 1e-8, "{name}");
            }
            (Err(LemkeError::RayTermination { .. }), Err(LemkeError::RayTermination { .. })) => {}
            (a, b) => panic!("{name}: single run {a:?}, ladder {b:?}"),
        }
    }
}
