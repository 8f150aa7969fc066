//! What a step reads and never writes (after warp.sim's `Model`): the grid, the particles'
//! masses, radius and area, the border loop, the colliders and the sticking surface. Built
//! once from a [`SimConfig`]; the time-varying state is in [`crate::state`], the user's input
//! in [`crate::control`].

mod cloth_mesh;
#[cfg(test)]
pub(crate) use cloth_mesh::test_square;
mod grid;
mod surface;

pub use cloth_mesh::{ClothMesh, ClothMeshError, MAX_MESH_PARTICLES};
pub use grid::{Grid, Neighbour, STENCIL};
pub use surface::ClothSurface;

use crate::forces::bending::Rigidity;
use crate::forces::fabric::Fabric;
use crate::forces::membrane::Orthotropic;
use crate::forces::mesh_spring::MeshSprings;
use crate::params::{BendingRest, ClothModel, ClothParams};
use std::sync::Arc;

use crate::collide::Collider;
use crate::collide::StickingPlane;
use crate::collide::plane::PlaneContact;
use crate::forces::spring::SpringConsts;
use crate::math::{Real, Soa, Vec3};
use crate::params::SimConfig;

/// The cloth's layout: the built-in grid (its fast paths) or a mesh with its springs.
#[derive(Clone, Copy, Debug)]
pub enum Layout<'a> {
    /// The grid.
    Grid(&'a Grid),
    /// A mesh and its springs.
    Mesh(&'a ClothMesh, &'a MeshSprings),
}

impl Layout<'_> {
    /// Rest distance between particles `a` and `b`, m.
    #[inline]
    pub fn rest_distance(&self, a: usize, b: usize) -> Real {
        match self {
            Layout::Grid(g) => g.rest_distance(a, b),
            Layout::Mesh(m, _) => (m.rest[b] - m.rest[a]).length(),
        }
    }
}

