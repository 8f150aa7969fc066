//! Colliders: static shapes the cloth's particle spheres rest on (thesis 3.1, 3.3).
//!
//! A collider only answers "where is the closest surface point and which way is out": the
//! contact response (normal force and Coulomb friction, thesis eq. 3.4-3.5) lives in
//! [`crate::contact`] and is the same for every shape, so a new shape touches nothing else.

use crate::error::ConfigError;
use crate::math::{Real, Vec3};

/// A collider shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// Infinite plane through `point` with unit `normal` (the solid is on the side opposite to
    /// the normal).
    Plane {
        /// A point on the plane, m. Scene default (0, 0, 0); any finite point.
        point: Vec3,
        /// Unit normal, pointing out of the solid. Scene default (0, 1, 0); any non-zero
        /// vector, normalised.
        normal: Vec3,
    },
    /// Solid sphere.
    Sphere {
        /// Centre, m. Scene default (0, 0, 0); any finite point.
        center: Vec3,
        /// Radius, m. Required; range (0, 1e4].
        radius: Real,
    },
    /// Solid axis-aligned box.
    Box {
        /// Centre, m. Scene default (0, 0, 0); any finite point.
        center: Vec3,
        /// Half extents along x, y, z, m. Required; each > 0.
        half_extents: Vec3,
    },
}

/// A static collider with a Coulomb friction coefficient.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Collider {
    /// The shape.
    pub shape: Shape,
    /// Coulomb friction coefficient mu, one for static and kinetic friction (thesis eq. 3.5).
    /// Default 0.6; range [0, 10].
    pub friction: Real,
}

impl Collider {
    /// A plane through `point` with normal `normal` (normalised here).
    pub fn plane(point: Vec3, normal: Vec3, friction: Real) -> Self {
        Self {
            shape: Shape::Plane {
                point,
                normal: normal.normalize_or_zero(),
            },
            friction,
        }
    }

    /// A solid sphere.
    pub fn sphere(center: Vec3, radius: Real, friction: Real) -> Self {
        Self {
            shape: Shape::Sphere { center, radius },
            friction,
        }
    }

    /// The plane as (point, unit normal), if this collider is one.
    pub fn as_plane(&self) -> Option<(Vec3, Vec3)> {
        match self.shape {
            Shape::Plane { point, normal } => Some((point, normal)),
            _ => None,
        }
    }

    /// Signed distance from `p` to the surface (negative inside) and the outward unit normal at
    /// the closest surface point.
    #[inline]
    pub fn distance(&self, p: Vec3) -> (Real, Vec3) {
        match self.shape {
            Shape::Plane { point, normal } => ((p - point).dot(normal), normal),
            Shape::Sphere { center, radius } => {
                let d = p - center;
                let len = d.length();
                let n = if len > 0.0 { d / len } else { Vec3::Y };
                (len - radius, n)
            }
            Shape::Box {
                center,
                half_extents,
            } => {
                let d = p - center;
                let q = d.abs() - half_extents;
                if q.max_element() > 0.0 {
                    // Outside: distance to the closest point of the box.
                    let outside = q.max(Vec3::ZERO);
                    let len = outside.length();
                    let n = (outside * d.signum()) / len;
                    (len, n)
                } else {
                    // Inside: leave through the nearest face.
                    let axis = if q.x >= q.y && q.x >= q.z {
                        Vec3::X
                    } else if q.y >= q.z {
                        Vec3::Y
                    } else {
                        Vec3::Z
                    };
                    (q.max_element(), axis * d.dot(axis).signum())
                }
            }
        }
    }

    /// Checks the collider's parameters; `index` names it in messages.
    pub fn validate(&self, index: usize) -> Result<(), ConfigError> {
        let key = |k: &str| format!("collider[{index}].{k}");
        if !(self.friction.is_finite() && (0.0..=10.0).contains(&self.friction)) {
            return Err(ConfigError::OutOfRange {
                key: key("friction"),
                value: self.friction.to_string(),
                range: "[0, 10]".into(),
            });
        }
        match self.shape {
            Shape::Plane { point, normal } => {
                if !point.is_finite() {
                    return Err(ConfigError::Invalid {
                        key: key("point"),
                        message: "must be finite".into(),
                    });
                }
                if !normal.is_finite() || (normal.length() - 1.0).abs() > 1e-9 {
                    return Err(ConfigError::Invalid {
                        key: key("normal"),
                        message: "must be a non-zero vector".into(),
                    });
                }
            }
            Shape::Sphere { center, radius } => {
                if !center.is_finite() {
                    return Err(ConfigError::Invalid {
                        key: key("center"),
                        message: "must be finite".into(),
                    });
                }
                if !(radius.is_finite() && radius > 0.0 && radius <= 1e4) {
                    return Err(ConfigError::OutOfRange {
                        key: key("radius"),
                        value: radius.to_string(),
                        range: "(0, 1e4]".into(),
                    });
                }
            }
            Shape::Box {
                center,
                half_extents,
            } => {
                if !center.is_finite() {
                    return Err(ConfigError::Invalid {
                        key: key("center"),
                        message: "must be finite".into(),
                    });
                }
                if !(half_extents.is_finite() && half_extents.min_element() > 0.0) {
                    return Err(ConfigError::OutOfRange {
                        key: key("half_extents"),
                        value: format!(
                            "[{}, {}, {}]",
                            half_extents.x, half_extents.y, half_extents.z
                        ),
                        range: "each component > 0".into(),
                    });
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_distances_match_the_geometry() {
        let plane = Collider::plane(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 2.0, 0.0), 0.5);
        assert_eq!(plane.distance(Vec3::new(3.0, 1.5, -2.0)), (0.5, Vec3::Y));
        let s = Collider::sphere(Vec3::ZERO, 1.0, 0.5);
        let (d, n) = s.distance(Vec3::new(0.0, 0.0, 3.0));
        assert_eq!((d, n), (2.0, Vec3::Z));
        let b = Collider {
            shape: Shape::Box {
                center: Vec3::ZERO,
                half_extents: Vec3::new(1.0, 2.0, 3.0),
            },
            friction: 0.0,
        };
        assert_eq!(b.distance(Vec3::new(0.0, 2.5, 0.0)), (0.5, Vec3::Y));
        let (d, n) = b.distance(Vec3::new(0.9, 0.0, 0.0));
        assert!((d + 0.1).abs() < 1e-12 && n == Vec3::X);
        let (d, n) = b.distance(Vec3::new(4.0, 6.0, 0.0));
        assert!((d - 5.0).abs() < 1e-12 && (n - Vec3::new(0.6, 0.8, 0.0)).length() < 1e-12);
    }
}
