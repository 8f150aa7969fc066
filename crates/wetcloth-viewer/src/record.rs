//! Recording the session to a run folder that `wetcloth render` and Blender read:
//! `frames/frame_NNNN.obj` (Y up, metres, with normals and texture coordinates), one per
//! recorded displayed frame, and `metrics.csv` with one row per frame.
//!
//! Files are written on a thread of their own, so recording never slows the window down.

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Sender};
use std::thread::JoinHandle;

use wetcloth::FrameMetrics;
use wetcloth::metrics::COLUMNS;

/// One frame to write.
struct Frame {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    metrics: FrameMetrics,
}

/// A recording in progress.
pub struct Recorder {
    dir: PathBuf,
    frames: u64,
    tx: Option<Sender<Frame>>,
    thread: Option<JoinHandle<io::Result<u64>>>,
}

impl Recorder {
    /// Creates `dir/frames/` and `dir/metrics.csv` and starts the writer. `triangles` and `uvs`
    /// describe the cloth mesh, which keeps its topology for the whole recording.
    pub fn start(dir: &Path, triangles: Vec<[u32; 3]>, uvs: Vec<[f32; 2]>) -> io::Result<Self> {
        fs::create_dir_all(dir.join("frames"))?;
        let mut csv = BufWriter::new(File::create(dir.join("metrics.csv"))?);
        writeln!(csv, "frame,{}", COLUMNS.join(","))?;
        let (tx, rx) = mpsc::channel::<Frame>();
        let frames_dir = dir.join("frames");
        let thread = std::thread::Builder::new()
            .name("wetcloth-record".into())
            .spawn(move || {
                let mut n = 0u64;
                for f in rx {
                    let path = frames_dir.join(format!("frame_{n:04}.obj"));
                    let mut out = BufWriter::new(File::create(&path)?);
                    write_obj(&mut out, &f.positions, &f.normals, &uvs, &triangles)?;
                    out.flush()?;
                    write!(csv, "{n}")?;
                    for v in f.metrics.values() {
                        write!(csv, ",{v:e}")?;
                    }
                    writeln!(csv)?;
                    n += 1;
                }
                csv.flush()?;
                Ok(n)
            })?;
        Ok(Self {
            dir: dir.to_path_buf(),
            frames: 0,
            tx: Some(tx),
            thread: Some(thread),
        })
    }

    /// The run folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Frames queued so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Queues one frame.
    pub fn record(&mut self, positions: &[[f32; 3]], normals: &[[f32; 3]], metrics: FrameMetrics) {
        if let Some(tx) = &self.tx
            && tx
                .send(Frame {
                    positions: positions.to_vec(),
                    normals: normals.to_vec(),
                    metrics,
                })
                .is_ok()
        {
            self.frames += 1;
        }
    }

    /// Waits for every queued frame to be written; returns how many were.
    pub fn finish(mut self) -> io::Result<u64> {
        self.tx = None;
        match self.thread.take().map(|t| t.join()) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(io::Error::other("the recording thread panicked")),
            None => Ok(0),
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Writes one Wavefront OBJ mesh: vertices, texture coordinates and normals share indices.
pub fn write_obj(
    out: &mut impl Write,
    positions: &[[f32; 3]],
    normals: &[[f32; 3]],
    uvs: &[[f32; 2]],
    triangles: &[[u32; 3]],
) -> io::Result<()> {
    writeln!(out, "# wetcloth frame: Y up, metres")?;
    writeln!(out, "o cloth")?;
    for p in positions {
        writeln!(out, "v {} {} {}", p[0], p[1], p[2])?;
    }
    for t in uvs {
        writeln!(out, "vt {} {}", t[0], t[1])?;
    }
    for n in normals {
        writeln!(out, "vn {} {} {}", n[0], n[1], n[2])?;
    }
    for t in triangles {
        let [a, b, c] = t.map(|i| i + 1);
        writeln!(out, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_frames_and_metrics() {
        let dir = std::env::temp_dir().join(format!("wetcloth-record-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        let tri = vec![[0, 1, 2]];
        let uv = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let mut r = Recorder::start(&dir, tri, uv).unwrap();
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let n = [[0.0, 1.0, 0.0]; 3];
        let m = FrameMetrics {
            time: 0.5,
            air_volume: 1e-6,
            air_pressure: 101325.0,
            kinetic_energy: 0.0,
            max_stretch: 0.0,
            contact_fraction: 1.0,
            max_height: 0.0,
            grab_force: 0.25,
        };
        r.record(&p, &n, m);
        r.record(&p, &n, m);
        assert_eq!(r.finish().unwrap(), 2);
        let obj = fs::read_to_string(dir.join("frames/frame_0001.obj")).unwrap();
        assert!(obj.contains("\nv 1 0 0\n"));
        assert!(obj.contains("\nvn 0 1 0\n"));
        assert!(obj.contains("\nf 1/1/1 2/2/2 3/3/3\n"));
        let csv = fs::read_to_string(dir.join("metrics.csv")).unwrap();
        let lines: Vec<_> = csv.lines().collect();
        assert_eq!(
            lines[0],
            "frame,time,air_volume,air_pressure,kinetic_energy,max_stretch,contact_fraction,\
             max_height,grab_force"
        );
        assert_eq!(lines.len(), 3);
        assert!(lines[2].starts_with("1,5e-1,"));
        fs::remove_dir_all(&dir).unwrap();
    }
}
