//! The 3D view: the cloth through the shared renderer, and the manipulation cursor.

use std::sync::Arc;

use crate::runner::ClothLayout;
use eframe::egui::{self, Color32, Pos2, Sense, Vec2 as EVec2};
use glam::Vec3;

use super::{PointerMode, ViewerApp};
use crate::pick;
use crate::view3d;

impl ViewerApp {
    pub(super) fn view(&mut self, ui: &mut egui::Ui) {
        let (rect, response) = ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
        self.view_rect = rect;
        let vp = self.viewport();
        self.view_proj = self.camera.view_proj(vp.aspect());
        self.view_input(ui, &response);
        self.view_proj = self.camera.view_proj(vp.aspect());

        let s = &self.snap;
        // Moving colliders are drawn where their keys put them at the snapshot's time.
        let scene = if s.config.colliders.iter().any(|c| c.is_moving()) {
            let at: Vec<_> = s
                .config
                .colliders
                .iter()
                .map(|c| c.at(s.metrics.time))
                .collect();
            Arc::new(wetcloth_render::collider_scene(&at))
        } else {
            Arc::clone(&self.mesh.scene)
        };
        let frame = view3d::Frame {
            positions: s.positions.clone(),
            normals: s.normals.clone(),
            indices: self.mesh.indices(),
            scene,
            show_particles: self.pick_mode,
            particle_radius: particle_size(&s.cloth),
            highlight: self.drag.map(|d| d.particle).or(self.hover),
            pinned: self.pins.particles(),
            camera: self.camera,
            wetness: 1.0,
            tint: self
                .pocket_tint
                .then(|| crate::pockets::pocket_tints(s, crate::pockets::colour_range(s))),
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
            "{} · dt = 1/{:.0} s{}",
            s.cloth.describe(),
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

/// Radius of the particle markers in pick mode, m: a fifth of the particle spacing (the
/// grid's, or a mesh's mean edge).
fn particle_size(cloth: &ClothLayout) -> f32 {
    (cloth.spacing / 5.0) as f32
}
