//! Seams (`[[cloth.seam]]`): particle pairs of two panels sewn together by zero-length
//! springs, as a garment's pattern pieces are before they are welded.
//!
//! Pair `(a, b)` pulls `a` towards `b` (and `b` back) with
//!
//! `F = min(k |d|, F_max) d / |d| + c (v_b - v_a)`,
//!
//! `d = x_b - x_a`, `k` the seam's `stiffness` (N/m per pair) and `F_max` its `max_force` (N
//! per pair, as Blender's sewing springs cap theirs), so panels laid far apart are drawn in at a
//! bounded pull that does not tear the cloth, and `c = 2 sqrt(k m_a m_b / (m_a + m_b))` damps
//! the pair's own relative motion critically (the damping is not capped: it brakes a pair that
//! the capped pull has set moving fast), so a seam closes without ringing. Its energy is
//! `k |d|^2 / 2` below the cap and `F_max |d| - F_max^2 / (2 k)` beyond it (the capped spring's
//! potential): the energy audit counts it with the cloth's.
//!
//! The paired particles are exempt from self-collision with each other, so a seam can close.

use crate::error::ConfigError;
use crate::math::{Real, Soa, Vec3};

/// A seam as a scene gives it (`[[cloth.seam]]`).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SeamSpec {
    /// One side's particles (as `vertex` indices, 0-based), paired in order with `b`.
    pub a: Vec<u32>,
    /// The other side's particles, as many as `a`.
    pub b: Vec<u32>,
    /// Stiffness of each pair's zero-length spring, N/m per pair. Default
    /// [`SeamSpec::DEFAULT_STIFFNESS`]; range (0, 1e7].
    pub stiffness: Real,
    /// Largest force of a pair, N. Default [`SeamSpec::DEFAULT_MAX_FORCE`]; range (0, 1e6].
    pub max_force: Real,
}

impl SeamSpec {
    /// The default stiffness, N/m per pair: a 1 kg/m^2 cloth's seam closes from a few
    /// centimetres in well under a second (`crates/wetcloth/tests/seams.rs`) and, closed, a
    /// pull of a millinewton opens it by 0.02 mm.
    pub const DEFAULT_STIFFNESS: Real = 50.0;
    /// The default force cap, N per pair: a pair pulling at it stretches a 2 cm spring of 500
    /// N/m by a tenth of a millimetre.
    pub const DEFAULT_MAX_FORCE: Real = 0.05;

    /// Checks the seam for a cloth of `n` particles; `index` names it (`cloth.seam[index]`).
    pub fn validate(&self, index: usize, n: usize) -> Result<(), ConfigError> {
        let key = |k: &str| format!("cloth.seam[{index}].{k}");
        if self.a.is_empty() || self.a.len() != self.b.len() {
            return Err(ConfigError::Invalid {
                key: key("b"),
                message: format!(
                    "`a` and `b` are two lists of particles paired in order: they must have \
                     the same, non-zero length (a has {}, b has {})",
                    self.a.len(),
                    self.b.len()
                ),
            });
        }
        for (side, list) in [("a", &self.a), ("b", &self.b)] {
            if let Some(&k) = list.iter().find(|&&k| k as usize >= n) {
                return Err(ConfigError::OutOfRange {
                    key: key(side),
                    value: k.to_string(),
                    range: format!("[0, {}] (the cloth's particles)", n.saturating_sub(1)),
                });
            }
        }
        if let Some((&a, _)) = self.a.iter().zip(&self.b).find(|(a, b)| a == b) {
            return Err(ConfigError::Invalid {
                key: key("b"),
                message: format!("particle {a} is paired with itself"),
            });
        }
        for (k, v, hi) in [
            ("stiffness", self.stiffness, 1e7),
            ("max_force", self.max_force, 1e6),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= hi) {
                return Err(ConfigError::OutOfRange {
                    key: key(k),
                    value: crate::math::num(v),
                    range: format!("(0, {hi:e}]"),
                });
            }
        }
        Ok(())
    }
}

/// Every seam's pairs, flattened.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Seams {
    /// The pairs `[a, b]`.
    pub pairs: Vec<[u32; 2]>,
    /// Each pair's stiffness, N/m.
    pub stiffness: Vec<Real>,
    /// Each pair's force cap, N.
    pub max_force: Vec<Real>,
    /// Each pair's damping coefficient, N s/m (critical for the pair's reduced mass).
    pub damping: Vec<Real>,
}

impl Seams {
    /// The pairs of `specs` on particles of masses `mass` (kg); `None` without seams.
    pub fn new(specs: &[SeamSpec], mass: impl Fn(usize) -> Real) -> Option<Self> {
        if specs.is_empty() {
            return None;
        }
        let mut s = Self::default();
        for spec in specs {
            for (&a, &b) in spec.a.iter().zip(&spec.b) {
                let (ma, mb) = (mass(a as usize), mass(b as usize));
                s.pairs.push([a, b]);
                s.stiffness.push(spec.stiffness);
                s.max_force.push(spec.max_force);
                s.damping
                    .push(2.0 * (spec.stiffness * ma * mb / (ma + mb)).sqrt());
            }
        }
        Some(s)
    }

    /// The pairs, for exemption from self-collision.
    pub fn exempt_pairs(&self) -> &[[u32; 2]] {
        &self.pairs
    }

