//! `wetcloth run [SCENE] [--out DIR]`: run a scene and write its frames and metrics.
//!
//! The run directory holds `frames/frame_NNNN.obj` (one mesh per written frame), `rest.obj` (a
//! copy of frame 0, the mesh point caches apply to), `metrics.csv` (one row per frame), `pockets.csv` (one row per sealed air pocket per frame),
//! `grabs.csv` (one row per scene grab per frame: its particles and force on the cloth),
//! `meshes/` (copies of the mesh files the scene read, a mesh cloth's among them),
//! `scene.toml` (the scene with every key explicit) and `run.json`; with `--export`, caches. Frame
//! `k` is the state at the first step whose time is at least `k / frame_rate`; frame 0 is the
//! state at t = 0. Every file is complete on disk as soon as it is named: frames, `scene.toml`
//! and `run.json` are written to `NAME.part` (never following a link left there) and renamed,
//! metrics rows are flushed one by one, so a run that blows up (or is interrupted) leaves a
//! complete prefix. `run.json` is written first (status `running`), then after every frame, and
//! last with how the run ended: `complete`, `interrupted` (Ctrl-C, SIGTERM: exit 130) or
//! `failed` (with the error), with the frames written and the time reached.

use crate::checkpoint;
use crate::error::CliError;
use crate::estimate::{self, Available};
use crate::interrupt::Interrupt;
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use std::fs;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use wetcloth::metrics::COLUMNS;
use wetcloth::{ClothSurface, Real, Simulation};
use wetcloth_export::{
    GrabsCsv, MetricsCsv, PocketsCsv, RunInfo, RunStatus, create_fresh, frame_file_name,
    is_frame_file_name, write_atomically, write_obj,
};
use wetcloth_scene::Scene;

/// Arguments of `wetcloth run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// Scene file (TOML). Without one, the built-in thesis demo runs: a 30 cm satin cloth,
    /// 50 x 50 particles, with 400 cm^3 of air under it, pinched at its centre and lifted 5 cm
    /// with the air force on.
    pub scene: Option<PathBuf>,

    /// Output directory; default out/NAME, NAME being the scene's name. Frame files of an
    /// earlier run there are removed first.
    #[arg(long, short, value_name = "DIR")]
    pub out: Option<PathBuf>,

    /// Worker threads for the simulation (default: all cores, or RAYON_NUM_THREADS). Results do
    /// not depend on it. May also be given before the command: `wetcloth --threads N run`.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub threads: Option<u32>,

    /// Run even when the estimate says the run needs more memory or disk than this machine
    /// has (the estimate is printed before large runs; without this flag such a run is
    /// refused before anything is written).
    #[arg(long)]
    pub force: bool,

    /// Write a checkpoint (`checkpoint.bin`, the full state, replaced atomically) after every
    /// N-th frame, starting with frame 0, and whenever the run is interrupted; 0 writes one
    /// only when interrupted. A complete run removes it. With --resume, the interval of the run
    /// being continued is kept.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_CHECKPOINT_EVERY)]
    pub checkpoint_every: u64,

    /// Continue the interrupted, killed or failed run in DIR from its last checkpoint: the
    /// finished folder is byte for byte what an uninterrupted run writes, with any thread
    /// count. A SCENE given too must be the run's scene. Refused (exit 2, naming the file)
    /// when DIR holds no checkpoint or a complete run, when its scene.toml was changed, or
    /// when the checkpoint is damaged.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["out", "force", "set"])]
    pub resume: Option<PathBuf>,

    /// Override one key of the scene for this run (repeatable, applied in order): KEY is a
    /// dotted key path (`cloth.mass`, `air.trapped_air`, `collider.0.friction`), VALUE is in TOML
    /// syntax (`0.05`, `[0.2,0.2]`, `true`), a bare word taken as a string
    /// (`--set air.model=pockets`). Checked as the scene file is; the resolved scene.toml has it.
    #[arg(long, value_name = "KEY=VALUE")]
    pub set: Vec<String>,

    /// Also write these caches when the run completes, as `wetcloth export` does: a comma list
    /// of pc2, mdd, usda, usdc, abc (e.g. `usdc,pc2`), each to DIR/<scene name>.<extension>.
    #[arg(long, value_name = "FORMATS", value_parser = crate::export::parse_format_list)]
    pub export: Option<crate::export::FormatList>,
}

/// Units of the metrics columns, for the summary.
const UNITS: [&str; 9] = ["s", "m^3", "Pa", "J", "", "", "m", "N", "m^3"];

// Frame timing lives with the run folder's format, where the Python package's runs find it too.
pub use wetcloth_export::{frame_step, last_frame};

/// Wall-clock time one call to `Simulation::advance` aims at, s: short enough that Ctrl-C and
/// the progress bar answer at once, long enough that the calls cost nothing.
const CHUNK_SECONDS: f64 = 0.1;

/// How a run that did not fail ended.
enum Ending {
    Complete,
    Interrupted,
}

/// Frames between checkpoints unless `--checkpoint-every` says otherwise.
pub const DEFAULT_CHECKPOINT_EVERY: u64 = 10;

