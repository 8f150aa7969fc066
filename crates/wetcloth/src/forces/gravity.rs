//! Gravity (thesis eq. 3.3) and velocity damping.

use crate::math::{Real, RowMut, RowRef, Vec3};

/// Gravity plus damping on one particle, N: `m g - c v`, with `c = damping * m` (1/s times kg)
/// and `v` the particle's velocity (m/s).
#[inline]
pub fn weight_and_damping(mass: Real, gravity: Vec3, damping: Real, velocity: Vec3) -> Vec3 {
    gravity * mass - velocity * (damping * mass)
}

/// Starts the forces of a row: `force = weight - damp * (here - prev)`, the weight `m g` (N)
/// and Verlet's damping with `damp = damping * m / dt` (kg/s^2) on the step `here - prev` (m).
#[inline(always)]
pub(crate) fn set_row(
    force: &mut RowMut<'_>,
    here: RowRef<'_>,
    prev: RowRef<'_>,
    weight: Vec3,
    damp: Real,
) {
    let nx = here.x.len();
    let (fx, fy, fz) = (&mut force.x[..nx], &mut force.y[..nx], &mut force.z[..nx]);
    let (px, py, pz) = (&prev.x[..nx], &prev.y[..nx], &prev.z[..nx]);
    for i in 0..nx {
        fx[i] = weight.x - damp * (here.x[i] - px[i]);
        fy[i] = weight.y - damp * (here.y[i] - py[i]);
        fz[i] = weight.z - damp * (here.z[i] - pz[i]);
    }
}
