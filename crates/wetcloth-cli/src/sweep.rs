//! `wetcloth sweep SCENE --vary KEY=V1,V2 ... --out sweep.csv`: a parameter sweep on Dask, run
//! by the `wetcloth` Python package (`python3 -m wetcloth sweep ...`), with the `python3` of the
//! active virtual environment, else the one on PATH.

use crate::error::CliError;
use clap::Args;
use std::path::PathBuf;
use std::process::Command;

/// Arguments of `wetcloth sweep`.
#[derive(Args, Debug)]
pub struct SweepArgs {
    /// Scene file (TOML) every run starts from.
    pub scene: PathBuf,

    /// A key to vary and its values (repeatable): KEY=V1,V2,... with each value in TOML syntax
    /// (`--vary air.trapped_air=0,1e-4,4e-4 --vary cloth.size=[0.2,0.2],[0.3,0.3]`). Every
    /// combination runs.
    #[arg(long, value_name = "KEY=V1,V2,...", required = true)]
    pub vary: Vec<String>,

    /// A running Dask scheduler (`tcp://HOST:PORT`); default: a local cluster with one worker
    /// process per core.
    #[arg(long, value_name = "ADDR")]
    pub scheduler: Option<String>,

    /// The CSV to write: one row per run (the varied values, the last frame's metrics,
    /// peak_grab_force, status, message, wall_time).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,

    /// Also write each run's folder (frames, metrics.csv, ...) under DIR, as DIR/run_NNNN.
    #[arg(long, value_name = "DIR")]
    pub runs: Option<PathBuf>,
}

/// The Python to run: the active virtual environment's, else `python3` on PATH.
fn python() -> PathBuf {
    if let Some(venv) = std::env::var_os("VIRTUAL_ENV") {
        let p = PathBuf::from(venv).join("bin").join("python3");
        if p.is_file() {
            return p;
        }
    }
    PathBuf::from("python3")
}

/// Runs `wetcloth sweep`: hands the arguments to the Python package, and exits as it does.
pub fn sweep(args: &SweepArgs, quiet: bool) -> Result<(), CliError> {
    let python = python();
    let probe = Command::new(&python)
        .args(["-c", "import wetcloth, dask.distributed, pandas"])
        .output();
    match probe {
        Err(e) => {
            return Err(CliError::Setup(format!(
                "wetcloth sweep runs on Python and Dask, but {} cannot be started ({e}); \
                 install Python 3.10 or newer, then the package: see docs/python.md",
                python.display()
            )));
        }
        Ok(out) if !out.status.success() => {
            return Err(CliError::Setup(format!(
                "wetcloth sweep needs the wetcloth Python package with Dask and pandas, which \
                 {} cannot import ({}); in a virtual environment: `pip install maturin && pip \
                 install ./crates/wetcloth-py \"dask[distributed]\" pandas` (see docs/python.md)",
                python.display(),
                String::from_utf8_lossy(&out.stderr)
                    .lines()
                    .last()
                    .unwrap_or("no message")
            )));
        }
        Ok(_) => {}
    }
    let mut cmd = Command::new(&python);
    cmd.args(["-m", "wetcloth", "sweep"]).arg(&args.scene);
    for v in &args.vary {
        cmd.arg("--vary").arg(v);
    }
    if let Some(s) = &args.scheduler {
        cmd.arg("--scheduler").arg(s);
    }
    cmd.arg("--out").arg(&args.out);
    if let Some(r) = &args.runs {
        cmd.arg("--runs").arg(r);
    }
    if quiet {
        cmd.arg("--quiet");
    }
    let status = cmd
        .status()
        .map_err(|e| CliError::Setup(format!("cannot start {}: {e}", python.display())))?;
    match status.code() {
        Some(0) => Ok(()),
        // The Python side said what went wrong; keep its exit code (2 for bad input).
        Some(code) => std::process::exit(code),
        None => Err(CliError::Setup(format!(
            "{} -m wetcloth sweep was killed by a signal",
            python.display()
        ))),
    }
}
