//! USD stages of a run: one description, two encodings ([`UsdaWriter`] text, [`UsdcWriter`]
//! binary).
//!
//! The stage (`build_stage`):
//!
//! ```text
//! #usda 1.0  (upAxis = "Y", metersPerUnit = 1, timeCodesPerSecond = framesPerSecond = the run's
//!             frame rate, startTimeCode = 0, endTimeCode = frames - 1, defaultPrim = <scene>)
//! def Xform "<scene>"            the scene's parameters as custom attributes wetcloth:table:key
//!     def Mesh "cloth"           faces, primvars:st (UVs), and per frame: points,
//!                                normals (vertex), extent; time code k = frame k
//!     def Scope "colliders"
//!         def Mesh "plane_0"     a large quad (PLANE_HALF_SIDE), custom wetcloth:* attributes
//!         def Sphere "sphere_1"  radius, xformOp:translate
//!         def Cube "box_2"       size 2, xformOp:translate and xformOp:scale (half extents)
//! ```
//!
//! Everything but the cloth's per-frame attributes is small and held in memory (`Prim`,
//! `Attr`); the per-frame attributes are `Data::Streamed`: each writer puts a frame's values
//! in its file as the frame arrives. A collider that moves is an `XformOps` with key frames:
//! USD interpolates time samples linearly and holds the value after the last, as wetcloth does.

mod usda;
mod usdc;

pub use usda::UsdaWriter;
pub use usdc::UsdcWriter;

use crate::cache::CacheSpec;
use crate::params::{ParamValue, SceneParam, identifier};
use wetcloth::collide::{Cuboid, Plane, Sphere};
use wetcloth::{Collider, Shape};

/// Half the side of the quad that stands for an (infinite) plane collider, in multiples of the
/// cloth's larger side (at least [`PLANE_MIN_HALF_SIDE`]).
pub const PLANE_HALF_SIDE: f64 = 5.0;
/// The smallest half side of a plane collider's quad, m.
pub const PLANE_MIN_HALF_SIDE: f64 = 1.0;

/// A value of an attribute or of stage metadata.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Value {
    Bool(bool),
    Int(i32),
    Double(f64),
    String(String),
    Token(String),
    /// `int2`, `int3` or `int4` (by length).
    IntTuple(Vec<i32>),
    /// `double2`, `double3` or `double4` (by length).
    DoubleTuple(Vec<f64>),
    Ints(Vec<i32>),
    Doubles(Vec<f64>),
    Tokens(Vec<String>),
    Float2s(Vec<[f32; 2]>),
    Float3s(Vec<[f32; 3]>),
}

/// The per-frame attributes of the cloth, written as frames arrive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stream {
    Points,
    Normals,
    Extent,
}

/// What an attribute holds.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Data {
    /// One value for all times.
    Default(Value),
    /// Values at time codes (held in memory: small attributes such as a collider's motion).
    Samples(Vec<(f64, Value)>),
    /// One value per frame at time code = frame number, fed frame by frame.
    Streamed(Stream),
}

/// An attribute.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Attr {
    pub name: String,
    /// USD type name, e.g. `point3f[]`.
    pub type_name: &'static str,
    pub custom: bool,
    pub uniform: bool,
    /// Primvar interpolation metadata (`vertex`), if any.
    pub interpolation: Option<&'static str>,
    pub data: Data,
}

impl Attr {
    fn new(name: &str, type_name: &'static str, value: Value) -> Self {
        Self {
            name: name.to_string(),
            type_name,
            custom: false,
            uniform: false,
            interpolation: None,
            data: Data::Default(value),
        }
    }

    fn uniform(mut self) -> Self {
        self.uniform = true;
        self
    }

    fn custom(mut self) -> Self {
        self.custom = true;
        self
    }

    fn vertex(mut self) -> Self {
        self.interpolation = Some("vertex");
        self
    }

    /// A primvar with a value per face corner (`faceVarying`).
    fn face_varying(mut self) -> Self {
        self.interpolation = Some("faceVarying");
        self
    }

    fn streamed(name: &str, type_name: &'static str, stream: Stream) -> Self {
        Self {
            data: Data::Streamed(stream),
            ..Attr::new(name, type_name, Value::Bool(false))
        }
    }
}

