//! The explicit integrator's stability limit.

use super::{PressureSolve, SimConfig};
use crate::math::Real;

impl SimConfig {
    /// Largest stable time step of the explicit integrator for this cloth, s.
    ///
    /// The fastest mode of the spring grid is the in-plane zig-zag where neighbours move in
    /// opposite directions: each particle then feels `4 (k_structural + k_shear) u` for a
    /// displacement `u`, so `omega^2 = 4 (k_s + k_sh) / m`, and position Verlet is stable for
    /// `omega dt < 2`. The thesis-like 50 x 50 cloth of 20 g with 1000 and 250 N/m has
    /// `dt_max = 8.0e-5 s`, just *below* the thesis' 1/12000 s: a free-hanging cloth with those
    /// values grows a zig-zag from round-off within milliseconds (resting on a plane, friction
    /// hides it). Hence the defaults of 500 and 125 N/m (`dt_max = 1.13e-4 s`).
    ///
    /// Trapped air adds a second limit. Moving the whole cloth by `u` along its normal changes
    /// the bubble by `A u` and its pressure by `-(P/v) A u` (Boyle), which pushes every particle
    /// back with `(P/v) A S u`: an air spring with `omega^2 = P_a A^2 / (v0 M)` (`A` the cloth's
    /// area, `M` its mass). A small bubble is a stiff spring: for the 20 g, 30 cm cloth at
    /// 1/12000 s, less than about 70 cm^3 of trapped air is unstable (none at all is fine: then
    /// the bubble is a vacuum and has no stiffness). This limit applies to
    /// [`PressureSolve::Explicit`] only; the default implicit pressure removes it.
    pub fn stable_time_step(&self) -> Real {
        let c = &self.cloth;
        let m = c.mass / c.particle_count() as Real;
        let k = 4.0 * (c.structural_stiffness + c.shear_stiffness);
        let springs = if k > 0.0 {
            2.0 * (m / k).sqrt()
        } else {
            Real::INFINITY
        };
        let a = &self.air;
        let area = c.size[0] * c.size[1];
        let air = if a.enabled
            && a.pressure_solve == PressureSolve::Explicit
            && a.trapped_air > 0.0
            && a.atmospheric_pressure > 0.0
        {
            2.0 * (c.mass * a.trapped_air / a.atmospheric_pressure).sqrt() / area
        } else {
            Real::INFINITY
        };
        springs.min(air)
    }
}
