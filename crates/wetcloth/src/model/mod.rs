//! What a step reads and never writes (after warp.sim's `Model`): the grid, the particles'
//! masses, radius and area, the border loop, the colliders and the sticking surface. Built
//! once from a [`SimConfig`]; the time-varying state is in [`crate::state`], the user's input
//! in [`crate::control`].

mod grid;

pub use grid::{Grid, Neighbour, STENCIL};

use crate::air::gap::StickingPlane;
use crate::collide::Collider;
use crate::collide::plane::PlaneContact;
use crate::forces::spring::SpringConsts;
use crate::math::{Real, Vec3};
use crate::params::SimConfig;

/// The static description of a simulation.
#[derive(Clone, Debug)]
pub struct Model {
    /// The particle grid and its rest geometry (thesis 3.1).
    pub grid: Grid,
    /// Mass of one particle, kg: the cloth's mass shared equally (thesis 3.1).
    pub particle_mass: Real,
    /// Inverse mass of each particle, 1/kg (0 would hold a particle in place). Integrators and
    /// position corrections weigh moves by it; the thesis' uniform cloth has `1 / particle_mass`
    /// everywhere.
    pub inv_mass: Vec<Real>,
    /// Radius of a particle's collision sphere, m: `(thickness + collision_margin) / 2`.
    pub radius: Real,
    /// Cloth area per particle S, m^2: rest area / particle count (thesis 3.4).
    pub area_per_particle: Real,
    /// Rest area of the whole cloth, m^2.
    pub cloth_area: Real,
    /// Border particles in order around the cloth, each once (for leaks through the border).
    pub border: Vec<u32>,
    /// How the pressure becomes forces on the particles.
    pub pressure_force: crate::params::PressureForce,
    /// Gravitational acceleration, m/s^2 (thesis eq. 3.3).
    pub gravity: Vec3,
    /// Velocity damping rate, 1/s.
    pub damping: Real,
    /// The colliders, in scene order.
    pub colliders: Vec<Collider>,
    /// The sticking surface of the air model (the first plane collider), if any.
    pub sticking: Option<StickingPlane>,
    /// The springs' stiffnesses and rest lengths.
    pub springs: SpringConsts,
    /// Plane colliders prepared for the vectorised contact row.
    pub(crate) planes: Vec<PlaneContact>,
    /// The colliders without a vectorised row (every shape but the plane), answered through
    /// [`Collider::distance`].
    pub(crate) non_planes: Vec<Collider>,
}

impl Model {
    /// The model of a validated configuration.
    pub fn new(config: &SimConfig) -> Self {
        let grid = Grid::new(&config.cloth);
        let n = grid.len();
        let cloth_area = config.cloth.size[0] * config.cloth.size[1];
        let radius = config.cloth.particle_radius();
        let particle_mass = config.cloth.mass / n as Real;
        Self {
            particle_mass,
            inv_mass: vec![1.0 / particle_mass; n],
            radius,
            area_per_particle: cloth_area / n as Real,
            cloth_area,
            border: grid.border_loop(),
            pressure_force: config.air.pressure_force,
            gravity: config.simulation.gravity,
            damping: config.cloth.damping,
            springs: SpringConsts {
                nx: grid.nx,
                nz: grid.nz,
                structural: config.cloth.structural_stiffness,
                shear: config.cloth.shear_stiffness,
                rest_x: grid.dx,
                rest_z: grid.dz,
                rest_diag: grid.dx.hypot(grid.dz),
            },
            colliders: config.colliders.clone(),
            sticking: config.sticking_plane(),
            planes: config
                .colliders
                .iter()
                .filter_map(|c| {
                    c.as_plane()
                        .map(|p| PlaneContact::new(p, c.friction, radius))
                })
                .collect(),
            non_planes: config
                .colliders
                .iter()
                .filter(|c| c.as_plane().is_none())
                .cloned()
                .collect(),
            grid,
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.inv_mass.capacity() * std::mem::size_of::<Real>() + self.border.capacity() * 4
    }
}