/// Where a run starts: from t = 0, or from a checkpoint of an earlier run in the same folder.
struct Start {
    /// The next frame to write.
    frames: u64,
    /// Simulated time of the last frame written, s.
    time: Real,
    /// Frames between checkpoints.
    every: u64,
    /// For a resumed run: the byte lengths to cut `metrics.csv` and `pockets.csv` back to,
    /// that of `grabs.csv` (`None` for a checkpoint of a version that wrote none: it starts
    /// again from the resumed frame), and the checkpoint it continues from (for `run.json`).
    resumed: Option<(u64, u64, Option<u64>, CheckpointNote)>,
    /// For a resumed run with attachments: the byte length to cut `attachments.csv` back to.
    attach_cut: Option<u64>,
}

/// Where the last checkpoint is and how far it had got: the `checkpoint` object of `run.json`
/// (absent once the run is complete, when the checkpoint is removed).
#[derive(Clone, Copy, Debug, Serialize)]
struct CheckpointNote {
    /// The file, in the run folder: always `checkpoint.bin`.
    file: &'static str,
    /// Frames written when it was taken; a resumed run writes from this frame on.
    frames: u64,
    /// Steps taken when it was taken.
    step: u64,
    /// Simulated time when it was taken, s.
    time: Real,
}

/// `run.json`: the export crate's [`RunInfo`] and, while the run is not complete, where its
/// last checkpoint is.
#[derive(Serialize)]
struct RunJson<'a> {
    #[serde(flatten)]
    info: &'a RunInfo,
    #[serde(skip_serializing_if = "Option::is_none")]
    checkpoint: Option<CheckpointNote>,
}

/// Runs `wetcloth run`.
pub fn run(args: &RunArgs, quiet: bool) -> Result<(), CliError> {
    if let Some(dir) = &args.resume {
        return resume(args, dir, quiet);
    }
    let mut scene = match &args.scene {
        Some(path) => wetcloth_scene::load(path)?,
        None => Scene::thesis_demo(),
    };
    for pair in &args.set {
        let Some((key, value)) = pair.split_once('=') else {
            return Err(CliError::Usage(format!(
                "--set {pair}: expected KEY=VALUE, e.g. --set cloth.mass=0.05"
            )));
        };
        scene.set(key.trim(), wetcloth_scene::parse_value(value))?;
    }
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(&scene.name));
    let config = scene.config.clone();

    // What the run needs, before anything is allocated or written.
    let est = estimate::estimate(&config, rayon::current_num_threads());
    if !args.force
        && let Some(why) = estimate::refusal(&est, Available::here(&dir), &config)
    {
        return Err(CliError::Usage(why));
    }
    if est.is_large() && !quiet {
        eprintln!("wetcloth: {} needs {}", scene.name, est.summary());
    }

    let sim = Simulation::new(config.clone()).map_err(|e| scene.locate(&e))?;
    let start = Start {
        frames: 0,
        time: 0.0,
        every: args.checkpoint_every,
        resumed: None,
        attach_cut: None,
    };
    bake(args, &scene, &dir, sim, start, quiet)
}

