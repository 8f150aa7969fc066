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
//! until a few hundred particles remain, and the coarsest level is solved by block-Jacobi
//! sweeps. A V-cycle smooths with damped block-Jacobi before and after the coarse correction.

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
        let d = Vec3::new(b.x_axis.x, b.y_axis.y, b.z_axis.z);
        DMat3::from_diagonal(Vec3::ONE / d.max(Vec3::splat(1e-300)))
    }
}

/// One level of the aggregation hierarchy: its matrix, its diagonal blocks' inverses, and the
/// aggregate each of its rows joins on the next (coarser) level.
#[derive(Clone, Debug, Default)]
struct Level {
    a: BlockCsr,
    inv_diag: Vec<DMat3>,
    aggregate: Vec<u32>,
    coarse_rows: usize,
}

/// The preconditioner of a mesh system: block-Jacobi, or an aggregation multigrid V-cycle.
#[derive(Clone, Debug, Default)]
pub(crate) struct Preconditioner {
    levels: Vec<Level>,
    /// Whether to run the multigrid (else block-Jacobi on the finest level).
    multigrid: bool,
    /// Scratch per level: residual, correction, product.
    scratch: Vec<[Soa; 3]>,
}

/// Smallest level aggregated further.
const COARSEST: usize = 200;
/// Damping of the block-Jacobi smoother.
const OMEGA: Real = 0.7;

/// Greedy aggregation of the graph of `a`: returns each row's aggregate and the count.
fn aggregate(a: &BlockCsr, fixed: &[bool]) -> (Vec<u32>, usize) {
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
    let _ = fixed;
    (agg, count as usize)
}

/// The Galerkin coarse matrix `P^T A P` of piecewise-constant aggregation.
fn coarsen(a: &BlockCsr, agg: &[u32], m: usize) -> BlockCsr {
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
    let mut c = BlockCsr::pattern(m, pairs.into_iter());
    for i in 0..n {
        let p = agg[i] as usize;
        for k in a.start[i] as usize..a.start[i + 1] as usize {
            let q = agg[a.col[k] as usize] as usize;
            if let Some(slot) = c.find(p, q) {
                c.val[slot] += a.val[k];
            }
        }
    }
    c
}

impl Preconditioner {
    /// Builds the preconditioner of `a`: with `multigrid`, the aggregation hierarchy; rows
    /// marked `fixed` act as the identity (their unknowns are known).
    pub fn build(&mut self, a: &BlockCsr, fixed: &[bool], multigrid: bool) {
        self.multigrid = multigrid;
        let mut fine = a.clone();
        // Fixed rows: identity, decoupled.
        for i in 0..fine.rows() {
            if fixed[i] {
                for k in fine.start[i] as usize..fine.start[i + 1] as usize {
                    fine.val[k] = DMat3::ZERO;
                }
                fine.val[fine.diag[i] as usize] = DMat3::IDENTITY;
            } else {
                for k in fine.start[i] as usize..fine.start[i + 1] as usize {
                    if fixed[fine.col[k] as usize] {
                        fine.val[k] = DMat3::ZERO;
                    }
                }
            }
        }
        self.levels.clear();
        let mut current = fine;
        loop {
            let inv_diag = (0..current.rows())
                .map(|i| invert(current.val[current.diag[i] as usize]))
                .collect();
            let n = current.rows();
            if !multigrid || n <= COARSEST {
                self.levels.push(Level {
                    a: current,
                    inv_diag,
                    aggregate: Vec::new(),
                    coarse_rows: 0,
                });
                break;
            }
            let (agg, m) = aggregate(&current, &[]);
            if m * 10 > n * 9 {
                // Not coarsening any more: stop here.
                self.levels.push(Level {
                    a: current,
                    inv_diag,
                    aggregate: Vec::new(),
                    coarse_rows: 0,
                });
                break;
            }
            let coarse = coarsen(&current, &agg, m);
            self.levels.push(Level {
                a: current,
                inv_diag,
                aggregate: agg,
                coarse_rows: m,
            });
            current = coarse;
        }
        self.scratch = self
            .levels
            .iter()
            .map(|l| {
                let (n, m) = (l.a.rows(), l.coarse_rows);
                [Soa::zeros(m), Soa::zeros(m), Soa::zeros(n)]
            })
            .collect();
    }

    /// `z = M^-1 r`.
    pub fn apply(&mut self, r: &Soa, z: &mut Soa) {
        if !self.multigrid {
            let inv = &self.levels[0].inv_diag;
            for i in 0..r.len() {
                z.set(i, inv[i] * r.get(i));
            }
            return;
        }
        self.cycle(0, r, z);
    }

