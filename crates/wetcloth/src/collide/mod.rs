//! Colliders and collisions (thesis 3.1, 3.3): the shapes the cloth's particle spheres rest on,
//! the contact response, and self-collision.
//!
//! A shape only answers "how far is the surface and which way is out" ([`Collider::distance`])
//! and "what does it look like" ([`Collider::surface`], for renderers); the contact response
//! (normal force and Coulomb friction, eq. 3.4-3.5) lives in [`contact`] and is the same for
//! every shape. A new shape is one file here with its distance, validation and surface, and one
//! variant of [`Shape`]: the step, the renderer and the viewer need nothing else.
//!
//! | file | contents |
//! |---|---|
//! | `plane.rs` | [`Plane`]: infinite plane; the vectorised row contact the step uses for planes |
//! | `sphere.rs` | [`Sphere`]: solid sphere |
//! | `cuboid.rs` | [`Cuboid`]: solid axis-aligned box |
//! | `mesh.rs` | [`Mesh`]: triangle mesh from a file, closed (a solid) or open (a sheet) |
//! | `motion.rs` | keys of a moving collider and the [`motion::Placement`] they give |
//! | `contact.rs` | normal force and friction as a position correction, for any shape |
//! | `self_collision.rs` | particle-particle collision: hashed grid, skinned lists, Jacobi; exempt pairs |
//! | `mesh_self.rs` | a mesh cloth's vertex-triangle and edge-edge self-contact, sides from the step's start |

pub mod contact;
pub mod cuboid;
pub mod deform;
pub mod mesh;
pub mod mesh_self;
pub mod motion;
pub mod plane;
pub mod self_collision;
pub mod sphere;
pub mod sticking;

pub use cuboid::Cuboid;
pub use deform::{PointMotion, PointSource};
pub use mesh::{Mesh, MeshError};
pub use motion::{Key, Placement};
pub use plane::Plane;
pub use sphere::Sphere;
pub use sticking::StickingPlane;

use crate::error::ConfigError;
use crate::math::{Real, Vec3};

/// A mesh collider moved by points that goes into a still plane collider
/// ([`plane_overlaps`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneOverlap {
    /// The mesh collider's place in the scene's list (0-based).
    pub mesh: usize,
    /// The plane collider's place in the list (0-based).
    pub plane: usize,
    /// How far the mesh's deepest point goes below the plane, m.
    pub depth: Real,
    /// The scene time of the frame it does, s.
    pub time: Real,
}

/// The mesh colliders moved by points (an OBJ sequence or a point cache) that go more than
/// `tolerance` m into a still plane collider in some frame of their motion: cloth caught
/// between the two has no room (the mesh pushes it through the plane and the plane pushes it
/// back), and is crushed or torn there. A body standing on the floor reaches the plane and no
/// further; a walk whose planted foot sinks into the floor does. Each mesh's deepest plane.
pub fn plane_overlaps(colliders: &[Collider], tolerance: Real) -> Vec<PlaneOverlap> {
    let mut out = Vec::new();
    for (m, c) in colliders.iter().enumerate() {
        let Shape::Mesh(mesh) = &c.shape else {
            continue;
        };
        if !c.keys.is_empty() {
            continue;
        }
        let mut worst: Option<PlaneOverlap> = None;
        for (p, plane) in colliders.iter().enumerate() {
            let Shape::Plane(plane_shape) = &plane.shape else {
                continue;
            };
            if !plane.keys.is_empty() {
                continue;
            }
            let Some((depth, time)) = mesh.deepest_below(plane_shape.point, plane_shape.normal)
            else {
                continue;
            };
            if depth > tolerance && worst.is_none_or(|w| depth > w.depth) {
                worst = Some(PlaneOverlap {
                    mesh: m,
                    plane: p,
                    depth,
                    time,
                });
            }
        }
        out.extend(worst);
    }
    out
}

/// A collider shape.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(tag = "shape", rename_all = "lowercase")
)]
pub enum Shape {
    /// Infinite plane (scene `shape = "plane"`).
    Plane(Plane),
    /// Solid sphere (scene `shape = "sphere"`).
    Sphere(Sphere),
    /// Solid axis-aligned box (scene `shape = "box"`).
    Box(Cuboid),
    /// Triangle mesh (scene `shape = "mesh"`): a solid if closed, else a two-sided sheet.
    Mesh(Mesh),
}

