//! # wetcloth: wet cloth that sticks
//!
//! The physics core of wetcloth, after W. Yamada, *Reproducing the behaviour of wet cloth
//! considering atmospheric pressure in 3DCG* (master's thesis, Tokyo University of Technology,
//! 2012). Wet cloth is nearly airtight: the air trapped between it and a surface (the
//! *bubble*) cannot escape, so lifting the cloth lowers the pressure under it and the
//! atmosphere presses it back down.
//!
//! This crate does no I/O: it reads a [`SimConfig`] and steps a [`Simulation`]. Scene files,
//! exporters and the command line live in other crates.
//!
//! ## Units
//!
//! SI throughout: m, kg, s, N, Pa, m^3. Y is up. Every parameter documents its unit, default and
//! valid range (see [`params`]).
//!
//! ## The model (thesis ch. 3)
//!
//! - Cloth (3.1, [`model`]): a square grid of equal-mass particles, each joined to its 4 grid
//!   neighbours by structural springs and its 4 diagonal neighbours by shear springs (Hooke,
//!   eq. 3.6, [`forces::spring_force`]); particles are spheres of diameter thickness + margin.
//! - Forces (3.3, [`forces`]): gravity (eq. 3.3), springs, optional velocity damping, and the
//!   pressure force (eq. 3.7, [`forces::pressure_force`]) `(P_b - P_a) S N` with the physical
//!   sign (the atmosphere presses a lifted cloth down); contact normal force and Coulomb
//!   friction (eq. 3.4-3.5, [`collide::contact`]); the hand (grabs, [`control`]).
//! - Air (3.4-3.5, [`air`]): Boyle's law `P_b v = P_a v0` with the bubble volume `v` by eq. 3.10,
//!   signed prisms under every triangle, so folds cancel.
//! - Integration ([`integrate`]): position Verlet (eq. 3.1) at the thesis' step 1/12000 s.
//! - Self-collision ([`collide::self_collision`]) with a hashed grid and skinned neighbour
//!   lists, and optional Provot strain limiting ([`constraints::strain_limit`]).
//!
//! ## Layout
//!
//! | folder | what | add here |
//! |---|---|---|
//! | [`params`] | the scene's parameters, one file per table; the stability limit | a parameter |
//! | [`model`] | what a step reads and never writes: grid, masses, colliders | |
//! | [`state`] | positions, previous positions or velocities, contacts, step count | |
//! | [`control`] | grabs and their targets, the air switch | |
//! | [`forces`] | one pure law and one row loop per force | a new force |
//! | [`integrate`] | one file per integrator | a new integrator |
//! | [`collide`] | one file per shape, the contact response, self-collision | a new collider |
//! | [`air`] | Boyle, the gap volume, the air models, leaks | a new air model |
//! | [`constraints`] | position corrections (strain limiting) | |
//!
//! The step's phases are listed on [`Simulation::step`].
//!
//! ## Determinism
//!
//! The same configuration gives bit-identical states whatever the number of threads: every
//! particle sums its forces in a fixed order, and reductions (volume, counts) are summed per
//! row and then in row order.
//!
//! ```
//! use wetcloth::{SimConfig, Simulation};
//! let mut cfg = SimConfig::thesis_demo();
//! cfg.cloth.resolution = [10, 10];
//! cfg.grabs.clear();
//! let mut sim = Simulation::new(cfg).unwrap();
//! sim.advance(1200).unwrap(); // 0.1 s
//! // The 400 cm^3 of trapped air stays under the cloth, at about atmospheric pressure.
//! let m = sim.metrics();
//! assert!((m.air_volume - 400e-6).abs() < 4e-6);
//! assert!((m.air_pressure - 101_325.0).abs() < 100.0);
//! ```

pub mod air;
pub mod bench;
pub mod checkpoint;
pub mod checks;
pub mod collide;
pub mod constraints;
pub mod control;
pub mod error;
mod exec;
pub mod forces;
pub mod integrate;
pub mod math;
mod measure;
pub mod metrics;
pub mod model;
pub mod params;
pub mod sim;
pub mod state;

pub use checkpoint::{CHECKPOINT_VERSION, Checkpoint, RestoreError};
pub use collide::{Collider, Shape, Surface, SurfaceMesh};
pub use control::{Control, Grab, GrabKey, GrabMotion, GrabPick, GrabSpec};
pub use error::{ConfigError, StepError};
pub use math::{Real, Soa, Vec3};
pub use metrics::FrameMetrics;
pub use model::{ClothMesh, ClothMeshError, ClothSurface, Grid, Layout, Model};
pub use params::{
    AirModelKind, AirParams, BendingParams, BendingRest, ClothMeshSource, ClothModel, ClothParams,
    Integrator, MembraneParams, PaintShape, PocketSeed, PressureForce, PressureSolve, SimConfig,
    SimulationParams, SolveBudget, WetPaint,
};
pub use sim::Simulation;
pub use state::{Motion, State};
