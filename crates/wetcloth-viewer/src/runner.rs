//! The simulation thread: it owns the [`Simulation`], takes [`Command`]s over a channel, steps
//! to keep up with the wall clock, and publishes [`Snapshot`]s that the window reads without
//! ever waiting for a step.
//!
//! Pacing: the thread steps in slices of at most [`SLICE`] of wall time, then looks at its
//! commands and publishes a snapshot. It steps until simulated time catches up with wall time
//! since the last (re)start; when it falls more than [`MAX_LAG`] behind it lets the lag go, so
//! a slow machine runs slower than real time (the real-time factor shows by how much) instead
//! of spiralling.

use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use wetcloth::{FrameMetrics, Grab, GrabMotion, Model, SimConfig, Simulation, Soa, Vec3};

/// Longest run of steps between two looks at the commands, wall time.
pub const SLICE: Duration = Duration::from_millis(12);

/// Largest lag behind the wall clock the thread tries to make up, s of simulated time.
pub const MAX_LAG: f64 = 0.1;

/// Speed limit of interactive grabs, m/s: a mouse jump moves the particle over several steps
/// instead of tearing the cloth in one.
pub const DRAG_SPEED: f64 = 2.0;

/// Largest relative elongation of a structural spring (1.2: 2.2 times its rest length) that
/// interactive pulling may cause. Past it the simulation holds the pull where it is: the
/// mass-spring cloth is far outside anything cloth does, and a little further it tears
/// numerically (the core stops at ten times the rest length). With the air force on and no
/// trapped air, the atmosphere holds the cloth down, and a pinch lifted a few centimetres gets
/// there.
pub const TEAR_GUARD: f64 = 1.2;

/// Steps between two checks of the tear guard.
const GUARD_EVERY: u64 = 16;

/// What the window asks of the simulation.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Grab `particle` (or move its grab) towards `target`, m.
    Hold {
        /// Particle index.
        particle: usize,
        /// Where to pull it, m.
        target: Vec3,
    },
    /// Let go of `particle`.
    Release {
        /// Particle index.
        particle: usize,
    },
    /// Let go of every interactive grab.
    ReleaseAll,
    /// Turn the pressure force on or off.
    SetAir(bool),
    /// Back to the scene's state at t = 0 (interactive grabs are dropped).
    Reset,
    /// Replace the parameters. The cloth keeps its shape, motion and grabs, and time goes on;
    /// a different resolution or cloth size (or a scene with keyframed grabs, whose paths are
    /// timed from t = 0) restarts from the new scene's initial state instead.
    Configure(Box<SimConfig>),
    /// Pause or resume.
    Pause(bool),
    /// Advance by one displayed frame (1/60 s) while paused.
    StepFrame,
    /// Stop the thread.
    Quit,
}

/// What the window shows: the latest state the simulation thread published.
#[derive(Clone, Debug)]
pub struct Snapshot {
    /// Counts published snapshots; a new value means new positions.
    pub serial: u64,
    /// Counts restarts (reset, new scene, new resolution).
    pub generation: u64,
    /// Particle positions, m, in single precision for drawing and picking.
    pub positions: Vec<[f32; 3]>,
    /// The exact particle positions, m (for recording).
    pub exact: Arc<Soa>,
    /// Smooth vertex normals.
    pub normals: Vec<[f32; 3]>,
    /// The cloth's layout: the grid's size or a mesh's triangles (shared by every snapshot of
    /// one simulation; a new one means a restart with another cloth).
    pub cloth: Arc<ClothLayout>,
    /// The parameters in use.
    pub config: SimConfig,
    /// Measurements of this state.
    pub metrics: FrameMetrics,
    /// Whether the pressure force acts.
    pub air_enabled: bool,
    /// Whether stepping is paused.
    pub paused: bool,
    /// Simulated seconds per wall second over the last half second.
    pub realtime_factor: f64,
    /// Steps per wall second over the last half second.
    pub steps_per_second: f64,
    /// Particles held by interactive grabs.
    pub held: Vec<usize>,
    /// Why the simulation stopped (it blew up); cleared by a reset.
    pub error: Option<String>,
    /// The last command that could not be carried out, and why (the run goes on).
    pub notice: Option<(u64, String)>,
    /// The sealed air pockets (`pockets.csv`'s rows; the thesis' bubble is pocket 0).
    pub pockets: Vec<wetcloth::air::PocketReport>,
    /// Each particle's pocket id, or `wetcloth_export::NO_POCKET`; `None` with the thesis air
    /// model (its bubble lies under the whole cloth).
    pub pocket_of: Option<Vec<u32>>,
}

