//! Self-collision: particles are spheres of diameter `thickness + collision_margin` that must
//! not overlap (thesis 3.1).
//!
//! Broad phase: a uniform hash grid (cells of `diameter + skin`, counting sort) builds, for each
//! particle, the list of particles within `diameter + skin` of it. The lists stay valid until
//! some particle has moved more than `skin / 2` since they were built (two particles closing
//! in on each other then have closed by at most `skin`), so a cloth that is settling or lying
//! still rebuilds rarely. Narrow phase, every step: each particle pushes itself out of its
//! listed neighbours by its share of the overlap (Jacobi: all corrections are computed from the
//! same positions, then applied, so the result does not depend on the order or the threads).
//!
//! Grid neighbours closer at rest than the diameter (a very fine cloth) are kept at their rest
//! distance instead: they are not pushed apart by the cloth's own tessellation.
//!
//! Pairs named in [`ExemptPairs`] (the particles of a seam, sewn pair by pair) are never pushed
//! apart, here or by a mesh cloth's vertex-triangle and edge-edge contact
//! ([`super::mesh_self`]).

use crate::math::{Real, Soa, Vec3};
use crate::model::Grid;
use rayon::prelude::*;

/// The skin of the neighbour lists, as a fraction of the particle diameter.
const SKIN_FRACTION: Real = 1.0;

/// Self-collision state: the neighbour lists and their reference positions.
#[derive(Clone, Debug, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SelfCollision {
    diameter: Real,
    skin: Real,
    reference: Soa,
    /// CSR neighbour lists: neighbours of `i` are `list[start[i]..start[i + 1]]`.
    start: Vec<u32>,
    list: Vec<u32>,
    /// Scratch for the broad phase (rebuilt with the lists, not saved in checkpoints).
    #[cfg_attr(feature = "serde", serde(skip))]
    cells: Vec<[i64; 3]>,
    #[cfg_attr(feature = "serde", serde(skip))]
    bucket_start: Vec<u32>,
    #[cfg_attr(feature = "serde", serde(skip))]
    bucket_items: Vec<u32>,
    corrections: Soa,
    /// How many times the neighbour lists were built.
    pub rebuilds: u64,
}

/// Particle pairs self-collision leaves alone (the two sides of a seam): a symmetric relation,
/// kept as each particle's sorted list of partners.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExemptPairs {
    /// Partners of `i` are `partners[start[i]..start[i + 1]]` (empty when there are none).
    start: Vec<u32>,
    partners: Vec<u32>,
}

impl ExemptPairs {
    /// The pairs `pairs` among `n` particles (either order; repeats are kept once). `Err` names
    /// the first pair with a particle out of range or a particle paired with itself.
    pub fn new(n: usize, pairs: &[[u32; 2]]) -> Result<Self, String> {
        if pairs.is_empty() {
            return Ok(Self::default());
        }
        if let Some((i, p)) = pairs
            .iter()
            .enumerate()
            .find(|(_, p)| p[0] as usize >= n || p[1] as usize >= n || p[0] == p[1])
        {
            return Err(if p[0] == p[1] {
                format!("pair {i} joins particle {} to itself", p[0])
            } else {
                format!("pair {i} names a particle out of range: the cloth has {n} particles")
            });
        }
        let mut count = vec![0u32; n + 1];
        for p in pairs {
            count[p[0] as usize + 1] += 1;
            count[p[1] as usize + 1] += 1;
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut partners = vec![0u32; count[n] as usize];
        for p in pairs {
            for (a, b) in [(p[0], p[1]), (p[1], p[0])] {
                partners[fill[a as usize] as usize] = b;
                fill[a as usize] += 1;
            }
        }
        // Sorted and without repeats, row by row.
        let mut start = Vec::with_capacity(n + 1);
        let mut out = Vec::with_capacity(partners.len());
        start.push(0u32);
        for i in 0..n {
            let row = &mut partners[count[i] as usize..count[i + 1] as usize];
            row.sort_unstable();
            let from = out.len();
            for &j in row.iter() {
                if out.len() == from || out[out.len() - 1] != j {
                    out.push(j);
                }
            }
            start.push(out.len() as u32);
        }
        Ok(Self {
            start,
            partners: out,
        })
    }

    /// True when no pair is exempt.
    pub fn is_empty(&self) -> bool {
        self.partners.is_empty()
    }

    /// Number of exempt pairs.
    pub fn len(&self) -> usize {
        self.partners.len() / 2
    }

    /// Whether particles `a` and `b` are an exempt pair.
    #[inline]
    pub fn contains(&self, a: usize, b: usize) -> bool {
        !self.partners.is_empty()
            && self.partners[self.start[a] as usize..self.start[a + 1] as usize]
                .binary_search(&(b as u32))
                .is_ok()
    }

    /// Whether particle `a` is exempt from any of `others`.
    #[inline]
    pub fn any(&self, a: usize, others: &[u32]) -> bool {
        !self.partners.is_empty() && others.iter().any(|&b| self.contains(a, b as usize))
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        (self.start.capacity() + self.partners.capacity()) * std::mem::size_of::<u32>()
    }
}

#[inline]
fn bucket_of(c: [i64; 3], mask: usize) -> usize {
    let h = (c[0].wrapping_mul(73_856_093))
        ^ (c[1].wrapping_mul(19_349_663))
        ^ (c[2].wrapping_mul(83_492_791));
    (h as usize) & mask
}

impl SelfCollision {
    /// Self-collision for `n` particles of diameter `diameter`, m.
    pub fn new(n: usize, diameter: Real) -> Self {
        Self {
            diameter,
            skin: SKIN_FRACTION * diameter,
            corrections: Soa::zeros(n),
            ..Default::default()
        }
    }