/// The static description of a simulation.
#[derive(Clone, Debug)]
pub struct Model {
    /// The particle grid and its rest geometry (thesis 3.1); `None` for a cloth of any shape
    /// ([`Model::mesh`]).
    pub grid: Option<Grid>,
    /// A cloth of any shape (`[cloth] mesh`): its topology and rest geometry; `None` for the
    /// built-in grid, whose passes read [`Model::grid`].
    pub mesh: Option<Arc<ClothMesh>>,
    /// The springs of a mesh cloth (its edges and across its edges); `None` on the grid.
    /// Under `model = "membrane"` they have no stiffness ([`MeshSprings::none`]).
    pub mesh_springs: Option<Arc<MeshSprings>>,
    /// The membrane and bending elements of `model = "membrane"`; `None` for the springs.
    pub fabric: Option<Arc<Fabric>>,
    /// The built-in grid's particles along x and z (particle `(i, j)` is `j * nx + i`), also
    /// when it runs as a mesh of its triangles (`model = "membrane"`); `None` for a mesh file.
    pub grid_size: Option<[usize; 2]>,
    /// Each particle's area S, m^2, where particles differ (a mesh cloth: a third of each
    /// triangle around it); `None` when every particle has [`Model::area_per_particle`].
    pub areas: Option<Vec<Real>>,
    /// Mass of one particle, kg: the cloth's mass shared equally (thesis 3.1), plus the water
    /// of a uniformly wet cloth (`[cloth] water_mass`). When the cloth is painted with several
    /// wetnesses and holds water, particles differ: see [`Model::masses`].
    pub particle_mass: Real,
    /// Each particle's mass, kg, when they differ (painted wetness with water); `None` when every
    /// particle weighs [`Model::particle_mass`].
    pub masses: Option<Vec<Real>>,
    /// Inverse mass of each particle, 1/kg (0 would hold a particle in place). Integrators and
    /// position corrections weigh moves by it.
    pub inv_mass: Vec<Real>,
    /// Wetness of each particle, 0 (dry) to 1 (soaked): `[cloth] wetness` and its paint.
    pub wetness: Vec<Real>,
    /// Each particle's share of the colliders' friction, `f + (1 - f) w` (`f` the dry friction
    /// factor), when it is not 1 everywhere.
    pub friction_scale: Option<Vec<Real>>,
    /// The water film's suction on a sealed particle at wetness 1, Pa (`[cloth] wet_adhesion`).
    pub wet_adhesion: Real,
    /// Radius of a particle's collision sphere, m: `(thickness + collision_margin) / 2`.
    pub radius: Real,
    /// Cloth area per particle S, m^2: rest area / particle count (thesis 3.4); on a mesh the
    /// mean of [`Model::areas`].
    pub area_per_particle: Real,
    /// Rest area of the whole cloth, m^2.
    pub cloth_area: Real,
    /// Border particles in order around the cloth, each once (for leaks through the border):
    /// loop after loop on a mesh (see [`Model::border_loops`]).
    pub border: Vec<u32>,
    /// Where each boundary loop ends in [`Model::border`] (exclusive): one loop on the grid.
    pub border_ends: Vec<u32>,
    /// How the pressure becomes forces on the particles.
    pub pressure_force: crate::params::PressureForce,
    /// Gravitational acceleration, m/s^2 (thesis eq. 3.3).
    pub gravity: Vec3,
    /// Velocity damping rate, 1/s.
    pub damping: Real,
    /// Largest relative stretch of a structural or shear spring (`[cloth] strain_limit`;
    /// dimensionless, 0.1 = 10 %; default 0 = no limit; valid [0, 10]). The explicit integrator enforces it after the step (Provot, see
    /// [`crate::constraints`]); the implicit one inside its solve, as a spring that stiffens
    /// beyond it (`integrate/implicit.rs`).
    pub strain_limit: Real,
    /// The colliders, in scene order.
    pub colliders: Vec<Collider>,
    /// The sticking surface of the air model (the first plane collider), if any.
    pub sticking: Option<StickingPlane>,
    /// The springs' stiffnesses and rest lengths.
    pub springs: SpringConsts,
    /// Plane colliders prepared for the vectorised contact row.
    pub(crate) planes: Vec<PlaneContact>,
    /// The still colliders without a vectorised row (every shape but the plane), answered
    /// through [`Collider::rest_contact`].
    pub(crate) non_planes: Vec<Collider>,
    /// The moving colliders (with keys), any shape, answered in their moving frame
    /// ([`crate::collide::contact::resolve_moving`]).
    pub(crate) moving: Vec<Collider>,
    /// The scene index of each of `planes`, `non_planes` and `moving`.
    pub(crate) contact_ids: [Vec<u32>; 3],
    /// For each particle, the collider (scene index) it does not collide with, `u32::MAX` for
    /// none: a soft attachment's particles and the collider they are attached to. Empty when
    /// no particle is exempt.
    pub contact_exempt: Vec<u32>,
    /// The seams' pairs (`[[cloth.seam]]`), if any.
    pub seams: Option<crate::forces::seam::Seams>,
}

