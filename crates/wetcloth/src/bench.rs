//! The benchmark workload (thesis table 4.2): the thesis' model with everything on, a cloth
//! lying on and settling onto the plane.

use crate::collide::Collider;
use crate::math::{Real, Vec3};
use crate::params::SimConfig;

/// The thesis cloth's particle spacing, m (30 cm over 49 gaps).
pub const THESIS_SPACING: Real = 0.30 / 49.0;
/// The thesis cloth's particle mass, kg (20 g over 2500 particles).
pub const THESIS_PARTICLE_MASS: Real = 0.02 / 2500.0;

/// The benchmark scene for `side x side` particles: the thesis' spacing and particle mass (a
/// larger cloth, not a finer one, so the same 1/12000 s step stays stable), 8-neighbour springs,
/// gravity, plane contact with friction, the air-pressure force with its volume, and
/// self-collision, starting 2 mm above the plane so it settles onto it.
pub fn thesis_workload(side: usize) -> SimConfig {
    let mut cfg = SimConfig {
        colliders: vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.6)],
        ..Default::default()
    };
    let extent = THESIS_SPACING * (side - 1) as Real;
    cfg.cloth.resolution = [side, side];
    cfg.cloth.size = [extent, extent];
    cfg.cloth.mass = THESIS_PARTICLE_MASS * (side * side) as Real;
    cfg.cloth.position = Vec3::new(0.0, 0.002, 0.0);
    cfg.cloth.self_collision = true;
    cfg.cloth.damping = 2.0;
    cfg.air.enabled = true;
    cfg.air.trapped_air = 0.0;
    cfg
}
