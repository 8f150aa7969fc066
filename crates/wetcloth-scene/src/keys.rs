//! The scene format's keys, and the walk over a parsed document that finds unknown keys and maps
//! key paths (`cloth.mass`, `collider[0].friction`) to spans and back.

use std::ops::Range;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// Keys at the top level of a scene file.
pub const TOP: &[&str] = &[
    "name",
    "simulation",
    "cloth",
    "air",
    "collider",
    "grab",
    "attach",
];
/// Keys of `[simulation]`.
pub const SIMULATION: &[&str] = &[
    "duration",
    "time_step",
    "integrator",
    "implicit_budget",
    "frame_rate",
    "gravity",
];
/// Keys of `[cloth]`.
pub const CLOTH: &[&str] = &[
    "size",
    "resolution",
    "position",
    "mass",
    "structural_stiffness",
    "shear_stiffness",
    "damping",
    "thickness",
    "collision_margin",
    "self_collision",
    "strain_limit",
    "strain_limit_iterations",
    "wetness",
    "water_mass",
    "dry_friction_factor",
    "wet_adhesion",
    "paint",
    "mesh",
    "rotation",
    "scale",
    "flip_normals",
    "model",
    "membrane",
    "bending",
    "density",
    "material",
    "seam",
    "shrink",
];
/// Keys of a `[[cloth.seam]]`.
pub const SEAM: &[&str] = &["a", "b", "stiffness", "max_force"];
/// Keys of `[cloth.membrane]`.
pub const MEMBRANE: &[&str] = &["warp", "weft", "shear", "poisson"];
/// Keys of `[cloth.bending]`.
pub const BENDING: &[&str] = &["stiffness", "warp", "weft", "rest"];
/// Keys of a `[[cloth.paint]]` region.
pub const PAINT: &[&str] = &["center", "radius", "half_size", "wetness"];
/// Keys of `[air]`.
pub const AIR: &[&str] = &[
    "enabled",
    "atmospheric_pressure",
    "trapped_air",
    "leak_conductance",
    "pressure_solve",
    "pressure_force",
    "model",
    "seal_distance",
    "seal_hysteresis",
    "seal_wetness",
    "permeability",
    "dry_permeability",
    "pocket",
];
/// Keys of a `[[air.pocket]]` seed.
pub const POCKET: &[&str] = &["center", "radius", "amount"];
/// Keys of a `[[collider]]`, all shapes together.
pub const COLLIDER: &[&str] = &[
    "shape",
    "point",
    "normal",
    "center",
    "radius",
    "half_extents",
    "friction",
    "file",
    "position",
    "rotation",
    "scale",
    "sequence",
    "cache",
    "frame_rate",
    "start",
    "sticky",
    "keys",
];
/// Keys of a `[[grab]]`.
pub const GRAB: &[&str] = &["particle", "vertex", "near", "within", "keys"];
/// Keys of an `[[attach]]`.
pub const ATTACH: &[&str] = &["collider", "vertex", "near", "within", "stiffness"];
/// Keys of a grab's `within` region.
pub const WITHIN: &[&str] = &["center", "radius", "half_size"];
/// Keys of one grab key (`keys = [{ time = ..., offset = [...] }]`).
pub const GRAB_KEY: &[&str] = &["time", "offset"];
/// Keys of one collider key (`keys = [{ time = ..., offset = [...], rotation = [...] }]`).
pub const COLLIDER_KEY: &[&str] = &["time", "offset", "rotation"];

/// Where a table sits in the format, for its list of valid keys.
#[derive(Clone, Copy)]
enum Place {
    Top,
    Simulation,
    Cloth,
    Air,
    Collider,
    Grab,
    GrabKey,
    Within,
    Paint,
    Pocket,
    ColliderKey,
    Membrane,
    Bending,
    Attach,
    AttachWithin,
    Seam,
}

