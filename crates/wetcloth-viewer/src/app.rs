//! The window: panels, readouts, the 3D view and its mouse handling, shortcuts, recording and
//! scripted input.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{self, Receiver};
use std::time::Instant;

use eframe::egui::{
    self, Color32, Event, Key, Modifiers, PointerButton, Pos2, RichText, Sense, Vec2 as EVec2,
};
use egui_plot::{Line, Plot};
use glam::{Mat4, Vec2, Vec3};
use wetcloth::{Grid, Shape, SimConfig};
use wetcloth_render::Solid;

use crate::ViewerOptions;
use crate::camera::OrbitCamera;
use crate::pick::{self, Drag, PICK_RADIUS_PX, Pins, Viewport};
use crate::record::Recorder;
use crate::runner::{Command, Runner, Snapshot};
use crate::script::{self, Command as ScriptCmd};
use crate::view3d;

/// Seconds of history in the live plot.
const PLOT_SECONDS: f64 = 10.0;

/// Vertical move per wheel notch while dragging, m.
const LIFT_PER_NOTCH: f32 = 0.005;

/// What the current pointer drag in the 3D view does.
#[derive(Clone, Copy, Debug, PartialEq)]
enum PointerMode {
    Idle,
    /// A particle is being pulled.
    Particle,
    Orbit,
    Pan,
    /// The left button is still down after a pin; it does nothing until released.
    Spent,
}

/// Parameters being edited, applied with one button.
#[derive(Clone, Debug, PartialEq)]
struct Edit {
    air_cm3: f64,
    structural: f64,
    shear: f64,
    friction: f64,
    damping: f64,
    /// Steps per second (1 / time step).
    rate: f64,
    resolution: usize,
}

impl Edit {
    fn from_config(c: &SimConfig) -> Self {
        Self {
            air_cm3: c.air.trapped_air * 1e6,
            structural: c.cloth.structural_stiffness,
            shear: c.cloth.shear_stiffness,
            friction: c.colliders.first().map_or(0.0, |c| c.friction),
            damping: c.cloth.damping,
            rate: (1.0 / c.simulation.time_step).round(),
            resolution: c.cloth.resolution[0],
        }
    }

    /// `base` with the edited values; values left alone keep their exact scene value (the
    /// sliders show rounded ones, e.g. a time step of 8.333e-5 s as 1/12000 s).
    fn apply(&self, base: &SimConfig) -> SimConfig {
        let now = Self::from_config(base);
        let mut c = base.clone();
        if self.air_cm3 != now.air_cm3 {
            c.air.trapped_air = self.air_cm3 * 1e-6;
        }
        if self.structural != now.structural {
            c.cloth.structural_stiffness = self.structural;
        }
        if self.shear != now.shear {
            c.cloth.shear_stiffness = self.shear;
        }
        if self.friction != now.friction {
            for col in &mut c.colliders {
                col.friction = self.friction;
            }
        }
        if self.damping != now.damping {
            c.cloth.damping = self.damping;
        }
        if self.rate != now.rate {
            c.simulation.time_step = 1.0 / self.rate;
        }
        if self.resolution != c.cloth.resolution[0] {
            // Keep the aspect of non-square grids; scene grabs name particles of the old grid.
            let r0 = c.cloth.resolution;
            let ratio = r0[1] as f64 / r0[0] as f64;
            c.cloth.resolution = [
                self.resolution,
                ((self.resolution as f64 * ratio).round() as usize).max(2),
            ];
            c.grabs.clear();
        }
        c
    }
}

/// Replays a script, one command at a time, as input events.
struct Player {
    commands: VecDeque<ScriptCmd>,
    /// The current command started at this instant, frame and simulated time.
    started: Option<(Instant, u64, f64)>,
    /// Pointer position, normalised view coordinates.
    pointer: [f32; 2],
    /// Left button down.
    pressed: bool,
    /// Drag in progress: from, to, frames, frames done.
    drag: Option<([f32; 2], [f32; 2], u32, u32)>,
    /// Waiting for a screenshot to be written.
    shot: Option<Receiver<Result<PathBuf, String>>>,
    finished: bool,
}

/// Shared results of the viewer run, read by [`crate::run`] after the window closes.
#[derive(Default)]
pub(crate) struct Outcome {
    pub(crate) error: Option<String>,
}

/// The application.
pub(crate) struct ViewerApp {
    runner: Runner,
    scene_name: String,
    scene_path: String,
    snap: Arc<Snapshot>,
    mesh: MeshCache,
    camera: OrbitCamera,
    pick_mode: bool,
    mode: PointerMode,
    drag: Option<Drag>,
    pins: Pins,
    hover: Option<usize>,
    view_rect: egui::Rect,
    view_proj: Mat4,
    history: VecDeque<[f64; 3]>,
    last_plot_time: f64,
    frame_time: (Option<Instant>, f64),
    frames: u64,
    edit: Edit,
    base_config: SimConfig,
    recorder: Option<Recorder>,
    record_dir: String,
    last_recorded: u64,
    message: Option<(String, bool)>,
    show_help: bool,
    player: Option<Player>,
    exit_after_script: bool,
    final_screenshot: Option<PathBuf>,
    outcome: Arc<std::sync::Mutex<Outcome>>,
    closing: bool,
}

/// Triangle indices of the current grid (they change only on a restart).
struct MeshCache {
    generation: u64,
    resolution: [usize; 2],
    indices: Arc<Vec<u32>>,
}

impl MeshCache {
    fn new(snap: &Snapshot) -> Self {
        let grid = Grid::new(&snap.config.cloth);
        Self {
            generation: snap.generation,
            resolution: snap.resolution,
            indices: Arc::new(grid.triangles().into_iter().flatten().collect()),
        }
    }
}

