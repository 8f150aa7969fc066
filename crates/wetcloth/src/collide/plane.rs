//! The infinite plane: the thesis' sticking surface (a desk, a floor), and its vectorised
//! contact row.

use super::require_finite;
use crate::error::ConfigError;
use crate::math::{Real, RowMut, RowRef, Vec3};

/// Infinite plane through `point` with unit `normal`; the solid is on the side opposite to the
/// normal.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(from = "PlaneRepr", into = "PlaneRepr")
)]
pub struct Plane {
    /// A point on the plane, m. Scene default (0, 0, 0); any finite point (a cloth must start
    /// on its outer side, within 1e4 m of the sticking plane: the scene reader checks).
    pub point: Vec3,
    /// Unit normal, pointing out of the solid. Scene default (0, 1, 0); any non-zero vector,
    /// normalised.
    pub normal: Vec3,
}

impl Plane {
    /// Signed distance of `p` (m, negative below) and the normal.
    #[inline]
    pub fn distance(&self, p: Vec3) -> (Real, Vec3) {
        ((p - self.point).dot(self.normal), self.normal)
    }

    pub(crate) fn validate(&self, key: &dyn Fn(&str) -> String) -> Result<(), ConfigError> {
        require_finite(key("point"), self.point)?;
        if !self.normal.is_finite() || (self.normal.length() - 1.0).abs() > 1e-9 {
            return Err(ConfigError::Invalid {
                key: key("normal"),
                message: format!(
                    "must be a finite, non-zero vector (got [{}, {}, {}]; it is normalised)",
                    self.normal.x, self.normal.y, self.normal.z
                ),
            });
        }
        Ok(())
    }
}

/// `run.json`'s form of a plane: arrays of numbers.
#[cfg(feature = "serde")]
#[derive(serde::Serialize, serde::Deserialize)]
struct PlaneRepr {
    point: [Real; 3],
    normal: [Real; 3],
}

#[cfg(feature = "serde")]
impl From<PlaneRepr> for Plane {
    fn from(r: PlaneRepr) -> Self {
        Self {
            point: r.point.into(),
            normal: r.normal.into(),
        }
    }
}

#[cfg(feature = "serde")]
impl From<Plane> for PlaneRepr {
    fn from(p: Plane) -> Self {
        Self {
            point: p.point.to_array(),
            normal: p.normal.to_array(),
        }
    }
}

/// A plane prepared for the vectorised contact row (`contact_row`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlaneContact {
    pub normal: Vec3,
    /// `normal . point + radius`: a particle centre is in contact below this, m.
    pub offset: Real,
    pub friction: Real,
}

impl PlaneContact {
    /// `plane` with friction `friction` for particles of radius `radius` (m).
    pub fn new(plane: &Plane, friction: Real, radius: Real) -> Self {
        Self {
            normal: plane.normal,
            offset: plane.normal.dot(plane.point) + radius,
            friction,
        }
    }
}

/// Contact with one plane for a row, branch-free so it vectorises: the same response as
/// [`super::contact::resolve`] (projection by the depth, then friction removing at most
/// `mu depth` of the tangential step since `here`), computed for every particle with the depth
/// clamped to 0 for those that do not touch. Sets `contact[i]` for those that touch.
#[cfg(test)]
#[inline(always)]
pub(crate) fn contact_row(
    p: &PlaneContact,
    here: RowRef<'_>,
    next: &mut RowMut<'_>,
    contact: &mut [bool],
) {
    contact_row_scaled(p, here, next, contact, None);
}

