//! Grabs: the user's hand (thesis 3.2 step 3, force F_u).
//!
//! A grabbed particle is moved kinematically: its velocity and force are cancelled and it is
//! given the velocity that carries it to its target in one step, exactly as the thesis' step
//! (fig. 3.4). The force the hand exerts on the cloth is what makes that motion happen:
//! `F_hand = m (x(t+dt) - 2 x(t) + x(t-dt)) / dt^2 - F`, with `F` the sum of every other force
//! on the particle. With the air force on, this is the suction a hand must overcome.

use crate::error::ConfigError;
use crate::math::{Real, Vec3};

/// One keyframe of a grab path.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct GrabKey {
    /// Time of the key, s (>= 0, strictly increasing along a path).
    pub time: Real,
    /// Offset from where the particle was when the grab began (at the first key), m.
    pub offset: Vec3,
}

/// A keyframed grab as a scene file gives it (`[[grab]]`).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct GrabSpec {
    /// Grid index (column along x, row along z), 0-based (`particle = [i, j]`; the grid only).
    /// Unused when [`GrabSpec::pick`] names the particles.
    pub particle: [usize; 2],
    /// Which particles it holds, when not `particle`: a vertex, the particle nearest a point,
    /// or every particle inside a ball or a box (at t = 0). `None`: `particle`.
    pub pick: Option<GrabPick>,
    /// Path keys, linear in between; the particle is free before the first key and held at the
    /// last key's position after it.
    pub keys: Vec<GrabKey>,
}

/// The particles a grab holds (`[[grab]]` takes exactly one of `particle`, `vertex`, `near` and
/// `within`).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum GrabPick {
    /// `vertex = K`: particle `K` (0-based; the mesh file's vertex, or `j * nx + i` on the grid).
    Vertex(usize),
    /// `near = [x, y, z]`: the particle nearest this point (m) at t = 0, ties to the lowest index.
    Near(Vec3),
    /// `within = { center, radius }`: every particle inside the ball (m) at t = 0.
    Ball {
        /// Centre, m.
        center: Vec3,
        /// Radius, m.
        radius: Real,
    },
    /// `within = { center, half_size }`: every particle inside the box (m) at t = 0.
    Box {
        /// Centre, m.
        center: Vec3,
        /// Half sizes along x, y, z, m.
        half_size: Vec3,
    },
}

impl GrabPick {
    /// The particles picked among positions `x` (m, at t = 0), in increasing order; empty if
    /// none (a vertex out of range, or no particle inside).
    pub fn particles(&self, x: &crate::math::Soa) -> Vec<usize> {
        let n = x.len();
        match *self {
            GrabPick::Vertex(k) => (k < n).then_some(k).into_iter().collect(),
            GrabPick::Near(p) => {
                let mut best: Option<(Real, usize)> = None;
                for k in 0..n {
                    let d = (x.get(k) - p).length_squared();
                    if best.is_none_or(|(b, _)| d < b) {
                        best = Some((d, k));
                    }
                }
                best.map(|(_, k)| k).into_iter().collect()
            }
            GrabPick::Ball { center, radius } => (0..n)
                .filter(|&k| (x.get(k) - center).length_squared() <= radius * radius)
                .collect(),
            GrabPick::Box { center, half_size } => (0..n)
                .filter(|&k| {
                    let d = (x.get(k) - center).abs();
                    d.x <= half_size.x && d.y <= half_size.y && d.z <= half_size.z
                })
                .collect(),
        }
    }
}

impl GrabSpec {
    /// Grabs `particle` at `t0` and lifts it straight up by `height` (m), reaching it at `t1`.
    pub fn lift(particle: [usize; 2], t0: Real, t1: Real, height: Real) -> Self {
        Self {
            particle,
            pick: None,
            keys: vec![
                GrabKey {
                    time: t0,
                    offset: Vec3::ZERO,
                },
                GrabKey {
                    time: t1,
                    offset: Vec3::new(0.0, height, 0.0),
                },
            ],
        }
    }

    /// The path's offset at time `t`, or `None` before the first key.
    pub fn offset_at(&self, t: Real) -> Option<Vec3> {
        let first = self.keys.first()?;
        if t < first.time {
            return None;
        }
        let i = self.keys.partition_point(|k| k.time <= t);
        if i >= self.keys.len() {
            return Some(self.keys[self.keys.len() - 1].offset);
        }
        let (a, b) = (self.keys[i - 1], self.keys[i]);
        let s = (t - a.time) / (b.time - a.time);
        Some(a.offset.lerp(b.offset, s))
    }

