//! The sticking surface: the plane the air model measures the gap under the cloth against
//! (thesis 3.5), the first plane collider of a scene. It is collider geometry, kept apart from
//! the air model that measures against it and the model and parameters that choose it.

use crate::math::Vec3;

/// The sticking surface the gap is measured against: a plane through `point` with unit normal
/// `up` (out of the solid, towards the cloth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StickingPlane {
    /// A point of the plane, m.
    pub point: Vec3,
    /// Unit normal, out of the solid.
    pub up: Vec3,
}

impl StickingPlane {
    /// The plane through `point` (m) with unit normal `up`.
    pub fn new(point: Vec3, up: Vec3) -> Self {
        Self { point, up }
    }
}
