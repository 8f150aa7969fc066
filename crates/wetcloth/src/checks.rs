//! Blow-up checks: a state no cloth can be in stops the run with a [`StepError`] (rapier's
//! quarantine, at one chokepoint: the end of every step).

use crate::error::StepError;
use crate::math::Real;
use crate::measure::Totals;

/// A structural spring longer than this many rest lengths means the run has blown up: cloth
/// tears long before, while strong suction legitimately stretches springs by tens of percent.
pub const BLOWUP_STRETCH: Real = 10.0;

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
