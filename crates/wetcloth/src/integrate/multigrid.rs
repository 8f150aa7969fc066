//! A geometric multigrid V-cycle on the cloth's grid: the implicit integrator's preconditioner.
//!
//! The implicit step's matrix couples each particle to its 8 grid neighbours through 3 x 3
//! blocks (the linearised springs, eq. 3.6), so it is a block 9-point stencil on the `nx` x
//! `nz` grid. Its stiffness relative to the mass, `dt^2 k / m`, is 4e4 on the thesis' cloth at
//! 1/120 s: smooth stretching modes then converge slowly under a diagonal preconditioner
//! (hundreds of iterations a solve). A V-cycle removes them on coarser grids.
//!
//! - **Coarse grids.** Every other node in each direction (`n` nodes become `ceil(n / 2)`),
//!   until both sides have at most [`COARSEST_SIDE`] nodes. Interpolation is bilinear (the
//!   coarse nodes are the even fine ones and the last one; linear in between, so that rigid
//!   rotations are represented exactly), restriction its transpose,
//!   and each coarse matrix the Galerkin product `P^T A P`, which is again a block 9-point
//!   stencil: no geometry is needed below the finest grid, and every coarse matrix is
//!   symmetric positive definite when the fine one is.
//! - **Smoother.** Block Gauss-Seidel (each node's 3 x 3 block solved exactly), one sweep
//!   forwards before the coarse correction and one backwards after it, so the cycle is a
//!   symmetric operator and a valid conjugate-gradient preconditioner.
//! - **Coarsest grid.** Solved exactly by a dense Cholesky factorisation (at most 48 unknowns).
//!
//! Everything runs in node order on one thread: the same bits for any thread count. The cycle
//! runs in single precision (SIMD lanes of four; its result only preconditions a solve carried
//! out in double).

use crate::math::{Real, Vec3};
use glam::{DMat3, Mat3A as Mat3, Vec3A as Vec3f};

/// Largest side, in nodes, of the coarsest grid (solved directly).
pub const COARSEST_SIDE: usize = 4;

/// Stencil slot of the neighbour at grid offset `(di, dj)`, each in `-1..=1`.
#[inline(always)]
pub const fn slot(di: isize, dj: isize) -> usize {
    ((dj + 1) * 3 + (di + 1)) as usize
}

/// The centre slot (the node's own block).
pub const CENTRE: usize = slot(0, 0);

/// The neighbours of node `(i, j)` of an `nx` x `nz` grid (not the node itself): each one's
/// stencil slot and node index, in node order.
pub(crate) fn neighbours(
    i: usize,
    j: usize,
    nx: usize,
    nz: usize,
) -> impl Iterator<Item = (usize, usize)> {
    (-1isize..=1).flat_map(move |dj| {
        (-1isize..=1).filter_map(move |di| {
            let (ii, jj) = (i as isize + di, j as isize + dj);
            let inside = ii >= 0 && jj >= 0 && ii < nx as isize && jj < nz as isize;
            (inside && (di, dj) != (0, 0)).then(|| (slot(di, dj), jj as usize * nx + ii as usize))
        })
    })
}

/// One grid's matrix and work vectors.
///
/// The matrix is built in double precision (`a`, all 9 blocks of a node) and cycled in single
/// precision, stored once per pair of neighbours: each node's own block, its inverse and its
/// blocks to the four neighbours after it in node order (an earlier neighbour's block is the
/// transpose of that neighbour's block to this node, the matrix being symmetric). That is 216
/// bytes a node instead of 720, so a 50 x 50 grid's cycle reads its matrix from the core's
/// own cache instead of the shared one.
#[derive(Clone, Debug, Default)]
struct Level {
    nx: usize,
    nz: usize,
    /// Per node, its 9 blocks: `a[node][slot(di, dj)]` couples it to node `(i + di, j + dj)`.
    a: Vec<[DMat3; 9]>,
    /// Own block, in single precision.
    diag: Vec<Mat3>,
    /// Inverse of each node's own block.
    inv: Vec<Mat3>,
    /// Blocks to the later neighbours, [`LATER`] order.
    later: Vec<[Mat3; 4]>,
    /// Solution, right-hand side and residual.
    x: Vec<Vec3f>,
    b: Vec<Vec3f>,
    r: Vec<Vec3f>,
}

