//! The thesis' air model (3.4): all the air under the cloth is one bubble between the cloth
//! and the sticking plane, its amount fixed (or changed only by a border leak), its pressure
//! by Boyle's law on the volume of eq. 3.10, acting on every particle.

use super::boyle::boyle_pressure;
use super::leak;
use crate::air::{AirLoad, Timing};
use crate::control::Control;
use crate::math::{Real, Soa};
use crate::model::Model;
use crate::params::{AirParams, PressureSolve};
use crate::state::State;

/// The single bubble.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
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
    /// The end-of-step pressure the integrator is to solve this step, if any.
    pending: Option<EndOfStep>,
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
            pending: None,
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

    /// Phase 2: how the step's pressure force is set. With the air force off, or
    /// [`PressureSolve::Explicit`], or no trapped air (a vacuum), the pressure is known now:
    /// Boyle's law on the current volume, recorded as [`Bubble::applied_pressure`]. Otherwise
    /// the integrator solves it at the end of the step ([`EndOfStep`]) and records it in
    /// [`Bubble::applied_pressure`].
    pub(crate) fn begin_step(
        &mut self,
        air: &AirParams,
        model: &Model,
        state: &State,
        control: &Control,
        dt: Real,
    ) -> Timing {
        self.start_pressure = self.pressure(air, model, control.air_enabled);
        let pa = air.atmospheric_pressure;
        let trapped = pa * self.trapped_air;
        let implicit = control.air_enabled
            && air.pressure_solve == PressureSolve::Implicit
            && trapped > 0.0
            && model.sticking.is_some();
        if implicit {
            self.pending = Some(EndOfStep {
                trapped,
                atmosphere: pa,
                area: model.area_per_particle,
                step_per_force: dt * dt / model.particle_mass
                    * if state.steps == 0 { 0.5 } else { 1.0 },
                first_step: state.steps == 0,
                dt,
                start: self.start_pressure,
            });
            Timing::EndOfStep
        } else {
            self.pending = None;
            self.applied_pressure = if control.air_enabled {
                self.start_pressure
            } else {
                pa
            };
            Timing::Now
        }
    }

    /// The load of the step: the applied pressure difference on every particle.
    pub(crate) fn load(&self, air: &AirParams) -> AirLoad<'_> {
        AirLoad::Uniform(self.applied_pressure - air.atmospheric_pressure)
    }

    /// Solves the step's end-of-step pressure from the coasting positions `coast` (m) and the
    /// gap volume under them `coast_volume` (m^3).
    pub(crate) fn solve_end_of_step(
        &mut self,
        model: &Model,
        coast: &crate::math::Soa,
        coast_volume: Real,
        held: &[bool],
    ) {
        if let Some(solve) = self.pending.take() {
            self.applied_pressure = solve.solve(model, coast, coast_volume, held);
        }
    }

    /// The pending end-of-step solve, taken (the integrator solves it itself).
    pub(crate) fn take_end_of_step(&mut self) -> Option<EndOfStep> {
        self.pending.take()
    }

    /// Phase 4: air leaking in (or out) where the border is lifted off the surface at the
    /// step's end (positions `x`, [`leak::open_border_length`]), with the volume of the step's
    /// start: the amount relaxed exactly towards atmospheric pressure ([`leak::relax`]), never
    /// past it.
    pub(crate) fn leak(
        &mut self,
        air: &AirParams,
        model: &Model,
        x: &Soa,
        enabled: bool,
        dt: Real,
    ) {
        let pa = air.atmospheric_pressure;
        if enabled && air.leak_conductance > 0.0 && pa > 0.0 {
            let open = leak::open_border_length(model, x, model.radius + air.seal_distance);
            // Boyle's volume at the step's start (the start pressure's), floored as Boyle's
            // law floors it.
            let volume = self.volume.max(super::boyle::MIN_GAP * model.cloth_area);
            self.trapped_air =
                leak::relax(self.trapped_air, volume, air.leak_conductance, open, dt).max(0.0);
        }
    }

    /// Records the volume of a new state, m^3.
    pub(crate) fn set_volume(&mut self, volume: Real) {
        self.prev_volume = self.volume;
        self.volume = volume;
    }
}