/// The cloth as the window draws and picks it: the built-in grid or a cloth of any shape. A
/// pick is a particle index either way (on the grid `j * nx + i`; on a mesh the file's vertex).
#[derive(Clone, Debug, PartialEq)]
pub struct ClothLayout {
    /// The grid's particles along x and z (columns, rows); `None` for a mesh cloth.
    pub grid: Option<[usize; 2]>,
    /// Particles.
    pub particles: usize,
    /// The triangles, three indices each, wound with the air below (the core's
    /// `Model::triangles`: the grid's two per cell, or the mesh's faces as fans).
    pub indices: Arc<Vec<u32>>,
    /// The spacing of the particles at rest, m: the grid's along x, or a mesh's mean edge
    /// length.
    pub spacing: f64,
    /// A mesh cloth's file name (without its folder); empty on the grid.
    pub file: String,
}

impl ClothLayout {
    /// The layout of `model`, built with `config`'s cloth.
    pub fn new(model: &Model, config: &SimConfig) -> Self {
        let c = &config.cloth;
        let indices = Arc::new(model.triangles().into_iter().flatten().collect());
        match (&model.grid, &model.mesh) {
            (Some(g), _) => Self {
                grid: Some([g.nx, g.nz]),
                particles: g.len(),
                indices,
                spacing: c.size[0] / (c.resolution[0].max(2) - 1) as f64,
                file: String::new(),
            },
            (None, _) if c.mesh.is_none() => Self {
                // The grid run as a mesh of its triangles (`model = "membrane"`).
                grid: Some(c.resolution),
                particles: model.len(),
                indices,
                spacing: c.size[0] / (c.resolution[0].max(2) - 1) as f64,
                file: String::new(),
            },
            (None, mesh) => {
                let spacing = mesh.as_ref().map_or(0.0, |m| {
                    let sum: f64 = m
                        .edges
                        .iter()
                        .map(|&[a, b]| (m.rest[b as usize] - m.rest[a as usize]).length())
                        .sum();
                    sum / m.edges.len().max(1) as f64
                });
                let file = c.mesh.as_ref().map_or_else(String::new, |m| {
                    std::path::Path::new(&m.file)
                        .file_name()
                        .map_or_else(|| m.file.clone(), |f| f.to_string_lossy().into_owned())
                });
                Self {
                    grid: None,
                    particles: model.len(),
                    indices,
                    spacing,
                    file,
                }
            }
        }
    }

    /// The particle of grid column `i`, row `j`; `None` off the grid or on a mesh cloth.
    pub fn grid_particle(&self, i: usize, j: usize) -> Option<usize> {
        let [nx, nz] = self.grid?;
        (i < nx && j < nz).then(|| j * nx + i)
    }

    /// The cloth in words for the view's caption: `40 × 40 particles` or
    /// `609 particles (towel.obj)`.
    pub fn describe(&self) -> String {
        match self.grid {
            Some([nx, nz]) => format!("{nx} × {nz} particles"),
            None => format!("{} particles ({})", self.particles, self.file),
        }
    }
}

/// Area-weighted smooth vertex normals of `n` particles at positions `x` over the triangles
/// `indices` (three each): each particle's normalised sum of the cross products of the
/// triangles around it, +Y where they cancel. On the grid's triangles this is
/// `Grid::vertex_normals` operation for operation.
pub fn vertex_normals(x: &Soa, indices: &[u32]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; x.len()];
    for t in indices.chunks_exact(3) {
        let (a, b, c) = (t[0] as usize, t[1] as usize, t[2] as usize);
        let w = (x.get(b) - x.get(a)).cross(x.get(c) - x.get(a));
        n[a] += w;
        n[b] += w;
        n[c] += w;
    }
    for v in &mut n {
        *v = v.normalize_or(Vec3::Y);
    }
    n
}