    /// Whether the lists fit a cloth of `n` particles (a stored copy may be damaged): empty or
    /// one row per particle, every neighbour in range.
    pub(crate) fn fits(&self, n: usize) -> bool {
        let lists = (self.start.is_empty() && self.list.is_empty())
            || (self.start.len() == n + 1
                && self.start.windows(2).all(|w| w[0] <= w[1])
                && self.start[n] as usize == self.list.len()
                && self.list.iter().all(|&j| (j as usize) < n));
        let reference = self.reference.is_empty()
            || (self.reference.x.len() == n
                && self.reference.y.len() == n
                && self.reference.z.len() == n);
        lists
            && reference
            && self.corrections.len() == n
            && self.corrections.y.len() == n
            && self.corrections.z.len() == n
    }

    /// Heap bytes held (lists, hash grid, scratch).
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.reference.heap_bytes()
            + self.corrections.heap_bytes()
            + (self.start.capacity()
                + self.list.capacity()
                + self.bucket_start.capacity()
                + self.bucket_items.capacity())
                * size_of::<u32>()
            + self.cells.capacity() * size_of::<[i64; 3]>()
    }

    /// Number of neighbour pairs (both directions) in the current lists.
    pub fn candidate_count(&self) -> usize {
        self.list.len()
    }

    /// The positions the lists were built at (none before the first build).
    pub fn reference(&self) -> Option<&Soa> {
        (!self.reference.is_empty()).then_some(&self.reference)
    }

    fn needs_rebuild(&self, p: &Soa) -> bool {
        if self.reference.len() != p.len() {
            return true;
        }
        let limit = (0.5 * self.skin) * (0.5 * self.skin);
        let r = &self.reference;
        // Largest squared displacement of a chunk, as a branch-free loop that vectorises.
        let moved = |range: std::ops::Range<usize>| {
            let (x, y, z) = (
                &p.x[range.clone()],
                &p.y[range.clone()],
                &p.z[range.clone()],
            );
            let (rx, ry, rz) = (&r.x[range.clone()], &r.y[range.clone()], &r.z[range]);
            let mut worst: Real = 0.0;
            for i in 0..x.len() {
                let (dx, dy, dz) = (x[i] - rx[i], y[i] - ry[i], z[i] - rz[i]);
                let d = dx * dx + dy * dy + dz * dz;
                worst = if d > worst { d } else { worst };
            }
            worst
        };
        let n = p.len();
        if crate::exec::use_pool(n) {
            (0..n.div_ceil(1024))
                .into_par_iter()
                .map(|c| moved(c * 1024..((c + 1) * 1024).min(n)))
                .any(|d| d > limit)
        } else {
            moved(0..n) > limit
        }
    }

    fn rebuild(&mut self, p: &Soa) {
        self.rebuilds += 1;
        let n = p.len();
        let cell = self.diameter + self.skin;
        let inv = 1.0 / cell;
        self.cells.clear();
        self.cells.extend((0..n).map(|i| {
            [
                (p.x[i] * inv).floor() as i64,
                (p.y[i] * inv).floor() as i64,
                (p.z[i] * inv).floor() as i64,
            ]
        }));
        // Counting sort of particles into hash buckets, in particle order.
        let buckets = (2 * n).next_power_of_two();
        let mask = buckets - 1;
        self.bucket_start.clear();
        self.bucket_start.resize(buckets + 1, 0);
        for c in &self.cells {
            self.bucket_start[bucket_of(*c, mask) + 1] += 1;
        }
        for b in 0..buckets {
            self.bucket_start[b + 1] += self.bucket_start[b];
        }
        self.bucket_items.clear();
        self.bucket_items.resize(n, 0);
        let mut fill = self.bucket_start.clone();
        for (i, c) in self.cells.iter().enumerate() {
            let b = bucket_of(*c, mask);
            self.bucket_items[fill[b] as usize] = i as u32;
            fill[b] += 1;
        }
        // Neighbour lists: everything within `cell` of each particle, in a fixed order.
        let reach2 = cell * cell;
        let (cells, bucket_start, bucket_items) =
            (&self.cells, &self.bucket_start, &self.bucket_items);
        let per_particle: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .with_min_len(1024)
            .map(|i| {
                let mut out = Vec::new();
                let c = cells[i];
                let pi = p.get(i);
                for ox in -1..=1 {
                    for oy in -1..=1 {
                        for oz in -1..=1 {
                            let q = [c[0] + ox, c[1] + oy, c[2] + oz];
                            let b = bucket_of(q, mask);
                            for &j in &bucket_items
                                [bucket_start[b] as usize..bucket_start[b + 1] as usize]
                            {
                                let j = j as usize;
                                if j == i || cells[j] != q {
                                    continue;
                                }
                                if (p.get(j) - pi).length_squared() < reach2 {
                                    out.push(j as u32);
                                }
                            }
                        }
                    }
                }
                out.sort_unstable();
                out
            })
            .collect();
        self.start.clear();
        self.list.clear();
        self.start.push(0);
        for l in per_particle {
            self.list.extend_from_slice(&l);
            self.start.push(self.list.len() as u32);
        }
        self.reference.clone_from(p);
    }

