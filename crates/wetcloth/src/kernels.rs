//! The row kernels of the step: the hot loops, written over structure-of-arrays slices so the
//! compiler vectorises them across the particles of a row (no branches in the inner loops, one
//! square root and one division per spring or normal, bounds checks lifted by slicing first).
//!
//! Every particle's result is a fixed sequence of operations on its neighbours' positions, so
//! the output is bit-identical however the rows are split between threads.

use crate::cloth::{Grid, STENCIL};
use crate::collider::Collider;
use crate::contact;
use crate::forces::{RowMut, RowRef, add_springs};
use crate::math::{Real, Soa, Vec3};

/// A plane collider prepared for the vectorised contact loop.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlaneContact {
    pub normal: Vec3,
    /// `normal . point + radius`: a particle centre is in contact below this.
    pub offset: Real,
    pub friction: Real,
}

/// Constants of one step, shared by the row kernels.
pub(crate) struct StepConsts<'a> {
    pub grid: &'a Grid,
    /// Plane colliders (vectorised path).
    pub planes: &'a [PlaneContact],
    /// Every other collider (scalar path).
    pub others: &'a [Collider],
    pub mass: Real,
    pub gravity: Vec3,
    /// `damping * m / dt`: the damping force is `-damp * (x - x_prev)`.
    pub damp: Real,
    pub structural: Real,
    pub shear: Real,
    pub rest: [Real; 8],
    /// `(P_b - P_a) S`, N: the pressure force is this times the unit normal.
    pub pressure_area: Real,
    pub radius: Real,
    /// `dt^2 / m` (halved on the first step: the Taylor start).
    pub h: Real,
}

/// Row `r` of `p` as read-only slices.
#[inline]
pub(crate) fn row(p: &Soa, nx: usize, r: usize) -> RowRef<'_> {
    RowRef {
        x: &p.x[r * nx..(r + 1) * nx],
        y: &p.y[r * nx..(r + 1) * nx],
        z: &p.z[r * nx..(r + 1) * nx],
    }
}

/// Phases 2-3 of the step for row `j`: forces, position Verlet, contacts. Reads the current
/// positions of rows `j - 1 ..= j + 1`; `prev` holds the row's previous positions on entry and
/// its new ones on exit (Verlet needs nothing else); `force` receives the forces (N).
pub(crate) fn step_row(
    c: &StepConsts<'_>,
    j: usize,
    x: &Soa,
    prev: &mut RowMut<'_>,
    force: &mut RowMut<'_>,
    contact: &mut [bool],
) {
    let grid = c.grid;
    let nx = grid.nx;
    let here = row(x, nx, j);
    let weight = c.gravity * c.mass;

    // Gravity (eq. 3.3) and velocity damping.
    {
        let (fx, fy, fz) = (&mut force.x[..nx], &mut force.y[..nx], &mut force.z[..nx]);
        let (px, py, pz) = (&prev.x[..nx], &prev.y[..nx], &prev.z[..nx]);
        for i in 0..nx {
            fx[i] = weight.x - c.damp * (here.x[i] - px[i]);
            fy[i] = weight.y - c.damp * (here.y[i] - py[i]);
            fz[i] = weight.z - c.damp * (here.z[i] - pz[i]);
        }
    }

    // Springs (eq. 3.6), one stencil direction at a time over the run of the row that has that
    // neighbour, always in the order of `STENCIL`.
    for (n, &rest) in STENCIL.iter().zip(&c.rest) {
        let jj = j as isize + n.dj;
        if jj < 0 || jj >= grid.nz as isize {
            continue;
        }
        let i0 = (-n.di).max(0) as usize;
        let len = nx - n.di.unsigned_abs();
        let k = if n.structural { c.structural } else { c.shear };
        let a = here.slice(i0, len);
        let b = row(x, nx, jj as usize).slice((i0 as isize + n.di) as usize, len);
        add_springs(force, i0, a, b, k, rest);
    }

    // Pressure force (eq. 3.7): (P_b - P_a) S N with N the normal of `Grid::normal`, the cross
    // product of the central differences along z and x (one-sided at the border).
    if c.pressure_area != 0.0 {
        let below = row(x, nx, j.saturating_sub(1));
        let above = row(x, nx, (j + 1).min(grid.nz - 1));
        add_pressure(force, here, below, above, c.pressure_area);
    }

    // Position Verlet (eq. 3.1), written as x + (x - x_prev) + F h: the step is added to x, not
    // to 2x, which halves the round-off for slow particles.
    {
        let (fx, fy, fz) = (&force.x[..nx], &force.y[..nx], &force.z[..nx]);
        let (px, py, pz) = (&mut prev.x[..nx], &mut prev.y[..nx], &mut prev.z[..nx]);
        for i in 0..nx {
            px[i] = here.x[i] + (here.x[i] - px[i]) + fx[i] * c.h;
            py[i] = here.y[i] + (here.y[i] - py[i]) + fy[i] * c.h;
            pz[i] = here.z[i] + (here.z[i] - pz[i]) + fz[i] * c.h;
        }
    }

    // Contacts: normal force and Coulomb friction (eq. 3.4-3.5), see `contact`.
    contact[..nx].fill(false);
    for plane in c.planes {
        plane_contacts(plane, here, prev, &mut contact[..nx]);
    }
    if !c.others.is_empty() {
        for i in 0..nx {
            let now = Vec3::new(here.x[i], here.y[i], here.z[i]);
            let next = Vec3::new(prev.x[i], prev.y[i], prev.z[i]);
            let (next, hit) = contact::resolve(c.others, now, next, c.radius);
            (prev.x[i], prev.y[i], prev.z[i]) = (next.x, next.y, next.z);
            contact[i] |= hit;
        }
    }
}

