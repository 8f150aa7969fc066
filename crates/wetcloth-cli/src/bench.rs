//! `wetcloth bench`: simulation speed on the thesis workload, the counterpart of the thesis'
//! table 4.2 (frame rate against particle count, one step per drawn frame).
//!
//! Each measurement builds [`wetcloth::bench::thesis_workload`] (the thesis' spacing and
//! particle mass, everything on, a cloth settling onto a plane) in a thread pool of the
//! requested size, lets it run for a warm-up, then times consecutive windows of
//! [`Simulation::advance`], the same stepping `run` and the viewer use, and reports the median
//! window. Medians, because a shared machine's timings have long upper tails.
//!
//! With `--scene FILE` it measures that scene instead: the scene from its start, without
//! writing anything, for its whole duration or until `--seconds` of wall time have passed,
//! once per thread count, reporting the simulated seconds per wall second (the real-time
//! factor) and, with the implicit integrator, the conjugate-gradient iterations per step.

use crate::error::CliError;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use wetcloth::AirModelKind;
use wetcloth::Simulation;
use wetcloth::bench::thesis_workload;

/// The thesis' table 4.2: particles and frames per second (one step per frame, Core i7-3930K).
pub const THESIS_TABLE_4_2: [(usize, f64); 5] = [
    (100, 1720.0),
    (400, 500.0),
    (900, 210.0),
    (1600, 115.0),
    (2500, 64.0),
];

/// Timed windows per measurement; the median is reported.
const WINDOWS: u32 = 7;

/// Arguments of `wetcloth bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Cloth sizes, in particles per side, comma separated. Default: the thesis' table 4.2
    /// (10, 20, 30, 40, 50: 100 to 2500 particles) and larger (100, 200: 10 000 and 40 000).
    #[arg(long, value_delimiter = ',', value_name = "N,N,...",
          value_parser = clap::value_parser!(u32).range(2..=4096))]
    pub sizes: Option<Vec<u32>>,

    /// Thread counts to measure with, comma separated. Default: 1 and all cores.
    #[arg(long, value_delimiter = ',', value_name = "T,T,...",
          value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<Vec<u32>>,

    /// Seconds of timed windows per measurement, after a warm-up of a fifth of that: each
    /// measurement takes about 1.2 S, or one step per window when a step is slower than that
    /// (plus building the cloth).
    #[arg(long, default_value_t = 2.0, value_name = "S",
          value_parser = parse_seconds)]
    pub seconds: f64,

    /// Also write the results as JSON: a list of objects with `particles`, `threads`,
    /// `steps_per_second`, `particle_steps_per_second`, `real_time_factor` and more.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,

    /// Measure with self-collision off (to see what it costs).
    #[arg(long)]
    pub no_self_collision: bool,

    /// The air model to measure: `thesis` (the single bubble) or `pockets` (sealed pockets:
    /// the cloth is wet and seals where it touches, so the pockets' search runs every step).
    #[arg(long, default_value = "thesis", value_name = "MODEL", value_parser = parse_air_model)]
    pub air_model: AirModelKind,

    /// The integrator: `verlet` (position Verlet, the thesis' eq. 3.1) or `implicit` (backward
    /// Euler with a conjugate gradient). Default: `verlet` (with `--scene`: the scene's).
    #[arg(long, value_name = "NAME", value_parser = parse_integrator)]
    pub integrator: Option<wetcloth::Integrator>,

    /// Time step, s. Default: the workload's 1/12000 s with `verlet`, 1/600 s with `implicit`
    /// (with `--scene`: the scene's own step).
    #[arg(long, value_name = "S", value_parser = parse_time_step)]
    pub time_step: Option<f64>,

    /// Measure this scene file instead of the thesis workload: it runs from its start for its
    /// whole duration (or until `--seconds` of wall time), writing nothing, once per thread
    /// count. `--integrator` and `--time-step` override the scene's when given; `--sizes` and
    /// `--air-model` do not apply.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["sizes", "air_model"])]
    pub scene: Option<PathBuf>,
}

