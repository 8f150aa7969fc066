//! Reading a run's OBJ frames back, one at a time, for the caches.

use std::fmt;
use std::fs::File;
use std::io::{self, BufRead, BufReader};
use std::path::{Path, PathBuf};

/// One frame's vertex data, kept between frames so reading allocates once.
#[derive(Clone, Debug, Default)]
pub struct FrameBuffers {
    /// Vertex positions (`v` lines), m.
    pub positions: Vec<[f32; 3]>,
    /// Vertex normals (`vn` lines).
    pub normals: Vec<[f32; 3]>,
    line: String,
}

/// What is wrong with a frame file: the file, the line where known, and what.
#[derive(Debug)]
pub struct FrameError {
    /// The frame file.
    pub path: PathBuf,
    /// 1-based line number, for a malformed line.
    pub line: Option<u64>,
    /// What is wrong.
    pub message: String,
    /// Whether the file could not be read at all (missing, unreadable) rather than read and
    /// found wrong.
    pub io: bool,
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}:{l}: {}", self.path.display(), self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

impl std::error::Error for FrameError {}

/// Reads the OBJ frame at `path` (as [`crate::write_obj`] writes it) into `bufs`: its `v` and
/// `vn` lines, in order, as `f32`.
///
/// # Errors
///
/// A [`FrameError`] when the file cannot be read, a `v` or `vn` line does not hold three finite
/// numbers, or the file has not exactly `vertices` vertices and normals and `faces` faces (a
/// truncated file, or one from another run).
pub fn read_obj_frame(
    path: &Path,
    vertices: usize,
    faces: usize,
    bufs: &mut FrameBuffers,
) -> Result<(), FrameError> {
    let err = |line, message: String, io| FrameError {
        path: path.to_path_buf(),
        line,
        message,
        io,
    };
    let file = File::open(path).map_err(|e| err(None, format!("cannot read: {e}"), true))?;
    read_obj_frame_from(
        BufReader::with_capacity(1 << 16, file),
        vertices,
        faces,
        bufs,
    )
    .map_err(|(line, message)| err(line, message, false))
}

/// [`read_obj_frame`] from any reader; errors as (line, message).
pub(crate) fn read_obj_frame_from(
    mut r: impl BufRead,
    vertices: usize,
    faces: usize,
    bufs: &mut FrameBuffers,
) -> Result<(), (Option<u64>, String)> {
    bufs.positions.clear();
    bufs.normals.clear();
    let mut face_lines = 0usize;
    let mut number = 0u64;
    loop {
        bufs.line.clear();
        let n = r
            .read_line(&mut bufs.line)
            .map_err(|e: io::Error| (Some(number + 1), format!("cannot read: {e}")))?;
        if n == 0 {
            break;
        }
        number += 1;
        // Every line of a frame ends in a newline: one that does not is where the file was cut.
        let cut = !bufs.line.ends_with('\n');
        let line = bufs.line.trim_end();
        let mut words = line.split_ascii_whitespace();
        let target = match words.next() {
            Some("v") => &mut bufs.positions,
            Some("vn") => &mut bufs.normals,
            Some("f") => {
                face_lines += 1;
                continue;
            }
            _ => continue,
        };
        let mut xyz = [0f32; 3];
        for c in &mut xyz {
            let v: f64 = words
                .next()
                .and_then(|w| w.parse().ok())
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    let msg = if cut {
                        format!("the file ends inside this line (truncated): `{line}`")
                    } else {
                        format!("expected three finite numbers, found `{line}`")
                    };
                    (Some(number), msg)
                })?;
            *c = v as f32;
        }
        target.push(xyz);
    }
    let found = [
        (bufs.positions.len(), vertices, "vertices (v lines)"),
        (bufs.normals.len(), vertices, "normals (vn lines)"),
        (face_lines, faces, "faces (f lines)"),
    ];
    for (have, want, what) in found {
        if have != want {
            return Err((
                None,
                format!(
                    "has {have} {what} where run.json's resolution means {want}: the file is \
                     truncated or from another run"
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO: &str = "# x\no cloth\nv 0 1 2\nv 3.5 -4 5e-1\nvt 0 0\nvt 1 1\nvn 0 1 0\nvn 0 1 0\nf 1/1/1 2/2/2 1/1/1\n";

    #[test]
    fn vertices_and_normals_are_read_in_order() {
        let mut b = FrameBuffers::default();
        read_obj_frame_from(TWO.as_bytes(), 2, 1, &mut b).unwrap();
        assert_eq!(b.positions, [[0.0, 1.0, 2.0], [3.5, -4.0, 0.5]]);
        assert_eq!(b.normals, [[0.0, 1.0, 0.0]; 2]);
    }

    #[test]
    fn a_damaged_line_is_named_and_a_truncated_file_counted() {
        let mut b = FrameBuffers::default();
        let bad = TWO.replace("v 3.5 -4 5e-1", "v 3.5 oops 5");
        let (line, msg) = read_obj_frame_from(bad.as_bytes(), 2, 1, &mut b).unwrap_err();
        assert_eq!(line, Some(4));
        assert!(msg.contains("`v 3.5 oops 5`"), "{msg}");
        let nan = TWO.replace("vn 0 1 0\nf", "vn 0 NaN 0\nf");
        assert_eq!(
            read_obj_frame_from(nan.as_bytes(), 2, 1, &mut b)
                .unwrap_err()
                .0,
            Some(8)
        );
        let (line, msg) = read_obj_frame_from(&TWO.as_bytes()[..28], 2, 1, &mut b).unwrap_err();
        assert_eq!(line, Some(4));
        assert!(
            msg.contains("ends inside this line (truncated): `v 3.5 -4`"),
            "{msg}"
        );
        let cut = &TWO[..TWO.find("vn").unwrap()];
        let (line, msg) = read_obj_frame_from(cut.as_bytes(), 2, 1, &mut b).unwrap_err();
        assert_eq!(line, None);
        assert!(msg.contains("has 0 normals"), "{msg}");
        let (_, msg) = read_obj_frame_from(TWO.as_bytes(), 3, 1, &mut b).unwrap_err();
        assert!(msg.contains("has 2 vertices (v lines) where run.json's resolution means 3"));
    }

    #[test]
    fn a_missing_file_names_its_path() {
        let mut b = FrameBuffers::default();
        let e = read_obj_frame(Path::new("/nonexistent/frame_0000.obj"), 1, 0, &mut b);
        let e = e.unwrap_err();
        assert!(e.io);
        assert!(
            e.to_string()
                .starts_with("/nonexistent/frame_0000.obj: cannot read"),
            "{e}"
        );
    }
}