/// The four neighbours after a node in node order, as grid offsets `(di, dj)`: the blocks
/// [`Level::later`] keeps.
const LATER: [(isize, isize); 4] = [(1, 0), (-1, 1), (0, 1), (1, 1)];

/// `M^T v`.
#[inline(always)]
fn transpose_mul(m: &Mat3, v: Vec3f) -> Vec3f {
    Vec3f::new(m.x_axis.dot(v), m.y_axis.dot(v), m.z_axis.dot(v))
}

impl Level {
    fn resize(&mut self, nx: usize, nz: usize) {
        let n = nx * nz;
        self.nx = nx;
        self.nz = nz;
        self.a.clear();
        self.a.resize(n, [DMat3::ZERO; 9]);
        self.diag.resize(n, Mat3::IDENTITY);
        self.inv.resize(n, Mat3::IDENTITY);
        self.later.resize(n, [Mat3::ZERO; 4]);
        self.x.resize(n, Vec3f::ZERO);
        self.b.resize(n, Vec3f::ZERO);
        self.r.resize(n, Vec3f::ZERO);
    }

    /// The single-precision copy the cycle reads (after `a` and its inverses are final).
    fn compact(&mut self) {
        let nx = self.nx;
        for (k, blocks) in self.a.iter().enumerate() {
            self.diag[k] = Mat3::from(blocks[CENTRE].as_mat3());
            let (i, j) = (k % nx, k / nx);
            for (t, &(di, dj)) in LATER.iter().enumerate() {
                let inside = i as isize + di >= 0 && (i as isize + di) < nx as isize;
                let inside = inside && j as isize + dj < self.nz as isize;
                self.later[k][t] = if inside {
                    Mat3::from(blocks[slot(di, dj)].as_mat3())
                } else {
                    Mat3::ZERO
                };
            }
        }
    }

    /// The matrices, read-only, beside the vectors the sweeps write.
    fn split(&mut self) -> (Mats<'_>, &mut [Vec3f], &[Vec3f], &mut [Vec3f]) {
        let m = Mats {
            nx: self.nx,
            diag: &self.diag,
            inv: &self.inv,
            later: &self.later,
        };
        (m, &mut self.x, &self.b, &mut self.r)
    }

    /// A forward Gauss-Seidel sweep from `x = 0` and the residual `r = b - A x` after it: a
    /// node's later neighbours are still zero when it is solved, so the sweep needs only its
    /// earlier ones, and the residual only its later ones (half a stencil each).
    fn smooth_from_zero(&mut self) {
        let (m, x, b, r) = self.split();
        forward_from_zero(&m, x, b, r);
        residual(&m, x, r);
    }

    /// One backward Gauss-Seidel sweep.
    fn sweep_backwards(&mut self) {
        let (m, x, b, _) = self.split();
        backward(&m, x, b);
    }
}

/// A level's matrices, read-only, for sweeps over slices of its rows.
#[derive(Clone, Copy)]
struct Mats<'a> {
    nx: usize,
    diag: &'a [Mat3],
    inv: &'a [Mat3],
    later: &'a [[Mat3; 4]],
}

impl<'a> Mats<'a> {
    /// `A_ab x_b` for the neighbour `b = a - 1`.
    #[inline(always)]
    fn left(&self, a: usize, x: Vec3f) -> Vec3f {
        transpose_mul(&self.later[a - 1][0], x)
    }

    /// `A_ab x_b` for the neighbour `b = a + 1`.
    #[inline(always)]
    fn right(&self, a: usize, x: Vec3f) -> Vec3f {
        self.later[a][0] * x
    }