impl ViewerApp {
    pub(crate) fn new(
        cc: &eframe::CreationContext<'_>,
        opts: ViewerOptions,
        script: Vec<ScriptCmd>,
        outcome: Arc<std::sync::Mutex<Outcome>>,
    ) -> Result<Self, String> {
        let render_state = cc
            .wgpu_render_state
            .as_ref()
            .ok_or("the window has no wgpu renderer")?;
        view3d::install(render_state);
        let ctx = cc.egui_ctx.clone();
        let base_config = opts.scene.clone();
        let runner = Runner::start(opts.scene, move || ctx.request_repaint())
            .map_err(|e| format!("the scene is invalid: {e}"))?;
        let snap = runner.latest();
        let c = &snap.config.cloth;
        let camera = OrbitCamera::framing(
            glam::DVec3::new(c.position.x, c.position.y, c.position.z).as_vec3(),
            c.size[0].max(c.size[1]) as f32,
        );
        style(&cc.egui_ctx);
        Ok(Self {
            mesh: MeshCache::new(&snap),
            edit: Edit::from_config(&snap.config),
            base_config,
            runner,
            scene_name: opts.scene_name,
            scene_path: opts
                .scene_path
                .map(|p| p.display().to_string())
                .unwrap_or_default(),
            snap,
            camera,
            pick_mode: true,
            mode: PointerMode::Idle,
            drag: None,
            pins: Pins::default(),
            hover: None,
            view_rect: egui::Rect::from_min_size(Pos2::ZERO, EVec2::splat(1.0)),
            view_proj: Mat4::IDENTITY,
            history: VecDeque::new(),
            last_plot_time: -1.0,
            frame_time: (None, 0.0),
            frames: 0,
            recorder: None,
            record_dir: opts
                .record_dir
                .map(|p| p.display().to_string())
                .unwrap_or_else(|| "runs/view".into()),
            last_recorded: 0,
            message: None,
            show_help: false,
            player: (opts.script.is_some() || opts.screenshot.is_some()).then(|| Player {
                commands: script.into(),
                started: None,
                pointer: [0.5, 0.5],
                pressed: false,
                drag: None,
                shot: None,
                finished: false,
            }),
            exit_after_script: opts.exit_after_script,
            final_screenshot: opts.screenshot,
            outcome,
            closing: false,
        })
    }

    fn say(&mut self, text: impl Into<String>) {
        self.message = Some((text.into(), false));
    }

    fn warn(&mut self, text: impl Into<String>) {
        self.message = Some((text.into(), true));
    }

    fn forward(&self) -> Vec3 {
        self.camera.forward()
    }

    fn viewport(&self) -> Viewport {
        Viewport {
            width: self.view_rect.width(),
            height: self.view_rect.height(),
        }
    }

    fn to_view(&self, p: Pos2) -> Vec2 {
        Vec2::new(p.x - self.view_rect.min.x, p.y - self.view_rect.min.y)
    }

    fn particle(&self, k: usize) -> Vec3 {
        Vec3::from_array(self.snap.positions[k])
    }

    // ----- actions (buttons and shortcuts share these) -----

    fn toggle_air(&mut self) {
        let on = !self.snap.air_enabled;
        self.runner.send(Command::SetAir(on));
        self.say(if on {
            "Air pressure force on: the cloth sticks"
        } else {
            "Air pressure force off: the cloth lifts freely"
        });
    }

    fn toggle_pick(&mut self) {
        self.pick_mode = !self.pick_mode;
        if !self.pick_mode {
            self.end_drag();
        }
    }

    fn reset(&mut self) {
        self.end_drag();
        self.pins.clear();
        self.runner.send(Command::Reset);
        self.history.clear();
        self.last_plot_time = -1.0;
        self.say("Reset to the scene's initial state");
    }

    fn toggle_pause(&mut self) {
        self.runner.send(Command::Pause(!self.snap.paused));
    }

    fn step_frame(&mut self) {
        if !self.snap.paused {
            self.runner.send(Command::Pause(true));
        }
        self.runner.send(Command::StepFrame);
    }

    fn release_pins(&mut self) {
        for p in self.pins.clear() {
            self.runner.send(Command::Release { particle: p });
        }
        self.say("Released every pinned particle");
    }

    fn toggle_record(&mut self) {
        if let Some(rec) = self.recorder.take() {
            let dir = rec.dir().to_path_buf();
            match rec.finish() {
                Ok(n) => self.say(format!("Recorded {n} frames to {}", dir.display())),
                Err(e) => self.warn(format!("Recording failed: {e}")),
            }
            return;
        }
        let dir = PathBuf::from(self.record_dir.trim());
        match Recorder::start(&dir, &self.scene_name, &self.snap.config) {
            Ok(r) => {
                self.recorder = Some(r);
                self.last_recorded = 0;
                self.say(format!("Recording to {}", dir.display()));
            }
            Err(e) => self.warn(format!("Cannot record to {}: {e}", dir.display())),
        }
    }

    fn apply_params(&mut self) {
        let cfg = self.edit.apply(&self.snap.config);
        let restarts = cfg.cloth.resolution != self.snap.config.cloth.resolution
            || !cfg.grabs.is_empty()
            || self.snap.error.is_some();
        self.runner.send(Command::Configure(Box::new(cfg)));
        if restarts {
            self.end_drag();
            self.pins.clear();
            self.say("New resolution: the run restarted");
        } else {
            self.say("Parameters applied");
        }
    }

    fn open_scene(&mut self) {
        let path = PathBuf::from(self.scene_path.trim());
        match wetcloth_scene::load(&path) {
            Ok(scene) => {
                let mut cfg = scene.config;
                cfg.air.enabled = cfg.air.enabled && cfg.sticking_plane().is_some();
                self.base_config = cfg.clone();
                self.edit = Edit::from_config(&cfg);
                self.end_drag();
                self.pins.clear();
                self.runner.send(Command::Configure(Box::new(cfg)));
                self.history.clear();
                self.last_plot_time = -1.0;
                self.scene_name = scene.name;
                let c = &self.base_config.cloth;
                self.camera =
                    OrbitCamera::framing(c.position.as_vec3(), c.size[0].max(c.size[1]) as f32);
                self.say(format!("Opened {}", path.display()));
            }
            Err(e) => self.warn(format!("Cannot open {}: {e}", path.display())),
        }
    }

