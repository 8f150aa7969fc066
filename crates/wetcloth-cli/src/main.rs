//! `wetcloth`: the command line of the wet-cloth simulator.
//!
//! Each subcommand lives in its own module; this file only parses the arguments, sets up what
//! every subcommand shares (the thread pool) and turns the outcome into an exit code:
//! 0 on success, 2 for bad input (arguments, scene files, damaged run folders), 1 when a run fails (the simulation
//! blows up, or its outputs cannot be written).

mod bench;
mod checkpoint;
mod error;
mod estimate;
mod export;
mod interrupt;
mod pocket_labels;
mod render;
mod run;
mod sweep;
mod threads;
mod view;

use clap::{Parser, Subcommand};
use error::CliError;
use std::process::ExitCode;

/// Wet cloth that sticks: a simulator of wet cloth and the air trapped under it
/// (W. Yamada, 2012).
#[derive(Parser, Debug)]
#[command(name = "wetcloth", version)]
struct Cli {
    /// No progress bar and no summary; errors and warnings still go to stderr.
    #[arg(long, short, global = true)]
    quiet: bool,

    /// Worker threads for the simulation of `run` and `view`, and the thread count of `bench`
    /// (default: all cores, or RAYON_NUM_THREADS). Results do not depend on it.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=threads::MAX_THREADS as i64))]
    threads: Option<u32>,

    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a scene and write its frames (OBJ), metrics.csv, the resolved scene.toml and run.json.
    Run(run::RunArgs),
    /// Measure simulation speed on the thesis workload (table 4.2): steps/s, particle-steps/s
    /// and real-time factor per cloth size and thread count.
    Bench(bench::BenchArgs),
    /// Render a run's frames to PNG images (and an MP4 when ffmpeg is installed), with the
    /// viewer's renderer; needs a GPU or Mesa's software Vulkan (lavapipe).
    Render(wetcloth_render::RenderOptions),
    /// Plot a run's metrics.csv over time into RUN_DIR/metrics.png.
    Plot(render::PlotArgs),
    /// Write a run's frames as one animation cache (PC2, MDD, USD) and RUN_DIR/rest.obj, the
    /// mesh the point caches apply to.
    Export(export::ExportArgs),
    /// Open the interactive demo window: pull the wet cloth off the table with the mouse.
    View(view::ViewArgs),
    /// Run every combination of some scene keys' values on Dask (a local cluster, or a
    /// scheduler's) and write one CSV row per run; needs the `wetcloth` Python package.
    Sweep(sweep::SweepArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match dispatch(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

/// Sets up the thread pool for the commands that simulate, then runs the command.
fn dispatch(mut cli: Cli) -> Result<(), CliError> {
    let threads = cli.threads.map(|n| n as usize);
    match &mut cli.command {
        Command::Run(args) => {
            let n = match (threads, args.threads.map(|n| n as usize)) {
                (Some(a), Some(b)) if a != b => {
                    return Err(CliError::Usage(format!(
                        "--threads is given twice, as {a} and {b}: give it once"
                    )));
                }
                (a, b) => a.or(b),
            };
            threads::start_pool(n)?;
        }
        Command::View(_) => {
            threads::start_pool(threads)?;
        }
        Command::Bench(args) => {
            if let Some(n) = threads {
                args.threads.get_or_insert_with(|| vec![n as u32]);
            }
        }
        Command::Render(_) | Command::Plot(_) | Command::Export(_) | Command::Sweep(_) => {}
    }
    match &cli.command {
        Command::Run(args) => run::run(args, cli.quiet),
        Command::Bench(args) => bench::bench(args, cli.quiet),
        Command::Render(opts) => render::render(opts, cli.quiet),
        Command::Plot(args) => render::plot(args, cli.quiet),
        Command::Export(args) => export::export(args, cli.quiet),
        Command::View(args) => view::view(args),
        Command::Sweep(args) => sweep::sweep(args, cli.quiet),
    }
}
