//! Run-folder reading: `run.json` ([`RunInfo`]) and the OBJ frames ([`read_obj`]), each
//! checked, so that a damaged folder is refused with the file and what is wrong instead of
//! being drawn as an empty or broken picture.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::RenderError;
use wetcloth::{Collider, Shape};

/// The largest `run.json` read, bytes (a run's is a few kilobytes).
pub const MAX_RUN_JSON_BYTES: u64 = 16 << 20;

/// The parts of `run.json` the renderer uses; other keys are ignored. [`read_run_info`]
/// checks every value it reads.
#[derive(Clone, Debug, Default)]
pub struct RunInfo {
    /// Scene name (names the MP4).
    pub name: String,
    /// Particles along x and z of the built-in grid; `[0, 0]` when `run.json` does not say,
    /// and for a cloth of any shape (see [`RunInfo::mesh`]).
    pub resolution: [usize; 2],
    /// A cloth of any shape (`run.json`'s `mesh`): its file and counts; `None` for the grid.
    pub mesh: Option<MeshInfo>,
    /// Particle collision radius, m.
    pub particle_radius: f64,
    /// Frames per simulated second.
    pub frame_rate: f64,
    /// Colliders, as the core describes them.
    pub colliders: Vec<Collider>,
    /// Grabbed particles of the grid as `[column, row]` (none for a cloth of any shape, whose
    /// particles have no column and row).
    pub grabs: Vec<[usize; 2]>,
    /// Frames the run wrote (`frame_0000.obj` up to `frames - 1`), when `run.json` says.
    pub frames: Option<u64>,
    /// How the run ended (`"running"`, `"complete"`, `"interrupted"`, `"failed"`), when
    /// `run.json` says.
    pub status: Option<String>,
}

/// `run.json`'s `mesh`: a cloth of any shape. Particle `k` is vertex `k` of every frame, and
/// every frame has the faces of the mesh file (polygons kept).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MeshInfo {
    /// The mesh file the scene named (for messages; empty when `run.json` does not say).
    pub file: String,
    /// Vertices of every frame (`v` lines).
    pub vertices: usize,
    /// Faces of every frame (`f` lines, each a polygon of 3 or more corners).
    pub faces: usize,
}

impl RunInfo {
    /// Vertices and triangles of every frame of this run, when the grid's resolution is known.
    pub fn mesh_size(&self) -> Option<(usize, usize)> {
        let [nx, nz] = self.resolution;
        (nx >= 2 && nz >= 2).then(|| (nx * nz, 2 * (nx - 1) * (nz - 1)))
    }
}

/// The most faces `run.json`'s `mesh` may have: four per vertex of the largest cloth.
const MAX_MESH_FACES: u64 = 4 * wetcloth::model::MAX_MESH_PARTICLES as u64;

/// `run.json` as written, every key optional.
#[derive(Deserialize)]
struct RawRunInfo {
    name: Option<String>,
    resolution: Option<[u64; 2]>,
    particle_radius: Option<f64>,
    frame_rate: Option<f64>,
    /// The colliders as written (a mesh by its copy in the run folder); read by
    /// `wetcloth_export::read_colliders`.
    colliders: Option<serde_json::Value>,
    grabs: Option<Vec<[u64; 2]>>,
    frames: Option<u64>,
    status: Option<String>,
    /// A cloth of any shape; its other keys (the copy, placement, bounds) are not read.
    mesh: Option<RawMeshInfo>,
}

/// `run.json`'s `mesh` as written.
#[derive(Deserialize)]
struct RawMeshInfo {
    file: Option<String>,
    vertices: Option<u64>,
    faces: Option<u64>,
}

impl RawMeshInfo {
    fn check(self) -> Result<MeshInfo, String> {
        let max = wetcloth::model::MAX_MESH_PARTICLES as u64;
        let vertices = match self.vertices {
            None => return Err("mesh.vertices is missing: a mesh run says how many".into()),
            Some(v) if (3..=max).contains(&v) => v as usize,
            Some(v) => {
                return Err(format!(
                    "mesh.vertices = {v} is out of range: allowed [3, {max}]"
                ));
            }
        };
        let faces = match self.faces {
            None => return Err("mesh.faces is missing: a mesh run says how many".into()),
            Some(f) if (1..=MAX_MESH_FACES).contains(&f) => f as usize,
            Some(f) => {
                return Err(format!(
                    "mesh.faces = {f} is out of range: allowed [1, {MAX_MESH_FACES}]"
                ));
            }
        };
        Ok(MeshInfo {
            file: self.file.unwrap_or_default(),
            vertices,
            faces,
        })
    }
}

