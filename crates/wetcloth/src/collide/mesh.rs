//! The triangle-mesh collider (scene `shape = "mesh"`): any surface given as triangles, placed
//! by a position, a rotation and a uniform scale.
//!
//! Queries go through `parry3d-f64`'s [`TriMesh`]: a bounding-volume hierarchy over the
//! triangles, the closest point on the surface, and the inside test by angle-weighted
//! pseudo-normals (Bærentzen and Aanæs 2005), which is exact for a closed, consistently wound
//! mesh.
//!
//! **Closed and open meshes.** A mesh is *closed* when, after merging vertices with identical
//! coordinates, every edge is shared by exactly two triangles that run it in opposite
//! directions. A closed mesh is a solid: its triangles are turned to face outwards (whatever
//! the file's winding), a point inside it is pushed out through the nearest surface, and the
//! signed distance is negative inside. Any other mesh (a sheet, a terrain, a mesh with holes or
//! inconsistent winding) is *open*: it is a two-sided surface of no thickness, a particle rests
//! on whichever side it comes from, and there is no inside.
//!
//! **Thin parts.** A particle's side is taken from where it was at the start of the step: if
//! the straight move from its previous position to its new one crosses the surface (a ray cast
//! through the hierarchy, done only when the surface is within the move's length of the new
//! position), the particle is put back on the side it came from. So a fast particle cannot pass
//! through a sheet, or through a closed mesh thinner than its move, between two steps; and since
//! a particle only gets inside by crossing the surface, a particle farther from the surface than
//! its radius plus its move needs no inside test (the contact query stops there).

use super::SurfaceMesh;
use super::deform::{Deform, PointMotion, Pose, SweptContact};
use super::motion::rotation_matrix;
use crate::error::ConfigError;
use crate::math::{Real, Vec3};
use glam::DMat3;
use parry3d_f64::math::Vector as PVec;
use parry3d_f64::query::{PointQueryWithLocation, Ray, RayCast};
use parry3d_f64::shape::{TriMesh, TriMeshFlags};
use std::collections::HashMap;
use std::sync::Arc;

/// Largest scale of a mesh (a metre-sized model scaled to ten kilometres).
pub const MAX_SCALE: Real = 1e4;

/// Largest vertex coordinate of a model, in its own units (1e9). With [`MAX_SCALE`] and a
/// position within 1e6 m, every squared distance the contact queries take stays far from
/// overflowing (coordinates near 1e155 overflowed them and judged a cloth inside a triangle
/// 1e200 m away).
pub const MAX_COORDINATE: Real = 1e9;

/// Why a mesh cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// No triangles at all.
    #[error("the mesh has no faces (it needs at least one triangle)")]
    NoFaces,
    /// A vertex with a NaN or infinite coordinate.
    #[error("vertex {index} (counting from 1) is not finite: [{x}, {y}, {z}]")]
    NonFiniteVertex {
        /// Vertex number, from 1 as in OBJ files.
        index: usize,
        /// Its coordinates.
        x: Real,
        /// y coordinate.
        y: Real,
        /// z coordinate.
        z: Real,
    },
    /// A triangle naming a vertex that does not exist.
    #[error(
        "triangle {triangle} (counting from 1) uses vertex {index} (counting from 1), but the \
         mesh has {count} vertices"
    )]
    IndexOutOfRange {
        /// Triangle number, from 1.
        triangle: usize,
        /// The vertex it names, from 1.
        index: u64,
        /// Number of vertices.
        count: usize,
    },
    /// Every triangle has zero area.
    #[error("every triangle of the mesh has zero area")]
    Degenerate,
    /// A vertex with a coordinate beyond [`MAX_COORDINATE`].
    #[error(
        "vertex {index} (counting from 1) has the coordinate {value:e}, out of range: allowed \
         each in [-1e9, 1e9] (the model's units)"
    )]
    HugeVertex {
        /// Vertex number, from 1 as in OBJ files.
        index: usize,
        /// The coordinate.
        value: Real,
    },
    /// A mesh read back from `run.json` without its triangles (they are in the copy beside
    /// it, [`Mesh::copy_name`]; `wetcloth_export::read_run_json` puts them back).
    #[error(
        "the mesh's triangles are not in run.json but in {copy} beside it (read run.json with \
         wetcloth_export::read_run_json)"
    )]
    NotInline {
        /// The copy's path relative to the run folder.
        copy: String,
    },
    /// A point motion that does not fit the mesh.
    #[error("{0}")]
    Motion(String),
}