impl Place {
    fn keys(self) -> &'static [&'static str] {
        match self {
            Place::Top => TOP,
            Place::Simulation => SIMULATION,
            Place::Cloth => CLOTH,
            Place::Air => AIR,
            Place::Collider => COLLIDER,
            Place::Grab => GRAB,
            Place::GrabKey => GRAB_KEY,
            Place::Within => WITHIN,
            Place::Paint => PAINT,
            Place::Pocket => POCKET,
            Place::ColliderKey => COLLIDER_KEY,
            Place::Membrane => MEMBRANE,
            Place::Bending => BENDING,
            Place::Attach => ATTACH,
            Place::AttachWithin => WITHIN,
            Place::Seam => SEAM,
        }
    }

    /// The place of the tables found under `key` in this table (directly or as array items).
    fn child(self, key: &str) -> Option<Place> {
        match (self, key) {
            (Place::Top, "simulation") => Some(Place::Simulation),
            (Place::Top, "cloth") => Some(Place::Cloth),
            (Place::Top, "air") => Some(Place::Air),
            (Place::Top, "collider") => Some(Place::Collider),
            (Place::Top, "grab") => Some(Place::Grab),
            (Place::Grab, "keys") => Some(Place::GrabKey),
            (Place::Grab, "within") => Some(Place::Within),
            (Place::Cloth, "paint") => Some(Place::Paint),
            (Place::Cloth, "membrane") => Some(Place::Membrane),
            (Place::Cloth, "bending") => Some(Place::Bending),
            (Place::Cloth, "seam") => Some(Place::Seam),
            (Place::Air, "pocket") => Some(Place::Pocket),
            (Place::Collider, "keys") => Some(Place::ColliderKey),
            (Place::Top, "attach") => Some(Place::Attach),
            (Place::Attach, "within") => Some(Place::AttachWithin),
            _ => None,
        }
    }

    fn prefix(self) -> &'static str {
        match self {
            Place::Top => "",
            Place::Simulation => "simulation.",
            Place::Cloth => "cloth.",
            Place::Air => "air.",
            Place::Collider => "collider[].",
            Place::Grab => "grab[].",
            Place::GrabKey => "grab[].keys[].",
            Place::Within => "grab[].within.",
            Place::Paint => "cloth.paint[].",
            Place::Pocket => "air.pocket[].",
            Place::ColliderKey => "collider[].keys[].",
            Place::Membrane => "cloth.membrane.",
            Place::Bending => "cloth.bending.",
            Place::Attach => "attach[].",
            Place::AttachWithin => "attach[].within.",
            Place::Seam => "cloth.seam[].",
        }
    }
}

const ALL_PLACES: [Place; 16] = [
    Place::Top,
    Place::Simulation,
    Place::Cloth,
    Place::Air,
    Place::Collider,
    Place::Grab,
    Place::GrabKey,
    Place::Within,
    Place::Paint,
    Place::Pocket,
    Place::ColliderKey,
    Place::Membrane,
    Place::Bending,
    Place::Attach,
    Place::AttachWithin,
    Place::Seam,
];

/// An unknown key found in a document.
pub struct Unknown {
    /// Full key path.
    pub key: String,
    /// Span of the key in the text.
    pub span: Range<usize>,
    /// Closest valid key at the same place, or the full path of a key of that name elsewhere.
    pub suggestion: Option<String>,
    /// Valid keys at that place.
    pub valid: &'static [&'static str],
}

/// The closest of `valid` to `key` (Jaro-Winkler similarity at least 0.8), or a valid key that
/// contains it, or the full path of a key with exactly that name at another place (`mass` at the
/// top level -> `cloth.mass`).
fn suggest(key: &str, valid: &[&str]) -> Option<String> {
    let best = valid
        .iter()
        .map(|v| (strsim::jaro_winkler(key, v), *v))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    if let Some((score, v)) = best
        && score >= 0.8
    {
        return Some(v.to_string());
    }
    // A part of a longer key (`stiffness` -> `structural_stiffness`).
    if key.len() >= 4
        && let Some(v) = valid.iter().find(|v| v.contains(key))
    {
        return Some(v.to_string());
    }
    ALL_PLACES
        .iter()
        .find(|p| p.keys().contains(&key))
        .map(|p| format!("{}{key}", p.prefix()))
}

/// The first unknown key of the document, in file order.
pub fn find_unknown(doc: &DeTable<'_>) -> Option<Unknown> {
    let mut found = Vec::new();
    walk_table(doc, Place::Top, "", &mut found);
    found.into_iter().min_by_key(|u| u.span.start)
}

fn walk_table(table: &DeTable<'_>, place: Place, path: &str, found: &mut Vec<Unknown>) {
    let valid = place.keys();
    for (k, v) in table.iter() {
        let name: &str = k.get_ref();
        let full = format!("{path}{name}");
        if !valid.contains(&name) {
            found.push(Unknown {
                suggestion: suggest(name, valid),
                key: full,
                span: k.span(),
                valid,
            });
            continue;
        }
        let Some(child) = place.child(name) else {
            continue;
        };
        match v.get_ref() {
            DeValue::Table(t) => walk_table(t, child, &format!("{full}."), found),
            DeValue::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    if let DeValue::Table(t) = item.get_ref() {
                        walk_table(t, child, &format!("{full}[{i}]."), found);
                    }
                }
            }
            _ => {}
        }
    }
}