    /// Pushes overlapping particles apart. `fixed[i]` marks grabbed particles, which do not
    /// move. Returns the number of overlapping (ordered) pairs found.
    pub fn solve(&mut self, grid: &Grid, p: &mut Soa, fixed: &[bool]) -> usize {
        let none = ExemptPairs::default();
        self.solve_moved(&|a, b| grid.rest_distance(a, b), p, fixed, &none, None)
    }

    /// [`SelfCollision::solve`] with the rest distance of any two particles `rest_distance`,
    /// leaving the pairs of `exempt` alone, given the largest squared distance (m^2) any
    /// particle of `p` has moved from [`SelfCollision::reference`] if the caller measured it
    /// already.
    pub fn solve_moved<R: Fn(usize, usize) -> Real + Sync>(
        &mut self,
        rest_distance: &R,
        p: &mut Soa,
        fixed: &[bool],
        exempt: &ExemptPairs,
        moved2: Option<Real>,
    ) -> usize {
        // Particles of no size never overlap (and a hash grid of cells of no size would put
        // every particle in one bucket).
        if self.diameter <= 0.0 {
            return 0;
        }
        let rebuild = match (moved2, self.reference()) {
            (Some(m), Some(_)) if self.reference.len() == p.len() => {
                m > (0.5 * self.skin) * (0.5 * self.skin)
            }
            _ => self.needs_rebuild(p),
        };
        if rebuild {
            self.rebuild(p);
        }
        if self.list.is_empty() {
            return 0;
        }
        let d = self.diameter;
        let (start, list) = (&self.start, &self.list);
        let pr = &*p;
        let hits = crate::exec::jacobi(&mut self.corrections, |i| {
            let mut corr = Vec3::ZERO;
            let mut hits = 0;
            if !fixed[i] {
                let pi = pr.get(i);
                for &j in &list[start[i] as usize..start[i + 1] as usize] {
                    let j = j as usize;
                    let min = d.min(rest_distance(i, j));
                    let delta = pi - pr.get(j);
                    let dist = delta.length();
                    if dist < min && dist > 0.0 && !exempt.contains(i, j) {
                        hits += 1;
                        let share = if fixed[j] { 1.0 } else { 0.5 };
                        corr += delta * (share * (min - dist) / dist);
                    }
                }
            }
            (corr, hits)
        });
        if hits > 0 {
            crate::exec::add_assign(p, &self.corrections);
        }
        hits
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two overlapping particles are pushed apart to the diameter, unless their pair is exempt.
    #[test]
    fn exempt_pairs_are_not_pushed_apart() {
        let d = 0.002;
        let start = Soa::from_vec3(&[
            Vec3::ZERO,
            Vec3::new(0.0005, 0.0, 0.0),
            Vec3::new(0.1, 0.0, 0.0),
        ]);
        let run = |exempt: &ExemptPairs| {
            let mut p = start.clone();
            let mut sc = SelfCollision::new(3, d);
            let hits = sc.solve_moved(&|_, _| 1.0, &mut p, &[false; 3], exempt, None);
            (hits, (p.get(1) - p.get(0)).length())
        };
        let (hits, gap) = run(&ExemptPairs::default());
        assert_eq!(hits, 2);
        assert!((gap - d).abs() < 1e-15, "{gap}");
        // Either order names the pair; the third particle is nobody's partner.
        let exempt = ExemptPairs::new(3, &[[1, 0]]).unwrap();
        assert!(exempt.contains(0, 1) && exempt.contains(1, 0) && !exempt.contains(0, 2));
        assert_eq!(exempt.len(), 1);
        assert_eq!(run(&exempt), (0, 0.0005));
        assert!(ExemptPairs::new(3, &[[0, 3]]).is_err());
        assert!(ExemptPairs::new(3, &[[2, 2]]).is_err());
        // Repeats are kept once.
        let twice = ExemptPairs::new(3, &[[0, 1], [1, 0], [2, 0]]).unwrap();
        assert_eq!(twice.len(), 2);
        assert!(twice.any(0, &[2]) && !twice.any(1, &[2]));
    }
}
