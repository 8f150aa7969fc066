//! The toolbar: the thesis' three buttons, pause and step, pins, recording, help.

use eframe::egui::{self, RichText};

use super::ViewerApp;

impl ViewerApp {
    pub(super) fn toolbar(&mut self, ui: &mut egui::Ui) {
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
}
