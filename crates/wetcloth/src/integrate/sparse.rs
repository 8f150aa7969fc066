//! The implicit integrator's system on a cloth of any shape: a block-sparse symmetric matrix
//! (3 x 3 blocks in CSR form, one row of blocks per particle) and two preconditioners for its
//! conjugate gradient, block-Jacobi and smoothed-free aggregation multigrid on the vertex graph.
//!
//! The grid's system keeps its stencil form (`implicit/matrix.rs`) and its geometric multigrid;
//! a mesh has no rows of neighbours, so its matrix stores each block where the springs put it.
//! Every product is a gather per row in column order (no scattered sums), so the result does
//! not depend on how rows are split between threads.
//!
//! Aggregation multigrid: the particles are grouped into aggregates (a particle and its
//! not-yet-grouped neighbours, greedily in index order; leftovers join a neighbouring
//! aggregate), the coarse matrix is the Galerkin product `P^T A P` with the piecewise-constant
//! prolongation `P` (each particle's block of the identity into its aggregate), levels repeat
//! until a few hundred particles remain, and the coarsest level is solved by symmetric block
//! Gauss-Seidel sweeps. A V-cycle smooths with a forward block Gauss-Seidel sweep before the
//! coarse correction and a backward one after it, so it is symmetric, as the conjugate gradient
//! needs.

use crate::math::{Real, Soa, Vec3};
use glam::DMat3;
use rayon::prelude::*;

/// Rows per task when a product runs on the pool.
const ROWS_PER_TASK: usize = 1024;

/// A symmetric block-sparse matrix: row `i`'s blocks at `start[i]..start[i + 1]` of `col` and
/// `val`, columns increasing, the diagonal at `diag[i]`.
#[derive(Clone, Debug, Default)]
pub(crate) struct BlockCsr {
    pub start: Vec<u32>,
    pub col: Vec<u32>,
    pub val: Vec<DMat3>,
    pub diag: Vec<u32>,
}

impl BlockCsr {
    /// The pattern of `n` rows with a block for every pair of `pairs` (both ways) and every
    /// diagonal; values zero.
    pub fn pattern(n: usize, pairs: impl Iterator<Item = [u32; 2]>) -> Self {
        let mut rows: Vec<Vec<u32>> = (0..n as u32).map(|i| vec![i]).collect();
        for [a, b] in pairs {
            if a != b {
                rows[a as usize].push(b);
                rows[b as usize].push(a);
            }
        }
        let mut start = Vec::with_capacity(n + 1);
        let mut col = Vec::new();
        let mut diag = Vec::with_capacity(n);
        start.push(0);
        for (i, mut r) in rows.into_iter().enumerate() {
            r.sort_unstable();
            r.dedup();
            let d = r.binary_search(&(i as u32)).unwrap_or(0);
            diag.push((col.len() + d) as u32);
            col.extend(r);
            start.push(col.len() as u32);
        }
        let val = vec![DMat3::ZERO; col.len()];
        Self {
            start,
            col,
            val,
            diag,
        }
    }

    /// Number of block rows.
    pub fn rows(&self) -> usize {
        self.diag.len()
    }

    /// Where block `(i, j)` is in `val`, if stored.
    pub fn find(&self, i: usize, j: usize) -> Option<usize> {
        let r = self.start[i] as usize..self.start[i + 1] as usize;
        self.col[r.clone()]
            .binary_search(&(j as u32))
            .ok()
            .map(|k| r.start + k)
    }

    /// Row `i` of `A x`.
    #[inline]
    pub fn row_times(&self, i: usize, x: &Soa) -> Vec3 {
        let mut y = Vec3::ZERO;
        for k in self.start[i] as usize..self.start[i + 1] as usize {
            y += self.val[k] * x.get(self.col[k] as usize);
        }
        y
    }

