//! The trapped air (thesis 3.4-3.5): Boyle's law, the gap volume, and the air models.
//!
//! | file | contents | thesis |
//! |---|---|---|
//! | `boyle.rs` | `P_b v = P_a v0` | eq. 3.8-3.9 |
//! | `gap.rs` | the volume between cloth and sticking surface, signed prisms | 3.5, eq. 3.10 |
//! | `bubble.rs` | the thesis' single bubble, with its explicit or implicit pressure | 3.4 |
//! | `leak.rs` | air through a lifted border | ch. 5 (future work) |
//!
//! An air model answers two questions each step: what pressure acts on the cloth during the
//! step (`AirModel::begin_step`, phase 2 of [`crate::Simulation::step`]), and what the air
//! becomes after it (leaks and the new volume, phases 4 and 7). A new model is a new file here
//! and a variant of [`AirModel`].

pub mod boyle;
pub mod bubble;
pub mod gap;
pub mod leak;

pub use boyle::{MIN_GAP, boyle_pressure};
pub use bubble::Bubble;
pub use gap::{StickingPlane, prism_volume, row_volume, volume};

use crate::control::Control;
use crate::math::Real;
use crate::model::Model;
use crate::params::AirParams;
use crate::state::State;

/// The pressure the air puts on the cloth during one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum AirLoad {
    /// Every particle feels the pressure difference `P_b - P_a`, this many Pa (0: no force).
    Uniform(Real),
    /// Every particle feels `(P_b - P_a) S N` with the pressure `P_b` of the state at the end
    /// of the step, which the integrator solves from its coasting positions.
    EndOfStep(bubble::EndOfStep),
}

/// The air model of a simulation.
#[derive(Clone, Debug, PartialEq)]
pub enum AirModel {
    /// The thesis' single bubble (3.4).
    Thesis(Bubble),
}

impl AirModel {
    /// The model the parameters ask for.
    pub fn new(air: &AirParams) -> Self {
        AirModel::Thesis(Bubble::new(air.trapped_air))
    }

    /// The thesis bubble.
    pub fn bubble(&self) -> &Bubble {
        match self {
            AirModel::Thesis(b) => b,
        }
    }

    /// Phase 2 of the step: the load on the cloth during the step.
    pub(crate) fn begin_step(
        &mut self,
        air: &AirParams,
        model: &Model,
        state: &State,
        control: &Control,
        dt: Real,
    ) -> AirLoad {
        match self {
            AirModel::Thesis(b) => b.begin_step(air, model, state, control, dt),
        }
    }

    /// Records the pressure the integrator solved for an [`AirLoad::EndOfStep`], Pa.
    pub(crate) fn set_applied_pressure(&mut self, pressure: Real) {
        match self {
            AirModel::Thesis(b) => b.set_applied_pressure(pressure),
        }
    }

    /// Phase 4: air through the border during the step (`contact` flags of the step).
    pub(crate) fn leak(
        &mut self,
        air: &AirParams,
        model: &Model,
        contact: &[bool],
        enabled: bool,
        dt: Real,
    ) {
        match self {
            AirModel::Thesis(b) => b.leak(air, model, contact, enabled, dt),
        }
    }

    /// Phase 7: the gap volume of the new state, m^3.
    pub(crate) fn set_volume(&mut self, volume: Real) {
        match self {
            AirModel::Thesis(b) => b.set_volume(volume),
        }
    }
}