    fn end_drag(&mut self) {
        if let Some(d) = self.drag.take()
            && !self.pins.is_pinned(d.particle)
        {
            self.runner.send(Command::Release {
                particle: d.particle,
            });
        }
        if self.mode == PointerMode::Particle {
            self.mode = PointerMode::Idle;
        }
    }

    // ----- input -----

    fn shortcuts(&mut self, ctx: &egui::Context) {
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        // A button clicked with the mouse keeps the focus, and Space would press it again on
        // top of the shortcut: keyboard focus stays with text fields only.
        ctx.memory_mut(|m| {
            if let Some(id) = m.focused() {
                m.surrender_focus(id);
            }
        });
        let pressed: Vec<(Key, Modifiers)> = ctx.input(|i| {
            i.events
                .iter()
                .filter_map(|e| match e {
                    Event::Key {
                        key,
                        pressed: true,
                        repeat: false,
                        modifiers,
                        ..
                    } => Some((*key, *modifiers)),
                    _ => None,
                })
                .collect()
        });
        for (key, m) in pressed {
            if m.ctrl || m.command || m.alt {
                continue;
            }
            match key {
                Key::A => self.toggle_air(),
                Key::P => self.toggle_pick(),
                Key::R => self.reset(),
                Key::Space => self.toggle_pause(),
                Key::S | Key::Period => self.step_frame(),
                Key::U => self.release_pins(),
                Key::C => self.toggle_record(),
                Key::H | Key::F1 => self.show_help = !self.show_help,
                Key::V => {
                    let c = &self.snap.config.cloth;
                    self.camera =
                        OrbitCamera::framing(c.position.as_vec3(), c.size[0].max(c.size[1]) as f32);
                }
                Key::Escape => self.end_drag(),
                _ => {}
            }
        }
    }

    /// Mouse handling in the 3D view.
    fn view_input(&mut self, ui: &egui::Ui, response: &egui::Response) {
        let (pointer, delta, shift, primary_pressed, primary_down, middle_pressed) =
            ui.input(|i| {
                (
                    i.pointer.latest_pos(),
                    i.pointer.delta(),
                    i.modifiers.shift,
                    i.pointer.button_pressed(PointerButton::Primary),
                    i.pointer.button_down(PointerButton::Primary),
                    i.pointer.button_pressed(PointerButton::Middle),
                )
            });
        let secondary_pressed = ui.input(|i| i.pointer.button_pressed(PointerButton::Secondary));
        let any_down = ui.input(|i| i.pointer.any_down());
        let notches: f32 = ui.input(|i| {
            i.events
                .iter()
                .map(|e| match e {
                    Event::MouseWheel { unit, delta, .. } => match unit {
                        egui::MouseWheelUnit::Line => delta.y,
                        egui::MouseWheelUnit::Page => delta.y * 3.0,
                        egui::MouseWheelUnit::Point => delta.y / 50.0,
                    },
                    _ => 0.0,
                })
                .sum()
        });
        // Over the view and not over a window on top of it (the help).
        let inside = response.contains_pointer();
        let vp = self.viewport();

        // Hover highlight in pick mode.
        self.hover = match (self.pick_mode, pointer, self.mode) {
            (true, Some(p), PointerMode::Idle) if inside => pick::pick_particle(
                self.view_proj,
                vp,
                &self.snap.positions,
                self.to_view(p),
                PICK_RADIUS_PX,
            ),
            _ => None,
        };

        // Presses start a mode.
        if let Some(p) = pointer
            && inside
            && self.mode == PointerMode::Idle
        {
            if primary_pressed {
                let picked = if self.pick_mode {
                    pick::pick_particle(
                        self.view_proj,
                        vp,
                        &self.snap.positions,
                        self.to_view(p),
                        PICK_RADIUS_PX,
                    )
                } else {
                    None
                };
                match picked {
                    Some(k) => {
                        // Picking a pinned particle takes it off its pin and into the hand.
                        let start = self.pins.target(k).unwrap_or_else(|| self.particle(k));
                        self.pins.unpin(k);
                        let drag = Drag::begin(k, start, self.forward());
                        self.runner.send(Command::Hold {
                            particle: k,
                            target: drag.target.as_dvec3(),
                        });
                        self.drag = Some(drag);
                        self.mode = PointerMode::Particle;
                    }
                    None => {
                        self.mode = if shift {
                            PointerMode::Pan
                        } else {
                            PointerMode::Orbit
                        }
                    }
                }
            } else if middle_pressed {
                self.mode = PointerMode::Orbit;
            } else if secondary_pressed {
                self.mode = PointerMode::Pan;
            }
        }

        match self.mode {
            PointerMode::Particle => {
                if secondary_pressed {
                    // Right click while dragging: pin it where it is.
                    if let Some(d) = self.drag.take() {
                        self.pins.pin(d.particle, d.target);
                        self.say(format!(
                            "Pinned particle {} (click it to release, U releases all)",
                            d.particle
                        ));
                    }
                    self.mode = PointerMode::Spent;
                } else if !primary_down {
                    self.end_drag();
                    self.mode = PointerMode::Idle;
                } else if let Some(mut d) = self.drag {
                    let before = d.target;
                    if notches != 0.0 {
                        d.lift(notches * LIFT_PER_NOTCH);
                    }
                    if shift {
                        let mpp = pick::metres_per_pixel(self.view_proj, vp, d.target);
                        d.lift(-delta.y * mpp);
                    } else if delta != EVec2::ZERO
                        && let Some(p) = pointer
                    {
                        let ray = pick::ray_through(self.view_proj, vp, self.to_view(p));
                        d.follow(&ray);
                    }
                    if d.target != before {
                        self.runner.send(Command::Hold {
                            particle: d.particle,
                            target: d.target.as_dvec3(),
                        });
                    }
                    self.drag = Some(d);
                }
            }
            PointerMode::Orbit => {
                self.camera.orbit(Vec2::new(delta.x, delta.y));
                if !any_down {
                    self.mode = PointerMode::Idle;
                }
            }
            PointerMode::Pan => {
                self.camera
                    .pan(Vec2::new(delta.x, delta.y), self.view_rect.height());
                if !any_down {
                    self.mode = PointerMode::Idle;
                }
            }
            PointerMode::Spent => {
                if !any_down {
                    self.mode = PointerMode::Idle;
                }
            }
            PointerMode::Idle => {
                if inside && notches != 0.0 {
                    self.camera.zoom(notches);
                }
            }
        }
    }