/// A prim (`def TYPE "name"`).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Prim {
    pub name: String,
    pub type_name: &'static str,
    pub attrs: Vec<Attr>,
    pub children: Vec<Prim>,
}

impl Prim {
    fn new(name: &str, type_name: &'static str) -> Self {
        Self {
            name: name.to_string(),
            type_name,
            attrs: Vec::new(),
            children: Vec::new(),
        }
    }
}

/// The stage: layer metadata and the root prim.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Stage {
    pub doc: String,
    /// Frames per second, and time codes per second.
    pub frame_rate: f64,
    pub start: f64,
    pub end: f64,
    pub root: Prim,
}

impl Stage {
    /// Layer metadata as (key in the crate file, key in usda, value), sorted by usda key as USD
    /// writes them.
    pub fn metadata(&self) -> Vec<(&'static str, &'static str, Value)> {
        vec![
            (
                "defaultPrim",
                "defaultPrim",
                Value::Token(self.root.name.clone()),
            ),
            ("documentation", "doc", Value::String(self.doc.clone())),
            ("endTimeCode", "endTimeCode", Value::Double(self.end)),
            (
                "framesPerSecond",
                "framesPerSecond",
                Value::Double(self.frame_rate),
            ),
            ("metersPerUnit", "metersPerUnit", Value::Double(1.0)),
            ("startTimeCode", "startTimeCode", Value::Double(self.start)),
            (
                "timeCodesPerSecond",
                "timeCodesPerSecond",
                Value::Double(self.frame_rate),
            ),
            ("upAxis", "upAxis", Value::Token("Y".to_string())),
        ]
    }
}

/// The stage of a run (see the [module docs](self)).
pub(crate) fn build_stage(spec: &CacheSpec<'_>) -> Stage {
    let run = spec.run;
    let mut root = Prim::new(&identifier(&run.name), "Xform");
    root.attrs = spec.params.iter().map(param_attr).collect();
    root.children.push(cloth_prim(spec));
    let size = run.cloth_span();
    let mut colliders = Prim::new("colliders", "Scope");
    for (k, c) in run.colliders.iter().enumerate() {
        colliders
            .children
            .push(collider_prim(k, c, size, run.frame_rate));
    }
    if !colliders.children.is_empty() {
        root.children.push(colliders);
    }
    let mut doc = format!(
        "wetcloth run `{}`: {}, {} frames at {} frames per second; metres, Y up; time code k \
         is frame k",
        run.name,
        run.cloth_words(),
        spec.frames,
        run.frame_rate
    );
    if let Some(why) = crate::incomplete(run) {
        doc.push_str(&format!("; INCOMPLETE: {why}"));
    }
    Stage {
        doc,
        frame_rate: run.frame_rate,
        start: 0.0,
        end: spec.frames.saturating_sub(1) as f64,
        root,
    }
}

/// The cloth: its faces as the frames have them (the grid's triangles, or a mesh cloth's
/// polygons in the file's order and winding), whose points, normals and extent are sampled
/// every frame. Texture coordinates are `primvars:st`: per vertex on the grid, face-varying
/// with `primvars:st:indices` (the file's `vt` indices, seams kept) on a mesh cloth whose
/// file has them.
fn cloth_prim(spec: &CacheSpec<'_>) -> Prim {
    let s = spec.surface;
    let mut p = Prim::new("cloth", "Mesh");
    let counts = s.faces().map(|f| f.len() as i32).collect();
    let indices = s.face_vertices.iter().map(|&i| i as i32).collect();
    p.attrs = vec![
        Attr::new("doubleSided", "bool", Value::Bool(true)).uniform(),
        Attr::new("faceVertexCounts", "int[]", Value::Ints(counts)),
        Attr::new("faceVertexIndices", "int[]", Value::Ints(indices)),
    ];
    let st = Attr::new(
        "primvars:st",
        "texCoord2f[]",
        Value::Float2s(spec.uvs_f32()),
    );
    match (&s.face_uvs, s.grid) {
        (Some(corners), _) => {
            p.attrs.push(st.face_varying());
            let corners = corners.iter().map(|&i| i as i32).collect();
            p.attrs.push(Attr::new(
                "primvars:st:indices",
                "int[]",
                Value::Ints(corners),
            ));
        }
        (None, Some(_)) => p.attrs.push(st.vertex()),
        (None, None) => {}
    }
    p.attrs.extend([
        Attr::new("subdivisionScheme", "token", Value::Token("none".into())).uniform(),
        Attr::streamed("points", "point3f[]", Stream::Points),
        Attr::streamed("normals", "normal3f[]", Stream::Normals).vertex(),
        Attr::streamed("extent", "float3[]", Stream::Extent),
    ]);
    p
}

