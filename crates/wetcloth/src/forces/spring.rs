//! Springs (thesis 3.1, eq. 3.6): structural springs to the 4 grid neighbours, shear springs to
//! the 4 diagonal ones, Hooke's law.
//!
//! The row loop evaluates each spring once: a row's springs are computed into `RowSprings`
//! (the force on each spring's start; the end feels the opposite), kept for the next row, and
//! every particle sums the terms it has in a fixed order (`add_row`).

use crate::math::{Real, RowMut, RowRef, Soa, Vec3, row};

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

/// Elastic energy of every spring of the grid in `x`, J: `sum k (d - l)^2 / 2` over the
/// structural and shear springs (the potential of eq. 3.6).
pub fn potential_energy(c: &SpringConsts, x: &Soa) -> Real {
    let (nx, nz) = (c.nx, c.nz);
    let mut e = 0.0;
    let mut add = |a: usize, b: usize, k: Real, l: Real| {
        let d = (x.get(b) - x.get(a)).length() - l;
        e += 0.5 * k * d * d;
    };
    for j in 0..nz {
        for i in 0..nx {
            let a = j * nx + i;
            if i + 1 < nx {
                add(a, a + 1, c.structural, c.rest_x);
            }
            if j + 1 < nz {
                add(a, a + nx, c.structural, c.rest_z);
                if i + 1 < nx {
                    add(a, a + nx + 1, c.shear, c.rest_diag);
                    add(a + 1, a + nx, c.shear, c.rest_diag);
                }
            }
        }
    }
    e
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

/// The springs' constants: stiffnesses (N/m) and rest lengths (m).
#[derive(Clone, Copy, Debug)]
pub struct SpringConsts {
    /// Particles along x.
    pub nx: usize,
    /// Particles along z.
    pub nz: usize,
    /// Structural stiffness, N/m.
    pub structural: Real,
    /// Shear stiffness, N/m.
    pub shear: Real,
    /// Rest length along x, m.
    pub rest_x: Real,
    /// Rest length along z, m.
    pub rest_z: Real,
    /// Rest length of the diagonals, m.
    pub rest_diag: Real,
}

/// Spring forces of one row, each spring computed once: for the springs that start at row `j`
/// (towards +x, +z, +x+z, and from (i+1, j) towards (i, j+1)), the force on the spring's start;
/// the end feels the opposite. Three components per spring kind.
#[derive(Clone, Debug, Default)]
pub(crate) struct RowSprings {
    /// Structural, (i, j) -> (i+1, j), entries 0..nx-1.
    right: [Vec<Real>; 3],
    /// Structural, (i, j) -> (i, j+1).
    down: [Vec<Real>; 3],
    /// Shear, (i, j) -> (i+1, j+1), entries 0..nx-1.
    diag: [Vec<Real>; 3],
    /// Shear, (i+1, j) -> (i, j+1), entries 0..nx-1.
    anti: [Vec<Real>; 3],
}

impl RowSprings {
    /// Buffers for rows of `nx` particles.
    pub fn new(nx: usize) -> Self {
        let v = || [vec![0.0; nx], vec![0.0; nx], vec![0.0; nx]];
        Self {
            right: v(),
            down: v(),
            diag: v(),
            anti: v(),
        }
    }

    /// True if sized for rows of `nx` particles.
    pub fn fits(&self, nx: usize) -> bool {
        self.right[0].len() == nx
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        [&self.right, &self.down, &self.diag, &self.anti]
            .iter()
            .flat_map(|a| a.iter())
            .map(|v| v.capacity() * std::mem::size_of::<Real>())
            .sum()
    }

    fn out(v: &mut [Vec<Real>; 3]) -> RowMut<'_> {
        let [x, y, z] = v;
        RowMut { x, y, z }
    }

    /// Computes the springs of row `j` of `x` (the `right` ones if `with_right`, the others if
    /// a next row exists).
    pub fn compute(&mut self, c: &SpringConsts, x: &Soa, j: usize, with_right: bool) {
        let (nx, nz) = (c.nx, c.nz);
        let here = row(x, nx, j);
        let m = nx - 1;
        if with_right {
            spring_forces(
                &mut Self::out(&mut self.right),
                here.slice(0, m),
                here.slice(1, m),
                c.structural,
                c.rest_x,
            );
        }
        if j + 1 < nz {
            let next = row(x, nx, j + 1);
            spring_forces(
                &mut Self::out(&mut self.down),
                here,
                next,
                c.structural,
                c.rest_z,
            );
            spring_forces(
                &mut Self::out(&mut self.diag),
                here.slice(0, m),
                next.slice(1, m),
                c.shear,
                c.rest_diag,
            );
            spring_forces(
                &mut Self::out(&mut self.anti),
                here.slice(1, m),
                next.slice(0, m),
                c.shear,
                c.rest_diag,
            );
        }
    }
}

