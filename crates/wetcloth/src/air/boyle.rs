//! Boyle's law (thesis 3.4, eq. 3.8-3.9): `P_b v = P_a v0 = K`, with `v0` the trapped air at
//! atmospheric pressure.
//!
//! The volume is floored at [`MIN_GAP`] times the cloth's area so a bubble squeezed flat gives
//! a large finite pressure instead of a division by zero.

use crate::math::Real;

/// Smallest mean gap used in Boyle's law, m (1 micrometre).
pub const MIN_GAP: Real = 1e-6;

/// Bubble pressure by Boyle's law (eq. 3.9), Pa: `P_a v0 / v`, with `v` floored at
/// `MIN_GAP * area` (`area` the cloth's rest area, m^2).
#[inline]
pub fn boyle_pressure(atmosphere: Real, trapped_air: Real, volume: Real, area: Real) -> Real {
    atmosphere * trapped_air / volume.max(MIN_GAP * area)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boyle_keeps_pv_constant() {
        for v in [1e-4, 4e-4, 1e-3] {
            let p = boyle_pressure(101_325.0, 4e-4, v, 0.09);
            assert!((p * v - 101_325.0 * 4e-4).abs() < 1e-9);
        }
        // No trapped air: a vacuum whatever the volume.
        assert_eq!(boyle_pressure(101_325.0, 0.0, 1e-3, 0.09), 0.0);
        // A squeezed bubble stays finite.
        assert!(boyle_pressure(101_325.0, 4e-4, 0.0, 0.09).is_finite());
    }
}