/// One segment of a key path: a key and an optional array index (`collider[0]`).
fn segments(path: &str) -> Vec<(&str, Option<usize>)> {
    path.split('.')
        .map(|seg| match seg.split_once('[') {
            Some((k, rest)) => (k, rest.trim_end_matches(']').parse().ok()),
            None => (seg, None),
        })
        .collect()
}

/// Span of the value at key path `path` and `true`; or, when the key is not in the document, the
/// span of the deepest part of the path that is (the table that lacks the key) and `false`; or
/// `None` when not even the first key is in the document.
pub fn locate(doc: &Spanned<DeTable<'_>>, path: &str) -> Option<(Range<usize>, bool)> {
    let mut table = doc.get_ref();
    let mut found: Option<Range<usize>> = None;
    let segs = segments(path);
    for (n, (key, index)) in segs.iter().enumerate() {
        let last = n + 1 == segs.len();
        let Some((_, value)) = table.iter().find(|(k, _)| k.get_ref() == key) else {
            return found.map(|s| (s, false));
        };
        let mut value: &Spanned<DeValue<'_>> = value;
        found = Some(value.span());
        if let Some(i) = *index {
            match value.get_ref() {
                DeValue::Array(items) if i < items.len() => {
                    value = &items[i];
                    found = Some(value.span());
                }
                _ => return found.map(|s| (s, false)),
            }
        }
        if last {
            return found.map(|s| (s, true));
        }
        match value.get_ref() {
            DeValue::Table(t) => table = t,
            _ => return found.map(|s| (s, false)),
        }
    }
    found.map(|s| (s, false))
}

/// The value at key path `path` (`collider[0].normal`), if the document has it.
fn value_at<'a, 'd>(doc: &'a Spanned<DeTable<'d>>, path: &str) -> Option<&'a Spanned<DeValue<'d>>> {
    let mut table = doc.get_ref();
    let segs = segments(path);
    for (n, (key, index)) in segs.iter().enumerate() {
        let (_, mut value) = table.iter().find(|(k, _)| k.get_ref() == key)?;
        if let Some(i) = *index {
            match value.get_ref() {
                DeValue::Array(items) => value = items.get(i)?,
                _ => return None,
            }
        }
        if n + 1 == segs.len() {
            return Some(value);
        }
        match value.get_ref() {
            DeValue::Table(t) => table = t,
            _ => return None,
        }
    }
    None
}

/// What kind of TOML value is at key path `path`, in words, with its text where that helps:
/// `a date-time 1979-05-27`, `an array of tables [[simulation]]`, `a table [collider]`,
/// `an inline table`, `an array`, `a string`, ... `None` when the path is not in the document.
pub fn kind_at(doc: &Spanned<DeTable<'_>>, text: &str, path: &str) -> Option<String> {
    let value = value_at(doc, path)?;
    let raw = text.get(value.span()).unwrap_or("").trim();
    Some(match value.get_ref() {
        DeValue::String(_) => "a string".into(),
        DeValue::Integer(_) => format!("an integer {raw}"),
        DeValue::Float(_) => format!("a number {raw}"),
        DeValue::Boolean(_) => format!("{raw} (true or false)"),
        DeValue::Datetime(_) => format!("a date-time {raw}"),
        DeValue::Array(items) => {
            let tables = !items.is_empty()
                && items
                    .iter()
                    .all(|i| matches!(i.get_ref(), DeValue::Table(_)));
            let header = items
                .first()
                .map(|i| text.get(i.span()).unwrap_or("").trim());
            match header {
                Some(h) if tables && h.starts_with("[[") => {
                    format!("an array of tables {}", h.lines().next().unwrap_or(h))
                }
                _ if tables => "an array of tables".into(),
                _ => "an array".into(),
            }
        }
        DeValue::Table(_) if raw.starts_with('[') => {
            format!("a table {}", raw.lines().next().unwrap_or(raw))
        }
        DeValue::Table(_) if raw.starts_with('{') => "an inline table".into(),
        DeValue::Table(_) => "a table".into(),
    })
}

/// What a top-level key must hold, in words, for the keys that hold tables.
pub fn expected_at_top(key: &str) -> Option<String> {
    match key {
        "simulation" | "cloth" | "air" => Some(format!("a table, written [{key}]")),
        "collider" | "grab" | "attach" => Some(format!("an array of tables, written [[{key}]]")),
        _ => None,
    }
}

