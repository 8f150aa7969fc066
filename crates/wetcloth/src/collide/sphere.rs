//! The solid sphere.

use super::{SurfaceMesh, require_position};
use crate::error::ConfigError;
use crate::math::{Real, Vec3};

/// Solid sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(from = "SphereRepr", into = "SphereRepr")
)]
pub struct Sphere {
    /// Centre, m. Scene default (0, 0, 0); each component in [-1e6, 1e6].
    pub center: Vec3,
    /// Radius, m. Required; range (0, 1e4].
    pub radius: Real,
}

impl Sphere {
    /// Signed distance of `p` (m, negative inside) and the outward normal (+Y at the centre).
    #[inline]
    pub fn distance(&self, p: Vec3) -> (Real, Vec3) {
        let d = p - self.center;
        let len = d.length();
        let n = if len > 0.0 { d / len } else { Vec3::Y };
        (len - self.radius, n)
    }

    /// A UV sphere: 48 segments around, 24 rings from pole to pole, smooth normals.
    pub fn surface_mesh(&self) -> SurfaceMesh {
        let (seg, rings) = (48u32, 24u32);
        let mut m = SurfaceMesh::default();
        for r in 0..=rings {
            let theta = std::f64::consts::PI * Real::from(r) / Real::from(rings);
            for s in 0..=seg {
                let phi = std::f64::consts::TAU * Real::from(s) / Real::from(seg);
                let n = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                m.positions.push(self.center + n * self.radius);
                m.normals.push(n);
            }
        }
        for r in 0..rings {
            for s in 0..seg {
                let a = r * (seg + 1) + s;
                let b = a + seg + 1;
                m.triangles.push([a, a + 1, b]);
                m.triangles.push([a + 1, b + 1, b]);
            }
        }
        m
    }

    pub(crate) fn validate(&self, key: &dyn Fn(&str) -> String) -> Result<(), ConfigError> {
        require_position(key("center"), self.center)?;
        let r = self.radius;
        if !(r.is_finite() && r > 0.0 && r <= 1e4) {
            return Err(ConfigError::OutOfRange {
                key: key("radius"),
                value: crate::math::num(r),
                range: "(0, 1e4]".into(),
            });
        }
        Ok(())
    }
}

/// `run.json`'s form of a sphere.
#[cfg(feature = "serde")]
#[derive(serde::Serialize, serde::Deserialize)]
struct SphereRepr {
    center: [Real; 3],
    radius: Real,
}

#[cfg(feature = "serde")]
impl From<SphereRepr> for Sphere {
    fn from(r: SphereRepr) -> Self {
        Self {
            center: r.center.into(),
            radius: r.radius,
        }
    }
}

#[cfg(feature = "serde")]
impl From<Sphere> for SphereRepr {
    fn from(s: Sphere) -> Self {
        Self {
            center: s.center.to_array(),
            radius: s.radius,
        }
    }
}