/// Adds `pressure_area * N` to every particle of a row, `N` the unit normal from the central
/// differences (rows `below` and `above` are the neighbouring rows, or the row itself at the
/// border).
fn add_pressure(
    force: &mut RowMut<'_>,
    here: RowRef<'_>,
    below: RowRef<'_>,
    above: RowRef<'_>,
    pressure_area: Real,
) {
    let nx = here.x.len();
    let normal = |tx: Vec3, tz: Vec3| {
        let n = tz.cross(tx);
        let len = n.length().max(1e-300);
        n * (pressure_area / len)
    };
    let tz_at = |i: usize| {
        Vec3::new(
            above.x[i] - below.x[i],
            above.y[i] - below.y[i],
            above.z[i] - below.z[i],
        )
    };
    let at = |r: RowRef<'_>, i: usize| Vec3::new(r.x[i], r.y[i], r.z[i]);
    // Border columns: one-sided differences.
    for (i, l, r) in [(0, 0, 1), (nx - 1, nx - 2, nx - 1)] {
        let f = normal(at(here, r) - at(here, l), tz_at(i));
        force.x[i] += f.x;
        force.y[i] += f.y;
        force.z[i] += f.z;
    }
    // Interior: written component-wise over equal-length slices so it vectorises.
    let m = nx - 2;
    let (lx, ly, lz) = (&here.x[..m], &here.y[..m], &here.z[..m]);
    let (rx, ry, rz) = (&here.x[2..], &here.y[2..], &here.z[2..]);
    let (bx, by, bz) = (&below.x[1..=m], &below.y[1..=m], &below.z[1..=m]);
    let (ax, ay, az) = (&above.x[1..=m], &above.y[1..=m], &above.z[1..=m]);
    let (fx, fy, fz) = (
        &mut force.x[1..=m],
        &mut force.y[1..=m],
        &mut force.z[1..=m],
    );
    for k in 0..m {
        let (tx, ty, tw) = (rx[k] - lx[k], ry[k] - ly[k], rz[k] - lz[k]);
        let (sx, sy, sw) = (ax[k] - bx[k], ay[k] - by[k], az[k] - bz[k]);
        // n = tz x tx
        let nxv = sy * tw - sw * ty;
        let nyv = sw * tx - sx * tw;
        let nzv = sx * ty - sy * tx;
        let len = (nxv * nxv + nyv * nyv + nzv * nzv).sqrt().max(1e-300);
        let s = pressure_area / len;
        fx[k] += nxv * s;
        fy[k] += nyv * s;
        fz[k] += nzv * s;
    }
}

