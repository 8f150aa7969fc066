//! The live readouts and the pressure and volume plots.

use std::sync::Arc;

use eframe::egui::{self, Color32, RichText};
use egui_plot::{Line, Plot};

use super::ViewerApp;

/// Seconds of history in the live plot.
pub(super) const PLOT_SECONDS: f64 = 10.0;

impl ViewerApp {
    pub(super) fn readouts(&mut self, ui: &mut egui::Ui) {
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
                let fps = self.frame_rate();
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
}

/// `x`, or 0 when it would print as "-0.00" (round-off around an empty bubble); `half_ulp` is
/// half the last printed digit.
fn no_negative_zero(x: f64, half_ulp: f64) -> f64 {
    if x.abs() < half_ulp { 0.0 } else { x }
}
