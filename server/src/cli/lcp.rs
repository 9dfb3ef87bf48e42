//! `cosim-server lcp FILE`: solve a Siconos LCP or mixed LCP file.

use super::{LcpArgs, EXIT_BAD_INPUT, EXIT_FAILED};
use crate::corpus::{read_lcp, read_mlcp, solve_lcp, solve_mlcp_with, LcpSolver, MlcpOutcome};
use crate::engine::solver::{Lcp, PgsParams};
use serde_json::json;
use std::process::ExitCode;

pub fn lcp(args: &LcpArgs) -> ExitCode {
    let file = args.file.display().to_string();
    let text = match std::fs::read_to_string(&args.file) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {file}: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let (solver, name, work) = match args.solver.as_str() {
        "lemke" => (LcpSolver::LemkeLadder, "lemke", "pivots"),
        "lemke-plain" => (LcpSolver::Lemke, "lemke-plain", "pivots"),
        "pgs" => (
            LcpSolver::Pgs(PgsParams {
                tolerance: args.tolerance,
                max_iterations: args.max_iterations,
                ..PgsParams::default()
            }),
            "pgs",
            "iterations",
        ),
        other => {
            eprintln!(
                "error: --solver: unknown solver {other:?} (expected lemke, lemke-plain or pgs)"
            );
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    // An MLCP file starts with its two storage flags; the name tells which
    // reader applies.
    let mixed = file.ends_with("_mlcp.dat");
    let report = if mixed {
        let p = match read_mlcp(&text) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("error: {file}: {e}");
                return ExitCode::from(EXIT_BAD_INPUT);
            }
        };
        match solve_mlcp_with(&p, solver) {
            MlcpOutcome::Solved {
                u,
                v,
                pivots,
                residual,
                ..
            } => {
                json!({"file": file, "status": "solved", "solver": name, work: pivots, "residual": residual, "u": u, "z": v})
            }
            MlcpOutcome::SingularEquality { ratio } => {
                json!({"file": file, "status": "singular", "solver": name, "pivot_ratio": if ratio.is_finite() { json!(ratio) } else { json!("inf") }})
            }
            MlcpOutcome::Failed { failure: f, .. } => {
                json!({"file": file, "status": f.status, "solver": name, work: f.work, "residual": f.residual, "message": f.message})
            }
        }
    } else {
        let p = match read_lcp(&text) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("error: {file}: {e}");
                return ExitCode::from(EXIT_BAD_INPUT);
            }
        };
        let n = p.q.len();
        let mut z = vec![0.0; n];
        let lcp = Lcp {
            n,
            m: &p.m.data,
            q: &p.q,
        };
        match solve_lcp(solver, &lcp, &mut z) {
            Ok((count, residual)) => {
                json!({"file": file, "status": "solved", "solver": name, work: count, "residual": residual, "z": z})
            }
            Err(f) => {
                json!({"file": file, "status": f.status, "solver": name, work: f.work, "residual": f.residual, "message": f.message})
            }
        }
    };
    let solved = report["status"] == "solved";
    if args.json {
        println!("{report}");
    } else {
        println!("{file}: {}", report["status"].as_str().unwrap_or("?"));
        for key in ["pivots", "iterations", "residual", "pivot_ratio", "message"] {
            if let Some(v) = report.get(key) {
                println!("  {key}: {v}");
            }
        }
        if let Some(z) = report.get("z") {
            println!("  z: {z}");
        }
    }
    if solved {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FAILED)
    }
}

/// `cosim-server fc3d FILE`: projected Gauss-Seidel on the circular cone.
pub fn fc3d(args: &super::Fc3dArgs) -> ExitCode {
    use crate::corpus::{read_fc3d, solve_fc3d};
    let file = args.file.display().to_string();
    let p = match std::fs::read_to_string(&args.file)
        .map_err(|e| e.to_string())
        .and_then(|t| read_fc3d(&t).map_err(|e| e.to_string()))
    {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {file}: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let t0 = std::time::Instant::now();
    let out = solve_fc3d(&p, args.tolerance, args.max_iterations);
    let seconds = t0.elapsed().as_secs_f64();
    let report = json!({
        "file": file,
        "status": if out.converged { "solved" } else { "not_converged" },
        "solver": "pgs",
        "cone": "circular",
        "contacts": p.nc,
        "iterations": out.iterations,
        "residual": out.residual,
        "residual_normalisation": "natural map with De Saxce's change of variable, divided by max(||q||, 1)",
        "seconds": seconds,
        "r": out.r,
    });
    if args.json {
        println!("{report}");
    } else {
        println!(
            "{file}: {} after {} iterations, residual {:.2e} (natural map, / max(||q||, 1)), {} contacts, {:.3} s",
            report["status"].as_str().unwrap_or("?"),
            out.iterations,
            out.residual,
            p.nc,
            seconds
        );
    }
    if out.converged {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FAILED)
    }
}
