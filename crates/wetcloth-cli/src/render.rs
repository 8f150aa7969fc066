//! `wetcloth render` and `wetcloth plot`: pictures of a run directory, by the shared renderer
//! of `wetcloth-render` (the same one the viewer draws with).

use crate::error::CliError;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use wetcloth_render::{RenderOptions, plot_run, render_run_with_progress};

/// Runs `wetcloth render`.
pub fn render(opts: &RenderOptions, quiet: bool) -> Result<(), CliError> {
    let bar = if quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::new(0);
        b.set_style(
            ProgressStyle::with_template("rendering {bar:30} {pos}/{len} frames, {eta} left")
                .expect("valid template"),
        );
        b
    };
    let summary = render_run_with_progress(opts.clone(), &mut |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .map_err(|e| match e {
        // Asking for pockets of a run that has none is bad input (exit 2).
        e @ wetcloth_render::RenderError::NoPockets(_) => CliError::Input(e.to_string()),
        e => CliError::Render(e.to_string()),
    })?;
    bar.finish_and_clear();
    if !quiet {
        println!("{summary}");
    }
    Ok(())
}

/// Arguments of `wetcloth plot`.
#[derive(Args, Debug)]
pub struct PlotArgs {
    /// Run directory written by `wetcloth run` (reads RUN_DIR/metrics.csv, writes
    /// RUN_DIR/metrics.png).
    #[arg(value_name = "RUN_DIR")]
    pub run_dir: PathBuf,
}

/// Runs `wetcloth plot`.
pub fn plot(args: &PlotArgs, quiet: bool) -> Result<(), CliError> {
    let path = plot_run(&args.run_dir).map_err(|e| CliError::Render(e.to_string()))?;
    if !quiet {
        println!("wrote {}", path.display());
    }
    Ok(())
}
