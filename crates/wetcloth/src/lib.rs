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
//! - Cloth (3.1, [`cloth`]): a square grid of equal-mass particles, each joined to its 4 grid
//!   neighbours by structural springs and its 4 diagonal neighbours by shear springs (Hooke,
//!   eq. 3.6, [`forces::spring_force`]); particles are spheres of diameter thickness + margin.
//! - Forces (3.3): gravity (eq. 3.3), springs, optional velocity damping, contact normal force
//!   and Coulomb friction (eq. 3.4-3.5, [`contact`]), the hand (grabs, [`grab`]) and the
//!   pressure force (eq. 3.7, [`forces::pressure_force`]) `(P_b - P_a) S N` with the physical
//!   sign (the atmosphere presses a lifted cloth down).
//! - Air (3.4-3.5, [`air`]): Boyle's law `P_b v = P_a v0` with the bubble volume `v` by eq. 3.10,
//!   signed prisms under every triangle, so folds cancel.
//! - Integration: position Verlet (eq. 3.1) at the thesis' step 1/12000 s.
//! - Self-collision ([`self_collision`]) with a hashed grid and skinned neighbour lists, and
//!   optional Provot strain limiting ([`strain`]).
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
pub mod cloth;
pub mod collider;
pub mod contact;
pub mod error;
mod exec;
pub mod forces;
pub mod grab;
mod kernels;
pub mod math;
pub mod metrics;
pub mod params;
pub mod self_collision;
pub mod sim;
pub mod strain;

pub use cloth::Grid;
pub use collider::{Collider, Shape};
pub use error::{ConfigError, StepError};
pub use grab::{Grab, GrabKey, GrabMotion, GrabSpec};
pub use math::{Real, Soa, Vec3};
pub use metrics::FrameMetrics;
pub use params::{AirParams, ClothParams, Integrator, PressureSolve, SimConfig, SimulationParams};
pub use sim::Simulation;
