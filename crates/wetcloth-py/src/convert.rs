//! Python values to TOML values and back, and the package's exceptions.

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use toml::Value;

/// A Python value as a TOML value: bool, int, float, str, list or tuple, dict with str keys;
/// NumPy arrays and scalars through `tolist()` / `float()`.
pub fn to_toml(v: &Bound<'_, PyAny>) -> PyResult<Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return Ok(Value::Integer(v.extract()?));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(Value::String(v.extract()?));
    }
    if v.is_instance_of::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in v.extract::<Bound<'_, PyDict>>()?.iter() {
            let k: String = k
                .extract()
                .map_err(|_| PyTypeError::new_err("a table's keys must be strings"))?;
            t.insert(k, to_toml(&x)?);
        }
        return Ok(Value::Table(t));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items: PyResult<Vec<_>> = v.try_iter()?.map(|x| to_toml(&x?)).collect();
        return Ok(Value::Array(items?));
    }
    if v.hasattr("tolist")? {
        let plain = v.call_method0("tolist")?;
        if !plain.is(v) {
            return to_toml(&plain);
        }
    }
    if let Ok(x) = v.extract::<f64>() {
        return Ok(Value::Float(x));
    }
    Err(PyTypeError::new_err(format!(
        "a scene value is a bool, int, float, str, list or dict, not {}",
        v.get_type().name()?
    )))
}

/// A TOML value as a Python value (a date-time as its text).
pub fn to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Boolean(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        Value::Float(x) => x.into_pyobject(py)?.into_any(),
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Datetime(d) => d.to_string().into_pyobject(py)?.into_any(),
        Value::Array(a) => {
            let items: PyResult<Vec<_>> = a.iter().map(|x| to_py(py, x)).collect();
            PyList::new(py, items?)?.into_any()
        }
        Value::Table(t) => {
            let d = PyDict::new(py);
            for (k, x) in t {
                d.set_item(k, to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// One of the exceptions the Python half defines (`wetcloth._errors`), made with `args`.
fn python_error<'py>(py: Python<'py>, name: &str, args: Bound<'py, PyTuple>) -> PyErr {
    let made = py
        .import("wetcloth._errors")
        .and_then(|m| m.getattr(name))
        .and_then(|cls| cls.call1(args));
    match made {
        Ok(e) => PyErr::from_value(e),
        Err(e) => e,
    }
}

/// `wetcloth.SceneError` (a `ValueError`) with the message, `.key`, `.value` and `.line`.
pub fn scene_error(py: Python<'_>, e: &wetcloth_scene::SceneError) -> PyErr {
    let line = e.location().map(|l| l.line).filter(|&l| l > 0);
    let args = (
        e.to_string(),
        e.key().map(str::to_string),
        e.value().map(str::to_string),
        line,
    );
    match args.into_pyobject(py) {
        Ok(t) => python_error(py, "SceneError", t),
        Err(e) => e,
    }
}

/// `wetcloth.Unstable` (a `RuntimeError`) with the message and `.time` (s).
pub fn unstable(py: Python<'_>, message: &str, time: f64) -> PyErr {
    match (message, time).into_pyobject(py) {
        Ok(t) => python_error(py, "Unstable", t),
        Err(e) => e,
    }
}