/// A triangle-mesh collider.
#[derive(Clone)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(try_from = "MeshRepr", into = "MeshRepr")
)]
pub struct Mesh {
    /// The mesh file it was read from, for descriptions (the scene reader gives the absolute
    /// path; the core reads no files).
    pub file: String,
    /// Where the model's origin goes, m. Default (0, 0, 0); each component in [-1e6, 1e6].
    pub position: Vec3,
    /// Rotation about x, y, z, applied in that order, degrees. Default (0, 0, 0); each
    /// component in [-1e6, 1e6].
    pub rotation: Vec3,
    /// Uniform scale of the model (its units to metres). Default 1; range (0, 1e4].
    pub scale: Real,
    /// The model's vertices as given (before scale, rotation and position).
    vertices: Arc<Vec<Vec3>>,
    /// The triangles as given, indices into `vertices`.
    triangles: Arc<Vec<[u32; 3]>>,
    /// The query structure, in the model frame scaled to metres (rotation and position apart).
    query: Arc<TriMesh>,
    /// Whether the mesh is a closed, consistently wound solid (see the module docs).
    closed: bool,
    /// `rotation` as a matrix.
    matrix: DMat3,
    /// [`mesh_digest`] of `vertices` and `triangles`.
    digest: u64,
    /// The motion of the mesh's points, for a deforming mesh (scene `sequence` or `cache`).
    deform: Option<Arc<Deform>>,
    /// The deformed mesh at one time, in a copy taken by [`super::Collider::at`]; `None` is the
    /// rest mesh.
    pose: Option<Arc<Pose>>,
}

/// A deforming mesh's poses at the start and end of a step (see [`super::deform`]).
#[derive(Clone, Debug)]
pub struct Sweep {
    /// The pose at the step's start.
    pub start: Arc<Pose>,
    /// The pose at the step's end.
    pub end: Arc<Pose>,
    /// The largest move of any point of the mesh over the step, m.
    pub max_move: Real,
}

impl std::fmt::Debug for Mesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Mesh")
            .field("file", &self.file)
            .field("position", &self.position)
            .field("rotation", &self.rotation)
            .field("scale", &self.scale)
            .field("vertices", &self.vertices.len())
            .field("triangles", &self.triangles.len())
            .field("closed", &self.closed)
            .field("deform", &self.deform)
            .finish()
    }
}

impl PartialEq for Mesh {
    fn eq(&self, o: &Self) -> bool {
        self.file == o.file
            && self.position == o.position
            && self.rotation == o.rotation
            && self.scale == o.scale
            && self.vertices == o.vertices
            && self.triangles == o.triangles
            && self.motion() == o.motion()
    }
}

fn pv(v: Vec3) -> PVec {
    PVec::new(v.x, v.y, v.z)
}

fn gv(v: PVec) -> Vec3 {
    Vec3::new(v.x, v.y, v.z)
}

