//! Reading the point motion of a deforming mesh collider: an OBJ file per frame (scene
//! `sequence = "body/frame_####.obj"`) or a PC2 / MDD point cache (scene `cache`).
//!
//! Every reader returns the frames' points in the file's own units and coordinates, one per
//! vertex of the rest mesh, or a message naming the file that is wrong and why.

use crate::obj::ObjMesh;
use std::path::{Path, PathBuf};
use wetcloth::{Real, Vec3};

/// The largest number of frames a motion may have (a minute at 1000 frames per second).
pub const MAX_FRAMES: usize = 60_000;

/// The largest point cache read, bytes (1 GiB).
pub const MAX_CACHE_BYTES: u64 = 1 << 30;

/// A sequence pattern split around its run of `#`: the folder, the file name's text before
/// and after the run, and the run's length (the least number of digits).
#[derive(Debug)]
struct Pattern {
    dir: PathBuf,
    prefix: String,
    suffix: String,
    width: usize,
}

impl Pattern {
    fn parse(path: &Path) -> Result<Self, String> {
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .ok_or_else(|| format!("{}: the pattern has no file name", path.display()))?;
        let start = name.find('#').ok_or_else(|| {
            format!(
                "{}: the file name has no run of `#` for the frame number (e.g. \
                 \"body/frame_####.obj\")",
                path.display()
            )
        })?;
        let width = name[start..].chars().take_while(|&c| c == '#').count();
        let (prefix, suffix) = (&name[..start], &name[start + width..]);
        if suffix.contains('#') {
            return Err(format!(
                "{}: the file name has more than one run of `#`; one run stands for the frame \
                 number",
                path.display()
            ));
        }
        Ok(Self {
            dir: path.parent().map_or_else(PathBuf::new, Path::to_path_buf),
            prefix: prefix.to_string(),
            suffix: suffix.to_string(),
            width,
        })
    }

    fn frame(&self, k: usize) -> PathBuf {
        self.dir.join(format!(
            "{}{k:0w$}{}",
            self.prefix,
            self.suffix,
            w = self.width
        ))
    }

    /// The frame numbers present in the folder (names this pattern writes for them).
    fn present(&self) -> Result<Vec<usize>, String> {
        let dir = if self.dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            &self.dir
        };
        let entries = std::fs::read_dir(dir)
            .map_err(|e| format!("cannot read the sequence's folder {}: {e}", dir.display()))?;
        let mut found = Vec::new();
        for e in entries.flatten() {
            let name = e.file_name();
            let Some(name) = name.to_str() else { continue };
            let Some(mid) = name
                .strip_prefix(self.prefix.as_str())
                .and_then(|r| r.strip_suffix(self.suffix.as_str()))
            else {
                continue;
            };
            if mid.is_empty() || !mid.bytes().all(|b| b.is_ascii_digit()) {
                continue;
            }
            if let Ok(k) = mid.parse::<usize>()
                && format!("{k:0w$}", w = self.width) == mid
            {
                found.push(k);
            }
        }
        found.sort_unstable();
        Ok(found)
    }
}

/// The frames of an OBJ sequence, and the first frame's mesh and path (the rest mesh when the
/// collider names no `file`). `rest` is the rest mesh when `file` is given: every frame must have its
/// vertex count and faces (else frame 0's).
pub fn read_sequence(
    pattern: &Path,
    rest: Option<&ObjMesh>,
) -> Result<(Vec<Vec<Vec3>>, ObjMesh, PathBuf), String> {
    let p = Pattern::parse(pattern)?;
    let present = p.present()?;
    if present.first() != Some(&0) {
        return Err(format!(
            "frame 0 of the sequence is missing: {} (frames are numbered from 0)",
            p.frame(0).display()
        ));
    }
    let count = present.len();
    if let Some(gap) = (0..count).find(|&k| present[k] != k) {
        return Err(format!(
            "frame {gap} of the sequence is missing: {} (frames {} to {} are there; a sequence \
             runs from frame 0 without gaps)",
            p.frame(gap).display(),
            present[gap],
            present[count - 1]
        ));
    }
    if count > MAX_FRAMES {
        return Err(format!(
            "the sequence {} has {count} frames, more than the {MAX_FRAMES} allowed",
            pattern.display()
        ));
    }
    let mut frames = Vec::with_capacity(count);
    let mut first: Option<ObjMesh> = None;
    for k in 0..count {
        let path = p.frame(k);
        let text = read_limited(&path, crate::obj::MAX_MESH_BYTES)?;
        let m = crate::obj::parse(&text).map_err(|e| {
            if e.line == 0 {
                format!("{}: {}", path.display(), e.message)
            } else {
                format!("{}:{}: {}", path.display(), e.line, e.message)
            }
        })?;
        let against = rest.or(first.as_ref());
        if let Some(r) = against {
            let what = if rest.is_some() {
                "the rest mesh (`file`)"
            } else {
                "frame 0"
            };
            if m.vertices.len() != r.vertices.len() {
                return Err(format!(
                    "{}: frame {k} has {} vertices, but {what} has {}: every frame needs the \
                     same vertices",
                    path.display(),
                    m.vertices.len(),
                    r.vertices.len()
                ));
            }
            if m.triangles != r.triangles {
                let which = m
                    .triangles
                    .iter()
                    .zip(&r.triangles)
                    .position(|(a, b)| a != b)
                    .unwrap_or(m.triangles.len().min(r.triangles.len()));
                return Err(format!(
                    "{}: frame {k} has different faces from {what} ({} triangles against {}, \
                     first different at triangle {}): every frame needs the same faces",
                    path.display(),
                    m.triangles.len(),
                    r.triangles.len(),
                    which + 1
                ));
            }
        }
        frames.push(m.vertices.clone());
        if first.is_none() {
            first = Some(m);
        }
    }
    Ok((frames, first.unwrap_or_default(), p.frame(0)))
}

