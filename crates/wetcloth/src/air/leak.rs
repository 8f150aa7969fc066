//! Air leaking in or out where the cloth's border is lifted off the surface (the thesis'
//! future work: "the amount of air should change while the cloth deforms").
//!
//! The flow is `leak_conductance * L_open * (P_a - P_b) / P_a` cubic metres per second
//! (measured at atmospheric pressure), `L_open` the length of border lifted off every collider.
//!
//! With Boyle's law `P_b = P_a N / V` (`N` the air, m^3 at atmospheric pressure, `V` the
//! volume) the flow is `dN/dt = (c L / V) (V - N)`: over a step with the volume and the open
//! length held it relaxes `N` exponentially towards `V`, the amount at which the bubble is at
//! atmospheric pressure ([`relax`], integrated exactly). So a leak only ever brings the bubble
//! towards the atmosphere, never past it, whatever the conductance and the step: an explicit
//! step `N + flow dt` admitted more air than the bubble holds once `c L dt / V > 1` (a vacuum
//! of 8 ml behind a lifted border at `leak_conductance = 1` rested at 39 atmospheres).

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
    let lifted = |k: usize| {
        let p = x.get(k);
        !model
            .colliders
            .iter()
            .any(|c| c.distance_within(p, reach).is_some_and(|(d, _)| d <= reach))
    };
    let mut length = 0.0;
    for border in model.border_loops() {
        let n = border.len();
        if n == 0 {
            continue;
        }
        // Each border particle is tested once: the loop carries the last edge's end.
        let start = lifted(border[0] as usize);
        let mut la = start;
        for e in 0..n {
            let (a, b) = (border[e] as usize, border[(e + 1) % n] as usize);
            let lb = if e + 1 == n { start } else { lifted(b) };
            length += 0.5 * Real::from(u8::from(la) + u8::from(lb)) * model.rest_distance(a, b);
            la = lb;
        }
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

/// The air after a step of `dt` (s) of leaking through an open length `open_length` (m) with
/// conductance `conductance` (m^2/s): `amount` (m^3 at atmospheric pressure) relaxed exactly
/// towards `volume` (m^3, positive: Boyle's volume, floored) by `dN/dt = (c L / V) (V - N)`,
/// `N -> V + (N - V) exp(-c L dt / V)`. The result lies between `amount` and `volume` (both
/// included), so the pressure `P_a N / V` moves towards the atmosphere and never past it.
#[inline]
pub fn relax(amount: Real, volume: Real, conductance: Real, open_length: Real, dt: Real) -> Real {
    let rate = conductance * open_length / volume;
    if !(rate > 0.0 && dt > 0.0) {
        return amount;
    }
    let relaxed = volume + (amount - volume) * (-rate * dt).exp();
    // Round-off must not carry it past either end.
    relaxed.clamp(amount.min(volume), amount.max(volume))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact relaxation matches the flow's closed form, its small-step limit is the
    /// explicit flow, and no step, however large, carries the air past the atmosphere.
    #[test]
    fn relax_is_exact_and_never_overshoots() {
        let (v, c, l) = (8e-6, 10.0, 0.4);
        // Small step: N + flow dt.
        let dt = 1e-12;
        let n0 = 2e-6;
        let flow = border_flow(c, l, 1e5, 1e5 * n0 / v);
        let n1 = relax(n0, v, c, l, dt);
        assert!(((n1 - n0) / dt - flow).abs() < 1e-6 * flow.abs(), "{n1}");
        // Two half steps give one whole step (an exponential).
        let whole = relax(n0, v, c, l, 1e-6);
        let halves = relax(relax(n0, v, c, l, 5e-7), v, c, l, 5e-7);
        assert!((whole - halves).abs() < 1e-18, "{whole} {halves}");
        // Any step, from a vacuum or from over-pressure: between the start and the volume.
        for dt in [1e-6, 1e-3, 0.01, 1.0, 1e6] {
            for n in [0.0, 4e-6, 8e-6, 3e-5] {
                let m = relax(n, v, c, l, dt);
                assert!(m >= n.min(v) && m <= n.max(v), "{n} {dt} {m}");
            }
        }
        // A closed border leaves the air as it is.
        assert_eq!(relax(3e-6, v, c, 0.0, 0.01), 3e-6);
    }
}