/// The statuses a run can be in.
const STATUSES: [&str; 4] = ["running", "complete", "interrupted", "failed"];

impl RawRunInfo {
    /// The checked run information, or what is wrong (naming the key).
    fn check(self, run_dir: &Path) -> Result<RunInfo, String> {
        let mesh = self.mesh.map(RawMeshInfo::check).transpose()?;
        // A mesh run's resolution, if it has one, means nothing.
        let resolution = match self.resolution.filter(|_| mesh.is_none()) {
            None => [0, 0],
            Some(r) if r.iter().all(|n| (2..=4096).contains(n)) => r.map(|n| n as usize),
            Some(r) => {
                return Err(format!(
                    "resolution = [{}, {}] is out of range: each in [2, 4096]",
                    r[0], r[1]
                ));
            }
        };
        let particle_radius = self.particle_radius.unwrap_or(0.0);
        if !(particle_radius.is_finite() && (0.0..=0.1).contains(&particle_radius)) {
            return Err(format!(
                "particle_radius = {particle_radius:?} is out of range: allowed [0, 0.1] m"
            ));
        }
        let frame_rate = self.frame_rate.unwrap_or(30.0);
        if !(frame_rate.is_finite() && (1.0..=1e4).contains(&frame_rate)) {
            return Err(format!(
                "frame_rate = {frame_rate:?} is out of range: allowed [1, 10000] frames per second"
            ));
        }
        let mut colliders: Vec<Collider> = match &self.colliders {
            None => Vec::new(),
            Some(c) => wetcloth_export::read_colliders(run_dir, c)?,
        };
        for (i, c) in colliders.iter_mut().enumerate() {
            // wetcloth writes unit normals; any other non-zero one means the same plane.
            if let Shape::Plane(plane) = &mut c.shape {
                let n = plane.normal;
                if n.is_finite() && n.length() > 1e-6 {
                    plane.normal = n.normalize();
                }
            }
            // A plane's point is finite for the core; a picture needs it within reach too.
            if let Shape::Plane(plane) = &c.shape {
                let p = plane.point;
                let m = wetcloth::collide::MAX_POSITION;
                if p.abs().max_element() > m {
                    return Err(format!(
                        "colliders[{i}].point = [{}, {}, {}] is out of range: allowed each \
                         coordinate in [-{m:e}, {m:e}] m",
                        p.x, p.y, p.z
                    ));
                }
            }
            c.validate(i).map_err(|e| {
                let key = e.key().replace("collider[", "colliders[");
                match e {
                    wetcloth::ConfigError::OutOfRange { value, range, .. } => {
                        format!("{key} = {value} is out of range: allowed {range}")
                    }
                    wetcloth::ConfigError::Invalid { message, .. } => format!("{key}: {message}"),
                }
            })?;
        }
        // A mesh run's grabs name no column and row.
        let grabs = self.grabs.filter(|_| mesh.is_none()).unwrap_or_default();
        for (i, g) in grabs.iter().enumerate() {
            if resolution == [0, 0] {
                return Err(format!(
                    "grabs[{i}] = [{}, {}] names a particle, but there is no resolution to \
                     find it in",
                    g[0], g[1]
                ));
            }
            if g[0] >= resolution[0] as u64 || g[1] >= resolution[1] as u64 {
                return Err(format!(
                    "grabs[{i}] = [{}, {}] is outside the {} x {} cloth: columns 0..{}, rows \
                     0..{}",
                    g[0],
                    g[1],
                    resolution[0],
                    resolution[1],
                    resolution[0] - 1,
                    resolution[1] - 1
                ));
            }
        }
        if let Some(s) = &self.status
            && !STATUSES.contains(&s.as_str())
        {
            return Err(format!(
                "status = {s:?} is not a run status: allowed {}",
                STATUSES.map(|s| format!("\"{s}\"")).join(", ")
            ));
        }
        Ok(RunInfo {
            name: self.name.unwrap_or_default(),
            resolution,
            mesh,
            particle_radius,
            frame_rate,
            colliders,
            grabs: grabs.iter().map(|g| g.map(|n| n as usize)).collect(),
            frames: self.frames,
            status: self.status,
        })
    }
}