    /// `sum of A_ab x_b` over node `a`'s (up to three) neighbours in the row above, whose
    /// values are `up` (that row).
    #[inline(always)]
    fn up(&self, a: usize, up: &[Vec3f]) -> Vec3f {
        let (nx, i) = (self.nx, a % self.nx);
        let above = |b: usize| b + a - nx - i;
        let mut s = transpose_mul(&self.later[above(i)][2], up[i]);
        if i > 0 {
            s += transpose_mul(&self.later[above(i - 1)][3], up[i - 1]);
        }
        if i + 1 < nx {
            s += transpose_mul(&self.later[above(i + 1)][1], up[i + 1]);
        }
        s
    }

    /// `sum of A_ab x_b` over node `a`'s neighbours in the row below, whose values are
    /// `down` (that row).
    #[inline(always)]
    fn down(&self, a: usize, down: &[Vec3f]) -> Vec3f {
        let (l, i) = (&self.later[a], a % self.nx);
        let mut s = l[2] * down[i];
        if i > 0 {
            s += l[1] * down[i - 1];
        }
        if i + 1 < self.nx {
            s += l[3] * down[i + 1];
        }
        s
    }
}

/// Forward Gauss-Seidel from `x = 0`, keeping `b - (earlier neighbours' share)` in `r`.
fn forward_from_zero(m: &Mats<'_>, x: &mut [Vec3f], b: &[Vec3f], r: &mut [Vec3f]) {
    let nx = m.nx;
    for j in 0..x.len() / nx {
        let (done, row) = x.split_at_mut(j * nx);
        let row = &mut row[..nx];
        let up = (j > 0).then(|| &done[(j - 1) * nx..]);
        for i in 0..nx {
            let a = j * nx + i;
            let mut t = b[a];
            if let Some(up) = up {
                t -= m.up(a, up);
            }
            if i > 0 {
                t -= m.left(a, row[i - 1]);
            }
            row[i] = m.inv[a] * t;
            r[a] = t;
        }
    }
}

/// `r -= D x + (later neighbours' share)`: a node's later neighbours are its right one and the
/// row below.
fn residual(m: &Mats<'_>, x: &[Vec3f], r: &mut [Vec3f]) {
    let nx = m.nx;
    let rows = x.len() / nx;
    for j in 0..rows {
        let down = (j + 1 < rows).then(|| &x[(j + 1) * nx..]);
        for i in 0..nx {
            let a = j * nx + i;
            let mut t = m.diag[a] * x[a];
            if i + 1 < nx {
                t += m.right(a, x[a + 1]);
            }
            if let Some(down) = down {
                t += m.down(a, down);
            }
            r[a] -= t;
        }
    }
}

/// Backward Gauss-Seidel, last node to first, over the whole stencil.
fn backward(m: &Mats<'_>, x: &mut [Vec3f], b: &[Vec3f]) {
    let nx = m.nx;
    let rows = x.len() / nx;
    for j in (0..rows).rev() {
        let (before, rest) = x.split_at_mut(j * nx);
        let (row, after) = rest.split_at_mut(nx);
        let up = (j > 0).then(|| &before[(j - 1) * nx..]);
        let down = (j + 1 < rows).then_some(&after[..]);
        for i in (0..nx).rev() {
            let a = j * nx + i;
            let mut t = b[a];
            if let Some(up) = up {
                t -= m.up(a, up);
            }
            if let Some(down) = down {
                t -= m.down(a, down);
            }
            if i > 0 {
                t -= m.left(a, row[i - 1]);
            }
            if i + 1 < nx {
                t -= m.right(a, row[i + 1]);
            }
            row[i] = m.inv[a] * t;
        }
    }
}