/// A scene parameter as a custom attribute.
fn param_attr(p: &SceneParam) -> Attr {
    let (type_name, value) = match &p.value {
        ParamValue::Bool(b) => ("bool", Value::Bool(*b)),
        ParamValue::Int(i) => match i32::try_from(*i) {
            Ok(i) => ("int", Value::Int(i)),
            Err(_) => ("double", Value::Double(*i as f64)),
        },
        ParamValue::Float(f) => ("double", Value::Double(*f)),
        ParamValue::Text(s) => ("string", Value::String(s.clone())),
        ParamValue::Ints(v) => match v.iter().map(|&i| i32::try_from(i)).collect() {
            Ok(ints) => match v.len() {
                2 => ("int2", Value::IntTuple(ints)),
                3 => ("int3", Value::IntTuple(ints)),
                4 => ("int4", Value::IntTuple(ints)),
                _ => ("int[]", Value::Ints(ints)),
            },
            Err(_) => (
                "double[]",
                Value::Doubles(v.iter().map(|&i| i as f64).collect()),
            ),
        },
        ParamValue::Floats(v) => match v.len() {
            2 => ("double2", Value::DoubleTuple(v.clone())),
            3 => ("double3", Value::DoubleTuple(v.clone())),
            4 => ("double4", Value::DoubleTuple(v.clone())),
            _ => ("double[]", Value::Doubles(v.clone())),
        },
    };
    Attr::new(&p.name, type_name, value).custom()
}

/// A collider's motion as `xformOp`s about its pivot `pivot` (m) with scene rotation `base`
/// (degrees): translate to the pivot plus each key's offset, rotate by `base` plus each key's
/// rotation, at time code `time * fps` (USD interpolates samples linearly and holds them
/// outside, as the keys do). A still collider gets the fixed pivot, and a rotation only if
/// `base` is not zero.
fn motion_ops(c: &Collider, pivot: [f64; 3], base: [f64; 3], fps: f64) -> XformOps {
    let add = |a: [f64; 3], b: wetcloth::Vec3| [a[0] + b.x, a[1] + b.y, a[2] + b.z];
    if c.keys.is_empty() {
        return XformOps {
            rotate_xyz: (base != [0.0; 3]).then_some(Motion::Fixed(base)),
            ..XformOps::translate(pivot)
        };
    }
    let at = |f: &dyn Fn(&wetcloth::collide::Key) -> [f64; 3]| {
        Motion::Keys(c.keys.iter().map(|k| (k.time * fps, f(k))).collect())
    };
    XformOps {
        translate: Some(at(&|k| add(pivot, k.offset))),
        rotate_xyz: Some(at(&|k| add(base, k.rotation))),
        scale: None,
    }
}

