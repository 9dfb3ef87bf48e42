use clap::{Parser, Subcommand};
use cosim_link::session::Endpoints;
use std::io::Write;
use std::process::ExitCode;
use std::time::Duration;

/// Controllers on another host in lockstep with a cosim-server, over Zenoh.
///
/// On the server's host: `cosim-link export NAME` (it listens on
/// tcp/0.0.0.0:7447 unless told otherwise). On the controller's host:
/// `cosim-link import NAME --connect tcp/SERVER-HOST:7447`, then start the
/// controller there with `--name NAME` as if the server were local.
#[derive(Parser)]
#[command(name = "cosim-link", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Args, Clone)]
struct Net {
    /// Zenoh endpoints to listen on (repeat the flag for several).
    #[arg(long)]
    listen: Vec<String>,
    /// Zenoh endpoints to connect to, e.g. tcp/192.168.1.20:7447.
    #[arg(long)]
    connect: Vec<String>,
    /// Seconds to wait for the server (export) or the exporter (import).
    #[arg(long, default_value_t = 30.0)]
    patience: f64,
}

#[derive(Subcommand)]
enum Command {
    /// Beside the server: offer server NAME to importers.
    Export {
        name: String,
        #[command(flatten)]
        net: Net,
    },
    /// Beside the controllers: server NAME of an exporter, as if local.
    Import {
        name: String,
        #[command(flatten)]
        net: Net,
    },
    /// The remote lockstep's rate and round trip beside Zenoh's own round
    /// trip of the same sizes, one run (bench/results/remote.md).
    Bench {
        /// Steps of each lockstep run.
        #[arg(long, default_value_t = 20_000)]
        steps: u64,
        /// Write the table here as well as to stdout.
        #[arg(long)]
        out: Option<std::path::PathBuf>,
    },
    /// A peer process of `bench` (internal).
    #[command(hide = true)]
    BenchPeer { role: String, arg: String },
}

fn endpoints(net: &Net, default_listen: &[&str]) -> Endpoints {
    let listen = if net.listen.is_empty() {
        default_listen.iter().map(|s| s.to_string()).collect()
    } else {
        net.listen.clone()
    };
    Endpoints {
        listen,
        connect: net.connect.clone(),
    }
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "info,zenoh=warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    let result: Result<(), Box<dyn std::error::Error>> = match cli.command {
        Command::Export { name, net } => {
            let opts = cosim_link::export::ExportOptions {
                endpoints: endpoints(&net, &["tcp/0.0.0.0:7447"]),
                patience: Duration::from_secs_f64(net.patience),
                name: name.clone(),
            };
            cosim_link::export::export(&opts, |at| {
                // The first line on stdout: what an importer connects to
                // (a test or a script reads it).
                println!("listening {}", at.join(" "));
                println!(
                    "on the controller's host: cosim-link import {name} --connect {}",
                    at.first().map(String::as_str).unwrap_or("tcp/HOST:7447")
                );
                let _ = std::io::stdout().flush();
            })
            .map_err(Into::into)
        }
        Command::Import { name, net } => {
            let opts = cosim_link::mirror::ImportOptions {
                endpoints: endpoints(&net, &[]),
                patience: Duration::from_secs_f64(net.patience),
                name: name.clone(),
            };
            cosim_link::mirror::import(&opts, || {
                println!("ready: server '{name}' is here; run controllers with --name {name}");
                let _ = std::io::stdout().flush();
            })
            .map_err(Into::into)
        }
        Command::Bench { steps, out } => cosim_link::bench::run(steps)
            .and_then(|table| {
                print!("{table}");
                if let Some(path) = out {
                    std::fs::write(&path, &table)?;
                }
                Ok(())
            })
            .map_err(|e| -> Box<dyn std::error::Error> { e }),
        Command::BenchPeer { role, arg } => {
            cosim_link::bench::peer(&role, &arg).map_err(|e| -> Box<dyn std::error::Error> { e })
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("cosim-link: {e}");
            ExitCode::FAILURE
        }
    }
}