    // ----- scripted input -----

    /// Turns the next script commands into input events for this frame.
    fn script_events(&mut self, ctx: &egui::Context, raw: &mut egui::RawInput) {
        let frames = self.frames;
        let rect = self.view_rect;
        let to_pos = |p: [f32; 2]| {
            Pos2::new(
                rect.min.x + p[0] * rect.width(),
                rect.min.y + p[1] * rect.height(),
            )
        };
        let snap = Arc::clone(&self.snap);
        let (view_proj, vp) = (self.view_proj, self.viewport());
        let Some(pl) = &mut self.player else {
            return;
        };
        if pl.finished {
            return;
        }
        // Never act before the first frame has laid the view out.
        if frames < 3 {
            return;
        }
        let mut events = Vec::new();
        let mut actions = Vec::new();
        loop {
            if let Some(rx) = &pl.shot {
                match rx.try_recv() {
                    Ok(r) => {
                        pl.shot = None;
                        actions.push(ScriptAction::ShotDone(r));
                    }
                    Err(mpsc::TryRecvError::Empty) => break,
                    Err(mpsc::TryRecvError::Disconnected) => {
                        pl.shot = None;
                        actions.push(ScriptAction::ShotDone(Err(
                            "the screenshot was never taken".into(),
                        )));
                    }
                }
            }
            let Some(cmd) = pl.commands.front().cloned() else {
                pl.finished = true;
                actions.push(ScriptAction::Finished);
                break;
            };
            let (t0, f0, sim0) =
                *pl.started
                    .get_or_insert((Instant::now(), frames, snap.metrics.time));
            let done = match cmd {
                ScriptCmd::Wait(s) => t0.elapsed().as_secs_f64() >= s,
                ScriptCmd::WaitFrames(n) => frames >= f0 + u64::from(n),
                ScriptCmd::WaitSim { time, relative } => {
                    let goal = if relative { sim0 + time } else { time };
                    snap.metrics.time >= goal || snap.error.is_some() || snap.paused
                }
                ScriptCmd::Move(p) => {
                    pl.pointer = p;
                    events.push(Event::PointerMoved(to_pos(p)));
                    true
                }
                ScriptCmd::Pick(p) => {
                    pl.pointer = p;
                    pl.pressed = true;
                    events.push(Event::PointerMoved(to_pos(p)));
                    events.push(button(to_pos(p), PointerButton::Primary, true));
                    true
                }
                ScriptCmd::PickParticle([i, j]) => {
                    let [nx, nz] = snap.resolution;
                    let k = (i < nx && j < nz).then(|| j * nx + i);
                    let proj = k.and_then(|k| {
                        pick::project(view_proj, vp, Vec3::from_array(snap.positions[k]))
                    });
                    match proj {
                        Some(q) => {
                            let p = [q.pixel.x / vp.width, q.pixel.y / vp.height];
                            pl.pointer = p;
                            pl.pressed = true;
                            events.push(Event::PointerMoved(to_pos(p)));
                            events.push(button(to_pos(p), PointerButton::Primary, true));
                        }
                        None => actions.push(ScriptAction::Warn(format!(
                            "script: particle ({i}, {j}) is not on screen"
                        ))),
                    }
                    true
                }
                ScriptCmd::DragTo { to, frames: n } => {
                    let (from, to, n, done) = *pl.drag.get_or_insert((pl.pointer, to, n, 0));
                    let done = done + 1;
                    let s = done as f32 / n as f32;
                    let p = [
                        from[0] + (to[0] - from[0]) * s,
                        from[1] + (to[1] - from[1]) * s,
                    ];
                    pl.pointer = p;
                    events.push(Event::PointerMoved(to_pos(p)));
                    if done >= n {
                        pl.drag = None;
                        true
                    } else {
                        pl.drag = Some((from, to, n, done));
                        // One step of the move per frame.
                        break;
                    }
                }
                ScriptCmd::Wheel(n) => {
                    events.push(Event::MouseWheel {
                        unit: egui::MouseWheelUnit::Line,
                        delta: EVec2::new(0.0, n),
                        phase: egui::TouchPhase::Move,
                        source: egui::MouseWheelSource::Wheel,
                        modifiers: Modifiers::NONE,
                    });
                    true
                }
                ScriptCmd::Pin => {
                    let p = to_pos(pl.pointer);
                    events.push(button(p, PointerButton::Secondary, true));
                    events.push(button(p, PointerButton::Secondary, false));
                    true
                }
                ScriptCmd::Release => {
                    pl.pressed = false;
                    events.push(button(to_pos(pl.pointer), PointerButton::Primary, false));
                    true
                }
                ScriptCmd::Key(name) => {
                    if let Some(key) = script::key_from_name(&name) {
                        for pressed in [true, false] {
                            events.push(Event::Key {
                                key,
                                physical_key: Some(key),
                                pressed,
                                repeat: false,
                                modifiers: Modifiers::NONE,
                            });
                        }
                    }
                    true
                }
                ScriptCmd::Screenshot(path) => {
                    pl.shot = Some(request_screenshot(ctx, path, rect));
                    pl.commands.pop_front();
                    pl.started = None;
                    break;
                }
                ScriptCmd::Quit => {
                    actions.push(ScriptAction::Quit);
                    pl.commands.clear();
                    pl.finished = true;
                    break;
                }
            };
            if !done {
                break;
            }
            pl.commands.pop_front();
            pl.started = None;
            // Button changes take effect one frame at a time, like a real mouse.
            if !events.is_empty() {
                break;
            }
        }
        raw.events.extend(events);
        for a in actions {
            match a {
                ScriptAction::ShotDone(Ok(p)) => self.say(format!("Saved {}", p.display())),
                ScriptAction::ShotDone(Err(e)) => {
                    self.fail(format!("screenshot failed: {e}"));
                }
                ScriptAction::Warn(w) => self.fail(w),
                ScriptAction::Finished => self.script_finished(ctx),
                ScriptAction::Quit => self.close(ctx),
            }
        }
    }

