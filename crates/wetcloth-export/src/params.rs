//! The scene's parameters as flat, named values, for the custom attributes of a USD stage.
//!
//! A run's `scene.toml` has every key explicit; [`scene_params`] flattens it: a key `mass` in
//! table `[cloth]` becomes `wetcloth:cloth:mass`, the `k`-th `[[grab]]` table `wetcloth:grab_k:…`,
//! and so on. Numbers keep their TOML type (integer or float) and full precision.

/// One parameter of the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneParam {
    /// Namespaced name, `wetcloth:table:key` (each part a valid USD identifier).
    pub name: String,
    /// The value.
    pub value: ParamValue,
}

/// The value of a [`SceneParam`].
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    /// `true` or `false`.
    Bool(bool),
    /// An integer.
    Int(i64),
    /// A float (unit as documented for the scene key).
    Float(f64),
    /// A string.
    Text(String),
    /// A list of integers (`resolution = [50, 50]`).
    Ints(Vec<i64>),
    /// A list of numbers with at least one float (`gravity = [0.0, -9.8, 0.0]`).
    Floats(Vec<f64>),
}

/// Flattens a scene file's text into parameters, sorted by table and key (the order is
/// deterministic, not the file's). Empty lists are left out.
///
/// # Errors
///
/// The TOML parser's message when `text` is not valid TOML.
pub fn scene_params(text: &str) -> Result<Vec<SceneParam>, String> {
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| e.to_string())?;
    let mut out = Vec::new();
    flatten_table("wetcloth", &table, &mut out);
    Ok(out)
}

fn flatten_table(prefix: &str, table: &toml::Table, out: &mut Vec<SceneParam>) {
    for (key, value) in table {
        flatten(&format!("{prefix}:{}", identifier(key)), value, out);
    }
}

fn flatten(name: &str, value: &toml::Value, out: &mut Vec<SceneParam>) {
    use toml::Value as V;
    let mut push = |value| {
        out.push(SceneParam {
            name: name.to_string(),
            value,
        })
    };
    match value {
        V::Boolean(b) => push(ParamValue::Bool(*b)),
        V::Integer(i) => push(ParamValue::Int(*i)),
        V::Float(f) => push(ParamValue::Float(*f)),
        V::String(s) => push(ParamValue::Text(s.clone())),
        V::Datetime(d) => push(ParamValue::Text(d.to_string())),
        V::Table(t) => flatten_table(name, t, out),
        V::Array(items) => {
            if items.is_empty() {
                return;
            }
            if items.iter().all(|v| v.is_integer()) {
                push(ParamValue::Ints(
                    items.iter().filter_map(|v| v.as_integer()).collect(),
                ));
            } else if items.iter().all(|v| v.is_integer() || v.is_float()) {
                push(ParamValue::Floats(
                    items
                        .iter()
                        .filter_map(|v| v.as_float().or(v.as_integer().map(|i| i as f64)))
                        .collect(),
                ));
            } else {
                for (k, item) in items.iter().enumerate() {
                    flatten(&format!("{name}_{k}"), item, out);
                }
            }
        }
    }
}

/// `key` as a USD identifier: letters, digits and `_`, not starting with a digit.
pub(crate) fn identifier(key: &str) -> String {
    let mut s: String = key
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        s.insert(0, '_');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_lists_and_arrays_of_tables_flatten_to_namespaced_names() {
        let text = r#"
name = "pinch-center"
[cloth]
resolution = [50, 50]
mass = 0.02
self_collision = true
[[grab]]
particle = [25, 25]
keys = [ { time = 0.25, offset = [0, 0.0, 0] } ]
[[collider]]
shape = "plane"
"#;
        let p = scene_params(text).unwrap();
        let get = |n: &str| {
            p.iter()
                .find(|x| x.name == n)
                .unwrap_or_else(|| panic!("{n} in {p:?}"))
                .value
                .clone()
        };
        assert_eq!(
            get("wetcloth:name"),
            ParamValue::Text("pinch-center".into())
        );
        assert_eq!(
            get("wetcloth:cloth:resolution"),
            ParamValue::Ints(vec![50, 50])
        );
        assert_eq!(get("wetcloth:cloth:mass"), ParamValue::Float(0.02));
        assert_eq!(get("wetcloth:cloth:self_collision"), ParamValue::Bool(true));
        assert_eq!(
            get("wetcloth:grab_0:particle"),
            ParamValue::Ints(vec![25, 25])
        );
        assert_eq!(get("wetcloth:grab_0:keys_0:time"), ParamValue::Float(0.25));
        assert_eq!(
            get("wetcloth:grab_0:keys_0:offset"),
            ParamValue::Floats(vec![0.0, 0.0, 0.0])
        );
        assert_eq!(
            get("wetcloth:collider_0:shape"),
            ParamValue::Text("plane".into())
        );
        assert_eq!(p.len(), 8);
        assert!(scene_params("a = ").is_err());
    }

    #[test]
    fn identifiers_are_made_valid() {
        assert_eq!(identifier("time_step"), "time_step");
        assert_eq!(identifier("a-b"), "a_b");
        assert_eq!(identifier("3d"), "_3d");
        assert_eq!(identifier(""), "_");
    }
}
