//! `wetcloth`: the command line of the wet-cloth simulator.
//!
//! Each subcommand lives in its own module; this file only parses the arguments, sets up what
//! every subcommand shares (the thread pool) and turns the outcome into an exit code:
//! 0 on success, 2 for bad input (arguments, scene files, damaged run folders), 1 when a run fails (the simulation
//! blows up, or its outputs cannot be written).

mod bench;
mod error;
mod export;
mod render;
mod run;
mod view;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Wet cloth that sticks: a simulator of wet cloth and the air trapped under it
/// (W. Yamada, 2012).
#[derive(Parser, Debug)]
#[command(name = "wetcloth", version)]
struct Cli {
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
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Command::Run(run::RunArgs {
        threads: Some(n), ..
    }) = &cli.command
        && let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(*n as usize)
            .build_global()
    {
        eprintln!("wetcloth: warning: cannot set up {n} threads: {e}");
    }
    let result = match &cli.command {
        Command::Run(args) => run::run(args, cli.quiet),
        Command::Bench(args) => bench::bench(args, cli.quiet),
        Command::Render(opts) => render::render(opts, cli.quiet),
        Command::Plot(args) => render::plot(args, cli.quiet),
        Command::Export(args) => export::export(args, cli.quiet),
        Command::View(args) => view::view(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
