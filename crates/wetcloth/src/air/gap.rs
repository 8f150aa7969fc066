//! The gap between the cloth and its sticking surface: the bubble volume (thesis 3.5, eq. 3.10).
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
//! [`prism_volume`] and [`volume`] are the readable reference; the step measures the same sum
//! with `cell_volume6`, written to vectorise over a row of cells, inside its fused pass.

use crate::math::{Real, Soa, Vec3};
use crate::model::Grid;

pub use crate::collide::StickingPlane;

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
pub fn row_volume(grid: &Grid, p: &Soa, j: usize, plane: StickingPlane, offset: Real) -> Real {
    let (origin, up) = (plane.point, plane.up);
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
pub fn volume(grid: &Grid, p: &Soa, plane: StickingPlane, offset: Real) -> Real {
    (0..grid.nz - 1)
        .map(|j| row_volume(grid, p, j, plane, offset))
        .sum()
}

/// Six times eq. 3.10 for the cell with corners `a = (i, j)`, `b = (i+1, j)`, `c = (i+1, j+1)`,
/// `d = (i, j+1)`, split as in [`Grid::triangles`] into `(a, c, b)` and `(a, d, c)`:
/// `U.((c-a) x (b-a)) (ha+hc+hb) + U.((d-a) x (c-a)) (ha+hd+hc)`, with the corner heights `h`
/// above the plane (m) and the edges `eb = b - a`, `ec = c - a`, `ed = d - a` (m). Scalar
/// arguments, so a loop over a row of cells that calls it vectorises.
#[inline(always)]
pub(crate) fn cell_volume6(
    [ux, uy, uz]: [Real; 3],
    [ha, hb, hc, hd]: [Real; 4],
    [ebx, eby, ebz]: [Real; 3],
    [ecx, ecy, ecz]: [Real; 3],
    [edx, edy, edz]: [Real; 3],
) -> Real {
    // U . (c x b) and U . (d x c).
    let acb =
        ux * (ecy * ebz - ecz * eby) + uy * (ecz * ebx - ecx * ebz) + uz * (ecx * eby - ecy * ebx);
    let adc =
        ux * (edy * ecz - edz * ecy) + uy * (edz * ecx - edx * ecz) + uz * (edx * ecy - edy * ecx);
    acb * (ha + hc + hb) + adc * (ha + hd + hc)
}