/// `contact_row` with each particle's friction scaled by `friction_scale[i]` if given.
#[inline(always)]
pub(crate) fn contact_row_scaled(
    p: &PlaneContact,
    here: RowRef<'_>,
    next: &mut RowMut<'_>,
    contact: &mut [bool],
    friction_scale: Option<&[Real]>,
) {
    if let Some(scale) = friction_scale {
        let n = here.x.len();
        for i in 0..n {
            let now = here.get(i);
            let to = Vec3::new(next.x[i], next.y[i], next.z[i]);
            let (to, hit) = plane_contact(p, now, to, scale[i]);
            (next.x[i], next.y[i], next.z[i]) = (to.x, to.y, to.z);
            contact[i] |= hit;
        }
        return;
    }
    let n = here.x.len();
    let (nx, ny, nz) = (p.normal.x, p.normal.y, p.normal.z);
    let (qx, qy, qz) = (&mut next.x[..n], &mut next.y[..n], &mut next.z[..n]);
    for i in 0..n {
        let dist = nx * qx[i] + ny * qy[i] + nz * qz[i] - p.offset;
        let depth = if dist < 0.0 { -dist } else { 0.0 };
        let (mut x, mut y, mut z) = (qx[i] + nx * depth, qy[i] + ny * depth, qz[i] + nz * depth);
        let (dx, dy, dz) = (x - here.x[i], y - here.y[i], z - here.z[i]);
        let dn = dx * nx + dy * ny + dz * nz;
        let (tx, ty, tz) = (dx - nx * dn, dy - ny * dn, dz - nz * dn);
        let slide = (tx * tx + ty * ty + tz * tz).sqrt();
        let grip = p.friction * depth;
        // Share of the tangential step that friction removes: all of it if it can (static),
        // else `grip / slide` (kinetic). Zero when not touching (grip = 0).
        let stop = if slide > grip { grip / slide } else { 1.0 };
        x -= tx * stop;
        y -= ty * stop;
        z -= tz * stop;
        (qx[i], qy[i], qz[i]) = (x, y, z);
        contact[i] |= depth > 0.0;
    }
}

/// One particle's contact with a plane moving from `here` to `next`, friction scaled by
/// `scale`: the scalar form of `contact_row`.
#[inline]
fn plane_contact(p: &PlaneContact, here: Vec3, mut next: Vec3, scale: Real) -> (Vec3, bool) {
    let dist = p.normal.dot(next) - p.offset;
    if dist >= 0.0 {
        return (next, false);
    }
    let depth = -dist;
    next += p.normal * depth;
    let step = next - here;
    let tangential = step - p.normal * step.dot(p.normal);
    let slide = tangential.length();
    let grip = p.friction * scale * depth;
    next -= if slide > grip {
        tangential * (grip / slide)
    } else {
        tangential
    };
    (next, true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collide::{Collider, contact};

    /// The vectorised row gives the scalar response of `contact::resolve`, touching or not,
    /// sticking or sliding, on a tilted plane.
    #[test]
    fn row_contact_matches_the_scalar_response() {
        let c = Collider::plane(Vec3::new(0.0, 0.1, 0.0), Vec3::new(0.2, 1.0, -0.1), 0.4);
        let plane = c.as_plane().unwrap();
        let r = 0.002;
        let pc = PlaneContact::new(plane, c.friction, r);
        let here: Vec<Vec3> = (0..9)
            .map(|i| Vec3::new(0.01 * i as Real, 0.1 + 0.0005 * i as Real, 0.0))
            .collect();
        let next: Vec<Vec3> = here
            .iter()
            .enumerate()
            .map(|(i, h)| *h + Vec3::new(0.0003 * i as Real, -0.002, 0.0001))
            .collect();
        let col = |v: &[Vec3], f: fn(&Vec3) -> Real| v.iter().map(f).collect::<Vec<_>>();
        let (hx, hy, hz) = (
            col(&here, |v| v.x),
            col(&here, |v| v.y),
            col(&here, |v| v.z),
        );
        let (mut qx, mut qy, mut qz) = (
            col(&next, |v| v.x),
            col(&next, |v| v.y),
            col(&next, |v| v.z),
        );
        let mut touched = vec![false; here.len()];
        contact_row(
            &pc,
            RowRef {
                x: &hx,
                y: &hy,
                z: &hz,
            },
            &mut RowMut {
                x: &mut qx,
                y: &mut qy,
                z: &mut qz,
            },
            &mut touched,
        );
        let mut some = [false; 2];
        for i in 0..here.len() {
            let (expect, hit) = contact::resolve(std::slice::from_ref(&c), here[i], next[i], r);
            let got = Vec3::new(qx[i], qy[i], qz[i]);
            assert!((got - expect).length() < 1e-15, "{i}: {got} vs {expect}");
            assert_eq!(touched[i], hit, "{i}");
            some[usize::from(hit)] = true;
        }
        assert!(
            some[0] && some[1],
            "the case should have particles on both sides"
        );
    }
}