/// The key path of the innermost key or value whose span contains byte `offset`, indexing
/// arrays of tables (`grab[0].keys[1].time`) but not arrays of numbers (`cloth.size`).
///
/// Spans of tables opened by a header (`[cloth]`) cover only the header, so every key and value
/// of the document is a candidate and the smallest span that contains `offset` wins.
pub fn path_at(doc: &DeTable<'_>, offset: usize) -> Option<String> {
    let mut best: Option<(usize, String)> = None;
    candidates(doc, "", offset, &mut best);
    best.map(|(_, p)| p)
}

fn consider(span: Range<usize>, path: &str, offset: usize, best: &mut Option<(usize, String)>) {
    let inside = span.start <= offset && offset < span.end.max(span.start + 1);
    let len = span.len();
    // On a tie the later, deeper candidate (an array item rather than the array) wins.
    if inside && best.as_ref().is_none_or(|(l, _)| len <= *l) {
        *best = Some((len, path.to_string()));
    }
}

fn candidates(table: &DeTable<'_>, path: &str, offset: usize, best: &mut Option<(usize, String)>) {
    for (k, v) in table.iter() {
        let full = format!("{path}{}", k.get_ref());
        consider(k.span(), &full, offset, best);
        consider(v.span(), &full, offset, best);
        match v.get_ref() {
            DeValue::Table(t) => candidates(t, &format!("{full}."), offset, best),
            DeValue::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    if let DeValue::Table(t) = item.get_ref() {
                        let p = format!("{full}[{i}]");
                        consider(item.span(), &p, offset, best);
                        candidates(t, &format!("{p}."), offset, best);
                    }
                }
            }
            _ => {}
        }
    }
}

/// One step of a key path given to [`crate::Scene::set`]: a key, or an index into an array.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Step {
    /// A key of a table.
    Key(String),
    /// An index into an array (of tables or of numbers), from 0.
    Index(usize),
}

/// Why a key path given to [`crate::Scene::set`] or [`crate::Scene::get`] names nothing.
pub enum PathError {
    /// A key the format does not have at that place.
    Unknown(Unknown),
    /// A path that is not written as one (`cloth..mass`, `cloth.mass.x`, `collider[a]`).
    Malformed(String),
}

/// Splits a key path into steps and checks every key against the format. Both spellings of an
/// index work: `collider.0.friction` and `collider[0].friction`. Returns the steps and the
/// path as the format writes it (`collider[0].friction`).
pub fn parse_path(path: &str) -> Result<(Vec<Step>, String), PathError> {
    let malformed = |why: &str| PathError::Malformed(format!("key path `{path}`: {why}"));
    let mut steps = Vec::new();
    for seg in path.split('.') {
        let (name, index) = match seg.split_once('[') {
            Some((k, rest)) => {
                let i = rest
                    .strip_suffix(']')
                    .and_then(|i| i.parse::<usize>().ok())
                    .ok_or_else(|| malformed("an index is written [N] or .N, N from 0"))?;
                (k, Some(i))
            }
            None => (seg, None),
        };
        if name.is_empty() && index.is_none() {
            return Err(malformed("an empty key (two dots, or a dot at an end)"));
        }
        match name.parse::<usize>() {
            Ok(i) if index.is_none() => steps.push(Step::Index(i)),
            _ if name.is_empty() => {}
            _ => steps.push(Step::Key(name.to_string())),
        }
        if let Some(i) = index {
            steps.push(Step::Index(i));
        }
    }
    // Check each key at its place; `place` is None inside a value (a number, an array of
    // numbers), where no key can follow.
    let mut place = Some(Place::Top);
    let mut written = String::new();
    for step in &steps {
        match step {
            Step::Key(k) => {
                let Some(p) = place else {
                    return Err(malformed(&format!(
                        "`{written}` holds a value, not a table, so it has no key `{k}`"
                    )));
                };
                if !written.is_empty() {
                    written.push('.');
                }
                written.push_str(k);
                if !p.keys().contains(&k.as_str()) {
                    return Err(PathError::Unknown(Unknown {
                        key: written,
                        span: 0..0,
                        suggestion: suggest(k, p.keys()),
                        valid: p.keys(),
                    }));
                }
                place = p.child(k);
            }
            Step::Index(i) => {
                if written.is_empty() {
                    return Err(malformed("a path starts with a key, not an index"));
                }
                written.push_str(&format!("[{i}]"));
            }
        }
    }
    Ok((steps, written))
}
