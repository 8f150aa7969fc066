//! `wetcloth`: the command line of the wet-cloth simulator.
//!
//! Each subcommand lives in its own module; this file only parses the arguments, sets up what
//! every subcommand shares (the thread pool) and turns the outcome into an exit code:
//! 0 on success, 2 for bad input (arguments, scene files), 1 when a run fails (the simulation
//! blows up, or its outputs cannot be written).

mod error;
mod run;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Wet cloth that sticks: a simulator of wet cloth and the air trapped under it
/// (W. Yamada, 2012).
#[derive(Parser, Debug)]
#[command(name = "wetcloth", version)]
struct Cli {
    /// Worker threads for the simulation (default: all cores, or RAYON_NUM_THREADS). Results do
    /// not depend on it.
    #[arg(long, global = true, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=4096))]
    threads: Option<u32>,

    /// No progress bar and no summary; errors and warnings still go to stderr.
    #[arg(long, short, global = true)]
    quiet: bool,

    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a scene and write its frames (OBJ), metrics.csv, the resolved scene.toml and run.json.
    Run(run::RunArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Some(n) = cli.threads
        && let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n as usize)
            .build_global()
    {
        eprintln!("wetcloth: warning: cannot set up {n} threads: {e}");
    }
    let result = match &cli.command {
        Command::Run(args) => run::run(args, cli.quiet),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
