//! The window: panels, readouts, the 3D view and its mouse handling, shortcuts, recording and
//! scripted input.
//!
//! By concern: `toolbar`, `readouts`, `parameters` and `panels` draw the panels; `view` the 3D
//! view; `input` the shortcuts and the mouse; `actions` what buttons and shortcuts do;
//! `scripted` the scripted input. This module holds the state and the per-frame loop.

mod actions;
mod input;
mod panels;
mod parameters;
mod readouts;
mod scripted;
mod toolbar;
mod view;

use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use eframe::egui::{self, Pos2, RichText, Vec2 as EVec2};
use glam::{Mat4, Vec2, Vec3};
use wetcloth::SimConfig;

use crate::ViewerOptions;
use crate::camera::OrbitCamera;
use crate::pick::{Drag, Pins, Viewport};
use crate::record::Recorder;
use crate::runner::{ClothLayout, Runner, Snapshot};
use crate::script::Command as ScriptCmd;
use crate::view3d;
use parameters::Edit;
use readouts::PLOT_SECONDS;
use scripted::Player;

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
    /// Whether the cloth over each air pocket is tinted by its pressure.
    pocket_tint: bool,
}

/// Triangle indices of the current cloth, the grid's or a mesh's (they change only on a
/// restart).
struct MeshCache {
    generation: u64,
    cloth: Arc<ClothLayout>,
    /// The ground and the solids, from the colliders' own description.
    scene: Arc<view3d::ColliderScene>,
}

impl MeshCache {
    fn new(snap: &Snapshot) -> Self {
        Self {
            generation: snap.generation,
            cloth: Arc::clone(&snap.cloth),
            scene: Arc::new(wetcloth_render::collider_scene(&snap.config.colliders)),
        }
    }

    fn indices(&self) -> Arc<Vec<u32>> {
        Arc::clone(&self.cloth.indices)
    }
}

/// The camera's 3/4 view of the cloth of `config` at t = 0: the grid's square (its larger
/// side) around its centre, or the bounds of a mesh cloth as placed.
pub(crate) fn cloth_camera(config: &SimConfig) -> OrbitCamera {
    let c = &config.cloth;
    let grid = || OrbitCamera::framing(c.position.as_vec3(), c.size[0].max(c.size[1]) as f32);
    let Some(m) = &c.mesh else {
        return grid();
    };
    let placed = m.placed(c.position);
    let lo = placed.iter().copied().reduce(|a, b| a.min(b));
    let hi = placed.iter().copied().reduce(|a, b| a.max(b));
    match (lo, hi) {
        (Some(lo), Some(hi)) if (hi - lo).is_finite() => {
            OrbitCamera::framing_bounds(lo.as_vec3(), hi.as_vec3())
        }
        _ => grid(),
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
        let camera = cloth_camera(&snap.config);
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
                begun: std::time::Instant::now(),
            }),
            exit_after_script: opts.exit_after_script,
            final_screenshot: opts.screenshot,
            outcome,
            closing: false,
            // On for the pockets model; the thesis' bubble would tint the whole cloth.
            pocket_tint: snap.config.air.model == wetcloth::params::AirModelKind::Pockets,
            snap,
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

    // ----- per-frame bookkeeping -----

    fn refresh(&mut self) {
        let snap = self.runner.latest();
        if let Some((n, text)) = &snap.notice
            && self.snap.notice.as_ref().map(|(m, _)| m) != Some(n)
        {
            self.message = Some((text.clone(), true));
        }
        if snap.generation != self.mesh.generation || !Arc::ptr_eq(&snap.cloth, &self.mesh.cloth) {
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

    /// Displayed frames per second (the smoothed frame period's inverse; 0 before two frames).
    pub(super) fn frame_rate(&self) -> f64 {
        if self.frame_time.1 > 0.0 {
            1.0 / self.frame_time.1
        } else {
            0.0
        }
    }
}

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
                    egui::CollapsingHeader::new(RichText::new("Air pockets").heading())
                        .default_open(true)
                        .show(ui, |ui| self.pocket_panel(ui));
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
