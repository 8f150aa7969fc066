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
    /// Whether the run reached its last frame (false while running or after a blow-up);
    /// `status` says more.
    pub complete: bool,
    /// Where the run is: `"running"` (still writing, or killed: a run that is stopped any
    /// other way says so), `"complete"`, `"interrupted"` (stopped by Ctrl-C or a termination
    /// signal) or `"failed"` (a blow-up or an output error, see `error`). Absent in files of
    /// older versions, which read as `"running"`.
    #[serde(default)]
    pub status: RunStatus,
    /// Simulated time of the last frame written, s (0 before the first).
    #[serde(default)]
    pub time: Real,
    /// Why the run failed (with `status = "failed"`); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The colliders, in scene order, each as the scene gives it with its `shape`:
    /// `{"shape": "plane", "point": [..], "normal": [..], "friction": ..}`,
    /// `{"shape": "sphere", "center": [..], "radius": .., ...}` or
    /// `{"shape": "box", "center": [..], "half_extents": [..], ...}` (lengths in m). The
    /// description is the core's [`Collider`], so every reader draws every shape alike.
    pub colliders: Vec<Collider>,
    /// Grabbed particles as grid indices `[column, row]`, in scene order.
    pub grabs: Vec<[usize; 2]>,
}

/// Where a run is, the `status` of `run.json`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RunStatus {
    /// Still writing frames; a folder left in this state by a run no longer running was
    /// killed (`SIGKILL`, a power cut). Its frame files and metrics rows may be one ahead of
    /// `frames`.
    #[default]
    Running,
    /// Every frame was written.
    Complete,
    /// Stopped by Ctrl-C or a termination signal, after its last whole frame.
    Interrupted,
    /// Stopped by a blow-up or an output error (`error` says which).
    Failed,
}

impl RunStatus {
    /// The name written in `run.json`.
    pub fn name(self) -> &'static str {
        match self {
            RunStatus::Running => "running",
            RunStatus::Complete => "complete",
            RunStatus::Interrupted => "interrupted",
            RunStatus::Failed => "failed",
        }
    }
}

impl RunInfo {
    /// The run information of scene `name` with configuration `config`, `frames` frames
    /// written; `status` is `complete` or `running` as `complete` says, `time` 0 (see
    /// [`RunInfo::with_status`]).
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
            status: if complete {
                RunStatus::Complete
            } else {
                RunStatus::Running
            },
            time: 0.0,
            error: None,
            colliders: config.colliders.clone(),
            grabs: config.grabs.iter().map(|g| g.particle).collect(),
        }
    }
}

/// Why the frames of `run` are not the whole run its scene asked for, if they are not: its
/// status (`running`: killed or still writing; `interrupted`; `failed`, with the error), for
/// the warning of an export and the caches' own metadata.
pub fn incomplete(run: &RunInfo) -> Option<String> {
    let frames = format!(
        "the cache holds the {} frame(s) written ({} s of the {} s asked for)",
        run.frames,
        wetcloth::math::num(run.time),
        wetcloth::math::num(run.duration)
    );
    match run.status {
        RunStatus::Complete => None,
        RunStatus::Running => Some(format!(
            "the run's status is \"running\" (killed, or still writing): {frames}"
        )),
        RunStatus::Interrupted => Some(format!("the run was interrupted: {frames}")),
        RunStatus::Failed => Some(format!(
            "the run failed ({}): {frames}",
            run.error.as_deref().unwrap_or("no error recorded")
        )),
    }
}

impl RunInfo {
    /// The same with `status` (and `complete` following it) and the simulated `time` of the
    /// last frame written, s.
    pub fn with_status(mut self, status: RunStatus, time: Real) -> Self {
        self.status = status;
        self.complete = status == RunStatus::Complete;
        self.time = time;
        self
    }

    /// The same as a failed run, with the error message.
    pub fn failed(mut self, error: impl Into<String>) -> Self {
        self.status = RunStatus::Failed;
        self.complete = false;
        self.error = Some(error.into());
        self
    }
}

/// Writes `info` as pretty-printed JSON with a final newline (numbers in full precision).
pub fn write_run_json(mut w: impl Write, info: &RunInfo) -> io::Result<()> {
    serde_json::to_writer_pretty(&mut w, info)?;
    writeln!(w)?;
    w.flush()
}

/// Writes `run.json` at `path` through `run.json.part` and a rename
/// ([`crate::write_atomically`]), so a reader never sees it half written (a run rewrites it
/// after every frame).
pub fn write_run_json_file(path: &std::path::Path, info: &RunInfo) -> io::Result<()> {
    crate::write_atomically(path, |w| write_run_json(w, info))
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
        assert_eq!(v["status"], "running");
        assert_eq!(v["time"], 0.0);
        assert!(v.get("error").is_none());
    }

    #[test]
    fn status_time_and_error_say_how_far_a_run_got() {
        let cfg = SimConfig::thesis_demo();
        let json = |info: &RunInfo| {
            let mut out = Vec::new();
            write_run_json(&mut out, info).unwrap();
            serde_json::from_slice::<serde_json::Value>(&out).unwrap()
        };
        let base = RunInfo::new("demo", &cfg, 7, false);
        let v = json(&base.clone().with_status(RunStatus::Interrupted, 0.1));
        assert_eq!(
            (v["status"].as_str(), v["complete"].as_bool()),
            (Some("interrupted"), Some(false))
        );
        assert_eq!(v["time"], 0.1);
        let v = json(&base.clone().with_status(RunStatus::Complete, 3.0));
        assert_eq!(
            (v["status"].as_str(), v["complete"].as_bool()),
            (Some("complete"), Some(true))
        );
        let v = json(
            &base
                .clone()
                .with_status(RunStatus::Running, 0.5)
                .failed("blew up"),
        );
        assert_eq!(
            (v["status"].as_str(), v["error"].as_str()),
            (Some("failed"), Some("blew up"))
        );
        for s in [
            RunStatus::Running,
            RunStatus::Complete,
            RunStatus::Interrupted,
            RunStatus::Failed,
        ] {
            assert_eq!(json(&base.clone().with_status(s, 0.0))["status"], s.name());
        }
        // A run.json of an older version (no status, time or error) still reads.
        let mut old = json(&base);
        let o = old.as_object_mut().unwrap();
        o.remove("status");
        o.remove("time");
        let back: RunInfo = serde_json::from_value(old).unwrap();
        assert_eq!(back.status, RunStatus::Running);
    }
}
