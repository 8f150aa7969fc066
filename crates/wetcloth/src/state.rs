//! The state of a simulation: what changes every step.
//!
//! Positions, and either the positions one step earlier (position Verlet, thesis eq. 3.1) or
//! the velocities (integrators that carry them); which one is the integrator's choice, and
//! [`State::velocity`] / [`State::set_velocities`] convert, so no caller rebuilds Verlet's
//! previous positions itself.

use crate::math::{Real, Soa, Vec3};

/// How the state carries the particles' motion.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Motion {
    /// Positions one step earlier, m (position Verlet): the velocity is `(x - prev) / dt`.
    Previous(Soa),
    /// Velocities, m/s.
    Velocity(Soa),
}

/// How a particle's contact with a collider ended a step of the implicit integrator (see
/// `integrate::implicit`'s `Constraint::Normal`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Slide {
    /// Not sliding: held by static friction, free, or not stepped by the implicit integrator.
    #[default]
    None,
    /// Sliding against Coulomb's kinetic friction of this magnitude, N.
    Kinetic(Real),
    /// Sliding against a drag of this rate, N per m/s: a slide friction stopped within the
    /// step, moving on more slowly.
    Drag(Real),
}

/// Positions, motion, contact flags and the step count.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct State {
    /// Particle positions, m.
    pub x: Soa,
    /// The particles' motion.
    pub motion: Motion,
    /// Whether each particle touched a collider during the last step.
    pub contact: Vec<bool>,
    /// How each particle's contact with a collider ended the last step (`Slide::None` where it
    /// was held, free, or stepped by the explicit integrator): the implicit step starts a
    /// contact that was sliding, and still moves, sliding against the friction it had.
    pub slides: Vec<Slide>,
    /// Each particle's mean acceleration over the last step of the implicit integrator, m/s^2
    /// (zero at rest; the explicit integrator leaves it as it was): the interactive solve
    /// budget's first guess of the next step's velocity is the velocity now plus this times the
    /// step.
    pub acceleration: Soa,
    /// Steps taken since t = 0.
    pub steps: u64,
}

impl State {
    /// Particles at rest at `x`, in Verlet's form (previous positions equal to `x`).
    pub fn at_rest(x: Soa) -> Self {
        let n = x.len();
        Self {
            motion: Motion::Previous(x.clone()),
            x,
            contact: vec![false; n],
            slides: vec![Slide::None; n],
            acceleration: Soa::zeros(n),
            steps: 0,
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// True when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Velocity of particle `k`, m/s, for a step of `dt` s.
    #[inline]
    pub fn velocity(&self, k: usize, dt: Real) -> Vec3 {
        match &self.motion {
            Motion::Previous(p) => (self.x.get(k) - p.get(k)) / dt,
            Motion::Velocity(v) => v.get(k),
        }
    }

    /// All velocities, m/s.
    pub fn velocities(&self, dt: Real) -> Soa {
        match &self.motion {
            Motion::Previous(_) => Soa::from_vec3(
                &(0..self.len())
                    .map(|k| self.velocity(k, dt))
                    .collect::<Vec<_>>(),
            ),
            Motion::Velocity(v) => v.clone(),
        }
    }

    /// Positions one step of `dt` earlier, m: Verlet's previous positions, or `x - v dt`.
    pub fn previous_positions(&self, dt: Real) -> Soa {
        match &self.motion {
            Motion::Previous(p) => p.clone(),
            Motion::Velocity(v) => Soa::from_vec3(
                &(0..self.len())
                    .map(|k| self.x.get(k) - v.get(k) * dt)
                    .collect::<Vec<_>>(),
            ),
        }
    }

    /// Sets the velocities (m/s), keeping the representation: Verlet's previous positions
    /// become `x - v dt`.
    pub fn set_velocities(&mut self, v: &Soa, dt: Real) {
        match &mut self.motion {
            Motion::Previous(p) => {
                for k in 0..self.x.len() {
                    p.set(k, self.x.get(k) - v.get(k) * dt);
                }
            }
            Motion::Velocity(w) => w.clone_from(v),
        }
    }

    /// Switches to carrying velocities (for a step of `dt` s).
    pub fn use_velocities(&mut self, dt: Real) {
        if matches!(self.motion, Motion::Previous(_)) {
            self.motion = Motion::Velocity(self.velocities(dt));
        }
    }

    /// Switches to carrying Verlet's previous positions (for a step of `dt` s).
    pub fn use_previous_positions(&mut self, dt: Real) {
        if matches!(self.motion, Motion::Velocity(_)) {
            self.motion = Motion::Previous(self.previous_positions(dt));
        }
    }

    /// Kinetic energy, J, of particles of mass `mass` (kg) for a step of `dt` s.
    pub fn kinetic_energy(&self, mass: Real, dt: Real) -> Real {
        match &self.motion {
            Motion::Previous(p) => {
                let v2: Real = (0..self.len())
                    .map(|k| (self.x.get(k) - p.get(k)).length_squared())
                    .sum();
                0.5 * mass * v2 / (dt * dt)
            }
            Motion::Velocity(v) => {
                let v2: Real = (0..self.len()).map(|k| v.get(k).length_squared()).sum();
                0.5 * mass * v2
            }
        }
    }

    /// Kinetic energy, J, of particles of equal mass `mass` (kg), or of masses `masses` (kg,
    /// one per particle) when given.
    pub fn kinetic_energy_with(&self, masses: Option<&[Real]>, mass: Real, dt: Real) -> Real {
        match masses {
            Some(m) => self.kinetic_energy_of(|k| m[k], dt),
            None => self.kinetic_energy(mass, dt),
        }
    }

    /// Kinetic energy, J, of particles of masses `mass(k)` (kg), with the velocities of
    /// [`State::velocity`] (`dt`, s, the step of Verlet's previous positions).
    pub fn kinetic_energy_of(&self, mass: impl Fn(usize) -> Real, dt: Real) -> Real {
        match &self.motion {
            Motion::Previous(p) => {
                let v2: Real = (0..self.len())
                    .map(|k| mass(k) * (self.x.get(k) - p.get(k)).length_squared())
                    .sum();
                0.5 * v2 / (dt * dt)
            }
            Motion::Velocity(v) => {
                let v2: Real = (0..self.len())
                    .map(|k| mass(k) * v.get(k).length_squared())
                    .sum();
                0.5 * v2
            }
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let motion = match &self.motion {
            Motion::Previous(s) | Motion::Velocity(s) => s.heap_bytes(),
        };
        self.x.heap_bytes() + motion + self.contact.capacity()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Verlet's previous positions and velocities convert both ways to round-off.
    #[test]
    fn velocities_and_previous_positions_convert_both_ways() {
        let x = Soa::from_vec3(&[Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1.0, 0.5, 0.0)]);
        let mut s = State::at_rest(x);
        let v = Soa::from_vec3(&[Vec3::new(0.1, -0.2, 0.3), Vec3::new(2.0, 0.0, -1.0)]);
        let dt = 1e-3;
        s.set_velocities(&v, dt);
        for k in 0..2 {
            assert!((s.velocity(k, dt) - v.get(k)).length() < 1e-12);
        }
        let e = s.kinetic_energy(0.5, dt);
        s.use_velocities(dt);
        assert!((s.kinetic_energy(0.5, dt) - e).abs() < 1e-12 * e);
        s.use_previous_positions(dt);
        for k in 0..2 {
            assert!((s.velocity(k, dt) - v.get(k)).length() < 1e-12);
        }
    }
}
