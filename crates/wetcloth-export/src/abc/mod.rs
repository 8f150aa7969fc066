//! Alembic caches of a run ([`AbcWriter`]): an Ogawa archive with the AbcGeom schemas, written
//! frame by frame.
//!
//! ```text
//! /<scene>                        Xform; .userProperties: the scene's parameters
//!     cloth                       Xform (identity)
//!         clothShape              PolyMesh: P and .selfBnds every frame; .faceIndices,
//!                                 .faceCounts and uv once, held for all frames (the grid: a
//!                                 uv per vertex; a mesh cloth: its polygons and, where its
//!                                 file has them, uv indexed per face corner, seams kept)
//!     colliders                   Xform (identity), when the run has colliders
//!         <shape>_<k>             Xform: identity, or a matrix per frame for a moving collider;
//!                                 .userProperties wetcloth:shape, wetcloth:friction
//!             <shape>_<k>Shape    PolyMesh of the collider where the scene puts it (a plane: a
//!                                 square of PLANE_HALF_SIDE times the cloth's size)
//! ```
//!
//! One time sampling, uniform at the run's frame rate from time 0: sample `k` is frame `k` at
//! `k / frame_rate` seconds. Coordinates are the run's: metres, Y up. Alembic lists a face's
//! vertices clockwise seen from its front (the RenderMan convention its readers undo), so
//! each face `[a, b, c, ...]` of the OBJ frames is written reversed, `[..., c, b, a]`, and so
//! are a face-varying uv's corners: Blender, Maya and Houdini show the faces as the OBJ frames
//! do.
//!
//! The container is in `ogawa.rs`, the sample hash in `murmur.rs`, the archive layout in
//! `schema.rs`. Memory is the file's offsets (a few per frame) and one reused buffer: the
//! frame's positions are hashed and written in pieces.

mod murmur;
mod ogawa;
mod schema;

use crate::cache::{CacheSpec, CacheWriter, Frame, check_complete, check_frame};
use crate::params::{ParamValue, SceneParam, identifier};
use crate::usd::{PLANE_HALF_SIDE, PLANE_MIN_HALF_SIDE, plane_corners};
use schema::{Archive, ObjId, Parent, Pod, PropId};
use std::io::{self, Seek, Write};
use wetcloth::{Collider, Surface, Vec3};

const XFORM_OBJECT: &str = "schema=AbcGeom_Xform_v3;schemaObjTitle=AbcGeom_Xform_v3:.xform";
const XFORM_SCHEMA: &str = "schema=AbcGeom_Xform_v3";
const MESH_OBJECT: &str = "schema=AbcGeom_PolyMesh_v1;schemaBaseType=AbcGeom_GeomBase_v1;\
                           schemaObjTitle=AbcGeom_PolyMesh_v1:.geom";
const MESH_SCHEMA: &str = "schema=AbcGeom_PolyMesh_v1;schemaBaseType=AbcGeom_GeomBase_v1";
const BOX: &str = "interpretation=box";
const POINTS: &str = "geoScope=vtx;interpretation=point";
const UV: &str = "arrayExtent=1;geoScope=vtx;interpretation=vector;isGeomParam=true;\
                  podExtent=2;podName=float32_t";
const UV_FACE_VARYING: &str = "arrayExtent=1;geoScope=fvr;interpretation=vector;isGeomParam=true;\
                               podExtent=2;podName=float32_t";
/// Matrix operation, the one op of a moving collider's transform (`kMatrixOperation << 4`).
const MATRIX_OP: u8 = 0x30;
/// Positions hashed and written per piece of a frame.
const PIECE: usize = 4096;

/// A moving collider's transform, sampled every frame.
#[derive(Debug)]
struct Moving {
    collider: Collider,
    vals: PropId,
    not_identity: PropId,
    anim_chans: PropId,
    first: Option<[f64; 16]>,
    animated: [bool; 16],
}