/// Contact with one plane for a row, branch-free so it vectorises: the same response as
/// [`contact::resolve`] (projection by the depth, then friction removing at most `mu depth` of
/// the tangential step), computed for every particle with the depth clamped to 0 for those
/// that do not touch.
fn plane_contacts(p: &PlaneContact, here: RowRef<'_>, next: &mut RowMut<'_>, contact: &mut [bool]) {
    let n = here.x.len();
    let (nx, ny, nz) = (p.normal.x, p.normal.y, p.normal.z);
    let (qx, qy, qz) = (&mut next.x[..n], &mut next.y[..n], &mut next.z[..n]);
    for i in 0..n {
        let dist = nx * qx[i] + ny * qy[i] + nz * qz[i] - p.offset;
        let depth = if dist < 0.0 { -dist } else { 0.0 };
        let (mut x, mut y, mut z) = (qx[i] + nx * depth, qy[i] + ny * depth, qz[i] + nz * depth);
        let (dx, dy, dz) = (x - here.x[i], y - here.y[i], z - here.z[i]);
        let dn = dx * nx + dy * ny + dz * nz;
        let (tx, ty, tz) = (dx - nx * dn, dy - ny * dn, dz - nz * dn);
        let slide = (tx * tx + ty * ty + tz * tz).sqrt();
        let grip = p.friction * depth;
        // Share of the tangential step that friction removes: all of it if it can (static),
        // else `grip / slide` (kinetic). Zero when not touching (grip = 0).
        let stop = if slide > grip { grip / slide } else { 1.0 };
        x -= tx * stop;
        y -= ty * stop;
        z -= tz * stop;
        (qx[i], qy[i], qz[i]) = (x, y, z);
        contact[i] |= depth > 0.0;
    }
}

/// What [`check_row`] measures of one row.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct RowCheck {
    /// Eq. 3.10 over the cells between this row and the next, m^3.
    pub volume: Real,
    /// Largest (length / rest length)^2 of the row's structural springs (right and down).
    pub stretch2: Real,
    /// NaN or infinite if any position of the row is.
    pub finite_probe: Real,
}