    /// The spring stiffness of pair `i` at separation `d` (m) as the implicit step linearises
    /// it: `k` below the cap, `F_max / |d|` beyond it (positive, so the system stays definite).
    pub fn stiffness_at(&self, i: usize, d: Vec3) -> Real {
        let (k, cap) = (self.stiffness[i], self.max_force[i]);
        let l = d.length();
        if k * l > cap { cap / l } else { k }
    }

    /// Force of pair `i` on its first particle, N, at separation `d = x_b - x_a` (m) and
    /// relative velocity `w = v_b - v_a` (m/s; zero for the spring alone).
    pub fn force(&self, i: usize, d: Vec3, w: Vec3) -> Vec3 {
        d * self.stiffness_at(i, d) + w * self.damping[i]
    }

    /// Adds every pair's force into `force` at positions `x` with the velocities `v(k)` (m/s),
    /// in the pairs' order (one thread: the sums do not depend on the pool).
    pub fn add_forces(&self, x: &Soa, v: impl Fn(usize) -> Vec3, force: &mut Soa) {
        for (i, &[a, b]) in self.pairs.iter().enumerate() {
            let (a, b) = (a as usize, b as usize);
            let f = self.force(i, x.get(b) - x.get(a), v(b) - v(a));
            force.set(a, force.get(a) + f);
            force.set(b, force.get(b) - f);
        }
    }

    /// The seams' stored energy at positions `x`, J.
    pub fn energy(&self, x: &Soa) -> Real {
        let mut e = 0.0;
        for (i, &[a, b]) in self.pairs.iter().enumerate() {
            let l = (x.get(b as usize) - x.get(a as usize)).length();
            let (k, cap) = (self.stiffness[i], self.max_force[i]);
            e += if k * l > cap {
                cap * l - cap * cap / (2.0 * k)
            } else {
                0.5 * k * l * l
            };
        }
        e
    }

    /// The largest distance between paired particles at positions `x`, m.
    pub fn widest_gap(&self, x: &Soa) -> Real {
        self.pairs
            .iter()
            .map(|&[a, b]| (x.get(b as usize) - x.get(a as usize)).length())
            .fold(0.0, Real::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two(d: Vec3) -> Soa {
        let mut x = Soa::zeros(2);
        x.set(1, d);
        x
    }

    const STILL: Vec3 = Vec3::ZERO;

    fn seams(k: Real, cap: Real) -> Seams {
        let spec = SeamSpec {
            a: vec![0],
            b: vec![1],
            stiffness: k,
            max_force: cap,
        };
        Seams::new(&[spec], |_| 1.0).unwrap()
    }

    #[test]
    fn force_is_hooke_below_the_cap_and_capped_beyond() {
        let s = seams(10.0, 1.0);
        let f = s.force(0, Vec3::new(0.05, 0.0, 0.0), STILL);
        assert!((f - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-15);
        let f = s.force(0, Vec3::new(0.0, 0.3, 0.0), STILL);
        assert!((f - Vec3::new(0.0, 1.0, 0.0)).length() < 1e-15);
        // Equal and opposite.
        let mut force = Soa::zeros(2);
        s.add_forces(&two(Vec3::new(0.0, 0.3, 0.0)), |_| STILL, &mut force);
        assert!((force.get(0) + force.get(1)).length() < 1e-15);
    }

    #[test]
    fn energy_is_the_integral_of_the_force() {
        let s = seams(10.0, 1.0);
        // Integrate F along the separation from 0 to 0.3 m (beyond the cap at 0.1 m).
        let steps = 30_000;
        let mut work = 0.0;
        for i in 0..steps {
            let l = (i as Real + 0.5) * 0.3 / steps as Real;
            work += s.force(0, Vec3::new(l, 0.0, 0.0), STILL).x * 0.3 / steps as Real;
        }
        let e = s.energy(&two(Vec3::new(0.3, 0.0, 0.0)));
        assert!((e - work).abs() < 1e-9, "{e} {work}");
        assert!((e - (1.0 * 0.3 - 1.0 / 20.0)).abs() < 1e-12);
    }

    #[test]
    fn damping_is_critical_for_the_pair() {
        let s = seams(8.0, 100.0);
        // Reduced mass 0.5 kg: c = 2 sqrt(8 * 0.5) = 4.
        assert!((s.damping[0] - 4.0).abs() < 1e-12);
    }

    #[test]
    fn bad_seams_are_refused_with_their_key() {
        let mut spec = SeamSpec {
            a: vec![0, 1],
            b: vec![2],
            stiffness: 1.0,
            max_force: 1.0,
        };
        let e = spec.validate(3, 10).unwrap_err().to_string();
        assert!(e.contains("cloth.seam[3].b") && e.contains("same"), "{e}");
        spec.b = vec![2, 10];
        let e = spec.validate(0, 10).unwrap_err().to_string();
        assert!(e.contains("cloth.seam[0].b") && e.contains("10"), "{e}");
        spec.b = vec![2, 1];
        assert!(
            spec.validate(0, 10)
                .unwrap_err()
                .to_string()
                .contains("itself")
        );
        spec.b = vec![2, 3];
        spec.stiffness = 0.0;
        assert!(
            spec.validate(0, 10)
                .unwrap_err()
                .to_string()
                .contains("cloth.seam[0].stiffness")
        );
    }
}
