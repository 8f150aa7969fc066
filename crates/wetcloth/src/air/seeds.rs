//! Where the seeded pockets (`[[air.pocket]]`) lie on the cloth at t = 0: which particles each
//! seed holds, and the coordinates its cap is laid out in ([`super::pockets::lift_seeds`]).
//!
//! On the built-in grid (the springs' or the membrane's) a seed is a disc in the cloth's rest
//! coordinates, x and z in metres from its centre, and its cap is laid out in that plane. On a
//! mesh cloth a seed is the ball of its `radius` about a point of the scene at t = 0, and its cap
//! is laid out in the plane through that point across the surface's normal under the seed: for
//! a mesh lying flat on a plane the same disc and cap as on the grid.

use crate::math::{Real, Vec3};
use crate::model::{Grid, Model};
use crate::params::{AirModelKind, SimConfig};

use super::pockets::NONE;

/// The seeds' coordinates of a cloth at t = 0.
#[derive(Clone, Debug, Default)]
pub(crate) struct SeedLayout {
    /// Each particle in the seeds' coordinates, m: the grid's rest position from the cloth's
    /// centre, `(x, 0, z)`, or the mesh as placed in the scene.
    at: Vec<Vec3>,
    /// Each seed's centre in those coordinates, m.
    centre: Vec<Vec3>,
    /// Each particle's seed: the first whose region holds it, or [`NONE`].
    pub seed_of: Vec<u32>,
    /// What bounds the caps' footprints.
    bounds: Bounds,
}

/// What keeps a seed's footprint off the cloth's border.
#[derive(Clone, Debug, Default)]
enum Bounds {
    /// No seeds.
    #[default]
    None,
    /// The grid: its half sizes along x and z and its larger spacing, m.
    Grid { half: [Real; 2], spacing: Real },
    /// A mesh: its border particles and its longest rest edge, m.
    Mesh { border: Vec<u32>, spacing: Real },
}

impl SeedLayout {
    /// The seeds of `config` on the cloth of `model` (built from it). Empty without the pockets
    /// model or seeds: every particle in no seed.
    pub(crate) fn new(config: &SimConfig, model: &Model) -> Self {
        let air = &config.air;
        let n = model.len();
        if air.model != AirModelKind::Pockets || air.pockets.is_empty() {
            return Self {
                seed_of: vec![NONE; n],
                ..Self::default()
            };
        }
        let (at, centre, bounds) = match &config.cloth.mesh {
            None => {
                // The grid, run as itself or (the membrane) as a mesh of its triangles, numbered
                // alike: its rest positions from its centre.
                let grid = model
                    .grid
                    .clone()
                    .unwrap_or_else(|| Grid::new(&config.cloth));
                let rest = grid.rest_positions(Vec3::ZERO);
                let centre = air
                    .pockets
                    .iter()
                    .map(|s| Vec3::new(s.center[0], 0.0, s.center[1]))
                    .collect();
                let half = [
                    0.5 * grid.dx * (grid.nx - 1) as Real,
                    0.5 * grid.dz * (grid.nz - 1) as Real,
                ];
                let spacing = grid.dx.max(grid.dz);
                (rest.to_vec3(), centre, Bounds::Grid { half, spacing })
            }
            Some(_) => {
                let mesh = model
                    .mesh
                    .as_ref()
                    .expect("a mesh cloth's model has its mesh");
                let centre = air
                    .pockets
                    .iter()
                    .map(|s| s.point.unwrap_or_default())
                    .collect();
                let spacing = mesh
                    .edges
                    .iter()
                    .map(|&[a, b]| (mesh.rest[b as usize] - mesh.rest[a as usize]).length())
                    .fold(0.0, Real::max);
                let border = model.border.clone();
                (mesh.rest.clone(), centre, Bounds::Mesh { border, spacing })
            }
        };
        let mut layout = Self {
            at,
            centre,
            seed_of: Vec::new(),
            bounds,
        };
        // Once per particle: particles x seeds (asking again per seed cost seeds^2 x particles:
        // 20 000 seeds took 30 s before the first step).
        layout.seed_of = (0..n)
            .map(|k| {
                air.pockets
                    .iter()
                    .enumerate()
                    .position(|(d, s)| layout.offset(k, d).length_squared() <= s.radius * s.radius)
                    .map_or(NONE, |d| d as u32)
            })
            .collect();
        layout
    }

    /// Whether the cloth is a mesh (not the grid).
    pub(crate) fn on_mesh(&self) -> bool {
        matches!(self.bounds, Bounds::Mesh { .. })
    }

    /// Particle `k` from seed `d`'s centre, m.
    #[inline]
    pub(crate) fn offset(&self, k: usize, d: usize) -> Vec3 {
        self.at[k] - self.centre[d]
    }

    /// Seed `a`'s centre from seed `b`'s, m.
    pub(crate) fn between(&self, a: usize, b: usize) -> Vec3 {
        self.centre[a] - self.centre[b]
    }

    /// The widest footprint seed `d` may have, m: its centre's distance to the cloth's border
    /// less two spacings (the grid: the nearest edge of its rectangle, its larger spacing; a
    /// mesh: the nearest border particle, its longest edge; unbounded for a closed mesh).
    pub(crate) fn room(&self, d: usize) -> Real {
        let c = self.centre[d];
        match &self.bounds {
            Bounds::None => 0.0,
            Bounds::Grid { half, spacing } => {
                (half[0] - c.x.abs()).min(half[1] - c.z.abs()) - 2.0 * spacing
            }
            Bounds::Mesh { border, spacing } => {
                let nearest = border
                    .iter()
                    .map(|&b| (self.at[b as usize] - c).length_squared())
                    .fold(Real::INFINITY, Real::min);
                nearest.sqrt() - 2.0 * spacing
            }
        }
    }

    /// The part of `offset` (from a seed's centre, m) across `normal`, the surface's unit normal
    /// under the seed: the cap's radial offset. On the grid, `offset` itself (the rest plane).
    #[inline]
    pub(crate) fn across(&self, offset: Vec3, normal: Vec3) -> Vec3 {
        if self.on_mesh() {
            offset - normal * offset.dot(normal)
        } else {
            offset
        }
    }
}