/// Writes an Alembic archive (Ogawa) to `W`, frame by frame (see the [module docs](self)).
#[derive(Debug)]
pub struct AbcWriter<W: Write + Seek> {
    archive: Archive<W>,
    vertices: usize,
    frames: u64,
    fed: u64,
    frame_rate: f64,
    points: PropId,
    bounds: PropId,
    /// Properties whose one sample holds for every frame.
    held: Vec<PropId>,
    moving: Vec<Moving>,
}

/// Adds an Xform object and its `.xform` schema with an `.inherits` property.
fn xform<W: Write + Seek>(
    a: &mut Archive<W>,
    parent: ObjId,
    name: &str,
    ts: u32,
) -> io::Result<(ObjId, PropId, PropId)> {
    let obj = a.add_object(parent, name, XFORM_OBJECT);
    let schema = a.add_compound(Parent::Object(obj), ".xform", XFORM_SCHEMA);
    let inherits = a.add_scalar(Parent::Compound(schema), ".inherits", "", Pod::Bool, 1, ts);
    a.set(inherits, &[1], 1)?;
    Ok((obj, schema, inherits))
}

/// Adds a PolyMesh with constant topology and UVs (if any) and its first points; returns
/// the points, bounds and the properties that hold.
fn poly_mesh<W: Write + Seek>(
    a: &mut Archive<W>,
    parent: ObjId,
    name: &str,
    ts: u32,
    mesh: MeshData<'_>,
) -> io::Result<(PropId, PropId, Vec<PropId>)> {
    let obj = a.add_object(parent, name, MESH_OBJECT);
    let geom = Parent::Compound(a.add_compound(Parent::Object(obj), ".geom", MESH_SCHEMA));
    let bounds = a.add_scalar(geom, ".selfBnds", BOX, Pod::F64, 6, ts);
    let points = a.add_array(geom, "P", POINTS, Pod::F32, 3, ts);
    let indices = a.add_array(geom, ".faceIndices", "", Pod::I32, 1, ts);
    let counts = a.add_array(geom, ".faceCounts", "", Pod::I32, 1, ts);
    if let Some(p) = mesh.points {
        set_points(a, points, bounds, p)?;
    }
    a.set_values(indices, &mesh.clockwise, 1, i32::to_le_bytes)?;
    a.set_values(counts, &mesh.counts, 1, i32::to_le_bytes)?;
    let mut held = vec![indices, counts];
    match mesh.uvs {
        Uvs::None => {}
        Uvs::Vertex(uv) => {
            let uvs = a.add_array(geom, "uv", UV, Pod::F32, 2, ts);
            let flat: Vec<f32> = uv.iter().flatten().copied().collect();
            a.set_values(uvs, &flat, 2, f32::to_le_bytes)?;
            held.push(uvs);
        }
        Uvs::FaceVarying(uv, corners) => {
            // An indexed geometry parameter: a compound of the values and each corner's index.
            let uvs = Parent::Compound(a.add_compound(geom, "uv", UV_FACE_VARYING));
            let vals = a.add_array(uvs, ".vals", UV_FACE_VARYING, Pod::F32, 2, ts);
            let flat: Vec<f32> = uv.iter().flatten().copied().collect();
            a.set_values(vals, &flat, 2, f32::to_le_bytes)?;
            let indices = a.add_array(uvs, ".indices", "", Pod::U32, 1, ts);
            a.set_values(indices, &corners, 1, u32::to_le_bytes)?;
            held.extend([vals, indices]);
        }
    }
    Ok((points, bounds, held))
}

/// A mesh to write: its faces as Alembic stores them, UVs per vertex and the first points
/// (the cloth's come with the first frame).
struct MeshData<'a> {
    /// Each face's vertices, clockwise (see [`clockwise`]).
    clockwise: Vec<i32>,
    /// Vertices per face.
    counts: Vec<i32>,
    uvs: Uvs<'a>,
    points: Option<&'a [[f32; 3]]>,
}

