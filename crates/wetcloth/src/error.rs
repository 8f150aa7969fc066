//! Errors of the core: invalid parameters, and steps that blow up or go unphysical.

use crate::math::Real;

/// A parameter is out of its documented range or inconsistent with another.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// A value outside its valid range. `key` is the scene-file key path (`cloth.mass`).
    #[error("`{key}` = {value} is out of range: allowed {range}")]
    OutOfRange {
        /// Scene-file key path, e.g. `cloth.mass` or `collider[0].friction`.
        key: String,
        /// The offending value as written.
        value: String,
        /// The allowed range, in words.
        range: String,
    },
    /// A value that is invalid for another reason.
    #[error("`{key}`: {message}")]
    Invalid {
        /// Scene-file key path.
        key: String,
        /// What is wrong and how to fix it.
        message: String,
    },
}

impl ConfigError {
    /// The scene-file key path the error is about.
    pub fn key(&self) -> &str {
        match self {
            ConfigError::OutOfRange { key, .. } | ConfigError::Invalid { key, .. } => key,
        }
    }
}

/// A step produced a state no cloth can be in; the state before the step is kept.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    /// A position became NaN or infinite.
    #[error(
        "the simulation blew up at t = {time:.6} s: a particle position became non-finite; \
         try a smaller time_step"
    )]
    NonFinite {
        /// Simulated time of the step that failed, s.
        time: Real,
    },
    /// A structural spring stretched far past anything cloth survives.
    #[error(
        "the simulation blew up at t = {time:.6} s: a structural spring is stretched to \
         {ratio:.1} times its rest length (limit {limit}); try a smaller time_step"
    )]
    OverStretch {
        /// Simulated time, s.
        time: Real,
        /// Current length / rest length of the longest structural spring.
        ratio: Real,
        /// The limit that was passed.
        limit: Real,
    },
    /// The bubble volume went more negative than any folded cloth can make it.
    #[error(
        "the simulation went unphysical at t = {time:.6} s: the bubble volume is \
         {volume:.3e} m^3 (below {floor:.3e}): the cloth has passed through the sticking surface \
         or through itself under the pressure force; try a smaller time_step, a finer cloth \
         (resolution) or more trapped_air"
    )]
    NegativeVolume {
        /// Simulated time, s.
        time: Real,
        /// The bubble volume, m^3.
        volume: Real,
        /// The most negative volume a cloth folded flat can have, m^3 (`-2 r A`).
        floor: Real,
    },
    /// The cloth gained far more energy than anything did work on it.
    #[error(
        "the simulation went unphysical at t = {time:.6} s: the cloth gained {gain:.3e} J of \
         energy while the hands, the moving colliders, the water film and the air can account \
         for at most {allowance:.3e} J; try a \
         smaller time_step or a finer cloth (resolution)"
    )]
    EnergyGain {
        /// Simulated time, s.
        time: Real,
        /// Mechanical energy gained since the start, J.
        gain: Real,
        /// The most the hands and the air allow, J.
        allowance: Real,
    },
    /// A particle went farther from where the cloth started than anything can carry it.
    #[error(
        "the simulation went unphysical at t = {time:.6} s: a particle is {distance:.3e} m from          where the cloth started, beyond the {reach:.3e} m that free fall, the hands and the          energy they and the air gave can explain; try a smaller time_step"
    )]
    OutOfReach {
        /// Simulated time, s.
        time: Real,
        /// The farthest particle's distance from the cloth's centre at the start, m.
        distance: Real,
        /// The farthest any particle can be (see `checks::EnergyAudit::reach`), m.
        reach: Real,
    },
}
