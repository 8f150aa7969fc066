//! Recording the session to a run folder in the layout of `wetcloth run`, which
//! `wetcloth render` and Blender read: `frames/frame_NNNN.obj` (Y up, metres, with normals and
//! texture coordinates), one per recorded displayed frame, `metrics.csv` with one row per frame,
//! `scene.toml` (the parameters in use) and `run.json`. The files are written with the
//! `wetcloth-export` writers, so they match a batch run's byte for byte in form.
//!
//! Files are written on a thread of their own, so recording never slows the window down.

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{self, Sender};
use std::thread::JoinHandle;

use wetcloth::{ClothSurface, FrameMetrics, SimConfig, Soa};
use wetcloth_export::{
    MetricsCsv, RunInfo, RunStatus, create_fresh, frame_file_name, is_frame_file_name,
    write_atomically, write_obj,
};

/// One frame to write: the exact particle positions and the measurements.
struct Frame {
    positions: Arc<Soa>,
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
    /// Prepares `dir` (removing frame files an earlier recording left in `dir/frames`), writes
    /// `scene.toml` and starts the writer for a session of the scene `name` with `config` (whose
    /// grid is kept for the whole recording).
    pub fn start(dir: &Path, name: &str, config: &SimConfig) -> io::Result<Self> {
        let frames_dir = dir.join("frames");
        fs::create_dir_all(&frames_dir)?;
        for entry in fs::read_dir(&frames_dir)? {
            let entry = entry?;
            if is_frame_file_name(&entry.file_name().to_string_lossy())
                && entry.file_type()?.is_file()
            {
                fs::remove_file(entry.path())?;
            }
        }
        let json = dir.join("run.json");
        let (name, mut config) = (name.to_string(), config.clone());
        // run.json names each mesh by its copy beside it.
        wetcloth_export::write_mesh_copies(dir, &config.colliders)?;
        if let Some(m) = &config.cloth.mesh {
            wetcloth_export::write_cloth_copy(dir, m)?;
        }
        write_run_json(&json, &name, &config, 0, RunStatus::Running, 0.0)?;
        let toml = wetcloth_scene::to_toml(&name, &config);
        write_atomically(&dir.join("scene.toml"), |w| w.write_all(toml.as_bytes()))?;
        let mut csv = MetricsCsv::new(BufWriter::new(create_fresh(&dir.join("metrics.csv"))?))?;
        // The frames' faces and texture coordinates (a mesh cloth's as its file has them).
        let surface = ClothSurface::new(&config.cloth);

        let (tx, rx) = mpsc::channel::<Frame>();
        let thread = std::thread::Builder::new()
            .name("wetcloth-record".into())
            .spawn(move || {
                let mut n = 0u64;
                let mut times = (0.0, 0.0);
                let written = || -> io::Result<()> {
                    for f in rx {
                        let path = frames_dir.join(frame_file_name(n));
                        let normals = surface.vertex_normals(&f.positions);
                        write_atomically(&path, |w| {
                            write_obj(w, &surface, &f.positions, &normals)
                        })?;
                        csv.write_row(n, &f.metrics)?;
                        if n == 0 {
                            times.0 = f.metrics.time;
                        }
                        times.1 = f.metrics.time;
                        n += 1;
                    }
                    Ok(())
                };
                let result = written();
                // Frames follow the window, not a fixed rate: record the mean rate.
                if n > 1 && times.1 > times.0 {
                    config.simulation.frame_rate = (n - 1) as f64 / (times.1 - times.0);
                }
                match result {
                    Ok(()) => {
                        write_run_json(&json, &name, &config, n, RunStatus::Complete, times.1)?;
                        Ok(n)
                    }
                    Err(e) => {
                        // Say so in run.json, if it can still be written.
                        let info = RunInfo::new(&name, &config, n, false)
                            .with_status(RunStatus::Running, times.1)
                            .failed(format!("recording failed: {e}"));
                        let _ = wetcloth_export::write_run_json_file(&json, &info);
                        Err(e)
                    }
                }
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
    pub fn record(&mut self, positions: Arc<Soa>, metrics: FrameMetrics) {
        if let Some(tx) = &self.tx
            && tx.send(Frame { positions, metrics }).is_ok()
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

/// Writes `run.json` (always complete, see `write_run_json_file`).
fn write_run_json(
    path: &Path,
    name: &str,
    config: &SimConfig,
    frames: u64,
    status: RunStatus,
    time: f64,
) -> io::Result<()> {
    let info = RunInfo::new(name, config, frames, false).with_status(status, time);
    wetcloth_export::write_run_json_file(path, &info)
}

#[cfg(test)]
mod tests {
    use super::*;
    use wetcloth::Simulation;

    #[test]
    fn writes_a_run_folder_like_wetcloth_run() {
        let dir = std::env::temp_dir().join(format!("wetcloth-record-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        // A stale frame from an earlier recording is removed.
        fs::create_dir_all(dir.join("frames")).unwrap();
        fs::write(dir.join("frames/frame_0007.obj"), "old").unwrap();
        let mut cfg = SimConfig::thesis_demo();
        cfg.cloth.resolution = [4, 3];
        cfg.grabs.clear();
        let mut sim = Simulation::new(cfg.clone()).unwrap();
        let mut r = Recorder::start(&dir, "session", &cfg).unwrap();
        r.record(Arc::new(sim.positions().clone()), sim.metrics());
        sim.advance(100).unwrap();
        r.record(Arc::new(sim.positions().clone()), sim.metrics());
        assert_eq!(r.finish().unwrap(), 2);

        assert!(!dir.join("frames/frame_0007.obj").exists());
        let obj = fs::read_to_string(dir.join("frames/frame_0001.obj")).unwrap();
        assert_eq!(obj.lines().filter(|l| l.starts_with("v ")).count(), 12);
        assert_eq!(obj.lines().filter(|l| l.starts_with("vn ")).count(), 12);
        assert_eq!(obj.lines().filter(|l| l.starts_with("vt ")).count(), 12);
        assert_eq!(obj.lines().filter(|l| l.starts_with("f ")).count(), 12);
        let csv = fs::read_to_string(dir.join("metrics.csv")).unwrap();
        let lines: Vec<_> = csv.lines().collect();
        assert_eq!(lines[0], wetcloth_export::csv_header());
        assert!(lines[0].starts_with("frame,time,air_volume,air_pressure,"));
        assert_eq!(lines.len(), 3);
        assert!(lines[2].starts_with("1,"));
        let json = fs::read_to_string(dir.join("run.json")).unwrap();
        assert!(
            json.contains("\"frames\": 2") || json.contains("\"frames\":2"),
            "{json}"
        );
        assert!(json.contains("\"status\": \"complete\""), "{json}");
        assert!(dir.join("scene.toml").exists());
        fs::remove_dir_all(&dir).unwrap();
    }
}