/// Phase 6 for row `j`: its share of the bubble volume (eq. 3.10; `plane` = (point, up),
/// heights minus `offset`) and the blow-up measures.
pub(crate) fn check_row(
    grid: &Grid,
    x: &Soa,
    j: usize,
    plane: Option<(Vec3, Vec3)>,
    offset: Real,
) -> RowCheck {
    let nx = grid.nx;
    let a = row(x, nx, j);
    let mut out = RowCheck::default();
    let has_next = j + 1 < grid.nz;
    let b = row(x, nx, if has_next { j + 1 } else { j });

    // Structural stretch to the right and down, and the finiteness probe (x * 0 is NaN exactly
    // when x is NaN or infinite).
    let (rx2, rz2) = (1.0 / (grid.dx * grid.dx), 1.0 / (grid.dz * grid.dz));
    let mut worst: Real = 0.0;
    let mut probe: Real = 0.0;
    for i in 0..nx - 1 {
        let (dx, dy, dz) = (
            a.x[i + 1] - a.x[i],
            a.y[i + 1] - a.y[i],
            a.z[i + 1] - a.z[i],
        );
        let s = (dx * dx + dy * dy + dz * dz) * rx2;
        worst = if s > worst { s } else { worst };
    }
    for i in 0..nx {
        probe += (a.x[i] + a.y[i] + a.z[i]) * 0.0;
    }
    if has_next {
        for i in 0..nx {
            let (dx, dy, dz) = (b.x[i] - a.x[i], b.y[i] - a.y[i], b.z[i] - a.z[i]);
            let s = (dx * dx + dy * dy + dz * dz) * rz2;
            worst = if s > worst { s } else { worst };
        }
    }
    out.stretch2 = worst;
    out.finite_probe = probe;

    // Eq. 3.10 over the cells (i, j)-(i+1, j)-(i+1, j+1)-(i, j+1), split as in
    // `Grid::triangles` into (a, c, b) and (a, d, c): the signed prism volumes
    // U.((c-a) x (b-a))/2 * (ha+hc+hb)/3 + U.((d-a) x (c-a))/2 * (ha+hd+hc)/3.
    if let (Some((origin, up)), true) = (plane, has_next) {
        let h0 = up.dot(origin) + offset;
        let m = nx - 1;
        let (a0x, a0y, a0z) = (&a.x[..m], &a.y[..m], &a.z[..m]);
        let (b0x, b0y, b0z) = (&a.x[1..], &a.y[1..], &a.z[1..]);
        let (c0x, c0y, c0z) = (&b.x[1..], &b.y[1..], &b.z[1..]);
        let (d0x, d0y, d0z) = (&b.x[..m], &b.y[..m], &b.z[..m]);
        let (ux, uy, uz) = (up.x, up.y, up.z);
        let mut v = 0.0;
        for i in 0..m {
            let h = |x: Real, y: Real, z: Real| ux * x + uy * y + uz * z - h0;
            let (ha, hb, hc, hd) = (
                h(a0x[i], a0y[i], a0z[i]),
                h(b0x[i], b0y[i], b0z[i]),
                h(c0x[i], c0y[i], c0z[i]),
                h(d0x[i], d0y[i], d0z[i]),
            );
            // Edges from a.
            let (bx, by, bz) = (b0x[i] - a0x[i], b0y[i] - a0y[i], b0z[i] - a0z[i]);
            let (cx, cy, cz) = (c0x[i] - a0x[i], c0y[i] - a0y[i], c0z[i] - a0z[i]);
            let (dx, dy, dz) = (d0x[i] - a0x[i], d0y[i] - a0y[i], d0z[i] - a0z[i]);
            // U . (c x b) and U . (d x c).
            let acb =
                ux * (cy * bz - cz * by) + uy * (cz * bx - cx * bz) + uz * (cx * by - cy * bx);
            let adc =
                ux * (dy * cz - dz * cy) + uy * (dz * cx - dx * cz) + uz * (dx * cy - dy * cx);
            v += acb * (ha + hc + hb) + adc * (ha + hd + hc);
        }
        out.volume = v / 6.0;
    }

    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ClothParams;

    /// The vectorised eq. 3.10 agrees with the reference `air::volume` on a crumpled cloth.
    #[test]
    fn row_volume_matches_the_reference() {
        let grid = Grid::new(&ClothParams {
            resolution: [9, 7],
            ..Default::default()
        });
        let mut p = grid.rest_positions(Vec3::new(0.1, 0.02, 0.0));
        for k in 0..grid.len() {
            let s = k as Real;
            p.x[k] += 0.003 * (1.3 * s).sin();
            p.y[k] += 0.01 * (0.7 * s).cos();
            p.z[k] += 0.002 * (2.1 * s).sin();
        }
        let up = Vec3::new(0.1, 1.0, -0.2).normalize();
        let plane = (Vec3::new(0.0, -0.01, 0.0), up);
        let reference = crate::air::volume(&grid, &p, plane, 0.001);
        let fast: Real = (0..grid.nz)
            .map(|j| check_row(&grid, &p, j, Some(plane), 0.001).volume)
            .sum();
        assert!(
            (fast - reference).abs() < 1e-14 * reference.abs(),
            "{fast} vs {reference}"
        );
    }
}