/// Adds the spring forces of row `j` (of `nz` rows) to `force`: as the start of this row's
/// springs (`cur`), then as the end of the springs of this row (to the left) and of the
/// previous row (`prv`). Interior particles (the common case) sum all eight in one loop; border
/// rows and columns add the terms they have one by one.
#[inline(always)]
pub(crate) fn add_row(
    force: &mut RowMut<'_>,
    cur: &RowSprings,
    prv: &RowSprings,
    j: usize,
    nx: usize,
    nz: usize,
) {
    if j > 0 && j + 1 < nz && nx > 2 {
        add_interior(force, cur, prv);
        for i in [0, nx - 1] {
            add_at(force, cur, prv, i, nx, true, true);
        }
    } else {
        for i in 0..nx {
            add_at(force, cur, prv, i, nx, j + 1 < nz, j > 0);
        }
    }
}

/// Adds the eight spring forces of every interior particle `1..nx-1` of a row in one pass.
#[inline(always)]
fn add_interior(f: &mut RowMut<'_>, cur: &RowSprings, prv: &RowSprings) {
    let n = f.x.len() - 2;
    for c in 0..3 {
        let out = match c {
            0 => &mut f.x[1..=n],
            1 => &mut f.y[1..=n],
            _ => &mut f.z[1..=n],
        };
        // Particle i = k + 1: start of right[i], down[i], diag[i], anti[i-1]; end of
        // right[i-1], prev down[i], prev diag[i-1], prev anti[i].
        let (r0, r1) = (&cur.right[c][1..=n], &cur.right[c][..n]);
        let (d, e, w) = (&cur.down[c][1..=n], &cur.diag[c][1..=n], &cur.anti[c][..n]);
        let (pd, pe, pw) = (&prv.down[c][1..=n], &prv.diag[c][..n], &prv.anti[c][1..=n]);
        for k in 0..n {
            out[k] += ((r0[k] - r1[k]) + (d[k] + e[k] + w[k])) - (pd[k] + pe[k] + pw[k]);
        }
    }
}

/// Adds the spring forces of particle `i` of a row, one term at a time: the springs to the
/// next row if `next`, from the previous row if `previous`, and those along the row.
fn add_at(
    f: &mut RowMut<'_>,
    cur: &RowSprings,
    prv: &RowSprings,
    i: usize,
    nx: usize,
    next: bool,
    previous: bool,
) {
    let mut acc = [0.0 as Real; 3];
    for (c, a) in acc.iter_mut().enumerate() {
        if i + 1 < nx {
            *a += cur.right[c][i];
        }
        if i > 0 {
            *a -= cur.right[c][i - 1];
        }
        if next {
            *a += cur.down[c][i];
            if i + 1 < nx {
                *a += cur.diag[c][i];
            }
            if i > 0 {
                *a += cur.anti[c][i - 1];
            }
        }
        if previous {
            *a -= prv.down[c][i];
            if i > 0 {
                *a -= prv.diag[c][i - 1];
            }
            if i + 1 < nx {
                *a -= prv.anti[c][i];
            }
        }
    }
    f.x[i] += acc[0];
    f.y[i] += acc[1];
    f.z[i] += acc[2];
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

    /// The row loop gives every particle the sum of its eight springs, as [`spring_force`]
    /// over the stencil does, on a crumpled grid (border rows and columns included).
    #[test]
    fn row_loop_sums_the_stencil() {
        use crate::model::{Grid, STENCIL};
        let grid = Grid::new(&crate::params::ClothParams {
            resolution: [6, 5],
            ..Default::default()
        });
        let mut p = grid.rest_positions(Vec3::ZERO);
        for k in 0..grid.len() {
            let s = k as Real;
            p.x[k] += 0.004 * (1.1 * s).sin();
            p.y[k] += 0.01 * (0.7 * s).cos();
        }
        let c = SpringConsts {
            nx: grid.nx,
            nz: grid.nz,
            structural: 500.0,
            shear: 125.0,
            rest_x: grid.dx,
            rest_z: grid.dz,
            rest_diag: grid.dx.hypot(grid.dz),
        };
        let (mut cur, mut prv) = (RowSprings::new(grid.nx), RowSprings::new(grid.nx));
        for j in 0..grid.nz {
            cur.compute(&c, &p, j, true);
            let (mut fx, mut fy, mut fz) =
                (vec![0.0; grid.nx], vec![0.0; grid.nx], vec![0.0; grid.nx]);
            let mut f = RowMut {
                x: &mut fx,
                y: &mut fy,
                z: &mut fz,
            };
            add_row(&mut f, &cur, &prv, j, grid.nx, grid.nz);
            for i in 0..grid.nx {
                let k = grid.index(i, j);
                let mut expect = Vec3::ZERO;
                for n in STENCIL {
                    let (a, b) = (i as isize + n.di, j as isize + n.dj);
                    if a < 0 || b < 0 || a >= grid.nx as isize || b >= grid.nz as isize {
                        continue;
                    }
                    let o = grid.index(a as usize, b as usize);
                    let k_n = if n.structural { c.structural } else { c.shear };
                    expect += spring_force(p.get(k), p.get(o), k_n, grid.rest_length(n));
                }
                let got = Vec3::new(fx[i], fy[i], fz[i]);
                assert!(
                    (got - expect).length() < 1e-12,
                    "({i}, {j}): {got} vs {expect}"
                );
            }
            std::mem::swap(&mut cur, &mut prv);
        }
    }
}
