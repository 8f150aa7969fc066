//! The solid axis-aligned box (scene `shape = "box"`).

use super::{SurfaceMesh, require_position};
use crate::error::ConfigError;
use crate::math::{Real, Vec3};

/// Solid axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(from = "CuboidRepr", into = "CuboidRepr")
)]
pub struct Cuboid {
    /// Centre, m. Scene default (0, 0, 0); each component in [-1e6, 1e6].
    pub center: Vec3,
    /// Half extents along x, y, z, m. Required; each in (0, 1e4].
    pub half_extents: Vec3,
}

impl Cuboid {
    /// Signed distance of `p` (m, negative inside) and the outward normal at the closest
    /// surface point; from inside, the way out through the nearest face.
    #[inline]
    pub fn distance(&self, p: Vec3) -> (Real, Vec3) {
        let d = p - self.center;
        let q = d.abs() - self.half_extents;
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

    /// Six flat faces of four vertices each (face normals).
    pub fn surface_mesh(&self) -> SurfaceMesh {
        let mut m = SurfaceMesh::default();
        let h = self.half_extents.abs();
        for axis in 0..3 {
            for sign in [-1.0, 1.0] {
                // The face's normal and two tangents with t1 x t2 = n (front side out).
                let mut n = Vec3::ZERO;
                n[axis] = sign;
                let mut t1 = Vec3::ZERO;
                t1[(axis + 1) % 3] = 1.0;
                let t2 = n.cross(t1);
                let base = m.positions.len() as u32;
                for (u, v) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    m.positions.push(self.center + (n + t1 * u + t2 * v) * h);
                    m.normals.push(n);
                }
                m.triangles.push([base, base + 1, base + 2]);
                m.triangles.push([base, base + 2, base + 3]);
            }
        }
        m
    }

    pub(crate) fn validate(&self, key: &dyn Fn(&str) -> String) -> Result<(), ConfigError> {
        require_position(key("center"), self.center)?;
        let h = self.half_extents;
        if !(h.is_finite() && h.min_element() > 0.0 && h.max_element() <= 1e4) {
            return Err(ConfigError::OutOfRange {
                key: key("half_extents"),
                value: crate::math::num3(h),
                range: "each component in (0, 1e4]".into(),
            });
        }
        Ok(())
    }
}

/// `run.json`'s form of a box.
#[cfg(feature = "serde")]
#[derive(serde::Serialize, serde::Deserialize)]
struct CuboidRepr {
    center: [Real; 3],
    half_extents: [Real; 3],
}

#[cfg(feature = "serde")]
impl From<CuboidRepr> for Cuboid {
    fn from(r: CuboidRepr) -> Self {
        Self {
            center: r.center.into(),
            half_extents: r.half_extents.into(),
        }
    }
}

#[cfg(feature = "serde")]
impl From<Cuboid> for CuboidRepr {
    fn from(c: Cuboid) -> Self {
        Self {
            center: c.center.to_array(),
            half_extents: c.half_extents.to_array(),
        }
    }
}
