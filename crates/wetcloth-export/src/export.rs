//! Exporting a run folder to caches: read `run.json`, `scene.toml` and the frames one by one,
//! feed every cache writer, and put each file in place when it is complete.

use crate::abc::AbcWriter;
use crate::cache::{CacheFormat, CacheSpec, CacheWriter, Frame};
use crate::params::{SceneParam, scene_params};
use crate::pointcache::{MddWriter, Pc2Writer};
use crate::read::{FrameBuffers, read_obj_frame};
use crate::usd::{UsdaWriter, UsdcWriter};
use crate::{RunInfo, frame_file_name};
use std::fs::{self, File};
use std::io::{self, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use wetcloth::{ClothParams, ClothSurface, Vec3};

/// Name of the rest mesh in a run folder.
pub const REST_OBJ: &str = "rest.obj";

/// One cache to write: its format and file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExportJob {
    /// The format.
    pub format: CacheFormat,
    /// The file; it appears only when complete (written as `FILE.part`, then renamed).
    pub out: PathBuf,
}

impl ExportJob {
    /// The default file of `format` for a run: `RUN_DIR/<scene name>.<extension>`.
    pub fn default_out(run_dir: &Path, run: &RunInfo, format: CacheFormat) -> PathBuf {
        run_dir.join(format!("{}.{}", run.name, format.extension()))
    }
}

/// Why an export failed.
#[derive(Debug)]
pub enum ExportError {
    /// The run folder is missing, incomplete or damaged (bad input; the message names the file
    /// and what is wrong).
    Input(String),
    /// An output could not be written.
    Output {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
}

impl std::fmt::Display for ExportError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ExportError::Input(m) => f.write_str(m),
            ExportError::Output { path, source } => {
                write!(f, "cannot write {}: {source}", path.display())
            }
        }
    }
}

impl std::error::Error for ExportError {}

fn output(path: &Path) -> impl FnOnce(io::Error) -> ExportError + '_ {
    move |source| ExportError::Output {
        path: path.to_path_buf(),
        source,
    }
}

/// What [`export_run`] read from the run folder.
#[derive(Clone, Debug)]
pub struct RunFolder {
    /// `run.json`.
    pub info: RunInfo,
    /// The scene's parameters (from `scene.toml`; empty when the folder has none).
    pub params: Vec<SceneParam>,
    /// The cloth's faces and texture coordinates, as the frames have them: the grid's, or a
    /// mesh cloth's read from its copy in the folder (`run.json`'s `mesh.copy`).
    pub surface: ClothSurface,
}

/// Reads `run.json` and `scene.toml` of a run folder and checks that frames can be exported.
///
/// # Errors
///
/// [`ExportError::Input`] naming the folder or file and what is wrong.
pub fn read_run_folder(run_dir: &Path) -> Result<RunFolder, ExportError> {
    if !run_dir.is_dir() {
        return Err(ExportError::Input(format!(
            "{}: no such run folder (expected the output folder of `wetcloth run`, holding \
             run.json and frames/)",
            run_dir.display()
        )));
    }
    let json = run_dir.join("run.json");
    let text = fs::read_to_string(&json)
        .map_err(|e| ExportError::Input(format!("{}: cannot read: {e}", json.display())))?;
    let info: RunInfo = crate::read_run_json(run_dir, &text).map_err(ExportError::Input)?;
    let surface = match (&info.mesh, info.resolution) {
        (Some(m), _) => {
            let src = crate::read_cloth_copy(run_dir, m)
                .map_err(|e| ExportError::Input(format!("{}: {e}", json.display())))?;
            ClothSurface::new(&ClothParams {
                position: Vec3::from(m.position),
                mesh: Some(src),
                ..ClothParams::default()
            })
        }
        (None, Some([nx, nz])) => {
            if nx < 2 || nz < 2 {
                return Err(ExportError::Input(format!(
                    "{}: resolution = [{nx}, {nz}]: each must be at least 2",
                    json.display()
                )));
            }
            if nx.checked_mul(nz).is_none_or(|n| n > i32::MAX as usize) {
                return Err(ExportError::Input(format!(
                    "{}: resolution = [{nx}, {nz}]: more particles than a cache can hold \
                     (2^31 - 1)",
                    json.display()
                )));
            }
            let size = info.size.ok_or_else(|| {
                ExportError::Input(format!(
                    "{}: not a wetcloth run.json: resolution without size",
                    json.display()
                ))
            })?;
            ClothSurface::new(&ClothParams {
                resolution: [nx, nz],
                size,
                ..ClothParams::default()
            })
        }
        (None, None) => {
            return Err(ExportError::Input(format!(
                "{}: not a wetcloth run.json: it describes no cloth (neither resolution nor \
                 mesh)",
                json.display()
            )));
        }
    };
    if info.frames == 0 {
        return Err(ExportError::Input(format!(
            "{}: frames = 0: the run wrote no frame to export",
            json.display()
        )));
    }
    if !(info.frame_rate.is_finite() && info.frame_rate > 0.0) {
        return Err(ExportError::Input(format!(
            "{}: frame_rate = {}: must be a positive number of frames per second",
            json.display(),
            info.frame_rate
        )));
    }
    let scene = run_dir.join("scene.toml");
    let params = match fs::read_to_string(&scene) {
        Ok(text) => scene_params(&text)
            .map_err(|e| ExportError::Input(format!("{}: {e}", scene.display())))?,
        Err(e) if e.kind() == io::ErrorKind::NotFound => Vec::new(),
        Err(e) => {
            return Err(ExportError::Input(format!(
                "{}: cannot read: {e}",
                scene.display()
            )));
        }
    };
    Ok(RunFolder {
        info,
        params,
        surface,
    })
}