    /// Checks the grab against the cloth's resolution; `index` names it in messages.
    pub fn validate(&self, index: usize, resolution: [usize; 2]) -> Result<(), ConfigError> {
        let key = |k: &str| format!("grab[{index}].{k}");
        let [i, j] = self.particle;
        if i >= resolution[0] || j >= resolution[1] {
            return Err(ConfigError::OutOfRange {
                key: key("particle"),
                value: format!("[{i}, {j}]"),
                range: format!(
                    "column in [0, {}], row in [0, {}]",
                    resolution[0] - 1,
                    resolution[1] - 1
                ),
            });
        }
        if self.keys.is_empty() {
            return Err(ConfigError::Invalid {
                key: key("keys"),
                message: "needs at least one key { time = ..., offset = [x, y, z] }".into(),
            });
        }
        let mut last = -1.0;
        for (n, k) in self.keys.iter().enumerate() {
            if !(k.time.is_finite() && k.time >= 0.0 && k.time > last) {
                return Err(ConfigError::OutOfRange {
                    key: format!("grab[{index}].keys[{n}].time"),
                    value: crate::math::num(k.time),
                    range: format!(
                        "> {} (key times must be >= 0 and strictly increase)",
                        crate::math::num(last)
                    ),
                });
            }
            if !(k.offset.is_finite() && k.offset.abs().max_element() <= 1e4) {
                return Err(ConfigError::OutOfRange {
                    key: format!("grab[{index}].keys[{n}].offset"),
                    value: crate::math::num3(k.offset),
                    range: "each component in [-1e4, 1e4]".into(),
                });
            }
            last = k.time;
        }
        Ok(())
    }
}

/// How a live grab moves its particle.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum GrabMotion {
    /// Follows a keyframed path relative to where the particle was at the first key.
    Path(GrabSpec),
    /// Moves towards `target` (m) at no more than `max_speed` (m/s) and holds it there: an
    /// interactive drag or, with the target left in place, a pin.
    Target {
        /// Where the particle should go, m.
        target: Vec3,
        /// Speed limit, m/s (> 0); keeps a mouse jump from tearing the cloth in one step.
        max_speed: Real,
    },
    /// Follows a point of a collider (an `[[attach]]`; its target is placed by the step, which
    /// knows the colliders).
    Attached(super::Attachment),
}

/// A grab acting on the cloth.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Grab {
    /// Particle index (`row * columns + column`).
    pub particle: usize,
    /// How it moves.
    pub motion: GrabMotion,
    /// Where the particle was when a path grab began.
    pub(crate) anchor: Option<Vec3>,
    /// Force of the hand on the cloth during the last step, N.
    pub(crate) force: Vec3,
}

impl Grab {
    /// A grab with the given motion.
    pub fn new(particle: usize, motion: GrabMotion) -> Self {
        Self {
            particle,
            motion,
            anchor: None,
            force: Vec3::ZERO,
        }
    }

    /// Force the hand exerted on the cloth during the last step, N (zero while inactive).
    pub fn force(&self) -> Vec3 {
        self.force
    }

    /// Where the particle must be at time `t` given its current position `x`, or `None` while
    /// the grab is not active (before a path's first key).
    pub(crate) fn target(&mut self, t: Real, x: Vec3, dt: Real) -> Option<Vec3> {
        match &self.motion {
            GrabMotion::Path(spec) => {
                let offset = spec.offset_at(t)?;
                let anchor = *self.anchor.get_or_insert(x);
                Some(anchor + offset)
            }
            GrabMotion::Target { target, max_speed } => {
                let d = *target - x;
                let max = max_speed * dt;
                let len = d.length();
                Some(if len > max {
                    x + d * (max / len)
                } else {
                    *target
                })
            }
            GrabMotion::Attached(_) => Some(x),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_is_linear_between_keys_and_held_after() {
        let g = GrabSpec::lift([0, 0], 1.0, 2.0, 0.1);
        assert_eq!(g.offset_at(0.5), None);
        assert_eq!(g.offset_at(1.0), Some(Vec3::ZERO));
        assert!((g.offset_at(1.25).unwrap().y - 0.025).abs() < 1e-15);
        assert_eq!(g.offset_at(2.0), Some(Vec3::new(0.0, 0.1, 0.0)));
        assert_eq!(g.offset_at(7.0), Some(Vec3::new(0.0, 0.1, 0.0)));
    }

    #[test]
    fn target_motion_respects_the_speed_limit() {
        let mut g = Grab::new(
            0,
            GrabMotion::Target {
                target: Vec3::new(1.0, 0.0, 0.0),
                max_speed: 2.0,
            },
        );
        let p = g.target(0.0, Vec3::ZERO, 0.01).unwrap();
        assert!((p.x - 0.02).abs() < 1e-15);
        let p = g.target(0.0, Vec3::new(0.99, 0.0, 0.0), 0.01).unwrap();
        assert_eq!(p, Vec3::new(1.0, 0.0, 0.0));
    }
}
