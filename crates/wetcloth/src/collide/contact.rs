//! Contact with colliders: the normal force and Coulomb friction (thesis eq. 3.4-3.5).
//!
//! The thesis adds, on penetration, "a force according to the depth, then recomputes the move".
//! Over one step of length `dt` a force `F` moves a particle by `F dt^2 / m`, so the force that
//! exactly cancels a penetration of depth `delta` is `F_n = m delta / dt^2` along the normal: it
//! is what eq. 3.4 asks for (it cancels gravity, pressure and springs pressing into the
//! surface), and applying it is the projection `x += delta n`. Friction (eq. 3.5) is then
//! `|F_f| <= mu |F_n|` against the tangential motion of the step, i.e. the tangential move is
//! reduced by at most `mu delta`: if that stops it the particle sticks (static friction),
//! otherwise it slides with the kinetic-friction deceleration. On a slope of angle theta this
//! gives exactly `a = g (sin theta - mu cos theta)`.
//!
//! **Moving colliders** ([`resolve_moving`]) answer in their own moving frame: the particle's
//! start of step is taken into the collider's frame at the start of the step, its predicted
//! position into the frame at the end, and the response above is computed there and mapped
//! back. So friction acts on the motion *relative to the surface*, and a particle resting on a
//! moving plate rides along with it. The collider does work on the cloth: the contact force
//! `F = m dx / dt^2` (`dx` the correction) over the move `u` of the touched surface point during
//! the step, `W = F . u`, which the energy audit counts (see `checks.rs`).
//!
//! **Deforming meshes** (a mesh whose points move) have no one moving frame: the start of the
//! particle's move is carried by the triangle nearest it instead, and the contact point's own
//! move over the step is the surface's (see [`super::deform`]); for a rigid motion of the points
//! that is the rigid frame's answer.

use super::mesh::Sweep;
use super::{Collider, Placement, Shape};
use crate::math::{Real, Vec3};

/// Pushes the particle sphere (radius `radius`, m) predicted at `x` out of every collider and
/// applies Coulomb friction to its motion since `x_old`. Returns the corrected position and
/// whether it touched anything.
#[inline]
pub fn resolve(colliders: &[Collider], x_old: Vec3, x: Vec3, radius: Real) -> (Vec3, bool) {
    resolve_scaled(colliders, x_old, x, radius, 1.0)
}

/// [`resolve`] for a particle whose friction is `friction_scale` times the colliders' (a
/// particle drier than the cloth the friction coefficients describe).
#[inline]
pub fn resolve_scaled(
    colliders: &[Collider],
    x_old: Vec3,
    mut x: Vec3,
    radius: Real,
    friction_scale: Real,
) -> (Vec3, bool) {
    let mut touched = false;
    for c in colliders {
        let Some((d, n)) = c.rest_contact(x_old, x, radius) else {
            continue;
        };
        if d >= radius {
            continue;
        }
        touched = true;
        let depth = radius - d;
        x += n * depth;
        let step = x - x_old;
        let tangential = step - n * step.dot(n);
        let slide = tangential.length();
        let grip = c.friction * friction_scale * depth;
        x -= if slide <= grip {
            tangential
        } else {
            tangential * (grip / slide)
        };
    }
    (x, touched)
}

/// Where a moving collider is at the start and at the end of a step.
#[derive(Clone, Debug)]
pub struct Frames {
    /// Placement at the start of the step.
    pub start: Placement,
    /// Placement at the end of the step.
    pub end: Placement,
    /// A deforming mesh's poses at the step's two ends (in its scene placement, which the
    /// placements above then move).
    pub sweep: Option<Sweep>,
}

impl Frames {
    /// The frames of `collider` over the step from `t` to `t + dt` (s).
    pub fn of(collider: &Collider, t: Real, dt: Real) -> Self {
        Self {
            start: collider.placement_at(t),
            end: collider.placement_at(t + dt),
            sweep: match &collider.shape {
                Shape::Mesh(m) => m.sweep(t, dt),
                _ => None,
            },
        }
    }