/// Reads `RUN_DIR/run.json`; `Ok(None)` when there is none. Every value the renderer uses is
/// checked: a resolution outside [2, 4096], a `mesh` without its vertex and face counts or with
/// counts out of range (a mesh run's `resolution` and `grabs` are not read), a negative or huge particle radius, a frame rate
/// outside [1, 10000], a collider with a non-finite or huge coordinate, a zero normal or a
/// non-positive size, a grab outside the cloth or an unknown status is refused, naming the key.
pub fn read_run_info(run_dir: &Path) -> Result<Option<RunInfo>, RenderError> {
    let path = run_dir.join("run.json");
    if std::fs::symlink_metadata(&path).is_err_and(|e| e.kind() == std::io::ErrorKind::NotFound) {
        return Ok(None);
    }
    let text = crate::read_limited(&path, MAX_RUN_JSON_BYTES)?;
    let raw: RawRunInfo = serde_json::from_str(&text).map_err(|e| RenderError::Parse {
        line: Some(e.line()),
        message: e.to_string(),
        path: path.clone(),
    })?;
    raw.check(run_dir)
        .map(Some)
        .map_err(|message| RenderError::Parse {
            path,
            line: None,
            message,
        })
}

/// A cloth frame read from OBJ: positions and triangle indices.
#[derive(Clone, Debug, Default)]
pub struct ObjMesh {
    /// Vertex positions, m.
    pub positions: Vec<[f32; 3]>,
    /// Triangle indices (each face as a fan of triangles from its first corner).
    pub indices: Vec<u32>,
    /// Faces (`f` lines) read, each a polygon of 3 or more corners.
    pub faces: usize,
    /// The grid size `[nx, nz]` named by the header comment wetcloth writes for the grid
    /// (`# wetcloth cloth mesh: NX x NZ particles`), if the file has one.
    pub header_resolution: Option<[usize; 2]>,
    /// The particles and faces `[n, f]` named by the header comment wetcloth writes for a cloth
    /// of any shape (`# wetcloth cloth mesh: N particles, F faces`), if the file has one.
    pub header_mesh: Option<[usize; 2]>,
}