/// A collider's prim, named `<shape>_<k>`. `cloth_size` (m) sizes a plane's quad; `fps` is
/// the stage's time codes per second, for a moving collider's time samples.
fn collider_prim(k: usize, c: &Collider, cloth_size: f64, fps: f64) -> Prim {
    let custom = |name: &str, type_name, value| Attr::new(name, type_name, value).custom();
    let shape = |s: &str| custom("wetcloth:shape", "token", Value::Token(s.into()));
    let friction = |f: f64| custom("wetcloth:friction", "double", Value::Double(f));
    let d3 = |v: &[f64; 3]| Value::DoubleTuple(v.to_vec());
    let mu = &c.friction;
    match &c.shape {
        Shape::Plane(Plane { point, normal }) => {
            let (point, normal) = (&point.to_array(), &normal.to_array());
            let half = (PLANE_HALF_SIDE * cloth_size).max(PLANE_MIN_HALF_SIDE);
            let mut p = if c.keys.is_empty() {
                plane_quad(&format!("plane_{k}"), *point, *normal, half)
            } else {
                // About its point, which the keys move.
                let mut p = plane_quad(&format!("plane_{k}"), [0.0; 3], *normal, half);
                motion_ops(c, *point, [0.0; 3], fps).author(&mut p);
                p
            };
            p.attrs.extend([
                shape("plane"),
                friction(*mu),
                custom("wetcloth:point", "double3", d3(point)),
                custom("wetcloth:normal", "double3", d3(normal)),
            ]);
            p
        }
        Shape::Sphere(Sphere { center, radius }) => {
            let center = &center.to_array();
            let mut p = Prim::new(&format!("sphere_{k}"), "Sphere");
            let r = *radius as f32;
            p.attrs = vec![
                Attr::new("radius", "double", Value::Double(*radius)),
                Attr::new("extent", "float3[]", Value::Float3s(vec![[-r; 3], [r; 3]])),
            ];
            motion_ops(c, *center, [0.0; 3], fps).author(&mut p);
            p.attrs.extend([shape("sphere"), friction(*mu)]);
            p
        }
        Shape::Box(Cuboid {
            center,
            half_extents,
        }) => {
            let (center, half_extents) = (&center.to_array(), &half_extents.to_array());
            let mut p = Prim::new(&format!("box_{k}"), "Cube");
            p.attrs = vec![
                Attr::new("size", "double", Value::Double(2.0)),
                Attr::new(
                    "extent",
                    "float3[]",
                    Value::Float3s(vec![[-1.0; 3], [1.0; 3]]),
                ),
            ];
            XformOps {
                scale: Some(Motion::Fixed(*half_extents)),
                ..motion_ops(c, *center, [0.0; 3], fps)
            }
            .author(&mut p);
            p.attrs.extend([
                shape("box"),
                friction(*mu),
                custom("wetcloth:half_extents", "double3", d3(half_extents)),
            ]);
            p
        }
        Shape::Mesh(m) => {
            // The model's own points, placed (and moved) by the xform ops.
            let points: Vec<[f32; 3]> = m
                .vertices()
                .iter()
                .map(|v| v.to_array().map(|c| c as f32))
                .collect();
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for q in &points {
                for i in 0..3 {
                    lo[i] = lo[i].min(q[i]);
                    hi[i] = hi[i].max(q[i]);
                }
            }
            let indices = m
                .triangles()
                .iter()
                .flat_map(|t| t.map(|i| i as i32))
                .collect();
            let mut p = Prim::new(&format!("mesh_{k}"), "Mesh");
            p.attrs = vec![
                Attr::new(
                    "faceVertexCounts",
                    "int[]",
                    Value::Ints(vec![3; m.triangles().len()]),
                ),
                Attr::new("faceVertexIndices", "int[]", Value::Ints(indices)),
                Attr::new("points", "point3f[]", Value::Float3s(points)),
                Attr::new("extent", "float3[]", Value::Float3s(vec![lo, hi])),
                Attr::new("subdivisionScheme", "token", Value::Token("none".into())).uniform(),
            ];
            let s = m.scale;
            XformOps {
                scale: (s != 1.0).then_some(Motion::Fixed([s; 3])),
                ..motion_ops(c, m.position.to_array(), m.rotation.to_array(), fps)
            }
            .author(&mut p);
            p.attrs.extend([
                shape("mesh"),
                friction(*mu),
                custom("wetcloth:file", "string", Value::String(m.file.clone())),
            ]);
            p
        }
    }
}