/// A mesh's texture coordinates.
enum Uvs<'a> {
    /// None.
    None,
    /// One per vertex (`geoScope=vtx`).
    Vertex(&'a [[f32; 2]]),
    /// The values and each corner's index into them, corner by corner in the order of
    /// `.faceIndices` (`geoScope=fvr`, indexed).
    FaceVarying(&'a [[f32; 2]], Vec<u32>),
}

/// Faces as Alembic stores them: the vertices of every face, clockwise, and their counts.
type Faces = (Vec<i32>, Vec<i32>);

/// Faces wound counter-clockwise (as the OBJ frames have them) as Alembic stores them: each
/// face's vertices in reverse order, clockwise seen from its front. Returns the flat
/// indices and the counts.
fn clockwise<'f>(faces: impl Iterator<Item = &'f [u32]>) -> Faces {
    let (mut idx, mut counts) = (Vec::new(), Vec::new());
    for f in faces {
        idx.extend(f.iter().rev().map(|&i| i as i32));
        counts.push(f.len() as i32);
    }
    (idx, counts)
}

/// Sets the next sample of `points` and of `bounds` (its axis-aligned box, float64 min then
/// max), hashing and writing the positions in pieces.
fn set_points<W: Write + Seek>(
    a: &mut Archive<W>,
    points: PropId,
    bounds: PropId,
    p: &[[f32; 3]],
) -> io::Result<()> {
    let mut buf = Vec::with_capacity(12 * PIECE.min(p.len()));
    let fill = |buf: &mut Vec<u8>, piece: &[[f32; 3]]| {
        buf.clear();
        for c in piece.iter().flatten() {
            buf.extend_from_slice(&c.to_le_bytes());
        }
    };
    let mut h = murmur::Murmur3::new();
    for piece in p.chunks(PIECE) {
        fill(&mut buf, piece);
        h.update(&buf);
    }
    a.set_with(
        points,
        h.finish(),
        12 * p.len() as u64,
        p.len() as u64,
        |o| {
            for piece in p.chunks(PIECE) {
                fill(&mut buf, piece);
                o.write_raw(&buf)?;
            }
            Ok(())
        },
    )?;
    let e = Frame {
        index: 0,
        positions: p,
        normals: p,
    }
    .extent();
    let b: Vec<f64> = e.iter().flatten().map(|&c| f64::from(c)).collect();
    a.set_values(bounds, &b, 6, f64::to_le_bytes)
}

/// Adds the `.userProperties` compound of an Xform schema with `params`.
fn user_properties<W: Write + Seek>(
    a: &mut Archive<W>,
    schema: PropId,
    params: &[SceneParam],
) -> io::Result<()> {
    if params.is_empty() {
        return Ok(());
    }
    let up = Parent::Compound(a.add_compound(Parent::Compound(schema), ".userProperties", ""));
    for p in params {
        let n = p.name.as_str();
        match &p.value {
            ParamValue::Bool(b) => {
                let id = a.add_scalar(up, n, "", Pod::Bool, 1, 0);
                a.set(id, &[u8::from(*b)], 1)?;
            }
            ParamValue::Int(i) => match i32::try_from(*i) {
                Ok(i) => {
                    let id = a.add_scalar(up, n, "", Pod::I32, 1, 0);
                    a.set(id, &i.to_le_bytes(), 1)?;
                }
                Err(_) => {
                    let id = a.add_scalar(up, n, "", Pod::F64, 1, 0);
                    a.set(id, &(*i as f64).to_le_bytes(), 1)?;
                }
            },
            ParamValue::Float(f) => {
                let id = a.add_scalar(up, n, "", Pod::F64, 1, 0);
                a.set(id, &f.to_le_bytes(), 1)?;
            }
            ParamValue::Text(s) => {
                let id = a.add_scalar(up, n, "", Pod::String, 1, 0);
                a.set_string(id, s)?;
            }
            ParamValue::Ints(v) => match v
                .iter()
                .map(|&i| i32::try_from(i))
                .collect::<Result<Vec<i32>, _>>()
            {
                Ok(ints) => {
                    let id = a.add_array(up, n, "", Pod::I32, 1, 0);
                    a.set_values(id, &ints, 1, i32::to_le_bytes)?;
                }
                Err(_) => {
                    let f: Vec<f64> = v.iter().map(|&i| i as f64).collect();
                    let id = a.add_array(up, n, "", Pod::F64, 1, 0);
                    a.set_values(id, &f, 1, f64::to_le_bytes)?;
                }
            },
            ParamValue::Floats(v) => {
                let id = a.add_array(up, n, "", Pod::F64, 1, 0);
                a.set_values(id, v, 1, f64::to_le_bytes)?;
            }
        }
    }
    Ok(())
}

