//! `wetcloth.run`: the command line's `run` from Python: frames at the same steps, the same
//! metrics, and with `out` the same folder (frames, rest.obj, metrics.csv, pockets.csv,
//! grabs.csv, scene.toml, run.json, a mesh cloth's copy in meshes/; no checkpoints).

use crate::scene::Scene;
use crate::sim::pool;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::PyOSError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use wetcloth::{ClothSurface, Real, Simulation};
use wetcloth_export::{
    GrabsCsv, MetricsCsv, PocketsCsv, RunInfo, RunStatus, create_fresh, frame_file_name,
    frame_step, is_frame_file_name, is_pocket_labels_file_name, last_frame, particle_pocket_ids,
    pocket_labels_file_name, write_atomically, write_obj, write_pocket_labels, write_run_json_file,
};

/// What a run recorded: rows of `metrics.csv` and `pockets.csv` as numbers, and the frames'
/// positions when asked for.
#[derive(Default)]
struct Record {
    metrics: Vec<Vec<f64>>,
    pockets: Vec<Vec<f64>>,
    frames: Vec<Vec<f64>>,
    /// `failed` and the command line's message, when the run blew up.
    failure: Option<String>,
    time: Real,
    written: u64,
}

/// The files of the run folder `dir`, when the run writes one.
struct Folder {
    dir: PathBuf,
    metrics: MetricsCsv<fs::File>,
    pockets: PocketsCsv<fs::File>,
    grabs: GrabsCsv<fs::File>,
    /// The faces and texture coordinates of the frames.
    surface: ClothSurface,
}

fn io_at(path: &Path) -> impl FnOnce(std::io::Error) -> String + '_ {
    move |e| format!("{}: {e}", path.display())
}

impl Folder {
    /// Prepares `dir` as the command line does: frame and label files of an earlier run
    /// removed, `scene.toml` written, fresh CSV files.
    fn create(dir: &Path, scene: &wetcloth_scene::Scene) -> Result<Self, String> {
        let frames = dir.join("frames");
        fs::create_dir_all(&frames).map_err(io_at(&frames))?;
        for entry in fs::read_dir(&frames).map_err(io_at(&frames))? {
            let entry = entry.map_err(io_at(&frames))?;
            let name = entry.file_name().to_string_lossy().into_owned();
            let base = name.strip_suffix(".part").unwrap_or(&name);
            let stale = is_frame_file_name(base) || is_pocket_labels_file_name(base);
            if stale && entry.file_type().is_ok_and(|t| !t.is_dir()) {
                fs::remove_file(entry.path()).map_err(io_at(&entry.path()))?;
            }
        }
        let _ = fs::remove_file(dir.join("checkpoint.bin"));
        let scene_path = dir.join("scene.toml");
        write_atomically(&scene_path, |w| w.write_all(scene.to_toml().as_bytes()))
            .map_err(io_at(&scene_path))?;
        let m = dir.join("metrics.csv");
        let metrics = MetricsCsv::new(create_fresh(&m).map_err(io_at(&m))?).map_err(io_at(&m))?;
        let p = dir.join("pockets.csv");
        let pockets = PocketsCsv::new(create_fresh(&p).map_err(io_at(&p))?).map_err(io_at(&p))?;
        let g = dir.join("grabs.csv");
        let grabs = GrabsCsv::new(create_fresh(&g).map_err(io_at(&g))?).map_err(io_at(&g))?;
        let meshes = dir.join("meshes");
        wetcloth_export::write_mesh_copies(dir, &scene.config.colliders).map_err(io_at(&meshes))?;
        if let Some(m) = &scene.config.cloth.mesh {
            wetcloth_export::write_cloth_copy(dir, m).map_err(io_at(&meshes))?;
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            metrics,
            pockets,
            grabs,
            surface: ClothSurface::new(&scene.config.cloth),
        })
    }

    fn write_frame(&mut self, sim: &Simulation, k: u64) -> Result<(), String> {
        let path = self.dir.join("frames").join(frame_file_name(k));
        let normals = self.surface.vertex_normals(sim.positions());
        write_atomically(&path, |w| {
            write_obj(w, &self.surface, sim.positions(), &normals)
        })
        .map_err(io_at(&path))?;
        let m = self.dir.join("metrics.csv");
        self.metrics
            .write_row(k, &sim.metrics())
            .map_err(io_at(&m))?;
        let p = self.dir.join("pockets.csv");
        self.pockets
            .write_frame(k, sim.time(), &sim.pocket_reports())
            .map_err(io_at(&p))?;
        let g = self.dir.join("grabs.csv");
        self.grabs
            .write_frame(k, sim.time(), &sim.grab_forces())
            .map_err(io_at(&g))?;
        if let Some(labels) = particle_pocket_ids(sim) {
            let path = self.dir.join("frames").join(pocket_labels_file_name(k));
            write_atomically(&path, |w| write_pocket_labels(w, &labels)).map_err(io_at(&path))?;
        }
        if k == 0 {
            wetcloth_export::write_rest_obj(&self.dir).map_err(|e| e.to_string())?;
        }
        Ok(())
    }

    fn write_json(&self, info: &RunInfo) -> Result<(), String> {
        let path = self.dir.join("run.json");
        write_run_json_file(&path, info).map_err(io_at(&path))
    }
}