/// The frames of a PC2 or MDD point cache (by its extension) for a rest mesh of `vertices`
/// vertices. The cache's own timing (start frame, sampling, times) is ignored.
pub fn read_cache(path: &Path, vertices: usize) -> Result<Vec<Vec<Vec3>>, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mdd = match ext.as_deref() {
        Some("pc2") => false,
        Some("mdd") => true,
        _ => {
            return Err(format!(
                "{}: a point cache is a .pc2 or .mdd file",
                path.display()
            ));
        }
    };
    let bytes = read_bytes(path, MAX_CACHE_BYTES)?;
    let bad = |m: String| format!("{}: {m}", path.display());
    let i32_at = |at: usize, big: bool| -> Result<i64, String> {
        let b: [u8; 4] = bytes
            .get(at..at + 4)
            .and_then(|s| s.try_into().ok())
            .ok_or_else(|| bad("the file ends inside its header".into()))?;
        Ok(i64::from(if big {
            i32::from_be_bytes(b)
        } else {
            i32::from_le_bytes(b)
        }))
    };
    let (points, frames, data) = if mdd {
        let frames = i32_at(0, true)?;
        let points = i32_at(4, true)?;
        (points, frames, 8 + 4 * frames.max(0) as usize)
    } else {
        if bytes.get(..12) != Some(b"POINTCACHE2\0".as_slice()) {
            return Err(bad(
                "not a PC2 file (it does not start with POINTCACHE2)".into()
            ));
        }
        (i32_at(16, false)?, i32_at(28, false)?, 32)
    };
    if points != vertices as i64 {
        return Err(bad(format!(
            "the cache has {points} points, but the rest mesh (`file`) has {vertices} vertices"
        )));
    }
    if !(1..=MAX_FRAMES as i64).contains(&frames) {
        return Err(bad(format!(
            "the cache has {frames} frames: allowed [1, {MAX_FRAMES}]"
        )));
    }
    let frames = frames as usize;
    let need = data + frames * vertices * 12;
    if bytes.len() < need {
        return Err(bad(format!(
            "the file is {} bytes, but {frames} frames of {vertices} points need {need}",
            bytes.len()
        )));
    }
    let f = |at: usize| -> Real {
        let b: [u8; 4] = bytes[at..at + 4].try_into().unwrap_or([0; 4]);
        Real::from(if mdd {
            f32::from_be_bytes(b)
        } else {
            f32::from_le_bytes(b)
        })
    };
    Ok((0..frames)
        .map(|k| {
            (0..vertices)
                .map(|v| {
                    let at = data + (k * vertices + v) * 12;
                    Vec3::new(f(at), f(at + 4), f(at + 8))
                })
                .collect()
        })
        .collect())
}

fn read_bytes(path: &Path, max: u64) -> Result<Vec<u8>, String> {
    use std::io::Read;
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() => {
            return Err(format!("{} is not a regular file", path.display()));
        }
        Err(e) => return Err(format!("cannot read {}: {e}", path.display())),
        _ => {}
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(max + 1).read_to_end(&mut bytes))
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    if bytes.len() as u64 > max {
        return Err(format!(
            "{} is larger than the {} MiB allowed",
            path.display(),
            max >> 20
        ));
    }
    Ok(bytes)
}

fn read_limited(path: &Path, max: u64) -> Result<String, String> {
    let bytes = read_bytes(path, max)?;
    Ok(match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => String::from_utf8_lossy(e.as_bytes()).into_owned(),
    })
}
