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

use super::Collider;
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
        let (d, n) = c.distance(x);
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

/// Pushes `x` out of every collider along the normal only (after position corrections such as
/// self-collision, which must not leave a particle inside a collider).
#[inline]
pub fn project(colliders: &[Collider], mut x: Vec3, radius: Real) -> Vec3 {
    for c in colliders {
        let (d, n) = c.distance(x);
        if d < radius {
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
}
