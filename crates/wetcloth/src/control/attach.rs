//! Attachments (scene `[[attach]]`): cloth particles bound to a collider at t = 0 that follow
//! it, a hem sewn to a moving body.
//!
//! Each attached particle is bound where it is at t = 0:
//!
//! - on a deforming mesh, to the triangle nearest it (in the mesh's frame at t = 0): as
//!   `a + s e1 + t e2 + h n` over that triangle's corner `a`, edges `e1`, `e2` and unit normal
//!   `n`, so it keeps its barycentric place and its offset along the normal as the triangle
//!   moves, stretches and turns;
//! - on any other collider (a plane, sphere, box or a mesh that does not deform), to the
//!   collider's moving frame (its keys): the point of its rest frame it was at.
//!
//! A hard attachment (no `stiffness`) holds its particles on their points as a hand holds
//! what it grabs: each is a grab ([`super::Grab`]) whose target at every step is its point
//! then, so it does not collide with anything while held, and the force that holds it is
//! reported as a hand's (`attach_force` in `metrics.csv`, `attachments.csv`).
//!
//! A soft attachment (`stiffness = k`, N/m per particle) pulls each of its particles towards
//! its point by a zero-length spring, `F = k (p(t) - x)`, a [`Tether`]: explicit in the Verlet
//! step (the point at the step's start), implicit in the implicit step (the point at its end,
//! `k` in the system matrix), so a stiff one is stable at large steps. The particles stay free
//! otherwise and do not collide with the collider they are attached to
//! ([`crate::Model::contact_exempt`]; they collide with the others). Its force is reported as a hard one's, and
//! its work on the cloth counts as a hand's in the energy audit. A mesh cloth's only (or the
//! grid with `model = "membrane"`).

use crate::collide::{Collider, Shape};
use crate::error::ConfigError;
use crate::math::{Real, Vec3};

use super::GrabPick;

/// An attachment as a scene gives it (`[[attach]]`).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct AttachSpec {
    /// The collider, 0-based in the scene's order (scene `collider`).
    pub collider: usize,
    /// The particles, chosen as a grab's (`vertex`, `near` or `within`).
    pub pick: GrabPick,
    /// Stiffness of each particle's spring to its point, N/m (scene `stiffness`); `None` (the
    /// default) holds the particles exactly on their points. Range (0, 1e7].
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub stiffness: Option<Real>,
}

impl AttachSpec {
    /// Checks the attachment against the scene's `colliders` count; `index` names it.
    pub fn validate(&self, index: usize, colliders: usize) -> Result<(), ConfigError> {
        if self.collider >= colliders {
            return Err(ConfigError::OutOfRange {
                key: format!("attach[{index}].collider"),
                value: self.collider.to_string(),
                range: if colliders == 0 {
                    "a collider's index, but the scene has no colliders".into()
                } else {
                    format!("[0, {}] (the scene's colliders, 0-based)", colliders - 1)
                },
            });
        }
        if let Some(k) = self.stiffness
            && !(k.is_finite() && k > 0.0 && k <= 1e7)
        {
            return Err(ConfigError::OutOfRange {
                key: format!("attach[{index}].stiffness"),
                value: crate::math::num(k),
                range: "(0, 1e7] N/m per particle; leave it out for a hard attachment".into(),
            });
        }
        Ok(())
    }
}

/// Where an attached particle is bound on its collider.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Binding {
    /// A point of the collider's rest frame (moved by its keys), m.
    Frame(Vec3),
    /// A deforming mesh's triangle (its index in the mesh's queries) and the particle's place
    /// over it at t = 0 (edge weights `s`, `t` and the offset `h` along its unit normal, m,
    /// in the mesh's scaled frame).
    Triangle {
        /// Triangle.
        tri: u32,
        /// Weight of the first edge.
        s: Real,
        /// Weight of the second edge.
        t: Real,
        /// Offset along the unit normal, m.
        h: Real,
    },
}

/// One attached particle's binding: which `[[attach]]` it belongs to, the collider, and where.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Attachment {
    /// The `[[attach]]` index.
    pub attach: u32,
    /// The collider's index.
    pub collider: u32,
    /// Where the particle is bound.
    pub binding: Binding,
}

/// A particle of a soft attachment: its spring to its point on the collider.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Tether {
    /// The particle.
    pub particle: usize,
    /// Its binding.
    pub attachment: Attachment,
    /// The spring's stiffness, N/m.
    pub stiffness: Real,
    /// Its point at the step's start and end, m (set as each step begins).
    pub points: [Vec3; 2],
    /// The spring's force on the particle during the last step, N.
    pub force: Vec3,
}

impl Tether {
    /// The spring's force on the particle at `x` towards `point`, N.
    #[inline]
    pub fn pull(&self, x: Vec3, point: Vec3) -> Vec3 {
        (point - x) * self.stiffness
    }
}

/// The binding of the point `x` (m, at t = 0) on `collider`.
pub fn bind(collider: &Collider, x: Vec3) -> Binding {
    let rest = collider.placement_at(0.0).to_rest(x);
    if let Shape::Mesh(m) = &collider.shape
        && let Some(d) = m.deform()
    {
        let (tri, s, t, h) = d.bind(&d.pose(0.0), m.to_mesh_frame(rest));
        return Binding::Triangle { tri, s, t, h };
    }
    Binding::Frame(rest)
}

/// Where `binding` on `collider` is at time `t` (s), m.
pub fn place(collider: &Collider, binding: &Binding, t: Real) -> Vec3 {
    let rest = match (binding, &collider.shape) {
        (Binding::Frame(p), _) => *p,
        (&Binding::Triangle { tri, s, t: w, h }, Shape::Mesh(m)) => match m.deform() {
            Some(d) => m.from_mesh_frame(d.place(&d.pose(t), tri, s, w, h)),
            None => return Vec3::ZERO,
        },
        _ => return Vec3::ZERO,
    };
    collider.placement_at(t).to_world(rest)
}
