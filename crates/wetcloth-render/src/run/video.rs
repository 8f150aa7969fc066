//! Video encoding: an `ffmpeg` process fed raw RGBA frames.

use std::io::Write;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};

use super::ImageSize;
use crate::error::RenderError;

/// Finds ffmpeg: `true` when `ffmpeg -version` runs.
pub fn ffmpeg_available() -> bool {
    Command::new("ffmpeg")
        .arg("-version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// An ffmpeg process reading raw RGBA frames on its standard input.
pub(super) struct Encoder {
    child: Child,
    path: PathBuf,
    stderr: std::thread::JoinHandle<String>,
}

impl Encoder {
    pub(super) fn start(path: PathBuf, size: ImageSize, fps: f64) -> Result<Self, RenderError> {
        let mut child = Command::new("ffmpeg")
            .args(["-hide_banner", "-loglevel", "error", "-y"])
            .args(["-f", "rawvideo", "-pix_fmt", "rgba"])
            .args(["-s", &size.to_string(), "-framerate", &format!("{fps}")])
            .args(["-i", "-"])
            // H.264 in yuv420p needs even sides: pad odd ones by a pixel.
            .args(["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"])
            .args(["-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "18"])
            .args(["-movflags", "+faststart"])
            .arg(&path)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| RenderError::Ffmpeg(format!("could not start ffmpeg: {e}")))?;
        let mut err = child.stderr.take().expect("stderr is piped");
        let stderr = std::thread::spawn(move || {
            let mut s = String::new();
            let _ = std::io::Read::read_to_string(&mut err, &mut s);
            s
        });
        Ok(Self {
            child,
            path,
            stderr,
        })
    }

    pub(super) fn push(&mut self, rgba: &[u8]) -> Result<(), RenderError> {
        let stdin = self.child.stdin.as_mut().expect("stdin is piped");
        stdin
            .write_all(rgba)
            .map_err(|e| RenderError::Ffmpeg(format!("writing a frame: {e}")))
    }

    pub(super) fn finish(mut self) -> Result<PathBuf, RenderError> {
        drop(self.child.stdin.take());
        let status = self
            .child
            .wait()
            .map_err(|e| RenderError::Ffmpeg(e.to_string()))?;
        let log = self.stderr.join().unwrap_or_default();
        if status.success() {
            Ok(self.path)
        } else {
            Err(RenderError::Ffmpeg(format!("{status}: {}", log.trim())))
        }
    }
}