    fn fail(&mut self, text: String) {
        self.warn(text.clone());
        let mut o = self.outcome.lock().unwrap_or_else(|e| e.into_inner());
        o.error.get_or_insert(text);
    }

    fn script_finished(&mut self, ctx: &egui::Context) {
        if let Some(path) = self.final_screenshot.take() {
            // Take it, then finish once it is written.
            if let Some(pl) = &mut self.player {
                pl.finished = false;
                pl.shot = Some(request_screenshot(ctx, path, self.view_rect));
            }
            return;
        }
        if self.exit_after_script {
            self.close(ctx);
        }
    }

    fn close(&mut self, ctx: &egui::Context) {
        if let Some(rec) = self.recorder.take()
            && let Err(e) = rec.finish()
        {
            self.fail(format!("recording failed: {e}"));
        }
        self.closing = true;
        ctx.send_viewport_cmd(egui::ViewportCommand::Close);
    }

    // ----- per-frame bookkeeping -----

    fn refresh(&mut self) {
        let snap = self.runner.latest();
        if let Some((n, text)) = &snap.notice
            && self.snap.notice.as_ref().map(|(m, _)| m) != Some(n)
        {
            self.message = Some((text.clone(), true));
        }
        if snap.generation != self.mesh.generation || snap.resolution != self.mesh.resolution {
            self.mesh = MeshCache::new(&snap);
            self.edit = Edit::from_config(&snap.config);
            self.drag = None;
            self.pins.clear();
            if self.mode == PointerMode::Particle {
                self.mode = PointerMode::Spent;
            }
        }
        // Plot history, one point per 1/60 s of simulated time.
        let t = snap.metrics.time;
        if t < self.last_plot_time {
            self.history.clear();
        }
        if t >= self.last_plot_time + 1.0 / 60.0 || self.history.is_empty() {
            self.history.push_back([
                t,
                snap.metrics.air_volume * 1e6,
                snap.metrics.air_pressure * 1e-3,
            ]);
            self.last_plot_time = t;
            while self
                .history
                .front()
                .is_some_and(|h| h[0] < t - PLOT_SECONDS)
            {
                self.history.pop_front();
            }
        }
        if let Some(rec) = &mut self.recorder
            && snap.serial != self.last_recorded
        {
            rec.record(Arc::clone(&snap.exact), snap.metrics);
            self.last_recorded = snap.serial;
        }
        let now = Instant::now();
        if let Some(prev) = self.frame_time.0 {
            let dt = now.duration_since(prev).as_secs_f64();
            self.frame_time.1 = if self.frame_time.1 == 0.0 {
                dt
            } else {
                0.9 * self.frame_time.1 + 0.1 * dt
            };
        }
        self.frame_time.0 = Some(now);
        self.snap = snap;
    }

    // ----- panels -----

