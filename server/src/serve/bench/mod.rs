//! `cosim-server bench ipc`: what lockstep costs, measured in one run.
//!
//! - the limit: a raw iceoryx2 ping-pong of a state frame and an input
//!   frame between two processes (spinning, and blocking on events);
//! - lockstep steps per second on the reference scene with 1, 2 and 4
//!   controller processes in spin, block and hybrid waiting;
//! - a monitor's cost, from windows of one run with it attached and
//!   detached ([`monitor_windows`]), the same for the live view (`cosim
//!   view` serving a Foxglove client), and a recorder process reading
//!   every frame;
//! - the baseline: the same lockstep over a TCP loopback socket, what a
//!   socket-based (gRPC-style) co-simulation pays at the least.
//!
//! Controllers and peers are this program started again with the hidden
//! `bench-peer` subcommand, so every figure crosses a process boundary.

use super::{epoch_seconds, serve, ServeOptions};
use crate::engine::{Engine, Model};
use cosim_client::{Controller, InputFrame, Monitor, WaitMode};
use cosim_shared::wire::{send_words, InputHeader, StateFrame, StateHeader, WordSink};
use iceoryx2::prelude::*;
use std::io::{Read, Write};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

mod lockstep;
mod peers;
mod pingpong;

use lockstep::*;
pub(crate) use peers::run_peer;
use peers::*;
use pingpong::*;

type BoxError = Box<dyn std::error::Error>;

