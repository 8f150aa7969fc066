//! `run.json`: what a renderer or a script needs to know about a run directory.

use serde::{Deserialize, Serialize};
use std::io::{self, Write};
use wetcloth::{Collider, Real, SimConfig};

/// The contents of `run.json`. Key names are a contract with the renderer: keep them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunInfo {
    /// Scene name.
    pub name: String,
    /// The built-in grid's particles along x and z: `frame_NNNN.obj` has `nx * nz` vertices,
    /// particle `(i, j)` is vertex `j * nx + i` (0-based). Absent for a mesh cloth (see
    /// `mesh`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution: Option<[usize; 2]>,
    /// Rest extent of the built-in grid along x and z, m. Absent for a mesh cloth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<[Real; 2]>,
    /// A cloth of any shape (`[cloth] mesh`): its file, the copy of it kept in the run folder,
    /// its vertex and face counts and placement. Absent for the built-in grid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<ClothMeshInfo>,
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
    /// Grabbed particles as grid indices `[column, row]`, in scene order; empty for a mesh
    /// cloth (see `grabs.csv`).
    pub grabs: Vec<[usize; 2]>,
}

/// `run.json`'s `mesh`: a cloth of any shape. Particle `k` is the file's vertex `k`; the
/// frames have the file's faces and texture coordinates (see [`wetcloth::ClothSurface`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClothMeshInfo {
    /// The file the scene named (absolute path, as the run read it).
    pub file: String,
    /// The copy of the mesh as read, in the run folder (`meshes/cloth-<digest>.obj`, see
    /// [`crate::write_cloth_copy`]): exports and resumed runs read it, so they work when the
    /// original file moves or changes.
    pub copy: String,
    /// FNV-1a digest of the copy's bytes, 16 hex digits.
    pub digest: String,
    /// Vertices (particles): every frame has this many `v` lines.
    pub vertices: usize,
    /// Faces (polygons, as the file has them): every frame has this many `f` lines.
    pub faces: usize,
    /// Texture coordinates (`vt` lines) of the file; 0 when it has none.
    pub texture_coordinates: usize,
    /// Where the file's origin is at t = 0, m.
    pub position: [Real; 3],
    /// Rotation about x, then y, then z, degrees.
    pub rotation: [Real; 3],
    /// The file's units to metres.
    pub scale: Real,
    /// Whether the physics reverses the faces' winding (the outputs keep the file's).
    pub flip_normals: bool,
    /// The cloth's bounds at t = 0, `[min, max]`, m.
    pub bounds: [[Real; 3]; 2],
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
        let cloth = &config.cloth;
        let mesh = cloth.mesh.as_ref().map(|m| {
            let (copy, digest, _) = crate::mesh_copy::cloth_copy(m);
            let placed = m.placed(cloth.position);
            let mut bounds = [[Real::INFINITY; 3], [Real::NEG_INFINITY; 3]];
            for p in &placed {
                for (a, c) in p.to_array().into_iter().enumerate() {
                    bounds[0][a] = bounds[0][a].min(c);
                    bounds[1][a] = bounds[1][a].max(c);
                }
            }
            ClothMeshInfo {
                file: m.file.clone(),
                copy,
                digest: format!("{digest:016x}"),
                vertices: m.vertices.len(),
                faces: m.faces.len(),
                texture_coordinates: m.uvs.len(),
                position: cloth.position.to_array(),
                rotation: m.rotation.to_array(),
                scale: m.scale,
                flip_normals: m.flip_normals,
                bounds,
            }
        });
        let grid = mesh.is_none();
        Self {
            name: name.to_string(),
            resolution: grid.then_some(cloth.resolution),
            size: grid.then_some(cloth.size),
            mesh,
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
            // A mesh cloth's grabs name no grid particle (grabs.csv has each one's particles
            // and force).
            grabs: if grid {
                config.grabs.iter().map(|g| g.particle).collect()
            } else {
                Vec::new()
            },
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
    /// Vertices of every frame: the grid's `nx * nz`, or the mesh's vertex count (0 when
    /// `run.json` gives neither).
    pub fn vertices(&self) -> usize {
        match (&self.mesh, self.resolution) {
            (Some(m), _) => m.vertices,
            (None, Some([nx, nz])) => nx.saturating_mul(nz),
            (None, None) => 0,
        }
    }

    /// The cloth's largest horizontal extent at rest, m: the grid's larger side, or the
    /// larger of a mesh's x and z spans (sizes the ground planes the caches draw).
    pub fn cloth_span(&self) -> Real {
        match (&self.mesh, self.size) {
            (Some(m), _) => {
                let [lo, hi] = m.bounds;
                (hi[0] - lo[0]).max(hi[2] - lo[2]).max(0.0)
            }
            (None, Some([x, z])) => x.max(z),
            (None, None) => 0.0,
        }
    }

    /// The cloth in words for the caches' descriptions: `50 x 50 particles` or `5 particles,
    /// 2 faces (towel.obj)`.
    pub fn cloth_words(&self) -> String {
        match (&self.mesh, self.resolution) {
            (Some(m), _) => {
                let file = std::path::Path::new(&m.file)
                    .file_name()
                    .map_or(m.file.clone(), |f| f.to_string_lossy().into_owned());
                format!("{} particles, {} faces ({file})", m.vertices, m.faces)
            }
            (None, Some([nx, nz])) => format!("{nx} x {nz} particles"),
            (None, None) => "no cloth".into(),
        }
    }

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