/// Reads an OBJ mesh: every `v` line (positions keep their file order, so vertex k is
/// particle k) and every `f` line (polygons split into a fan of triangles from their first
/// corner for drawing; `v`, `v/vt`, `v/vt/vn`,
/// `v//vn` and negative, relative indices). Other lines (`vt`, `vn`, `o`, comments, ...) are
/// skipped.
///
/// Refused, with the file and the line: a line that is not text, a vertex without three
/// numbers or with a non-finite one (NaN, infinite, or beyond the 32-bit range), a face with
/// fewer than three corners or a corner that names no vertex defined above it, a file that
/// ends in the middle of a line (truncated), and a file without vertices or without faces.
pub fn read_obj(path: &Path) -> Result<ObjMesh, RenderError> {
    let file = std::fs::File::open(path).map_err(|e| RenderError::io(path, e))?;
    if !file
        .metadata()
        .map_err(|e| RenderError::io(path, e))?
        .is_file()
    {
        return Err(parse_error(path, None, "not a regular file".into()));
    }
    let mut reader = BufReader::new(file);
    let mut mesh = ObjMesh::default();
    let mut buf = Vec::new();
    let mut line_no = 0usize;
    let mut polygon: Vec<u32> = Vec::new();
    loop {
        buf.clear();
        let n = reader
            .read_until(b'\n', &mut buf)
            .map_err(|e| RenderError::io(path, e))?;
        if n == 0 {
            break;
        }
        line_no += 1;
        if buf.last() != Some(&b'\n') {
            return Err(parse_error(
                path,
                Some(line_no),
                "the file ends in the middle of a line: it is truncated".into(),
            ));
        }
        let line = std::str::from_utf8(&buf)
            .map_err(|_| parse_error(path, Some(line_no), "not text (invalid UTF-8)".into()))?;
        let err = |message: String| parse_error(path, Some(line_no), message);
        let mut words = line.split_ascii_whitespace();
        match words.next() {
            Some("v") => {
                let xyz: Vec<&str> = words.collect();
                if !(3..=4).contains(&xyz.len()) {
                    return Err(err(format!(
                        "a vertex needs 3 coordinates x y z, found {}",
                        xyz.len()
                    )));
                }
                let mut p = [0f32; 3];
                for (c, w) in p.iter_mut().zip(&xyz) {
                    let v: f32 = w
                        .parse()
                        .map_err(|_| err(format!("vertex coordinate {w:?} is not a number")))?;
                    if !v.is_finite() {
                        return Err(err(format!(
                            "vertex {} = ({}) is not finite: NaN, infinite or beyond the 32-bit \
                             range",
                            mesh.positions.len() + 1,
                            xyz[..3].join(", ")
                        )));
                    }
                    *c = v;
                }
                mesh.positions.push(p);
            }
            Some("f") => {
                polygon.clear();
                let count = mesh.positions.len();
                for corner in words {
                    let v = corner.split('/').next().unwrap_or("");
                    let k: i64 = v.parse().map_err(|_| {
                        err(format!(
                            "face corner {corner:?} does not start with a vertex number"
                        ))
                    })?;
                    let index = if k > 0 { k - 1 } else { count as i64 + k };
                    if k == 0 || index < 0 || index >= count as i64 {
                        return Err(err(format!(
                            "face corner {corner:?} names no vertex: {count} are defined above it"
                        )));
                    }
                    polygon.push(index as u32);
                }
                if polygon.len() < 3 {
                    return Err(err(format!(
                        "a face needs at least 3 corners, found {}",
                        polygon.len()
                    )));
                }
                for k in 1..polygon.len() - 1 {
                    mesh.indices
                        .extend([polygon[0], polygon[k], polygon[k + 1]]);
                }
                mesh.faces += 1;
            }
            Some("#") if mesh.header_resolution.is_none() && mesh.header_mesh.is_none() => {
                mesh.header_resolution = header_resolution(line);
                mesh.header_mesh = header_mesh(line);
            }
            _ => {}
        }
    }
    if mesh.positions.is_empty() {
        return Err(parse_error(
            path,
            None,
            "no vertices: the file is empty or truncated".into(),
        ));
    }
    if mesh.indices.is_empty() {
        return Err(parse_error(
            path,
            None,
            format!(
                "no faces after its {} vertices: the file is truncated or not a cloth mesh",
                mesh.positions.len()
            ),
        ));
    }
    Ok(mesh)
}

/// `[nx, nz]` from wetcloth's header comment `# wetcloth cloth mesh: NX x NZ particles`.
fn header_resolution(line: &str) -> Option<[usize; 2]> {
    let rest = line
        .trim()
        .strip_prefix("# wetcloth cloth mesh:")?
        .trim()
        .strip_suffix("particles")?;
    let (a, b) = rest.split_once('x')?;
    Some([a.trim().parse().ok()?, b.trim().parse().ok()?])
}

/// `[n, f]` from wetcloth's header comment of a cloth of any shape,
/// `# wetcloth cloth mesh: N particles, F faces`.
fn header_mesh(line: &str) -> Option<[usize; 2]> {
    let rest = line
        .trim()
        .strip_prefix("# wetcloth cloth mesh:")?
        .trim()
        .strip_suffix("faces")?;
    let (n, f) = rest.split_once("particles,")?;
    Some([n.trim().parse().ok()?, f.trim().parse().ok()?])
}

fn parse_error(path: &Path, line: Option<usize>, message: String) -> RenderError {
    RenderError::Parse {
        path: path.to_path_buf(),
        line,
        message,
    }
}

/// The cloth every frame of a run must be.
#[derive(Clone, Debug, PartialEq)]
enum Cloth {
    /// The built-in grid: `nx * nz` vertices, two triangles per cell.
    Grid([usize; 2]),
    /// A cloth of any shape: its vertices and faces (polygons), and its file, if known.
    Mesh {
        vertices: usize,
        faces: usize,
        file: String,
    },
}