    fn toolbar(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            ui.label(RichText::new("wetcloth").strong().size(16.0));
            ui.label(RichText::new(&self.scene_name).weak());
            ui.separator();
            let air = self.snap.air_enabled;
            if ui
                .selectable_label(air, if air { "(1) Air: on" } else { "(1) Air: off" })
                .on_hover_text("Air-pressure force on/off [A]")
                .clicked()
            {
                self.toggle_air();
            }
            if ui
                .selectable_label(self.pick_mode, "(2) Pick mode")
                .on_hover_text(
                    "Show the particles; drag one to pull it, right click while dragging to pin \
                     it [P]",
                )
                .clicked()
            {
                self.toggle_pick();
            }
            if ui
                .button("(3) Reset")
                .on_hover_text("Back to the scene's initial state [R]")
                .clicked()
            {
                self.reset();
            }
            ui.separator();
            let paused = self.snap.paused;
            if ui
                .button(if paused { "Run" } else { "Pause" })
                .on_hover_text("Pause or resume [Space]")
                .clicked()
            {
                self.toggle_pause();
            }
            if ui
                .button("Step")
                .on_hover_text("Advance one frame, 1/60 s [S] or [.]")
                .clicked()
            {
                self.step_frame();
            }
            ui.add_enabled_ui(!self.pins.is_empty(), |ui| {
                if ui
                    .button(format!("Release pins ({})", self.pins.len()))
                    .on_hover_text("Let go of every pinned particle [U]")
                    .clicked()
                {
                    self.release_pins();
                }
            });
            let rec = self.recorder.is_some();
            if ui
                .selectable_label(rec, if rec { "● Recording" } else { "Record" })
                .on_hover_text("Record frames (OBJ) and metrics.csv to the run folder [C]")
                .clicked()
            {
                self.toggle_record();
            }
            if ui
                .selectable_label(self.show_help, "? Help")
                .on_hover_text("Controls and shortcuts [H]")
                .clicked()
            {
                self.show_help = !self.show_help;
            }
        });
    }

    fn readouts(&mut self, ui: &mut egui::Ui) {
        let s = Arc::clone(&self.snap);
        let m = &s.metrics;
        ui.heading("Live");
        egui::Grid::new("readouts")
            .num_columns(2)
            .spacing([16.0, 3.0])
            .show(ui, |ui| {
                let row = |ui: &mut egui::Ui, name: &str, value: RichText| {
                    ui.label(name);
                    ui.label(value.monospace());
                    ui.end_row();
                };
                row(ui, "Simulated time", format!("{:8.3} s", m.time).into());
                let rtf = s.realtime_factor;
                let rtf_text = if s.paused {
                    RichText::new("  paused")
                } else if rtf < 0.95 {
                    RichText::new(format!("{rtf:8.2} ×  behind"))
                        .color(Color32::from_rgb(230, 170, 60))
                } else {
                    RichText::new(format!("{rtf:8.2} ×"))
                };
                row(ui, "Real-time factor", rtf_text);
                row(
                    ui,
                    "Steps / s",
                    format!("{:8.0}", s.steps_per_second).into(),
                );
                let fps = if self.frame_time.1 > 0.0 {
                    1.0 / self.frame_time.1
                } else {
                    0.0
                };
                row(ui, "Frame rate", format!("{fps:8.1} fps").into());
                row(
                    ui,
                    "Bubble volume",
                    format!("{:8.2} cm³", no_negative_zero(m.air_volume * 1e6, 0.005)).into(),
                );
                row(
                    ui,
                    "Bubble pressure",
                    format!("{:8.2} kPa", m.air_pressure * 1e-3).into(),
                );
                row(ui, "Grab force", format!("{:8.3} N", m.grab_force).into());
                row(
                    ui,
                    "Highest point",
                    format!("{:8.1} mm", m.max_height * 1e3).into(),
                );
                row(
                    ui,
                    "In contact",
                    format!("{:8.0} %", m.contact_fraction * 100.0).into(),
                );
            });
        ui.add_space(6.0);
        let link = egui::Id::unique("wetcloth plots");
        let vol: Vec<[f64; 2]> = self.history.iter().map(|h| [h[0], h[1]]).collect();
        let pres: Vec<[f64; 2]> = self.history.iter().map(|h| [h[0], h[2]]).collect();
        let atm = s.config.air.atmospheric_pressure * 1e-3;
        ui.label(RichText::new("Pressure (kPa)").small());
        Plot::new("pressure")
            .height(80.0)
            .link_axis(link, [true, false])
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .show_x(false)
            .include_y(0.0)
            .include_y(atm)
            .show(ui, |p| {
                p.line(Line::new("pressure", pres).color(Color32::from_rgb(90, 160, 240)));
            });
        ui.label(RichText::new("Bubble volume (cm³)").small());
        Plot::new("volume")
            .height(80.0)
            .link_axis(link, [true, false])
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .show_x(false)
            .include_y(0.0)
            .include_y(1.0)
            .show(ui, |p| {
                p.line(Line::new("volume", vol).color(Color32::from_rgb(240, 150, 80)));
            });
    }

    fn parameters(&mut self, ui: &mut egui::Ui) {
        let e = &mut self.edit;
        // A change applies when the slider is let go (or a typed value is entered), so a drag
        // across the range does not restart anything on the way.
        let mut commit = false;
        let mut done = |r: egui::Response| {
            commit |= r.drag_stopped() || (r.changed() && !r.dragged());
        };
        egui::Grid::new("params")
            .num_columns(2)
            .spacing([8.0, 4.0])
            .show(ui, |ui| {
                ui.label("Air amount").on_hover_text(
                    "Trapped air v0 at atmospheric pressure (thesis: 0 and 400 cm³)",
                );
                done(ui.add(egui::Slider::new(&mut e.air_cm3, 0.0..=1000.0).suffix(" cm³")));
                ui.end_row();
                ui.label("Structural k");
                done(
                    ui.add(
                        egui::Slider::new(&mut e.structural, 10.0..=20000.0)
                            .logarithmic(true)
                            .suffix(" N/m"),
                    ),
                );
                ui.end_row();
                ui.label("Shear k");
                done(
                    ui.add(
                        egui::Slider::new(&mut e.shear, 1.0..=20000.0)
                            .logarithmic(true)
                            .suffix(" N/m"),
                    ),
                );
                ui.end_row();
                ui.label("Friction μ");
                done(ui.add(egui::Slider::new(&mut e.friction, 0.0..=2.0)));
                ui.end_row();
                ui.label("Damping");
                done(ui.add(egui::Slider::new(&mut e.damping, 0.0..=20.0).suffix(" 1/s")));
                ui.end_row();
                ui.label("Time step");
                done(
                    ui.add(
                        egui::Slider::new(&mut e.rate, 1000.0..=40000.0)
                            .logarithmic(true)
                            .prefix("1/")
                            .suffix(" s")
                            .integer(),
                    ),
                );
                ui.end_row();
                ui.label("Resolution")
                    .on_hover_text("Particles per side; a new resolution restarts the run");
                done(ui.add(egui::Slider::new(&mut e.resolution, 4..=100).suffix(" per side")));
                ui.end_row();
            });
        let stable = self.edit.apply(&self.snap.config).stable_time_step();
        if 1.0 / self.edit.rate > stable {
            ui.label(
                RichText::new(format!(
                    "Above this cloth's stable time step, 1/{:.0} s",
                    (1.0 / stable).ceil()
                ))
                .color(Color32::from_rgb(200, 120, 20)),
            );
        }
        let changed = Edit::from_config(&self.snap.config) != self.edit;
        if commit && changed {
            self.apply_params();
        }
        ui.horizontal(|ui| {
            if ui
                .button("Scene defaults")
                .on_hover_text("Back to the parameters of the scene as loaded")
                .clicked()
            {
                self.edit = Edit::from_config(&self.base_config);
                if Edit::from_config(&self.snap.config) != self.edit {
                    self.apply_params();
                }
            }
        });
    }

    fn files(&mut self, ui: &mut egui::Ui) {
        ui.label("Scene file (TOML)");
        ui.horizontal(|ui| {
            let w = ui.available_width() - 60.0;
            ui.add(
                egui::TextEdit::singleline(&mut self.scene_path)
                    .desired_width(w)
                    .hint_text("scenes/air-400.toml"),
            );
            if ui.button("Open").clicked() {
                self.open_scene();
            }
        });
        ui.label("Run folder for recording");
        ui.horizontal(|ui| {
            let w = ui.available_width() - 60.0;
            ui.add_enabled(
                self.recorder.is_none(),
                egui::TextEdit::singleline(&mut self.record_dir).desired_width(w),
            );
            let label = if self.recorder.is_some() {
                "Stop"
            } else {
                "Start"
            };
            if ui.button(label).clicked() {
                self.toggle_record();
            }
        });
        if let Some(r) = &self.recorder {
            ui.label(
                RichText::new(format!("● {} frames → {}", r.frames(), r.dir().display()))
                    .color(Color32::from_rgb(230, 80, 70)),
            );
        }
    }

    fn status_bar(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            if let Some(err) = self.snap.error.clone() {
                ui.label(
                    RichText::new(format!("Stopped: {err}")).color(Color32::from_rgb(220, 60, 50)),
                );
                if ui.button("Reset").clicked() {
                    self.reset();
                }
                return;
            }
            match &self.message {
                Some((m, true)) => {
                    ui.label(RichText::new(m).color(Color32::from_rgb(240, 170, 60)));
                }
                Some((m, false)) => {
                    ui.label(m);
                }
                None => {
                    ui.label(
                        RichText::new(
                            "Drag a particle to pull the cloth · right click while dragging pins it · \
                             H for help",
                        )
                        .weak(),
                    );
                }
            }
        });
    }

    fn help(&mut self, ctx: &egui::Context) {
        let mut open = self.show_help;
        let pos = self.view_rect.left_top() + EVec2::new(10.0, 10.0);
        egui::Window::new("Controls")
            .open(&mut open)
            .resizable(false)
            .collapsible(false)
            .default_pos(pos)
            .show(ctx, |ui| {
                egui::Grid::new("help")
                    .num_columns(2)
                    .spacing([12.0, 1.0])
                    .striped(true)
                    .show(ui, |ui| {
                        for (k, what) in HELP {
                            ui.label(RichText::new(*k).small().strong());
                            ui.label(RichText::new(*what).small());
                            ui.end_row();
                        }
                    });
            });
        self.show_help = open;
    }

    fn view(&mut self, ui: &mut egui::Ui) {
        let (rect, response) = ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
        self.view_rect = rect;
        let vp = self.viewport();
        self.view_proj = self.camera.view_proj(vp.aspect());
        self.view_input(ui, &response);
        self.view_proj = self.camera.view_proj(vp.aspect());

        let s = &self.snap;
        let frame = view3d::Frame {
            positions: s.positions.clone(),
            normals: s.normals.clone(),
            indices: Arc::clone(&self.mesh.indices),
            ground: s
                .config
                .sticking_plane()
                .map(|p| (p.point.as_vec3(), p.up.as_vec3())),
            solids: solids(&s.config),
            show_particles: self.pick_mode,
            particle_radius: particle_size(&s.config),
            highlight: self.drag.map(|d| d.particle).or(self.hover),
            pinned: self.pins.particles(),
            camera: self.camera,
            wetness: 1.0,
        };
        ui.painter().add(view3d::callback(rect, frame));

        // The manipulation cursor (fig. 4.1 item 6): a ring on the held particle and a line to
        // where the mouse pulls it.
        let painter = ui.painter_at(rect);
        let to_screen = |p: Vec3| {
            pick::project(self.view_proj, vp, p)
                .map(|q| Pos2::new(rect.min.x + q.pixel.x, rect.min.y + q.pixel.y))
        };
        if let Some(d) = self.drag
            && let (Some(a), Some(b)) = (to_screen(self.particle(d.particle)), to_screen(d.target))
        {
            let col = Color32::from_rgb(255, 210, 60);
            painter.line_segment([a, b], egui::Stroke::new(1.5, col));
            painter.circle_stroke(b, 9.0, egui::Stroke::new(2.0, col));
            painter.line_segment([b - EVec2::X * 13.0, b + EVec2::X * 13.0], (1.0, col));
            painter.line_segment([b - EVec2::Y * 13.0, b + EVec2::Y * 13.0], (1.0, col));
        }
        for k in self.pins.particles() {
            if let Some(p) = to_screen(self.particle(k)) {
                painter.circle_filled(p, 5.0, Color32::from_rgb(230, 70, 60));
                painter.circle_stroke(p, 7.0, egui::Stroke::new(1.5, Color32::WHITE));
            }
        }
        if let Some(k) = self.hover
            && let Some(p) = to_screen(self.particle(k))
        {
            painter.circle_stroke(
                p,
                8.0,
                egui::Stroke::new(1.5, Color32::from_rgb(255, 210, 60)),
            );
        }
        // Corner caption.
        let info = format!(
            "{} × {} particles · dt = 1/{:.0} s{}",
            s.resolution[0],
            s.resolution[1],
            1.0 / s.config.simulation.time_step,
            if s.paused { " · paused" } else { "" }
        );
        painter.text(
            rect.left_bottom() + EVec2::new(8.0, -8.0),
            egui::Align2::LEFT_BOTTOM,
            info,
            egui::FontId::proportional(12.0),
            Color32::from_gray(60),
        );
        if response.hovered() && self.pick_mode && self.hover.is_some() {
            ui.ctx().set_cursor_icon(egui::CursorIcon::Grab);
        }
        if self.mode == PointerMode::Particle {
            ui.ctx().set_cursor_icon(egui::CursorIcon::Grabbing);
        }
    }
}