/// Runs `scene` frame by frame; an error is an output error (a blow-up is recorded).
fn bake(
    scene: &wetcloth_scene::Scene,
    mut sim: Simulation,
    out: Option<&Path>,
    keep_frames: bool,
) -> Result<Record, String> {
    let config = &scene.config;
    let base = RunInfo::new(&scene.name, config, 0, false);
    let info = |frames: u64, status: RunStatus, time: Real| {
        let mut i = base.clone().with_status(status, time);
        i.frames = frames;
        i
    };
    let mut folder = match out {
        Some(dir) => {
            fs::create_dir_all(dir).map_err(io_at(dir))?;
            let f = Folder::create(dir, scene)?;
            f.write_json(&info(0, RunStatus::Running, 0.0))?;
            Some(f)
        }
        None => None,
    };
    let mut rec = Record::default();
    let last = last_frame(config);
    let (rate, dt) = (config.simulation.frame_rate, config.simulation.time_step);
    for k in 0..=last {
        let target = frame_step(k, rate, dt);
        if let Err(e) = sim.advance(target.saturating_sub(sim.step_count())) {
            // The command line's message (as its run.json and stderr say it); the core's
            // alone without a folder.
            let message = match out {
                Some(dir) => format!(
                    "{e}\n  the {} frame(s) and metrics rows written before it are in {}",
                    rec.written,
                    dir.display()
                ),
                None => e.to_string(),
            };
            if let Some(f) = &folder {
                f.write_json(
                    &info(rec.written, RunStatus::Running, rec.time).failed(message.clone()),
                )?;
            }
            rec.failure = Some(message);
            return Ok(rec);
        }
        let m = sim.metrics();
        rec.metrics
            .push(std::iter::once(k as f64).chain(m.values()).collect());
        for p in sim.pocket_reports() {
            rec.pockets.push(vec![
                k as f64,
                sim.time(),
                p.id as f64,
                p.volume,
                p.amount,
                p.pressure,
                p.area,
                p.particles as f64,
            ]);
        }
        if keep_frames {
            let x = sim.positions();
            rec.frames.push(
                (0..x.len())
                    .flat_map(|i| [x.x[i], x.y[i], x.z[i]])
                    .collect(),
            );
        }
        if let Some(f) = &mut folder {
            f.write_frame(&sim, k)?;
        }
        (rec.written, rec.time) = (k + 1, sim.time());
        if let Some(f) = &folder {
            let status = if k == last {
                RunStatus::Complete
            } else {
                RunStatus::Running
            };
            f.write_json(&info(rec.written, status, rec.time))?;
        }
    }
    Ok(rec)
}

/// Runs `scene` as `wetcloth run` does (into `out` when given) and returns what it recorded:
/// `status`, `message`, `frames_written`, `time`, `metrics` and `pockets` (lists of rows in
/// the CSV files' columns), `frames` (a list of `(n, 3)` arrays, or None). A blow-up is a
/// `failed` status, not an exception; a scene that cannot make a simulation raises
/// `SceneError`, an output error `OSError`.
#[pyfunction]
#[pyo3(signature = (scene, out = None, frames = true, threads = 0))]
pub fn run_scene<'py>(
    py: Python<'py>,
    scene: &Scene,
    out: Option<PathBuf>,
    frames: bool,
    threads: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let sim = Simulation::new(scene.inner.config.clone())
        .map_err(|e| crate::convert::scene_error(py, &scene.inner.locate(&e)))?;
    let pool = pool(threads)?;
    let inner = &scene.inner;
    let n = sim.particle_count();
    let rec = py
        .detach(|| pool.install(|| bake(inner, sim, out.as_deref(), frames)))
        .map_err(PyOSError::new_err)?;
    let d = PyDict::new(py);
    d.set_item(
        "status",
        if rec.failure.is_some() {
            RunStatus::Failed.name()
        } else {
            RunStatus::Complete.name()
        },
    )?;
    d.set_item("message", rec.failure.clone().unwrap_or_default())?;
    d.set_item("frames_written", rec.written)?;
    d.set_item("time", rec.time)?;
    d.set_item("metrics", rec.metrics)?;
    d.set_item("pockets", rec.pockets)?;
    if frames {
        let arrays: PyResult<Vec<_>> = rec
            .frames
            .into_iter()
            .map(|f| {
                let a = PyArray1::from_vec(py, f).reshape([n, 3])?;
                a.getattr("flags")?.setattr("writeable", false)?;
                Ok(a)
            })
            .collect();
        d.set_item("frames", arrays?)?;
    } else {
        d.set_item("frames", py.None())?;
    }
    d.set_item("out", out)?;
    Ok(d)
}
