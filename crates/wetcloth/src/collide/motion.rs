//! Moving colliders: keyframes of an offset and a rotation, and the rigid placement they give
//! at any time.
//!
//! A collider's keys (scene `keys = [{ time, offset, rotation }]`) move it from where the scene
//! puts it: at time `t` the shape is translated by `offset(t)` (m) and turned by `rotation(t)`
//! (degrees about x, y, z, applied in that order, *added* to the collider's own scene rotation),
//! both linear between keys, held at the first key before it and at the last key after it.
//!
//! Every shape is moved the same way, through a [`Placement`]: the rigid map from the shape as
//! the scene describes it (its *rest* frame) to the world at time `t`,
//!
//! `x_world = pivot + offset(t) + R(base + rotation(t)) R(base)^T (x_rest - pivot)`,
//!
//! with `pivot` the shape's reference point (a mesh's `position`, a sphere's or box's centre, a
//! plane's point) and `base` its scene rotation (a mesh's `rotation`, zero for the others). So
//! a shape is queried in its rest frame and its answers (points, normals) are mapped back.

use crate::error::ConfigError;
use crate::math::{Real, Vec3};
use glam::DMat3;

/// One key of a collider's motion.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(from = "KeyRepr", into = "KeyRepr")
)]
pub struct Key {
    /// Time of the key, s. Range [0, 1e6]; keys strictly increasing in time.
    pub time: Real,
    /// Offset from the collider's scene position, m. Default (0, 0, 0); each component in
    /// [-1e6, 1e6].
    pub offset: Vec3,
    /// Rotation about x, y, z (applied in that order), degrees, added to the collider's scene
    /// rotation. Default (0, 0, 0); each component in [-1e6, 1e6].
    pub rotation: Vec3,
}

/// `run.json`'s form of a key.
#[cfg(feature = "serde")]
#[derive(serde::Serialize, serde::Deserialize)]
struct KeyRepr {
    time: Real,
    offset: [Real; 3],
    rotation: [Real; 3],
}

#[cfg(feature = "serde")]
impl From<KeyRepr> for Key {
    fn from(r: KeyRepr) -> Self {
        Self {
            time: r.time,
            offset: r.offset.into(),
            rotation: r.rotation.into(),
        }
    }
}

#[cfg(feature = "serde")]
impl From<Key> for KeyRepr {
    fn from(k: Key) -> Self {
        Self {
            time: k.time,
            offset: k.offset.to_array(),
            rotation: k.rotation.to_array(),
        }
    }
}

/// The offset (m) and added rotation (degrees) of `keys` at time `t` (s): linear between keys,
/// held at the first before it and at the last after it; zero without keys.
pub fn offset_at(keys: &[Key], t: Real) -> (Vec3, Vec3) {
    let (Some(first), Some(last)) = (keys.first(), keys.last()) else {
        return (Vec3::ZERO, Vec3::ZERO);
    };
    if t <= first.time {
        return (first.offset, first.rotation);
    }
    if t >= last.time {
        return (last.offset, last.rotation);
    }
    // The key after t: keys are strictly increasing, so this is the segment [a, b] holding t.
    let i = keys.partition_point(|k| k.time <= t);
    let (a, b) = (keys[i - 1], keys[i]);
    let s = (t - a.time) / (b.time - a.time);
    (
        a.offset + (b.offset - a.offset) * s,
        a.rotation + (b.rotation - a.rotation) * s,
    )
}

/// The rotation matrix of `degrees` about x, then y, then z (`R = Rz Ry Rx`).
pub fn rotation_matrix(degrees: Vec3) -> DMat3 {
    let r = degrees * (std::f64::consts::PI / 180.0);
    DMat3::from_rotation_z(r.z) * DMat3::from_rotation_y(r.y) * DMat3::from_rotation_x(r.x)
}

/// A rigid map from a shape's rest frame to the world (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// The shape's reference point in its rest frame, m.
    pub pivot: Vec3,
    /// Where the pivot is in the world, m.
    pub origin: Vec3,
    /// The rotation from the rest frame to the world (orthonormal).
    pub rotation: DMat3,
}

impl Placement {
    /// The placement of a shape with reference point `pivot` and scene rotation `base`
    /// (degrees) moved by `keys` at time `t`.
    pub fn at(keys: &[Key], pivot: Vec3, base: Vec3, t: Real) -> Self {
        let (offset, turn) = offset_at(keys, t);
        let rotation = if turn == Vec3::ZERO {
            DMat3::IDENTITY
        } else {
            rotation_matrix(base + turn) * rotation_matrix(base).transpose()
        };
        Self {
            pivot,
            origin: pivot + offset,
            rotation,
        }
    }

    /// A point of the rest frame in the world, m.
    #[inline]
    pub fn to_world(&self, rest: Vec3) -> Vec3 {
        self.origin + self.rotation * (rest - self.pivot)
    }