enum ScriptAction {
    ShotDone(Result<PathBuf, String>),
    Warn(String),
    Finished,
    Quit,
}

fn button(pos: Pos2, button: PointerButton, pressed: bool) -> Event {
    Event::PointerButton {
        pos,
        button,
        pressed,
        modifiers: Modifiers::NONE,
    }
}

/// Asks for a screenshot of the next frame, written as PNG to `path`; the receiver gets the
/// outcome.
///
/// Each saved screenshot is reported on stderr with where the 3D view lies in it, in pixels,
/// so that scripts and tests can look at the right pixels.
fn request_screenshot(
    ctx: &egui::Context,
    path: PathBuf,
    view: egui::Rect,
) -> Receiver<Result<PathBuf, String>> {
    let (tx, rx) = mpsc::channel();
    let repaint = ctx.clone();
    let ppp = ctx.pixels_per_point();
    ctx.request_screenshot(move |image| {
        let r = save_png(&path, &image).map(|()| path.clone());
        if r.is_ok() {
            eprintln!(
                "wetcloth: saved screenshot {} ({}x{} px; 3D view at x={:.0} y={:.0} w={:.0} h={:.0} px)",
                path.display(),
                image.size[0],
                image.size[1],
                view.min.x * ppp,
                view.min.y * ppp,
                view.width() * ppp,
                view.height() * ppp
            );
        }
        let _ = tx.send(r);
        repaint.request_repaint();
    });
    ctx.request_repaint();
    rx
}