/// The coarse nodes (and weights) a fine node interpolates from, along one side of `n` fine
/// nodes, linearly: the coarse nodes are the even fine ones and the last one (on an even side
/// the last two coarse nodes are three apart instead of two), so every linear function, a
/// rigid rotation's displacement included, is represented exactly. A side of at most
/// [`COARSEST_SIDE`] nodes is not coarsened.
#[inline]
fn parents(i: usize, n: usize) -> ([(usize, Real); 2], usize) {
    const ONE: [(usize, Real); 2] = [(0, 1.0), (0, 0.0)];
    if n <= COARSEST_SIDE {
        return ([(i, 1.0), ONE[1]], 1);
    }
    let last = n.div_ceil(2) - 1;
    if n.is_multiple_of(2) && i + 3 >= n {
        // The last interval, fine nodes n - 4 .. n - 1.
        return match n - 1 - i {
            0 => ([(last, 1.0), ONE[1]], 1),
            1 => ([(last - 1, 1.0 / 3.0), (last, 2.0 / 3.0)], 2),
            _ => ([(last - 1, 2.0 / 3.0), (last, 1.0 / 3.0)], 2),
        };
    }
    if i.is_multiple_of(2) {
        ([(i / 2, 1.0), ONE[1]], 1)
    } else {
        ([(i / 2, 0.5), (i / 2 + 1, 0.5)], 2)
    }
}

/// Coarse side for `n` fine nodes.
#[inline]
fn coarse_side(n: usize) -> usize {
    if n <= COARSEST_SIDE { n } else { n.div_ceil(2) }
}

/// The multigrid hierarchy of one matrix.
#[derive(Clone, Debug, Default)]
pub(crate) struct Multigrid {
    levels: Vec<Level>,
    /// Dense Cholesky factor (lower, row-major) of the coarsest matrix, `m` x `m`.
    chol: Vec<Real>,
    m: usize,
    /// The coarsest solve's right-hand side and solution, flattened.
    y: Vec<Real>,
}

impl Multigrid {
    /// The finest grid's blocks, zeroed, for the caller to fill (`a[node][slot]`), for an
    /// `nx` x `nz` grid. Call [`Multigrid::build`] after.
    pub fn fine(&mut self, nx: usize, nz: usize) -> &mut [[DMat3; 9]] {
        if self.levels.is_empty() {
            self.levels.push(Level::default());
        }
        self.levels[0].resize(nx, nz);
        &mut self.levels[0].a
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.levels
            .iter()
            .map(|l| {
                l.a.capacity() * std::mem::size_of::<[DMat3; 9]>()
                    + (l.diag.capacity() + l.inv.capacity()) * std::mem::size_of::<Mat3>()
                    + l.later.capacity() * std::mem::size_of::<[Mat3; 4]>()
                    + (l.x.capacity() + l.b.capacity() + l.r.capacity())
                        * std::mem::size_of::<Vec3f>()
            })
            .sum::<usize>()
            + self.chol.capacity() * 8
    }

    /// Builds the coarse grids from the finest one's blocks, and factors the coarsest.
    pub fn build(&mut self) {
        let mut l = 0;
        loop {
            let (nx, nz) = (self.levels[l].nx, self.levels[l].nz);
            invert_diagonal(&mut self.levels[l]);
            self.levels[l].compact();
            if nx <= COARSEST_SIDE && nz <= COARSEST_SIDE {
                break;
            }
            if self.levels.len() == l + 1 {
                self.levels.push(Level::default());
            }
            let (fine, rest) = self.levels.split_at_mut(l + 1);
            galerkin(&fine[l], &mut rest[0]);
            l += 1;
        }
        self.levels.truncate(l + 1);
        self.factor_coarsest();
    }

    /// `x = V b`: one symmetric V-cycle from `x = 0`. `b` and `x` are per node of the finest
    /// grid.
    pub fn apply(&mut self, b: impl Fn(usize) -> Vec3, mut x: impl FnMut(usize, Vec3)) {
        let n = self.levels[0].nx * self.levels[0].nz;
        for a in 0..n {
            self.levels[0].b[a] = b(a).as_vec3().into();
        }
        self.cycle(0);
        for a in 0..n {
            x(a, self.levels[0].x[a].as_dvec3());
        }
    }

