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
//! Gauss-Seidel sweeps. A V-cycle smooths with a forward block Gauss-Seidel sweep from zero
//! before the coarse correction (it reads only the lower blocks, and the residual after it is
//! the upper blocks' product alone) and a backward one after it, so it is symmetric, as the
//! conjugate gradient needs. The sweeps run over fixed blocks of rows side by side (Gauss-Seidel
//! inside a block, the other blocks' values from before the sweep): the same bits on any
//! thread count, and both cores at work.

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
    /// Inverses of this level's diagonal blocks.
    inv_diag: Vec<DMat3>,
    /// The aggregate (row of this level) each row of the finer level joins.
    aggregate: Vec<u32>,
    /// For each block of the finer level's matrix, where it adds in `a.val`.
    galerkin: Vec<u32>,
    /// Scratch: the restricted residual, the coarse correction, a sweep's.
    res: Vec<Vec3>,
    x: Vec<Vec3>,
    work: Vec<Vec3>,
}

/// The preconditioner of a mesh system: an aggregation multigrid V-cycle (block Gauss-Seidel
/// smoothing), or block-Jacobi alone. The hierarchy's pattern is built once from the matrix's
/// pattern ([`Preconditioner::setup`]); each step refreshes its values
/// ([`Preconditioner::refresh`]).
#[derive(Clone, Debug, Default)]
pub(crate) struct Preconditioner {
    /// Inverses of the finest matrix's diagonal blocks (zero for fixed rows).
    inv_diag: Vec<DMat3>,
    /// The finest level's rows left out (fixed).
    fixed: Vec<bool>,
    /// The coarse levels, finest first (none: block-Jacobi).
    levels: Vec<Level>,
    /// Scratch of the finest level's sweeps.
    work: Vec<Vec3>,
    /// The finest matrix as the solve sees it when some rows slide (`S A S` with each sliding
    /// row's filter `S = I - n n^T`, and its diagonal block's scale along `n`), the matrix the
    /// hierarchy is then built from; `None` when no row slides (the matrix itself).
    projected: Option<BlockCsr>,
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

/// Rows of a smoothing block: a sweep runs over blocks of this many consecutive rows (on the
/// pool when there is one), Gauss-Seidel within each block, each block taking the others'
/// values from before the sweep (Jacobi between blocks). The blocks are fixed, so the bits do
/// not depend on the thread count; a level of at most this many rows is swept exactly.
const SWEEP_ROWS: usize = 512;

/// `sum A_ik x_(k - offset)` over the blocks `lo..hi` of `a`'s storage, in two interleaved
/// sums (the blocks' products do not wait on one another).
#[inline(always)]
fn blocks_times(a: &BlockCsr, lo: usize, hi: usize, x: &[Vec3], offset: usize) -> Vec3 {
    let (mut y0, mut y1) = (Vec3::ZERO, Vec3::ZERO);
    let (val, col) = (&a.val[lo..hi], &a.col[lo..hi]);
    let pairs = val.len() / 2;
    for k in 0..pairs {
        y0 += val[2 * k] * x[col[2 * k] as usize - offset];
        y1 += val[2 * k + 1] * x[col[2 * k + 1] as usize - offset];
    }
    if val.len() % 2 == 1 {
        y0 += val[val.len() - 1] * x[col[col.len() - 1] as usize - offset];
    }
    y0 + y1
}

/// Where row `i`'s columns from `lo` on, and from `hi` on, start in `a`'s storage.
#[inline(always)]
fn split_row(a: &BlockCsr, i: usize, lo: usize, hi: usize) -> (usize, usize) {
    let s = a.start[i] as usize;
    let cols = &a.col[s..a.start[i + 1] as usize];
    (
        s + cols.partition_point(|&j| (j as usize) < lo),
        s + cols.partition_point(|&j| (j as usize) < hi),
    )
}

/// Runs `f(block, rows)` on each smoothing block of `x`, on the pool when `parallel`.
fn by_blocks(x: &mut [Vec3], parallel: bool, f: impl Fn(usize, &mut [Vec3]) + Sync) {
    let pooled = parallel && x.len() > SWEEP_ROWS;
    crate::exec::by_chunks(x, SWEEP_ROWS, pooled, f);
}

/// `x = (D + L_b)^-1 b`, `L_b` the lower blocks inside each smoothing block: a forward sweep
/// from zero (every other column is still zero).
fn forward_from_zero(a: &BlockCsr, inv: &[DMat3], b: &[Vec3], x: &mut [Vec3], parallel: bool) {
    by_blocks(x, parallel, |lo, xs| {
        for l in 0..xs.len() {
            let i = lo + l;
            let (p, _) = split_row(a, i, lo, lo);
            let r = b[i] - blocks_times(a, p, a.diag[i] as usize, xs, lo);
            xs[l] = inv[i] * r;
        }
    });
}

/// Row `i`'s residual `b_i - (A x)_i` after [`forward_from_zero`]: minus the blocks it did not
/// read (each row's own and lower in-block part it solved exactly).
#[inline]
fn residual_after_forward(a: &BlockCsr, i: usize, x: &[Vec3]) -> Vec3 {
    let lo = i / SWEEP_ROWS * SWEEP_ROWS;
    let (p, _) = split_row(a, i, lo, lo);
    -(blocks_times(a, a.start[i] as usize, p, x, 0)
        + blocks_times(a, a.diag[i] as usize + 1, a.start[i + 1] as usize, x, 0))
}

/// One block Gauss-Seidel sweep, forward or backward, in smoothing blocks: each row's residual
/// with the rows of its block already swept and the other blocks' values from before the sweep
/// (`old`, scratch), `x_i += D_i^-1 r_i`.
fn sweep(
    a: &BlockCsr,
    inv: &[DMat3],
    b: &[Vec3],
    x: &mut [Vec3],
    old: &mut Vec<Vec3>,
    forward: bool,
    parallel: bool,
) {
    if x.len() > SWEEP_ROWS {
        old.clear();
        old.extend_from_slice(x);
    }
    let old = &old[..];
    by_blocks(x, parallel, |lo, xs| {
        let hi = lo + xs.len();
        let row = |l: usize, xs: &mut [Vec3]| {
            let i = lo + l;
            let (s, e) = (a.start[i] as usize, a.start[i + 1] as usize);
            let (p, q) = split_row(a, i, lo, hi);
            let r = b[i]
                - blocks_times(a, s, p, old, 0)
                - blocks_times(a, p, q, xs, lo)
                - blocks_times(a, q, e, old, 0);
            xs[l] += inv[i] * r;
        };
        if forward {
            (0..xs.len()).for_each(|l| row(l, xs));
        } else {
            (0..xs.len()).rev().for_each(|l| row(l, xs));
        }
    });
}

/// A V-cycle on the level whose matrix is `a` (inverse diagonal `inv`, its rows `skip` marks
/// left out: their unknowns stay zero), right-hand side `b`, into `x` (`work`: scratch);
/// `coarse[0]` is the next coarser level. A forward sweep from zero; the residual after it
/// restricted to the aggregates and the coarse correction added back; a backward sweep. The
/// backward sweep is the forward one's transpose, so the cycle is symmetric, as the conjugate
/// gradient needs.
#[allow(clippy::too_many_arguments)] // a level's matrix, its unknowns and scratch
fn cycle(
    a: &BlockCsr,
    inv: &[DMat3],
    skip: Option<&[bool]>,
    coarse: &mut [Level],
    b: &[Vec3],
    x: &mut [Vec3],
    work: &mut Vec<Vec3>,
    parallel: bool,
) {
    forward_from_zero(a, inv, b, x, parallel);
    let kept = |i: usize| !skip.is_some_and(|f| f[i]);
    match coarse.split_first_mut() {
        Some((level, rest)) => {
            work.resize(a.rows(), Vec3::ZERO);
            let xr = &*x;
            by_blocks(work, parallel, |lo, out| {
                for (l, o) in out.iter_mut().enumerate() {
                    *o = residual_after_forward(a, lo + l, xr);
                }
            });
            level.res.fill(Vec3::ZERO);
            for i in 0..a.rows() {
                if kept(i) {
                    level.res[level.aggregate[i] as usize] += work[i];
                }
            }
            let Level {
                a: ca,
                inv_diag,
                res,
                x: cx,
                work: cwork,
                ..
            } = level;
            cycle(ca, inv_diag, None, rest, res, cx, cwork, parallel);
            for i in 0..a.rows() {
                if kept(i) {
                    x[i] += cx[level.aggregate[i] as usize];
                }
            }
        }
        None => {
            // The coarsest level: symmetric sweeps.
            for _ in 0..3 {
                sweep(a, inv, b, x, work, false, parallel);
                sweep(a, inv, b, x, work, true, parallel);
            }
        }
    }
    sweep(a, inv, b, x, work, false, parallel);
}

/// `out` (of `a`'s pattern) = `S A S` with `S_i = I - n_i n_i^T` on the rows with a non-zero
/// unit vector in `normals` (the identity elsewhere), plus `n_i n_i^T` times a third of the
/// diagonal block's trace on those rows: the system the filtered conjugate gradient solves,
/// definite along the filtered directions too.
fn project(a: &BlockCsr, normals: &[Vec3], out: &mut BlockCsr) {
    let outer = |m: Vec3| outer_of(m, m);
    for i in 0..a.rows() {
        let mi = normals[i];
        for k in a.start[i] as usize..a.start[i + 1] as usize {
            let mj = normals[a.col[k] as usize];
            let mut b = a.val[k];
            // (I - m m^T) B = B - m (m^T B), and B (I - m m^T) = B - (B m) m^T.
            if mi != Vec3::ZERO {
                b -= outer_of(mi, b.transpose() * mi);
            }
            if mj != Vec3::ZERO {
                b -= outer_of(b * mj, mj);
            }
            out.val[k] = b;
        }
        if mi != Vec3::ZERO {
            let d = a.val[a.diag[i] as usize];
            let scale = (d.x_axis.x + d.y_axis.y + d.z_axis.z) / 3.0;
            out.val[a.diag[i] as usize] += outer(mi) * scale;
        }
    }
}

/// The outer product `u v^T`.
#[inline]
fn outer_of(u: Vec3, v: Vec3) -> DMat3 {
    DMat3::from_cols(u * v.x, u * v.y, u * v.z)
}

impl Preconditioner {
    /// The hierarchy of the matrix pattern `a` (`multigrid`), or block-Jacobi alone.
    pub fn setup(&mut self, a: &BlockCsr, multigrid: bool) {
        self.levels.clear();
        self.projected = None;
        self.inv_diag = vec![DMat3::ZERO; a.rows()];
        self.fixed = vec![false; a.rows()];
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
                inv_diag: vec![DMat3::ZERO; m],
                aggregate: agg,
                galerkin,
                res: vec![Vec3::ZERO; m],
                x: vec![Vec3::ZERO; m],
                work: Vec::new(),
            });
            fine = c;
        }
    }

    /// The values of the matrix `a` (of the pattern [`Preconditioner::setup`] took), its rows
    /// marked `fixed` known (left out of every level), and the rows with a non-zero unit vector
    /// in `normals` (empty: none) sliding along their plane: the conjugate gradient filters
    /// their part along `n` out of every vector (see [`pcg`]), so the hierarchy is built from
    /// the filtered matrix `S A S` (a sliding row's block along `n` kept at its diagonal's
    /// scale, so the matrix stays definite). Built from `A` itself, the cycle's corrections
    /// along `n`, which the filter then drops, cost a sliding cloth half its convergence.
    pub fn refresh(&mut self, a: &BlockCsr, fixed: &[bool], normals: &[Vec3]) {
        if normals.iter().any(|&m| m != Vec3::ZERO) {
            let mut p = self.projected.take().unwrap_or_else(|| a.clone());
            project(a, normals, &mut p);
            self.refresh_values(&p, fixed);
            self.projected = Some(p);
        } else {
            self.projected = None;
            self.refresh_values(a, fixed);
        }
    }

    fn refresh_values(&mut self, a: &BlockCsr, fixed: &[bool]) {
        for i in 0..a.rows() {
            self.inv_diag[i] = if fixed[i] {
                DMat3::ZERO
            } else {
                invert(a.val[a.diag[i] as usize])
            };
        }
        self.fixed.clear();
        self.fixed.extend_from_slice(fixed);
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

    /// `z = M^-1 r` for the matrix `a` of the last refresh (`r` zero on the fixed rows; `z`
    /// is zero there).
    pub fn apply(&mut self, a: &BlockCsr, r: &[Vec3], z: &mut [Vec3], parallel: bool) {
        if self.levels.is_empty() {
            for i in 0..r.len() {
                z[i] = self.inv_diag[i] * r[i];
            }
            return;
        }
        let a = self.projected.as_ref().unwrap_or(a);
        cycle(
            a,
            &self.inv_diag,
            Some(&self.fixed),
            &mut self.levels,
            r,
            z,
            &mut self.work,
            parallel,
        );
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.inv_diag.capacity() * size_of::<DMat3>()
            + self.fixed.capacity()
            + self.work.capacity() * size_of::<Vec3>()
            + self
                .levels
                .iter()
                .map(|l| {
                    l.a.heap_bytes()
                        + l.inv_diag.capacity() * size_of::<DMat3>()
                        + (l.aggregate.capacity() + l.galerkin.capacity()) * 4
                        + (l.res.capacity() + l.x.capacity() + l.work.capacity())
                            * size_of::<Vec3>()
                })
                .sum::<usize>()
    }
}