/// Writes an egui image as PNG (opaque RGBA).
pub(crate) fn save_png(path: &Path, image: &egui::ColorImage) -> Result<(), String> {
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let [w, h] = image.size;
    let mut bytes = Vec::with_capacity(w * h * 4);
    for c in &image.pixels {
        let [r, g, b, _] = c.to_array();
        bytes.extend_from_slice(&[r, g, b, 255]);
    }
    image::save_buffer(
        path,
        &bytes,
        w as u32,
        h as u32,
        image::ExtendedColorType::Rgba8,
    )
    .map_err(|e| format!("{}: {e}", path.display()))
}

/// `x`, or 0 when it would print as "-0.00" (round-off around an empty bubble); `half_ulp` is
/// half the last printed digit.
fn no_negative_zero(x: f64, half_ulp: f64) -> f64 {
    if x.abs() < half_ulp { 0.0 } else { x }
}

/// The sphere and box colliders, for drawing.
fn solids(c: &SimConfig) -> Vec<Solid> {
    c.colliders
        .iter()
        .filter_map(|col| match &col.shape {
            Shape::Sphere(wetcloth::collide::Sphere { center, radius }) => Some(Solid::Sphere {
                center: center.as_vec3().to_array(),
                radius: *radius as f32,
            }),
            Shape::Box(wetcloth::collide::Cuboid {
                center,
                half_extents,
            }) => Some(Solid::Box {
                center: center.as_vec3().to_array(),
                half_extents: half_extents.as_vec3().to_array(),
            }),
            Shape::Plane(_) => None,
        })
        .collect()
}

/// Radius of the particle markers in pick mode, m: a fifth of the grid spacing.
fn particle_size(c: &SimConfig) -> f32 {
    let cl = &c.cloth;
    let dx = cl.size[0] / (cl.resolution[0].max(2) - 1) as f64;
    (dx / 5.0) as f32
}

/// Shortcuts and mouse controls, as listed in the help window.
pub(crate) const HELP: &[(&str, &str)] = &[
    ("A", "(1) air-pressure force on/off"),
    ("P", "(2) pick mode on/off (particles shown)"),
    ("R", "(3) reset to the initial state"),
    ("Space", "pause / resume"),
    ("S or .", "step one frame (1/60 s) while paused"),
    ("U", "release every pinned particle"),
    ("C", "start / stop recording to the run folder"),
    ("V", "reset the camera"),
    ("H or F1", "show / hide this help"),
    ("Esc", "let go of the dragged particle"),
    (
        "Left drag on a particle",
        "pull it (pick mode), in a plane facing you",
    ),
    ("+ Shift, or wheel", "move it up and down"),
    ("Right click while dragging", "pin it where it is"),
    ("Click a pinned particle", "release it (or drag it on)"),
    ("Left drag elsewhere / middle drag", "orbit the camera"),
    ("Right drag / Shift + left drag", "pan"),
    ("Wheel", "zoom"),
];

fn style(ctx: &egui::Context) {
    ctx.set_visuals(egui::Visuals::light());
}

impl eframe::App for ViewerApp {
    fn raw_input_hook(&mut self, ctx: &egui::Context, raw_input: &mut egui::RawInput) {
        self.script_events(ctx, raw_input);
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.frames += 1;
        self.refresh();
        self.shortcuts(&ctx);

        egui::Panel::top("toolbar").show(ui, |ui| {
            ui.add_space(3.0);
            self.toolbar(ui);
            ui.add_space(1.0);
        });
        egui::Panel::bottom("status").show(ui, |ui| self.status_bar(ui));
        egui::Panel::right("side")
            .default_size(310.0)
            .resizable(true)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    self.readouts(ui);
                    ui.separator();
                    egui::CollapsingHeader::new(RichText::new("Parameters").heading())
                        .default_open(true)
                        .show(ui, |ui| self.parameters(ui));
                    ui.separator();
                    egui::CollapsingHeader::new(RichText::new("Files").heading())
                        .default_open(true)
                        .show(ui, |ui| self.files(ui));
                });
            });
        egui::CentralPanel::no_frame().show(ui, |ui| self.view(ui));
        self.help(&ctx);

        // New snapshots ask for a repaint themselves (see `Runner::start`), and so does input;
        // a script needs frames to count and to move the mouse in.
        let scripted = self
            .player
            .as_ref()
            .is_some_and(|p| !p.finished || p.shot.is_some());
        if scripted && !self.closing {
            ctx.request_repaint();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edits_round_trip_and_map_to_the_scene_keys() {
        let mut cfg = SimConfig::thesis_demo();
        cfg.grabs.clear();
        let e = Edit::from_config(&cfg);
        assert_eq!(e.apply(&cfg), cfg, "no edit, no change");
        assert_eq!(e.rate, 12000.0);
        let mut e2 = e.clone();
        e2.air_cm3 = 400.0;
        e2.friction = 0.3;
        e2.rate = 16000.0;
        let c = e2.apply(&cfg);
        assert!((c.air.trapped_air - 400e-6).abs() < 1e-12);
        assert!(c.colliders.iter().all(|k| k.friction == 0.3));
        assert!((c.simulation.time_step - 1.0 / 16000.0).abs() < 1e-15);
        assert_eq!(c.cloth.resolution, cfg.cloth.resolution);
    }

    #[test]
    fn untouched_values_keep_their_exact_scene_value() {
        let mut cfg = SimConfig::thesis_demo();
        cfg.simulation.time_step = 8.333e-5;
        let mut e = Edit::from_config(&cfg);
        e.damping = 1.0;
        let c = e.apply(&cfg);
        assert_eq!(c.simulation.time_step, 8.333e-5);
        assert_eq!(c.cloth.damping, 1.0);
    }

    #[test]
    fn a_new_resolution_keeps_the_aspect_and_drops_scene_grabs() {
        let mut cfg = SimConfig::thesis_demo();
        cfg.cloth.resolution = [40, 20];
        cfg.grabs[0].particle = [20, 10];
        let mut e = Edit::from_config(&cfg);
        e.resolution = 30;
        let c = e.apply(&cfg);
        assert_eq!(c.cloth.resolution, [30, 15]);
        assert!(c.grabs.is_empty(), "grabs name particles of the old grid");
        assert!(c.validate().is_ok());
    }
}