    fn cycle(&mut self, l: usize) {
        if l + 1 == self.levels.len() {
            self.solve_coarsest();
            return;
        }
        {
            let lv = &mut self.levels[l];
            lv.smooth_from_zero();
        }
        let (fine, rest) = self.levels.split_at_mut(l + 1);
        let (f, c) = (&fine[l], &mut rest[0]);
        // Restriction: b_c = P^T r.
        c.b.fill(Vec3f::ZERO);
        for j in 0..f.nz {
            let (pz, nzp) = parents(j, f.nz);
            for i in 0..f.nx {
                let (px, nxp) = parents(i, f.nx);
                let r = f.r[j * f.nx + i];
                for &(jc, wz) in &pz[..nzp] {
                    for &(ic, wx) in &px[..nxp] {
                        c.b[jc * c.nx + ic] += r * (wx * wz) as f32;
                    }
                }
            }
        }
        self.cycle(l + 1);
        let (fine, rest) = self.levels.split_at_mut(l + 1);
        let (f, c) = (&mut fine[l], &rest[0]);
        // Prolongation: x += P x_c.
        for j in 0..f.nz {
            let (pz, nzp) = parents(j, f.nz);
            for i in 0..f.nx {
                let (px, nxp) = parents(i, f.nx);
                let mut e = Vec3f::ZERO;
                for &(jc, wz) in &pz[..nzp] {
                    for &(ic, wx) in &px[..nxp] {
                        e += c.x[jc * c.nx + ic] * (wx * wz) as f32;
                    }
                }
                f.x[j * f.nx + i] += e;
            }
        }
        f.sweep_backwards();
    }

    fn factor_coarsest(&mut self) {
        let lv = self.levels.last().expect("built");
        let n = lv.nx * lv.nz;
        let m = 3 * n;
        self.m = m;
        self.chol.clear();
        self.chol.resize(m * m, 0.0);
        let c = &mut self.chol;
        // The dense matrix from the blocks.
        for a in 0..n {
            let (i, j) = (a % lv.nx, a / lv.nx);
            let own = std::iter::once((CENTRE, a));
            for (s, b) in own.chain(neighbours(i, j, lv.nx, lv.nz)) {
                let blk = lv.a[a][s];
                for r in 0..3 {
                    for t in 0..3 {
                        c[(3 * a + r) * m + 3 * b + t] = blk.col(t)[r];
                    }
                }
            }
        }
        cholesky(c, m);
    }

    fn solve_coarsest(&mut self) {
        let m = self.m;
        let lv = self.levels.last_mut().expect("built");
        let y = &mut self.y;
        y.clear();
        y.extend(lv.b.iter().flat_map(|b| b.as_dvec3().to_array()));
        cholesky_solve(&self.chol, m, y);
        for (a, x) in lv.x.iter_mut().enumerate() {
            *x = Vec3::new(y[3 * a], y[3 * a + 1], y[3 * a + 2])
                .as_vec3()
                .into();
        }
    }
}

/// In-place dense Cholesky factorisation (lower, row-major) of the `m` x `m` matrix `c`; a
/// pivot that is not positive is replaced by the diagonal's magnitude.
pub(crate) fn cholesky(c: &mut [Real], m: usize) {
    for k in 0..m {
        let mut d = c[k * m + k];
        for t in 0..k {
            d -= c[k * m + t] * c[k * m + t];
        }
        let scale = c[k * m + k].abs().max(Real::MIN_POSITIVE);
        let d = if d > 1e-14 * scale { d } else { scale }.sqrt();
        c[k * m + k] = d;
        for r in k + 1..m {
            let mut s = c[r * m + k];
            for t in 0..k {
                s -= c[r * m + t] * c[k * m + t];
            }
            c[r * m + k] = s / d;
        }
    }
}

/// Solves `L L^T y = b` in place, with `L` from [`cholesky`].
pub(crate) fn cholesky_solve(c: &[Real], m: usize, y: &mut [Real]) {
    for k in 0..m {
        let mut s = y[k];
        for t in 0..k {
            s -= c[k * m + t] * y[t];
        }
        y[k] = s / c[k * m + k];
    }
    for k in (0..m).rev() {
        let mut s = y[k];
        for t in k + 1..m {
            s -= c[t * m + k] * y[t];
        }
        y[k] = s / c[k * m + k];
    }
}

