//! A controller for examples/scenes/push.toml in a process of its own: it
//! pushes the box to a target point on the floor by body impulses
//! (`cosim_client::push`: each step `m (v* - v)`, `v* = k (x* - x)`
//! clipped), and prints the box's last position.
//!
//! ```sh
//! cosim-server serve examples/scenes/push.toml --controllers 1 --name lab --duration 3 &
//! cargo run --release -p cosim-examples --bin push_controller -- --name lab --x 0.5 --y 0.2
//! ```

use cosim_examples::arg;
use std::process::ExitCode;
use std::time::Duration;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let name = arg(&args, "--name", "default");
    let parse = |flag, default| arg(&args, flag, default).parse::<f64>();
    let (Ok(x), Ok(y)) = (parse("--x", "0.5"), parse("--y", "0.2")) else {
        eprintln!("error: --x and --y take the target's coordinates in m");
        return ExitCode::from(2);
    };
    // The server may still be creating its services.
    let run = cosim_client::when_up(Duration::from_secs(30), || {
        cosim_client::push::run(&name, [x, y], Duration::from_secs(30))
    });
    match run {
        Ok(out) => {
            let [px, py, _] = out.position;
            println!("push: answered {} steps; x {px:?} m y {py:?} m", out.steps);
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: push controller: {e}");
            ExitCode::FAILURE
        }
    }
}