/// Handle to the simulation thread.
pub struct Runner {
    commands: Sender<Command>,
    latest: Arc<Mutex<Arc<Snapshot>>>,
    thread: Option<JoinHandle<()>>,
}

impl Runner {
    /// Builds the simulation and starts its thread. `on_publish` is called after each new
    /// snapshot (the window uses it to request a repaint).
    pub fn start(
        config: SimConfig,
        on_publish: impl Fn() + Send + 'static,
    ) -> Result<Self, wetcloth::ConfigError> {
        let sim = Simulation::new(config)?;
        let state = State::new(sim);
        let latest = Arc::new(Mutex::new(Arc::new(state.snapshot(0, None))));
        let (tx, rx) = mpsc::channel();
        let shared = Arc::clone(&latest);
        // The step is parallel; leave one core to the window (and to a software rasteriser).
        let workers = std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .saturating_sub(1)
            .max(1);
        let thread = std::thread::Builder::new()
            .name("wetcloth-sim".into())
            .spawn(move || {
                match rayon::ThreadPoolBuilder::new()
                    .num_threads(workers)
                    .thread_name(|i| format!("wetcloth-step-{i}"))
                    .build()
                {
                    Ok(pool) => pool.install(|| state.run(rx, shared, on_publish)),
                    Err(_) => state.run(rx, shared, on_publish),
                }
            })
            .expect("spawning the simulation thread");
        Ok(Self {
            commands: tx,
            latest,
            thread: Some(thread),
        })
    }

    /// Sends a command; never blocks.
    pub fn send(&self, command: Command) {
        // The thread only ends on Quit or a panic; either way there is nobody to tell.
        let _ = self.commands.send(command);
    }

    /// The latest snapshot; takes a lock only long enough to clone a pointer.
    pub fn latest(&self) -> Arc<Snapshot> {
        Arc::clone(&self.latest.lock().unwrap_or_else(|e| e.into_inner()))
    }
}