    /// A world point in the rest frame, m.
    #[inline]
    pub fn to_rest(&self, world: Vec3) -> Vec3 {
        self.pivot + self.rotation.transpose() * (world - self.origin)
    }

    /// A direction of the rest frame in the world.
    #[inline]
    pub fn dir_to_world(&self, rest: Vec3) -> Vec3 {
        self.rotation * rest
    }
}

/// Checks `keys`; `key` names a scene key in messages.
pub(crate) fn validate(keys: &[Key], key: &dyn Fn(&str) -> String) -> Result<(), ConfigError> {
    let mut before = None;
    for (i, k) in keys.iter().enumerate() {
        let name = |field: &str| key(&format!("keys[{i}].{field}"));
        if !(k.time.is_finite() && (0.0..=1e6).contains(&k.time)) {
            return Err(ConfigError::OutOfRange {
                key: name("time"),
                value: crate::math::num(k.time),
                range: "[0, 1e6] s".into(),
            });
        }
        if let Some(t) = before
            && k.time <= t
        {
            return Err(ConfigError::OutOfRange {
                key: name("time"),
                value: crate::math::num(k.time),
                range: format!(
                    "after the previous key's time {} s (keys strictly increasing)",
                    crate::math::num(t)
                ),
            });
        }
        before = Some(k.time);
        for (field, v) in [("offset", k.offset), ("rotation", k.rotation)] {
            if !(v.is_finite() && v.abs().max_element() <= 1e6) {
                return Err(ConfigError::OutOfRange {
                    key: name(field),
                    value: crate::math::num3(v),
                    range: "each component in [-1e6, 1e6]".into(),
                });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(time: Real, offset: [Real; 3], rotation: [Real; 3]) -> Key {
        Key {
            time,
            offset: offset.into(),
            rotation: rotation.into(),
        }
    }

    /// The contract's keys: still until the first key, linear in between, held after the last.
    #[test]
    fn keys_are_linear_between_and_held_outside() {
        let keys = [
            key(0.5, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
            key(1.0, [0.0, -0.05, 0.0], [0.0, 90.0, 0.0]),
            key(2.0, [0.2, -0.05, 0.0], [0.0, 90.0, 0.0]),
        ];
        assert_eq!(offset_at(&keys, 0.0), (Vec3::ZERO, Vec3::ZERO));
        assert_eq!(offset_at(&keys, 0.5), (Vec3::ZERO, Vec3::ZERO));
        let (o, r) = offset_at(&keys, 0.75);
        assert!((o - Vec3::new(0.0, -0.025, 0.0)).length() < 1e-15);
        assert!((r - Vec3::new(0.0, 45.0, 0.0)).length() < 1e-12);
        let (o, _) = offset_at(&keys, 1.5);
        assert!((o - Vec3::new(0.1, -0.05, 0.0)).length() < 1e-15);
        assert_eq!(offset_at(&keys, 7.0), (keys[2].offset, keys[2].rotation));
        assert_eq!(offset_at(&[], 3.0), (Vec3::ZERO, Vec3::ZERO));
    }

    #[test]
    fn rotations_apply_about_x_then_y_then_z() {
        // 90 degrees about x takes +y to +z; then 90 about y takes +z to +x.
        let r = rotation_matrix(Vec3::new(90.0, 90.0, 0.0));
        assert!((r * Vec3::Y - Vec3::X).length() < 1e-15);
        let r = rotation_matrix(Vec3::new(0.0, 0.0, 90.0));
        assert!((r * Vec3::X - Vec3::Y).length() < 1e-15);
    }

    #[test]
    fn placement_turns_about_the_pivot_and_round_trips() {
        let keys = [key(1.0, [1.0, 0.0, 0.0], [0.0, 0.0, 90.0])];
        let p = Placement::at(
            &keys,
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(30.0, 0.0, 0.0),
            2.0,
        );
        // The pivot moves by the offset; a point beside it turns with it.
        assert!((p.to_world(Vec3::new(0.0, 1.0, 0.0)) - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-15);
        let q = Vec3::new(0.3, -0.2, 0.7);
        assert!((p.to_rest(p.to_world(q)) - q).length() < 1e-14);
    }

    #[test]
    fn bad_keys_are_refused_by_name() {
        let keys = [key(1.0, [0.0; 3], [0.0; 3]), key(1.0, [0.0; 3], [0.0; 3])];
        let e = validate(&keys, &|k| format!("collider[0].{k}")).unwrap_err();
        assert!(e.to_string().contains("collider[0].keys[1].time"), "{e}");
        let keys = [key(0.0, [Real::NAN, 0.0, 0.0], [0.0; 3])];
        let e = validate(&keys, &|k| format!("collider[2].{k}")).unwrap_err();
        assert!(e.to_string().contains("collider[2].keys[0].offset"), "{e}");
    }
}
