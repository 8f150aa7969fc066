//! What can go wrong in a subcommand, and the exit code for each.

use std::path::PathBuf;

/// A failed subcommand. The message is printed on stderr after `error: `.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// Bad input: a scene file that cannot be read or is invalid. Exit code 2.
    #[error("{0}")]
    Scene(#[from] wetcloth_scene::SceneError),
    /// The simulation blew up. Exit code 1.
    #[error("{error}\n  the {frames} frame(s) and metrics rows written before it are in {}", dir.display())]
    BlowUp {
        /// The core's error: names the simulated time and suggests a smaller time step.
        error: wetcloth::StepError,
        /// Frames written before it.
        frames: u64,
        /// The output directory.
        dir: PathBuf,
    },
    /// A frame about to be written holds a non-finite value: refused by the writers as a last
    /// line of defence behind the core's checks. Exit code 1.
    #[error("frame {frame} would hold {what}; it was not written, and the {frame} frame(s) before it are in {}", dir.display())]
    Unwritable {
        /// The frame refused.
        frame: u64,
        /// What is wrong with it.
        what: String,
        /// The output directory.
        dir: PathBuf,
    },
    /// Bad input other than a scene file: a missing or damaged run folder. Exit code 2.
    #[error("{0}")]
    Input(String),
    /// Rendering or plotting failed (a missing or malformed run directory, no graphics
    /// adapter). Exit code 1.
    #[error("{0}")]
    Render(String),
    /// The run could not be set up (threads, an invalid built-in configuration). Exit code 1.
    #[error("{0}")]
    Setup(String),
    /// Bad input other than a scene file: an environment variable, options that contradict
    /// each other, a run that cannot fit the machine (refused before anything is written).
    /// Exit code 2.
    #[error("{0}")]
    Usage(String),
    /// The run was stopped by Ctrl-C or a termination signal after its last whole frame.
    /// Exit code 130.
    #[error("interrupted at t = {time} s after {frames} frame(s); they are in {}, and run.json says \"interrupted\"", dir.display())]
    Interrupted {
        /// Frames written.
        frames: u64,
        /// Simulated time of the last frame written, s.
        time: f64,
        /// The output directory.
        dir: PathBuf,
    },
    /// An output could not be written. Exit code 1.
    #[error("cannot write {}: {source}", path.display())]
    Output {
        /// The file or directory.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}

impl CliError {
    /// The process exit code: 2 for bad input, 1 for a failed run, 130 for an interrupted
    /// one.
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Scene(_) | CliError::Usage(_) | CliError::Input(_) => 2,
            CliError::Interrupted { .. } => 130,
            CliError::BlowUp { .. }
            | CliError::Unwritable { .. }
            | CliError::Output { .. }
            | CliError::Setup(_)
            | CliError::Render(_) => 1,
        }
    }

    /// An output error at `path`.
    pub fn output(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> CliError {
        let path = path.into();
        move |source| CliError::Output { path, source }
    }
}
