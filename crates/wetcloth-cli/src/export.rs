//! `wetcloth export RUN_DIR --format FORMAT [--out FILE]`: a run's frames as one cache file
//! (PC2, MDD, USD text or binary) plus `RUN_DIR/rest.obj`, the mesh point caches apply to.
//! Also behind `wetcloth run --export`.

use crate::error::CliError;
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use wetcloth_export::{CacheFormat, ExportError, ExportJob, REST_OBJ, export_run, read_run_folder};

/// Arguments of `wetcloth export`.
#[derive(Args, Debug)]
pub struct ExportArgs {
    /// Run folder written by `wetcloth run` (reads run.json, scene.toml and frames/).
    #[arg(value_name = "RUN_DIR")]
    pub run_dir: PathBuf,

    /// Cache format: pc2 (Blender, 3ds Max), mdd (Houdini, Blender, LightWave), usda (USD
    /// text), usdc (USD binary) or abc (Alembic: Maya, Houdini, Blender, Cinema 4D, Unreal).
    #[arg(long, short, value_name = "FORMAT", value_parser = parse_format)]
    pub format: CacheFormat,

    /// Output file; default RUN_DIR/<scene name>.<extension>.
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

fn parse_format(s: &str) -> Result<CacheFormat, String> {
    s.parse()
}

/// A comma-separated list of cache formats, as `wetcloth run --export usdc,pc2` takes it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FormatList(pub Vec<CacheFormat>);

/// Parses `--export`'s list.
pub fn parse_format_list(s: &str) -> Result<FormatList, String> {
    CacheFormat::parse_list(s).map(FormatList)
}

/// Runs `wetcloth export`.
pub fn export(args: &ExportArgs, quiet: bool) -> Result<(), CliError> {
    write_caches(&args.run_dir, &[(args.format, args.out.clone())], quiet)
}

/// Writes the caches `formats` (each with its file, or the default one) of the run in
/// `run_dir`, and `rest.obj`, with a progress bar over the frames and a summary line per file.
pub fn write_caches(
    run_dir: &Path,
    formats: &[(CacheFormat, Option<PathBuf>)],
    quiet: bool,
) -> Result<(), CliError> {
    let folder = read_run_folder(run_dir).map_err(from_export)?;
    // A cache of a run that did not complete is written all the same (exit 0), with a word.
    if let Some(why) = wetcloth_export::incomplete(&folder.info) {
        eprintln!(
            "wetcloth: warning: {} is incomplete: {why}",
            run_dir.display()
        );
    }
    let jobs: Vec<ExportJob> = formats
        .iter()
        .map(|(format, out)| ExportJob {
            format: *format,
            out: out
                .clone()
                .unwrap_or_else(|| ExportJob::default_out(run_dir, &folder.info, *format)),
        })
        .collect();
    let bar = progress_bar(folder.info.frames, &jobs, quiet);
    let result = export_run(run_dir, &jobs, &mut |done, _| bar.set_position(done));
    match result {
        Ok(_) => bar.finish_and_clear(),
        Err(e) => {
            bar.abandon();
            return Err(from_export(e));
        }
    }
    if !quiet {
        for job in &jobs {
            let size = std::fs::metadata(&job.out).map(|m| m.len()).unwrap_or(0);
            println!(
                "wrote {} ({}: {} frames of {} vertices, {})",
                job.out.display(),
                job.format,
                folder.info.frames,
                folder.info.vertices(),
                bytes(size)
            );
        }
        println!(
            "wrote {} (the mesh the point caches apply to)",
            run_dir.join(REST_OBJ).display()
        );
    }
    Ok(())
}

/// A file size for people: kB, MB or GB (powers of 1000), one decimal.
fn bytes(n: u64) -> String {
    let n = n as f64;
    if n < 1e6 {
        format!("{:.1} kB", n / 1e3)
    } else if n < 1e9 {
        format!("{:.1} MB", n / 1e6)
    } else {
        format!("{:.1} GB", n / 1e9)
    }
}

fn from_export(e: ExportError) -> CliError {
    match e {
        ExportError::Input(m) => CliError::Input(m),
        ExportError::Output { path, source } => CliError::Output { path, source },
    }
}

/// A progress bar over the frames on stderr, or a hidden one when stderr is not a terminal or
/// the command is quiet.
fn progress_bar(frames: u64, jobs: &[ExportJob], quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(frames), ProgressDrawTarget::stderr());
    let names: Vec<&str> = jobs.iter().map(|j| j.format.name()).collect();
    if let Ok(style) = ProgressStyle::with_template(&format!(
        "exporting {} {{wide_bar}} {{pos}}/{{len}} frames (eta {{eta}})",
        names.join(",")
    )) {
        bar.set_style(style);
    }
    bar
}
