//! # wetcloth-scene: scene files for wetcloth
//!
//! A scene file is TOML and says everything a run needs: a `name`, `[simulation]`, `[cloth]`,
//! `[air]`, any number of `[[collider]]` and `[[grab]]`. Every field of the core's parameter
//! structs ([`wetcloth::SimulationParams`], [`wetcloth::ClothParams`], [`wetcloth::AirParams`])
//! is a key of the same name, and a missing key takes the core's default. The format is
//! described key by key in `docs/scene-format.md`.
//!
//! [`load`] and [`parse`] turn a file into a [`Scene`]; every error ([`SceneError`]) names the
//! file, line and column, the key, the value and what is allowed, and suggests the closest key
//! for a misspelt one. [`to_toml`] writes a configuration back with every key explicit, so a
//! run can record exactly what ran; it parses back to the same configuration.
//!
//! ```
//! let text = "[cloth]\nresolution = [8, 8]\n";
//! let scene = wetcloth_scene::parse(text, "small.toml".as_ref()).unwrap();
//! assert_eq!(scene.name, "small");
//! assert_eq!(scene.config.cloth.resolution, [8, 8]);
//! assert_eq!(scene.config.cloth.mass, wetcloth::ClothParams::default().mass);
//!
//! let err = wetcloth_scene::parse("[cloth]\nmass = -1\n", "bad.toml".as_ref()).unwrap_err();
//! assert!(err.to_string().starts_with("bad.toml:2:8: cloth.mass = -1 is out of range"));
//! ```

mod cloth_obj;
mod collider_motion;
mod error;
mod keys;
pub mod obj;
pub mod points;
mod raw;
mod set;
mod start;
mod write;

pub use error::{Location, SceneError};
pub use set::parse_value;
pub use write::to_toml;

use std::path::Path;
use wetcloth::{ConfigError, SimConfig};

/// Name of the built-in default scene, [`Scene::thesis_demo`].
pub const THESIS_DEMO_NAME: &str = "thesis-demo";

/// A scene: its name and the simulation configuration it describes.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The scene's name (`name = "..."`, or the file stem when absent). Letters, digits, `-`,
    /// `_` and `.`, not starting with `.`: it names the output directory of a run.
    pub name: String,
    /// The validated configuration.
    pub config: SimConfig,
    /// The file and text the scene came from, to locate errors found later.
    source: Option<(String, String)>,
}

impl Scene {
    /// The built-in default: [`SimConfig::thesis_demo`] named [`THESIS_DEMO_NAME`].
    pub fn thesis_demo() -> Self {
        Self {
            name: THESIS_DEMO_NAME.to_string(),
            config: SimConfig::thesis_demo(),
            source: None,
        }
    }

    /// A scene from a configuration built in code (not validated here).
    pub fn new(name: impl Into<String>, config: SimConfig) -> Self {
        Self {
            name: name.into(),
            config,
            source: None,
        }
    }

    /// The scene with every key explicit, as [`to_toml`] writes it.
    pub fn to_toml(&self) -> String {
        to_toml(&self.name, &self.config)
    }

    /// Checks that the cloth starts clear of every collider (its particles' collision spheres
    /// outside every solid) and within 1e4 m above its sticking plane (the first plane).
    /// The error names the collider (`collider[1].center`), at its line, and says how far
    /// inside the cloth is. [`parse`] and [`load`] call it; a scene built in code may.
    pub fn check_start(&self) -> Result<(), SceneError> {
        let doc = self
            .source
            .as_ref()
            .and_then(|(_, text)| toml::de::DeTable::parse(text).ok());
        let given = |i: usize, k: &str| {
            doc.as_ref().is_some_and(|doc| {
                keys::locate(doc, &format!("collider[{i}].{k}")).is_some_and(|(_, exact)| exact)
            })
        };
        let Err(p) = start::check(&self.config, given) else {
            return Ok(());
        };
        let key = format!("collider[{}].{}", p.collider, p.key);
        let shape_keys: &[&str] = match self.config.colliders[p.collider].shape {
            wetcloth::Shape::Plane(_) => &["point", "normal"],
            wetcloth::Shape::Sphere(_) => &["center", "radius"],
            wetcloth::Shape::Box(_) => &["center", "half_extents"],
            wetcloth::Shape::Mesh(_) => &["position", "rotation", "scale", "file"],
        };
        Err(match &self.source {
            Some((file, text)) => {
                let placed = |k: &str| format!("collider[{}].{k}", p.collider);
                // The key itself, else the collider's other key that places it, else its
                // table (the value then is the default).
                let found = doc.as_ref().and_then(|doc| {
                    std::iter::once(p.key)
                        .chain(shape_keys.iter().copied())
                        .find_map(|k| {
                            keys::locate(doc, &placed(k))
                                .filter(|(_, exact)| *exact)
                                .map(|(span, _)| (placed(k), span, true))
                        })
                        .or_else(|| {
                            keys::locate(doc, &key).map(|(span, _)| (key.clone(), span, false))
                        })
                });
                match found {
                    Some((key, span, exact)) => SceneError::Invalid {
                        value: if exact {
                            text.get(span.clone()).unwrap_or("?").trim().to_string()
                        } else {
                            "(default)".into()
                        },
                        at: Box::new(Location::of_span(file, text, span)),
                        key,
                        message: p.message,
                    },
                    // No [[collider]] table at all: the default ground plane is the collider.
                    // Point at what would fix it: the cloth's position (or its table, or the
                    // file's first line), and say where the plane comes from.
                    None => {
                        let message = format!(
                            "{}; the scene has no [[collider]] table, so collider[0] is the \
                             default ground plane through [0, 0, 0] with normal [0, 1, 0]: add \
                             a [[collider]] table or raise cloth.position",
                            p.message
                        );
                        let placed = doc
                            .as_ref()
                            .and_then(|doc| keys::locate(doc, "cloth.position"));
                        match placed {
                            Some((span, exact)) => SceneError::Invalid {
                                value: if exact {
                                    text.get(span.clone()).unwrap_or("?").trim().to_string()
                                } else {
                                    "(default)".into()
                                },
                                at: Box::new(Location::of_span(file, text, span)),
                                key: "cloth.position".into(),
                                message,
                            },
                            None => SceneError::Invalid {
                                at: Box::new(Location::of_span(file, text, 0..0)),
                                key: "cloth.position".into(),
                                value: "(default)".into(),
                                message,
                            },
                        }
                    }
                }
            }
            None => SceneError::Invalid {
                at: Box::new(Location::file_only(&format!("scene `{}`", self.name))),
                key,
                value: "(as configured)".into(),
                message: p.message,
            },
        })
    }

