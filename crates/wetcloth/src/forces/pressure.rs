//! The air-pressure force (thesis 3.4, eq. 3.7, with the physical sign).

use crate::math::{Real, RowMut, RowRef, Vec3};

/// Pressure force on a particle (thesis eq. 3.7, physical sign): `(P_b - P_a) S N`, with `N`
/// the unit cloth normal pointing out of the bubble and `S` the cloth area per particle (m^2).
/// Under-pressure (`P_b < P_a`) pushes the cloth into the bubble: the atmosphere presses a
/// lifted cloth back down.
#[inline]
pub fn pressure_force(bubble: Real, atmosphere: Real, area: Real, normal: Vec3) -> Vec3 {
    normal * ((bubble - atmosphere) * area)
}

/// Adds `pressure_area * N` (N) to every particle of a row, `pressure_area` = `(P_b - P_a) S`
/// and `N` the unit normal of [`crate::Grid::normal`]: the cross product of the central
/// differences along z and x (rows `below` and `above` are the neighbouring rows, or the row
/// itself at the border; one-sided differences at the border columns).
#[inline(always)]
pub(crate) fn add_row(
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
    let tz_at = |i: usize| above.get(i) - below.get(i);
    // Border columns: one-sided differences.
    for (i, l, r) in [(0, 0, 1), (nx - 1, nx - 2, nx - 1)] {
        let f = normal(here.get(r) - here.get(l), tz_at(i));
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

/// [`add_row`] with each particle's own pressure: adds `pressures[i] * factor * N` (N) to
/// particle `i` (`pressures` in Pa, `factor` the area per particle S times any scale, m^2).
pub(crate) fn add_row_each(
    force: &mut RowMut<'_>,
    here: RowRef<'_>,
    below: RowRef<'_>,
    above: RowRef<'_>,
    pressures: &[Real],
    factor: Real,
) {
    let nx = here.x.len();
    let normal = |tx: Vec3, tz: Vec3, p: Real| {
        let n = tz.cross(tx);
        let len = n.length().max(1e-300);
        n * (p * factor / len)
    };
    let tz_at = |i: usize| above.get(i) - below.get(i);
    // Border columns: one-sided differences.
    for (i, l, r) in [(0, 0, 1), (nx - 1, nx - 2, nx - 1)] {
        let f = normal(here.get(r) - here.get(l), tz_at(i), pressures[i]);
        force.x[i] += f.x;
        force.y[i] += f.y;
        force.z[i] += f.z;
    }
    // Interior: component-wise over equal-length slices, as in `add_row`, so it vectorises.
    let m = nx - 2;
    let (lx, ly, lz) = (&here.x[..m], &here.y[..m], &here.z[..m]);
    let (rx, ry, rz) = (&here.x[2..], &here.y[2..], &here.z[2..]);
    let (bx, by, bz) = (&below.x[1..=m], &below.y[1..=m], &below.z[1..=m]);
    let (ax, ay, az) = (&above.x[1..=m], &above.y[1..=m], &above.z[1..=m]);
    let pr = &pressures[1..=m];
    let (fx, fy, fz) = (
        &mut force.x[1..=m],
        &mut force.y[1..=m],
        &mut force.z[1..=m],
    );
    for k in 0..m {
        let (tx, ty, tw) = (rx[k] - lx[k], ry[k] - ly[k], rz[k] - lz[k]);
        let (sx, sy, sw) = (ax[k] - bx[k], ay[k] - by[k], az[k] - bz[k]);
        let nxv = sy * tw - sw * ty;
        let nyv = sw * tx - sx * tw;
        let nzv = sx * ty - sy * tx;
        let len = (nxv * nxv + nyv * nyv + nzv * nzv).sqrt().max(1e-300);
        let s = pr[k] * factor / len;
        fx[k] += nxv * s;
        fy[k] += nyv * s;
        fz[k] += nzv * s;
    }
}

/// Adds `pressure(i) * A_i` (N) to every particle `i` of row `here`, `pressure(i)` = `P - P_a`
/// (Pa)
/// and `A_i` the particle's share of the cloth's area vector ([`crate::PressureForce::Area`]):
/// a sixth of `(b - v) x (c - v)` over the (up to six) triangles of `crate::Grid::triangles`
/// around it, `v` the particle. `below` and `above` are the neighbouring rows, `None` at the
/// grid's edge.
pub(crate) fn add_row_area(
    force: &mut RowMut<'_>,
    here: RowRef<'_>,
    below: Option<RowRef<'_>>,
    above: Option<RowRef<'_>>,
    pressure: impl Fn(usize) -> Real,
) {
    let nx = here.x.len();
    for i in 0..nx {
        let scale = pressure(i) / 6.0;
        let v = here.get(i);
        let (west, east) = (i > 0, i + 1 < nx);
        let mut sum = Vec3::ZERO;
        let mut tri = |b: Vec3, c: Vec3| sum += (b - v).cross(c - v);
        // The ring E, S, SW, W, N, NE: triangles (v, NE, E), (v, N, NE), (v, W, N), (v, S, SW),
        // (v, SW, W), (v, E, S), as in `Grid::triangles`.
        if let Some(a) = above {
            if east {
                tri(a.get(i + 1), here.get(i + 1));
                tri(a.get(i), a.get(i + 1));
            }
            if west {
                tri(here.get(i - 1), a.get(i));
            }
        }
        if let Some(b) = below {
            if west {
                tri(b.get(i), b.get(i - 1));
                tri(b.get(i - 1), here.get(i - 1));
            }
            if east {
                tri(here.get(i + 1), b.get(i));
            }
        }
        force.x[i] += sum.x * scale;
        force.y[i] += sum.y * scale;
        force.z[i] += sum.z * scale;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Soa, row};
    use crate::model::Grid;
    use crate::params::ClothParams;

    /// The vectorised pressure force is `pressure_area` times the normal `Grid::normal`
    /// defines, border rows and columns included, on a crumpled cloth.
    #[test]
    fn row_pressure_matches_the_grid_normal() {
        let grid = Grid::new(&ClothParams {
            resolution: [7, 5],
            ..Default::default()
        });
        let mut p = grid.rest_positions(Vec3::ZERO);
        for k in 0..grid.len() {
            let s = k as Real;
            p.y[k] += 0.01 * (0.9 * s).sin();
            p.x[k] += 0.002 * (1.7 * s).cos();
        }
        let nx = grid.nx;
        for j in 0..grid.nz {
            let (mut fx, mut fy, mut fz) = (vec![0.0; nx], vec![0.0; nx], vec![0.0; nx]);
            let mut f = RowMut {
                x: &mut fx,
                y: &mut fy,
                z: &mut fz,
            };
            let below = row(&p, nx, j.saturating_sub(1));
            let above = row(&p, nx, (j + 1).min(grid.nz - 1));
            add_row(&mut f, row(&p, nx, j), below, above, -3.5);
            for i in 0..nx {
                let expect = grid.normal(&p, grid.index(i, j)) * -3.5;
                let got = Vec3::new(fx[i], fy[i], fz[i]);
                assert!(
                    (got - expect).length() < 1e-12,
                    "({i}, {j}): {got} vs {expect}"
                );
            }
        }
    }

    /// The area shares sum to the cloth's area vector (a flat cloth: its area, up), give an
    /// interior particle of a flat cloth `dx dz`, and are the gradient of the enclosed volume:
    /// moving one particle by `d` changes the divergence-theorem volume of the cloth closed by
    /// its projection by `A_i . d` to first order.
    #[test]
    fn area_shares_sum_to_the_area_and_are_the_volume_gradient() {
        let grid = Grid::new(&ClothParams {
            resolution: [6, 5],
            ..Default::default()
        });
        let nx = grid.nx;
        let shares = |p: &Soa| {
            let mut out = Vec::new();
            for j in 0..grid.nz {
                let (mut fx, mut fy, mut fz) = (vec![0.0; nx], vec![0.0; nx], vec![0.0; nx]);
                let mut f = RowMut {
                    x: &mut fx,
                    y: &mut fy,
                    z: &mut fz,
                };
                let below = (j > 0).then(|| row(p, nx, j - 1));
                let above = (j + 1 < grid.nz).then(|| row(p, nx, j + 1));
                add_row_area(&mut f, row(p, nx, j), below, above, |_| 1.0);
                out.extend((0..nx).map(|i| Vec3::new(fx[i], fy[i], fz[i])));
            }
            out
        };
        let flat = grid.rest_positions(Vec3::ZERO);
        let a = shares(&flat);
        let total: Vec3 = a.iter().copied().sum();
        let area = 0.3 * 0.3;
        assert!((total - Vec3::Y * area).length() < 1e-15, "{total}");
        assert!((a[grid.index(2, 2)].y - grid.dx * grid.dz).abs() < 1e-15);
        // The volume of the triangles' cones from the origin, (1/6) sum a . (b x c).
        let volume = |p: &Soa| -> Real {
            grid.triangles()
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|k| p.get(k as usize));
                    a.dot(b.cross(c)) / 6.0
                })
                .sum()
        };
        let mut p = flat.clone();
        for k in 0..grid.len() {
            let s = k as Real;
            p.y[k] += 0.02 * (0.9 * s).sin();
            p.x[k] += 0.004 * (1.7 * s).cos();
        }
        let a = shares(&p);
        let k = grid.index(2, 3);
        let d = Vec3::new(1.0, -2.0, 0.5) * 1e-7;
        let mut q = p.clone();
        q.set(k, p.get(k) + d);
        let dv = volume(&q) - volume(&p);
        assert!(
            (dv - a[k].dot(d)).abs() < 1e-6 * dv.abs(),
            "{dv} vs {}",
            a[k].dot(d)
        );
    }

    #[test]
    fn pressure_force_presses_towards_the_lower_pressure() {
        // Half an atmosphere under 1 cm^2 of cloth whose normal points up: 5.07 N down.
        let f = pressure_force(50_662.5, 101_325.0, 1e-4, Vec3::Y);
        assert!((f - Vec3::new(0.0, -5.066_25, 0.0)).length() < 1e-12);
    }
}