    /// `y = A x`, on the pool when `parallel`.
    pub fn mul(&self, x: &Soa, y: &mut Soa, parallel: bool) {
        let n = self.rows();
        if parallel && n > 2 * ROWS_PER_TASK {
            let (ys, zs) = (&mut y.y, &mut y.z);
            y.x.par_chunks_mut(ROWS_PER_TASK)
                .zip(ys.par_chunks_mut(ROWS_PER_TASK))
                .zip(zs.par_chunks_mut(ROWS_PER_TASK))
                .enumerate()
                .for_each(|(c, ((a, b), d))| {
                    for l in 0..a.len() {
                        let v = self.row_times(c * ROWS_PER_TASK + l, x);
                        (a[l], b[l], d[l]) = (v.x, v.y, v.z);
                    }
                });
        } else {
            for i in 0..n {
                y.set(i, self.row_times(i, x));
            }
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        (self.start.capacity() + self.col.capacity() + self.diag.capacity()) * 4
            + self.val.capacity() * std::mem::size_of::<DMat3>()
    }
}

/// Inverse of a symmetric positive block, or of its diagonal where it is singular.
fn invert(b: DMat3) -> DMat3 {
    let det = b.determinant();
    if det.is_finite() && det.abs() > 1e-300 {
        b.inverse()
    } else {
        // A singular block: its diagonal's inverse where it is positive, none where it is not
        // (a coarse aggregate of known particles only has no unknowns: a huge inverse there
        // would turn round-off into an infinite correction).
        let d = Vec3::new(b.x_axis.x, b.y_axis.y, b.z_axis.z);
        let inv = |v: Real| if v > 1e-300 { 1.0 / v } else { 0.0 };
        DMat3::from_diagonal(Vec3::new(inv(d.x), inv(d.y), inv(d.z)))
    }
}

/// A coarse level of the aggregation hierarchy: its matrix, its diagonal blocks' inverses,
/// and the fine level's map onto it.
#[derive(Clone, Debug, Default)]
struct Level {
    /// The coarse matrix (`P^T A P` of the finer level).
    a: BlockCsr,
    /// The aggregate (row of this level) each row of the finer level joins.
    aggregate: Vec<u32>,
    /// For each block of the finer level's matrix, where it adds in `a.val`.
    galerkin: Vec<u32>,
    /// Inverses of this level's diagonal blocks.
    inv_diag: Vec<DMat3>,
    /// Scratch: the restricted residual, the coarse correction, a product.
    res: Soa,
    x: Soa,
    ax: Soa,
}

/// The preconditioner of a mesh system: an aggregation multigrid V-cycle (block Gauss-Seidel
/// smoothing), or block-Jacobi alone. The hierarchy's pattern is built once from the matrix's
/// pattern ([`Preconditioner::setup`]); each step refreshes its values
/// ([`Preconditioner::refresh`]).
#[derive(Clone, Debug, Default)]
pub(crate) struct Preconditioner {
    /// Inverses of the finest matrix's diagonal blocks (zero for fixed rows).
    inv_diag: Vec<DMat3>,
    /// The coarse levels, finest first (none: block-Jacobi).
    levels: Vec<Level>,
    /// Scratch of the finest level: a product.
    ax: Soa,
}

/// Smallest level aggregated further.
const COARSEST: usize = 200;

/// Greedy aggregation of the graph of `a`: returns each row's aggregate and the count.
fn aggregate(a: &BlockCsr) -> (Vec<u32>, usize) {
    let n = a.rows();
    const NONE: u32 = u32::MAX;
    let mut agg = vec![NONE; n];
    let mut count = 0u32;
    // Seeds: a row none of whose neighbours is aggregated yet takes them all.
    for i in 0..n {
        if agg[i] != NONE {
            continue;
        }
        let r = a.start[i] as usize..a.start[i + 1] as usize;
        if a.col[r.clone()].iter().all(|&j| agg[j as usize] == NONE) {
            for &j in &a.col[r] {
                agg[j as usize] = count;
            }
            count += 1;
        }
    }
    // Leftovers join a neighbour's aggregate (the first in column order), or start their own.
    for i in 0..n {
        if agg[i] != NONE {
            continue;
        }
        let r = a.start[i] as usize..a.start[i + 1] as usize;
        match a.col[r]
            .iter()
            .map(|&j| agg[j as usize])
            .find(|&g| g != NONE)
        {
            Some(g) => agg[i] = g,
            None => {
                agg[i] = count;
                count += 1;
            }
        }
    }
    (agg, count as usize)
}

/// The pattern of the Galerkin coarse matrix of piecewise-constant aggregation `agg` (`m`
/// aggregates) of `a`, and where each block of `a` adds in it.
fn coarse_pattern(a: &BlockCsr, agg: &[u32], m: usize) -> (BlockCsr, Vec<u32>) {
    let n = a.rows();
    let mut pairs = Vec::new();
    for i in 0..n {
        for k in a.start[i] as usize..a.start[i + 1] as usize {
            let (p, q) = (agg[i], agg[a.col[k] as usize]);
            if p < q {
                pairs.push([p, q]);
            }
        }
    }
    let c = BlockCsr::pattern(m, pairs.into_iter());
    let mut galerkin = vec![0u32; a.col.len()];
    for i in 0..n {
        let p = agg[i] as usize;
        for k in a.start[i] as usize..a.start[i + 1] as usize {
            let q = agg[a.col[k] as usize] as usize;
            galerkin[k] = c.find(p, q).unwrap_or(0) as u32;
        }
    }
    (c, galerkin)
}

/// One block Gauss-Seidel sweep over the rows, forward or backward: each row's residual with
/// the rows already swept, `x_i += D_i^-1 r_i`. A forward sweep before the coarse correction and
/// a backward one after keep the V-cycle symmetric (the conjugate gradient needs that).
fn gauss_seidel(a: &BlockCsr, inv_diag: &[DMat3], b: &Soa, x: &mut Soa, forward: bool) {
    let n = b.len();
    let mut row = |i: usize| {
        let mut r = b.get(i);
        for k in a.start[i] as usize..a.start[i + 1] as usize {
            r -= a.val[k] * x.get(a.col[k] as usize);
        }
        x.set(i, x.get(i) + inv_diag[i] * r);
    };
    if forward {
        (0..n).for_each(&mut row);
    } else {
        (0..n).rev().for_each(&mut row);
    }
}

impl Preconditioner {
    /// The hierarchy of the matrix pattern `a` (`multigrid`), or block-Jacobi alone.
    pub fn setup(&mut self, a: &BlockCsr, multigrid: bool) {
        self.levels.clear();
        self.inv_diag = vec![DMat3::ZERO; a.rows()];
        self.ax = Soa::zeros(a.rows());
        if !multigrid {
            return;
        }
        let mut fine = a.clone();
        while fine.rows() > COARSEST {
            let (agg, m) = aggregate(&fine);
            if m * 10 > fine.rows() * 9 {
                break;
            }
            let (c, galerkin) = coarse_pattern(&fine, &agg, m);
            self.levels.push(Level {
                a: c.clone(),
                aggregate: agg,
                galerkin,
                inv_diag: vec![DMat3::ZERO; m],
                res: Soa::zeros(m),
                x: Soa::zeros(m),
                ax: Soa::zeros(m),
            });
            fine = c;
        }
    }

