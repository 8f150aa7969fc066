//! When the frames of a run fall: frame `k` is the state at the first step whose time is at
//! least `k / frame_rate`; the last frame is `floor(duration * frame_rate)`.

use wetcloth::{Real, SimConfig};

/// Relative tolerance when counting frames, so that `duration * frame_rate` a hair below an
/// integer by round-off (0.29 * 100 = 28.999999999999996) still counts that last frame.
const FRAME_COUNT_TOLERANCE: Real = 1e-12;

/// Fraction of a step by which a step time may fall short of a frame time and still count.
const STEP_TOLERANCE: Real = 1e-6;

/// Index of the last frame: `floor(duration * frame_rate)`, up to round-off.
pub fn last_frame(config: &SimConfig) -> u64 {
    let x = config.simulation.duration * config.simulation.frame_rate;
    (x * (1.0 + FRAME_COUNT_TOLERANCE)).floor() as u64
}

/// The step at which frame `k` is written: [`step_at`] the frame's time `k / frame_rate`.
pub fn frame_step(k: u64, frame_rate: Real, dt: Real) -> u64 {
    step_at(k as Real / frame_rate, dt)
}

/// The first step count `n` with `n * dt >= t`, computed from integers so that no time is
/// accumulated. A step that misses `t` by round-off only (600 steps of 1/12000 s is
/// 0.049999999999999996 s, not 0.05) counts as on it, so frames stay evenly spaced in steps.
pub fn step_at(t: Real, dt: Real) -> u64 {
    let t = t - STEP_TOLERANCE * dt;
    let mut n = (t / dt).ceil().max(0.0) as u64;
    while n > 0 && (n - 1) as Real * dt >= t {
        n -= 1;
    }
    while (n as Real) * dt < t {
        n += 1;
    }
    n
}