/// Runs `wetcloth run --resume DIR`: checks that `dir` holds a run that can go on, and goes
/// on from its last checkpoint.
fn resume(args: &RunArgs, dir: &Path, quiet: bool) -> Result<(), CliError> {
    let nothing =
        |why: String| CliError::Input(format!("nothing to resume in {}: {why}", dir.display()));
    if !dir.is_dir() {
        return Err(nothing("no such folder".into()));
    }
    let json_path = dir.join("run.json");
    let status = match fs::read(&json_path) {
        Ok(bytes) => serde_json::from_slice::<serde_json::Value>(&bytes)
            .ok()
            .and_then(|v| v.get("status").and_then(|s| s.as_str()).map(String::from))
            .ok_or_else(|| {
                CliError::Input(format!(
                    "{} is damaged: not the run.json of a wetcloth run",
                    json_path.display()
                ))
            })?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(nothing(format!("{} not found", json_path.display())));
        }
        Err(e) => {
            return Err(CliError::Input(format!(
                "cannot read {}: {e}",
                json_path.display()
            )));
        }
    };
    let ckpt_path = checkpoint::path(dir);
    if status == RunStatus::Complete.name() {
        // A run killed between its last run.json and removing its checkpoint: the run is
        // complete, so the checkpoint is of no use.
        let _ = fs::remove_file(&ckpt_path);
        return Err(nothing(format!(
            "the run is complete ({} says \"complete\")",
            json_path.display()
        )));
    }
    let Some(saved) = checkpoint::read(dir)? else {
        return Err(nothing(format!(
            "{} not found (the run stopped before its first checkpoint, or was run with \
             --checkpoint-every 0); run the scene again",
            ckpt_path.display()
        )));
    };
    let scene_path = dir.join("scene.toml");
    let toml = match fs::read(&scene_path) {
        Ok(t) => t,
        Err(e) => {
            return Err(CliError::Input(format!(
                "cannot read {}: {e}; a run folder to resume holds the scene it ran",
                scene_path.display()
            )));
        }
    };
    if checkpoint::digest(&toml) != saved.scene_digest {
        return Err(CliError::Input(format!(
            "{} does not match {}: the scene was changed after the checkpoint was written",
            scene_path.display(),
            ckpt_path.display()
        )));
    }
    let scene = load_run_scene(dir, &scene_path, &toml)?;
    // The files the run read besides its scene (meshes) must hold what they held.
    let now = checkpoint::inputs(&scene.config);
    for (k, (file, was)) in saved.inputs.iter().enumerate() {
        match now.get(k) {
            Some((f, d)) if f == file && d == was => {}
            _ => {
                return Err(CliError::Input(format!(
                    "{file} changed since the run in {} started (the run read a mesh of digest \
                     {was:016x}, the file now holds {}): a resumed run must read what the run \
                     read; put the file back or run the scene again",
                    dir.display(),
                    now.get(k)
                        .map_or("something else".into(), |(_, d)| format!("digest {d:016x}"))
                )));
            }
        }
    }
    if let Some(given) = &args.scene {
        let other = wetcloth_scene::load(given)?;
        if checkpoint::digest(other.to_toml().as_bytes()) != saved.scene_digest {
            return Err(CliError::Input(format!(
                "{} is not the scene of the run in {} (its scene.toml differs); give no scene \
                 to resume that run",
                given.display(),
                dir.display()
            )));
        }
    }
    let damaged =
        |why: String| CliError::Input(format!("{} is damaged: {why}", ckpt_path.display()));
    let last = last_frame(&scene.config);
    if saved.frames > last {
        return Err(damaged(format!(
            "it says {} frames were written, the scene has {}",
            saved.frames,
            last + 1
        )));
    }
    let (csv_len, pockets_len, grabs_len, attach_len) = match saved.appended.as_slice() {
        [(a, m), (b, p), (c, g)] if a == "metrics.csv" && b == "pockets.csv" && c == GRABS_CSV => {
            (*m, *p, Some(*g), None)
        }
        [(a, m), (b, p), (c, g), (d, t)]
            if a == "metrics.csv"
                && b == "pockets.csv"
                && c == GRABS_CSV
                && d == ATTACHMENTS_CSV =>
        {
            (*m, *p, Some(*g), Some(*t))
        }
        // Taken by a version that wrote no grabs.csv.
        [(a, m), (b, p)] if a == "metrics.csv" && b == "pockets.csv" => (*m, *p, None, None),
        _ => {
            return Err(damaged(
                "it does not list metrics.csv, pockets.csv and grabs.csv".into(),
            ));
        }
    };
    let appended = [
        ("metrics.csv", Some(csv_len)),
        ("pockets.csv", Some(pockets_len)),
        (GRABS_CSV, grabs_len),
        (ATTACHMENTS_CSV, attach_len),
    ];
    for (name, len) in appended.into_iter().filter_map(|(n, l)| l.map(|l| (n, l))) {
        let path = dir.join(name);
        let have = fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        if have < len {
            return Err(CliError::Input(format!(
                "{} holds {have} bytes, fewer than the {len} of the {} frame(s) {} was taken \
                 after; run the scene again",
                path.display(),
                saved.frames,
                ckpt_path.display()
            )));
        }
    }
    let frames_dir = dir.join("frames");
    if let Some(k) = (0..saved.frames).find(|&k| !frames_dir.join(frame_file_name(k)).is_file()) {
        return Err(CliError::Input(format!(
            "{} is missing: the frames before the checkpoint must be there to resume; run the \
             scene again",
            frames_dir.join(frame_file_name(k)).display()
        )));
    }
    let note = CheckpointNote {
        file: checkpoint::FILE_NAME,
        frames: saved.frames,
        step: saved.sim.steps(),
        time: saved.sim.steps() as Real * scene.config.simulation.time_step,
    };
    let start = Start {
        frames: saved.frames,
        time: saved.frame_time,
        every: saved.every,
        resumed: Some((csv_len, pockets_len, grabs_len, note)),
        attach_cut: attach_len,
    };
    let sim = Simulation::restore(scene.config.clone(), saved.sim).map_err(|e| {
        CliError::Input(format!(
            "{} does not fit {}: {e}",
            ckpt_path.display(),
            scene_path.display()
        ))
    })?;
    if !quiet {
        eprintln!(
            "wetcloth: resuming {} at frame {} (t = {} s)",
            scene.name,
            start.frames,
            human(sim.time())
        );
    }
    bake(args, &scene, dir, sim, start, quiet)
}

/// The name of the grab forces file in a run folder.
const GRABS_CSV: &str = "grabs.csv";
/// Each attachment's force on the cloth, one row per attachment per frame (written when the
/// scene has `[[attach]]`).
const ATTACHMENTS_CSV: &str = "attachments.csv";

