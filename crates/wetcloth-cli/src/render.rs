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
    if let Some(note) = runtime_dir_note(std::env::var_os("XDG_RUNTIME_DIR").as_deref())
        && !quiet
    {
        eprintln!("{note}");
    }
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

/// What to say, once and before the graphics driver speaks, when `XDG_RUNTIME_DIR` (the
/// environment variable's value, if set) is not a folder: Mesa's software renderer then
/// prints "XDG_RUNTIME_DIR is invalid or not set" to stderr, which means nothing for an
/// off-screen picture. (Setting a private one for the driver would need `set_var`, which is
/// unsound once threads run.)
fn runtime_dir_note(value: Option<&std::ffi::OsStr>) -> Option<&'static str> {
    match value {
        Some(v) if std::path::Path::new(v).is_dir() => None,
        _ => Some(
            "wetcloth: note: XDG_RUNTIME_DIR is not set (or not a folder); if the graphics \
             driver warns about it below, the warning is harmless: pictures are drawn off \
             screen and need no runtime folder",
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The note is given exactly when the driver would warn.
    #[test]
    fn render_explains_a_missing_runtime_dir() {
        assert!(runtime_dir_note(None).is_some());
        assert!(runtime_dir_note(Some("/no/such/folder".as_ref())).is_some());
        let here = std::env::temp_dir();
        assert_eq!(runtime_dir_note(Some(here.as_os_str())), None);
    }
}