/// The implicit bubble pressure of one step ([`PressureSolve::Implicit`]): Boyle's law at the
/// end of the step, `P v(t + dt) = K`, with the volume predicted from the step's own dynamics.
///
/// The integrator first moves every particle by everything but the pressure (inertia, springs,
/// gravity, damping) to its *coasting* position. Over the step a pressure `P` then moves each
/// particle a hand does not hold by `h (P - P_a) S` along its normal (`h = dt^2 / m`, halved on
/// the Taylor first step), which changes the volume by about `S` times that move. Under-pressure
/// pulls a particle towards the surface only until it touches: its move is capped by the gap its
/// coasting position leaves above contact (and a particle coasting into the surface is pushed
/// back out of it by the contact). Over-pressure lifts every particle not held, resting or not.
/// So the volume at the end of the step is a known, increasing, piecewise-linear function of
/// `P`, and `P v(P) = K` has one root, found by safeguarded Newton iterations.
///
/// Springs and contacts are in the prediction (the coasting positions), so the pressure the
/// step applies is the pressure its end state has, to the linearisation: a small bubble, a stiff
/// air spring, is integrated implicitly. (Predicting from the volume alone, ignoring the
/// springs, biased the pressure by the springs' share, 10 % on a peeled corner, and that error,
/// fed back one step late, shook a small leaking bubble until it blew up at small time steps.)
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct EndOfStep {
    /// `K = P_a v0`, J (Pa m^3).
    pub trapped: Real,
    /// Atmospheric pressure `P_a`, Pa.
    pub atmosphere: Real,
    /// Cloth area per particle `S`, m^2.
    pub area: Real,
    /// `h = dt^2 / m` (halved on the first step), s^2/kg, for particles of the uniform mass.
    pub step_per_force: Real,
    /// Whether this is the Taylor first step (h halved).
    pub first_step: bool,
    /// The step, s.
    pub dt: Real,
    /// Boyle's pressure at the start of the step, Pa: the first guess.
    pub start: Real,
}

impl EndOfStep {
    /// The pressure at the end of the step, Pa, given the coasting positions `coast` (m), the
    /// gap volume under them `coast_volume` (m^3, eq. 3.10), the sticking plane and particle
    /// radius of `model`, and which particles a hand holds.
    pub fn solve(
        &self,
        model: &Model,
        coast: &crate::math::Soa,
        coast_volume: Real,
        held: &[bool],
    ) -> Real {
        let Some(plane) = model.sticking else {
            return self.start;
        };
        let (s, h, pa, k) = (
            self.area,
            self.step_per_force,
            self.atmosphere,
            self.trapped,
        );
        let up = plane.up;
        let contact = up.dot(plane.point) + model.radius;
        // Gaps above contact (m) of the particles free to move; those coasting into the surface
        // are pushed back out (adding their depth to the volume) and have no gap.
        let mut base = coast_volume;
        let gap = |i: usize| up.x * coast.x[i] + up.y * coast.y[i] + up.z * coast.z[i] - contact;
        // Each particle's area S: the uniform one on the grid, its lumped area on a mesh.
        let s_of = |i: usize| model.areas.as_ref().map_or(s, |a| a[i]);
        for i in 0..coast.len() {
            let g = gap(i);
            if g < 0.0 && !held[i] {
                base -= s_of(i) * g;
            }
        }
        // The move per pascal of particle i, m/Pa.
        let first = if self.first_step { 0.5 } else { 1.0 };
        let h_of = |i: usize| match &model.masses {
            None => h,
            Some(m) => self.dt * self.dt / m[i] * first,
        };
        // The volume at the end of the step under pressure P (m^3) and its slope dV/dP.
        let volume = |p: Real| {
            let (mut v, mut slope) = (base, 0.0);
            for i in 0..coast.len() {
                if held[i] {
                    continue;
                }
                let (h, s) = (h_of(i), s_of(i));
                let push = h * s * (p - pa);
                let g = gap(i).max(0.0);
                if push >= 0.0 || -push < g {
                    v += s * push;
                    slope += h * s * s;
                } else {
                    v -= s * g;
                }
            }
            (v, slope)
        };
        solve_boyle(k, pa, self.start, volume)
    }
}

/// The pressure `P` (Pa) with `P V(P) = K` (`K` in J), `volume(P)` giving `V(P)` (m^3) and its
/// slope `dV/dP` (increasing in `P`), by Newton iterations kept inside their bracket, from the
/// first guess `start` (Pa); `pa` scales the smallest first guess.
pub(crate) fn solve_boyle(
    k: Real,
    pa: Real,
    start: Real,
    volume: impl Fn(Real) -> (Real, Real),
) -> Real {
    let (mut lo, mut hi) = (0.0, Real::INFINITY);
    let mut p = start.max(1e-3 * pa).max(1e-9);
    for _ in 0..100 {
        let (v, slope) = volume(p);
        let f = p * v - k;
        if f > 0.0 {
            hi = p;
        } else {
            lo = p;
        }
        let df = v + p * slope;
        let mut next = if df > 0.0 { p - f / df } else { Real::NAN };
        if !(next > lo && next < hi) {
            next = if hi.is_finite() {
                0.5 * (lo + hi)
            } else {
                2.0 * p.max(lo)
            };
        }
        let done = (next - p).abs() <= 1e-13 * p;
        p = next;
        if done {
            break;
        }
    }
    p
}