/// The scene of the run in `dir` (its `scene.toml` at `scene_path`, bytes `toml`), to resume
/// it: a mesh cloth is read from the copy the run kept (`run.json`'s `mesh.copy`, checked
/// against its digest), so that the run goes on when the original file was moved or changed;
/// the cloth keeps the original's name. Everything else is read as the scene says.
fn load_run_scene(dir: &Path, scene_path: &Path, toml: &[u8]) -> Result<Scene, CliError> {
    let copy = fs::read(dir.join("run.json"))
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .and_then(|v| v.get("mesh").cloned())
        .and_then(|m| serde_json::from_value::<wetcloth_export::ClothMeshInfo>(m).ok());
    let Some(info) = copy else {
        return Ok(wetcloth_scene::load(scene_path)?);
    };
    let bad = |why: String| {
        CliError::Input(format!(
            "{}: {why}; run the scene again",
            dir.join("run.json").display()
        ))
    };
    wetcloth_export::read_cloth_copy(dir, &info).map_err(bad)?;
    let text = String::from_utf8_lossy(toml);
    let copy_path = std::path::absolute(dir.join(&info.copy)).unwrap_or(dir.join(&info.copy));
    let quoted =
        serde_json::to_string(&copy_path.display().to_string()).expect("a string serialises");
    // `[cloth]`'s `mesh = "..."` line, as the resolved scene writes it.
    let mut in_cloth = false;
    let mut replaced = false;
    let mut lines = Vec::new();
    for line in text.lines() {
        if line.starts_with('[') {
            in_cloth = line.trim() == "[cloth]";
        }
        if in_cloth && !replaced && line.starts_with("mesh = ") {
            lines.push(format!("mesh = {quoted}"));
            replaced = true;
        } else {
            lines.push(line.to_string());
        }
    }
    if !replaced {
        return Err(bad(format!(
            "run.json describes a mesh cloth, {} has no [cloth] mesh",
            scene_path.display()
        )));
    }
    let mut scene = wetcloth_scene::parse(&(lines.join("\n") + "\n"), scene_path)?;
    if let Some(m) = scene.config.cloth.mesh.as_mut() {
        m.file = info.file.clone();
        if wetcloth_export::cloth_copy(m).1 != u64::from_str_radix(&info.digest, 16).unwrap_or(0) {
            return Err(bad(format!(
                "{} does not read back as the cloth the run read",
                info.copy
            )));
        }
    }
    Ok(scene)
}