/// The collider's transform at time `t` (s) from its scene placement, as Alembic's 4 x 4
/// matrix (row vectors: rows 0 to 2 the images of the axes, row 3 the translation).
fn collider_matrix(c: &Collider, t: f64) -> [f64; 16] {
    let p = c.placement_at(t);
    let mut m = [0.0; 16];
    for (row, axis) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().enumerate() {
        let a = p.dir_to_world(axis);
        m[4 * row..4 * row + 3].copy_from_slice(&a.to_array());
    }
    m[12..15].copy_from_slice(&p.to_world(Vec3::ZERO).to_array());
    m[15] = 1.0;
    m
}

/// The collider's mesh where the scene puts it: its points and its faces, clockwise.
fn collider_mesh(c: &Collider, cloth_size: f64) -> (Vec<[f32; 3]>, Faces) {
    match c.surface() {
        Surface::Plane { point, normal } => {
            let half = (PLANE_HALF_SIDE * cloth_size).max(PLANE_MIN_HALF_SIDE);
            let q = plane_corners(point.to_array(), normal.to_array(), half);
            (q, clockwise([&[0, 1, 2, 3][..]].into_iter()))
        }
        Surface::Mesh(m) => (
            m.positions
                .iter()
                .map(|v| v.to_array().map(|c| c as f32))
                .collect(),
            clockwise(m.triangles.iter().map(|t| &t[..])),
        ),
    }
}

/// `s` without the `;` and `=` that separate Alembic metadata.
fn meta_value(s: &str) -> String {
    s.replace([';', '='], " ")
}