impl Mesh {
    /// A mesh collider from a model's `vertices` and `triangles` (indices from 0), placed by
    /// `position` (m), `rotation` (degrees about x, y, z in that order) and `scale`. `file`
    /// only names it. Refuses meshes with no faces, non-finite vertices, indices out of range
    /// or only zero-area triangles; the placement is checked by [`super::Collider::validate`]
    /// (a scale of 0 or less gives a mesh of no size, refused there).
    pub fn new(
        file: impl Into<String>,
        vertices: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        position: Vec3,
        rotation: Vec3,
        scale: Real,
    ) -> Result<Self, MeshError> {
        if triangles.is_empty() {
            return Err(MeshError::NoFaces);
        }
        if let Some((i, v)) = vertices.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(MeshError::NonFiniteVertex {
                index: i + 1,
                x: v.x,
                y: v.y,
                z: v.z,
            });
        }
        for (i, v) in vertices.iter().enumerate() {
            if let Some(&value) = v.to_array().iter().find(|c| c.abs() > MAX_COORDINATE) {
                return Err(MeshError::HugeVertex {
                    index: i + 1,
                    value,
                });
            }
        }
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&i) = tri.iter().find(|&&i| i as usize >= vertices.len()) {
                return Err(MeshError::IndexOutOfRange {
                    triangle: t + 1,
                    index: u64::from(i) + 1,
                    count: vertices.len(),
                });
            }
        }
        // A scale that is not usable still builds (validate names it); the query uses 1.
        let s = if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            1.0
        };
        let (query, closed) = build_query(&vertices, &triangles, s)?;
        let digest = mesh_digest(&vertices, &triangles);
        Ok(Self {
            file: file.into(),
            position,
            rotation,
            scale,
            vertices: Arc::new(vertices),
            triangles: Arc::new(triangles),
            query: Arc::new(query),
            closed,
            matrix: rotation_matrix(rotation),
            digest,
            deform: None,
            pose: None,
        })
    }

    /// This mesh with its points moved by `motion` (a deforming mesh, see [`super::deform`]).
    /// Refuses a motion whose frames do not all have the mesh's vertex count, or have a
    /// non-finite point or one beyond [`MAX_COORDINATE`].
    pub fn with_motion(mut self, motion: PointMotion) -> Result<Self, MeshError> {
        if motion.frames.is_empty() {
            return Err(MeshError::Motion("the motion has no frames".into()));
        }
        for (f, frame) in motion.frames.iter().enumerate() {
            if frame.len() != self.vertices.len() {
                return Err(MeshError::Motion(format!(
                    "frame {f} has {} points, but the rest mesh has {} vertices",
                    frame.len(),
                    self.vertices.len()
                )));
            }
            if let Some((i, v)) = frame
                .iter()
                .enumerate()
                .find(|(_, v)| !(v.is_finite() && v.abs().max_element() <= MAX_COORDINATE))
            {
                return Err(MeshError::Motion(format!(
                    "frame {f}, point {} (counting from 1) is [{}, {}, {}]: allowed finite, each \
                     in [-1e9, 1e9]",
                    i + 1,
                    v.x,
                    v.y,
                    v.z
                )));
            }
        }
        let s = if self.scale.is_finite() && self.scale > 0.0 {
            self.scale
        } else {
            1.0
        };
        self.deform = Some(Arc::new(Deform::new(
            &self.vertices,
            &self.triangles,
            s,
            motion,
        )));
        Ok(self)
    }

    /// Where a run folder keeps a copy of a deforming mesh's point motion (a PC2 cache of its
    /// frames in file coordinates, `meshes/<model digest>-<points digest>.pc2`); `None` for a
    /// mesh that does not deform.
    pub fn points_copy_name(&self) -> Option<String> {
        self.deform
            .as_deref()
            .map(|d| points_copy_name(self.digest, d.points_digest))
    }

    /// The motion of the mesh's points, if it deforms.
    pub fn motion(&self) -> Option<&PointMotion> {
        self.deform.as_deref().map(|d| &d.motion)
    }

    /// How far the points of a mesh moved by points ([`Mesh::is_deforming`]) go below the plane
    /// through `point` with unit normal `up` (m: the largest over every frame, negative when no
    /// point reaches the plane) and the scene time of that frame (s); `None` for a still mesh.
    pub fn deepest_below(&self, point: Vec3, up: Vec3) -> Option<(Real, Real)> {
        let deform = self.deform.as_ref()?;
        let mut deepest = (Real::NEG_INFINITY, 0.0);
        for (t, points) in deform.frames() {
            for &q in points {
                let depth = -up.dot(self.position + self.matrix * q - point);
                if depth > deepest.0 {
                    deepest = (depth, t);
                }
            }
        }
        Some(deepest)
    }

    /// Whether the mesh's points move (scene `sequence` or `cache`).
    pub fn is_deforming(&self) -> bool {
        self.deform.is_some()
    }

    /// The deformation, if the mesh deforms.
    pub fn deform(&self) -> Option<&Deform> {
        self.deform.as_deref()
    }

    /// A copy of the mesh deformed as it is at time `t` (s); itself for a mesh that does not
    /// deform.
    pub fn at_time(&self, t: Real) -> Self {
        let mut m = self.clone();
        if let Some(d) = &self.deform {
            m.pose = Some(d.pose(t));
        }
        m
    }

    /// The poses over the step from `t` to `t + dt` (s), for a deforming mesh.
    pub fn sweep(&self, t: Real, dt: Real) -> Option<Sweep> {
        let d = self.deform.as_ref()?;
        let (start, end) = (d.pose(t), d.pose(t + dt));
        let max_move = d.max_move(&start, &end);
        Some(Sweep {
            start,
            end,
            max_move,
        })
    }

    /// The contact of a particle moving from `prev` to `p` (world at the mesh's scene
    /// placement, m) with the deforming mesh over the step `sweep`, within `reach` (m): in the
    /// surface's frame (see [`super::deform`]); positions, normal and move in the same frame.
    pub fn swept_contact(
        &self,
        sweep: &Sweep,
        prev: Vec3,
        p: Vec3,
        reach: Real,
    ) -> Option<SweptContact> {
        let d = self.deform.as_ref()?;
        let c = d.swept_contact(
            &sweep.start,
            &sweep.end,
            sweep.max_move,
            self.local(prev),
            self.local(p),
            reach,
        )?;
        Some(SweptContact {
            distance: c.distance,
            normal: self.matrix * c.normal,
            from: self.position + self.matrix * c.from,
            moved: self.matrix * c.moved,
        })
    }

    /// Where the surface near `p` (world at the mesh's scene placement, m) is carried over the
    /// step `sweep`: `p` carried by the triangle nearest it within `reach` (m), or `p` itself
    /// when none is that near.
    pub fn carry(&self, sweep: &Sweep, p: Vec3, reach: Real) -> Vec3 {
        match &self.deform {
            Some(d) => d
                .carry(&sweep.start, &sweep.end, self.local(p), reach)
                .map_or(p, |q| self.position + self.matrix * q),
            None => p,
        }
    }

    /// The content digest of the model as read ([`mesh_digest`] of its vertices and
    /// triangles): what a run records of the mesh it read, to refuse a resume after the file
    /// changed.
    pub fn digest(&self) -> u64 {
        self.digest
    }

    /// Where a run folder keeps a copy of the model, relative to the folder:
    /// `meshes/<digest as 16 hex digits>.obj` (`run.json` names it instead of holding the
    /// triangles).
    pub fn copy_name(&self) -> String {
        copy_name(self.digest)
    }

    /// The model's vertices as given (before scale, rotation and position).
    pub fn vertices(&self) -> &[Vec3] {
        &self.vertices
    }

    /// The model's triangles, indices into [`Mesh::vertices`].
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Whether the mesh is a closed solid (see the module docs).
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// A world point in the query frame.
    #[inline]
    fn local(&self, p: Vec3) -> Vec3 {
        self.matrix.transpose() * (p - self.position)
    }

    /// A point where the scene puts the mesh (m) in the mesh's own frame, scaled to metres
    /// (the frame of its [`Deform`]'s poses).
    pub fn to_mesh_frame(&self, p: Vec3) -> Vec3 {
        self.local(p)
    }

    /// A point of the mesh's own frame, scaled to metres, where the scene puts the mesh (m).
    pub fn from_mesh_frame(&self, q: Vec3) -> Vec3 {
        self.position + self.matrix * q
    }

    /// Signed distance of `p` from the surface (m; negative inside a closed mesh) and the unit
    /// normal pointing from the surface towards `p` (out of a closed mesh).
    pub fn distance(&self, p: Vec3) -> (Real, Vec3) {
        let q = self.local(p);
        if let (Some(d), Some(pose)) = (&self.deform, &self.pose) {
            let (dist, n) = d.distance(pose, q);
            return (dist, self.matrix * n);
        }
        let (proj, (tri, _)) = self
            .query
            .project_local_point_and_get_location(pv(q), false);
        let (d, n) = self.signed(q, gv(proj.point), proj.is_inside, tri);
        (d, self.matrix * n)
    }

    /// The contact query of a particle moving from `prev` to `p` (world, m): `None` when the
    /// surface is farther than `reach` (m) from `p` and the move crossed no surface; else the
    /// signed distance of `p` on the side the particle came from and the unit normal towards
    /// that side (see the module docs).
    pub fn contact(&self, prev: Vec3, p: Vec3, reach: Real) -> Option<(Real, Vec3)> {
        let q = self.local(p);
        let q0 = self.local(prev);
        if let (Some(d), Some(pose)) = (&self.deform, &self.pose) {
            let c = d.swept_contact(pose, pose, 0.0, q0, q, reach)?;
            return Some((c.distance, self.matrix * c.normal));
        }
        let step = q - q0;
        let len = step.length();
        let (proj, (tri, _)) = self
            .query
            .project_local_point_and_get_location_with_max_dist(pv(q), false, reach.max(len))?;
        let c = gv(proj.point);
        if len > 0.0 && (q - c).length() <= len {
            // The surface is within the move: did the move cross it?
            let ray = Ray::new(pv(q0), pv(step));
            if let Some(hit) = self.query.cast_local_ray_and_get_normal(&ray, 1.0, false) {
                let at = q0 + step * hit.time_of_impact;
                let face = self.face_normal(hit.subshape);
                let from = (q0 - at).dot(face);
                // An open surface stops the particle on the side it came from; a closed one
                // only when it came from outside (a particle leaving a solid is let out).
                let side = if from > 0.0 {
                    Some(face)
                } else if from < 0.0 && !self.closed {
                    Some(-face)
                } else {
                    None
                };
                if let Some(n) = side {
                    return Some(((q - at).dot(n), self.matrix * n));
                }
            }
        }
        let (d, n) = self.signed(q, c, proj.is_inside, tri);
        Some((d, self.matrix * n))
    }

    /// Signed distance and normal of the query point `q` from its closest surface point `c` on
    /// triangle `tri`, `inside` by the pseudo-normal test.
    #[inline]
    fn signed(&self, q: Vec3, c: Vec3, inside: bool, tri: u32) -> (Real, Vec3) {
        let diff = q - c;
        let dist = diff.length();
        let inside = self.closed && inside;
        if dist <= 1e-12 * (1.0 + c.abs().max_element()) {
            // On the surface: the face's normal (out of a closed mesh).
            return (0.0, self.face_normal(tri));
        }
        let n = diff / dist;
        if inside { (-dist, -n) } else { (dist, n) }
    }

    /// Unit normal of query triangle `tri` (outwards on a closed mesh).
    fn face_normal(&self, tri: u32) -> Vec3 {
        self.query
            .triangle(tri)
            .normal()
            .map_or(Vec3::Y, |n| gv(n).normalize_or(Vec3::Y))
    }

    /// The mesh in the world for drawing: placed vertices, area-weighted vertex normals.
    pub fn surface_mesh(&self) -> SurfaceMesh {
        let positions: Vec<Vec3> = match (&self.deform, &self.pose) {
            (Some(d), Some(pose)) => d
                .file_points(pose)
                .into_iter()
                .map(|v| self.position + self.matrix * v)
                .collect(),
            _ => self
                .vertices
                .iter()
                .map(|v| self.position + self.matrix * (*v * self.scale))
                .collect(),
        };
        let mut triangles = self.triangles.to_vec();
        // Draw a closed mesh wound outwards, as the query uses it.
        let flip = self.closed && signed_volume(&positions, &triangles) < 0.0;
        if flip {
            for t in &mut triangles {
                t.swap(1, 2);
            }
        }
        let mut normals = vec![Vec3::ZERO; positions.len()];
        for t in &triangles {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let face = (b - a).cross(c - a);
            for &i in t {
                normals[i as usize] += face;
            }
        }
        for n in &mut normals {
            *n = n.normalize_or(Vec3::Y);
        }
        SurfaceMesh {
            positions,
            normals,
            triangles,
        }
    }

    pub(crate) fn validate(&self, key: &dyn Fn(&str) -> String) -> Result<(), ConfigError> {
        super::require_position(key("position"), self.position)?;
        let r = self.rotation;
        if !(r.is_finite() && r.abs().max_element() <= 1e6) {
            return Err(ConfigError::OutOfRange {
                key: key("rotation"),
                value: crate::math::num3(r),
                range: "each component in [-1e6, 1e6] degrees".into(),
            });
        }
        let s = self.scale;
        if !(s.is_finite() && s > 0.0 && s <= MAX_SCALE) {
            return Err(ConfigError::OutOfRange {
                key: key("scale"),
                value: crate::math::num(s),
                range: format!("(0, {MAX_SCALE:e}]"),
            });
        }
        if let Some(m) = self.motion() {
            if !(m.frame_rate.is_finite() && (1e-3..=1e5).contains(&m.frame_rate)) {
                return Err(ConfigError::OutOfRange {
                    key: key("frame_rate"),
                    value: crate::math::num(m.frame_rate),
                    range: "[1e-3, 1e5] 1/s".into(),
                });
            }
            if !(m.start.is_finite() && m.start.abs() <= 1e6) {
                return Err(ConfigError::OutOfRange {
                    key: key("start"),
                    value: crate::math::num(m.start),
                    range: "[-1e6, 1e6] s".into(),
                });
            }
        }
        Ok(())
    }
}