/// Writes the frames of `scene` from `start` on into `dir`, with checkpoints.
fn bake(
    args: &RunArgs,
    scene: &Scene,
    dir: &Path,
    mut sim: Simulation,
    start: Start,
    quiet: bool,
) -> Result<(), CliError> {
    let config = scene.config.clone();
    let dir = dir.to_path_buf();
    let dt = config.simulation.time_step;
    let est_seconds = estimate::estimate(&config, rayon::current_num_threads()).seconds;
    let stable = config.stable_time_step();
    // The implicit integrator is made for steps above the explicit limit.
    if dt > stable && config.simulation.integrator == wetcloth::Integrator::Verlet {
        eprintln!(
            "wetcloth: warning: time_step = {dt} s is above this cloth's explicit stability \
             limit of {stable:.3e} s; the run will probably blow up"
        );
    }
    for o in wetcloth::collide::plane_overlaps(&config.colliders, config.cloth.particle_radius()) {
        let file = match &config.colliders[o.mesh].shape {
            wetcloth::collide::Shape::Mesh(m) => Path::new(&m.file)
                .file_name()
                .map_or_else(|| m.file.clone(), |f| f.to_string_lossy().into_owned()),
            _ => String::new(),
        };
        eprintln!(
            "wetcloth: warning: [[collider]] {} (mesh {file}) goes {:.1} mm into [[collider]] {} \
             (a plane) at t = {:.3} s: cloth caught between them has no room and is crushed or \
             torn there; move the plane down or the mesh's motion up",
            o.mesh + 1,
            o.depth * 1e3,
            o.plane + 1,
            o.time
        );
    }
    let interrupt = Interrupt::install();

    // run.json first: from now on it says a run is writing here (an earlier run's
    // "complete" must not outlive the frames removed next).
    let json_path = dir.join("run.json");
    let base = RunInfo::new(&scene.name, &config, 0, false);
    let info = |frames: u64, status: RunStatus, time: Real| {
        let mut i = base.clone().with_status(status, time);
        i.frames = frames;
        i
    };
    let frames_dir = dir.join("frames");
    fs::create_dir_all(&frames_dir).map_err(CliError::output(&frames_dir))?;
    // run.json names each mesh collider by a copy of the model beside it (it stays small
    // however large the mesh, though rewritten after every frame).
    wetcloth_export::write_mesh_copies(&dir, &config.colliders)
        .map_err(CliError::output(dir.join("meshes")))?;
    // A mesh cloth's file too: exports and a resumed run read the copy.
    if let Some(m) = &config.cloth.mesh {
        wetcloth_export::write_cloth_copy(&dir, m).map_err(CliError::output(dir.join("meshes")))?;
    }
    // The last checkpoint written, for run.json.
    let mut note = start.resumed.map(|(_, _, _, n)| n);
    write_run_json(
        &json_path,
        &info(start.frames, RunStatus::Running, start.time),
        note,
    )?;

    // How far the run got: frames written and the time of the last.
    let (mut written, mut time) = (start.frames, start.time);
    let progress = progress_bar(0, quiet);
    let started = Instant::now();
    let csv_path = dir.join("metrics.csv");
    let pockets_path = dir.join("pockets.csv");
    let grabs_path = dir.join(GRABS_CSV);
    let attach_path = dir.join(ATTACHMENTS_CSV);
    let attaches = !config.attachments.is_empty();
    let mut body = || -> Result<Ending, CliError> {
        prepare_dir(&frames_dir, start.frames)?;
        if start.resumed.is_none() {
            // An earlier run's checkpoint must not be taken for this run's.
            let old = checkpoint::path(&dir);
            match fs::remove_file(&old) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(CliError::output(&old)(e));
                }
                _ => {}
            }
            let scene_path = dir.join("scene.toml");
            let toml = scene.to_toml();
            write_atomically(&scene_path, |w| w.write_all(toml.as_bytes()))
                .map_err(CliError::output(&scene_path))?;
        }
        // Fresh files, or (resumed) the files cut back to the checkpoint: rows a killed run
        // wrote after it are written again; the header is already there and the writers'
        // own is dropped.
        let (csv_cut, pockets_cut, grabs_cut) = match start.resumed {
            Some((m, p, g, _)) => (Some(m), Some(p), g),
            None => (None, None, None),
        };
        let metrics_header = wetcloth_export::csv_header().len() as u64 + 1;
        let mut csv = MetricsCsv::new(open_appended(&csv_path, csv_cut, metrics_header)?)
            .map_err(CliError::output(&csv_path))?;
        let pockets_header = wetcloth_export::POCKETS_CSV_HEADER.len() as u64 + 1;
        let mut pockets_csv =
            PocketsCsv::new(open_appended(&pockets_path, pockets_cut, pockets_header)?)
                .map_err(CliError::output(&pockets_path))?;
        let grabs_header = wetcloth_export::GRABS_CSV_HEADER.len() as u64 + 1;
        let mut grabs_csv = GrabsCsv::new(open_appended(&grabs_path, grabs_cut, grabs_header)?)
            .map_err(CliError::output(&grabs_path))?;
        let mut attach_csv = if attaches {
            let header = wetcloth_export::ATTACHMENTS_CSV_HEADER.len() as u64 + 1;
            let cut = start.resumed.as_ref().and(start.attach_cut);
            Some(
                GrabsCsv::with_header(
                    open_appended(&attach_path, cut, header)?,
                    wetcloth_export::ATTACHMENTS_CSV_HEADER,
                )
                .map_err(CliError::output(&attach_path))?,
            )
        } else {
            None
        };
        let scene_digest = checkpoint::digest(
            &fs::read(dir.join("scene.toml")).map_err(CliError::output(dir.join("scene.toml")))?,
        );

        let last = last_frame(&config);
        let rate = config.simulation.frame_rate;
        progress.set_length(frame_step(last, rate, dt));
        progress.set_position(sim.step_count());
        // The faces and texture coordinates the frames have: a mesh cloth's as its file has them.
        let surface = ClothSurface::new(&config.cloth);

        let write_frame = |sim: &Simulation,
                           csv: &mut MetricsCsv<Appended>,
                           pockets_csv: &mut PocketsCsv<Appended>,
                           grabs_csv: &mut GrabsCsv<Appended>,
                           attach_csv: &mut Option<GrabsCsv<Appended>>,
                           k: u64|
         -> Result<(), CliError> {
            let metrics = sim.metrics();
            if let Some(what) = non_finite(sim.positions(), &metrics) {
                return Err(CliError::Unwritable {
                    frame: k,
                    what,
                    dir: dir.clone(),
                });
            }
            let path = frames_dir.join(frame_file_name(k));
            let normals = surface.vertex_normals(sim.positions());
            write_atomically(&path, |w| write_obj(w, &surface, sim.positions(), &normals))
                .map_err(CliError::output(&path))?;
            csv.write_row(k, &metrics)
                .map_err(CliError::output(&csv_path))?;
            pockets_csv
                .write_frame(k, sim.time(), &sim.pocket_reports())
                .map_err(CliError::output(&pockets_path))?;
            grabs_csv
                .write_frame(k, sim.time(), &sim.grab_forces())
                .map_err(CliError::output(&grabs_path))?;
            if let Some(a) = attach_csv {
                a.write_frame(k, sim.time(), &sim.attach_forces())
                    .map_err(CliError::output(&attach_path))?;
            }
            crate::pocket_labels::write_frame(&frames_dir, sim, k)?;
            if k == 0 {
                wetcloth_export::write_rest_obj(&dir).map_err(|e| match e {
                    wetcloth_export::ExportError::Output { path, source } => {
                        CliError::Output { path, source }
                    }
                    e => CliError::Setup(e.to_string()),
                })?;
            }
            Ok(())
        };
        let save =
            |sim: &Simulation, frames: u64, frame_time: Real| -> Result<CheckpointNote, CliError> {
                let saved = checkpoint::Saved {
                    scene_digest,
                    every: start.every,
                    frames,
                    frame_time,
                    appended: {
                        let mut files = vec![
                            ("metrics.csv".into(), csv_len(&csv_path)?),
                            ("pockets.csv".into(), csv_len(&pockets_path)?),
                            (GRABS_CSV.into(), csv_len(&grabs_path)?),
                        ];
                        if attaches {
                            files.push((ATTACHMENTS_CSV.into(), csv_len(&attach_path)?));
                        }
                        files
                    },
                    inputs: checkpoint::inputs(&config),
                    sim: sim.checkpoint(),
                };
                checkpoint::write(&dir, &saved)?;
                Ok(CheckpointNote {
                    file: checkpoint::FILE_NAME,
                    frames,
                    step: sim.step_count(),
                    time: sim.time(),
                })
            };

        let mut chunk = 1u64;
        // The up-front estimate models the cloth's own cost; what it cannot see (a mesh whose
        // faces reach everywhere, the implicit solve's iterations, many pockets) shows in the
        // run's own rate: measured over its first second, and said once if the run will take
        // more than a minute.
        let mut pace = Pace::new(sim.step_count(), frame_step(last, rate, dt), est_seconds);
        for k in start.frames..=last {
            let target = frame_step(k, rate, dt);
            loop {
                if interrupt.raised() {
                    // Where the run is now, mid-frame or not, so no step is lost.
                    note = Some(save(&sim, written, time)?);
                    return Ok(Ending::Interrupted);
                }
                if sim.step_count() >= target {
                    break;
                }
                // In chunks of about CHUNK_SECONDS, so the progress bar moves and Ctrl-C
                // answers during long frames (the chunking does not change the results).
                let steps = (target - sim.step_count()).min(chunk);
                let t0 = Instant::now();
                sim.advance(steps).map_err(|error| CliError::BlowUp {
                    error,
                    frames: written,
                    dir: dir.clone(),
                })?;
                let took = t0.elapsed().as_secs_f64();
                if took < 0.5 * CHUNK_SECONDS && steps == chunk {
                    chunk = (chunk * 2).min(1 << 16);
                } else if took > 2.0 * CHUNK_SECONDS {
                    chunk = (chunk / 2).max(1);
                }
                progress.set_position(sim.step_count());
                if let Some(line) = pace.check(sim.step_count()) {
                    progress.suspend(|| {
                        if !quiet {
                            eprintln!("wetcloth: {}: {line}", scene.name);
                        }
                    });
                }
            }
            progress.set_message(format!("frame {k}/{last}"));
            // The energy and reach audit before every frame (the core's own runs every
            // AUDIT_INTERVAL steps): no frame is written that has not passed it.
            sim.audit().map_err(|error| CliError::BlowUp {
                error,
                frames: written,
                dir: dir.clone(),
            })?;
            write_frame(
                &sim,
                &mut csv,
                &mut pockets_csv,
                &mut grabs_csv,
                &mut attach_csv,
                k,
            )?;
            (written, time) = (k + 1, sim.time());
            if k == last {
                // Complete: run.json says so first, then the checkpoint goes (a kill in
                // between leaves a checkpoint that --resume removes).
                write_run_json(&json_path, &info(written, RunStatus::Complete, time), None)?;
                let old = checkpoint::path(&dir);
                fs::remove_file(&old).or_else(|e| {
                    if e.kind() == std::io::ErrorKind::NotFound {
                        Ok(())
                    } else {
                        Err(CliError::output(&old)(e))
                    }
                })?;
                note = None;
            } else {
                if start.every > 0 && k % start.every == 0 {
                    note = Some(save(&sim, written, time)?);
                }
                write_run_json(&json_path, &info(written, RunStatus::Running, time), note)?;
            }
        }
        Ok(Ending::Complete)
    };
    let body = body();

    match body {
        Ok(Ending::Complete) => {
            progress.finish_and_clear();
            if !quiet {
                print_summary(scene, &sim, &dir, written, started.elapsed());
            }
            if let Some(list) = &args.export {
                let formats: Vec<_> = list.0.iter().map(|f| (*f, None)).collect();
                crate::export::write_caches(&dir, &formats, quiet)?;
            }
            Ok(())
        }
        Ok(Ending::Interrupted) => {
            progress.abandon();
            write_run_json(
                &json_path,
                &info(written, RunStatus::Interrupted, time),
                note,
            )?;
            Err(CliError::Interrupted {
                frames: written,
                time,
                dir,
            })
        }
        Err(e) => {
            progress.abandon();
            // Say why in run.json; if even that cannot be written, the first error stands.
            let failed = info(written, RunStatus::Running, time).failed(e.to_string());
            let _ = write_run_json(&json_path, &failed, note);
            Err(e)
        }
    }
}