/// A collider: a shape with a Coulomb friction coefficient, whether air may seal against it,
/// and its motion.
///
/// Not `Copy`: shapes may own data (a triangle mesh cannot be copied for free; it is shared).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Collider {
    /// The shape, where the scene puts it.
    #[cfg_attr(feature = "serde", serde(flatten))]
    pub shape: Shape,
    /// Coulomb friction coefficient mu, one for static and kinetic friction (thesis eq. 3.5).
    /// Default 0.6; range [0, 10].
    pub friction: Real,
    /// Whether trapped air may seal against this collider (scene `sticky`). Default true.
    /// (Written to `run.json` only when false, and `keys` only when there are some, so a
    /// still, sticky collider reads as before.)
    #[cfg_attr(
        feature = "serde",
        serde(default = "sticky_default", skip_serializing_if = "is_true")
    )]
    pub sticky: bool,
    /// The collider's motion (scene `keys`, see [`motion`]): offsets and rotations from where
    /// the scene puts it, linear between keys, held outside them. Default none (still).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Vec::is_empty")
    )]
    pub keys: Vec<Key>,
    /// Where the shape is at the time this copy was taken by [`Collider::at`]; `None` is the
    /// scene's own placement.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub placement: Option<Placement>,
}

#[cfg(feature = "serde")]
fn sticky_default() -> bool {
    true
}

#[cfg(feature = "serde")]
fn is_true(b: &bool) -> bool {
    *b
}

/// What a collider looks like, for renderers: an infinite plane, or a triangle mesh.
#[derive(Clone, Debug, PartialEq)]
pub enum Surface {
    /// An infinite plane through `point` (m) with unit `normal`, out of the solid.
    Plane {
        /// A point of the plane, m.
        point: Vec3,
        /// Unit normal, out of the solid.
        normal: Vec3,
    },
    /// A triangle mesh (closed, except for an open mesh collider).
    Mesh(SurfaceMesh),
}

/// A triangle mesh for drawing: positions (m) and unit normals per vertex, triangles wound
/// counter-clockwise seen from outside (`(b - a) x (c - a)` points out).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceMesh {
    /// Vertex positions, m.
    pub positions: Vec<Vec3>,
    /// Vertex normals (unit, outwards).
    pub normals: Vec<Vec3>,
    /// Triangles as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
}

impl Collider {
    /// A plane through `point` with normal `normal` (normalised here).
    pub fn plane(point: Vec3, normal: Vec3, friction: Real) -> Self {
        Self {
            shape: Shape::Plane(Plane {
                point,
                normal: normal.normalize_or_zero(),
            }),
            friction,
            sticky: true,
            keys: Vec::new(),
            placement: None,
        }
    }

    /// A solid sphere.
    pub fn sphere(center: Vec3, radius: Real, friction: Real) -> Self {
        Self {
            shape: Shape::Sphere(Sphere { center, radius }),
            friction,
            sticky: true,
            keys: Vec::new(),
            placement: None,
        }
    }

    /// A solid axis-aligned box with half extents `half_extents` (m).
    pub fn cuboid(center: Vec3, half_extents: Vec3, friction: Real) -> Self {
        Self {
            shape: Shape::Box(Cuboid {
                center,
                half_extents,
            }),
            friction,
            sticky: true,
            keys: Vec::new(),
            placement: None,
        }
    }

    /// A mesh collider.
    pub fn mesh(mesh: Mesh, friction: Real) -> Self {
        Self {
            shape: Shape::Mesh(mesh),
            friction,
            sticky: true,
            keys: Vec::new(),
            placement: None,
        }
    }

    /// Whether the collider moves (has keys, or is a mesh whose points move).
    pub fn is_moving(&self) -> bool {
        !self.keys.is_empty() || self.is_deforming()
    }

    /// Whether the collider is a mesh whose points move (scene `sequence` or `cache`).
    pub fn is_deforming(&self) -> bool {
        matches!(&self.shape, Shape::Mesh(m) if m.is_deforming())
    }

    /// The shape's reference point for its motion (m) and its scene rotation (degrees): a
    /// mesh's position and rotation, a sphere's or box's centre, a plane's point.
    pub fn pivot(&self) -> (Vec3, Vec3) {
        match &self.shape {
            Shape::Plane(s) => (s.point, Vec3::ZERO),
            Shape::Sphere(s) => (s.center, Vec3::ZERO),
            Shape::Box(s) => (s.center, Vec3::ZERO),
            Shape::Mesh(s) => (s.position, s.rotation),
        }
    }

    /// The placement of the shape at time `t` (s) by its keys.
    pub fn placement_at(&self, t: Real) -> Placement {
        let (pivot, base) = self.pivot();
        Placement::at(&self.keys, pivot, base, t)
    }