/// Six times the signed volume enclosed by `triangles` (positive when wound outwards).
fn signed_volume(positions: &[Vec3], triangles: &[[u32; 3]]) -> Real {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            a.dot(b.cross(c))
        })
        .sum()
}

/// The query mesh (vertices scaled by `scale`, duplicates merged, zero-area triangles dropped,
/// a closed mesh wound outwards) and whether it is closed.
fn build_query(
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    scale: Real,
) -> Result<(TriMesh, bool), MeshError> {
    // Merge vertices with identical coordinates, so that seams of an OBJ file (a vertex repeated
    // for its texture coordinates) do not open the surface.
    let mut index_of: HashMap<[u64; 3], u32> = HashMap::new();
    let mut merged: Vec<Vec3> = Vec::new();
    let remap: Vec<u32> = vertices
        .iter()
        .map(|v| {
            let p = *v * scale;
            *index_of
                .entry([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                .or_insert_with(|| {
                    merged.push(p);
                    (merged.len() - 1) as u32
                })
        })
        .collect();
    let mut tris: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| t.map(|i| remap[i as usize]))
        .filter(|t| {
            let [a, b, c] = t.map(|i| merged[i as usize]);
            (b - a).cross(c - a).length_squared() > 0.0
        })
        .collect();
    if tris.is_empty() {
        return Err(MeshError::Degenerate);
    }
    let closed = closed_and_oriented(&merged, &mut tris);
    let flags = if closed {
        TriMeshFlags::ORIENTED
    } else {
        TriMeshFlags::empty()
    };
    let points = merged.into_iter().map(pv).collect();
    TriMesh::with_flags(points, tris, flags)
        .map(|m| (m, closed))
        .map_err(|_| MeshError::Degenerate)
}

/// Whether the mesh of `points` and `tris` (duplicates merged) is closed (each directed edge
/// once, and its reverse once) and a solid; a closed mesh's parts are turned outwards
/// ([`orient_parts`]).
pub(crate) fn closed_and_oriented(points: &[Vec3], tris: &mut [[u32; 3]]) -> bool {
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in tris.iter() {
        for k in 0..3 {
            *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    let closed = edges
        .iter()
        .all(|(&(a, b), &count)| count == 1 && edges.get(&(b, a)) == Some(&1));
    closed && orient_parts(points, tris)
}

/// Turns every connected part of a closed mesh (`tris`, consistently wound within each part)
/// to face outwards, each by its own signed volume: a mesh made of parts wound opposite ways
/// (two boxes, one wound inwards) would otherwise keep one part inside-out, and all of space
/// outside that part would count as inside the solid. Returns false, leaving the mesh to be
/// taken as open and two-sided, when a part encloses no volume (a flat sheet folded onto
/// itself: closed by its edges, but no solid), measured against its size: `|6 V| <= 1e-9 d^3`,
/// `d` the diagonal of its bounding box.
fn orient_parts(points: &[Vec3], tris: &mut [[u32; 3]]) -> bool {
    // Parts: triangles joined by their (undirected) edges, by union-find.
    let mut parent: Vec<u32> = (0..tris.len() as u32).collect();
    fn find(parent: &mut [u32], mut a: u32) -> u32 {
        while parent[a as usize] != a {
            let up = parent[parent[a as usize] as usize];
            parent[a as usize] = up;
            a = up;
        }
        a
    }
    let mut first: HashMap<(u32, u32), u32> = HashMap::new();
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let key = (a.min(b), a.max(b));
            match first.get(&key) {
                Some(&other) => {
                    let (ra, rb) = (find(&mut parent, t as u32), find(&mut parent, other));
                    if ra != rb {
                        parent[ra.max(rb) as usize] = ra.min(rb);
                    }
                }
                None => {
                    first.insert(key, t as u32);
                }
            }
        }
    }
    let roots: Vec<u32> = (0..tris.len() as u32)
        .map(|t| find(&mut parent, t))
        .collect();
    // Each part's six times signed volume and bounding box.
    let mut parts: HashMap<u32, (Real, Vec3, Vec3)> = HashMap::new();
    for (tri, &r) in tris.iter().zip(&roots) {
        let [a, b, c] = tri.map(|i| points[i as usize]);
        let e = parts.entry(r).or_insert((
            0.0,
            Vec3::splat(Real::INFINITY),
            Vec3::splat(-Real::INFINITY),
        ));
        e.0 += a.dot(b.cross(c));
        for p in [a, b, c] {
            e.1 = e.1.min(p);
            e.2 = e.2.max(p);
        }
    }
    if parts
        .values()
        .any(|&(v, lo, hi)| v.abs() <= 1e-9 * (hi - lo).length().powi(3))
    {
        return false;
    }
    for (tri, r) in tris.iter_mut().zip(&roots) {
        if parts[r].0 < 0.0 {
            tri.swap(1, 2);
        }
    }
    true
}

/// FNV-1a (64 bits) of a model's vertices (each coordinate's 8 bytes, little-endian) and
/// triangles (each index's 4 bytes): the content of a mesh as read, whatever the file's
/// formatting.
pub fn mesh_digest(vertices: &[Vec3], triangles: &[[u32; 3]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(&(vertices.len() as u64).to_le_bytes());
    for v in vertices {
        for c in v.to_array() {
            eat(&c.to_le_bytes());
        }
    }
    eat(&(triangles.len() as u64).to_le_bytes());
    for t in triangles {
        for i in t {
            eat(&i.to_le_bytes());
        }
    }
    h
}

/// The copy of a model of digest `digest` in a run folder: `meshes/<16 hex digits>.obj`.
pub fn copy_name(digest: u64) -> String {
    format!("meshes/{digest:016x}.obj")
}

/// The name of the copy of a deforming mesh's point motion in a run folder, by the model's
/// digest and the frames' ([`Mesh::points_copy_name`]).
pub fn points_copy_name(digest: u64, points: u64) -> String {
    format!("meshes/{digest:016x}-{points:016x}.pc2")
}

/// `run.json`'s form of a mesh: its placement, and the model by reference (`copy`, the copy
/// of it in the run folder, and its `digest`, [`mesh_digest`] as 16 hex digits) so that
/// `run.json` stays a few kilobytes whatever the mesh. Older files (and readers that put the
/// model back, `wetcloth_export::read_run_json`) give the model inline as `vertices` and
/// `triangles`.
#[cfg(feature = "serde")]
#[derive(serde::Serialize, serde::Deserialize)]
struct MeshRepr {
    file: String,
    position: [Real; 3],
    rotation: [Real; 3],
    scale: Real,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    copy: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    digest: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    triangle_count: Option<u64>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    vertices: Vec<[Real; 3]>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    triangles: Vec<[u32; 3]>,
    /// A deforming mesh's point motion, described (its frames are not in `run.json`: a mesh
    /// read back from it is the rest mesh).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    sequence: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    cache: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    frame_rate: Option<Real>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    start: Option<Real>,
    /// The copy of the motion's frames in the run folder (a PC2 cache, single precision), for
    /// renderers and exporters that read the run back.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    points_copy: Option<String>,
}

#[cfg(feature = "serde")]
impl TryFrom<MeshRepr> for Mesh {
    type Error = MeshError;
    fn try_from(r: MeshRepr) -> Result<Self, MeshError> {
        if r.triangles.is_empty()
            && let Some(copy) = r.copy
        {
            return Err(MeshError::NotInline { copy });
        }
        Mesh::new(
            r.file,
            r.vertices.into_iter().map(Vec3::from).collect(),
            r.triangles,
            r.position.into(),
            r.rotation.into(),
            r.scale,
        )
    }
}

#[cfg(feature = "serde")]
impl From<Mesh> for MeshRepr {
    fn from(m: Mesh) -> Self {
        use super::deform::PointSource;
        let motion = m.motion().cloned();
        let (sequence, cache) = match motion.as_ref().map(|mo| &mo.source) {
            Some(PointSource::Sequence(s)) => (Some(s.clone()), None),
            Some(PointSource::Cache(c)) => (None, Some(c.clone())),
            None => (None, None),
        };
        Self {
            points_copy: m.points_copy_name(),
            sequence,
            cache,
            frame_rate: motion.as_ref().map(|mo| mo.frame_rate),
            start: motion.as_ref().map(|mo| mo.start),
            file: m.file,
            position: m.position.to_array(),
            rotation: m.rotation.to_array(),
            scale: m.scale,
            copy: Some(copy_name(m.digest)),
            digest: Some(format!("{:016x}", m.digest)),
            triangle_count: Some(m.triangles.len() as u64),
            vertices: Vec::new(),
            triangles: Vec::new(),
        }
    }
}