fn parse_integrator(s: &str) -> Result<wetcloth::Integrator, String> {
    wetcloth::Integrator::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = wetcloth::Integrator::ALL.iter().map(|i| i.name()).collect();
        format!("unknown integrator `{s}`: one of {}", names.join(", "))
    })
}

fn parse_time_step(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    if v.is_finite() && (1e-7..=0.05).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{s} is out of range: allowed [1e-7, 0.05] s"))
    }
}

fn parse_air_model(s: &str) -> Result<AirModelKind, String> {
    AirModelKind::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = AirModelKind::ALL.iter().map(|m| m.name()).collect();
        format!("unknown air model `{s}`: allowed {}", names.join(", "))
    })
}

fn parse_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    if v.is_finite() && (0.01..=3600.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{s} is out of range: allowed [0.01, 3600] s"))
    }
}

/// One measurement.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Measurement {
    /// Particles in the cloth.
    pub particles: usize,
    /// Particles per side.
    pub side: usize,
    /// Worker threads.
    pub threads: usize,
    /// Median steps per second.
    pub steps_per_second: f64,
    /// `steps_per_second * particles`.
    pub particle_steps_per_second: f64,
    /// Simulated seconds per wall second: `steps_per_second * time_step`.
    pub real_time_factor: f64,
    /// The time step, s.
    pub time_step: f64,
    /// Whether self-collision was on.
    pub self_collision: bool,
    /// The air model (`thesis` or `pockets`).
    pub air_model: &'static str,
    /// The integrator's scene name.
    pub integrator: &'static str,
    /// Heap memory the simulation held at the end, bytes (`Simulation::memory_bytes`).
    pub memory_bytes: usize,
    /// Fastest and slowest window, steps per second.
    pub steps_per_second_range: [f64; 2],
    /// Timed windows.
    pub windows: u32,
    /// Steps in the timed windows.
    pub steps: u64,
    /// Wall-clock time of the warm-up and the windows, s (bounded by about 1.2 `--seconds`).
    pub measured_seconds: f64,
    /// The thesis' frame rate for this particle count (table 4.2), if it lists it.
    pub thesis_steps_per_second: Option<f64>,
    /// The scene file measured (`--scene`), or none for the thesis workload.
    pub scene: Option<PathBuf>,
    /// Simulated seconds covered: the scene's duration, or less where `--seconds` stopped it
    /// (`--scene` only; the workload's windows otherwise).
    pub simulated_seconds: f64,
    /// Conjugate-gradient iterations per step, mean over the measured steps (0 with Verlet).
    pub solver_iterations_per_step: f64,
}

/// Runs `wetcloth bench`.
pub fn bench(args: &BenchArgs, quiet: bool) -> Result<(), CliError> {
    let sizes: Vec<usize> = args.sizes.clone().map_or_else(
        || vec![10, 20, 30, 40, 50, 100, 200],
        |v| v.into_iter().map(|s| s as usize).collect(),
    );
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut threads: Vec<usize> = args.threads.clone().map_or_else(
        || vec![1, cores],
        |v| v.into_iter().map(|t| t as usize).collect(),
    );
    threads.dedup();

    let total = sizes.len() * threads.len();
    let bar = if quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::new(total as u64);
        b.set_style(
            ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}").expect("valid template"),
        );
        b
    };
    let mut results = Vec::with_capacity(total);
    if let Some(path) = &args.scene {
        for &t in &threads {
            bar.set_message(format!("{}, {t} thread(s)", path.display()));
            results.push(measure_scene(path, t, args)?);
            bar.inc(1);
        }
        bar.finish_and_clear();
        if !quiet {
            print_scene_table(&results);
        }
        return write_json(args, &results);
    }
    for &side in &sizes {
        for &t in &threads {
            bar.set_message(format!("{side} x {side}, {t} thread(s)"));
            results.push(measure(side, t, args, !args.no_self_collision)?);
            bar.inc(1);
        }
    }
    bar.finish_and_clear();

    if !quiet {
        print_table(&results);
    }
    write_json(args, &results)
}

