//! Force kernels (thesis 3.3, eq. 3.2-3.7): one pure function per force, and the row loops
//! that apply them over the grid stencil.

use crate::math::{Real, Vec3};

/// Smallest spring length used as a divisor, m: a spring collapsed to a point exerts no force
/// instead of a NaN.
const MIN_LENGTH: Real = 1e-12;

/// Hooke spring force on the particle at `xi` from its neighbour at `xj` (thesis eq. 3.6):
/// `k (d - l) D`, with `d = |xj - xi|`, `l` the rest length and `D` the unit vector towards the
/// neighbour. Pulls when stretched, pushes when compressed, zero for a collapsed spring.
#[inline]
pub fn spring_force(xi: Vec3, xj: Vec3, stiffness: Real, rest_length: Real) -> Vec3 {
    let d = xj - xi;
    let len = d.length();
    if len < MIN_LENGTH {
        return Vec3::ZERO;
    }
    d * (stiffness * (len - rest_length) / len)
}

/// Pressure force on a particle (thesis eq. 3.7, physical sign): `(P_b - P_a) S N`, with `N`
/// the unit cloth normal pointing out of the bubble and `S` the cloth area per particle (m^2).
/// Under-pressure (`P_b < P_a`) pushes the cloth into the bubble: the atmosphere presses a
/// lifted cloth back down.
#[inline]
pub fn pressure_force(bubble: Real, atmosphere: Real, area: Real, normal: Vec3) -> Vec3 {
    normal * ((bubble - atmosphere) * area)
}

/// Mutable x, y, z slices of one row of a vector field.
pub(crate) struct RowMut<'a> {
    pub x: &'a mut [Real],
    pub y: &'a mut [Real],
    pub z: &'a mut [Real],
}

impl RowMut<'_> {
    /// The same slices, read-only.
    pub fn as_ref(&self) -> RowRef<'_> {
        RowRef {
            x: self.x,
            y: self.y,
            z: self.z,
        }
    }
}

/// Read-only x, y, z slices of one row.
#[derive(Clone, Copy)]
pub(crate) struct RowRef<'a> {
    pub x: &'a [Real],
    pub y: &'a [Real],
    pub z: &'a [Real],
}

impl<'a> RowRef<'a> {
    /// The sub-row `start..start + len`.
    #[inline]
    pub fn slice(self, start: usize, len: usize) -> RowRef<'a> {
        RowRef {
            x: &self.x[start..start + len],
            y: &self.y[start..start + len],
            z: &self.z[start..start + len],
        }
    }
}

/// Writes to `f[k]` the spring force on particle `a[k]` from particle `b[k]` for every `k` (the
/// force on `b[k]` is its opposite): one stencil direction over a run of a row. Written over
/// plain slices (no branches, one square root and one divide) so the compiler vectorises it
/// across particles; the select replaces the zero-length guard of [`spring_force`].
#[inline]
pub(crate) fn spring_forces(
    f: &mut RowMut<'_>,
    a: RowRef<'_>,
    b: RowRef<'_>,
    stiffness: Real,
    rest_length: Real,
) {
    let n = a.x.len();
    let (fx, fy, fz) = (&mut f.x[..n], &mut f.y[..n], &mut f.z[..n]);
    let (bx, by, bz) = (&b.x[..n], &b.y[..n], &b.z[..n]);
    for k in 0..n {
        let dx = bx[k] - a.x[k];
        let dy = by[k] - a.y[k];
        let dz = bz[k] - a.z[k];
        let len = (dx * dx + dy * dy + dz * dz).sqrt().max(MIN_LENGTH);
        let s = stiffness * (len - rest_length) / len;
        let s = if len > MIN_LENGTH { s } else { 0.0 };
        fx[k] = s * dx;
        fy[k] = s * dy;
        fz[k] = s * dz;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spring_force_is_hooke() {
        // Stretched by 0.01 m at k = 100 N/m: 1 N towards the neighbour.
        let f = spring_force(Vec3::ZERO, Vec3::new(0.11, 0.0, 0.0), 100.0, 0.1);
        assert!((f - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-12);
        // Compressed: pushes away. Collapsed: no force, no NaN.
        let f = spring_force(Vec3::ZERO, Vec3::new(0.0, 0.05, 0.0), 100.0, 0.1);
        assert!((f - Vec3::new(0.0, -5.0, 0.0)).length() < 1e-12);
        assert_eq!(spring_force(Vec3::ONE, Vec3::ONE, 100.0, 0.1), Vec3::ZERO);
    }

    #[test]
    fn row_kernel_matches_the_pure_function() {
        let a = [0.0, 1.0, 2.0];
        let b = [0.3, 1.0 + 1e-13, 2.5];
        let zero = [0.0; 3];
        let (mut fx, mut fy, mut fz) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        let by = [0.1, 0.0, -0.2];
        let mut row = RowMut {
            x: &mut fx,
            y: &mut fy,
            z: &mut fz,
        };
        spring_forces(
            &mut row,
            RowRef {
                x: &a,
                y: &zero,
                z: &zero,
            },
            RowRef {
                x: &b,
                y: &by,
                z: &zero,
            },
            50.0,
            0.2,
        );
        for k in 0..3 {
            let expect = spring_force(
                Vec3::new(a[k], 0.0, 0.0),
                Vec3::new(b[k], by[k], 0.0),
                50.0,
                0.2,
            );
            let got = Vec3::new(fx[k], fy[k], fz[k]);
            assert!(
                (got - expect).length() <= 1e-12 * (1.0 + expect.length()),
                "{k}"
            );
        }
    }
}