/// Writes `RUN_DIR/rest.obj`, the mesh the point caches apply to: a copy of frame 0 (vertex `k`
/// is particle `k`, as in every frame). Written as `rest.obj.part` and renamed.
///
/// # Errors
///
/// The I/O error, with the file it concerns.
pub fn write_rest_obj(run_dir: &Path) -> Result<(), ExportError> {
    let frame0 = run_dir.join("frames").join(frame_file_name(0));
    let rest = run_dir.join(REST_OBJ);
    let part = run_dir.join(format!("{REST_OBJ}.part"));
    match fs::copy(&frame0, &part) {
        Ok(_) => {}
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Err(ExportError::Input(format!(
                "{}: cannot read: {e}",
                frame0.display()
            )));
        }
        Err(e) => return Err(output(&part)(e)),
    }
    fs::rename(&part, &rest).map_err(output(&rest))
}

/// Exports the run in `run_dir` to every cache of `jobs` in one pass over its frames, then
/// writes `rest.obj`. `progress(done, total)` is called after each frame.
///
/// # Errors
///
/// [`ExportError::Input`] for a missing or damaged run folder: a missing `run.json`, a frame
/// that is missing, malformed, truncated or of another vertex count than `run.json` says (the
/// message names the file, and the line where it can). [`ExportError::Output`] when a cache
/// cannot be written. A failed export leaves its caches as `FILE.part`.
pub fn export_run(
    run_dir: &Path,
    jobs: &[ExportJob],
    progress: &mut dyn FnMut(u64, u64),
) -> Result<RunFolder, ExportError> {
    let folder = read_run_folder(run_dir)?;
    let info = &folder.info;
    let spec = CacheSpec {
        run: info,
        frames: info.frames,
        surface: &folder.surface,
        params: &folder.params,
    };

    let mut writers = Vec::with_capacity(jobs.len());
    for job in jobs {
        let part = part_path(&job.out);
        let w = open_writer(job.format, &part, &spec).map_err(|e| {
            if e.kind() == io::ErrorKind::InvalidInput {
                ExportError::Input(format!("{}: {e}", run_dir.join("run.json").display()))
            } else {
                output(&part)(e)
            }
        })?;
        writers.push((w, part));
    }

    let frames_dir = run_dir.join("frames");
    let mut bufs = FrameBuffers::default();
    for k in 0..info.frames {
        let path = frames_dir.join(frame_file_name(k));
        read_obj_frame(
            &path,
            spec.vertices(),
            folder.surface.face_count(),
            &mut bufs,
        )
        .map_err(|e| {
            let hint = if e.io {
                format!(" (run.json says the run wrote {} frames)", info.frames)
            } else {
                String::new()
            };
            let mut e = e.to_string();
            if info.mesh.is_some() {
                e = e.replace("run.json's resolution", "run.json's mesh");
            }
            ExportError::Input(format!("{e}{hint}"))
        })?;
        let frame = Frame {
            index: k,
            positions: &bufs.positions,
            normals: &bufs.normals,
        };
        for (w, part) in &mut writers {
            w.write_frame(&frame).map_err(output(part))?;
        }
        progress(k + 1, info.frames);
    }
    for ((w, part), job) in writers.into_iter().zip(jobs) {
        w.finish().map_err(output(&part))?;
        fs::rename(&part, &job.out).map_err(output(&job.out))?;
    }
    write_rest_obj(run_dir)?;
    Ok(folder)
}

/// `FILE.part`.
fn part_path(out: &Path) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(".part");
    PathBuf::from(s)
}

/// A cache writer of `format` writing to a new file at `path`.
fn open_writer(
    format: CacheFormat,
    path: &Path,
    spec: &CacheSpec<'_>,
) -> io::Result<Box<dyn CacheWriter>> {
    let file = BufWriter::with_capacity(1 << 20, File::create(path)?);
    Ok(match format {
        CacheFormat::Pc2 => Box::new(Pc2Writer::new(file, spec)?),
        CacheFormat::Mdd => Box::new(MddWriter::new(file, spec)?),
        CacheFormat::Usdc => Box::new(UsdcWriter::new(file, spec)?),
        CacheFormat::Abc => Box::new(AbcWriter::new(file, spec)?),
        CacheFormat::Usda => Box::new(UsdaWriter::new(file, spec, |attr| {
            let mut s = path.as_os_str().to_owned();
            s.push(format!(".{attr}"));
            SpillFile::create(PathBuf::from(s))
        })?),
    })
}

/// A temporary file next to the output, removed when dropped.
struct SpillFile {
    file: BufWriter<File>,
    path: PathBuf,
}

impl SpillFile {
    fn create(path: PathBuf) -> io::Result<Self> {
        let file = fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(&path)?;
        Ok(Self {
            file: BufWriter::with_capacity(1 << 20, file),
            path,
        })
    }
}

impl Drop for SpillFile {
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.path);
    }
}

impl Write for SpillFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

impl Read for SpillFile {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.file.flush()?;
        self.file.get_mut().read(buf)
    }
}

impl Seek for SpillFile {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.file.seek(pos)
    }
}