/// The run's own pace: after its first second of stepping, the time the rest will take at
/// that rate, said once when it is more than a minute and the up-front estimate said less.
struct Pace {
    started: Instant,
    first_step: u64,
    last_step: u64,
    estimate: f64,
    said: bool,
}

impl Pace {
    /// Pace of a run stepping from `first_step` to `last_step`, estimated up front at
    /// `estimate` seconds.
    fn new(first_step: u64, last_step: u64, estimate: f64) -> Self {
        Self {
            started: Instant::now(),
            first_step,
            last_step,
            estimate,
            said: false,
        }
    }

    /// At step `step`: the line to print, once.
    fn check(&mut self, step: u64) -> Option<String> {
        let elapsed = self.started.elapsed().as_secs_f64();
        if self.said || elapsed < 1.0 || step <= self.first_step {
            return None;
        }
        self.said = true;
        let rate = elapsed / (step - self.first_step) as f64;
        let left = rate * self.last_step.saturating_sub(step) as f64;
        projected_line(left, elapsed, step - self.first_step, self.estimate)
    }
}

/// The line that says a run will take `left` more seconds, measured over `steps` steps that
/// took `elapsed` s, when that is more than a minute and more than the up-front `estimate`
/// said (s); `None` otherwise.
fn projected_line(left: f64, elapsed: f64, steps: u64, estimate: f64) -> Option<String> {
    (left > 60.0 && left > 2.0 * estimate).then(|| {
        format!(
            "at the pace of its first {steps} step(s) ({:.2e} s each) the run will take about {} \
             more on this machine (estimated {} before it started: the estimate does not see \
             every cost)",
            elapsed / steps as f64,
            estimate::duration(left),
            estimate::duration(estimate)
        )
    })
}

