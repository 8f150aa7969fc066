//! The forces of the thesis (3.3, eq. 3.2): one pure law per force and the row loop that
//! applies it over the grid stencil.
//!
//! | force | law | row loop | thesis |
//! |---|---|---|---|
//! | springs | [`spring_force`] | `spring::RowSprings`, `spring::add_row` | eq. 3.6 |
//! | gravity and velocity damping | [`gravity::weight_and_damping`] | `gravity::set_row` | eq. 3.3 |
//! | springs on a mesh cloth | `mesh_spring::MeshSprings::force` | `MeshSprings::force_on` | eq. 3.6 |
//! | seams (zero-length springs between panels) | `seam::Seams::force` | `Seams::add_forces` | (garments) |
//! | air pressure | [`pressure_force`] | `pressure::add_row` | eq. 3.7 (physical sign) |
//!
//! The normal force and friction (eq. 3.4-3.5) are position corrections, in
//! [`crate::collide::contact`]; the hand (F_u) is in [`crate::control`].
//!
//! Row loops write over structure-of-arrays slices with no branches in their inner loops, so
//! the compiler vectorises them across the particles of a row. Every particle adds its terms in
//! a fixed order, so the result does not depend on how rows are split between threads.

pub mod bending;
pub mod fabric;
pub mod gravity;
pub mod membrane;
pub mod mesh_spring;
pub mod pressure;
pub mod seam;
pub mod spring;

pub use pressure::pressure_force;
pub use spring::spring_force;