/// A Mesh prim: one quad of half side `half` centred on `point`, facing `normal`.
fn plane_quad(name: &str, point: [f64; 3], normal: [f64; 3], half: f64) -> Prim {
    let n = normalize(normal);
    let points = plane_corners(point, normal, half);
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in &points {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    let nf = n.map(|c| c as f32);
    let mut p = Prim::new(name, "Mesh");
    p.attrs = vec![
        Attr::new("faceVertexCounts", "int[]", Value::Ints(vec![4])),
        Attr::new("faceVertexIndices", "int[]", Value::Ints(vec![0, 1, 2, 3])),
        Attr::new("points", "point3f[]", Value::Float3s(points)),
        Attr::new("normals", "normal3f[]", Value::Float3s(vec![nf; 4])).vertex(),
        Attr::new("extent", "float3[]", Value::Float3s(vec![lo, hi])),
        Attr::new("subdivisionScheme", "token", Value::Token("none".into())).uniform(),
    ];
    p
}

/// The corners of a square of half side `half` (m) centred on `point` in the plane through
/// it with normal `normal`, counter-clockwise seen from the normal's side (the quad that
/// stands for a plane collider).
pub(crate) fn plane_corners(point: [f64; 3], normal: [f64; 3], half: f64) -> Vec<[f32; 3]> {
    let n = normalize(normal);
    // A tangent: the cross product of the normal with the axis it is least aligned with.
    let axis = if n[0].abs() <= n[1].abs() && n[0].abs() <= n[2].abs() {
        [1.0, 0.0, 0.0]
    } else if n[1].abs() <= n[2].abs() {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    let u = normalize(cross(n, axis));
    let v = cross(n, u);
    // Counter-clockwise seen from the normal's side: u, v, n is right-handed.
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    corners
        .iter()
        .map(|(a, b)| std::array::from_fn(|i| (point[i] + half * (a * u[i] + b * v[i])) as f32))
        .collect()
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    if l > 0.0 {
        a.map(|c| c / l)
    } else {
        [0.0, 1.0, 0.0]
    }
}

/// A vector that is fixed or moves through key frames.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Motion {
    /// The same value at all times.
    Fixed([f64; 3]),
    /// `(time code, value)` keys, in increasing time: linear between keys, held before the
    /// first and after the last (USD's rule for time samples).
    Keys(Vec<(f64, [f64; 3])>),
}

impl Motion {
    fn data(&self) -> Data {
        match self {
            Motion::Fixed(v) => Data::Default(Value::DoubleTuple(v.to_vec())),
            Motion::Keys(keys) => Data::Samples(
                keys.iter()
                    .map(|(t, v)| (*t, Value::DoubleTuple(v.to_vec())))
                    .collect(),
            ),
        }
    }
}

/// A prim's placement: translate, then rotate about x, y, z in that order (degrees), then
/// scale, applied to the prim's own geometry in the reverse order (scale first), as USD's
/// `xformOpOrder = [translate, rotateXYZ, scale]` does.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct XformOps {
    pub translate: Option<Motion>,
    pub rotate_xyz: Option<Motion>,
    pub scale: Option<Motion>,
}

impl XformOps {
    fn translate(t: [f64; 3]) -> Self {
        Self {
            translate: Some(Motion::Fixed(t)),
            ..Self::default()
        }
    }

