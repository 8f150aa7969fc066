//! The cloth's grid: particle layout, spring stencil and render triangles (thesis 3.1).
//!
//! Particle `(i, j)` (column `i` along x, row `j` along z) has index `j * nx + i`. Springs are
//! not stored as a list: every particle is joined to its 8 grid neighbours (4 structural, 4
//! shear) and the loops walk that fixed stencil row by row, which is what lets the step run
//! like an image filter (contiguous rows, no index indirection).

use crate::math::{Real, Soa, Vec3};
use crate::params::ClothParams;

/// A neighbour direction of the 8-spring stencil.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    /// Column offset.
    pub di: isize,
    /// Row offset.
    pub dj: isize,
    /// True for structural springs, false for shear.
    pub structural: bool,
}

/// The 8 neighbours, in the fixed order every stencil loop sums them (so results do not depend
/// on scheduling).
pub const STENCIL: [Neighbour; 8] = [
    Neighbour {
        di: -1,
        dj: 0,
        structural: true,
    },
    Neighbour {
        di: 1,
        dj: 0,
        structural: true,
    },
    Neighbour {
        di: 0,
        dj: -1,
        structural: true,
    },
    Neighbour {
        di: 0,
        dj: 1,
        structural: true,
    },
    Neighbour {
        di: -1,
        dj: -1,
        structural: false,
    },
    Neighbour {
        di: 1,
        dj: -1,
        structural: false,
    },
    Neighbour {
        di: -1,
        dj: 1,
        structural: false,
    },
    Neighbour {
        di: 1,
        dj: 1,
        structural: false,
    },
];

/// The regular particle grid of a cloth and its rest geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Particles along x.
    pub nx: usize,
    /// Particles along z.
    pub nz: usize,
    /// Rest spacing along x, m.
    pub dx: Real,
    /// Rest spacing along z, m.
    pub dz: Real,
}

impl Grid {
    /// The grid of `cloth`.
    pub fn new(cloth: &ClothParams) -> Self {
        let [nx, nz] = cloth.resolution;
        Self {
            nx,
            nz,
            dx: cloth.size[0] / (nx - 1) as Real,
            dz: cloth.size[1] / (nz - 1) as Real,
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.nx * self.nz
    }

    /// True for an empty grid (never, for a validated cloth).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Index of particle `(i, j)`.
    #[inline]
    pub fn index(&self, i: usize, j: usize) -> usize {
        j * self.nx + i
    }

    /// Rest length of the spring towards neighbour `n`, m.
    pub fn rest_length(&self, n: Neighbour) -> Real {
        let (a, b) = (n.di as Real * self.dx, n.dj as Real * self.dz);
        (a * a + b * b).sqrt()
    }

    /// Rest distance between particles `(i0, j0)` and `(i1, j1)`, m.
    pub fn rest_distance(&self, a: usize, b: usize) -> Real {
        let (ia, ja) = ((a % self.nx) as Real, (a / self.nx) as Real);
        let (ib, jb) = ((b % self.nx) as Real, (b / self.nx) as Real);
        let (u, v) = ((ia - ib) * self.dx, (ja - jb) * self.dz);
        (u * u + v * v).sqrt()
    }

    /// The border particles in order around the grid (each once): along row 0, up the last
    /// column, back along the last row, down the first column.
    pub fn border_loop(&self) -> Vec<u32> {
        let (nx, nz) = (self.nx, self.nz);
        let mut b = Vec::with_capacity(2 * (nx + nz));
        b.extend((0..nx).map(|i| self.index(i, 0)));
        b.extend((1..nz).map(|j| self.index(nx - 1, j)));
        b.extend((0..nx - 1).rev().map(|i| self.index(i, nz - 1)));
        b.extend((1..nz - 1).rev().map(|j| self.index(0, j)));
        b.into_iter().map(|k| k as u32).collect()
    }

    /// Flat rest positions, centred on `centre`, in the xz plane.
    pub fn rest_positions(&self, centre: Vec3) -> Soa {
        let mut p = Soa::zeros(self.len());
        let (w, d) = (
            self.dx * (self.nx - 1) as Real,
            self.dz * (self.nz - 1) as Real,
        );
        for j in 0..self.nz {
            for i in 0..self.nx {
                let k = self.index(i, j);
                p.set(
                    k,
                    centre
                        + Vec3::new(
                            i as Real * self.dx - 0.5 * w,
                            0.0,
                            j as Real * self.dz - 0.5 * d,
                        ),
                );
            }
        }
        p
    }

    /// Render and volume triangles: two per grid cell, wound so that their normals point +Y
    /// (away from a sticking plane below) in the flat rest state.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        let mut t = Vec::with_capacity(2 * (self.nx - 1) * (self.nz - 1));
        for j in 0..self.nz - 1 {
            for i in 0..self.nx - 1 {
                let a = self.index(i, j) as u32;
                let b = self.index(i + 1, j) as u32;
                let c = self.index(i + 1, j + 1) as u32;
                let d = self.index(i, j + 1) as u32;
                t.push([a, c, b]);
                t.push([a, d, c]);
            }
        }
        t
    }

    /// Texture coordinates of every particle in [0, 1]^2 (u along x, v along z).
    pub fn uvs(&self) -> Vec<[Real; 2]> {
        let mut uv = Vec::with_capacity(self.len());
        for j in 0..self.nz {
            for i in 0..self.nx {
                uv.push([
                    i as Real / (self.nx - 1) as Real,
                    j as Real / (self.nz - 1) as Real,
                ]);
            }
        }
        uv
    }

    /// Smooth vertex normals for rendering and export: the area-weighted sum of the normals of
    /// the triangles around each particle (see [`Grid::triangles`]), normalised.
    pub fn vertex_normals(&self, p: &Soa) -> Vec<Vec3> {
        let mut n = vec![Vec3::ZERO; self.len()];
        for [a, b, c] in self.triangles() {
            let (a, b, c) = (a as usize, b as usize, c as usize);
            let w = (p.get(b) - p.get(a)).cross(p.get(c) - p.get(a));
            n[a] += w;
            n[b] += w;
            n[c] += w;
        }
        for v in &mut n {
            *v = v.normalize_or(Vec3::Y);
        }
        n
    }

    /// Unit normal of particle `k`: the cross product of the central differences along z and x
    /// (one-sided at the border). On a regular grid this is the area-weighted normal of the
    /// surrounding cells, and it points +Y for the flat rest state.
    #[inline]
    pub fn normal(&self, p: &Soa, k: usize) -> Vec3 {
        let (i, j) = (k % self.nx, k / self.nx);
        let tx = p.get(self.index((i + 1).min(self.nx - 1), j))
            - p.get(self.index(i.saturating_sub(1), j));
        let tz = p.get(self.index(i, (j + 1).min(self.nz - 1)))
            - p.get(self.index(i, j.saturating_sub(1)));
        tz.cross(tx).normalize_or_zero()
    }
}