    /// The values of the matrix `a` (of the pattern [`Preconditioner::setup`] took), its rows
    /// marked `fixed` known (left out of every level).
    pub fn refresh(&mut self, a: &BlockCsr, fixed: &[bool]) {
        for i in 0..a.rows() {
            self.inv_diag[i] = if fixed[i] {
                DMat3::ZERO
            } else {
                invert(a.val[a.diag[i] as usize])
            };
        }
        for l in 0..self.levels.len() {
            let (done, rest) = self.levels.split_at_mut(l);
            let level = &mut rest[0];
            for v in &mut level.a.val {
                *v = DMat3::ZERO;
            }
            let fine = if l == 0 { a } else { &done[l - 1].a };
            for i in 0..fine.rows() {
                if l == 0 && fixed[i] {
                    continue;
                }
                for k in fine.start[i] as usize..fine.start[i + 1] as usize {
                    if l == 0 && fixed[fine.col[k] as usize] {
                        continue;
                    }
                    level.a.val[level.galerkin[k] as usize] += fine.val[k];
                }
            }
            for i in 0..level.a.rows() {
                level.inv_diag[i] = invert(level.a.val[level.a.diag[i] as usize]);
            }
        }
    }

    /// `z = M^-1 r` for the matrix `a` of the last refresh.
    pub fn apply(&mut self, a: &BlockCsr, r: &Soa, z: &mut Soa) {
        if self.levels.is_empty() {
            for i in 0..r.len() {
                z.set(i, self.inv_diag[i] * r.get(i));
            }
            return;
        }
        let mut ax = std::mem::take(&mut self.ax);
        let inv = std::mem::take(&mut self.inv_diag);
        self.cycle(0, a, &inv, r, z, &mut ax);
        self.inv_diag = inv;
        self.ax = ax;
    }