/// Runs every measurement and prints the table (Markdown).
pub fn run(steps: u64, quick: bool) -> Result<String, BoxError> {
    let mut out = String::new();
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    let pinned = pin_self(cores);
    out.push_str(&format!(
        "cosim-server bench ipc: reference scene, {steps} steps per lockstep row, {cores} cores{}\n\n",
        if pinned {
            "; server on core 0, a single controller or peer on core 1, several controllers and the monitor anywhere (taskset)"
        } else {
            "; not pinned"
        }
    ));
    out.push_str("| measurement | steps/s | round trip median (us) | step compute median / mean (us) | overhead per step (us) |\n|---|---|---|---|---|\n");
    let mut raw_spin = f64::NAN;
    for mode in [WaitMode::Spin, WaitMode::Block] {
        if quick && mode == WaitMode::Block {
            continue;
        }
        let rt = raw_pingpong(
            mode,
            if mode == WaitMode::Spin {
                20_000
            } else {
                5_000
            },
        )?;
        if mode == WaitMode::Spin {
            raw_spin = rt;
        }
        out.push_str(&format!(
            "| raw iceoryx2 ping-pong, {} | {:.0} | {rt:.2} | - | {rt:.2} |\n",
            mode.as_str(),
            1e6 / rt
        ));
    }
    let (tcp, tcp_rt, tcp_over, _) = tcp_lockstep(steps)?;
    out.push_str(&format!(
        "| lockstep over TCP loopback, 1 controller | {tcp:.0} | {tcp_rt:.2} | - | {tcp_over:.2} |\n"
    ));
    let mut rows = Vec::new();
    for n in [1usize, 2, 4] {
        for mode in [WaitMode::Spin, WaitMode::Block, WaitMode::Hybrid] {
            if quick && (n > 1 || mode == WaitMode::Block) {
                continue;
            }
            // Oversubscribed spinning is slow by design: fewer steps.
            let s = if mode == WaitMode::Spin && n + 1 > cores {
                steps / 10
            } else {
                steps
            };
            let r = lockstep(n, mode, s.max(100), None)?;
            out.push_str(&r.row(&format!(
                "{n} controller{}, {}",
                if n > 1 { "s" } else { "" },
                mode.as_str()
            )));
            rows.push((n, mode, r));
        }
    }
    // One controller on the server's own core (issue 47, point 3): the
    // case where spinning holds the core the other process needs.
    if pinned && !quick {
        for mode in [WaitMode::Spin, WaitMode::Block, WaitMode::Hybrid] {
            let s = if mode == WaitMode::Spin {
                steps / 10
            } else {
                steps
            };
            let r = lockstep_on(Client::Rust, 1, mode, s.max(100), None, Some("0"))?;
            out.push_str(&r.row(&format!(
                "1 controller on the server's core, {}",
                mode.as_str()
            )));
        }
    }
    // The Python package's controller (issue 16, point 9), where python3
    // has it: the same loop, answered from Python.
    if python_package() {
        for mode in [WaitMode::Spin, WaitMode::Block] {
            if quick && mode == WaitMode::Block {
                continue;
            }
            let r = lockstep_of(Client::Python, 1, mode, steps, None)?;
            out.push_str(&r.row(&format!(
                "1 Python controller (cosim package), {}",
                mode.as_str()
            )));
        }
    } else {
        out.push_str("| lockstep, 1 Python controller | skipped: python3 does not import the cosim package (pip install ./python) | - | - | - |\n");
    }
    let spin1 = rows
        .iter()
        .find(|(n, m, _)| *n == 1 && *m == WaitMode::Spin)
        .map(|r| r.2.steps_per_s)
        .unwrap_or(f64::NAN);
    let phases = rows
        .iter()
        .filter(|(n, _, _)| *n == 1)
        .map(|(_, mode, r)| {
            let p = r.phases;
            format!(
                "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |\n",
                mode.as_str(),
                p[0],
                p[1],
                p[2],
                p[3],
                p[4],
                p[5],
                1e6 / r.steps_per_s
            )
        })
        .collect::<String>();
    // The TCP baseline's blocking wake-ups vary with how idle the cores
    // are (2,700 to 8,800 steps/s across runs here): the ratio is taken
    // from medians of three alternating runs of each.
    let (mut spins, mut tcps) = (Vec::new(), Vec::new());
    let (mut spin_steps, mut tcp_steps) = (Vec::new(), Vec::new());
    for _ in 0..3 {
        let l = lockstep(1, WaitMode::Spin, steps, None)?;
        spins.push(l.steps_per_s);
        spin_steps.push(l.median_step_us);
        let t = tcp_lockstep(steps)?;
        tcps.push(t.0);
        tcp_steps.push(t.3);
    }
    let (spin_med, tcp_med) = (median(&mut spins), median(&mut tcps));
    // The median step of each run, robust to a run's preemptions.
    let (spin_step, tcp_step) = (median(&mut spin_steps), median(&mut tcp_steps));
    let overheads = rows
        .iter()
        .find(|(n, m, _)| *n == 1 && *m == WaitMode::Spin)
        .map(|(_, _, r)| {
            format!(
                "spin, 1 controller: round trip minus the step compute it overlaps (prepare) \
                 {:.2} us = {:.1}x the raw ping-pong ({raw_spin:.2} us); wall time per step minus \
                 prepare and finish {:.2} us = {:.1}x\n",
                r.round_trip_us - r.phases[1],
                (r.round_trip_us - r.phases[1]) / raw_spin,
                r.overhead_us,
                r.overhead_us / raw_spin
            )
        })
        .unwrap_or_default();
    let footer = format!(
        "\nspin, 1 controller, against TCP: {:.1}x the steps per second in the rows above; \
         medians of 3 alternating runs: {spin_med:.0} against {tcp_med:.0} steps/s, {:.1}x; \
         median step {spin_step:.2} us against {tcp_step:.2} us, {:.1}x\n\
         {overheads}\n\
         Where a step's wall time goes, 1 controller (means, us): control requests at the \
         step boundary, `Engine::prepare` (overlapped with the controller), waiting for the \
         input after it, `Engine::finish`, the inputs and outputs around it, publishing.\n\n\
         | wait | boundary | prepare | wait for input | finish | around finish | publish | wall per step |\n\
         |---|---|---|---|---|---|---|---|\n{phases}",
        spin1 / tcp,
        spin_med / tcp_med,
        tcp_step / spin_step
    );
    if quick {
        out.push_str(&footer);
        return Ok(out);
    }
    // The monitor's cost is a few percent at most, below this machine's
    // noise between two runs: measured inside one run of 50 times the
    // steps (see `monitor_windows`).
    // The live view (issue 16, point 8) in the spinning loop alone, the
    // one a monitor could slow most.
    let toggles = [
        (
            WaitMode::Spin,
            "monitor-toggle",
            "a monitor process (cosim monitor, newest frame at 10 Hz)",
        ),
        (
            WaitMode::Hybrid,
            "monitor-toggle",
            "a monitor process (cosim monitor, newest frame at 10 Hz)",
        ),
        (
            WaitMode::Spin,
            "view-toggle",
            "a view process (cosim view --rate 30, a Foxglove client subscribed to every channel)",
        ),
    ];
    for (mode, role, what) in toggles {
        let (mut rate, mut step) = monitor_windows(mode, 50 * steps, role)?;
        let pct = |v: &mut Vec<f64>| {
            if v.is_empty() {
                return "no windows".to_string();
            }
            v.sort_by(f64::total_cmp);
            let q = |p: f64| (v[((v.len() - 1) as f64 * p).round() as usize] - 1.0) * 100.0;
            format!(
                "{:+.1} % (quartiles {:+.1} / {:+.1} %)",
                q(0.5),
                q(0.25),
                q(0.75)
            )
        };
        out.push_str(&format!(
            "| lockstep, 1 controller, {}: {what} attached against detached, alternate {WINDOW} s windows of one run, median ratio over {} pairs of windows | steps/s {}; median step {} | - | - | - |\n",
            mode.as_str(),
            rate.len(),
            pct(&mut rate),
            pct(&mut step),
        ));
    }
    for mode in [WaitMode::Spin, WaitMode::Hybrid] {
        let r = lockstep(1, mode, steps, Some("recorder"))?;
        out.push_str(&r.row(&format!(
            "1 controller, {}, + recorder process (every frame, woken for each)",
            mode.as_str()
        )));
    }
    out.push_str(&footer);
    Ok(out)
}