impl Model {
    /// The model of a validated configuration. A mesh cloth the configuration names must be a
    /// valid [`ClothMesh`] (`SimConfig::validate` checks it).
    pub fn new(config: &SimConfig) -> Self {
        let cloth = &config.cloth;
        let membrane = cloth.model == ClothModel::Membrane;
        let (grid, mesh) = match &cloth.mesh {
            None if membrane => {
                // The membrane takes the grid's triangles: the grid as a mesh.
                let g = Grid::new(cloth);
                let rest = g.rest_positions(cloth.position).to_vec3();
                let mesh = ClothMesh::new(rest, g.triangles()).expect("the grid's triangles");
                (None, Some(Arc::new(mesh)))
            }
            None => (Some(Grid::new(cloth)), None),
            Some(src) => {
                let (triangles, _) = src.triangles();
                let mesh = ClothMesh::new(src.placed(cloth.position), triangles)
                    .expect("a validated configuration's cloth mesh");
                (None, Some(Arc::new(mesh)))
            }
        };
        let n = grid
            .as_ref()
            .map_or_else(|| mesh.as_ref().map_or(0, |m| m.len()), Grid::len);
        let cloth_area = match &mesh {
            None => cloth.size[0] * cloth.size[1],
            Some(m) => m.total_area(),
        };
        // The dry cloth's mass, kg: `mass`, or `density` times the rest area.
        let cloth_mass = cloth.density.map_or(cloth.mass, |d| d * cloth_area);
        let radius = cloth.particle_radius();
        let area_per_particle = cloth_area / n as Real;
        let areas = mesh.as_ref().map(|m| m.area.clone());
        // Wetness at each particle's rest position: on the grid (the springs' or, numbered alike,
        // the membrane's mesh of its triangles) from the cloth's centre; on a mesh cloth in the
        // scene at t = 0.
        let wetness: Vec<Real> = match (&cloth.mesh, &mesh) {
            (None, _) => {
                let rest = grid
                    .clone()
                    .unwrap_or_else(|| Grid::new(cloth))
                    .rest_positions(Vec3::ZERO);
                (0..n)
                    .map(|k| cloth.wetness_at(rest.x[k], rest.z[k]))
                    .collect()
            }
            (Some(_), Some(m)) => m.rest.iter().map(|&p| cloth.wetness_at_point(p)).collect(),
            (Some(_), None) => Vec::new(),
        };
        let uniform = cloth.uniformly_wet();
        // The dry cloth's mass: equal shares on the grid (the thesis), by area on a mesh.
        let dry_share = |k: usize| match &areas {
            None => cloth_mass / n as Real,
            Some(a) => cloth_mass * a[k] / cloth_area,
        };
        let area_of = |k: usize| areas.as_ref().map_or(area_per_particle, |a| a[k]);
        let water = |k: usize, w: Real| cloth.water_mass * w * area_of(k);
        let particle_mass = if cloth.water_mass > 0.0 && uniform {
            cloth_mass / n as Real + cloth.water_mass * cloth.wetness * area_per_particle
        } else {
            cloth_mass / n as Real
        };
        let masses = ((cloth.water_mass > 0.0 && !uniform) || areas.is_some()).then(|| {
            wetness
                .iter()
                .enumerate()
                .map(|(k, &w)| dry_share(k) + water(k, w))
                .collect::<Vec<_>>()
        });
        let inv_mass = match &masses {
            Some(m) => m.iter().map(|m| 1.0 / m).collect(),
            None => vec![1.0 / particle_mass; n],
        };
        let f = cloth.dry_friction_factor;
        let friction_scale = (f != 1.0 && wetness.iter().any(|&w| w != 1.0))
            .then(|| wetness.iter().map(|&w| f + (1.0 - f) * w).collect());
        // The rest shape of the springs and elements: the cloth as placed, scaled by `1 -
        // shrink` (lengths and areas of its rest state; its angles kept).
        let keep = 1.0 - cloth.shrink;
        let shrunk = mesh.as_ref().filter(|_| keep != 1.0).map(|m| {
            ClothMesh::new(
                m.rest.iter().map(|&p| p * keep).collect(),
                m.triangles.clone(),
            )
            .expect("a scaled valid mesh")
        });
        let mechanics = shrunk.as_ref().or(mesh.as_deref());
        let mesh_springs = mechanics.map(|m| {
            Arc::new(if membrane {
                MeshSprings::none(m)
            } else {
                MeshSprings::new(m, cloth.structural_stiffness, cloth.shear_stiffness)
            })
        });
        let fabric = match (mechanics, membrane) {
            (Some(m), true) => Some(Arc::new(fabric_of(cloth, m))),
            _ => None,
        };
        let springs = match &grid {
            Some(grid) => SpringConsts {
                nx: grid.nx,
                nz: grid.nz,
                structural: cloth.structural_stiffness,
                shear: cloth.shear_stiffness,
                rest_x: grid.dx * keep,
                rest_z: grid.dz * keep,
                rest_diag: grid.dx.hypot(grid.dz) * keep,
            },
            None => SpringConsts {
                nx: n,
                nz: 1,
                structural: cloth.structural_stiffness,
                shear: cloth.shear_stiffness,
                rest_x: 0.0,
                rest_z: 0.0,
                rest_diag: 0.0,
            },
        };
        let border = match (&grid, &mesh) {
            (Some(g), _) => g.border_loop(),
            (None, Some(m)) => m.border(),
            (None, None) => Vec::new(),
        };
        let border_ends = match &mesh {
            Some(m) => m
                .boundary
                .iter()
                .scan(0u32, |end, l| {
                    *end += l.len() as u32;
                    Some(*end)
                })
                .collect(),
            None => vec![border.len() as u32],
        };
        let seams = crate::forces::seam::Seams::new(&cloth.seams, |k| match &masses {
            Some(m) => m[k],
            None => particle_mass,
        });
        Self {
            seams,
            border_ends,
            particle_mass,
            masses,
            inv_mass,
            wetness,
            friction_scale,
            wet_adhesion: cloth.wet_adhesion,
            radius,
            area_per_particle,
            areas,
            cloth_area,
            border,
            pressure_force: config.air.pressure_force,
            gravity: config.simulation.gravity,
            damping: config.cloth.damping,
            strain_limit: config.cloth.strain_limit,
            springs,
            colliders: config.colliders.clone(),
            sticking: config.sticking_plane(),
            planes: config
                .colliders
                .iter()
                .filter(|c| !c.is_moving())
                .filter_map(|c| {
                    c.as_plane()
                        .map(|p| PlaneContact::new(p, c.friction, radius))
                })
                .collect(),
            non_planes: config
                .colliders
                .iter()
                .filter(|c| c.as_plane().is_none() && !c.is_moving())
                .cloned()
                .collect(),
            moving: config
                .colliders
                .iter()
                .filter(|c| c.is_moving())
                .cloned()
                .collect(),
            contact_ids: {
                let ids = |keep: &dyn Fn(&Collider) -> bool| {
                    (0..config.colliders.len() as u32)
                        .filter(|&i| keep(&config.colliders[i as usize]))
                        .collect()
                };
                [
                    ids(&|c| !c.is_moving() && c.as_plane().is_some()),
                    ids(&|c| c.as_plane().is_none() && !c.is_moving()),
                    ids(&|c| c.is_moving()),
                ]
            },
            contact_exempt: Vec::new(),
            grid,
            mesh,
            mesh_springs,
            fabric,
            grid_size: cloth.mesh.is_none().then_some(cloth.resolution),
        }
    }