fn write_json(args: &BenchArgs, results: &[Measurement]) -> Result<(), CliError> {
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(results).expect("plain data serialises");
        std::fs::write(path, text + "\n").map_err(CliError::output(path))?;
    }
    Ok(())
}

fn print_scene_table(results: &[Measurement]) {
    println!(
        "{:>9} {:>7} {:>10} {:>10} {:>10} {:>10} {:>14}",
        "particles", "threads", "simulated", "wall", "steps/s", "real-time", "CG iter/step"
    );
    for m in results {
        println!(
            "{:>9} {:>7} {:>9.3}s {:>9.2}s {:>10.0} {:>9.3}x {:>14.1}",
            m.particles,
            m.threads,
            m.simulated_seconds,
            m.measured_seconds,
            m.steps_per_second,
            m.real_time_factor,
            m.solver_iterations_per_step
        );
    }
    if let Some(m) = results.first() {
        println!(
            "({}; {} integrator; time step {:.4e} s; self-collision {})",
            m.scene
                .as_deref()
                .unwrap_or(std::path::Path::new("-"))
                .display(),
            m.integrator,
            m.time_step,
            if m.self_collision { "on" } else { "off" }
        );
    }
}

/// Times the workload of `side x side` particles on `threads` threads.
fn measure(
    side: usize,
    threads: usize,
    args: &BenchArgs,
    self_collision: bool,
) -> Result<Measurement, CliError> {
    let seconds = args.seconds;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| CliError::Setup(format!("cannot start {threads} threads: {e}")))?;
    let mut cfg = thesis_workload(side);
    cfg.cloth.self_collision = self_collision;
    cfg.air.model = args.air_model;
    let integrator = args.integrator.unwrap_or(wetcloth::Integrator::Verlet);
    cfg.simulation.integrator = integrator;
    cfg.simulation.time_step = args.time_step.unwrap_or(match integrator {
        wetcloth::Integrator::Verlet => cfg.simulation.time_step,
        wetcloth::Integrator::Implicit => 1.0 / 600.0,
    });
    let dt = cfg.simulation.time_step;
    let particles = side * side;
    pool.install(|| {
        let mut sim = Simulation::new(cfg).map_err(|e| CliError::Setup(e.to_string()))?;
        let blow_up = |error| CliError::BlowUp {
            error,
            frames: 0,
            dir: PathBuf::from("."),
        };
        // Every window and the warm-up stop at their time, however fast or slow the steps:
        // steps go in chunks of about a twentieth of a window, so a window overruns by at
        // most a chunk (or one step when a step takes longer).
        let window = seconds / WINDOWS as f64;
        let warm = Duration::from_secs_f64(seconds / 5.0);
        let start = Instant::now();
        let mut chunk = 1u64;
        while start.elapsed() < warm {
            let t = Instant::now();
            sim.advance(chunk).map_err(blow_up)?;
            if t.elapsed().as_secs_f64() < window / 40.0 {
                chunk *= 2;
            }
        }
        let mut rates = Vec::with_capacity(WINDOWS as usize);
        let mut steps = 0u64;
        let iterations_before = sim.solver_iterations();
        for _ in 0..WINDOWS {
            let t = Instant::now();
            let mut done = 0u64;
            while t.elapsed().as_secs_f64() < window {
                sim.advance(chunk).map_err(blow_up)?;
                done += chunk;
            }
            rates.push(done as f64 / t.elapsed().as_secs_f64());
            steps += done;
        }
        let measured_seconds = start.elapsed().as_secs_f64();
        rates.sort_by(f64::total_cmp);
        let median = rates[rates.len() / 2];
        Ok(Measurement {
            particles,
            side,
            threads,
            steps_per_second: median,
            particle_steps_per_second: median * particles as f64,
            real_time_factor: median * dt,
            time_step: dt,
            self_collision,
            air_model: args.air_model.name(),
            integrator: integrator.name(),
            memory_bytes: sim.memory_bytes(),
            steps_per_second_range: [rates[0], rates[rates.len() - 1]],
            windows: WINDOWS,
            steps,
            measured_seconds,
            thesis_steps_per_second: THESIS_TABLE_4_2
                .iter()
                .find(|(n, _)| *n == particles)
                .map(|(_, fps)| *fps),
            scene: None,
            simulated_seconds: steps as f64 * dt,
            solver_iterations_per_step: (sim.solver_iterations() - iterations_before) as f64
                / steps.max(1) as f64,
        })
    })
}

