//! The scene file as written (every key optional), its conversion to a [`SimConfig`], and the
//! mapping of every error back to a place in the file.

use crate::error::{Location, SceneError};
use crate::keys;
use serde::Deserialize;
use std::ops::Range;
use toml::Spanned;
use toml::de::DeTable;
use wetcloth::collide::{Cuboid, Key, Mesh, Plane, Sphere};
use wetcloth::{
    AirModelKind, AirParams, ClothParams, Collider, ConfigError, GrabKey, GrabSpec, Integrator,
    PaintShape, PocketSeed, PressureForce, PressureSolve, Real, Shape, SimConfig, SimulationParams,
    SolveBudget, Vec3, WetPaint,
};
use wetcloth::{BendingRest, ClothMeshSource, ClothModel, GrabPick, MembraneParams};

/// A fixed-length array that, unlike `[T; N]`, refuses extra elements.
struct Arr<T, const N: usize>([T; N]);

impl<'de, T: Deserialize<'de>, const N: usize> Deserialize<'de> for Arr<T, N> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Vec::<T>::deserialize(d)?;
        let len = v.len();
        v.try_into().map(Arr).map_err(|_| {
            serde::de::Error::invalid_length(len, &format!("an array of {N} elements").as_str())
        })
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    name: Option<Spanned<String>>,
    simulation: Option<RawSimulation>,
    cloth: Option<RawCloth>,
    air: Option<RawAir>,
    collider: Option<Vec<Spanned<RawCollider>>>,
    #[serde(default)]
    grab: Vec<Spanned<RawGrab>>,
    #[serde(default)]
    attach: Vec<Spanned<RawAttach>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAttach {
    collider: usize,
    vertex: Option<usize>,
    near: Option<Arr<Real, 3>>,
    within: Option<RawWithin>,
    stiffness: Option<Real>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSimulation {
    duration: Option<Real>,
    time_step: Option<Real>,
    integrator: Option<Spanned<String>>,
    implicit_budget: Option<Spanned<String>>,
    frame_rate: Option<Real>,
    gravity: Option<Arr<Real, 3>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCloth {
    size: Option<Arr<Real, 2>>,
    resolution: Option<Arr<usize, 2>>,
    position: Option<Arr<Real, 3>>,
    mass: Option<Real>,
    structural_stiffness: Option<Real>,
    shear_stiffness: Option<Real>,
    damping: Option<Real>,
    thickness: Option<Real>,
    collision_margin: Option<Real>,
    self_collision: Option<bool>,
    strain_limit: Option<Real>,
    strain_limit_iterations: Option<usize>,
    wetness: Option<Real>,
    water_mass: Option<Real>,
    dry_friction_factor: Option<Real>,
    wet_adhesion: Option<Real>,
    paint: Option<Vec<Spanned<RawPaint>>>,
    mesh: Option<Spanned<String>>,
    rotation: Option<Spanned<Arr<Real, 3>>>,
    scale: Option<Spanned<Real>>,
    flip_normals: Option<Spanned<bool>>,
    model: Option<Spanned<String>>,
    membrane: Option<RawMembrane>,
    bending: Option<RawBending>,
    density: Option<Spanned<Real>>,
    material: Option<Spanned<String>>,
    seam: Option<Vec<RawSeam>>,
    shrink: Option<Real>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSeam {
    a: Vec<u32>,
    b: Vec<u32>,
    stiffness: Option<Real>,
    max_force: Option<Real>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMembrane {
    warp: Option<Real>,
    weft: Option<Real>,
    shear: Option<Real>,
    poisson: Option<Real>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBending {
    stiffness: Option<Real>,
    warp: Option<Real>,
    weft: Option<Real>,
    rest: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPaint {
    center: Option<Spanned<Vec<Real>>>,
    radius: Option<Real>,
    half_size: Option<Spanned<Vec<Real>>>,
    wetness: Real,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAir {
    enabled: Option<bool>,
    atmospheric_pressure: Option<Real>,
    trapped_air: Option<Real>,
    leak_conductance: Option<Real>,
    pressure_solve: Option<Spanned<String>>,
    pressure_force: Option<Spanned<String>>,
    model: Option<Spanned<String>>,
    seal_distance: Option<Real>,
    seal_hysteresis: Option<Real>,
    seal_wetness: Option<Real>,
    permeability: Option<Real>,
    dry_permeability: Option<Real>,
    pocket: Option<Vec<RawPocket>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPocket {
    center: Spanned<Vec<Real>>,
    radius: Real,
    amount: Real,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCollider {
    shape: Spanned<String>,
    point: Option<Spanned<Arr<Real, 3>>>,
    normal: Option<Spanned<Arr<Real, 3>>>,
    center: Option<Spanned<Arr<Real, 3>>>,
    radius: Option<Spanned<Real>>,
    half_extents: Option<Spanned<Arr<Real, 3>>>,
    file: Option<Spanned<String>>,
    position: Option<Spanned<Arr<Real, 3>>>,
    rotation: Option<Spanned<Arr<Real, 3>>>,
    scale: Option<Spanned<Real>>,
    sequence: Option<Spanned<String>>,
    cache: Option<Spanned<String>>,
    frame_rate: Option<Spanned<Real>>,
    start: Option<Spanned<Real>>,
    friction: Option<Real>,
    sticky: Option<bool>,
    keys: Option<Vec<RawColliderKey>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawColliderKey {
    time: Real,
    offset: Option<Arr<Real, 3>>,
    rotation: Option<Arr<Real, 3>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGrab {
    particle: Option<Arr<usize, 2>>,
    vertex: Option<usize>,
    near: Option<Arr<Real, 3>>,
    within: Option<RawWithin>,
    keys: Vec<RawGrabKey>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWithin {
    center: Arr<Real, 3>,
    radius: Option<Real>,
    half_size: Option<Arr<Real, 3>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGrabKey {
    time: Real,
    offset: Arr<Real, 3>,
}

/// Default Coulomb friction of a collider without a `friction` key.
pub const DEFAULT_FRICTION: Real = 0.6;

/// The collider of a scene without `[[collider]]`: the ground, a plane through the origin facing
/// +Y with the default friction.
pub fn default_ground() -> Collider {
    Collider::plane(Vec3::ZERO, Vec3::Y, DEFAULT_FRICTION)
}

/// The collider shapes a scene may name.
pub const SHAPES: [&str; 4] = ["plane", "sphere", "box", "mesh"];

/// Context for building errors that point into the text.
pub(crate) struct Ctx<'a> {
    file: &'a str,
    text: &'a str,
}

impl Ctx<'_> {
    pub(crate) fn at(&self, span: Range<usize>) -> Box<Location> {
        Box::new(Location::of_span(self.file, self.text, span))
    }

    pub(crate) fn raw(&self, span: &Range<usize>) -> String {
        self.text
            .get(span.clone())
            .unwrap_or("?")
            .trim()
            .to_string()
    }
}

/// Parses `text` into the scene's name and configuration (not yet range-checked).
pub fn parse(
    text: &str,
    file: &str,
    default_name: &str,
) -> Result<(String, SimConfig), SceneError> {
    let cx = Ctx { file, text };
    let doc = DeTable::parse(text).map_err(|e| {
        let message = e.message().trim().to_string();
        let span = e.span().or_else(|| {
            first_line_where(text, |prefix| {
                DeTable::parse(prefix)
                    .is_err_and(|e| e.span().is_none() && e.message().trim() == message)
            })
        });
        SceneError::Syntax {
            at: span.map_or_else(|| Box::new(Location::file_only(file)), |s| cx.at(s)),
            message: syntax_help(&message),
        }
    })?;
    if let Some(u) = keys::find_unknown(doc.get_ref()) {
        return Err(SceneError::UnknownKey {
            at: cx.at(u.span),
            key: u.key,
            suggestion: u.suggestion,
            valid: u.valid.iter().map(|s| s.to_string()).collect(),
        });
    }
    let raw: RawScene = toml::from_str(text).map_err(|e| serde_error(&cx, &doc, &e))?;
    convert(&cx, &doc, raw, default_name)
}

/// The span of the first line `i` such that `fails(text up to the end of line i)`, by
/// bisection: for errors the parser reports without a position (a recursion limit), the
/// first line whose text triggers them. `fails` must hold for every longer prefix once it
/// holds for one (the parser stops at the first error).
fn first_line_where(text: &str, fails: impl Fn(&str) -> bool) -> Option<Range<usize>> {
    let ends: Vec<usize> = text
        .match_indices('\n')
        .map(|(i, _)| i + 1)
        .chain((!text.ends_with('\n')).then_some(text.len()))
        .collect();
    if ends.is_empty() || !fails(text) {
        return None;
    }
    let (mut lo, mut hi) = (0, ends.len() - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if fails(&text[..ends[mid]]) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    let start = if lo == 0 { 0 } else { ends[lo - 1] };
    Some(start..ends[lo])
}

/// The TOML parser's message, with a word on what to do where it is terse.
fn syntax_help(message: &str) -> String {
    if message.contains("recursion") {
        format!("{message}: keys or values nested too deeply (a scene needs at most 4 levels)")
    } else {
        message.to_string()
    }
}

/// Maps a deserialisation error (a wrong type, a missing key) to the key it is about.
fn serde_error(cx: &Ctx<'_>, doc: &Spanned<DeTable<'_>>, e: &toml::de::Error) -> SceneError {
    let message = e.message().trim().to_string();
    let Some(span) = e.span() else {
        let line = first_line_where(cx.text, |prefix| {
            toml::from_str::<RawScene>(prefix)
                .is_err_and(|e| e.span().is_none() && e.message().trim() == message)
        });
        return SceneError::Syntax {
            at: line.map_or_else(|| Box::new(Location::file_only(cx.file)), |s| cx.at(s)),
            message: syntax_help(&message),
        };
    };
    let key = keys::path_at(doc.get_ref(), span.start).unwrap_or_default();
    if let Some(field) = message
        .strip_prefix("missing field `")
        .and_then(|m| m.split('`').next())
    {
        let key = if key.is_empty() {
            field.to_string()
        } else {
            format!("{key}.{field}")
        };
        return SceneError::Missing {
            at: cx.at(span),
            message: missing_help(field).to_string(),
            key,
        };
    }
    // A table written as an array of tables (`[[simulation]]`) or the other way round: the
    // key is the top-level one, whatever element serde was reading.
    let root = key.split(['.', '[']).next().unwrap_or("").to_string();
    let key = match keys::expected_at_top(&root) {
        Some(_) if !key.contains('.') => root.clone(),
        _ => key,
    };
    let found = keys::kind_at(doc, cx.text, &key);
    let message = match (keys::expected_at_top(&key), &found) {
        (Some(expected), Some(found)) => format!("expected {expected}, found {found}"),
        // serde reads a date-time as a map: say what it is.
        (None, Some(found)) if found.starts_with("a date-time") => {
            let expected = friendly_types(&message);
            let expected = expected
                .strip_prefix("expected ")
                .and_then(|e| e.split(", found ").next())
                .unwrap_or("another type")
                .to_string();
            format!("expected {expected}, found {found}")
        }
        _ => friendly_types(&message),
    };
    SceneError::WrongType {
        at: cx.at(span.clone()),
        key,
        value: cx.raw(&span),
        message,
    }
}

fn missing_help(field: &str) -> &'static str {
    match field {
        "shape" => "every [[collider]] needs shape = \"plane\", \"sphere\", \"box\" or \"mesh\"",
        "particle" => {
            "every [[grab]] needs one of particle = [column, row] (the grid), vertex = K, near = \
             [x, y, z] or within = { center = [x, y, z], radius = R }"
        }
        "keys" => "every [[grab]] needs keys = [{ time = ..., offset = [x, y, z] }, ...]",
        "time" => "every grab key needs time = ... (s)",
        "offset" => "every grab key needs offset = [x, y, z] (m)",
        _ => "this key is required here",
    }
}

/// Rewrites serde's message in words: `invalid type: string "a", expected f64` becomes
/// `expected a number, found string "a"`.
fn friendly_types(message: &str) -> String {
    let words = |s: &str| {
        if s.starts_with("struct Raw") {
            return "a table".to_string();
        }
        s.replace("f64", "a number")
            .replace("usize", "a non-negative integer")
            .replace("a boolean", "true or false")
            .replace("a sequence", "an array")
    };
    for (prefix, found) in [
        ("invalid type: ", ""),
        ("invalid value: ", ""),
        ("invalid length ", "length "),
    ] {
        if let Some((what, expected)) = message
            .strip_prefix(prefix)
            .and_then(|m| m.split_once(", expected "))
        {
            return format!("expected {}, found {found}{what}", words(expected));
        }
    }
    words(message)
}

fn vec3(a: Arr<Real, 3>) -> Vec3 {
    Vec3::from_array(a.0)
}

fn convert(
    cx: &Ctx<'_>,
    doc: &Spanned<DeTable<'_>>,
    raw: RawScene,
    default_name: &str,
) -> Result<(String, SimConfig), SceneError> {
    let name = match raw.name {
        Some(n) => {
            crate::check_name(n.get_ref()).map_err(|message| SceneError::Invalid {
                at: cx.at(n.span()),
                key: "name".into(),
                value: format!("{:?}", n.get_ref()),
                message,
            })?;
            n.into_inner()
        }
        None => sanitize_name(default_name),
    };

    let mut simulation = SimulationParams::default();
    if let Some(s) = raw.simulation {
        let d = &mut simulation;
        set(&mut d.duration, s.duration);
        set(&mut d.time_step, s.time_step);
        set(&mut d.frame_rate, s.frame_rate);
        set(&mut d.gravity, s.gravity.map(vec3));
        if let Some(i) = s.integrator {
            d.integrator = named(
                cx,
                &i,
                "simulation.integrator",
                "integrator",
                Integrator::ALL,
                Integrator::name,
            )?;
        }
        if let Some(b) = s.implicit_budget {
            d.implicit_budget = named(
                cx,
                &b,
                "simulation.implicit_budget",
                "implicit budget",
                SolveBudget::ALL,
                SolveBudget::name,
            )?;
        }
    }

    let mut cloth = ClothParams::default();
    if let Some(c) = raw.cloth {
        let d = &mut cloth;
        set(&mut d.size, c.size.as_ref().map(|a| a.0));
        set(&mut d.resolution, c.resolution.as_ref().map(|a| a.0));
        set(
            &mut d.position,
            c.position.as_ref().map(|a| Vec3::from(a.0)),
        );
        set(&mut d.mass, c.mass);
        set(&mut d.structural_stiffness, c.structural_stiffness);
        set(&mut d.shear_stiffness, c.shear_stiffness);
        set(&mut d.damping, c.damping);
        set(&mut d.thickness, c.thickness);
        set(&mut d.collision_margin, c.collision_margin);
        set(&mut d.self_collision, c.self_collision);
        set(&mut d.strain_limit, c.strain_limit);
        set(&mut d.strain_limit_iterations, c.strain_limit_iterations);
        set(&mut d.wetness, c.wetness);
        set(&mut d.water_mass, c.water_mass);
        set(&mut d.dry_friction_factor, c.dry_friction_factor);
        set(&mut d.wet_adhesion, c.wet_adhesion);
        fabric_keys(cx, d, &c)?;
        if let Some(file) = &c.mesh {
            for (k, given) in [
                ("size", c.size.is_some()),
                ("resolution", c.resolution.is_some()),
            ] {
                if given {
                    return Err(SceneError::Invalid {
                        at: cx.at(file.span()),
                        key: format!("cloth.{k}"),
                        value: cx.raw(&file.span()),
                        message: format!(
                            "`{k}` describes the built-in grid and cannot be given with `mesh`: \
                             a mesh cloth's size and particles are its file's"
                        ),
                    });
                }
            }
            if c.position.is_none() {
                d.position = Vec3::ZERO;
            }
            d.mesh = Some(cloth_mesh(cx, file, &c)?);
        } else {
            for (k, given) in [
                ("rotation", c.rotation.as_ref().map(|s| s.span())),
                ("scale", c.scale.as_ref().map(|s| s.span())),
                ("flip_normals", c.flip_normals.as_ref().map(|s| s.span())),
            ] {
                if let Some(span) = given {
                    return Err(SceneError::Invalid {
                        at: cx.at(span.clone()),
                        key: format!("cloth.{k}"),
                        value: cx.raw(&span),
                        message: format!(
                            "`{k}` places a mesh cloth: it needs `mesh = \"file.obj\"` in [cloth]"
                        ),
                    });
                }
            }
        }
        set(&mut d.shrink, c.shrink);
        for s in c.seam.unwrap_or_default() {
            d.seams.push(wetcloth::forces::seam::SeamSpec {
                a: s.a,
                b: s.b,
                stiffness: s
                    .stiffness
                    .unwrap_or(wetcloth::forces::seam::SeamSpec::DEFAULT_STIFFNESS),
                max_force: s
                    .max_force
                    .unwrap_or(wetcloth::forces::seam::SeamSpec::DEFAULT_MAX_FORCE),
            });
        }
        let on_mesh = d.mesh.is_some();
        for (i, p) in c.paint.unwrap_or_default().into_iter().enumerate() {
            let span = p.span();
            let p = p.into_inner();
            let dims = if on_mesh { 3 } else { 2 };
            let bad_len = |v: &Spanned<Vec<Real>>, what: &str| SceneError::Invalid {
                at: cx.at(v.span()),
                key: format!("cloth.paint[{i}].{what}"),
                value: cx.raw(&v.span()),
                message: if on_mesh {
                    format!(
                        "on a mesh cloth `{what}` has 3 components [x, y, z] (m, scene coordinates at t = 0)"
                    )
                } else {
                    format!(
                        "on the grid `{what}` has 2 components [x, z] (m from the cloth's centre)"
                    )
                },
            };
            for v in [&p.center, &p.half_size].into_iter().flatten() {
                if v.get_ref().len() != dims {
                    let what =
                        if std::ptr::eq(v, p.center.as_ref().unwrap_or(v)) && p.center.is_some() {
                            "center"
                        } else {
                            "half_size"
                        };
                    return Err(bad_len(v, what));
                }
            }
            let center = p.center.as_ref().map(|c| c.get_ref().clone());
            let shape = match (p.radius, p.half_size.as_ref().map(|h| h.get_ref().clone())) {
                (Some(r), None) => PaintShape::Disc(r),
                (None, Some(h)) if on_mesh => PaintShape::Cuboid([h[0], h[1], h[2]]),
                (None, Some(h)) => PaintShape::Box([h[0], h[1]]),
                (r, _) => {
                    return Err(SceneError::Invalid {
                        at: cx.at(span.clone()),
                        key: format!("cloth.paint[{i}]"),
                        value: cx.raw(&span),
                        message: if r.is_some() {
                            "a painted region has either `radius` (a disc) or `half_size` (a \
                             box), not both"
                        } else {
                            "a painted region needs `radius` (a disc, m) or `half_size` (a box, \
                             [x, z] in m)"
                        }
                        .into(),
                    });
                }
            };
            let (center, point) = match center {
                Some(c) if on_mesh => ([c[0], c[2]], Some(Vec3::new(c[0], c[1], c[2]))),
                Some(c) => ([c[0], c[1]], None),
                None => ([0.0, 0.0], on_mesh.then_some(Vec3::ZERO)),
            };
            d.paint.push(WetPaint {
                center,
                shape,
                wetness: p.wetness,
                point,
            });
        }
    }

    let mut air = AirParams::default();
    if let Some(a) = raw.air {
        set(&mut air.enabled, a.enabled);
        set(&mut air.atmospheric_pressure, a.atmospheric_pressure);
        set(&mut air.trapped_air, a.trapped_air);
        set(&mut air.leak_conductance, a.leak_conductance);
        if let Some(p) = a.pressure_solve {
            air.pressure_solve = named(
                cx,
                &p,
                "air.pressure_solve",
                "pressure solve",
                PressureSolve::ALL,
                PressureSolve::name,
            )?;
        }
        if let Some(p) = a.pressure_force {
            air.pressure_force = named(
                cx,
                &p,
                "air.pressure_force",
                "pressure force",
                PressureForce::ALL,
                PressureForce::name,
            )?;
        }
        if let Some(m) = a.model {
            air.model = named(
                cx,
                &m,
                "air.model",
                "air model",
                AirModelKind::ALL,
                AirModelKind::name,
            )?;
        }
        set(&mut air.seal_distance, a.seal_distance);
        set(&mut air.seal_hysteresis, a.seal_hysteresis);
        set(&mut air.seal_wetness, a.seal_wetness);
        set(&mut air.permeability, a.permeability);
        set(&mut air.dry_permeability, a.dry_permeability);
        // On a mesh cloth a seed's `center` is a point of the scene at t = 0; on the grid (either
        // model) it is `[x, z]` from the cloth's centre at rest, as `[[cloth.paint]]`'s.
        let on_mesh = cloth.mesh.is_some();
        for (i, p) in a.pocket.unwrap_or_default().into_iter().enumerate() {
            let c = p.center.get_ref();
            let dims = if on_mesh { 3 } else { 2 };
            if c.len() != dims {
                return Err(SceneError::Invalid {
                    at: cx.at(p.center.span()),
                    key: format!("air.pocket[{i}].center"),
                    value: cx.raw(&p.center.span()),
                    message: if on_mesh {
                        "on a mesh cloth `center` has 3 components [x, y, z] (m, scene \
                         coordinates at t = 0)"
                    } else {
                        "on the grid `center` has 2 components [x, z] (m from the cloth's \
                         centre at rest)"
                    }
                    .into(),
                });
            }
            let (center, point) = if on_mesh {
                ([c[0], c[2]], Some(Vec3::new(c[0], c[1], c[2])))
            } else {
                ([c[0], c[1]], None)
            };
            air.pockets.push(PocketSeed {
                center,
                radius: p.radius,
                amount: p.amount,
                point,
            });
        }
    }

    // No `[[collider]]` at all means the ground (the thesis' table); `collider = []` means none.
    let colliders = match raw.collider {
        None => vec![default_ground()],
        Some(list) => list
            .into_iter()
            .enumerate()
            .map(|(i, c)| collider(cx, doc, i, c))
            .collect::<Result<Vec<_>, _>>()?,
    };

    let on_mesh = cloth.mesh.is_some();
    let grabs = raw
        .grab
        .into_iter()
        .enumerate()
        .map(|(i, g)| {
            let span = g.span();
            let g = g.into_inner();
            let fail = |message: String| SceneError::Invalid {
                at: cx.at(span.clone()),
                key: format!("grab[{i}]"),
                value: cx.raw(&span),
                message,
            };
            let given = usize::from(g.particle.is_some())
                + usize::from(g.vertex.is_some())
                + usize::from(g.near.is_some())
                + usize::from(g.within.is_some());
            if given != 1 {
                return Err(fail(format!(
                    "a grab takes exactly one of `particle = [i, j]` (the grid), `vertex = K`, \
                     `near = [x, y, z]` and `within = {{ center = [x, y, z], radius = R }}` (or \
                     `half_size = [hx, hy, hz]`); found {given}"
                )));
            }
            let particle = g.particle.as_ref().map_or([0, 0], |p| p.0);
            let pick = match (g.particle, g.vertex, g.near, g.within) {
                (Some(_), ..) if on_mesh => {
                    return Err(fail(
                        "`particle = [i, j]` names a grid particle; on a mesh cloth use \
                         `vertex = K` (the file's vertex, from 0), `near` or `within`"
                            .into(),
                    ));
                }
                (Some(_), ..) => None,
                (_, Some(k), ..) => Some(GrabPick::Vertex(k)),
                (_, _, Some(p), _) => Some(GrabPick::Near(vec3(p))),
                (_, _, _, Some(w)) => Some(match (w.radius, w.half_size) {
                    (Some(radius), None) => GrabPick::Ball {
                        center: vec3(w.center),
                        radius,
                    },
                    (None, Some(h)) => GrabPick::Box {
                        center: vec3(w.center),
                        half_size: vec3(h),
                    },
                    _ => {
                        return Err(fail(
                            "`within` takes exactly one of `radius` (a ball, m) and \
                             `half_size` (a box, [hx, hy, hz] in m)"
                                .into(),
                        ));
                    }
                }),
                _ => None,
            };
            Ok(GrabSpec {
                particle,
                pick,
                keys: g
                    .keys
                    .into_iter()
                    .map(|k| GrabKey {
                        time: k.time,
                        offset: vec3(k.offset),
                    })
                    .collect(),
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let attachments = raw
        .attach
        .into_iter()
        .enumerate()
        .map(|(i, a)| attach(cx, i, a))
        .collect::<Result<Vec<_>, _>>()?;

    Ok((
        name,
        SimConfig {
            simulation,
            cloth,
            air,
            colliders,
            grabs,
            attachments,
        },
    ))
}

/// An `[[attach]]` table: its collider and its particles, picked as a grab's.
fn attach(
    cx: &Ctx<'_>,
    i: usize,
    a: Spanned<RawAttach>,
) -> Result<wetcloth::control::AttachSpec, SceneError> {
    let span = a.span();
    let a = a.into_inner();
    let fail = |span: Range<usize>, key: String, message: String| SceneError::Invalid {
        at: cx.at(span.clone()),
        key,
        value: cx.raw(&span),
        message,
    };
    let given = usize::from(a.vertex.is_some())
        + usize::from(a.near.is_some())
        + usize::from(a.within.is_some());
    let pick = match (a.vertex, a.near, a.within) {
        _ if given != 1 => None,
        (Some(k), ..) => Some(GrabPick::Vertex(k)),
        (_, Some(p), _) => Some(GrabPick::Near(vec3(p))),
        (_, _, Some(w)) => match (w.radius, w.half_size) {
            (Some(radius), None) => Some(GrabPick::Ball {
                center: vec3(w.center),
                radius,
            }),
            (None, Some(h)) => Some(GrabPick::Box {
                center: vec3(w.center),
                half_size: vec3(h),
            }),
            _ => None,
        },
        _ => None,
    };
    let pick = pick.ok_or_else(|| {
        fail(
            span,
            format!("attach[{i}]"),
            format!(
                "an attachment takes exactly one of `vertex = K`, `near = [x, y, z]` and \
                 `within = {{ center = [x, y, z], radius = R }}` (or `half_size = [hx, hy, \
                 hz]`, not both); found {given}"
            ),
        )
    })?;
    Ok(wetcloth::control::AttachSpec {
        collider: a.collider,
        pick,
        stiffness: a.stiffness,
    })
}

/// The choice among `all` that `value` names (by `name`), or an error at its span listing the
/// allowed names and suggesting the closest; `what` names the kind of choice in the message.
fn named<T: Copy, const N: usize>(
    cx: &Ctx<'_>,
    value: &Spanned<String>,
    key: &str,
    what: &str,
    all: [T; N],
    name: fn(T) -> &'static str,
) -> Result<T, SceneError> {
    let names = all.map(name);
    all.into_iter()
        .find(|t| name(*t) == value.get_ref())
        .ok_or_else(|| {
            let allowed: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
            SceneError::Invalid {
                at: cx.at(value.span()),
                key: key.into(),
                value: format!("{:?}", value.get_ref()),
                message: format!(
                    "unknown {what}{}: allowed {}",
                    did_you_mean(value.get_ref(), &names),
                    allowed.join(", ")
                ),
            }
        })
}

/// ` (did you mean "x"?)` for the closest of `names` to `value`, or nothing.
fn did_you_mean(value: &str, names: &[&str]) -> String {
    names
        .iter()
        .map(|n| (strsim::jaro_winkler(value, n), *n))
        .filter(|(score, _)| *score >= 0.7)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, n)| format!(" (did you mean \"{n}\"?)"))
        .unwrap_or_default()
}

fn set<T>(field: &mut T, value: Option<T>) {
    if let Some(v) = value {
        *field = v;
    }
}

/// A name usable as a directory from a file stem: characters outside the allowed set become `-`.
fn sanitize_name(stem: &str) -> String {
    let s: String = stem
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '-'
            }
        })
        .collect();
    let s = s.trim_start_matches('.');
    if s.is_empty() {
        "scene".to_string()
    } else {
        s.to_string()
    }
}

/// Normalises a plane normal, keeping it bit for bit when it is already of unit length, so a
/// resolved scene parses back to the same normal. Any finite non-zero vector has a direction,
/// however small or large its components (`[1e-200, 1e-200, 0]`, `[1e300, 1e300, 0]`): it is
/// scaled by its largest component first, so its length neither underflows nor overflows.
/// `None` for the zero vector and for non-finite components.
fn unit(n: Vec3) -> Option<Vec3> {
    if !n.is_finite() {
        return None;
    }
    let len = n.length();
    if (len - 1.0).abs() <= 1e-12 {
        return Some(n);
    }
    let big = n.abs().max_element();
    if big == 0.0 {
        return None;
    }
    let m = n / big;
    Some(m / m.length())
}

fn collider(
    cx: &Ctx<'_>,
    doc: &Spanned<DeTable<'_>>,
    index: usize,
    c: Spanned<RawCollider>,
) -> Result<Collider, SceneError> {
    let table_span = c.span();
    let c = c.into_inner();
    let shape_name = c.shape.get_ref().as_str();
    let key = |k: &str| format!("collider[{index}].{k}");
    // Keys that belong to another shape are a mistake worth naming.
    let allowed: &[&str] = match shape_name {
        "plane" => &["point", "normal"],
        "sphere" => &["center", "radius"],
        "box" => &["center", "half_extents"],
        "mesh" => &[
            "file",
            "position",
            "rotation",
            "scale",
            "sequence",
            "cache",
            "frame_rate",
            "start",
        ],
        _ => {
            return Err(SceneError::Invalid {
                at: cx.at(c.shape.span()),
                key: key("shape"),
                value: format!("{shape_name:?}"),
                message: format!(
                    "unknown collider shape{}: allowed {}",
                    did_you_mean(shape_name, &SHAPES),
                    SHAPES.map(|s| format!("\"{s}\"")).join(", ")
                ),
            });
        }
    };
    let given = [
        ("point", c.point.as_ref().map(|s| s.span())),
        ("normal", c.normal.as_ref().map(|s| s.span())),
        ("center", c.center.as_ref().map(|s| s.span())),
        ("radius", c.radius.as_ref().map(|s| s.span())),
        ("half_extents", c.half_extents.as_ref().map(|s| s.span())),
        ("file", c.file.as_ref().map(|s| s.span())),
        ("position", c.position.as_ref().map(|s| s.span())),
        ("rotation", c.rotation.as_ref().map(|s| s.span())),
        ("scale", c.scale.as_ref().map(|s| s.span())),
        ("sequence", c.sequence.as_ref().map(|s| s.span())),
        ("cache", c.cache.as_ref().map(|s| s.span())),
        ("frame_rate", c.frame_rate.as_ref().map(|s| s.span())),
        ("start", c.start.as_ref().map(|s| s.span())),
    ];
    for (name, span) in given {
        if let Some(span) = span
            && !allowed.contains(&name)
        {
            let key_span = keys::locate(doc, &key(name)).map_or(span.clone(), |(s, _)| s);
            return Err(SceneError::Invalid {
                at: cx.at(key_span),
                key: key(name),
                value: cx.raw(&span),
                message: format!(
                    "a {shape_name} collider has no `{name}`: its keys are {}, friction, \
                     sticky, keys",
                    allowed.join(", ")
                ),
            });
        }
    }
    let missing = |name: &str, help: &str| SceneError::Missing {
        at: cx.at(table_span.clone()),
        key: key(name),
        message: format!("a {shape_name} collider needs {name} = {help}"),
    };
    let friction = c.friction.unwrap_or(DEFAULT_FRICTION);
    let v = |s: Option<Spanned<Arr<Real, 3>>>| s.map(|s| vec3(s.into_inner()));
    let normal_span = c.normal.as_ref().map(|s| s.span());
    let shape = match shape_name {
        "plane" => Shape::Plane(Plane {
            point: v(c.point).unwrap_or(Vec3::ZERO),
            normal: {
                let n = v(c.normal).unwrap_or(Vec3::Y);
                unit(n).ok_or_else(|| {
                    let span = normal_span.clone().unwrap_or(table_span.clone());
                    SceneError::Invalid {
                        at: cx.at(span.clone()),
                        key: key("normal"),
                        value: cx.raw(&span),
                        message: if n.is_finite() {
                            "the zero vector has no direction: a plane's normal is any non-zero \
                             vector pointing out of the solid, e.g. [0, 1, 0]"
                                .into()
                        } else {
                            "must be finite (inf and nan have no direction): a plane's normal is \
                             any non-zero vector pointing out of the solid, e.g. [0, 1, 0]"
                                .into()
                        },
                    }
                })?
            },
        }),
        "sphere" => Shape::Sphere(Sphere {
            center: v(c.center).unwrap_or(Vec3::ZERO),
            radius: c
                .radius
                .map(Spanned::into_inner)
                .ok_or_else(|| missing("radius", "... (m)"))?,
        }),
        "box" => Shape::Box(Cuboid {
            center: v(c.center).unwrap_or(Vec3::ZERO),
            half_extents: v(c.half_extents)
                .ok_or_else(|| missing("half_extents", "[x, y, z] (m)"))?,
        }),
        _ => {
            let rest = match &c.file {
                Some(file) => Some(load_mesh(cx, &key("file"), file)?),
                None => None,
            };
            let moving = crate::collider_motion::read(
                cx,
                &key,
                table_span.clone(),
                rest.as_ref(),
                crate::collider_motion::Keys {
                    sequence: c.sequence.as_ref(),
                    cache: c.cache.as_ref(),
                    frame_rate: c.frame_rate.as_ref(),
                    start: c.start.as_ref(),
                },
            )?;
            let (file, mesh) = match (c.file, rest, moving.rest) {
                (Some(file), Some(mesh), _) => (file, mesh),
                (None, _, Some((seq, mesh))) => (seq, mesh),
                _ => {
                    return Err(missing(
                        "file",
                        "\"path/to/mesh.obj\" (relative to the scene file)",
                    ));
                }
            };
            // The collider names its file by the absolute path it was read from, so the
            // resolved scene a run writes (`to_toml`) reads the same mesh from any folder.
            let path = mesh_path(cx, file.get_ref());
            let named = std::path::absolute(&path).unwrap_or(path);
            let placed = Mesh::new(
                named.display().to_string(),
                mesh.vertices,
                mesh.triangles,
                v(c.position).unwrap_or(Vec3::ZERO),
                v(c.rotation).unwrap_or(Vec3::ZERO),
                c.scale.map_or(1.0, Spanned::into_inner),
            );
            let placed = match (placed, moving.motion) {
                (Ok(m), Some((motion, span, k))) => {
                    m.with_motion(motion).map_err(|e| SceneError::Invalid {
                        at: cx.at(span.clone()),
                        key: key(k),
                        value: cx.raw(&span),
                        message: e.to_string(),
                    })
                }
                (placed, _) => placed.map_err(|e| SceneError::Invalid {
                    at: cx.at(file.span()),
                    key: key("file"),
                    value: cx.raw(&file.span()),
                    message: format!("{}: {e}", mesh_path(cx, file.get_ref()).display()),
                }),
            };
            Shape::Mesh(placed?)
        }
    };
    let keys = c
        .keys
        .unwrap_or_default()
        .into_iter()
        .map(|k| Key {
            time: k.time,
            offset: k.offset.map_or(Vec3::ZERO, vec3),
            rotation: k.rotation.map_or(Vec3::ZERO, vec3),
        })
        .collect();
    Ok(Collider {
        shape,
        friction,
        sticky: c.sticky.unwrap_or(true),
        keys,
        placement: None,
    })
}

/// The cloth mesh named by `[cloth] mesh = file`, read, placed and checked: a face the mesh
/// cannot be a cloth with is named by its line.
/// `[cloth] model`, `density`, `material`, `[cloth.membrane]` and `[cloth.bending]` into `d`
/// (after `wetness`, `mass`, `water_mass` and `dry_friction_factor` are set): a material fills
/// every value the scene does not write, at the cloth's wetness.
fn fabric_keys(cx: &Ctx<'_>, d: &mut ClothParams, c: &RawCloth) -> Result<(), SceneError> {
    if let Some(m) = &c.model {
        d.model = named(
            cx,
            m,
            "cloth.model",
            "cloth model",
            ClothModel::ALL,
            ClothModel::name,
        )?;
    }
    if let Some(density) = &c.density {
        if c.mass.is_some() {
            return Err(SceneError::Invalid {
                at: cx.at(density.span()),
                key: "cloth.density".into(),
                value: cx.raw(&density.span()),
                message: "`density` (kg/m^2) and `mass` (kg) both set the cloth's mass: give one"
                    .into(),
            });
        }
        d.density = Some(*density.get_ref());
    }
    let membrane = c.membrane.as_ref();
    let bending = c.bending.as_ref();
    if let Some(name) = &c.material {
        let Some(fabric) = wetcloth::params::materials::fabric(name.get_ref()) else {
            return Err(SceneError::Invalid {
                at: cx.at(name.span()),
                key: "cloth.material".into(),
                value: cx.raw(&name.span()),
                message: format!(
                    "unknown material; the measured fabrics are {}",
                    wetcloth::params::materials::names()
                        .iter()
                        .map(|n| format!("\"{n}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            });
        };
        let w = d.wetness.clamp(0.0, 1.0);
        d.material = Some(fabric.name.to_string());
        if c.model.is_none() {
            d.model = ClothModel::Membrane;
        }
        if c.density.is_none() && c.mass.is_none() {
            d.density = Some(fabric.density);
        }
        if c.water_mass.is_none() {
            d.water_mass = fabric.water_mass;
        }
        if c.dry_friction_factor.is_none() {
            d.dry_friction_factor = fabric.dry_friction_factor;
        }
        d.membrane = MembraneParams {
            warp: fabric.warp.at(w),
            weft: fabric.weft.at(w),
            shear: fabric.shear.at(w),
            poisson: fabric.poisson,
        };
        d.bending.stiffness = fabric.bending.at(w);
        d.bending.warp = fabric.bending_warp;
        d.bending.weft = fabric.bending_weft;
    }
    if let Some(m) = membrane {
        set(&mut d.membrane.warp, m.warp);
        set(&mut d.membrane.weft, m.weft);
        set(&mut d.membrane.shear, m.shear);
        set(&mut d.membrane.poisson, m.poisson);
    }
    if let Some(b) = bending {
        set(&mut d.bending.stiffness, b.stiffness);
        set(&mut d.bending.warp, b.warp);
        set(&mut d.bending.weft, b.weft);
        if let Some(r) = &b.rest {
            d.bending.rest = named(
                cx,
                r,
                "cloth.bending.rest",
                "bending rest",
                BendingRest::ALL,
                BendingRest::name,
            )?;
        }
    }
    Ok(())
}

fn cloth_mesh(
    cx: &Ctx<'_>,
    file: &Spanned<String>,
    c: &RawCloth,
) -> Result<ClothMeshSource, SceneError> {
    let path = mesh_path(cx, file.get_ref());
    let fail = |message: String| SceneError::Invalid {
        at: cx.at(file.span()),
        key: "cloth.mesh".into(),
        value: cx.raw(&file.span()),
        message,
    };
    let text = read_text(
        cx,
        "cloth.mesh",
        file,
        crate::cloth_obj::MAX_CLOTH_BYTES,
        "a cloth mesh",
    )?;
    let obj = crate::cloth_obj::parse_cloth(&text).map_err(|e| {
        if e.line == 0 {
            fail(format!("{}: {}", path.display(), e.message))
        } else {
            fail(format!("{}:{}: {}", path.display(), e.line, e.message))
        }
    })?;
    drop(text);
    let scale = c.scale.as_ref().map_or(1.0, |s| *s.get_ref());
    if !(scale > 0.0 && scale <= 1e4) {
        let span = c.scale.as_ref().map_or(file.span(), |s| s.span());
        return Err(SceneError::Invalid {
            at: cx.at(span.clone()),
            key: "cloth.scale".into(),
            value: cx.raw(&span),
            message: "out of range: allowed (0, 1e4] (the file's units to metres)".into(),
        });
    }
    let named = std::path::absolute(&path).unwrap_or(path.clone());
    let src = ClothMeshSource {
        file: named.display().to_string(),
        vertices: std::sync::Arc::new(obj.vertices),
        faces: std::sync::Arc::new(obj.faces),
        uvs: std::sync::Arc::new(obj.uvs),
        face_uvs: std::sync::Arc::new(obj.face_uvs),
        rotation: c
            .rotation
            .as_ref()
            .map_or(Vec3::ZERO, |r| Vec3::from(r.get_ref().0)),
        scale,
        flip_normals: c.flip_normals.as_ref().is_some_and(|f| *f.get_ref()),
    };
    let position = c.position.as_ref().map_or(Vec3::ZERO, |p| Vec3::from(p.0));
    if !(position.is_finite() && src.rotation.is_finite()) {
        // Left to the configuration's range checks, which name the key.
        return Ok(src);
    }
    let (triangles, from) = src.triangles();
    if let Err(e) = wetcloth::ClothMesh::new(src.placed(position), triangles) {
        let at = e
            .triangle()
            .and_then(|t| from.get(t))
            .and_then(|&f| obj.face_lines.get(f as usize));
        return Err(fail(match at {
            Some(line) => format!("{}:{line}: {e}", path.display()),
            None => format!("{}: {e}", path.display()),
        }));
    }
    Ok(src)
}

/// Where a mesh file named `file` in the scene is: relative to the scene file's folder.
pub(crate) fn mesh_path(cx: &Ctx<'_>, file: &str) -> std::path::PathBuf {
    let base = std::path::Path::new(cx.file)
        .parent()
        .unwrap_or(std::path::Path::new(""));
    base.join(file)
}

/// Reads and parses the OBJ file named by the scene key `key` (its value `file`).
pub(crate) fn load_mesh(
    cx: &Ctx<'_>,
    key: &str,
    file: &Spanned<String>,
) -> Result<crate::obj::ObjMesh, SceneError> {
    let path = mesh_path(cx, file.get_ref());
    let text = read_text(cx, key, file, crate::obj::MAX_MESH_BYTES, "a mesh")?;
    crate::obj::parse(&text).map_err(|e| SceneError::Invalid {
        at: cx.at(file.span()),
        key: key.to_string(),
        value: cx.raw(&file.span()),
        message: if e.line == 0 {
            format!("{}: {}", path.display(), e.message)
        } else {
            format!("{}:{}: {}", path.display(), e.line, e.message)
        },
    })
}

/// The text of the file named by the scene key `key` (its value `file`, relative to the scene
/// file), at most `max_bytes` long; `what` names what the file is for in messages.
fn read_text(
    cx: &Ctx<'_>,
    key: &str,
    file: &Spanned<String>,
    max_bytes: u64,
    what: &str,
) -> Result<String, SceneError> {
    use std::io::Read;
    let path = mesh_path(cx, file.get_ref());
    let fail = |message: String| SceneError::Invalid {
        at: cx.at(file.span()),
        key: key.to_string(),
        value: cx.raw(&file.span()),
        message,
    };
    // A FIFO, a device or a folder is refused before it is opened: opening a FIFO for reading
    // waits for a writer, forever.
    match std::fs::metadata(&path) {
        Ok(m) if !m.is_file() => {
            let kind = if m.is_dir() {
                "a folder"
            } else {
                "not a regular file (a FIFO, a socket or a device)"
            };
            let reader = if what == "a mesh" {
                "a mesh collider"
            } else {
                "a mesh cloth"
            };
            return Err(fail(format!(
                "the mesh file {} is {kind}: {reader} reads an OBJ file",
                path.display()
            )));
        }
        _ => {}
    }
    let mut bytes = Vec::new();
    std::fs::File::open(&path)
        .and_then(|f| f.take(max_bytes + 1).read_to_end(&mut bytes))
        .map_err(|e| {
            fail(format!(
                "cannot read the mesh file {}: {e} (the path is relative to the scene file)",
                path.display()
            ))
        })?;
    if bytes.len() as u64 > max_bytes {
        return Err(fail(format!(
            "the mesh file {} is larger than the {} MiB {what} may have",
            path.display(),
            max_bytes >> 20
        )));
    }
    Ok(match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => String::from_utf8_lossy(e.as_bytes()).into_owned(),
    })
}

/// A [`ConfigError`] placed at its key in the file (or at the table that lacks the key).
pub fn config_error(
    file: &str,
    text: &str,
    doc: &Spanned<DeTable<'_>>,
    err: &ConfigError,
) -> SceneError {
    match keys::locate(doc, err.key()) {
        Some((span, exact)) => {
            let value = if exact {
                text.get(span.clone()).unwrap_or("?").trim().to_string()
            } else {
                "(default)".to_string()
            };
            from_config_error(Location::of_span(file, text, span), value, err)
        }
        None => from_config_error(Location::file_only(file), "(default)".into(), err),
    }
}

/// A [`ConfigError`] with no place in a file (a scene built in code).
pub fn config_error_unplaced(label: &str, err: &ConfigError) -> SceneError {
    from_config_error(Location::file_only(label), "(as configured)".into(), err)
}

fn from_config_error(at: Location, value: String, err: &ConfigError) -> SceneError {
    let at = Box::new(at);
    match err {
        ConfigError::OutOfRange { key, value, range } => SceneError::OutOfRange {
            at,
            key: key.clone(),
            value: value.clone(),
            range: range.clone(),
        },
        ConfigError::Invalid { key, message } => SceneError::Invalid {
            at,
            key: key.clone(),
            value,
            message: message.clone(),
        },
    }
}
