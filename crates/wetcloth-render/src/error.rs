//! Errors of rendering and plotting.

use std::path::PathBuf;

/// Why a frame, a run or a plot could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// No graphics adapter could be opened.
    #[error(
        "no graphics adapter found ({0}); on a machine without a GPU install Mesa's software \
         Vulkan driver (Debian/Ubuntu: `apt-get install mesa-vulkan-drivers libvulkan1`)"
    )]
    NoAdapter(String),
    /// The adapter refused to open a device.
    #[error("could not open the graphics device: {0}")]
    Device(String),
    /// Reading the rendered image back from the GPU failed.
    #[error("could not read the rendered image back: {0}")]
    Readback(String),
    /// A width or height of zero, or beyond the device's limits.
    #[error("invalid image size {width}x{height}: {reason}")]
    Size {
        /// Requested width, px.
        width: u32,
        /// Requested height, px.
        height: u32,
        /// Why it is refused.
        reason: String,
    },
    /// A file or directory could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A run's input file is malformed.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The 1-based line, where known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// A run directory without frames to render.
    #[error("no frames to render in {}: expected frames/frame_NNNN.obj (written by `wetcloth run`)", .0.display())]
    NoFrames(PathBuf),
    /// A frame selection that matches none of a run's frames.
    #[error(
        "no frame of {} matches --frames {selection}: the run has {count} frame(s), numbered \
         {first} to {last}",
        dir.display()
    )]
    NoFramesSelected {
        /// The run directory.
        dir: PathBuf,
        /// The selection, as written.
        selection: String,
        /// The first frame number found.
        first: u64,
        /// The last frame number found.
        last: u64,
        /// Frames found.
        count: usize,
    },
    /// `--pockets` on a run folder without `pockets.csv`.
    #[error(
        "no pockets.csv in {}: --pockets needs the pocket pressures a run of this version \
         writes (run the scene again with `wetcloth run`)",
        .0.display()
    )]
    NoPockets(PathBuf),
    /// An option out of its range.
    #[error("{0}")]
    Option(String),
    /// Encoding a PNG failed.
    #[error("could not write {}: {message}", path.display())]
    Image {
        /// The image file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// ffmpeg ran but failed.
    #[error("ffmpeg failed: {0}")]
    Ffmpeg(String),
    /// Drawing the plot failed.
    #[error("plotting failed: {0}")]
    Plot(String),
}

impl RenderError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}