    /// Adds the `xformOp:*` attributes and `xformOpOrder` to `prim`.
    fn author(&self, prim: &mut Prim) {
        let ops = [
            ("xformOp:translate", &self.translate),
            ("xformOp:rotateXYZ", &self.rotate_xyz),
            ("xformOp:scale", &self.scale),
        ];
        let mut order = Vec::new();
        for (name, motion) in ops {
            if let Some(m) = motion {
                prim.attrs.push(Attr {
                    data: m.data(),
                    ..Attr::new(name, "double3", Value::Bool(false))
                });
                order.push(name.to_string());
            }
        }
        if !order.is_empty() {
            prim.attrs
                .push(Attr::new("xformOpOrder", "token[]", Value::Tokens(order)).uniform());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plane_quad_faces_its_normal_and_lies_in_the_plane() {
        for normal in [[0.0, 1.0, 0.0], [0.3, 0.9, -0.2], [0.0, 0.0, -1.0]] {
            let p = plane_quad("p", [0.1, 0.2, 0.3], normal, 2.0);
            let Data::Default(Value::Float3s(pts)) = &p.attrs[2].data else {
                panic!("points")
            };
            let n = normalize(normal);
            let d = |q: &[f32; 3]| -> [f64; 3] {
                [q[0] as f64 - 0.1, q[1] as f64 - 0.2, q[2] as f64 - 0.3]
            };
            for q in pts {
                let r = d(q);
                let along = r[0] * n[0] + r[1] * n[1] + r[2] * n[2];
                assert!(along.abs() < 1e-6, "{q:?} off the plane");
            }
            // Counter-clockwise about the normal: (p1 - p0) x (p2 - p0) = 4 x 4 along n.
            let (a, b, c) = (d(&pts[0]), d(&pts[1]), d(&pts[2]));
            let w = cross(
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            let dot = w[0] * n[0] + w[1] * n[1] + w[2] * n[2];
            assert!((dot - 16.0).abs() < 1e-4, "{dot}");
        }
    }

    /// A mesh collider is written with its model's triangles and points, placed by its
    /// position, rotation and scale; a moving collider's keys become time samples at
    /// `time * fps` of its pivot plus offset and its rotation plus the key's.
    #[test]
    fn mesh_colliders_carry_their_triangles_and_motion() {
        use wetcloth::Vec3;
        use wetcloth::collide::{Key, Mesh};
        let v = vec![Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::Y];
        let f = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let mesh = Mesh::new(
            "/m/tetra.obj",
            v,
            f,
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(0.0, 90.0, 0.0),
            0.5,
        )
        .unwrap();
        let mut c = Collider::mesh(mesh, 0.4);
        c.keys = vec![
            Key {
                time: 0.5,
                offset: Vec3::ZERO,
                rotation: Vec3::ZERO,
            },
            Key {
                time: 1.0,
                offset: Vec3::new(0.0, -0.1, 0.0),
                rotation: Vec3::new(0.0, 0.0, 30.0),
            },
        ];
        let p = collider_prim(2, &c, 0.3, 60.0);
        assert_eq!((p.name.as_str(), p.type_name), ("mesh_2", "Mesh"));
        let attr = |name: &str| {
            &p.attrs
                .iter()
                .find(|a| a.name == name)
                .unwrap_or_else(|| panic!("no {name}"))
                .data
        };
        let Data::Default(Value::Ints(counts)) = attr("faceVertexCounts") else {
            panic!("counts")
        };
        assert_eq!(counts, &vec![3; 4]);
        let Data::Default(Value::Ints(indices)) = attr("faceVertexIndices") else {
            panic!("indices")
        };
        assert_eq!(indices[..6], [0, 2, 1, 0, 1, 3]);
        let Data::Default(Value::Float3s(points)) = attr("points") else {
            panic!("points")
        };
        assert_eq!(points[3], [0.0, 1.0, 0.0]);
        let Data::Samples(t) = attr("xformOp:translate") else {
            panic!("translate samples")
        };
        assert_eq!(t.len(), 2);
        assert_eq!(t[0], (30.0, Value::DoubleTuple(vec![1.0, 2.0, 3.0])));
        let Data::Samples(r) = attr("xformOp:rotateXYZ") else {
            panic!("rotate samples")
        };
        assert_eq!(r[1], (60.0, Value::DoubleTuple(vec![0.0, 90.0, 30.0])));
        let Data::Default(Value::DoubleTuple(scale)) = attr("xformOp:scale") else {
            panic!("scale")
        };
        assert_eq!(scale, &vec![0.5; 3]);
        // A still sphere keeps its fixed translate and no rotation.
        let p = collider_prim(0, &Collider::sphere(Vec3::X, 0.1, 0.5), 0.3, 60.0);
        assert!(p.attrs.iter().all(|a| a.name != "xformOp:rotateXYZ"));
    }

    #[test]
    fn xform_ops_are_listed_in_order_and_keys_become_time_samples() {
        let mut p = Prim::new("m", "Mesh");
        XformOps {
            translate: Some(Motion::Keys(vec![(0.0, [0.0; 3]), (30.0, [0.0, 1.0, 0.0])])),
            rotate_xyz: None,
            scale: Some(Motion::Fixed([2.0; 3])),
        }
        .author(&mut p);
        let names: Vec<&str> = p.attrs.iter().map(|a| a.name.as_str()).collect();
        assert_eq!(
            names,
            ["xformOp:translate", "xformOp:scale", "xformOpOrder"]
        );
        assert_eq!(
            p.attrs[0].data,
            Data::Samples(vec![
                (0.0, Value::DoubleTuple(vec![0.0; 3])),
                (30.0, Value::DoubleTuple(vec![0.0, 1.0, 0.0]))
            ])
        );
        assert_eq!(
            p.attrs[2].data,
            Data::Default(Value::Tokens(vec![
                "xformOp:translate".into(),
                "xformOp:scale".into()
            ]))
        );
        assert!(p.attrs[2].uniform);
    }
}
