//! Position corrections after the integrator: constraints the step enforces on the new
//! positions.

pub mod strain_limit;
