//! What the buttons and the shortcuts do (they share these actions).

use std::path::PathBuf;

use super::{Edit, PointerMode, ViewerApp};
use crate::record::Recorder;
use crate::runner::Command;

impl ViewerApp {
    pub(super) fn toggle_air(&mut self) {
        let on = !self.snap.air_enabled;
        self.runner.send(Command::SetAir(on));
        self.say(if on {
            "Air pressure force on: the cloth sticks"
        } else {
            "Air pressure force off: the cloth lifts freely"
        });
    }

    pub(super) fn toggle_pick(&mut self) {
        self.pick_mode = !self.pick_mode;
        if !self.pick_mode {
            self.end_drag();
        }
    }

    pub(super) fn reset(&mut self) {
        self.end_drag();
        self.pins.clear();
        self.runner.send(Command::Reset);
        self.history.clear();
        self.last_plot_time = -1.0;
        self.say("Reset to the scene's initial state");
    }

    pub(super) fn toggle_pause(&mut self) {
        self.runner.send(Command::Pause(!self.snap.paused));
    }

    pub(super) fn step_frame(&mut self) {
        if !self.snap.paused {
            self.runner.send(Command::Pause(true));
        }
        self.runner.send(Command::StepFrame);
    }

    pub(super) fn release_pins(&mut self) {
        for p in self.pins.clear() {
            self.runner.send(Command::Release { particle: p });
        }
        self.say("Released every pinned particle");
    }

    pub(super) fn toggle_record(&mut self) {
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

    pub(super) fn apply_params(&mut self) {
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

    pub(super) fn open_scene(&mut self) {
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
                self.camera = super::cloth_camera(&self.base_config);
                self.say(format!("Opened {}", path.display()));
            }
            Err(e) => self.warn(format!("Cannot open {}: {e}", path.display())),
        }
    }

    pub(super) fn end_drag(&mut self) {
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
}