    /// The collider (scene index) particle `k` does not collide with, if any.
    #[inline]
    pub fn exempt_collider(&self, k: usize) -> Option<usize> {
        self.contact_exempt
            .get(k)
            .filter(|&&c| c != u32::MAX)
            .map(|&c| c as usize)
    }

    /// Number of particles.
    #[inline]
    pub fn len(&self) -> usize {
        self.inv_mass.len()
    }

    /// True for a model without particles (never, for a validated configuration).
    pub fn is_empty(&self) -> bool {
        self.inv_mass.is_empty()
    }

    /// The grid of a grid cloth. Panics on a mesh cloth: for the grid's own passes, which a
    /// step chooses only when [`Model::grid`] is `Some`.
    #[inline]
    pub fn grid(&self) -> &Grid {
        self.grid
            .as_ref()
            .expect("a pass of the grid's fast path on a mesh cloth")
    }

    /// The boundary loops of the cloth, each a slice of [`Model::border`] in order.
    pub fn border_loops(&self) -> impl Iterator<Item = &[u32]> {
        let mut start = 0usize;
        self.border_ends.iter().map(move |&end| {
            let l = &self.border[start..end as usize];
            start = end as usize;
            l
        })
    }

    /// Rest distance between particles `a` and `b`, m.
    #[inline]
    pub fn rest_distance(&self, a: usize, b: usize) -> Real {
        self.layout().rest_distance(a, b)
    }

