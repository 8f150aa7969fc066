//! `wetcloth._native`: the compiled half of the `wetcloth` Python package.
//!
//! It wraps the Rust crates (the core [`wetcloth`], scene files [`wetcloth_scene`], the run
//! folder's writers [`wetcloth_export`]); the Python half (`python/wetcloth/`) adds the
//! exceptions, the `Run` object and the Dask sweeps. Every long computation releases the GIL.
//! The stubs the Python half ships (`_native.pyi`) are checked against this module by a test.

mod convert;
mod run;
mod scene;
mod sim;

use pyo3::prelude::*;

/// The native module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<scene::Scene>()?;
    m.add_class::<sim::Simulation>()?;
    m.add_function(wrap_pyfunction!(run::run_scene, m)?)?;
    m.add_function(wrap_pyfunction!(scene::parse_value, m)?)?;
    m.add(
        "METRICS_COLUMNS",
        wetcloth_export::csv_header().split(',').collect::<Vec<_>>(),
    )?;
    m.add(
        "POCKETS_COLUMNS",
        wetcloth_export::POCKETS_CSV_HEADER
            .split(',')
            .collect::<Vec<_>>(),
    )?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