    /// A V-cycle on the level whose matrix is `a` (inverse diagonal `inv`), right-hand side
    /// `b`, into `x`; `levels[l]` is the next coarser level.
    fn cycle(&mut self, l: usize, a: &BlockCsr, inv: &[DMat3], b: &Soa, x: &mut Soa, ax: &mut Soa) {
        let n = b.len();
        // Pre-smooth from zero: a forward Gauss-Seidel sweep.
        for v in [&mut x.x, &mut x.y, &mut x.z] {
            v.fill(0.0);
        }
        gauss_seidel(a, inv, b, x, true);
        if l < self.levels.len() {
            a.mul(x, ax, false);
            let mut level = std::mem::take(&mut self.levels[l]);
            for v in [&mut level.res.x, &mut level.res.y, &mut level.res.z] {
                v.fill(0.0);
            }
            for i in 0..n {
                let g = level.aggregate[i] as usize;
                level.res.set(g, level.res.get(g) + (b.get(i) - ax.get(i)));
            }
            let (coarse_a, coarse_inv) = (
                std::mem::take(&mut level.a),
                std::mem::take(&mut level.inv_diag),
            );
            let (res, mut cx, mut cax) = (
                std::mem::take(&mut level.res),
                std::mem::take(&mut level.x),
                std::mem::take(&mut level.ax),
            );
            self.cycle(l + 1, &coarse_a, &coarse_inv, &res, &mut cx, &mut cax);
            for i in 0..n {
                let g = level.aggregate[i] as usize;
                x.set(i, x.get(i) + cx.get(g));
            }
            level.a = coarse_a;
            level.inv_diag = coarse_inv;
            level.res = res;
            level.x = cx;
            level.ax = cax;
            self.levels[l] = level;
        } else {
            // The coarsest level: symmetric sweeps.
            for _ in 0..3 {
                gauss_seidel(a, inv, b, x, false);
                gauss_seidel(a, inv, b, x, true);
            }
        }
        // Post-smooth: the backward sweep.
        gauss_seidel(a, inv, b, x, false);
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.inv_diag.capacity() * std::mem::size_of::<DMat3>()
            + self.ax.heap_bytes()
            + self
                .levels
                .iter()
                .map(|l| {
                    l.a.heap_bytes()
                        + l.inv_diag.capacity() * std::mem::size_of::<DMat3>()
                        + (l.aggregate.capacity() + l.galerkin.capacity()) * 4
                        + l.res.heap_bytes()
                        + l.x.heap_bytes()
                        + l.ax.heap_bytes()
                })
                .sum::<usize>()
    }
}

/// `a . b` over the rows not `fixed`, summed in row order.
pub(crate) fn dot(a: &Soa, b: &Soa, fixed: &[bool]) -> Real {
    let mut s = 0.0;
    for i in 0..a.len() {
        if !fixed[i] {
            s += a.get(i).dot(b.get(i));
        }
    }
    s
}

/// The conjugate gradient's vectors, kept between solves.
#[derive(Clone, Debug, Default)]
pub(crate) struct CgScratch {
    r: Soa,
    z: Soa,
    p: Soa,
    ap: Soa,
}

impl CgScratch {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.r.heap_bytes() + self.z.heap_bytes() + self.p.heap_bytes() + self.ap.heap_bytes()
    }
}