    /// Turns a [`ConfigError`] about this scene's configuration (from [`SimConfig::validate`] or
    /// [`wetcloth::Simulation::new`]) into a [`SceneError`] that points at the key in the file.
    pub fn locate(&self, err: &ConfigError) -> SceneError {
        match &self.source {
            Some((file, text)) => match toml::de::DeTable::parse(text) {
                Ok(doc) => raw::config_error(file, text, &doc, err),
                Err(_) => raw::config_error_unplaced(file, err),
            },
            None => raw::config_error_unplaced(&format!("scene `{}`", self.name), err),
        }
    }
}

/// The largest scene file [`load`] reads, bytes (16 MiB; the shipped scenes are a few
/// kilobytes, and a grab with a key per frame of a long run a few hundred).
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

/// Reads and validates the scene file at `path`. The scene's name defaults to the file stem.
///
/// At most [`MAX_SCENE_BYTES`] are read, so a path such as `/dev/zero` is refused rather than
/// read forever; pipes (`<(...)`) work. Text that is not UTF-8 is refused at its line and
/// column.
pub fn load(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
    use std::io::Read;
    let path = path.as_ref();
    let read_error = |source| SceneError::Read {
        path: path.display().to_string(),
        source,
    };
    let file = std::fs::File::open(path).map_err(read_error)?;
    let mut bytes = Vec::new();
    file.take(MAX_SCENE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(read_error)?;
    if bytes.len() as u64 > MAX_SCENE_BYTES {
        return Err(read_error(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "larger than the {} MiB a scene file may have (is it a scene file?)",
                MAX_SCENE_BYTES >> 20
            ),
        )));
    }
    let text = match String::from_utf8(bytes) {
        Ok(t) => t,
        Err(e) => {
            let at = e.utf8_error().valid_up_to();
            let byte = e.as_bytes()[at];
            let lossy = String::from_utf8_lossy(e.as_bytes());
            return Err(SceneError::Syntax {
                at: Box::new(Location::of_span(
                    &path.display().to_string(),
                    &lossy,
                    at..at + 1,
                )),
                message: format!(
                    "not UTF-8 text: byte 0x{byte:02x} here (scene files are UTF-8 TOML)"
                ),
            });
        }
    };
    parse(&text, path)
}

/// Parses and validates scene text. `file` names the text in error messages, and its stem is the
/// scene's name when the text has no `name` key.
pub fn parse(text: &str, file: &Path) -> Result<Scene, SceneError> {
    let file_label = file.display().to_string();
    let default_name = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".to_string());
    let (name, config) = raw::parse(text, &file_label, &default_name)?;
    let scene = Scene {
        name,
        config,
        source: Some((file_label, text.to_string())),
    };
    scene.config.validate().map_err(|e| scene.locate(&e))?;
    scene.check_start()?;
    Ok(scene)
}

/// Checks a scene name: letters, digits, `-`, `_` and `.`, not empty and not starting with `.`
/// (it becomes a directory name). Returns what is wrong.
pub fn check_name(name: &str) -> Result<(), String> {
    let ok_char = |c: char| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.');
    if name.is_empty() || name.starts_with('.') || !name.chars().all(ok_char) {
        Err(
            "a scene name must be non-empty, use only letters, digits, '-', '_' and '.', and \
             not start with '.' (it names the output directory)"
                .to_string(),
        )
    } else {
        Ok(())
    }
}
