//! `run.json`: what a renderer or a script needs to know about a run directory.

use serde::{Deserialize, Serialize};
use std::io::{self, Write};
use wetcloth::{Collider, Real, SimConfig};

/// The contents of `run.json`. Key names are a contract with the renderer: keep them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunInfo {
    /// Scene name.
    pub name: String,
    /// Particles along x and z: `frame_NNNN.obj` has `nx * nz` vertices, particle `(i, j)` is
    /// vertex `j * nx + i` (0-based).
    pub resolution: [usize; 2],
    /// Rest extent of the cloth along x and z, m.
    pub size: [Real; 2],
    /// Radius of a particle's collision sphere, m (the cloth's half thickness plus margin): a
    /// cloth resting on a plane lies this far above it.
    pub particle_radius: Real,
    /// Integration step, s.
    pub time_step: Real,
    /// Frames per simulated second: frame `k` is the state at about `k / frame_rate` s (exactly:
    /// the `time` column of `metrics.csv`).
    pub frame_rate: Real,
    /// Simulated time the scene asked for, s.
    pub duration: Real,
    /// Frames written so far: `frame_0000.obj` up to `frames - 1`, and as many rows in
    /// `metrics.csv`.
    pub frames: u64,
    /// Whether the run reached its last frame (false while running or after a blow-up).
    pub complete: bool,
    /// The colliders, in scene order, each as the scene gives it with its `shape`:
    /// `{"shape": "plane", "point": [..], "normal": [..], "friction": ..}`,
    /// `{"shape": "sphere", "center": [..], "radius": .., ...}` or
    /// `{"shape": "box", "center": [..], "half_extents": [..], ...}` (lengths in m). The
    /// description is the core's [`Collider`], so every reader draws every shape alike.
    pub colliders: Vec<Collider>,
    /// Grabbed particles as grid indices `[column, row]`, in scene order.
    pub grabs: Vec<[usize; 2]>,
}

impl RunInfo {
    /// The run information of scene `name` with configuration `config`, `frames` frames written.
    pub fn new(name: &str, config: &SimConfig, frames: u64, complete: bool) -> Self {
        Self {
            name: name.to_string(),
            resolution: config.cloth.resolution,
            size: config.cloth.size,
            particle_radius: config.cloth.particle_radius(),
            time_step: config.simulation.time_step,
            frame_rate: config.simulation.frame_rate,
            duration: config.simulation.duration,
            frames,
            complete,
            colliders: config.colliders.clone(),
            grabs: config.grabs.iter().map(|g| g.particle).collect(),
        }
    }
}

/// Writes `info` as pretty-printed JSON with a final newline (numbers in full precision).
pub fn write_run_json(mut w: impl Write, info: &RunInfo) -> io::Result<()> {
    serde_json::to_writer_pretty(&mut w, info)?;
    writeln!(w)?;
    w.flush()
}

/// Writes `run.json` at `path` through `path.json.part` and a rename, so a reader never sees it
/// half written (a run rewrites it after every frame).
pub fn write_run_json_file(path: &std::path::Path, info: &RunInfo) -> io::Result<()> {
    let part = path.with_extension("json.part");
    write_run_json(io::BufWriter::new(std::fs::File::create(&part)?), info)?;
    std::fs::rename(&part, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_demo_has_its_ground_plane_and_grab_under_the_agreed_keys() {
        let cfg = SimConfig::thesis_demo();
        let mut out = Vec::new();
        write_run_json(&mut out, &RunInfo::new("thesis-demo", &cfg, 3, false)).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
        assert_eq!(v["name"], "thesis-demo");
        assert_eq!(v["resolution"], serde_json::json!([50, 50]));
        assert_eq!(v["size"], serde_json::json!([0.3, 0.3]));
        assert_eq!(v["frames"], 3);
        assert_eq!(v["grabs"], serde_json::json!([[25, 25]]));
        assert_eq!(
            v["colliders"][0],
            serde_json::json!({"shape": "plane", "point": [0.0, 0.0, 0.0],
                               "normal": [0.0, 1.0, 0.0], "friction": 0.6})
        );
        for key in ["particle_radius", "time_step", "frame_rate"] {
            assert!(v[key].is_f64(), "{key}");
        }
        let back: RunInfo = serde_json::from_slice(&out).unwrap();
        assert_eq!(back, RunInfo::new("thesis-demo", &cfg, 3, false));
    }
}
