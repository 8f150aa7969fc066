//! Blow-up checks: a state no cloth can be in stops the run with a [`StepError`] (rapier's
//! quarantine, at one chokepoint: the end of every step).
//!
//! - **Non-finite** positions, and a structural spring past [`BLOWUP_STRETCH`] rest lengths
//!   (measured every step in the integrator's pass, the crate's private `measure` module).
//! - **A negative bubble**: with the air force on, a gap volume below `-2 r A` (`r` the particle
//!   radius, `A` the cloth's area) is more negative than any cloth lying folded flat can give;
//!   the cloth has passed through the sticking surface or through itself, and Boyle's law
//!   means nothing any more.
//! - **Energy from nowhere** ([`EnergyAudit`]): the cloth's mechanical energy (kinetic,
//!   elastic, gravitational) may grow only by the work the hands do and the energy the air can
//!   give; a run that gains far more is pumping energy out of round-off or out of a force law
//!   pushed past its validity, and stops.

use crate::error::StepError;
use crate::forces::spring;
use crate::math::{Real, Vec3};
use crate::measure::Totals;
use crate::model::Model;
use crate::state::State;

/// A structural spring longer than this many rest lengths means the run has blown up: cloth
/// tears long before, while strong suction legitimately stretches springs by tens of percent.
pub const BLOWUP_STRETCH: Real = 10.0;

/// Steps between two energy audits: often enough to stop a run long before it writes garbage,
/// rarely enough to cost nothing measurable (one pass over the springs every 128 steps).
pub const AUDIT_INTERVAL: u64 = 128;

/// `Err` if the measured state at time `time` (s) has a non-finite position or a structural
/// spring past [`BLOWUP_STRETCH`].
pub(crate) fn check(totals: &Totals, time: Real) -> Result<(), StepError> {
    if !totals.finite {
        return Err(StepError::NonFinite { time });
    }
    if totals.stretch2 > BLOWUP_STRETCH * BLOWUP_STRETCH {
        return Err(StepError::OverStretch {
            time,
            ratio: totals.stretch2.sqrt(),
            limit: BLOWUP_STRETCH,
        });
    }
    Ok(())
}

/// `Err` if the bubble volume `volume` (m^3) is more negative than a folded cloth can make it
/// (see the module docs), while the air force acts.
pub(crate) fn check_volume(model: &Model, volume: Real, time: Real) -> Result<(), StepError> {
    let floor = -2.0 * model.radius * model.cloth_area;
    if volume < floor {
        return Err(StepError::NegativeVolume {
            time,
            volume,
            floor,
        });
    }
    Ok(())
}

/// The cloth's energy budget (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct EnergyAudit {
    /// Mechanical energy when the audit started, J.
    start: Real,
    /// [`crate::Control::hand_work`] when the audit started, J.
    hand_work_start: Real,
    /// Largest bubble volume seen, m^3, and largest pressure difference across the cloth, Pa:
    /// the air can give at most their product.
    air_volume: Real,
    air_pressure: Real,
}

impl EnergyAudit {
    /// Starts the budget from `state`, with the hands' work so far `hand_work` (J).
    pub fn new(model: &Model, state: &State, dt: Real, hand_work: Real) -> Self {
        Self {
            start: mechanical_energy(model, state, dt),
            hand_work_start: hand_work,
            ..Default::default()
        }
    }

    /// Records the air after a step: bubble volume (m^3) and pressure difference (Pa).
    pub(crate) fn record_air(&mut self, volume: Real, pressure_difference: Real) {
        self.air_volume = self.air_volume.max(volume);
        self.air_pressure = self.air_pressure.max(pressure_difference.abs());
    }

    /// The most the mechanical energy may have grown, J, with the hands' work so far
    /// `hand_work` (J): twice what the hands and the air can have given, plus a millijoule.
    pub fn allowance(&self, hand_work: Real) -> Real {
        2.0 * ((hand_work - self.hand_work_start) + self.air_volume * self.air_pressure) + 1e-3
    }

    /// `Err` if the mechanical energy of `state` exceeds the start by more than
    /// [`EnergyAudit::allowance`].
    pub(crate) fn check(
        &self,
        model: &Model,
        state: &State,
        hand_work: Real,
        dt: Real,
        time: Real,
    ) -> Result<(), StepError> {
        let gain = mechanical_energy(model, state, dt) - self.start;
        let allowance = self.allowance(hand_work);
        if gain > allowance {
            return Err(StepError::EnergyGain {
                time,
                gain,
                allowance,
            });
        }
        Ok(())
    }
}

/// Kinetic plus elastic plus gravitational energy of the cloth, J (gravity's zero at the
/// origin).
pub fn mechanical_energy(model: &Model, state: &State, dt: Real) -> Real {
    let weight = model.gravity * model.particle_mass;
    let gravity: Real = (0..state.len()).map(|k| -weight.dot(state.x.get(k))).sum();
    state.kinetic_energy(model.particle_mass, dt)
        + spring::potential_energy(&model.springs, &state.x)
        + gravity
}

/// Work of a hand force `force` (N) over the move `from` -> `to` (m), J.
#[inline]
pub(crate) fn work(force: Vec3, from: Vec3, to: Vec3) -> Real {
    force.dot(to - from)
}