    /// This collider as it is at time `t` (s): itself if it does not move, else a copy whose
    /// queries ([`Collider::distance`], [`Collider::surface`]) answer for its placement then.
    pub fn at(&self, t: Real) -> Self {
        let mut c = self.clone();
        if !self.keys.is_empty() {
            c.placement = Some(self.placement_at(t));
        }
        if let Shape::Mesh(m) = &self.shape
            && m.is_deforming()
        {
            c.shape = Shape::Mesh(m.at_time(t));
        }
        c
    }

    /// The plane, if this collider is one.
    pub fn as_plane(&self) -> Option<&Plane> {
        match &self.shape {
            Shape::Plane(p) => Some(p),
            _ => None,
        }
    }

    /// The scene-file name of the shape (`"plane"`, `"sphere"`, `"box"`).
    pub fn shape_name(&self) -> &'static str {
        match self.shape {
            Shape::Plane(_) => "plane",
            Shape::Sphere(_) => "sphere",
            Shape::Box(_) => "box",
            Shape::Mesh(_) => "mesh",
        }
    }

    /// Signed distance from `p` to the surface (m, negative inside) and the outward unit normal
    /// at the closest surface point.
    #[inline]
    pub fn distance(&self, p: Vec3) -> (Real, Vec3) {
        // A still plane, the common table, inline (the shapes' match is not).
        if let (None, Shape::Plane(plane)) = (&self.placement, &self.shape) {
            return plane.distance(p);
        }
        match &self.placement {
            None => self.rest_distance(p),
            Some(at) => {
                let (d, n) = self.rest_distance(at.to_rest(p));
                (d, at.dir_to_world(n))
            }
        }
    }

    /// [`Collider::distance`] where the surface is within `reach` (m) of `p`; `None` when it is
    /// certainly farther (only a mesh answers `None`, sparing the full closest-point search).
    #[inline]
    pub fn distance_within(&self, p: Vec3, reach: Real) -> Option<(Real, Vec3)> {
        self.contact(p, p, reach)
    }

    /// The contact query of a particle moving from `prev` to `p` (world, m): `None` when the
    /// surface is certainly farther than `reach` (m) from `p`; else the signed distance of `p`
    /// and the unit normal on the side the particle came from. For a closed shape this is
    /// [`Collider::distance`]; an open mesh (a two-sided sheet, where the plain distance has
    /// no inside) answers negative for a particle the move took through it.
    #[inline]
    pub fn contact(&self, prev: Vec3, p: Vec3, reach: Real) -> Option<(Real, Vec3)> {
        match &self.placement {
            None => self.rest_contact(prev, p, reach),
            Some(at) => {
                let (d, n) = self.rest_contact(at.to_rest(prev), at.to_rest(p), reach)?;
                Some((d, at.dir_to_world(n)))
            }
        }
    }

    /// [`Collider::distance`] of the shape where the scene puts it.
    #[inline]
    pub fn rest_distance(&self, p: Vec3) -> (Real, Vec3) {
        match &self.shape {
            Shape::Plane(s) => s.distance(p),
            Shape::Sphere(s) => s.distance(p),
            Shape::Box(s) => s.distance(p),
            Shape::Mesh(s) => s.distance(p),
        }
    }

    /// The contact query of a particle moving from `prev` to `p` (both in the shape's scene
    /// placement, m): `None` when the surface is certainly farther than `reach` (m) from `p`;
    /// else the signed distance of `p` and the unit normal, on the side the particle came from
    /// (which only a mesh needs: see [`mesh`]).
    #[inline]
    pub fn rest_contact(&self, prev: Vec3, p: Vec3, reach: Real) -> Option<(Real, Vec3)> {
        match &self.shape {
            Shape::Mesh(s) => s.contact(prev, p, reach),
            _ => Some(self.rest_distance(p)),
        }
    }

    /// What the collider looks like (for renderers and viewers).
    pub fn surface(&self) -> Surface {
        let rest = match &self.shape {
            Shape::Plane(s) => Surface::Plane {
                point: s.point,
                normal: s.normal,
            },
            Shape::Sphere(s) => Surface::Mesh(s.surface_mesh()),
            Shape::Box(s) => Surface::Mesh(s.surface_mesh()),
            Shape::Mesh(s) => Surface::Mesh(s.surface_mesh()),
        };
        let Some(at) = &self.placement else {
            return rest;
        };
        match rest {
            Surface::Plane { point, normal } => Surface::Plane {
                point: at.to_world(point),
                normal: at.dir_to_world(normal),
            },
            Surface::Mesh(mut m) => {
                for p in &mut m.positions {
                    *p = at.to_world(*p);
                }
                for n in &mut m.normals {
                    *n = at.dir_to_world(*n);
                }
                Surface::Mesh(m)
            }
        }
    }

    /// What the collider looks like at time `t` (s), moved by its keys.
    pub fn surface_at(&self, t: Real) -> Surface {
        self.at(t).surface()
    }

    /// Checks the collider's parameters; `index` names it in messages (`collider[index].key`).
    pub fn validate(&self, index: usize) -> Result<(), ConfigError> {
        let key = |k: &str| format!("collider[{index}].{k}");
        if !(self.friction.is_finite() && (0.0..=10.0).contains(&self.friction)) {
            return Err(ConfigError::OutOfRange {
                key: key("friction"),
                value: crate::math::num(self.friction),
                range: "[0, 10]".into(),
            });
        }
        motion::validate(&self.keys, &key)?;
        match &self.shape {
            Shape::Plane(s) => s.validate(&key),
            Shape::Sphere(s) => s.validate(&key),
            Shape::Box(s) => s.validate(&key),
            Shape::Mesh(s) => s.validate(&key),
        }
    }
}

