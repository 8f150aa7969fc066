//! Frame selection: which of a run's frames to render ([`FrameSelection`]), and the frame
//! files of a run folder ([`list_frames`]).

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use crate::error::RenderError;

/// Which frames to render, by the number in their file name, written `[RANGE][:STEP]`:
/// `120` (one frame), `0..240` (end excluded), `0..=240`, `100..`, `..50`, `:5` (every fifth
/// frame), `0..=240:2`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameSelection {
    /// First frame number, inclusive.
    pub start: Option<u64>,
    /// Last frame number, inclusive.
    pub end: Option<u64>,
    /// Keep every `step`-th of the frames in range (>= 1).
    pub step: u64,
}

impl Default for FrameSelection {
    /// Every frame.
    fn default() -> Self {
        Self {
            start: None,
            end: None,
            step: 1,
        }
    }
}

impl FrameSelection {
    /// Whether frame `n` is in range (the step is applied to the frames found, in order).
    pub fn contains(&self, n: u64) -> bool {
        self.start.is_none_or(|s| n >= s) && self.end.is_none_or(|e| n <= e)
    }
}

impl fmt::Display for FrameSelection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.start, self.end) {
            (Some(a), Some(b)) if a == b => write!(f, "{a}")?,
            (a, b) => {
                if let Some(a) = a {
                    write!(f, "{a}")?;
                }
                if a.is_some() || b.is_some() {
                    write!(f, "..")?;
                }
                if let Some(b) = b {
                    write!(f, "={b}")?;
                }
            }
        }
        if self.step != 1 {
            write!(f, ":{}", self.step)?;
        }
        Ok(())
    }
}

impl FromStr for FrameSelection {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || {
            format!(
                "invalid frame selection {s:?}: expected N, A..B, A..=B, A.., ..B, with an \
                 optional :STEP (e.g. 0..=240:2, or :5 for every fifth frame)"
            )
        };
        let num = |t: &str| t.trim().parse::<u64>().map_err(|_| bad());
        let (range, step) = match s.trim().split_once(':') {
            Some((r, st)) => (r.trim(), num(st)?),
            None => (s.trim(), 1),
        };
        if step == 0 {
            return Err(format!(
                "invalid frame selection {s:?}: the step must be >= 1"
            ));
        }
        let (start, end) = if range.is_empty() {
            (None, None)
        } else if let Some((a, b)) = range.split_once("..") {
            let start = if a.trim().is_empty() {
                None
            } else {
                Some(num(a)?)
            };
            let end = if let Some(b) = b.strip_prefix('=') {
                Some(num(b)?)
            } else if b.trim().is_empty() {
                None
            } else {
                let b = num(b)?;
                if b == 0 {
                    return Err(format!("invalid frame selection {s:?}: the range is empty"));
                }
                Some(b - 1)
            };
            (start, end)
        } else {
            let n = num(range)?;
            (Some(n), Some(n))
        };
        if let (Some(a), Some(b)) = (start, end)
            && a > b
        {
            return Err(format!("invalid frame selection {s:?}: the range is empty"));
        }
        Ok(Self { start, end, step })
    }
}

/// The frame files of a run, `(number, path)` in number order.
pub fn list_frames(run_dir: &Path) -> Result<Vec<(u64, PathBuf)>, RenderError> {
    let dir = run_dir.join("frames");
    let entries = std::fs::read_dir(&dir).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            RenderError::NoFrames(run_dir.to_path_buf())
        } else {
            RenderError::io(&dir, e)
        }
    })?;
    let mut frames = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| RenderError::io(&dir, e))?;
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        if let Some(n) = name
            .strip_prefix("frame_")
            .and_then(|r| r.strip_suffix(".obj"))
            .and_then(|n| n.parse::<u64>().ok())
        {
            frames.push((n, entry.path()));
        }
    }
    frames.sort();
    if let Some(w) = frames.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(RenderError::Parse {
            path: w[1].1.clone(),
            line: None,
            message: format!(
                "is frame {} again, as is {}: one file per frame",
                w[0].0,
                w[0].1.display()
            ),
        });
    }
    Ok(frames)
}

/// Checks that every frame a run says it wrote (`frame_0000.obj` up to `written - 1`, from
/// `run.json`) is in `frames` (as [`list_frames`] returns them); frames beyond are allowed (a
/// run stopped between writing a frame and updating `run.json`).
pub(super) fn check_complete(
    run_dir: &Path,
    frames: &[(u64, PathBuf)],
    written: u64,
) -> Result<(), RenderError> {
    let mut expected = 0u64;
    for &(n, _) in frames {
        if n >= written || n > expected {
            break;
        }
        expected = n + 1;
    }
    if expected < written {
        let missing = run_dir
            .join("frames")
            .join(format!("frame_{expected:04}.obj"));
        return Err(RenderError::Parse {
            path: run_dir.join("run.json"),
            line: None,
            message: format!(
                "the run wrote {written} frame(s), frame_0000.obj to frame_{:04}.obj, but {} \
                 is missing: the run folder is damaged",
                written - 1,
                missing.display()
            ),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_selections_parse() {
        let p = |s: &str| s.parse::<FrameSelection>().unwrap();
        assert_eq!(
            p("7"),
            FrameSelection {
                start: Some(7),
                end: Some(7),
                step: 1
            }
        );
        assert_eq!(
            p("0..10"),
            FrameSelection {
                start: Some(0),
                end: Some(9),
                step: 1
            }
        );
        assert_eq!(
            p("0..=10:2"),
            FrameSelection {
                start: Some(0),
                end: Some(10),
                step: 2
            }
        );
        assert_eq!(
            p(":5"),
            FrameSelection {
                start: None,
                end: None,
                step: 5
            }
        );
        assert_eq!(
            p("100.."),
            FrameSelection {
                start: Some(100),
                end: None,
                step: 1
            }
        );
        for bad in ["x", "5..2", "0..0", ":0", "1..2:x"] {
            assert!(bad.parse::<FrameSelection>().is_err(), "{bad}");
        }
        for s in ["7", "3..=9:2", ":5", "4.."] {
            assert_eq!(p(&p(s).to_string()), p(s), "{s}");
        }
    }
}
