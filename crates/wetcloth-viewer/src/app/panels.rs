//! The side and bottom panels besides readouts and parameters: files, status bar, help.

use eframe::egui::{self, Color32, RichText, Vec2 as EVec2};

use super::ViewerApp;

impl ViewerApp {
    pub(super) fn files(&mut self, ui: &mut egui::Ui) {
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

    pub(super) fn status_bar(&mut self, ui: &mut egui::Ui) {
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

    pub(super) fn help(&mut self, ctx: &egui::Context) {
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
}

/// Shortcuts and mouse controls, as listed in the help window.
pub(crate) const HELP: &[(&str, &str)] = &[
    ("A", "(1) air-pressure force on/off"),
    ("P", "(2) pick mode on/off (particles shown)"),
    ("R", "(3) reset to the initial state"),
    ("Space", "pause / resume"),
    ("S or .", "step one frame (1/60 s) while paused"),
    ("U", "release every pinned particle"),
    ("T", "tint the air pockets by pressure on/off"),
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

impl ViewerApp {
    /// The air pockets: the tint toggle, its colour range, and one row per sealed pocket.
    pub(super) fn pocket_panel(&mut self, ui: &mut egui::Ui) {
        use crate::pockets::{colour_range, pocket_rows};
        let s = std::sync::Arc::clone(&self.snap);
        ui.checkbox(&mut self.pocket_tint, "Tint by pressure (T)")
            .on_hover_text("blue below atmospheric pressure, red above");
        if self.pocket_tint {
            let range = colour_range(&s);
            ui.horizontal(|ui| {
                let swatch = |t: f64| {
                    let [r, g, b] = wetcloth_render::pressure_colour(t)
                        .map(|c| (c.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0) as u8);
                    Color32::from_rgb(r, g, b)
                };
                for t in [-1.0, -0.5, 0.0, 0.5, 1.0] {
                    let (rect, _) =
                        ui.allocate_exact_size(EVec2::new(14.0, 10.0), egui::Sense::hover());
                    ui.painter().rect_filled(rect, 1.0, swatch(t));
                }
                ui.label(RichText::new(format!("±{range:.1} Pa")).small());
            });
        }
        let rows = pocket_rows(&s);
        if rows.is_empty() {
            ui.label(RichText::new("no sealed pocket").weak());
            return;
        }
        // In a scroll area of its own: the table must not widen the side panel (the 3D view
        // would change size as the numbers do).
        egui::ScrollArea::horizontal()
            .id_salt("pockets-scroll")
            .show(ui, |ui| {
                egui::Grid::new("pockets")
                    .num_columns(7)
                    .spacing([10.0, 2.0])
                    .striped(true)
                    .show(ui, |ui| {
                        for h in ["id", "V cm³", "N cm³", "P kPa", "ΔP Pa", "A cm²", "n"] {
                            ui.label(RichText::new(h).small().strong());
                        }
                        ui.end_row();
                        for r in rows.iter().take(40) {
                            let cell = |ui: &mut egui::Ui, t: String| {
                                ui.label(RichText::new(t).small().monospace());
                            };
                            cell(ui, r.id.to_string());
                            cell(ui, format!("{:.2}", r.volume_cm3));
                            cell(ui, format!("{:.2}", r.amount_cm3));
                            cell(ui, format!("{:.3}", r.pressure * 1e-3));
                            cell(ui, format!("{:+.1}", r.delta_p));
                            cell(ui, format!("{:.1}", r.area_cm2));
                            cell(ui, r.particles.to_string());
                            ui.end_row();
                        }
                    });
            });
        if rows.len() > 40 {
            ui.label(RichText::new(format!("… and {} more", rows.len() - 40)).weak());
        }
    }
}