impl Drop for Runner {
    fn drop(&mut self) {
        let _ = self.commands.send(Command::Quit);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The thread's side.
struct State {
    sim: Simulation,
    initial: Simulation,
    /// The layout of `sim`'s cloth.
    cloth: Arc<ClothLayout>,
    paused: bool,
    error: Option<String>,
    notice: Option<(u64, String)>,
    /// Simulated time before the current `Simulation` began (parameters changed mid-run), s.
    time_offset: f64,
    /// Whether the tear guard holds the interactive grabs (see [`TEAR_GUARD`]).
    guarded: bool,
    generation: u64,
    serial: u64,
    /// Wall instant and simulated time of the last pacing anchor.
    anchor: (Instant, f64),
    /// Rate window: wall instant, simulated time and step count at its start.
    window: (Instant, f64, u64),
    rates: (f64, f64),
    pending_frame_steps: u64,
}

impl State {
    fn new(sim: Simulation) -> Self {
        let now = Instant::now();
        Self {
            cloth: Arc::new(ClothLayout::new(sim.model(), sim.config())),
            initial: sim.clone(),
            sim,
            paused: false,
            error: None,
            notice: None,
            time_offset: 0.0,
            guarded: false,
            generation: 0,
            serial: 0,
            anchor: (now, 0.0),
            window: (now, 0.0, 0),
            rates: (0.0, 0.0),
            pending_frame_steps: 0,
        }
    }

    fn snapshot(&self, serial: u64, _prev: Option<&Snapshot>) -> Snapshot {
        let sim = &self.sim;
        let x = sim.positions();
        let positions = (0..x.len())
            .map(|k| x.get(k).as_vec3().to_array())
            .collect();
        let normals = vertex_normals(x, &self.cloth.indices)
            .into_iter()
            .map(|n| n.as_vec3().to_array())
            .collect();
        Snapshot {
            serial,
            generation: self.generation,
            positions,
            exact: Arc::new(x.clone()),
            normals,
            cloth: Arc::clone(&self.cloth),
            config: sim.config().clone(),
            metrics: FrameMetrics {
                time: sim.time() + self.time_offset,
                ..sim.metrics()
            },
            air_enabled: sim.air_enabled(),
            paused: self.paused || self.error.is_some(),
            realtime_factor: self.rates.0,
            steps_per_second: self.rates.1,
            held: interactive_grabs(&self.sim),
            error: self.error.clone(),
            notice: self.notice.clone(),
            pockets: sim.pocket_reports(),
            pocket_of: wetcloth_export::particle_pocket_ids(sim),
        }
    }

    fn reanchor(&mut self) {
        self.anchor = (Instant::now(), self.sim.time());
    }

    fn restart(&mut self, sim: Simulation) {
        self.time_offset = 0.0;
        self.guarded = false;
        let air = self.sim.air_enabled();
        self.initial = sim.clone();
        self.cloth = Arc::new(ClothLayout::new(sim.model(), sim.config()));
        self.sim = sim;
        self.sim.set_air_enabled(air);
        self.generation += 1;
        self.error = None;
        self.reanchor();
        self.window = (Instant::now(), self.sim.time(), self.sim.step_count());
    }

    /// Applies one command; returns false on Quit.
    fn apply(&mut self, cmd: Command) -> bool {
        match cmd {
            Command::Hold { particle, target } => {
                if particle >= self.sim.particle_count() {
                    return true;
                }
                let motion = GrabMotion::Target {
                    target,
                    max_speed: DRAG_SPEED,
                };
                match find_grab(&self.sim, particle) {
                    // While the guard holds, only pulls back down are taken.
                    Some(i)
                        if self.guarded
                            && grab_target(&self.sim, i).is_some_and(|t| target.y > t.y) => {}
                    Some(i) => self.sim.grab_mut(i).motion = motion,
                    None => {
                        self.sim.add_grab(Grab::new(particle, motion));
                    }
                }
            }
            Command::Release { particle } => {
                if let Some(i) = find_grab(&self.sim, particle) {
                    self.sim.remove_grab(i);
                }
            }
            Command::ReleaseAll => {
                while let Some(&p) = interactive_grabs(&self.sim).first() {
                    let i = find_grab(&self.sim, p).expect("listed grab exists");
                    self.sim.remove_grab(i);
                }
            }
            Command::SetAir(on) => {
                if !self.sim.set_air_enabled(on) {
                    self.notify(
                        "the air force needs a plane collider to stick to; this scene has none",
                    );
                }
            }
            Command::Reset => {
                let sim = self.initial.clone();
                self.restart(sim);
            }
            Command::Configure(cfg) => self.configure(*cfg),
            Command::Pause(p) => {
                self.paused = p;
                self.reanchor();
            }
            Command::StepFrame => {
                let frame = 1.0 / 60.0;
                self.pending_frame_steps += (frame / self.sim.time_step()).round().max(1.0) as u64;
            }
            Command::Quit => return false,
        }
        true
    }

    /// Carries the cloth's state over to a simulation with new parameters, or restarts when
    /// the state cannot carry over.
    fn configure(&mut self, cfg: SimConfig) {
        let old = self.sim.config();
        let same_cloth = cfg.cloth.resolution == old.cloth.resolution
            && cfg.cloth.size == old.cloth.size
            && cfg.cloth.mesh == old.cloth.mesh
            && cfg.grabs.is_empty()
            && old.grabs.is_empty();
        let mut sim = match Simulation::new(cfg) {
            Ok(sim) => sim,
            Err(e) => return self.notify(format!("parameters refused: {e}")),
        };
        if !same_cloth || self.error.is_some() {
            return self.restart(sim);
        }
        // Keep the particles' velocities across a new time step.
        let velocities = self.sim.velocities();
        if let Err(e) = sim.set_positions_and_velocities(self.sim.positions().clone(), &velocities)
        {
            return self.notify(format!("parameters refused: {e}"));
        }
        sim.set_air_enabled(self.sim.air_enabled());
        for g in self.sim.grabs() {
            sim.add_grab(Grab::new(g.particle, g.motion.clone()));
        }
        // Reset now starts the scene over with the new parameters.
        if let Ok(fresh) = Simulation::new(sim.config().clone()) {
            self.initial = fresh;
        }
        self.time_offset += self.sim.time();
        self.sim = sim;
        self.reanchor();
        self.window = (Instant::now(), self.sim.time(), self.sim.step_count());
    }

    /// Holds every interactive grab where its particle is once the cloth is stretched past
    /// [`TEAR_GUARD`], and lets go of the hold when it has relaxed.
    fn guard(&mut self) {
        let held = interactive_grabs(&self.sim);
        if held.is_empty() {
            self.guarded = false;
            return;
        }
        let stretch = self.sim.metrics().max_stretch;
        if self.guarded {
            self.guarded = stretch > 0.75 * TEAR_GUARD;
        } else if stretch > TEAR_GUARD {
            self.guarded = true;
            for p in held {
                let here = self.sim.positions().get(p);
                if let Some(i) = find_grab(&self.sim, p) {
                    self.sim.grab_mut(i).motion = GrabMotion::Target {
                        target: here,
                        max_speed: DRAG_SPEED,
                    };
                }
            }
            let air = if self.sim.air_enabled() && self.sim.config().air.trapped_air == 0.0 {
                " With no air under it the atmosphere holds the cloth down: turn the air force \
                 off (A) to lift it further."
            } else {
                ""
            };
            self.notify(format!(
                "Pull held: the cloth is stretched to {:.1} times its rest length and would \
                 tear.{air}",
                1.0 + stretch
            ));
        }
    }

    fn notify(&mut self, text: impl Into<String>) {
        let serial = self.notice.as_ref().map_or(1, |(n, _)| n + 1);
        self.notice = Some((serial, text.into()));
    }

    fn step(&mut self) -> bool {
        match self.sim.step() {
            Ok(()) => {
                if self.sim.step_count().is_multiple_of(GUARD_EVERY) {
                    self.guard();
                }
                true
            }
            Err(e) => {
                self.error = Some(format!("{e}. Press Reset (R) to start again."));
                false
            }
        }
    }

    fn run(mut self, rx: Receiver<Command>, latest: Arc<Mutex<Arc<Snapshot>>>, notify: impl Fn()) {
        self.reanchor();
        loop {
            // Commands first, so a drag target is never older than one slice.
            loop {
                match rx.try_recv() {
                    Ok(cmd) => {
                        if !self.apply(cmd) {
                            return;
                        }
                    }
                    Err(mpsc::TryRecvError::Empty) => break,
                    Err(mpsc::TryRecvError::Disconnected) => return,
                }
            }

            let start = Instant::now();
            let mut stepped = false;
            if self.error.is_none() && self.pending_frame_steps > 0 {
                while self.pending_frame_steps > 0 && start.elapsed() < SLICE {
                    self.pending_frame_steps -= 1;
                    stepped = true;
                    if !self.step() {
                        self.pending_frame_steps = 0;
                    }
                }
                self.reanchor();
            } else if !self.paused && self.error.is_none() {
                let (t0_wall, t0_sim) = self.anchor;
                let goal = t0_sim + t0_wall.elapsed().as_secs_f64();
                if goal - self.sim.time() > MAX_LAG {
                    // Too far behind to catch up: drop the lag, run slower than real time.
                    self.anchor = (Instant::now(), self.sim.time());
                }
                let goal =
                    self.anchor.1 + self.anchor.0.elapsed().as_secs_f64() + SLICE.as_secs_f64();
                let mut n = 0u32;
                while self.sim.time() < goal {
                    stepped = true;
                    if !self.step() {
                        break;
                    }
                    n += 1;
                    if n.is_multiple_of(4) && start.elapsed() >= SLICE {
                        break;
                    }
                }
            }
            self.update_rates();

            if stepped || self.serial == 0 || self.snapshot_stale(&latest) {
                self.serial += 1;
                let snap = Arc::new(self.snapshot(self.serial, None));
                *latest.lock().unwrap_or_else(|e| e.into_inner()) = snap;
                notify();
            }

            if !stepped {
                // Ahead of the clock, paused or stopped: wait for a command or the next slice.
                let wait = if self.paused || self.error.is_some() {
                    Duration::from_millis(50)
                } else {
                    Duration::from_millis(2)
                };
                match rx.recv_timeout(wait) {
                    Ok(cmd) => {
                        if !self.apply(cmd) {
                            return;
                        }
                        // Publish the command's effect (a held target, a reset) right away.
                        self.serial += 1;
                        let snap = Arc::new(self.snapshot(self.serial, None));
                        *latest.lock().unwrap_or_else(|e| e.into_inner()) = snap;
                        notify();
                    }
                    Err(RecvTimeoutError::Timeout) => {}
                    Err(RecvTimeoutError::Disconnected) => return,
                }
            }
        }
    }

    /// Whether the published snapshot misses a change that needs no step to show (pause,
    /// air switch, error, rates while paused).
    fn snapshot_stale(&self, latest: &Mutex<Arc<Snapshot>>) -> bool {
        let s = latest.lock().unwrap_or_else(|e| e.into_inner());
        s.paused != (self.paused || self.error.is_some())
            || s.air_enabled != self.sim.air_enabled()
            || s.error != self.error
            || s.notice != self.notice
            || s.generation != self.generation
            || s.held != interactive_grabs(&self.sim)
            || (s.realtime_factor - self.rates.0).abs() > 1e-3
    }

    fn update_rates(&mut self) {
        let (w0, t0, s0) = self.window;
        let dt = w0.elapsed().as_secs_f64();
        if dt >= 0.5 {
            let sim_dt = self.sim.time() - t0;
            let steps = self.sim.step_count().saturating_sub(s0);
            self.rates = (sim_dt.max(0.0) / dt, steps as f64 / dt);
            self.window = (Instant::now(), self.sim.time(), self.sim.step_count());
        }
    }
}

/// Index of the interactive grab holding `particle`.
fn find_grab(sim: &Simulation, particle: usize) -> Option<usize> {
    sim.grabs()
        .iter()
        .position(|g| g.particle == particle && matches!(g.motion, GrabMotion::Target { .. }))
}

/// Target of grab `i`, if it is an interactive one.
fn grab_target(sim: &Simulation, i: usize) -> Option<Vec3> {
    match sim.grabs()[i].motion {
        GrabMotion::Target { target, .. } => Some(target),
        GrabMotion::Path(_) | GrabMotion::Attached(_) => None,
    }
}

/// Particles held by interactive grabs.
fn interactive_grabs(sim: &Simulation) -> Vec<usize> {
    sim.grabs()
        .iter()
        .filter(|g| matches!(g.motion, GrabMotion::Target { .. }))
        .map(|g| g.particle)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> SimConfig {
        let mut cfg = SimConfig::thesis_demo();
        cfg.grabs.clear();
        cfg.cloth.resolution = [10, 10];
        cfg.simulation.time_step = 1.0 / 2000.0;
        cfg
    }

    fn wait_for(r: &Runner, what: impl Fn(&Snapshot) -> bool) -> Arc<Snapshot> {
        let t = Instant::now();
        loop {
            let s = r.latest();
            if what(&s) {
                return s;
            }
            assert!(
                t.elapsed() < Duration::from_secs(20),
                "timed out: {:?}, error {:?}, notice {:?}",
                s.metrics,
                s.error,
                s.notice
            );
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    #[test]
    fn runs_in_real_time_and_holds_a_grabbed_particle() {
        let r = Runner::start(small(), || {}).unwrap();
        let s = wait_for(&r, |s| s.metrics.time > 0.2);
        assert!(s.error.is_none());
        let k = 55;
        let target = Vec3::new(0.0, 0.05, 0.0);
        r.send(Command::Hold {
            particle: k,
            target,
        });
        let s = wait_for(&r, |s| {
            (Vec3::from(s.positions[k].map(f64::from)) - target).length() < 1e-4
        });
        assert_eq!(s.held, vec![k]);
        assert!(s.metrics.grab_force > 0.0);
        r.send(Command::Release { particle: k });
        wait_for(&r, |s| s.held.is_empty());
    }

    #[test]
    fn a_pull_that_would_tear_the_cloth_is_held() {
        // Air on and no trapped air: the atmosphere holds the cloth down, and pulling one
        // particle 10 cm up would stretch its springs far past TEAR_GUARD.
        let mut cfg = SimConfig::thesis_demo();
        cfg.grabs.clear();
        cfg.cloth.resolution = [20, 20];
        cfg.air.trapped_air = 0.0;
        cfg.cloth.position.y = cfg.cloth.particle_radius();
        let k = 10 * 20 + 10;
        let r = Runner::start(cfg, || {}).unwrap();
        wait_for(&r, |s| s.metrics.time > 0.05);
        let high = Vec3::new(0.0, 0.1, 0.0);
        r.send(Command::Hold {
            particle: k,
            target: high,
        });
        let s = wait_for(&r, |s| s.notice.is_some() || s.error.is_some());
        assert!(s.error.is_none(), "{:?}", s.error);
        assert!(s.notice.as_ref().unwrap().1.contains("Pull held"), "{s:?}");
        let (t, y) = (s.metrics.time, s.positions[k][1]);
        let s = wait_for(&r, |s| s.metrics.time > t + 0.2);
        assert!(s.error.is_none(), "{:?}", s.error);
        assert!(s.metrics.max_stretch < 5.0, "{:?}", s.metrics);
        let y_now = s.positions[k][1];
        assert!(
            y_now < y + 0.005 && y_now < 0.099,
            "the pull stopped: {y} then {y_now}"
        );
        // Pulling higher is ignored; pulling back down is taken.
        r.send(Command::Hold {
            particle: k,
            target: Vec3::new(0.0, 0.005, 0.0),
        });
        wait_for(&r, |s| s.positions[k][1] < 0.006);
    }

    #[test]
    fn pause_stops_time_and_step_frame_advances_it() {
        let r = Runner::start(small(), || {}).unwrap();
        wait_for(&r, |s| s.metrics.time > 0.05);
        r.send(Command::Pause(true));
        let s = wait_for(&r, |s| s.paused);
        std::thread::sleep(Duration::from_millis(100));
        let t = r.latest().metrics.time;
        assert!((t - s.metrics.time).abs() < 0.02);
        r.send(Command::StepFrame);
        let s2 = wait_for(&r, |s| s.metrics.time > t + 1.0 / 60.0 - 1e-3);
        assert!(s2.paused);
    }

    #[test]
    fn reset_goes_back_to_t0_and_a_new_resolution_restarts() {
        let r = Runner::start(small(), || {}).unwrap();
        wait_for(&r, |s| s.metrics.time > 0.1);
        r.send(Command::Reset);
        let s = wait_for(&r, |s| s.generation == 1);
        assert!(s.metrics.time < 0.1);
        let mut cfg = small();
        cfg.cloth.resolution = [12, 8];
        r.send(Command::Configure(Box::new(cfg)));
        let s = wait_for(&r, |s| s.generation == 2);
        assert_eq!(s.cloth.grid, Some([12, 8]));
        assert_eq!(s.positions.len(), 96);
    }

    #[test]
    fn new_parameters_keep_the_cloth_its_grabs_and_the_clock() {
        let r = Runner::start(small(), || {}).unwrap();
        wait_for(&r, |s| s.metrics.time > 0.1);
        let target = Vec3::new(0.0, 0.03, 0.0);
        r.send(Command::Hold {
            particle: 55,
            target,
        });
        let before = wait_for(&r, |s| {
            (Vec3::from(s.positions[55].map(f64::from)) - target).length() < 1e-4
        });
        let mut cfg = small();
        cfg.cloth.structural_stiffness *= 2.0;
        cfg.simulation.time_step *= 0.5;
        r.send(Command::Configure(Box::new(cfg)));
        let s = wait_for(&r, |s| s.config.simulation.time_step < 1.0 / 3000.0);
        assert_eq!(s.generation, before.generation, "no restart");
        assert_eq!(s.held, vec![55]);
        assert!(s.metrics.time >= before.metrics.time, "time goes on");
        assert!((Vec3::from(s.positions[55].map(f64::from)) - target).length() < 1e-3);
        assert!(s.error.is_none());
    }

    /// The shipped mesh scene: a towel hung by its top edge.
    fn towel() -> SimConfig {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../scenes/towel-pinned.toml"
        );
        wetcloth_scene::load(std::path::Path::new(path))
            .unwrap()
            .config
    }

    #[test]
    fn the_normals_are_the_grids_on_the_grid() {
        let mut cfg = small();
        cfg.cloth.resolution = [7, 5];
        let mut sim = Simulation::new(cfg).unwrap();
        sim.advance(50).unwrap();
        let layout = ClothLayout::new(sim.model(), sim.config());
        assert_eq!(layout.grid, Some([7, 5]));
        assert_eq!(layout.grid_particle(6, 4), Some(34));
        assert_eq!(layout.grid_particle(7, 0), None);
        let x = sim.positions();
        assert_eq!(
            vertex_normals(x, &layout.indices),
            sim.model().grid().vertex_normals(x)
        );
    }

    #[test]
    fn a_mesh_cloth_is_drawn_and_any_vertex_can_be_held() {
        let cfg = towel();
        let vertices = cfg.cloth.mesh.as_ref().unwrap().vertices.len();
        let r = Runner::start(cfg, || {}).unwrap();
        let s = wait_for(&r, |s| s.metrics.time > 0.05);
        assert!(s.error.is_none(), "{:?}", s.error);
        assert_eq!(s.cloth.grid, None);
        assert_eq!(s.cloth.particles, vertices);
        assert_eq!(s.positions.len(), vertices);
        assert_eq!(s.normals.len(), vertices);
        assert!(
            s.cloth.describe().contains("towel.obj"),
            "{}",
            s.cloth.describe()
        );
        assert!(s.cloth.indices.iter().all(|&i| (i as usize) < vertices));
        assert!(
            (0.02..0.03).contains(&s.cloth.spacing),
            "{}",
            s.cloth.spacing
        );
        assert_eq!(s.cloth.grid_particle(0, 0), None);
        // The towel hangs in the xy plane: its normals point along z.
        let n = s.normals[300];
        assert!(n[2].abs() > 0.9, "{n:?}");
        // The middle of its bottom edge, pulled up and forward.
        let k = 598;
        let target = Vec3::new(0.05, 0.8, 0.2);
        r.send(Command::Hold {
            particle: k,
            target,
        });
        let s = wait_for(&r, |s| {
            (Vec3::from(s.positions[k].map(f64::from)) - target).length() < 0.01
        });
        assert_eq!(s.held, vec![k]);
        // A particle past the mesh is ignored.
        r.send(Command::Hold {
            particle: vertices,
            target,
        });
        r.send(Command::Release { particle: k });
        let s = wait_for(&r, |s| s.held.is_empty());
        assert!(s.error.is_none(), "{:?}", s.error);
        // A reset keeps the mesh's layout.
        r.send(Command::Reset);
        let s2 = wait_for(&r, |s| s.generation == 1);
        assert_eq!(*s2.cloth, *s.cloth);
    }

    #[test]
    fn a_refused_configuration_is_reported_and_the_run_goes_on() {
        let r = Runner::start(small(), || {}).unwrap();
        let mut cfg = small();
        cfg.simulation.time_step = -1.0;
        r.send(Command::Configure(Box::new(cfg)));
        let s = wait_for(&r, |s| s.notice.is_some());
        assert!(s.notice.as_ref().unwrap().1.contains("time_step"), "{s:?}");
        assert!(s.error.is_none());
        let t = s.metrics.time;
        wait_for(&r, |s| s.metrics.time > t + 0.05);
    }
}