    /// The cloth's layout, for passes that choose their path once.
    #[inline]
    pub fn layout(&self) -> Layout<'_> {
        match (&self.grid, &self.mesh, &self.mesh_springs) {
            (Some(g), _, _) => Layout::Grid(g),
            (None, Some(m), Some(s)) => Layout::Mesh(m, s),
            _ => unreachable!("a model has a grid or a mesh"),
        }
    }

    /// The area S of particle `k`, m^2.
    #[inline]
    pub fn area(&self, k: usize) -> Real {
        self.areas.as_ref().map_or(self.area_per_particle, |a| a[k])
    }

    /// Unit normal of particle `k` at positions `x` (the grid's central differences, or the
    /// mesh's area-weighted triangle normals).
    #[inline]
    pub fn normal(&self, x: &Soa, k: usize) -> Vec3 {
        match (&self.grid, &self.mesh) {
            (Some(g), _) => g.normal(x, k),
            (None, Some(m)) => m.normal(x, k),
            (None, None) => Vec3::ZERO,
        }
    }

    /// The rest positions at t = 0, m: the grid flat in the xz plane centred on `centre`, or the
    /// mesh as placed.
    pub fn rest_positions(&self, centre: Vec3) -> Soa {
        match (&self.grid, &self.mesh) {
            (Some(g), _) => g.rest_positions(centre),
            (None, Some(m)) => m.rest_positions(),
            (None, None) => Soa::zeros(0),
        }
    }

    /// The triangles of the cloth (the grid's two per cell, or the mesh's), wound with the
    /// air below.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        match (&self.grid, &self.mesh) {
            (Some(g), _) => g.triangles(),
            (None, Some(m)) => m.triangles.clone(),
            (None, None) => Vec::new(),
        }
    }

    /// Mass of particle `k`, kg.
    #[inline]
    pub fn mass(&self, k: usize) -> Real {
        self.masses.as_ref().map_or(self.particle_mass, |m| m[k])
    }

    /// Mass of the whole cloth with its water, kg.
    pub fn total_mass(&self) -> Real {
        match &self.masses {
            Some(m) => m.iter().sum(),
            None => self.particle_mass * self.len() as Real,
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let reals = self.inv_mass.capacity()
            + self.wetness.capacity()
            + self.masses.as_ref().map_or(0, Vec::capacity)
            + self.friction_scale.as_ref().map_or(0, Vec::capacity);
        reals * std::mem::size_of::<Real>()
            + self.border.capacity() * 4
            + self.areas.as_ref().map_or(0, |a| a.capacity() * 8)
            + self.mesh.as_ref().map_or(0, |m| m.heap_bytes())
            + self.mesh_springs.as_ref().map_or(0, |s| s.heap_bytes())
            + self.fabric.as_ref().map_or(0, |f| f.heap_bytes())
    }

    /// The elastic energy stored at positions `x`, J: the springs', or the membrane and bending
    /// elements'.
    pub fn elastic_energy(&self, x: &Soa) -> Real {
        let cloth = match (&self.fabric, &self.mesh_springs) {
            (Some(f), _) => f.energy(x),
            (None, Some(s)) => s.energy(x),
            (None, None) => crate::forces::spring::potential_energy(&self.springs, x),
        };
        cloth + self.seams.as_ref().map_or(0.0, |s| s.energy(x))
    }
}

/// The membrane and bending elements of `cloth` on `mesh`: each triangle's warp along its
/// texture coordinates' `dX/du` where the mesh has them, else along the scene's x axis.
fn fabric_of(cloth: &ClothParams, mesh: &ClothMesh) -> Fabric {
    let uvs = cloth.mesh.as_ref().and_then(|m| m.triangle_uvs());
    let warp: Vec<Vec3> = mesh
        .triangles
        .iter()
        .enumerate()
        .map(|(t, tri)| {
            let Some(uv) = uvs.as_ref().and_then(|u| u.get(t)) else {
                return Vec3::X;
            };
            let p = tri.map(|v| mesh.rest[v as usize]);
            let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
            let (du1, dv1) = (uv[1][0] - uv[0][0], uv[1][1] - uv[0][1]);
            let (du2, dv2) = (uv[2][0] - uv[0][0], uv[2][1] - uv[0][1]);
            let det = du1 * dv2 - du2 * dv1;
            if det.abs() <= Real::EPSILON * (du1.abs() + du2.abs()) * (dv1.abs() + dv2.abs()) {
                return Vec3::X;
            }
            // dX/du: the first column of [e1 e2] [[du1, du2], [dv1, dv2]]^-1.
            (e1 * dv2 - e2 * dv1) / det
        })
        .collect();
    let m = &cloth.membrane;
    let b = &cloth.bending;
    Fabric::new(
        mesh,
        &warp,
        Orthotropic::new(m.warp, m.weft, m.shear, m.poisson),
        Rigidity {
            warp: b.stiffness * b.warp,
            weft: b.stiffness * b.weft,
        },
        b.rest == BendingRest::Flat,
    )
}
