//! Air leaking in or out where the cloth's border is lifted off the surface (the thesis'
//! future work: "the amount of air should change while the cloth deforms").
//!
//! The flow is `leak_conductance * L_open * (P_a - P_b) / P_a` cubic metres per second
//! (measured at atmospheric pressure), `L_open` the length of border lifted off every collider.

use crate::math::{Real, Soa};
use crate::model::Model;

/// Length of the cloth's border lifted off every collider, m, at the positions `x`: a border
/// particle is lifted where no collider's surface lies within `reach` (m; its collision radius
/// plus `[air] seal_distance`, the gap that the border's water film still closes). A border
/// edge counts fully when both of its particles are lifted, and half when one is (the gap opens
/// somewhere along it).
///
/// The gap is measured, not taken from the step's contact flags: those say whether the
/// integrator's step ended inside a surface, which position Verlet does only every few steps
/// for a particle resting on the table (at 1/20000 s the flags of 92 % of a cloth lying stuck
/// dropped for 13 ms and the leak saw its whole border open).
pub fn open_border_length(model: &Model, x: &Soa, reach: Real) -> Real {
    let border = &model.border;
    let n = border.len();
    let lifted = |k: usize| {
        let p = x.get(k);
        !model
            .colliders
            .iter()
            .any(|c| c.distance_within(p, reach).is_some_and(|(d, _)| d <= reach))
    };
    if n == 0 {
        return 0.0;
    }
    // Each border particle is tested once: the loop carries the last edge's end.
    let start = lifted(border[0] as usize);
    let mut la = start;
    let mut length = 0.0;
    for e in 0..n {
        let (a, b) = (border[e] as usize, border[(e + 1) % n] as usize);
        let lb = if e + 1 == n { start } else { lifted(b) };
        length += 0.5 * Real::from(u8::from(la) + u8::from(lb)) * model.grid.rest_distance(a, b);
        la = lb;
    }
    length
}

/// Air flowing in through an open length `open_length` (m) of border with conductance
/// `conductance` (m^2/s) at bubble pressure `pressure` (Pa): m^3/s at atmospheric pressure
/// `atmosphere` (Pa), negative when air flows out.
#[inline]
pub fn border_flow(conductance: Real, open_length: Real, atmosphere: Real, pressure: Real) -> Real {
    conductance * open_length * (atmosphere - pressure) / atmosphere
}