/// What is not finite in a frame about to be written (positions, metrics), if anything: the
/// writers' last line of defence, so that no NaN or infinity reaches a file of a run, whatever
/// the core's checks missed.
fn non_finite(x: &wetcloth::Soa, metrics: &wetcloth::FrameMetrics) -> Option<String> {
    for (axis, v) in [("x", &x.x), ("y", &x.y), ("z", &x.z)] {
        if let Some(k) = v.iter().position(|c| !c.is_finite()) {
            return Some(format!("{axis} = {} at vertex {}", v[k], k + 1));
        }
    }
    COLUMNS
        .iter()
        .zip(metrics.values())
        .find(|(_, v)| !v.is_finite())
        .map(|(name, v)| format!("{name} = {v} in metrics.csv"))
}

/// A file `metrics.csv` is appended to: drops the first `skip` bytes written (the header a
/// resumed run's `MetricsCsv` writes again).
struct Appended {
    file: fs::File,
    skip: u64,
}

impl Appended {
    /// Appends to `file` (positioned at its end), dropping the first `skip` bytes written.
    fn new(file: fs::File, skip: u64) -> Self {
        Self { file, skip }
    }
}

impl Write for Appended {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let dropped = self.skip.min(buf.len() as u64) as usize;
        if dropped > 0 {
            self.skip -= dropped as u64;
            return Ok(dropped);
        }
        self.file.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

/// `path` to append rows to: created fresh (`cut` None), or cut back to `cut` bytes with its
/// header of `header` bytes already there, which the writer's own header then skips.
fn open_appended(path: &Path, cut: Option<u64>, header: u64) -> Result<Appended, CliError> {
    match cut {
        None => {
            let file = create_fresh(path).map_err(CliError::output(path))?;
            Ok(Appended::new(file, 0))
        }
        Some(len) => {
            let mut file = fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(CliError::output(path))?;
            file.set_len(len).map_err(CliError::output(path))?;
            std::io::Seek::seek(&mut file, std::io::SeekFrom::Start(len))
                .map_err(CliError::output(path))?;
            Ok(Appended::new(file, header))
        }
    }
}

/// The length of a CSV file (every row is flushed as it is written), bytes.
fn csv_len(path: &Path) -> Result<u64, CliError> {
    fs::metadata(path)
        .map(|m| m.len())
        .map_err(CliError::output(path))
}

/// Creates `frames_dir` (and its parent) and removes frame files an earlier run left there from
/// frame `from` on (every one for a new run, those after the checkpoint for a resumed one), and
/// every `.part` file, so a shorter rerun leaves no stale frames. Other files are left alone.
fn prepare_dir(frames_dir: &Path, from: u64) -> Result<(), CliError> {
    fs::create_dir_all(frames_dir).map_err(CliError::output(frames_dir))?;
    let entries = fs::read_dir(frames_dir).map_err(CliError::output(frames_dir))?;
    for entry in entries {
        let entry = entry.map_err(CliError::output(frames_dir))?;
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let index = |n: &str| {
            n.strip_prefix("frame_")
                .and_then(|n| n.strip_suffix(".obj"))
                .and_then(|n| n.parse::<u64>().ok())
        };
        let stale = (is_frame_file_name(&name) && index(&name).is_none_or(|k| k >= from))
            || name.strip_suffix(".part").is_some_and(is_frame_file_name);
        // Files and links (a link itself, never what it points to); not directories.
        if stale && entry.file_type().is_ok_and(|t| !t.is_dir()) {
            fs::remove_file(entry.path()).map_err(CliError::output(entry.path()))?;
        }
    }
    Ok(())
}

/// Writes `run.json` (always whole: through a `.part` file and a rename), with the last
/// checkpoint while the run is not complete; pretty-printed JSON with a final newline, as
/// `wetcloth_export::write_run_json` writes it.
fn write_run_json(
    path: &Path,
    info: &RunInfo,
    checkpoint: Option<CheckpointNote>,
) -> Result<(), CliError> {
    let json = RunJson { info, checkpoint };
    write_atomically(path, |w| {
        serde_json::to_writer_pretty(&mut *w, &json)?;
        writeln!(w)
    })
    .map_err(CliError::output(path))
}

/// A progress bar over the steps on stderr, or a hidden one when stderr is not a terminal or the
/// run is quiet.
fn progress_bar(total_steps: u64, quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(total_steps), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} steps, {msg} (eta {eta})",
    ) {
        bar.set_style(style);
    }
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

