//! `wetcloth run [SCENE] [--out DIR]`: run a scene and write its frames and metrics.
//!
//! The run directory holds `frames/frame_NNNN.obj` (one mesh per written frame), `rest.obj` (a
//! copy of frame 0, the mesh point caches apply to), `metrics.csv` (one row per frame), `pockets.csv` (one row per sealed air pocket per frame),
//! `scene.toml` (the scene with every key explicit) and `run.json`; with `--export`, caches. Frame
//! `k` is the state at the first step whose time is at least `k / frame_rate`; frame 0 is the
//! state at t = 0. Every file is complete on disk as soon as it is named: frames, `scene.toml`
//! and `run.json` are written to `NAME.part` (never following a link left there) and renamed,
//! metrics rows are flushed one by one, so a run that blows up (or is interrupted) leaves a
//! complete prefix. `run.json` is written first (status `running`), then after every frame, and
//! last with how the run ended: `complete`, `interrupted` (Ctrl-C, SIGTERM: exit 130) or
//! `failed` (with the error), with the frames written and the time reached.

use crate::error::CliError;
use crate::estimate::{self, Available};
use crate::interrupt::Interrupt;
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::fs;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use wetcloth::metrics::COLUMNS;
use wetcloth::{Real, SimConfig, Simulation};
use wetcloth_export::{
    MetricsCsv, PocketsCsv, RunInfo, RunStatus, create_fresh, frame_file_name, is_frame_file_name,
    write_atomically, write_obj,
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

    /// Also write these caches when the run completes, as `wetcloth export` does: a comma list
    /// of pc2, mdd, usda, usdc (e.g. `usdc,pc2`), each to DIR/<scene name>.<extension>.
    #[arg(long, value_name = "FORMATS", value_parser = crate::export::parse_format_list)]
    pub export: Option<crate::export::FormatList>,
}

/// Units of the metrics columns, for the summary.
const UNITS: [&str; 10] = ["s", "m^3", "Pa", "J", "", "", "m", "N", "m^3", ""];

/// Relative tolerance when counting frames, so that `duration * frame_rate` a hair below an
/// integer by round-off (0.29 * 100 = 28.999999999999996) still counts that last frame.
const FRAME_COUNT_TOLERANCE: Real = 1e-12;

/// Index of the last frame: `floor(duration * frame_rate)`, up to round-off.
pub fn last_frame(config: &SimConfig) -> u64 {
    let x = config.simulation.duration * config.simulation.frame_rate;
    (x * (1.0 + FRAME_COUNT_TOLERANCE)).floor() as u64
}

/// The step at which frame `k` is written: the first step count `n` with `n * dt >= k / rate`,
/// computed from integers so that no time is accumulated. A step that misses the frame time by
/// round-off only (600 steps of 1/12000 s is 0.049999999999999996 s, not 0.05) counts as on it,
/// so frames stay evenly spaced in steps.
pub fn frame_step(k: u64, frame_rate: Real, dt: Real) -> u64 {
    let t = k as Real / frame_rate - STEP_TOLERANCE * dt;
    let mut n = (t / dt).ceil().max(0.0) as u64;
    while n > 0 && (n - 1) as Real * dt >= t {
        n -= 1;
    }
    while (n as Real) * dt < t {
        n += 1;
    }
    n
}

/// Fraction of a step by which a step time may fall short of a frame time and still count.
const STEP_TOLERANCE: Real = 1e-6;

/// Wall-clock time one call to `Simulation::advance` aims at, s: short enough that Ctrl-C and
/// the progress bar answer at once, long enough that the calls cost nothing.
const CHUNK_SECONDS: f64 = 0.1;

/// How a run that did not fail ended.
enum Ending {
    Complete,
    Interrupted,
}

