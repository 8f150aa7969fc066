//! The trapped air (thesis 3.4-3.5): Boyle's law, the gap volume, and the air models.
//!
//! | file | contents | thesis |
//! |---|---|---|
//! | `boyle.rs` | `P_b v = P_a v0` | eq. 3.8-3.9 |
//! | `gap.rs` | the volume between cloth and sticking surface, signed prisms | 3.5, eq. 3.10 |
//! | `bubble.rs` | the thesis' single bubble, with its explicit or implicit pressure | 3.4 |
//! | `leak.rs` | air through a lifted border | ch. 5 (future work) |
//! | `pockets.rs` | several sealed pockets that form, merge, split, leak and open | ch. 5 (future work) |
//! | `seeds.rs` | where the seeded pockets (`[[air.pocket]]`) lie on the grid or a mesh at t = 0 | fig. 1.3 |
//!
//! An air model answers two questions each step: what pressure acts on the cloth during the
//! step (`AirModel::begin_step`, phase 2 of [`crate::Simulation::step`]), and what the air
//! becomes after it (leaks and the new volume, phases 4 and 7). A new model is a new file here
//! and a variant of [`AirModel`].

pub mod boyle;
pub mod bubble;
pub mod gap;
pub mod leak;
pub mod pockets;
pub(crate) mod region;
pub(crate) mod seeds;
pub(crate) mod solve;

pub use boyle::{MIN_GAP, boyle_pressure};
pub use bubble::Bubble;
pub use gap::{StickingPlane, prism_volume, row_volume, volume};
pub use pockets::{Pocket, Pockets};

use crate::control::Control;
use crate::math::{Real, Soa};
use crate::measure::Measures;
use crate::model::Model;
use crate::params::{AirModelKind, AirParams};
use crate::state::State;

/// When a step's pressure is known.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Timing {
    /// At its start (explicit, or no air to solve for).
    Now,
    /// At its end: the integrator moves the particles by every other force first, then asks
    /// the air model for the pressure ([`AirModel::solve_end_of_step`]).
    EndOfStep,
}

/// The pressure the air puts on the cloth during one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum AirLoad<'a> {
    /// Every particle feels the pressure difference `P - P_a`, this many Pa (0: no force).
    Uniform(Real),
    /// Each particle feels its own pressure difference, Pa.
    PerParticle(&'a [Real]),
}

/// One sealed pocket as the outputs report it (`pockets.csv`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PocketReport {
    /// Id, kept while the pocket persists (the thesis' bubble is pocket 0).
    pub id: u32,
    /// Volume, m^3 (for a pocket, [`pockets::Pocket::effective_volume`]: at least a 1 um gap).
    pub volume: Real,
    /// Air, m^3 at atmospheric pressure.
    pub amount: Real,
    /// Pressure, Pa.
    pub pressure: Real,
    /// Cloth area over it, m^2.
    pub area: Real,
    /// Particles in it.
    pub particles: u32,
}

/// The air model of a simulation.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum AirModel {
    /// The thesis' single bubble (3.4).
    Thesis(Bubble),
    /// Sealed pockets ([`pockets`]).
    Pockets(Box<Pockets>),
}

impl AirModel {
    /// The model the parameters ask for, for the cloth of `model` in `state` (measured in
    /// `measures`, with cell volumes for the pockets model; each particle's seeded pocket in
    /// `seed_of`, `air::seeds`).
    pub(crate) fn new(
        air: &AirParams,
        model: &Model,
        state: &State,
        measures: &Measures,
        seed_of: &[u32],
    ) -> Self {
        match air.model {
            AirModelKind::Thesis => AirModel::Thesis(Bubble::new(air.trapped_air)),
            AirModelKind::Pockets => {
                AirModel::Pockets(Box::new(Pockets::new(air, model, state, measures, seed_of)))
            }
        }
    }

    /// Whether the model needs each cell's gap volume measured.
    pub fn keeps_cells(air: &AirParams) -> bool {
        air.model == AirModelKind::Pockets
    }

    /// The thesis bubble, if this is the thesis model.
    pub fn bubble(&self) -> Option<&Bubble> {
        match self {
            AirModel::Thesis(b) => Some(b),
            AirModel::Pockets(_) => None,
        }
    }

    /// The pockets, if this is the pockets model.
    pub fn pockets(&self) -> Option<&Pockets> {
        match self {
            AirModel::Thesis(_) => None,
            AirModel::Pockets(p) => Some(p),
        }
    }

    /// Volume of the trapped air, m^3: the bubble's, or the sealed pockets' together.
    pub fn volume(&self) -> Real {
        match self {
            AirModel::Thesis(b) => b.volume,
            AirModel::Pockets(p) => p.volume(),
        }
    }

    /// Pressure of the trapped air, Pa: the bubble's by Boyle's law (atmospheric with the air
    /// force off), or the sealed pockets' volume-weighted mean (atmospheric without any).
    pub fn pressure(&self, air: &AirParams, model: &Model, enabled: bool) -> Real {
        match self {
            AirModel::Thesis(b) => b.pressure(air, model, enabled),
            AirModel::Pockets(p) if enabled => p.mean_pressure(air.atmospheric_pressure),
            AirModel::Pockets(_) => air.atmospheric_pressure,
        }
    }