    /// Where the surface point nearest `x` (world, m, at the step's start) is at the step's
    /// end: carried rigidly by the placements, and on a deforming mesh by the triangle nearest
    /// it within `reach` (m; farther points see the placements' motion only).
    pub fn carry(&self, collider: &Collider, x: Vec3, reach: Real) -> Vec3 {
        let q = self.start.to_rest(x);
        let q = match (&self.sweep, &collider.shape) {
            (Some(sweep), Shape::Mesh(m)) => m.carry(sweep, q, reach),
            _ => q,
        };
        self.end.to_world(q)
    }

    /// The contact query of a particle moving from `x_old` to `x` (world, m) over the step,
    /// in the collider's moving frame: `None` when the surface is certainly farther than
    /// `reach` (m); else the signed distance and the unit normal (world, at the step's end).
    pub fn contact(
        &self,
        collider: &Collider,
        x_old: Vec3,
        x: Vec3,
        reach: Real,
    ) -> Option<(Real, Vec3)> {
        let (q0, q) = (self.start.to_rest(x_old), self.end.to_rest(x));
        let (d, n) = match (&self.sweep, &collider.shape) {
            (Some(sweep), Shape::Mesh(m)) => {
                let c = m.swept_contact(sweep, q0, q, reach)?;
                (c.distance, c.normal)
            }
            _ => collider.rest_contact(q0, q, reach)?,
        };
        Some((d, self.end.dir_to_world(n)))
    }
}

/// [`resolve_scaled`] for one moving collider `c` at `frames`, in its moving frame (see the
/// module docs), for a particle of mass `mass` (kg) over a step whose forces move a particle
/// by `F step_per_force / m` (`step_per_force` = `dt^2`, s^2). Returns the corrected position,
/// whether it touched, and the work the collider did on the particle (J).
#[inline]
#[allow(clippy::too_many_arguments)] // one particle, its collider and its step
pub fn resolve_moving(
    c: &Collider,
    frames: &Frames,
    x_old: Vec3,
    x: Vec3,
    radius: Real,
    friction_scale: Real,
    mass: Real,
    step_per_force: Real,
) -> (Vec3, bool, Real) {
    if let (Some(sweep), Shape::Mesh(m)) = (&frames.sweep, &c.shape) {
        return resolve_deforming(
            c,
            m,
            sweep,
            frames,
            x_old,
            x,
            radius,
            friction_scale,
            mass,
            step_per_force,
        );
    }
    let q0 = frames.start.to_rest(x_old);
    let mut q = frames.end.to_rest(x);
    let Some((d, n)) = c.rest_contact(q0, q, radius) else {
        return (x, false, 0.0);
    };
    if d >= radius {
        return (x, false, 0.0);
    }
    let depth = radius - d;
    q += n * depth;
    let step = q - q0;
    let tangential = step - n * step.dot(n);
    let slide = tangential.length();
    let grip = c.friction * friction_scale * depth;
    q -= if slide <= grip {
        tangential
    } else {
        tangential * (grip / slide)
    };
    let out = frames.end.to_world(q);
    let surface_move = out - frames.start.to_world(q);
    let work = mass * (out - x).dot(surface_move) / step_per_force;
    (out, true, work)
}

/// [`resolve_moving`] for a deforming mesh `m` (the shape of `c`) over the step `sweep`: the
/// particle's start carried by the surface nearest it (see [`super::deform`]).
#[allow(clippy::too_many_arguments)] // one particle, its collider and its step
fn resolve_deforming(
    c: &Collider,
    m: &super::Mesh,
    sweep: &Sweep,
    frames: &Frames,
    x_old: Vec3,
    x: Vec3,
    radius: Real,
    friction_scale: Real,
    mass: Real,
    step_per_force: Real,
) -> (Vec3, bool, Real) {
    let q0 = frames.start.to_rest(x_old);
    let mut q = frames.end.to_rest(x);
    let Some(hit) = m.swept_contact(sweep, q0, q, radius) else {
        return (x, false, 0.0);
    };
    if hit.distance >= radius {
        return (x, false, 0.0);
    }
    let n = hit.normal;
    let depth = radius - hit.distance;
    q += n * depth;
    let step = q - hit.from;
    let tangential = step - n * step.dot(n);
    let slide = tangential.length();
    let grip = c.friction * friction_scale * depth;
    q -= if slide <= grip {
        tangential
    } else {
        tangential * (grip / slide)
    };
    let out = frames.end.to_world(q);
    let surface_move = out - frames.start.to_world(q - hit.moved);
    let work = mass * (out - x).dot(surface_move) / step_per_force;
    (out, true, work)
}