/// Runs `wetcloth run`.
pub fn run(args: &RunArgs, quiet: bool) -> Result<(), CliError> {
    let scene = match &args.scene {
        Some(path) => wetcloth_scene::load(path)?,
        None => Scene::thesis_demo(),
    };
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

    let mut sim = Simulation::new(config.clone()).map_err(|e| scene.locate(&e))?;

    let dt = config.simulation.time_step;
    let stable = config.stable_time_step();
    if dt > stable && config.simulation.integrator == wetcloth::Integrator::Verlet {
        eprintln!(
            "wetcloth: warning: time_step = {dt} s is above this cloth's explicit stability \
             limit of {stable:.3e} s; the run will probably blow up"
        );
    }
    let interrupt = Interrupt::install();

    // run.json first: from now on it says a run is writing here (an earlier run's
    // "complete" must not outlive the frames removed next).
    let json_path = dir.join("run.json");
    let info = |frames: u64, status: RunStatus, time: Real| {
        RunInfo::new(&scene.name, &config, frames, false).with_status(status, time)
    };
    let frames_dir = dir.join("frames");
    fs::create_dir_all(&frames_dir).map_err(CliError::output(&frames_dir))?;
    write_run_json(&json_path, &info(0, RunStatus::Running, 0.0))?;

    // How far the run got: frames written and the time of the last.
    let mut written = 0u64;
    let mut time: Real = 0.0;
    let progress = progress_bar(0, quiet);
    let start = Instant::now();
    let body = (|| -> Result<Ending, CliError> {
        prepare_dir(&frames_dir)?;
        let scene_path = dir.join("scene.toml");
        let toml = scene.to_toml();
        write_atomically(&scene_path, |w| w.write_all(toml.as_bytes()))
            .map_err(CliError::output(&scene_path))?;
        let csv_path = dir.join("metrics.csv");
        let csv_file = create_fresh(&csv_path).map_err(CliError::output(&csv_path))?;
        let mut csv =
            MetricsCsv::new(BufWriter::new(csv_file)).map_err(CliError::output(&csv_path))?;
        let pockets_path = dir.join("pockets.csv");
        let pockets_file = create_fresh(&pockets_path).map_err(CliError::output(&pockets_path))?;
        let mut pockets_csv = PocketsCsv::new(BufWriter::new(pockets_file))
            .map_err(CliError::output(&pockets_path))?;

        let last = last_frame(&config);
        let rate = config.simulation.frame_rate;
        progress.set_length(frame_step(last, rate, dt));
        let grid = sim.grid().clone();
        let uvs = grid.uvs();

        let mut write_frame = |sim: &Simulation, k: u64| -> Result<(), CliError> {
            let path = frames_dir.join(frame_file_name(k));
            let normals = grid.vertex_normals(sim.positions());
            write_atomically(&path, |w| {
                write_obj(w, &grid, sim.positions(), &normals, &uvs)
            })
            .map_err(CliError::output(&path))?;
            csv.write_row(k, &sim.metrics())
                .map_err(CliError::output(&csv_path))?;
            pockets_csv
                .write_frame(k, sim.time(), &sim.pocket_reports())
                .map_err(CliError::output(&pockets_path))?;
            crate::pocket_labels::write_frame(&frames_dir, sim, k)?;
            if k == 0 {
                wetcloth_export::write_rest_obj(&dir).map_err(|e| match e {
                    wetcloth_export::ExportError::Output { path, source } => {
                        CliError::Output { path, source }
                    }
                    e => CliError::Setup(e.to_string()),
                })?;
            }
            let status = if k == last {
                RunStatus::Complete
            } else {
                RunStatus::Running
            };
            write_run_json(&json_path, &info(k + 1, status, sim.time()))
        };

        if interrupt.raised() {
            return Ok(Ending::Interrupted);
        }
        write_frame(&sim, 0)?;
        (written, time) = (1, sim.time());
        let mut chunk = 1u64;
        for k in 1..=last {
            let target = frame_step(k, rate, dt);
            while sim.step_count() < target {
                if interrupt.raised() {
                    return Ok(Ending::Interrupted);
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
            }
            progress.set_message(format!("frame {k}/{last}"));
            write_frame(&sim, k)?;
            (written, time) = (k + 1, sim.time());
        }
        Ok(Ending::Complete)
    })();

    match body {
        Ok(Ending::Complete) => {
            progress.finish_and_clear();
            if !quiet {
                print_summary(&scene, &sim, &dir, written, start.elapsed());
            }
            if let Some(list) = &args.export {
                let formats: Vec<_> = list.0.iter().map(|f| (*f, None)).collect();
                crate::export::write_caches(&dir, &formats, quiet)?;
            }
            Ok(())
        }
        Ok(Ending::Interrupted) => {
            progress.abandon();
            write_run_json(&json_path, &info(written, RunStatus::Interrupted, time))?;
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
            let _ = write_run_json(&json_path, &failed);
            Err(e)
        }
    }
}

/// Creates `frames_dir` (and its parent) and removes frame files an earlier run left there, so a
/// shorter rerun leaves no stale frames. Other files are left alone.
fn prepare_dir(frames_dir: &Path) -> Result<(), CliError> {
    fs::create_dir_all(frames_dir).map_err(CliError::output(frames_dir))?;
    let entries = fs::read_dir(frames_dir).map_err(CliError::output(frames_dir))?;
    for entry in entries {
        let entry = entry.map_err(CliError::output(frames_dir))?;
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let stale =
            is_frame_file_name(&name) || name.strip_suffix(".part").is_some_and(is_frame_file_name);
        // Files and links (a link itself, never what it points to); not directories.
        if stale && entry.file_type().is_ok_and(|t| !t.is_dir()) {
            fs::remove_file(entry.path()).map_err(CliError::output(entry.path()))?;
        }
    }
    Ok(())
}

/// Writes `run.json` (always complete, see `write_run_json_file`).
fn write_run_json(path: &Path, info: &RunInfo) -> Result<(), CliError> {
    wetcloth_export::write_run_json_file(path, info).map_err(CliError::output(path))
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
    let particles = sim.grid().len() as f64;
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
        sim.grid().len()
    );
    println!(
        "  wall time  {secs:.3} s: {sps:.0} steps/s, {:.3e} particle-steps/s on {} thread(s)",
        sps * particles,
        rayon::current_num_threads()
    );
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
    if v == 0.0 || (1e-3..1e6).contains(&a) {
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