impl<W: Write + Seek> AbcWriter<W> {
    /// Writes the archive's constant parts (topology, UVs, colliders, parameters) for
    /// `spec.frames` frames of `spec.vertices()` vertices.
    ///
    /// # Errors
    ///
    /// I/O errors.
    pub fn new(w: W, spec: &CacheSpec<'_>) -> io::Result<Self> {
        let run = spec.run;
        let meta = format!(
            "_ai_Application=wetcloth {};_ai_Description={}",
            env!("CARGO_PKG_VERSION"),
            meta_value(&format!(
                "run {}: {}, {} frames at {} frames per second, metres, Y up",
                run.name,
                run.cloth_words(),
                spec.frames,
                run.frame_rate
            ))
        );
        let mut a = Archive::new(w, meta)?;
        let ts = a.add_uniform_sampling(1.0 / run.frame_rate, 0.0);
        let top = a.top();
        let (scene, scene_schema, _) = xform(&mut a, top, &identifier(&run.name), ts)?;
        user_properties(&mut a, scene_schema, spec.params)?;
        let (cloth, _, _) = xform(&mut a, scene, "cloth", ts)?;
        let surface = spec.surface;
        let (clockwise, counts) = clockwise(surface.faces());
        let uv = spec.uvs_f32();
        let uvs = match (&surface.face_uvs, surface.grid) {
            // Each face's corners reversed, as its vertices are.
            (Some(_), _) => Uvs::FaceVarying(
                &uv,
                (0..surface.face_count())
                    .flat_map(|f| surface.face_uv(f).unwrap_or(&[]).iter().rev().copied())
                    .collect(),
            ),
            (None, Some(_)) => Uvs::Vertex(&uv),
            (None, None) => Uvs::None,
        };
        let mesh = MeshData {
            clockwise,
            counts,
            uvs,
            points: None,
        };
        // The cloth's topology and UVs are set once and held for every frame; a still
        // transform is one sample.
        let (points, bounds, mut held) = poly_mesh(&mut a, cloth, "clothShape", ts, mesh)?;

        let mut moving = Vec::new();
        if !run.colliders.is_empty() {
            let (group, _, _) = xform(&mut a, scene, "colliders", ts)?;
            let size = run.cloth_span();
            for (k, c) in run.colliders.iter().enumerate() {
                let name = format!("{}_{k}", c.shape_name());
                let (obj, schema, inherits) = xform(&mut a, group, &name, ts)?;
                if c.is_moving() {
                    held.push(inherits);
                    let s = Parent::Compound(schema);
                    let ops = a.add_scalar(s, ".ops", "", Pod::U8, 1, ts);
                    a.set(ops, &[MATRIX_OP], 1)?;
                    held.push(ops);
                    let vals = a.add_scalar(s, ".vals", "", Pod::F64, 16, ts);
                    let not_identity =
                        a.add_scalar(s, "isNotConstantIdentity", "", Pod::Bool, 1, 0);
                    let anim_chans = a.add_array(s, ".animChans", "", Pod::U32, 1, 0);
                    moving.push(Moving {
                        collider: c.clone(),
                        vals,
                        not_identity,
                        anim_chans,
                        first: None,
                        animated: [false; 16],
                    });
                }
                let params = [
                    SceneParam {
                        name: "wetcloth:shape".into(),
                        value: ParamValue::Text(c.shape_name().into()),
                    },
                    SceneParam {
                        name: "wetcloth:friction".into(),
                        value: ParamValue::Float(c.friction),
                    },
                ];
                user_properties(&mut a, schema, &params)?;
                let (p, (clockwise, counts)) = collider_mesh(c, size);
                let mesh = MeshData {
                    clockwise,
                    counts,
                    uvs: Uvs::None,
                    points: Some(&p),
                };
                poly_mesh(&mut a, obj, &format!("{name}Shape"), ts, mesh)?;
            }
        }
        Ok(Self {
            archive: a,
            vertices: spec.vertices(),
            frames: spec.frames,
            fed: 0,
            frame_rate: run.frame_rate,
            points,
            bounds,
            held,
            moving,
        })
    }
}

impl<W: Write + Seek> CacheWriter for AbcWriter<W> {
    fn write_frame(&mut self, frame: &Frame<'_>) -> io::Result<()> {
        check_frame(frame, self.fed, self.vertices)?;
        let a = &mut self.archive;
        set_points(a, self.points, self.bounds, frame.positions)?;
        if self.fed > 0 {
            for &id in &self.held {
                a.repeat(id)?;
            }
        }
        let t = frame.index as f64 / self.frame_rate;
        for m in &mut self.moving {
            let v = collider_matrix(&m.collider, t);
            let first = *m.first.get_or_insert(v);
            for (i, flag) in m.animated.iter_mut().enumerate() {
                *flag |= v[i] != first[i];
            }
            a.set_values(m.vals, &v, 16, f64::to_le_bytes)?;
        }
        self.fed += 1;
        Ok(())
    }

    fn finish(self: Box<Self>) -> io::Result<()> {
        check_complete(self.fed, self.frames)?;
        let this = *self;
        let mut a = this.archive;
        for m in &this.moving {
            a.set(m.not_identity, &[1], 1)?;
            let chans: Vec<u32> = (0..16).filter(|&i| m.animated[i as usize]).collect();
            a.set_values(m.anim_chans, &chans, 1, u32::to_le_bytes)?;
        }
        a.finish()?;
        Ok(())
    }
}