/// Inverts every node's own block (symmetric positive definite; a singular or non-finite one
/// falls back to its diagonal).
fn invert_diagonal(lv: &mut Level) {
    for (inv, blocks) in lv.inv.iter_mut().zip(&lv.a) {
        let d = blocks[CENTRE];
        let det = d.determinant();
        let scale = d.x_axis.x.abs() * d.y_axis.y.abs() * d.z_axis.z.abs();
        *inv = Mat3::from(
            (if det.is_finite() && det > 1e-12 * scale {
                d.inverse()
            } else {
                let safe = |v: Real| if v > 0.0 { 1.0 / v } else { 0.0 };
                DMat3::from_diagonal(Vec3::new(
                    safe(d.x_axis.x),
                    safe(d.y_axis.y),
                    safe(d.z_axis.z),
                ))
            })
            .as_mat3(),
        );
    }
}

/// `coarse = P^T fine P` (bilinear `P`).
fn galerkin(fine: &Level, coarse: &mut Level) {
    let (nx, nz) = (fine.nx, fine.nz);
    coarse.resize(coarse_side(nx), coarse_side(nz));
    let cnx = coarse.nx;
    for j in 0..nz {
        let (pzj, nzj) = parents(j, nz);
        for i in 0..nx {
            let (pxi, nxi) = parents(i, nx);
            let a = j * nx + i;
            for dj in -1isize..=1 {
                let jj = j as isize + dj;
                if jj < 0 || jj >= nz as isize {
                    continue;
                }
                let (pzb, nzb) = parents(jj as usize, nz);
                for di in -1isize..=1 {
                    let ii = i as isize + di;
                    if ii < 0 || ii >= nx as isize {
                        continue;
                    }
                    let blk = fine.a[a][slot(di, dj)];
                    if blk == DMat3::ZERO {
                        continue;
                    }
                    let (pxb, nxb) = parents(ii as usize, nx);
                    for &(ja, wza) in &pzj[..nzj] {
                        for &(ia, wxa) in &pxi[..nxi] {
                            let wa = wza * wxa;
                            let row = &mut coarse.a[ja * cnx + ia];
                            for &(jb, wzb) in &pzb[..nzb] {
                                for &(ib, wxb) in &pxb[..nxb] {
                                    let s =
                                        slot(ib as isize - ia as isize, jb as isize - ja as isize);
                                    row[s] += blk * (wa * wzb * wxb);
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block 9-point SPD matrix on an `nx` x `nz` grid: springs to the 8 neighbours with
    /// anisotropic 3 x 3 stiffness, plus a small mass on the diagonal.
    fn laplacian(mg: &mut Multigrid, nx: usize, nz: usize, mass: Real) -> Vec<[DMat3; 9]> {
        let a = mg.fine(nx, nz);
        let k = |di: isize, dj: isize| {
            let (di, dj) = (di as Real, dj as Real);
            // Odd in the offset, so that the blocks of a spring's two ends agree.
            let d = Vec3::new(di, 0.1 * di - 0.05 * dj, dj).normalize();
            DMat3::from_diagonal(Vec3::splat(0.05)) + DMat3::from_cols(d * d.x, d * d.y, d * d.z)
        };
        for j in 0..nz as isize {
            for i in 0..nx as isize {
                let node = (j as usize) * nx + i as usize;
                a[node][CENTRE] = DMat3::from_diagonal(Vec3::splat(mass));
                for dj in -1..=1 {
                    for di in -1..=1 {
                        let (ii, jj) = (i + di, j + dj);
                        if (di, dj) == (0, 0)
                            || ii < 0
                            || jj < 0
                            || ii >= nx as isize
                            || jj >= nz as isize
                        {
                            continue;
                        }
                        let s = k(di, dj);
                        a[node][CENTRE] += s;
                        a[node][slot(di, dj)] = -s;
                    }
                }
            }
        }
        a.to_vec()
    }

    fn multiply(a: &[[DMat3; 9]], nx: usize, nz: usize, x: &[Vec3]) -> Vec<Vec3> {
        let mut y = vec![Vec3::ZERO; nx * nz];
        for j in 0..nz as isize {
            for i in 0..nx as isize {
                let node = (j as usize) * nx + i as usize;
                for dj in -1..=1 {
                    for di in -1..=1 {
                        let (ii, jj) = (i + di, j + dj);
                        if ii < 0 || jj < 0 || ii >= nx as isize || jj >= nz as isize {
                            continue;
                        }
                        y[node] += a[node][slot(di, dj)] * x[jj as usize * nx + ii as usize];
                    }
                }
            }
        }
        y
    }

    /// Stationary iteration `x += V (b - A x)`: the V-cycle must contract the error by a factor
    /// independent of the grid's size (what makes it worth its cost), and the coarsest
    /// solve alone is exact.
    #[test]
    fn v_cycle_contracts_the_error_by_a_grid_independent_factor() {
        for (nx, nz) in [(4, 3), (17, 9), (33, 33), (65, 65), (50, 50), (101, 64)] {
            let mut mg = Multigrid::default();
            let a = laplacian(&mut mg, nx, nz, 1e-5);
            mg.build();
            let n = nx * nz;
            let truth: Vec<Vec3> = (0..n)
                .map(|k| Vec3::new((k as Real).sin(), (0.3 * k as Real).cos(), 1.0))
                .collect();
            let b = multiply(&a, nx, nz, &truth);
            let mut x = vec![Vec3::ZERO; n];
            let err = |x: &[Vec3]| {
                x.iter()
                    .zip(&truth)
                    .map(|(x, t)| (*x - *t).length_squared())
                    .sum::<Real>()
                    .sqrt()
            };
            let e0 = err(&x);
            let mut factor: Real = 0.0;
            let mut last = e0;
            for _ in 0..8 {
                let ax = multiply(&a, nx, nz, &x);
                let r: Vec<Vec3> = b.iter().zip(&ax).map(|(b, a)| *b - *a).collect();
                let mut dx = vec![Vec3::ZERO; n];
                mg.apply(|k| r[k], |k, v| dx[k] = v);
                for (x, d) in x.iter_mut().zip(&dx) {
                    *x += *d;
                }
                let e = err(&x);
                factor = factor.max(e / last);
                last = e;
            }
            if nx <= COARSEST_SIDE {
                assert!(last < 1e-9 * e0, "{nx}x{nz}: direct solve left {last}");
            } else {
                assert!(
                    factor < 0.5,
                    "{nx}x{nz}: error contraction {factor} per cycle"
                );
            }
        }
    }

    /// The V-cycle is symmetric: `u . V w = w . V u` (a conjugate-gradient preconditioner
    /// must be), to the single precision it runs in (a wrong sweep order or a restriction
    /// that is not the prolongation's transpose is off in the first digits).
    #[test]
    fn v_cycle_is_symmetric() {
        let (nx, nz) = (23, 12);
        let mut mg = Multigrid::default();
        laplacian(&mut mg, nx, nz, 1e-3);
        mg.build();
        let n = nx * nz;
        let u: Vec<Vec3> = (0..n)
            .map(|k| Vec3::new((k as Real).sin(), 1.0, (k as Real * 0.7).cos()))
            .collect();
        let w: Vec<Vec3> = (0..n)
            .map(|k| Vec3::new((k as Real * 1.3).cos(), -0.5, (k as Real).sin()))
            .collect();
        let mut vu = vec![Vec3::ZERO; n];
        let mut vw = vec![Vec3::ZERO; n];
        mg.apply(|k| u[k], |k, v| vu[k] = v);
        mg.apply(|k| w[k], |k, v| vw[k] = v);
        let a: Real = w.iter().zip(&vu).map(|(a, b)| a.dot(*b)).sum();
        let b: Real = u.iter().zip(&vw).map(|(a, b)| a.dot(*b)).sum();
        assert!((a - b).abs() <= 1e-5 * a.abs().max(b.abs()), "{a} vs {b}");
    }
}