/// Runs the scene `path` from its start on `threads` threads, for its duration or until
/// `args.seconds` of wall time.
fn measure_scene(
    path: &std::path::Path,
    threads: usize,
    args: &BenchArgs,
) -> Result<Measurement, CliError> {
    let scene = wetcloth_scene::load(path)?;
    let mut cfg = scene.config;
    if let Some(integrator) = args.integrator {
        cfg.simulation.integrator = integrator;
    }
    if let Some(dt) = args.time_step {
        cfg.simulation.time_step = dt;
    }
    if args.no_self_collision {
        cfg.cloth.self_collision = false;
    }
    cfg.validate().map_err(|e| CliError::Setup(e.to_string()))?;
    let dt = cfg.simulation.time_step;
    let integrator = cfg.simulation.integrator;
    let self_collision = cfg.cloth.self_collision;
    let air_model = cfg.air.model.name();
    let total = (cfg.simulation.duration / dt).round().max(1.0) as u64;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| CliError::Setup(format!("cannot start {threads} threads: {e}")))?;
    pool.install(|| {
        let mut sim = Simulation::new(cfg).map_err(|e| CliError::Setup(e.to_string()))?;
        let particles = sim.particle_count();
        // A mesh cloth has no side: the side of a square grid of as many particles.
        let side = sim
            .model()
            .grid
            .as_ref()
            .map_or((particles as f64).sqrt().round() as usize, |g| g.nx);
        let start = Instant::now();
        // Chunks of at most 1 % of the scene, so `--seconds` stops it in time.
        let chunk = (total / 100).max(1);
        let mut steps = 0u64;
        while steps < total && start.elapsed().as_secs_f64() < args.seconds {
            let n = chunk.min(total - steps);
            sim.advance(n).map_err(|error| CliError::BlowUp {
                error,
                frames: 0,
                dir: PathBuf::from("."),
            })?;
            steps += n;
        }
        let wall = start.elapsed().as_secs_f64().max(1e-9);
        let rate = steps as f64 / wall;
        Ok(Measurement {
            particles,
            side,
            threads,
            steps_per_second: rate,
            particle_steps_per_second: rate * particles as f64,
            real_time_factor: rate * dt,
            time_step: dt,
            self_collision,
            air_model,
            integrator: integrator.name(),
            memory_bytes: sim.memory_bytes(),
            steps_per_second_range: [rate, rate],
            windows: 1,
            steps,
            measured_seconds: wall,
            thesis_steps_per_second: None,
            scene: Some(path.to_path_buf()),
            simulated_seconds: steps as f64 * dt,
            solver_iterations_per_step: sim.solver_iterations() as f64 / steps.max(1) as f64,
        })
    })
}

fn print_table(results: &[Measurement]) {
    println!(
        "{:>9} {:>7} {:>12} {:>16} {:>10} {:>14} {:>10}",
        "particles",
        "threads",
        "steps/s",
        "particle-steps/s",
        "real-time",
        "thesis steps/s",
        "memory"
    );
    for m in results {
        println!(
            "{:>9} {:>7} {:>12.0} {:>16.3e} {:>9.2}x {:>14} {:>7.1} MB",
            m.particles,
            m.threads,
            m.steps_per_second,
            m.particle_steps_per_second,
            m.real_time_factor,
            m.thesis_steps_per_second
                .map_or_else(|| "-".to_string(), |v| format!("{v:.0}")),
            m.memory_bytes as f64 / 1e6
        );
    }
    if let Some(m) = results.first() {
        println!(
            "(median of {} windows each; {} integrator; time step {:.4e} s; self-collision {})",
            m.windows,
            m.integrator,
            m.time_step,
            if m.self_collision { "on" } else { "off" }
        );
    }
}