/// Largest magnitude of a solid collider's position coordinates, m (a thousand kilometres: a
/// scene is metres across, and 32-bit renderers lose anything much farther out).
pub const MAX_POSITION: Real = 1e6;

/// `Err` naming `key` unless `v` is finite.
pub(crate) fn require_finite(key: String, v: Vec3) -> Result<(), ConfigError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(ConfigError::Invalid {
            key,
            message: "must be finite".into(),
        })
    }
}

/// `Err` naming `key` unless every component of the position `v` (m) is within
/// [`MAX_POSITION`] of the origin.
pub(crate) fn require_position(key: String, v: Vec3) -> Result<(), ConfigError> {
    if v.is_finite() && v.abs().max_element() <= MAX_POSITION {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key,
            value: format!("[{:e}, {:e}, {:e}]", v.x, v.y, v.z),
            range: format!("each component in [-{MAX_POSITION:e}, {MAX_POSITION:e}] m"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_distances_match_the_geometry() {
        let plane = Collider::plane(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 2.0, 0.0), 0.5);
        assert_eq!(plane.distance(Vec3::new(3.0, 1.5, -2.0)), (0.5, Vec3::Y));
        let s = Collider::sphere(Vec3::ZERO, 1.0, 0.5);
        let (d, n) = s.distance(Vec3::new(0.0, 0.0, 3.0));
        assert_eq!((d, n), (2.0, Vec3::Z));
        let b = Collider::cuboid(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0), 0.0);
        assert_eq!(b.distance(Vec3::new(0.0, 2.5, 0.0)), (0.5, Vec3::Y));
        let (d, n) = b.distance(Vec3::new(0.9, 0.0, 0.0));
        assert!((d + 0.1).abs() < 1e-12 && n == Vec3::X);
        let (d, n) = b.distance(Vec3::new(4.0, 6.0, 0.0));
        assert!((d - 5.0).abs() < 1e-12 && (n - Vec3::new(0.6, 0.8, 0.0)).length() < 1e-12);
    }

    /// Every surface mesh lies on its shape (distance 0 at each vertex), its normals agree with
    /// the shape's, and its triangles face outwards.
    #[test]
    fn surface_meshes_lie_on_their_shapes_and_face_out() {
        for c in [
            Collider::sphere(Vec3::new(0.1, 0.2, -0.3), 0.25, 0.5),
            Collider::cuboid(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.5, 0.25, 1.0), 0.5),
        ] {
            let Surface::Mesh(m) = c.surface() else {
                panic!("{} has no mesh", c.shape_name())
            };
            assert!(!m.triangles.is_empty());
            assert_eq!(m.positions.len(), m.normals.len());
            for (p, n) in m.positions.iter().zip(&m.normals) {
                let (d, _) = c.distance(*p);
                assert!(d.abs() < 1e-12, "{}: vertex {p} at {d}", c.shape_name());
                let (_, out) = c.distance(*p + *n * 1e-3);
                assert!(out.dot(*n) > 0.7, "{}: normal {n} vs {out}", c.shape_name());
            }
            for [a, b, t] in &m.triangles {
                let [a, b, t] = [*a, *b, *t].map(|k| m.positions[k as usize]);
                let face = (b - a).cross(t - a);
                if face.length() < 1e-15 {
                    continue; // a sliver at a sphere's pole
                }
                let centre = (a + b + t) / 3.0;
                let (_, out) = c.distance(centre + face.normalize() * 1e-3);
                assert!(
                    face.dot(out) > 0.0,
                    "{}: a triangle faces in",
                    c.shape_name()
                );
            }
        }
    }
}
