//! The parameters panel: values being edited, applied with one button.

use eframe::egui::{self, Color32, RichText};
use wetcloth::SimConfig;

use super::ViewerApp;

/// Parameters being edited, applied with one button.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Edit {
    air_cm3: f64,
    structural: f64,
    shear: f64,
    friction: f64,
    damping: f64,
    /// Steps per second (1 / time step).
    rate: f64,
    resolution: usize,
    integrator: wetcloth::Integrator,
    /// How much the implicit integrator solves a step.
    budget: wetcloth::SolveBudget,
}

impl Edit {
    pub(super) fn from_config(c: &SimConfig) -> Self {
        Self {
            air_cm3: c.air.trapped_air * 1e6,
            structural: c.cloth.structural_stiffness,
            shear: c.cloth.shear_stiffness,
            friction: c.colliders.first().map_or(0.0, |c| c.friction),
            damping: c.cloth.damping,
            rate: (1.0 / c.simulation.time_step).round(),
            resolution: c.cloth.resolution[0],
            integrator: c.simulation.integrator,
            budget: c.simulation.implicit_budget,
        }
    }

    /// `base` with the edited values; values left alone keep their exact scene value (the
    /// sliders show rounded ones, e.g. a time step of 8.333e-5 s as 1/12000 s).
    pub(super) fn apply(&self, base: &SimConfig) -> SimConfig {
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
        c.simulation.integrator = self.integrator;
        c.simulation.implicit_budget = self.budget;
        // A mesh cloth has no resolution to change.
        if c.cloth.mesh.is_none() && self.resolution != c.cloth.resolution[0] {
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

/// A slider that keeps a value outside its range as the scene gave it: egui's default clamps
/// it on display, and the next applied edit would then silently set, say, a 200 000 N/m cloth
/// to the slider's end. Only what the user drags or types is clamped.
fn slider<Num: egui::emath::Numeric>(
    value: &mut Num,
    range: std::ops::RangeInclusive<Num>,
) -> egui::Slider<'_> {
    egui::Slider::new(value, range).clamping(egui::SliderClamping::Edits)
}

/// The panel's name for an implicit solve budget.
fn budget_label(b: wetcloth::SolveBudget) -> &'static str {
    match b {
        wetcloth::SolveBudget::Interactive => "Interactive (real time)",
        wetcloth::SolveBudget::Converged => "Converged (accurate)",
    }
}

impl ViewerApp {
    pub(super) fn parameters(&mut self, ui: &mut egui::Ui) {
        let mesh = match self.snap.cloth.grid {
            Some(_) => String::new(),
            None => self.snap.cloth.describe(),
        };
        let e = &mut self.edit;
        // A change applies when the slider is let go (or a typed value is entered), so a drag
        // across the range does not restart anything on the way.
        let mut commit = false;
        let mut done = |r: egui::Response| {
            commit |= r.drag_stopped() || (r.changed() && !r.dragged());
        };
        let mut switched = false;
        egui::Grid::new("params")
            .num_columns(2)
            .spacing([8.0, 4.0])
            .show(ui, |ui| {
                ui.label("Air amount").on_hover_text(
                    "Trapped air v0 at atmospheric pressure (thesis: 0 and 400 cm³)",
                );
                done(ui.add(slider(&mut e.air_cm3, 0.0..=1000.0).suffix(" cm³")));
                ui.end_row();
                ui.label("Structural k");
                done(
                    ui.add(
                        slider(&mut e.structural, 10.0..=1e6)
                            .logarithmic(true)
                            .suffix(" N/m"),
                    ),
                );
                ui.end_row();
                ui.label("Shear k");
                done(
                    ui.add(
                        slider(&mut e.shear, 1.0..=1e6)
                            .logarithmic(true)
                            .suffix(" N/m"),
                    ),
                );
                ui.end_row();
                ui.label("Friction μ");
                done(ui.add(slider(&mut e.friction, 0.0..=2.0)));
                ui.end_row();
                ui.label("Damping");
                done(ui.add(slider(&mut e.damping, 0.0..=20.0).suffix(" 1/s")));
                ui.end_row();
                ui.label("Integrator").on_hover_text(
                    "Verlet: the thesis' explicit step, small steps only. Implicit: backward \
                     Euler, steps of 1/600 s to 1/60 s (see docs/integrators.md)",
                );
                let before = e.integrator;
                egui::ComboBox::from_id_salt("integrator")
                    .selected_text(match e.integrator {
                        wetcloth::Integrator::Verlet => "Verlet (explicit)",
                        wetcloth::Integrator::Implicit => "Implicit (large steps)",
                    })
                    .show_ui(ui, |ui| {
                        ui.selectable_value(
                            &mut e.integrator,
                            wetcloth::Integrator::Verlet,
                            "Verlet (explicit)",
                        );
                        ui.selectable_value(
                            &mut e.integrator,
                            wetcloth::Integrator::Implicit,
                            "Implicit (large steps)",
                        );
                    });
                ui.end_row();
                ui.label("Implicit solve").on_hover_text(
                    "Interactive: three coarse solves a step, for real time at 1/60 s. \
                     Converged: solved until contacts, friction and the bubble's pressure \
                     settle, as batch runs do (see docs/integrators.md)",
                );
                let before_budget = e.budget;
                ui.add_enabled_ui(e.integrator == wetcloth::Integrator::Implicit, |ui| {
                    egui::ComboBox::from_id_salt("implicit_budget")
                        .selected_text(budget_label(e.budget))
                        .show_ui(ui, |ui| {
                            for b in wetcloth::SolveBudget::ALL {
                                ui.selectable_value(&mut e.budget, b, budget_label(b));
                            }
                        });
                });
                switched = e.integrator != before || e.budget != before_budget;
                ui.end_row();
                ui.label("Time step");
                done(
                    ui.add(
                        slider(&mut e.rate, 60.0..=40000.0)
                            .logarithmic(true)
                            .prefix("1/")
                            .suffix(" s")
                            .integer(),
                    ),
                );
                ui.end_row();
                if mesh.is_empty() {
                    ui.label("Resolution")
                        .on_hover_text("Particles per side; a new resolution restarts the run");
                    done(ui.add(slider(&mut e.resolution, 4..=100).suffix(" per side")));
                } else {
                    // A cloth of any shape has the particles of its file.
                    ui.label("Cloth")
                        .on_hover_text("A cloth read from a mesh file: a particle per vertex");
                    ui.label(mesh.as_str());
                }
                ui.end_row();
            });
        commit |= switched;
        let edited = self.edit.apply(&self.snap.config);
        let stable = edited.stable_time_step();
        let explicit = edited.simulation.integrator == wetcloth::Integrator::Verlet;
        if explicit && 1.0 / self.edit.rate > stable {
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
        let mut e3 = e.clone();
        e3.integrator = wetcloth::Integrator::Implicit;
        e3.rate = 120.0;
        let c = e3.apply(&cfg);
        assert_eq!(c.simulation.integrator, wetcloth::Integrator::Implicit);
        assert!((c.simulation.time_step - 1.0 / 120.0).abs() < 1e-15);
        assert!(c.validate().is_ok());
        assert_eq!(Edit::from_config(&c), e3, "round trip");
        let mut e4 = e3.clone();
        e4.budget = wetcloth::SolveBudget::Interactive;
        let c = e4.apply(&cfg);
        assert_eq!(
            c.simulation.implicit_budget,
            wetcloth::SolveBudget::Interactive
        );
        assert_eq!(Edit::from_config(&c), e4, "round trip");
    }

    /// One frame of a headless egui context showing `slider` on `value`; returns the value.
    fn shown(value: f64, slider: impl Fn(&mut f64) -> egui::Slider<'_>) -> f64 {
        let ctx = egui::Context::default();
        let mut value = value;
        let out = ctx.run_ui(egui::RawInput::default(), |ui| {
            ui.add(slider(&mut value));
        });
        out.drop_without_applying_deltas();
        value
    }

    /// Found: the stiffness sliders ended at 20 000 N/m and clamped on display (egui's
    /// default), so `pinch-fine`'s 200 000 N/m showed as 20 000 and the next applied edit of any
    /// parameter set it. Now a value outside the range stays as the scene gave it.
    #[test]
    fn sliders_keep_a_scene_value_outside_their_range() {
        assert_eq!(shown(2.0e7, |v| slider(v, 10.0..=1e6)), 2.0e7);
        // What egui's default does, and what the viewer did before.
        assert_eq!(shown(2.0e7, |v| egui::Slider::new(v, 10.0..=1e6)), 1e6);
        let mut cfg = SimConfig::thesis_demo();
        cfg.cloth.structural_stiffness = 2.0e5;
        let mut e = Edit::from_config(&cfg);
        e.damping = 1.0;
        assert_eq!(e.apply(&cfg).cloth.structural_stiffness, 2.0e5);
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