fn print_summary(scene: &Scene, sim: &Simulation, dir: &Path, frames: u64, wall: Duration) {
    let steps = sim.step_count();
    let secs = wall.as_secs_f64().max(1e-9);
    let particles = sim.particle_count() as f64;
    let sps = steps as f64 / secs;
    println!("wetcloth run: {} -> {}", scene.name, dir.display());
    println!(
        "  frames     {frames} ({} .. {}), metrics.csv, pockets.csv, scene.toml, run.json",
        frame_file_name(0),
        frame_file_name(frames - 1)
    );
    println!(
        "  simulated  {} s in {steps} steps of {} s ({} particles)",
        human(sim.time()),
        human(sim.time_step()),
        sim.particle_count()
    );
    println!(
        "  wall time  {secs:.3} s: {sps:.0} steps/s, {:.3e} particle-steps/s on {} thread(s)",
        sps * particles,
        rayon::current_num_threads()
    );
    if sim.halvings() > 0 {
        println!(
            "  halved     {} step(s) taken again as two of half the time step (strain limit \
             broken by more than a quarter, or a blow-up)",
            sim.halvings()
        );
    }
    println!("  final metrics:");
    for ((name, value), unit) in COLUMNS.iter().zip(sim.metrics().values()).zip(UNITS) {
        let line = format!("    {name:<17} {} {unit}", human(value));
        println!("{}", line.trim_end());
    }
}

/// A number for people: 6 decimals in the everyday range, scientific notation outside it.
/// (Files get full precision; this is only for the summary.)
fn human(v: Real) -> String {
    let a = v.abs();
    if v == 0.0 {
        // Not "-0": a run that trapped no air says 0.
        "0".into()
    } else if (1e-3..1e6).contains(&a) {
        let s = format!("{v:.6}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        format!("{v:.4e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wetcloth::SimConfig;

    /// The summary printed `trapped_air -0 m^3` for a run without air.
    #[test]
    fn the_summary_never_prints_minus_zero() {
        assert_eq!(human(-0.0), "0");
        assert_eq!(human(0.0), "0");
        assert_eq!(human(-0.25), "-0.25");
        assert_eq!(human(1e308), "1.0000e308");
    }

    /// A run whose own pace says more than a minute (and more than twice the estimate) is
    /// announced; one within its estimate or under a minute is not.
    #[test]
    fn the_run_says_when_its_pace_makes_it_long() {
        let line = projected_line(600.0, 1.0, 10, 5.0).unwrap();
        assert!(line.contains("10 min") && line.contains("5 s"), "{line}");
        assert_eq!(projected_line(50.0, 1.0, 10, 5.0), None);
        assert_eq!(projected_line(600.0, 1.0, 10, 400.0), None);
    }

    #[test]
    fn frames_fall_on_the_first_step_at_or_after_their_time() {
        let dt = 1.0 / 12000.0;
        assert_eq!(frame_step(0, 60.0, dt), 0);
        assert_eq!(frame_step(1, 60.0, dt), 200);
        assert_eq!(frame_step(180, 60.0, dt), 36000);
        // Not a whole number of steps per frame: the first step at or after k / rate.
        for k in 0..100 {
            let n = frame_step(k, 7.0, 1e-3);
            let t = k as Real / 7.0;
            assert!(n as Real * 1e-3 >= t - 1e-9);
            assert!(n == 0 || (n - 1) as Real * 1e-3 < t);
        }
        // Evenly spaced even where the step's time is off by round-off.
        for k in 0..=180 {
            assert_eq!(frame_step(k, 60.0, dt), 200 * k);
            assert_eq!(frame_step(k, 20.0, dt), 600 * k);
        }
    }

    /// The writers refuse what the core's checks might let through: a non-finite position or
    /// metric is never written (`wetcloth run` then exits 1 with run.json saying "failed").
    #[test]
    fn the_writers_refuse_non_finite_frames() {
        let sim = Simulation::new({
            let mut c = SimConfig::thesis_demo();
            c.cloth.resolution = [5, 5];
            c.grabs.clear();
            c
        })
        .unwrap();
        let (x, m) = (sim.positions().clone(), sim.metrics());
        assert_eq!(non_finite(&x, &m), None);
        let mut bad = x.clone();
        bad.y[7] = Real::NAN;
        assert_eq!(non_finite(&bad, &m).as_deref(), Some("y = NaN at vertex 8"));
        let mut bad = x.clone();
        bad.z[0] = Real::INFINITY;
        assert!(non_finite(&bad, &m).unwrap().starts_with("z = inf"));
        let mut worse = m;
        worse.kinetic_energy = Real::INFINITY;
        assert_eq!(
            non_finite(&x, &worse).as_deref(),
            Some("kinetic_energy = inf in metrics.csv")
        );
        let e = CliError::Unwritable {
            frame: 4,
            what: "x = NaN at vertex 1".into(),
            dir: "out/d".into(),
        };
        assert_eq!(e.exit_code(), 1);
        assert!(e.to_string().contains("frame 4 would hold x = NaN"));
    }

    #[test]
    fn the_last_frame_survives_round_off() {
        let mut c = SimConfig::default();
        c.simulation.duration = 0.29;
        c.simulation.frame_rate = 100.0;
        assert_eq!(last_frame(&c), 29);
        c.simulation.duration = 0.295;
        assert_eq!(last_frame(&c), 29);
        c.simulation.duration = 3.0;
        c.simulation.frame_rate = 60.0;
        assert_eq!(last_frame(&c), 180);
    }
}
