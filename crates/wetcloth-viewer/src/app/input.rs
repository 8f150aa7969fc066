//! Keyboard shortcuts and mouse handling in the 3D view.

use eframe::egui::{self, Event, Key, Modifiers, PointerButton, Vec2 as EVec2};
use glam::Vec2;

use super::{PointerMode, ViewerApp};
use crate::pick::{self, Drag, PICK_RADIUS_PX};
use crate::runner::Command;

/// Vertical move per wheel notch while dragging, m.
const LIFT_PER_NOTCH: f32 = 0.005;

impl ViewerApp {
    pub(super) fn shortcuts(&mut self, ctx: &egui::Context) {
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
                Key::T => self.pocket_tint = !self.pocket_tint,
                Key::C => self.toggle_record(),
                Key::H | Key::F1 => self.show_help = !self.show_help,
                Key::V => {
                    self.camera = super::cloth_camera(&self.snap.config);
                }
                Key::Escape => self.end_drag(),
                _ => {}
            }
        }
    }

    /// Mouse handling in the 3D view.
    pub(super) fn view_input(&mut self, ui: &egui::Ui, response: &egui::Response) {
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
}
