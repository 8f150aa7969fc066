//! Where per-particle work runs: on the calling thread, or split over the rayon pool.
//!
//! Handing a job to the pool from outside it and waiting costs microseconds, more than a small
//! cloth's whole step; from inside the pool (see `Simulation::advance`) a split costs tens of
//! nanoseconds. Results never depend on the choice: every helper here computes each particle's
//! value independently and sums counts (integers) only.

use crate::math::{Real, Soa, Vec3};
use rayon::prelude::*;

/// Below this many particles, work called from outside the thread pool stays on the calling
/// thread.
pub const PARALLEL_MIN_PARTICLES: usize = 16_384;

/// Below this many particles even work inside the thread pool stays on one thread.
pub const PARALLEL_MIN_PARTICLES_IN_POOL: usize = 1_024;

/// Particles per task in the per-particle passes.
const CHUNK: usize = 1024;

/// Whether work on `n` particles should be split over the pool.
pub(crate) fn use_pool(n: usize) -> bool {
    let min = if rayon::current_thread_index().is_some() {
        PARALLEL_MIN_PARTICLES_IN_POOL
    } else {
        PARALLEL_MIN_PARTICLES
    };
    n >= min && rayon::current_num_threads() > 1
}

/// A Jacobi pass: `out[k] = f(k).0` for every particle, returning the sum of the counts
/// `f(k).1`.
pub(crate) fn jacobi<F>(out: &mut Soa, f: F) -> usize
where
    F: Fn(usize) -> (Vec3, usize) + Sync,
{
    let chunk = |start: usize, x: &mut [Real], y: &mut [Real], z: &mut [Real]| {
        let mut count = 0;
        for i in 0..x.len() {
            let (c, n) = f(start + i);
            (x[i], y[i], z[i]) = (c.x, c.y, c.z);
            count += n;
        }
        count
    };
    if use_pool(out.len()) {
        (
            out.x.par_chunks_mut(CHUNK),
            out.y.par_chunks_mut(CHUNK),
            out.z.par_chunks_mut(CHUNK),
        )
            .into_par_iter()
            .enumerate()
            .map(|(b, (x, y, z))| chunk(b * CHUNK, x, y, z))
            .sum()
    } else {
        let (x, y, z) = (&mut out.x[..], &mut out.y[..], &mut out.z[..]);
        chunk(0, x, y, z)
    }
}

/// `f(first, chunk)` over `out` in chunks of `len` items (the last may be shorter), `first` the
/// index of the chunk's first item; the chunks side by side on the pool if `parallel`, else in
/// order on this thread. Each chunk is the same either way, so a pass whose chunks do not read
/// each other's items has the same bits on any thread count.
pub(crate) fn by_chunks<T: Send>(
    out: &mut [T],
    len: usize,
    parallel: bool,
    f: impl Fn(usize, &mut [T]) + Sync,
) {
    if parallel {
        out.par_chunks_mut(len)
            .enumerate()
            .for_each(|(c, part)| f(c * len, part));
    } else {
        out.chunks_mut(len)
            .enumerate()
            .for_each(|(c, part)| f(c * len, part));
    }
}

/// `p[k] = f(k, p[k])` for every particle.
pub(crate) fn map_in_place<F>(p: &mut Soa, f: F)
where
    F: Fn(usize, Vec3) -> Vec3 + Sync,
{
    let chunk = |start: usize, x: &mut [Real], y: &mut [Real], z: &mut [Real]| {
        for i in 0..x.len() {
            let v = f(start + i, Vec3::new(x[i], y[i], z[i]));
            (x[i], y[i], z[i]) = (v.x, v.y, v.z);
        }
    };
    if use_pool(p.len()) {
        (
            p.x.par_chunks_mut(CHUNK),
            p.y.par_chunks_mut(CHUNK),
            p.z.par_chunks_mut(CHUNK),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(b, (x, y, z))| chunk(b * CHUNK, x, y, z));
    } else {
        let (x, y, z) = (&mut p.x[..], &mut p.y[..], &mut p.z[..]);
        chunk(0, x, y, z);
    }
}

/// `p += c`, component-wise.
pub(crate) fn add_assign(p: &mut Soa, c: &Soa) {
    let pooled = use_pool(p.len());
    for (a, b) in [(&mut p.x, &c.x), (&mut p.y, &c.y), (&mut p.z, &c.z)] {
        if pooled {
            a.par_iter_mut().zip(b).for_each(|(a, b)| *a += b);
        } else {
            a.iter_mut().zip(b).for_each(|(a, b)| *a += b);
        }
    }
}

/// Fewest rows handed to one parallel task of a row pass. Results never depend on how rows are
/// split (every particle's sum has a fixed order).
const MIN_ROWS_PER_TASK: usize = 4;

/// How a row pass over a grid of `nz` rows of `nx` particles is split: `Some(rows per task)`
/// on the pool, `None` on the calling thread. One block of rows per thread, at least
/// [`MIN_ROWS_PER_TASK`]: every block recomputes the springs of the row above it and leaves one
/// row of cells to measure after the join, so fewer, larger blocks do less extra work; on a
/// quiet machine that measured 3 % faster than two blocks per thread at 50 x 50 and 100 x 100.
pub(crate) fn row_split(nx: usize, nz: usize) -> Option<usize> {
    use_pool(nx * nz).then(|| {
        let tasks = rayon::current_num_threads();
        nz.div_ceil(tasks).max(MIN_ROWS_PER_TASK)
    })
}
