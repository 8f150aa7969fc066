//! The thesis' air model (3.4): all the air under the cloth is one bubble between the cloth
//! and the sticking plane, its amount fixed (or changed only by a border leak), its pressure
//! by Boyle's law on the volume of eq. 3.10, acting on every particle.

use super::boyle::boyle_pressure;
use super::leak;
use crate::control::Control;
use crate::math::{Real, Vec3};
use crate::model::Model;
use crate::params::{AirParams, PressureSolve};
use crate::state::State;

/// The single bubble.
#[derive(Clone, Debug, PartialEq)]
pub struct Bubble {
    /// Trapped air now, m^3 at atmospheric pressure: the scene's `trapped_air` plus what has
    /// leaked in since.
    pub trapped_air: Real,
    /// Bubble volume of the current state (eq. 3.10), m^3; 0 without a sticking plane.
    pub volume: Real,
    /// Bubble volume one step earlier, m^3 (for the implicit pressure's prediction).
    pub prev_volume: Real,
    /// The bubble pressure the last step's pressure force used, Pa.
    pub applied_pressure: Real,
    /// Boyle's pressure at the start of the step being taken, Pa (the leak's driving pressure).
    start_pressure: Real,
}

impl Bubble {
    /// A bubble holding `trapped_air` (m^3 at atmospheric pressure), volume not yet measured.
    pub fn new(trapped_air: Real) -> Self {
        Self {
            trapped_air,
            volume: 0.0,
            prev_volume: 0.0,
            applied_pressure: 0.0,
            start_pressure: 0.0,
        }
    }

    /// Boyle's pressure (eq. 3.9) on the current volume, Pa; atmospheric with the air force
    /// off (the cloth is then treated as permeable).
    pub fn pressure(&self, air: &AirParams, model: &Model, enabled: bool) -> Real {
        if enabled {
            boyle_pressure(
                air.atmospheric_pressure,
                self.trapped_air,
                self.volume,
                model.cloth_area,
            )
        } else {
            air.atmospheric_pressure
        }
    }

    /// Phase 2: the bubble pressure the step's pressure force uses, Pa, recorded as
    /// [`Bubble::applied_pressure`]. `state` and `control` are at the start of the step (with
    /// this step's grab targets).
    pub(crate) fn begin_step(
        &mut self,
        air: &AirParams,
        model: &Model,
        state: &State,
        control: &Control,
        dt: Real,
    ) -> Real {
        self.start_pressure = self.pressure(air, model, control.air_enabled);
        self.applied_pressure = if control.air_enabled {
            self.predict_pressure(air, model, state, control, dt)
        } else {
            air.atmospheric_pressure
        };
        self.applied_pressure
    }

    /// The pressure of [`PressureSolve`]: Boyle on the current volume (explicit), or the
    /// pressure at the end of the step (implicit).
    fn predict_pressure(
        &self,
        air: &AirParams,
        model: &Model,
        state: &State,
        control: &Control,
        dt: Real,
    ) -> Real {
        let k = air.atmospheric_pressure * self.trapped_air;
        if air.pressure_solve == PressureSolve::Explicit || k == 0.0 {
            return self.start_pressure;
        }
        // The bubble as a single degree of freedom: over one Verlet step a pressure P moves
        // every particle not held by a contact or a hand by h (P - P_a) S along its normal
        // (h = dt^2/m, halved on the Taylor first step), which changes the volume by
        // c (P - P_a) with c = h S^2 n_free. Inertia (damped), gravity and that term predict
        // the volume at the end of the step; P solves P * v(P) = K = P_a v0:
        //   c P^2 + a0 P - K = 0,  a0 = v_coast - c P_a,
        // whose positive root, written without cancellation, is 2K / (a0 + sqrt(a0^2 + 4cK)).
        let mass = model.particle_mass;
        let h = dt * dt / mass * if state.steps == 0 { 0.5 } else { 1.0 };
        let s = model.area_per_particle;
        let held = state
            .contact
            .iter()
            .zip(&control.held)
            .filter(|(c, f)| **c || **f)
            .count();
        let free = (model.grid.len() - held) as Real;
        let c = h * s * s * free;
        let up = model.sticking.map_or(Vec3::Y, |p| p.up);
        let keep = (1.0 - model.damping * dt).max(0.0);
        let gravity = h * mass * model.gravity.dot(up) * s * free;
        let coast = self.volume + keep * (self.volume - self.prev_volume) + gravity;
        let a0 = coast - c * air.atmospheric_pressure;
        let root = (a0 * a0 + 4.0 * c * k).sqrt();
        if a0 + root > 0.0 {
            2.0 * k / (a0 + root)
        } else {
            self.start_pressure
        }
    }

    /// Phase 4: air leaking in (or out) where the border is lifted off the surface during the
    /// step (`contact` flags of the step), at the pressure of the step's start (explicit Euler
    /// on the amount of air).
    pub(crate) fn leak(
        &mut self,
        air: &AirParams,
        model: &Model,
        contact: &[bool],
        enabled: bool,
        dt: Real,
    ) {
        let pa = air.atmospheric_pressure;
        if enabled && air.leak_conductance > 0.0 && pa > 0.0 {
            let open = leak::open_border_length(model, contact);
            let flow = leak::border_flow(air.leak_conductance, open, pa, self.start_pressure);
            self.trapped_air = (self.trapped_air + flow * dt).max(0.0);
        }
    }

    /// Records the volume of a new state, m^3.
    pub(crate) fn set_volume(&mut self, volume: Real) {
        self.prev_volume = self.volume;
        self.volume = volume;
    }
}