    /// A V-cycle from level `l` on the right-hand side `b`, into `x`.
    fn cycle(&mut self, l: usize, b: &Soa, x: &mut Soa) {
        let n = b.len();
        if l + 1 == self.levels.len() {
            // Coarsest: damped block-Jacobi sweeps from zero.
            let level = &self.levels[l];
            for i in 0..n {
                x.set(i, level.inv_diag[i] * b.get(i));
            }
            let mut ax = Soa::zeros(n);
            for _ in 0..8 {
                level.a.mul(x, &mut ax, false);
                for i in 0..n {
                    let r = b.get(i) - ax.get(i);
                    x.set(i, x.get(i) + level.inv_diag[i] * r * OMEGA);
                }
            }
            return;
        }
        let [mut res, mut coarse_x, mut ax] = std::mem::take(&mut self.scratch[l]);
        {
            let level = &self.levels[l];
            // Pre-smooth from zero.
            for i in 0..n {
                x.set(i, level.inv_diag[i] * b.get(i) * OMEGA);
            }
            level.a.mul(x, &mut ax, false);
            for i in 0..n {
                let r = b.get(i) - ax.get(i);
                x.set(i, x.get(i) + level.inv_diag[i] * r * OMEGA);
            }
            level.a.mul(x, &mut ax, false);
            // Restrict the residual.
            for v in [&mut res.x, &mut res.y, &mut res.z] {
                v.fill(0.0);
            }
            for i in 0..n {
                let g = level.aggregate[i] as usize;
                res.set(g, res.get(g) + (b.get(i) - ax.get(i)));
            }
        }
        self.cycle(l + 1, &res, &mut coarse_x);
        let level = &self.levels[l];
        for i in 0..n {
            let g = level.aggregate[i] as usize;
            x.set(i, x.get(i) + coarse_x.get(g));
        }
        // Post-smooth.
        for _ in 0..2 {
            level.a.mul(x, &mut ax, false);
            for i in 0..n {
                let r = b.get(i) - ax.get(i);
                x.set(i, x.get(i) + level.inv_diag[i] * r * OMEGA);
            }
        }
        self.scratch[l] = [res, coarse_x, ax];
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.levels
            .iter()
            .map(|l| {
                l.a.heap_bytes()
                    + l.inv_diag.capacity() * std::mem::size_of::<DMat3>()
                    + l.aggregate.capacity() * 4
            })
            .sum::<usize>()
            + self
                .scratch
                .iter()
                .map(|s| s.iter().map(Soa::heap_bytes).sum::<usize>())
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

/// Solves `A x = b` for the rows not `fixed` (their `x` kept as given, their residual ignored)
/// by the preconditioned conjugate gradient, from the `x` given, to a residual of `tolerance`
/// times the right-hand side's norm or `max_iterations`. Returns the iterations taken.
#[allow(clippy::too_many_arguments)] // the system, its unknowns and the CG's scratch
pub(crate) fn pcg(
    a: &BlockCsr,
    pre: &mut Preconditioner,
    b: &Soa,
    x: &mut Soa,
    fixed: &[bool],
    tolerance: Real,
    max_iterations: usize,
    parallel: bool,
) -> usize {
    let n = b.len();
    let mut r = Soa::zeros(n);
    let mut z = Soa::zeros(n);
    let mut p = Soa::zeros(n);
    let mut ap = Soa::zeros(n);
    a.mul(x, &mut ap, parallel);
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
    let norm_b = dot(b, b, fixed).sqrt().max(1e-300);
    let mask = |v: &mut Soa| {
        for i in 0..n {
            if fixed[i] {
                v.set(i, Vec3::ZERO);
            }
        }
    };
    if dot(&r, &r, fixed).sqrt() <= tolerance * norm_b {
        return 0;
    }
    pre.apply(&r, &mut z);
    mask(&mut z);
    p.clone_from(&z);
    let mut rz = dot(&r, &z, fixed);
    for it in 1..=max_iterations {
        a.mul(&p, &mut ap, parallel);
        mask(&mut ap);
        let pap = dot(&p, &ap, fixed);
        if pap.is_nan() || pap <= 0.0 {
            return it;
        }
        let alpha = rz / pap;
        for i in 0..n {
            x.set(i, x.get(i) + p.get(i) * alpha);
            r.set(i, r.get(i) - ap.get(i) * alpha);
        }
        if dot(&r, &r, fixed).sqrt() <= tolerance * norm_b {
            return it;
        }
        pre.apply(&r, &mut z);
        mask(&mut z);
        let rz_new = dot(&r, &z, fixed);
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
            pre.build(&a, &fixed, mg);
            let mut x = Soa::zeros(n);
            iters[slot] = pcg(&a, &mut pre, &b, &mut x, &fixed, 1e-10, 5000, false);
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
