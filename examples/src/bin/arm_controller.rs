//! A controller for examples/scenes/arm.toml in a process of its own: it
//! steers the shoulder and elbow to target angles by their velocity motors
//! (`cosim_client::arm`: `v* = k (q* - q)` clipped, sent as motor targets,
//! protocol 4), and prints the last angles it read.
//!
//! ```sh
//! cosim-server serve examples/scenes/arm.toml --controllers 1 --name lab --duration 3 &
//! cargo run --release -p cosim-examples --bin arm_controller -- --name lab
//! ```

use cosim_examples::arg;
use std::process::ExitCode;
use std::time::Duration;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let name = arg(&args, "--name", "default");
    let parse = |flag, default| arg(&args, flag, default).parse::<f64>();
    let (Ok(shoulder), Ok(elbow)) = (parse("--shoulder", "0.6"), parse("--elbow", "-1.0")) else {
        eprintln!("error: --shoulder and --elbow take angles in rad");
        return ExitCode::from(2);
    };
    // The server may still be creating its services.
    let run = cosim_client::when_up(Duration::from_secs(30), || {
        cosim_client::arm::run(&name, [shoulder, elbow], Duration::from_secs(30))
    });
    match run {
        Ok(out) => {
            let [s, e] = out.angles;
            println!(
                "arm: answered {} steps; shoulder {s:?} rad elbow {e:?} rad",
                out.steps
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: arm controller: {e}");
            ExitCode::FAILURE
        }
    }
}
