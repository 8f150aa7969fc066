//! Air leaking in or out where the cloth's border is lifted off the surface (the thesis'
//! future work: "the amount of air should change while the cloth deforms").
//!
//! The flow is `leak_conductance * L_open * (P_a - P_b) / P_a` cubic metres per second
//! (measured at atmospheric pressure), `L_open` the length of border lifted off every collider.

use crate::math::Real;
use crate::model::Model;

/// Length of the cloth's border lifted off every collider, m, given each particle's contact
/// flag: a border edge counts fully when neither of its particles touched anything, and half
/// when one of them did (the gap opens somewhere along it).
pub fn open_border_length(model: &Model, contact: &[bool]) -> Real {
    let border = &model.border;
    let n = border.len();
    (0..n)
        .map(|e| {
            let (a, b) = (border[e] as usize, border[(e + 1) % n] as usize);
            let lifted = u8::from(!contact[a]) + u8::from(!contact[b]);
            0.5 * Real::from(lifted) * model.grid.rest_distance(a, b)
        })
        .sum()
}

/// Air flowing in through an open length `open_length` (m) of border with conductance
/// `conductance` (m^2/s) at bubble pressure `pressure` (Pa): m^3/s at atmospheric pressure
/// `atmosphere` (Pa), negative when air flows out.
#[inline]
pub fn border_flow(conductance: Real, open_length: Real, atmosphere: Real, pressure: Real) -> Real {
    conductance * open_length * (atmosphere - pressure) / atmosphere
}