/// Solves `A x = b` for the rows not `fixed` (their `x` must be zero: their columns are the
/// caller's, moved to `b`; their residual is ignored) by the preconditioned conjugate gradient,
/// from the `x` given, to a residual of `tolerance` times the right-hand side's norm or
/// `max_iterations`. Returns the iterations taken.
///
/// A row with a non-zero unit vector in `normals` (empty: none) is constrained along it
/// (Baraff and Witkin's filter `I - n n^T`): its `x` must have no part along it (the part the
/// constraint fixes is the caller's, its columns moved to `b`), and the solve leaves that part
/// and its residual out.
#[allow(clippy::too_many_arguments)] // the system, its unknowns and the CG's scratch
pub(crate) fn pcg(
    a: &BlockCsr,
    pre: &mut Preconditioner,
    b: &Soa,
    x: &mut Soa,
    fixed: &[bool],
    normals: &[Vec3],
    tolerance: Real,
    max_iterations: usize,
    parallel: bool,
    scratch: &mut CgScratch,
) -> usize {
    let n = b.len();
    let CgScratch { r, z, p, ap } = scratch;
    for v in [&mut *r, &mut *z, &mut *p, &mut *ap] {
        if v.len() != n {
            *v = Soa::zeros(n);
        }
    }
    let mask = |v: &mut Soa| {
        for i in 0..n {
            if fixed[i] {
                v.set(i, Vec3::ZERO);
            }
        }
        for (i, &m) in normals.iter().enumerate() {
            if m != Vec3::ZERO {
                let p = v.get(i);
                v.set(i, p - m * m.dot(p));
            }
        }
    };
    a.mul(x, ap, parallel);
    for i in 0..n {
        r.set(
            i,
            if fixed[i] {
                Vec3::ZERO
            } else {
                b.get(i) - ap.get(i)
            },
        );
    }
    mask(r);
    let norm_b = if normals.is_empty() {
        dot(b, b, fixed).sqrt().max(1e-300)
    } else {
        let mut fb = std::mem::take(z);
        fb.clone_from(b);
        mask(&mut fb);
        let norm = dot(&fb, &fb, fixed).sqrt().max(1e-300);
        *z = fb;
        norm
    };
    if dot(r, r, fixed).sqrt() <= tolerance * norm_b {
        return 0;
    }
    pre.apply(a, r, z);
    mask(z);
    p.clone_from(z);
    let mut rz = dot(r, z, fixed);
    for it in 1..=max_iterations {
        a.mul(p, ap, parallel);
        mask(ap);
        let pap = dot(p, ap, fixed);
        if pap.is_nan() || pap <= 0.0 {
            return it;
        }
        let alpha = rz / pap;
        for i in 0..n {
            x.set(i, x.get(i) + p.get(i) * alpha);
            r.set(i, r.get(i) - ap.get(i) * alpha);
        }
        if dot(r, r, fixed).sqrt() <= tolerance * norm_b {
            return it;
        }
        pre.apply(a, r, z);
        mask(z);
        let rz_new = dot(r, z, fixed);
        let beta = rz_new / rz;
        rz = rz_new;
        for i in 0..n {
            p.set(i, z.get(i) + p.get(i) * beta);
        }
    }
    max_iterations
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1-D chain of springs with masses: both preconditioners solve it to the tolerance, and
    /// the multigrid in fewer iterations than block-Jacobi.
    #[test]
    fn both_preconditioners_solve_a_stiff_chain() {
        let n = 2000;
        let pairs = (0..n as u32 - 1).map(|i| [i, i + 1]);
        let mut a = BlockCsr::pattern(n, pairs);
        let (m, k) = (1e-3, 1e3 * 1e-4);
        for i in 0..n {
            for s in a.start[i] as usize..a.start[i + 1] as usize {
                let j = a.col[s] as usize;
                a.val[s] = if i == j {
                    let deg = if i == 0 || i == n - 1 { 1.0 } else { 2.0 };
                    DMat3::from_diagonal(Vec3::splat(m + k * deg))
                } else {
                    DMat3::from_diagonal(Vec3::splat(-k))
                };
            }
        }
        let fixed = vec![false; n];
        let mut b = Soa::zeros(n);
        for i in 0..n {
            b.set(i, Vec3::new(1.0, -2.0, (i % 7) as Real));
        }
        let mut iters = [0; 2];
        for (slot, mg) in [false, true].into_iter().enumerate() {
            let mut pre = Preconditioner::default();
            pre.setup(&a, mg);
            pre.refresh(&a, &fixed);
            let mut x = Soa::zeros(n);
            let mut scratch = CgScratch::default();
            iters[slot] = pcg(
                &a,
                &mut pre,
                &b,
                &mut x,
                &fixed,
                &[],
                1e-10,
                5000,
                false,
                &mut scratch,
            );
            let mut ax = Soa::zeros(n);
            a.mul(&x, &mut ax, false);
            let mut err: Real = 0.0;
            for i in 0..n {
                err = err.max((ax.get(i) - b.get(i)).length());
            }
            assert!(err < 1e-7, "multigrid {mg}: residual {err}");
        }
        assert!(iters[1] < iters[0], "iterations {iters:?}");
    }
}
