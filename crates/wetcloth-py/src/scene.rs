//! `wetcloth.Scene`: a scene file, read, changed key by key and written back.

use crate::convert::{scene_error, to_py, to_toml};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// A scene: what a run needs (cloth, air, colliders, grabs), validated as the command line
/// validates scene files.
#[pyclass(module = "wetcloth._native", from_py_object)]
#[derive(Clone)]
pub struct Scene {
    pub inner: wetcloth_scene::Scene,
    /// The file label errors name and mesh paths are relative to.
    pub label: String,
}

#[pymethods]
impl Scene {
    /// The built-in thesis demo (what `wetcloth run` runs without a scene file).
    #[staticmethod]
    fn thesis_demo() -> Self {
        let inner = wetcloth_scene::Scene::thesis_demo();
        let label = format!("{}.toml", inner.name);
        Self { inner, label }
    }

    /// Reads and validates the scene file at `path`.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Self> {
        let inner = wetcloth_scene::load(&path).map_err(|e| scene_error(py, &e))?;
        Ok(Self {
            inner,
            label: path.display().to_string(),
        })
    }

    /// Parses and validates scene text; `path` names it in errors (and mesh files are relative
    /// to its folder), its stem is the name when the text has none.
    #[staticmethod]
    #[pyo3(signature = (text, path = "scene.toml"))]
    fn from_toml(py: Python<'_>, text: &str, path: &str) -> PyResult<Self> {
        let inner = wetcloth_scene::parse(text, path.as_ref()).map_err(|e| scene_error(py, &e))?;
        Ok(Self {
            inner,
            label: path.to_string(),
        })
    }

    /// The scene with every key explicit, as a run's `scene.toml`.
    fn to_toml(&self) -> String {
        self.inner.to_toml()
    }

    /// Sets the key at the dotted path (`"cloth.mass"`, `"collider.0.friction"`) and checks
    /// the scene again; raises `SceneError` (and changes nothing) when the key or value is bad.
    fn set(&mut self, py: Python<'_>, key: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let value = to_toml(value)?;
        self.inner.set(key, value).map_err(|e| scene_error(py, &e))
    }

    /// The value at the dotted path, or `None` for a valid key the scene does not have.
    fn get<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
        match self.inner.get(key).map_err(|e| scene_error(py, &e))? {
            Some(v) => Ok(Some(to_py(py, &v)?)),
            None => Ok(None),
        }
    }

    /// The scene's name (names the output folder of a run).
    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }

    /// The file the scene came from (or the label it was given).
    #[getter]
    fn path(&self) -> String {
        self.label.clone()
    }

    /// A copy (`set` on it leaves this scene alone).
    fn copy(&self) -> Self {
        self.clone()
    }

    fn __copy__(&self) -> Self {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Self {
        self.clone()
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .extract::<Scene>()
            .is_ok_and(|o| o.inner.name == self.inner.name && o.inner.config == self.inner.config)
    }

    fn __repr__(&self) -> String {
        format!("Scene({:?})", self.inner.name)
    }

    /// Pickling (Dask sends scenes to its workers): the resolved text and the label, made
    /// absolute so that mesh files are found from a worker's own folder.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let py = slf.py();
        let this = slf.borrow();
        let label = std::path::absolute(&this.label)
            .map_or_else(|_| this.label.clone(), |p| p.display().to_string());
        let ctor = py.get_type::<Scene>().getattr("from_toml")?;
        (ctor, (this.inner.to_toml(), label)).into_pyobject(py)
    }
}

/// A value written in TOML syntax as a Python value; text that is not TOML is a string (the
/// rule of `wetcloth run --set` and `wetcloth sweep --vary`).
#[pyfunction]
pub fn parse_value<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    to_py(py, &wetcloth_scene::parse_value(text))
}
