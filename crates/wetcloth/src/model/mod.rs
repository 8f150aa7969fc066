//! What a step reads and never writes (after warp.sim's `Model`): the grid, the particles'
//! masses, radius and area, the border loop, the colliders and the sticking surface. Built
//! once from a [`SimConfig`]; the time-varying state is in [`crate::state`], the user's input
//! in [`crate::control`].

mod grid;

pub use grid::{Grid, Neighbour, STENCIL};

use crate::collide::Collider;
use crate::collide::StickingPlane;
use crate::collide::plane::PlaneContact;
use crate::forces::spring::SpringConsts;
use crate::math::{Real, Vec3};
use crate::params::SimConfig;

/// The static description of a simulation.
#[derive(Clone, Debug)]
pub struct Model {
    /// The particle grid and its rest geometry (thesis 3.1).
    pub grid: Grid,
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
}

impl Model {
    /// The model of a validated configuration.
    pub fn new(config: &SimConfig) -> Self {
        let grid = Grid::new(&config.cloth);
        let n = grid.len();
        let cloth_area = config.cloth.size[0] * config.cloth.size[1];
        let radius = config.cloth.particle_radius();
        let cloth = &config.cloth;
        let area_per_particle = cloth_area / n as Real;
        // Wetness at each particle's rest position, relative to the cloth's centre.
        let rest = grid.rest_positions(Vec3::ZERO);
        let wetness: Vec<Real> = (0..n)
            .map(|k| cloth.wetness_at(rest.x[k], rest.z[k]))
            .collect();
        let dry_share = cloth.mass / n as Real;
        let water = |w: Real| cloth.water_mass * w * area_per_particle;
        let uniform = cloth.uniformly_wet();
        let particle_mass = if cloth.water_mass > 0.0 && uniform {
            dry_share + water(cloth.wetness)
        } else {
            dry_share
        };
        let masses = (cloth.water_mass > 0.0 && !uniform).then(|| {
            wetness
                .iter()
                .map(|&w| dry_share + water(w))
                .collect::<Vec<_>>()
        });
        let inv_mass = match &masses {
            Some(m) => m.iter().map(|m| 1.0 / m).collect(),
            None => vec![1.0 / particle_mass; n],
        };
        let f = cloth.dry_friction_factor;
        let friction_scale = (f != 1.0 && wetness.iter().any(|&w| w != 1.0))
            .then(|| wetness.iter().map(|&w| f + (1.0 - f) * w).collect());
        Self {
            particle_mass,
            masses,
            inv_mass,
            wetness,
            friction_scale,
            wet_adhesion: cloth.wet_adhesion,
            radius,
            area_per_particle,
            cloth_area,
            border: grid.border_loop(),
            pressure_force: config.air.pressure_force,
            gravity: config.simulation.gravity,
            damping: config.cloth.damping,
            strain_limit: config.cloth.strain_limit,
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
            grid,
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
            None => self.particle_mass * self.grid.len() as Real,
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let reals = self.inv_mass.capacity()
            + self.wetness.capacity()
            + self.masses.as_ref().map_or(0, Vec::capacity)
            + self.friction_scale.as_ref().map_or(0, Vec::capacity);
        reals * std::mem::size_of::<Real>() + self.border.capacity() * 4
    }
}