/// How far (in particle radii) [`project`] searches a mesh for the surface a particle must
/// leave.
const PROJECT_REACH: Real = 16.0;

/// Pushes `x` out of every collider along the normal only (after position corrections such as
/// self-collision, which must not leave a particle inside a collider). A mesh is searched
/// within sixteen radii of `x`, not one: a mesh cloth's self-contact may push a
/// particle deeper into a collider than its radius (a sleeve pinched between arm and
/// shoulder), and the surface it has to leave is then farther than that.
#[inline]
pub fn project(colliders: &[Collider], mut x: Vec3, radius: Real) -> Vec3 {
    for c in colliders {
        if let Some((d, n)) = c.distance_within(x, PROJECT_REACH * radius)
            && d < radius
        {
            x += n * (radius - d);
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn penetration_is_removed_and_static_friction_sticks() {
        let floor = [Collider::plane(Vec3::ZERO, Vec3::Y, 0.5)];
        // Pressed 1 mm in while moving 0.4 mm sideways: grip 0.5 mm stops it.
        let (x, hit) = resolve(
            &floor,
            Vec3::new(0.0, 0.01, 0.0),
            Vec3::new(4e-4, 0.009, 0.0),
            0.01,
        );
        assert!(hit);
        assert!((x - Vec3::new(0.0, 0.01, 0.0)).length() < 1e-15);
        // Moving 2 mm sideways: slides 1.5 mm.
        let (x, _) = resolve(
            &floor,
            Vec3::new(0.0, 0.01, 0.0),
            Vec3::new(2e-3, 0.009, 0.0),
            0.01,
        );
        assert!((x.x - 1.5e-3).abs() < 1e-15 && (x.y - 0.01).abs() < 1e-15);
        // Clear of the plane: untouched.
        let p = Vec3::new(1.0, 0.5, 0.0);
        assert_eq!(resolve(&floor, p, p, 0.01), (p, false));
    }

    /// A particle resting on a plate that moves sideways rides along when friction can hold it
    /// (static friction in the plate's frame), and slides by the grip `mu depth` when not; the
    /// plate does work on it only along its move.
    #[test]
    fn a_particle_rides_a_moving_plate() {
        let plate = |speed: Real| {
            let mut c = Collider::plane(Vec3::ZERO, Vec3::Y, 0.5);
            c.keys = [0.0, 1.0]
                .map(|t| super::super::Key {
                    time: t,
                    offset: Vec3::new(speed * t, 0.0, 0.0),
                    rotation: Vec3::ZERO,
                })
                .to_vec();
            c
        };
        let (r, dt2) = (0.01, 1e-6);
        // Resting at height r, pressed 1e-6 m in over the step: grip 5e-7 m.
        let start = Vec3::new(0.0, r, 0.0);
        let pressed = start - Vec3::Y * 1e-6;
        // The plate moves 1e-7 m in the step: carried along exactly.
        let slow = plate(1e-4);
        let frames = Frames::of(&slow, 0.5, 1e-3);
        let (x, hit, work) = resolve_moving(&slow, &frames, start, pressed, r, 1.0, 1.0, dt2);
        assert!(hit);
        assert!((x - Vec3::new(1e-7, r, 0.0)).length() < 1e-15, "{x}");
        // F = m dx / dt^2 with dx = (1e-7, 1e-6, 0), over the plate's move (1e-7, 0, 0).
        let expected = 1e-7 * 1e-7 / dt2;
        assert!((work - expected).abs() < 1e-9 * expected, "{work}");
        // The plate moves 1e-3 m: the particle slides, dragged by the grip only.
        let fast = plate(1.0);
        let frames = Frames::of(&fast, 0.5, 1e-3);
        let (x, _, _) = resolve_moving(&fast, &frames, start, pressed, r, 1.0, 1.0, dt2);
        assert!((x - Vec3::new(5e-7, r, 0.0)).length() < 1e-15, "{x}");
    }
}
