//! Run-folder reading: `run.json` ([`RunInfo`]) and the OBJ frames ([`read_obj`]).

use std::io::BufReader;
use std::path::Path;

use serde::Deserialize;

use crate::error::RenderError;

/// The parts of `run.json` the renderer uses; other keys are ignored.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(default)]
pub struct RunInfo {
    /// Scene name (names the MP4).
    pub name: String,
    /// Particles along x and z.
    pub resolution: [usize; 2],
    /// Particle collision radius, m.
    pub particle_radius: f64,
    /// Frames per simulated second.
    pub frame_rate: f64,
    /// Colliders.
    pub colliders: Vec<ColliderInfo>,
    /// Grabbed particles as `[column, row]`.
    pub grabs: Vec<[usize; 2]>,
}

/// A collider of `run.json`.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "shape", rename_all = "lowercase")]
pub enum ColliderInfo {
    /// An infinite plane.
    Plane {
        /// A point of the plane, m.
        point: [f64; 3],
        /// Its normal.
        normal: [f64; 3],
    },
    /// A sphere.
    Sphere {
        /// Centre, m.
        center: [f64; 3],
        /// Radius, m.
        radius: f64,
    },
    /// An axis-aligned box.
    Box {
        /// Centre, m.
        center: [f64; 3],
        /// Half edge lengths, m.
        half_extents: [f64; 3],
    },
}

/// f64 coordinates as the renderer's f32.
pub(super) fn f32s(v: [f64; 3]) -> [f32; 3] {
    v.map(|x| x as f32)
}

/// Reads `RUN_DIR/run.json`; `Ok(None)` when there is none.
pub fn read_run_info(run_dir: &Path) -> Result<Option<RunInfo>, RenderError> {
    let path = run_dir.join("run.json");
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(RenderError::io(path, e)),
    };
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| RenderError::Parse {
            line: Some(e.line()),
            message: e.to_string(),
            path,
        })
}

/// A cloth frame read from OBJ: positions and triangle indices.
#[derive(Clone, Debug, Default)]
pub struct ObjMesh {
    /// Vertex positions, m.
    pub positions: Vec<[f32; 3]>,
    /// Triangle indices.
    pub indices: Vec<u32>,
}

/// Reads an OBJ file's first object (triangulated; positions keep their file order, so vertex
/// k is particle k).
pub fn read_obj(path: &Path) -> Result<ObjMesh, RenderError> {
    let file = std::fs::File::open(path).map_err(|e| RenderError::io(path, e))?;
    // tobj adds fields behind its optional features: keep the struct update.
    #[allow(clippy::needless_update)]
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj_buf(&mut BufReader::new(file), &opts, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| RenderError::Parse {
        path: path.to_path_buf(),
        line: None,
        message: format!("not a readable OBJ mesh: {e}"),
    })?;
    let model = models
        .into_iter()
        .next()
        .ok_or_else(|| RenderError::Parse {
            path: path.to_path_buf(),
            line: None,
            message: "no mesh in the file".into(),
        })?;
    let positions = model
        .mesh
        .positions
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    Ok(ObjMesh {
        positions,
        indices: model.mesh.indices,
    })
}