    /// Air trapped, m^3 at atmospheric pressure.
    pub fn trapped_air(&self) -> Real {
        match self {
            AirModel::Thesis(b) => b.trapped_air,
            AirModel::Pockets(p) => p.amount(),
        }
    }

    /// Number of sealed pockets (the thesis' bubble counts as one).
    pub fn pocket_count(&self) -> usize {
        match self {
            AirModel::Thesis(_) => 1,
            AirModel::Pockets(p) => p.pockets.len(),
        }
    }

    /// The sealed pockets as the outputs report them.
    pub fn reports(&self, air: &AirParams, model: &Model, enabled: bool) -> Vec<PocketReport> {
        match self {
            AirModel::Thesis(b) => vec![PocketReport {
                id: 0,
                volume: b.volume,
                amount: b.trapped_air,
                pressure: b.pressure(air, model, enabled),
                area: model.cloth_area,
                particles: model.len() as u32,
            }],
            AirModel::Pockets(p) => p
                .pockets
                .iter()
                .map(|q| PocketReport {
                    id: q.id,
                    volume: q.effective_volume(),
                    amount: q.amount,
                    pressure: if enabled {
                        q.pressure
                    } else {
                        air.atmospheric_pressure
                    },
                    area: q.area,
                    particles: q.particles,
                })
                .collect(),
        }
    }

    /// The largest pressure difference across the cloth, Pa (for the energy audit).
    pub(crate) fn largest_pressure_difference(
        &self,
        air: &AirParams,
        model: &Model,
        enabled: bool,
    ) -> Real {
        if !enabled {
            return 0.0;
        }
        let pa = air.atmospheric_pressure;
        match self {
            AirModel::Thesis(b) => (b.applied_pressure - pa)
                .abs()
                .max((b.pressure(air, model, enabled) - pa).abs()),
            // (The water film's pull is counted as work, `Control::film_work`.)
            AirModel::Pockets(p) => p
                .pockets
                .iter()
                .map(|q| (q.pressure - pa).abs())
                .fold(0.0, Real::max),
        }
    }

    /// Phase 2 of the step: when the step's pressure is known.
    pub(crate) fn begin_step(
        &mut self,
        air: &AirParams,
        model: &Model,
        state: &State,
        control: &Control,
        dt: Real,
    ) -> Timing {
        match self {
            AirModel::Thesis(b) => b.begin_step(air, model, state, control, dt),
            AirModel::Pockets(p) => p.begin_step(air, model, state, control, dt),
        }
    }

    /// The load on the cloth during the step (once known).
    pub(crate) fn load(&self, air: &AirParams) -> AirLoad<'_> {
        match self {
            AirModel::Thesis(b) => b.load(air),
            AirModel::Pockets(p) => p.load(),
        }
    }

    /// For [`Timing::EndOfStep`]: solves the step's pressure from the coasting positions
    /// `coast` (m), measured in `coast_measures`; `held` marks the hands' particles. The
    /// pockets take the particles' `response` per pascal from an implicit solve if given, with
    /// the particles its contacts held ([`Pockets::solve_end_of_step`]); the thesis' bubble
    /// ignores it.
    pub(crate) fn solve_end_of_step(
        &mut self,
        air: &AirParams,
        model: &Model,
        coast: &Soa,
        coast_measures: &Measures,
        held: &[bool],
        response: Option<(&Soa, &[bool])>,
    ) {
        match self {
            AirModel::Thesis(b) => {
                b.solve_end_of_step(model, coast, coast_measures.totals().volume, held)
            }
            AirModel::Pockets(p) => {
                p.solve_end_of_step(air, model, coast, coast_measures, held, response)
            }
        }
    }

    /// For an integrator that solves the end-of-step pressure itself (the mesh's implicit
    /// step): the thesis bubble's pending solve, taken; `None` for the pockets model or when the
    /// pressure is known now.
    pub(crate) fn take_end_of_step(&mut self) -> Option<bubble::EndOfStep> {
        match self {
            AirModel::Thesis(b) => b.take_end_of_step(),
            AirModel::Pockets(_) => None,
        }
    }

    /// Records the bubble pressure (Pa) the step applied (the thesis' bubble; see
    /// [`AirModel::take_end_of_step`]).
    pub(crate) fn set_applied_pressure(&mut self, pressure: Real) {
        if let AirModel::Thesis(b) = self {
            b.applied_pressure = pressure;
        }
    }

    /// Phase 4: air through the border lifted at the step's end (positions `x`; the thesis'
    /// bubble).
    pub(crate) fn leak(
        &mut self,
        air: &AirParams,
        model: &Model,
        x: &Soa,
        enabled: bool,
        dt: Real,
    ) {
        if let AirModel::Thesis(b) = self {
            b.leak(air, model, x, enabled, dt)
        }
    }

    /// Phase 6: the air of the new state, measured in `measures` (total gap volume `volume`,
    /// m^3).
    pub(crate) fn finish_step(
        &mut self,
        air: &AirParams,
        model: &Model,
        state: &State,
        measures: &Measures,
        volume: Real,
        dt: Real,
    ) {
        match self {
            AirModel::Thesis(b) => b.set_volume(volume),
            AirModel::Pockets(p) => p.finish_step(air, model, state, measures, dt),
        }
    }
}
