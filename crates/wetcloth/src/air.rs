//! The trapped air: bubble volume (thesis 3.5, eq. 3.10) and Boyle's law (3.4, eq. 3.8-3.9).
//!
//! # Volume
//!
//! `v = sum_t (U . N_t) A_t h_t` over all cloth triangles: `U` the sticking plane's unit normal,
//! `N_t` and `A_t` the triangle's unit normal and area, `h_t` the mean height of its vertices
//! above the plane. `(U . N_t) A_t` is the triangle's area projected on the plane, so each term
//! is the volume of the prism between the triangle and the plane, exact when the heights are
//! linear over the triangle. Triangles are wound so their normals point away from the plane in
//! the rest state; where the cloth folds over itself the upper layer faces down, its projected
//! area is negative, and the prisms under overlapping layers cancel (figs. 3.11-3.12).
//!
//! Heights are measured from the plane to the *particle centres* minus the particle radius:
//! a cloth resting flat on the plane, its particle spheres touching it, encloses no air.
//!
//! # Pressure
//!
//! Boyle: `P_b v = P_a v0 = K`, with `v0` the trapped air at atmospheric pressure. The volume is
//! floored at [`MIN_GAP`] times the cloth's area so a bubble squeezed flat gives a large finite
//! pressure instead of a division by zero.

use crate::cloth::Grid;
use crate::math::{Real, Soa, Vec3};

/// Smallest mean gap used in Boyle's law, m (1 micrometre).
pub const MIN_GAP: Real = 1e-6;

/// Signed volume of the prism between triangle `(a, b, c)` and the plane (eq. 3.10, one term):
/// its area projected along `up` times the mean height of its vertices. `ha, hb, hc` are the
/// vertex heights above the plane, m.
#[inline]
pub fn prism_volume(a: Vec3, b: Vec3, c: Vec3, ha: Real, hb: Real, hc: Real, up: Vec3) -> Real {
    // (U . N_t) A_t = U . ((b - a) x (c - a)) / 2.
    let projected_area = 0.5 * up.dot((b - a).cross(c - a));
    projected_area * (ha + hb + hc) / 3.0
}

/// Eq. 3.10 summed over the two triangles of every cell between rows `j` and `j + 1`.
pub fn row_volume(grid: &Grid, p: &Soa, j: usize, plane: (Vec3, Vec3), offset: Real) -> Real {
    let (origin, up) = plane;
    let h = |k: usize| (p.get(k) - origin).dot(up) - offset;
    let mut v = 0.0;
    for i in 0..grid.nx - 1 {
        let ia = grid.index(i, j);
        let ib = ia + 1;
        let ic = ib + grid.nx;
        let id = ia + grid.nx;
        let (a, b, c, d) = (p.get(ia), p.get(ib), p.get(ic), p.get(id));
        let (ha, hb, hc, hd) = (h(ia), h(ib), h(ic), h(id));
        // The same two triangles, with the same winding, as `Grid::triangles`.
        v += prism_volume(a, c, b, ha, hc, hb, up) + prism_volume(a, d, c, ha, hd, hc, up);
    }
    v
}

/// Bubble volume of the whole cloth (eq. 3.10), m^3, summed row by row in a fixed order.
pub fn volume(grid: &Grid, p: &Soa, plane: (Vec3, Vec3), offset: Real) -> Real {
    (0..grid.nz - 1)
        .map(|j| row_volume(grid, p, j, plane, offset))
        .sum()
}

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
