//! Scripted input: a script replayed as input events, screenshots, closing when done.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{self, Receiver};
use std::time::Instant;

use eframe::egui::{self, Event, Modifiers, PointerButton, Pos2, Vec2 as EVec2};
use glam::Vec3;

use super::ViewerApp;
use crate::pick;
use crate::runner::Snapshot;
use crate::script::{self, Command as ScriptCmd, ParticleRef};

/// Replays a script, one command at a time, as input events.
pub(super) struct Player {
    pub(super) commands: VecDeque<ScriptCmd>,
    /// The current command started at this instant, frame and simulated time.
    pub(super) started: Option<(Instant, u64, f64)>,
    /// Pointer position, normalised view coordinates.
    pub(super) pointer: [f32; 2],
    /// Left button down.
    pub(super) pressed: bool,
    /// Drag in progress: from, to, frames, frames done.
    pub(super) drag: Option<([f32; 2], [f32; 2], u32, u32)>,
    /// Waiting for a screenshot to be written.
    pub(super) shot: Option<Receiver<Result<PathBuf, String>>>,
    pub(super) finished: bool,
    /// When the script started (`report` prints the wall-clock time since).
    pub(super) begun: Instant,
}

impl ViewerApp {
    /// Turns the next script commands into input events for this frame.
    pub(super) fn script_events(&mut self, ctx: &egui::Context, raw: &mut egui::RawInput) {
        let frames = self.frames;
        let rect = self.view_rect;
        let to_pos = |p: [f32; 2]| {
            Pos2::new(
                rect.min.x + p[0] * rect.width(),
                rect.min.y + p[1] * rect.height(),
            )
        };
        let snap = Arc::clone(&self.snap);
        let fps = self.frame_rate();
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
                ScriptCmd::PickParticle(which) => {
                    let proj = match particle_index(&snap, which) {
                        Ok(k) => pick::project(view_proj, vp, Vec3::from_array(snap.positions[k]))
                            .ok_or_else(|| format!("script: particle {which} is not on screen")),
                        Err(e) => Err(e),
                    };
                    match proj {
                        Ok(q) => {
                            let p = [q.pixel.x / vp.width, q.pixel.y / vp.height];
                            pl.pointer = p;
                            pl.pressed = true;
                            events.push(Event::PointerMoved(to_pos(p)));
                            events.push(button(to_pos(p), PointerButton::Primary, true));
                        }
                        Err(e) => actions.push(ScriptAction::Warn(e)),
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
                ScriptCmd::Report => {
                    println!(
                        "wetcloth: report wall {:.3} s, simulated {:.4} s, real-time factor \
                         {:.3} (last 0.5 s), {:.1} steps/s, {:.1} frames/s, grab force {:.4} N",
                        pl.begun.elapsed().as_secs_f64(),
                        snap.metrics.time,
                        snap.realtime_factor,
                        snap.steps_per_second,
                        fps,
                        snap.metrics.grab_force
                    );
                    true
                }
                ScriptCmd::ReportParticle(which) => {
                    match particle_index(&snap, which) {
                        Ok(k) => {
                            let [x, y, z] = snap.positions[k];
                            println!("wetcloth: particle {k} at {x} {y} {z} m");
                        }
                        Err(e) => actions.push(ScriptAction::Warn(e)),
                    }
                    true
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

    pub(super) fn fail(&mut self, text: String) {
        self.warn(text.clone());
        let mut o = self.outcome.lock().unwrap_or_else(|e| e.into_inner());
        o.error.get_or_insert(text);
    }

    pub(super) fn script_finished(&mut self, ctx: &egui::Context) {
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

    pub(super) fn close(&mut self, ctx: &egui::Context) {
        if let Some(rec) = self.recorder.take()
            && let Err(e) = rec.finish()
        {
            self.fail(format!("recording failed: {e}"));
        }
        self.closing = true;
        ctx.send_viewport_cmd(egui::ViewportCommand::Close);
    }
}

enum ScriptAction {
    ShotDone(Result<PathBuf, String>),
    Warn(String),
    Finished,
    Quit,
}

/// The index of the particle a script names, or why it names none: an index past the cloth's
/// particles, or a grid column and row outside the grid or on a mesh cloth.
fn particle_index(snap: &Snapshot, which: ParticleRef) -> Result<usize, String> {
    let n = snap.positions.len();
    let k = match which {
        ParticleRef::Index(k) => Some(k),
        ParticleRef::Grid([i, j]) => match snap.cloth.grid {
            Some(_) => snap.cloth.grid_particle(i, j),
            None => {
                return Err(format!(
                    "script: particle {which} names a grid column and row, but the cloth is a \
                     mesh: name its particle by index (0 to {})",
                    n.saturating_sub(1)
                ));
            }
        },
    };
    match k {
        Some(k) if k < n => Ok(k),
        _ => Err(format!(
            "script: there is no particle {which}: the cloth has {}",
            snap.cloth.describe()
        )),
    }
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