/// Checks that the frames of a run are meshes of one cloth: the vertex and triangle counts of
/// the run's grid, or the vertex and face counts of its mesh (from `run.json`, or else the first
/// frame's header), and the same triangles as the first frame read (vertex k is particle k in
/// every frame).
#[derive(Debug, Default)]
pub(super) struct FrameCheck {
    /// The cloth and where it comes from.
    cloth: Option<(Cloth, String)>,
    /// The first frame checked, its vertex count and its triangles.
    reference: Option<(PathBuf, usize, Vec<u32>)>,
}

impl FrameCheck {
    /// A check against the run's cloth, if `run.json` gives it.
    pub(super) fn new(info: Option<&RunInfo>) -> Self {
        let cloth = info.and_then(|i| match &i.mesh {
            Some(m) => Some((
                Cloth::Mesh {
                    vertices: m.vertices,
                    faces: m.faces,
                    file: m.file.clone(),
                },
                "run.json's mesh".to_string(),
            )),
            None => i.mesh_size().map(|_| {
                (
                    Cloth::Grid(i.resolution),
                    "run.json's resolution".to_string(),
                )
            }),
        });
        Self {
            cloth,
            reference: None,
        }
    }

    /// Reads the frame at `path` and checks it.
    pub(super) fn read(&mut self, path: &Path) -> Result<ObjMesh, RenderError> {
        let mesh = read_obj(path)?;
        self.check(path, &mesh)?;
        Ok(mesh)
    }

    fn check(&mut self, path: &Path, mesh: &ObjMesh) -> Result<(), RenderError> {
        let refuse = |message: String| parse_error(path, None, message);
        if self.cloth.is_none() {
            let from = || format!("the header of {}", path.display());
            if let Some(r) = mesh.header_resolution
                && r.iter().all(|n| (2..=4096).contains(n))
            {
                self.cloth = Some((Cloth::Grid(r), from()));
            } else if let Some([n, f]) = mesh.header_mesh
                && n >= 3
                && f >= 1
            {
                let cloth = Cloth::Mesh {
                    vertices: n,
                    faces: f,
                    file: String::new(),
                };
                self.cloth = Some((cloth, from()));
            }
        }
        match &self.cloth {
            Some((Cloth::Grid([nx, nz]), from)) => {
                let (v, t) = (nx * nz, 2 * (nx - 1) * (nz - 1));
                if mesh.positions.len() != v {
                    return Err(refuse(format!(
                        "{} vertices where a {nx} x {nz} cloth ({from}) has {v}: the frame is \
                         truncated or from another run",
                        mesh.positions.len()
                    )));
                }
                if mesh.indices.len() / 3 != t {
                    return Err(refuse(format!(
                        "{} triangles where a {nx} x {nz} cloth ({from}) has {t}: the frame is \
                         truncated or from another run",
                        mesh.indices.len() / 3
                    )));
                }
            }
            Some((
                Cloth::Mesh {
                    vertices,
                    faces,
                    file,
                },
                from,
            )) => {
                let name = match Path::new(file).file_name() {
                    Some(f) => format!("the mesh cloth {}", f.to_string_lossy()),
                    None => "the mesh cloth".to_string(),
                };
                if mesh.positions.len() != *vertices {
                    return Err(refuse(format!(
                        "{} vertices where {name} ({from}) has {vertices}: the frame is \
                         truncated or from another run",
                        mesh.positions.len()
                    )));
                }
                if mesh.faces != *faces {
                    return Err(refuse(format!(
                        "{} faces where {name} ({from}) has {faces}: the frame is truncated or \
                         from another run",
                        mesh.faces
                    )));
                }
            }
            None => {}
        }
        match &self.reference {
            None => {
                self.reference = Some((
                    path.to_path_buf(),
                    mesh.positions.len(),
                    mesh.indices.clone(),
                ));
            }
            Some((first, vertices, indices)) => {
                if *vertices != mesh.positions.len() {
                    return Err(refuse(format!(
                        "{} vertices where {} has {vertices} (every frame of a run has one \
                         vertex per particle): the frame is truncated or from another run",
                        mesh.positions.len(),
                        first.display()
                    )));
                }
                if *indices != mesh.indices {
                    return Err(refuse(format!(
                        "its faces differ from those of {} (every frame of a run is the \
                         same mesh, vertex k being particle k): the frame is damaged or from \
                         another run",
                        first.display()
                    )));
                }
            }
        }
        Ok(())
    }
}
