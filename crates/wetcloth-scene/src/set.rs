//! Changing one key of a scene by its key path: `wetcloth run --set KEY=VALUE` and the Python
//! package's `scene.set(key, value)` / `scene.get(key)` share this code, so they accept the same
//! paths and give the same messages as a scene file.

use crate::Scene;
use crate::error::{Location, SceneError};
use crate::keys::{self, PathError, Step};
use toml::{Table, Value};

/// Where errors of [`Scene::set`] and [`Scene::get`] say they come from: `set KEY`.
fn origin(written: &str) -> Location {
    Location::file_only(&format!("set {written}"))
}

/// Checks `path` against the format: the steps, and the path as the format writes it.
fn checked(path: &str) -> Result<(Vec<Step>, String), SceneError> {
    keys::parse_path(path).map_err(|e| match e {
        PathError::Unknown(u) => SceneError::UnknownKey {
            at: Box::new(origin(&u.key)),
            key: u.key,
            suggestion: u.suggestion,
            valid: u.valid.iter().map(|s| s.to_string()).collect(),
        },
        PathError::Malformed(message) => SceneError::Invalid {
            at: Box::new(Location::file_only("set")),
            key: path.to_string(),
            value: "(none)".into(),
            message,
        },
    })
}

/// Parses a value written in TOML syntax (`0.05`, `[0.2, 0.2]`, `"pockets"`, `true`,
/// `{ time = 0.0, offset = [0.0, 0.0, 0.0] }`); text that is not a TOML value is taken as a
/// string, so a bare word needs no quotes (`pockets`).
pub fn parse_value(text: &str) -> Value {
    let text = text.trim();
    toml::from_str::<Table>(&format!("v = {text}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| Value::String(text.to_string()))
}

impl Scene {
    /// The scene's file label (as errors show it) for re-reading it after a change: the file
    /// it came from, or the name with `.toml` for a scene built in code.
    fn label(&self) -> String {
        match &self.source {
            Some((file, _)) => file.clone(),
            None => format!("{}.toml", self.name),
        }
    }

    /// Sets the key at `path` (`cloth.mass`, `air.trapped_air`, `collider.0.friction` or
    /// `collider[0].friction`, `grab.1.keys`) to `value`, then checks the whole scene again as
    /// a scene file is checked. An unknown key is refused with the closest valid one; a value
    /// of the wrong type or out of range with the message a file gets, from `set KEY` instead of
    /// a file and line. The scene is unchanged when an error is returned.
    ///
    /// An index one past the end of an array of tables adds a table there
    /// (`grab.2.particle` on a scene with two grabs starts a third).
    ///
    /// ```
    /// let mut scene = wetcloth_scene::Scene::thesis_demo();
    /// scene.set("cloth.mass", toml::Value::Float(0.05)).unwrap();
    /// assert_eq!(scene.config.cloth.mass, 0.05);
    /// let err = scene.set("cloth.mas", toml::Value::Float(0.05)).unwrap_err();
    /// assert!(err.to_string().starts_with("set cloth.mas: unknown key `cloth.mas`; did you mean `mass`?"));
    /// let err = scene.set("cloth.mass", toml::Value::Float(-1.0)).unwrap_err();
    /// assert!(err.to_string().starts_with("set cloth.mass: cloth.mass = -1"));
    /// ```
    pub fn set(&mut self, path: &str, value: Value) -> Result<(), SceneError> {
        let (steps, written) = checked(path)?;
        let resolved = self.to_toml();
        let mut doc: Table = toml::from_str(&resolved).map_err(|e| SceneError::Invalid {
            at: Box::new(origin(&written)),
            key: written.clone(),
            value: "(scene)".into(),
            message: format!("the resolved scene does not read back: {e}"),
        })?;
        put(&mut doc, &steps, value).map_err(|message| SceneError::Invalid {
            at: Box::new(origin(&written)),
            key: written.clone(),
            value: "(none)".into(),
            message,
        })?;
        let text = toml::to_string(&doc).map_err(|e| SceneError::Invalid {
            at: Box::new(origin(&written)),
            key: written.clone(),
            value: "(none)".into(),
            message: format!("cannot be written as TOML: {e}"),
        })?;
        let label = self.label();
        let mut scene =
            crate::parse(&text, label.as_ref()).map_err(|e| e.placed(origin(&written)))?;
        // Keep the original label, so that mesh files stay relative to the scene file.
        scene.source = Some((label, text));
        *self = scene;
        Ok(())
    }

    /// The value at `path` in the resolved scene (every key explicit, as [`Scene::to_toml`]
    /// writes it), or `None` for a valid key the scene does not have (an index past the end, an
    /// optional table left out). An unknown key is refused as [`Scene::set`] refuses it.
    pub fn get(&self, path: &str) -> Result<Option<Value>, SceneError> {
        let (steps, written) = checked(path)?;
        let doc: Table = toml::from_str(&self.to_toml()).map_err(|e| SceneError::Invalid {
            at: Box::new(origin(&written)),
            key: written.clone(),
            value: "(scene)".into(),
            message: format!("the resolved scene does not read back: {e}"),
        })?;
        let mut at: Option<&Value> = None;
        for step in &steps {
            at = match (at, step) {
                (None, Step::Key(k)) => doc.get(k),
                (Some(Value::Table(t)), Step::Key(k)) => t.get(k),
                (Some(Value::Array(a)), Step::Index(i)) => a.get(*i),
                _ => None,
            };
            if at.is_none() {
                return Ok(None);
            }
        }
        Ok(at.cloned())
    }
}

/// Puts `value` at `steps` in `doc`, creating the tables on the way; an index may be one past
/// the end of an array (a new table there). Says what is wrong otherwise.
fn put(doc: &mut Table, steps: &[Step], value: Value) -> Result<(), String> {
    let Some((Step::Key(first), rest)) = steps.split_first() else {
        return Err("a key path starts with a key".into());
    };
    let mut slot: &mut Value = doc
        .entry(first.clone())
        .or_insert_with(|| match rest.first() {
            Some(Step::Index(_)) => Value::Array(Vec::new()),
            _ => Value::Table(Table::new()),
        });
    for (n, step) in rest.iter().enumerate() {
        let next_is_index = matches!(rest.get(n + 1), Some(Step::Index(_)));
        let fresh = || {
            if next_is_index {
                Value::Array(Vec::new())
            } else {
                Value::Table(Table::new())
            }
        };
        slot = match (slot, step) {
            (Value::Table(t), Step::Key(k)) => t.entry(k.clone()).or_insert_with(fresh),
            (Value::Array(a), Step::Index(i)) => {
                let len = a.len();
                if *i == len {
                    a.push(fresh());
                }
                a.get_mut(*i).ok_or_else(|| {
                    format!("index {i} is past the end: the array has {len} item(s)")
                })?
            }
            (Value::Array(_), Step::Key(k)) => {
                return Err(format!("an array: `{k}` needs an index before it"));
            }
            (_, Step::Index(i)) => return Err(format!("not an array, so it has no item {i}")),
            (_, Step::Key(k)) => {
                return Err(format!("a value, not a table, so it has no key `{k}`"));
            }
        };
    }
    *slot = value;
    Ok(())
}