/// `a . b` over the rows not `fixed`, summed in row order.
fn dot(a: &[Vec3], b: &[Vec3], fixed: &[bool]) -> Real {
    let mut s = 0.0;
    for i in 0..a.len() {
        if !fixed[i] {
            s += a[i].dot(b[i]);
        }
    }
    s
}

/// The conjugate gradient's vectors, kept between solves (a vector of a particle's three
/// components each: a row's product gathers its neighbours' whole vectors at once).
#[derive(Clone, Debug, Default)]
pub(crate) struct CgScratch {
    b: Vec<Vec3>,
    x: Vec<Vec3>,
    r: Vec<Vec3>,
    z: Vec<Vec3>,
    p: Vec<Vec3>,
    ap: Vec<Vec3>,
}

impl CgScratch {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        [&self.b, &self.x, &self.r, &self.z, &self.p, &self.ap]
            .iter()
            .map(|v| v.capacity() * std::mem::size_of::<Vec3>())
            .sum()
    }
}

/// `y = A x`, on the pool when `parallel` (a row is a gather in column order: the same bits
/// whichever thread takes it).
fn product(a: &BlockCsr, x: &[Vec3], y: &mut [Vec3], parallel: bool) {
    let row = |i: usize| blocks_times(a, a.start[i] as usize, a.start[i + 1] as usize, x, 0);
    if parallel && y.len() > 2 * ROWS_PER_TASK {
        y.par_chunks_mut(ROWS_PER_TASK)
            .enumerate()
            .for_each(|(c, out)| {
                for (l, o) in out.iter_mut().enumerate() {
                    *o = row(c * ROWS_PER_TASK + l);
                }
            });
    } else {
        for (i, o) in y.iter_mut().enumerate() {
            *o = row(i);
        }
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
    let CgScratch {
        b: bv,
        x: xv,
        r,
        z,
        p,
        ap,
    } = scratch;
    for v in [&mut *bv, &mut *xv, &mut *r, &mut *z, &mut *p, &mut *ap] {
        v.resize(n, Vec3::ZERO);
    }
    for i in 0..n {
        bv[i] = b.get(i);
        xv[i] = x.get(i);
    }
    let iterations = solve(
        a,
        pre,
        bv,
        xv,
        fixed,
        normals,
        tolerance,
        max_iterations,
        parallel,
        [r, z, p, ap],
    );
    for (i, &v) in xv.iter().enumerate() {
        x.set(i, v);
    }
    iterations
}

/// [`pcg`] on vectors of particles' three components.
#[allow(clippy::too_many_arguments)] // the system, its unknowns and the CG's scratch
fn solve(
    a: &BlockCsr,
    pre: &mut Preconditioner,
    b: &[Vec3],
    x: &mut [Vec3],
    fixed: &[bool],
    normals: &[Vec3],
    tolerance: Real,
    max_iterations: usize,
    parallel: bool,
    [r, z, p, ap]: [&mut Vec<Vec3>; 4],
) -> usize {
    let n = b.len();
    let mask = |v: &mut [Vec3]| {
        for i in 0..n {
            if fixed[i] {
                v[i] = Vec3::ZERO;
            }
        }
        for (v, &m) in v.iter_mut().zip(normals) {
            if m != Vec3::ZERO {
                *v -= m * m.dot(*v);
            }
        }
    };
    product(a, x, ap, parallel);
    for i in 0..n {
        r[i] = if fixed[i] { Vec3::ZERO } else { b[i] - ap[i] };
    }
    mask(r);
    // The right-hand side's norm over what the solve sees of it.
    z.clone_from_slice(b);
    mask(z);
    let norm_b = dot(z, z, fixed).sqrt().max(1e-300);
    if dot(r, r, fixed).sqrt() <= tolerance * norm_b {
        return 0;
    }
    pre.apply(a, r, z, parallel);
    mask(z);
    p.clone_from(z);
    let mut rz = dot(r, z, fixed);
    for it in 1..=max_iterations {
        product(a, p, ap, parallel);
        mask(ap);
        let pap = dot(p, ap, fixed);
        if pap.is_nan() || pap <= 0.0 {
            return it;
        }
        let alpha = rz / pap;
        for i in 0..n {
            x[i] += p[i] * alpha;
            r[i] -= ap[i] * alpha;
        }
        if dot(r, r, fixed).sqrt() <= tolerance * norm_b {
            return it;
        }
        pre.apply(a, r, z, parallel);
        mask(z);
        let rz_new = dot(r, z, fixed);
        let beta = rz_new / rz;
        rz = rz_new;
        for i in 0..n {
            p[i] = z[i] + p[i] * beta;
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
            pre.refresh(&a, &fixed, &[]);
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
            let xs: Vec<Vec3> = (0..n).map(|i| x.get(i)).collect();
            let mut ax = vec![Vec3::ZERO; n];
            product(&a, &xs, &mut ax, false);
            let mut err: Real = 0.0;
            for i in 0..n {
                err = err.max((ax[i] - b.get(i)).length());
            }
            assert!(err < 1e-7, "multigrid {mg}: residual {err}");
        }
        assert!(iters[1] < iters[0], "iterations {iters:?}");
    }

    /// A stiff sheet whose rows mostly slide along planes of many orientations: the filtered
    /// conjugate gradient reaches the filtered system's solution (no part along a sliding
    /// row's normal, no filtered residual) with the hierarchy built from `A` (the normals left
    /// out of the refresh) and with it built from `S A S`, the latter in at most half the
    /// iterations (38 against 13 here).
    #[test]
    fn the_hierarchy_of_the_filtered_matrix_solves_sliding_rows_faster() {
        let side = 40;
        let n = side * side;
        let at = |i: usize, j: usize| (j * side + i) as u32;
        let mut pairs = Vec::new();
        for j in 0..side {
            for i in 0..side {
                if i + 1 < side {
                    pairs.push([at(i, j), at(i + 1, j)]);
                }
                if j + 1 < side {
                    pairs.push([at(i, j), at(i, j + 1)]);
                }
                if i + 1 < side && j + 1 < side {
                    pairs.push([at(i, j), at(i + 1, j + 1)]);
                }
            }
        }
        let mut a = BlockCsr::pattern(n, pairs.iter().copied());
        let (m, k) = (1e-4, 1.0);
        for i in 0..n {
            let deg = (a.start[i + 1] - a.start[i] - 1) as Real;
            for s in a.start[i] as usize..a.start[i + 1] as usize {
                let j = a.col[s] as usize;
                a.val[s] = if i == j {
                    DMat3::from_diagonal(Vec3::splat(m + k * deg))
                } else {
                    DMat3::from_diagonal(Vec3::splat(-k))
                };
            }
        }
        let fixed: Vec<bool> = (0..n).map(|i| i % 97 == 0).collect();
        let normals: Vec<Vec3> = (0..n)
            .map(|i| {
                if i % 3 == 0 {
                    Vec3::ZERO
                } else {
                    let t = i as Real;
                    Vec3::new(0.6 * t.sin(), 1.0, 0.6 * (1.7 * t).cos()).normalize()
                }
            })
            .collect();
        let mut b = Soa::zeros(n);
        for i in 0..n {
            let v = if fixed[i] {
                Vec3::ZERO
            } else {
                Vec3::new(1.0, -2.0, (i % 7) as Real - 3.0)
            };
            b.set(i, v - normals[i] * normals[i].dot(v));
        }
        let mut iters = [0; 2];
        for (slot, filtered) in [false, true].into_iter().enumerate() {
            let mut pre = Preconditioner::default();
            pre.setup(&a, true);
            pre.refresh(&a, &fixed, if filtered { &normals } else { &[] });
            let mut x = Soa::zeros(n);
            let mut scratch = CgScratch::default();
            iters[slot] = pcg(
                &a,
                &mut pre,
                &b,
                &mut x,
                &fixed,
                &normals,
                1e-9,
                5000,
                false,
                &mut scratch,
            );
            let xs: Vec<Vec3> = (0..n).map(|i| x.get(i)).collect();
            let mut ax = vec![Vec3::ZERO; n];
            product(&a, &xs, &mut ax, false);
            for i in 0..n {
                if fixed[i] {
                    assert_eq!(xs[i], Vec3::ZERO);
                    continue;
                }
                let nm = normals[i];
                let r = b.get(i) - ax[i];
                let r = r - nm * nm.dot(r);
                assert!(
                    r.length() < 1e-6,
                    "filtered {filtered}: row {i} residual {r}"
                );
                assert!(
                    nm.dot(xs[i]).abs() < 1e-12,
                    "row {i} moved along its normal"
                );
            }
        }
        assert!(
            2 * iters[1] <= iters[0],
            "iterations, hierarchy of A then of S A S: {iters:?}"
        );
    }
}
