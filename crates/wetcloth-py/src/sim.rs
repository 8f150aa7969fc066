//! `wetcloth.Simulation`: a simulation stepped from Python, with the GIL released while it
//! steps, on its own rayon pool.

use crate::convert::{scene_error, unstable};
use crate::scene::Scene;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyIndexError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::sync::{Arc, Mutex, MutexGuard};
use wetcloth::metrics::COLUMNS;
use wetcloth::{Grab, GrabMotion, Real, Soa, StepError, Vec3};

/// The simulated time a step error names, s.
pub fn error_time(e: &StepError) -> Real {
    match e {
        StepError::NonFinite { time }
        | StepError::OverStretch { time, .. }
        | StepError::NegativeVolume { time, .. }
        | StepError::EnergyGain { time, .. }
        | StepError::OutOfReach { time, .. } => *time,
    }
}

/// Magic bytes in front of a checkpoint from `Simulation.checkpoint()`.
const CHECKPOINT_MAGIC: &[u8; 8] = b"WCLOTHCK";

/// Speed limit of a hand driven from Python, m/s: a target set far away is reached at this
/// speed rather than in one step (as a mouse drag in the viewer).
const GRAB_SPEED: Real = 2.0;

struct Inner {
    sim: wetcloth::Simulation,
    /// Why and when the simulation blew up, after which it refuses to step.
    failed: Option<(String, Real)>,
}

/// A rayon pool of `threads` threads (0: rayon's default, all cores or RAYON_NUM_THREADS).
pub fn pool(threads: usize) -> PyResult<Arc<rayon::ThreadPool>> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map(Arc::new)
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start {threads} threads: {e}")))
}

/// A simulation of a scene.
#[pyclass(module = "wetcloth._native")]
pub struct Simulation {
    inner: Mutex<Inner>,
    pool: Arc<rayon::ThreadPool>,
}

impl Simulation {
    fn lock(&self) -> MutexGuard<'_, Inner> {
        // A panic while stepping cannot leave the state half written (steps are all or
        // nothing), so a poisoned lock still holds a usable simulation.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Takes `steps` steps without the GIL; raises `Unstable` on a blow-up (and from then on).
    fn run_steps(
        &self,
        py: Python<'_>,
        steps: impl FnOnce(&wetcloth::Simulation) -> u64 + Send,
    ) -> PyResult<()> {
        let outcome = py.detach(|| {
            let mut g = self.lock();
            if let Some((why, time)) = &g.failed {
                return Err((format!("{why} (this simulation stopped there and refuses to step; restore a checkpoint or start a new one)"), *time));
            }
            let n = steps(&g.sim);
            let sim = &mut g.sim;
            let r = self.pool.install(|| sim.advance(n));
            r.map_err(|e| {
                let failed = (e.to_string(), error_time(&e));
                g.failed = Some(failed.clone());
                failed
            })
        });
        outcome.map_err(|(why, time)| unstable(py, &why, time))
    }
}

/// `(n, 3)` float64 array of `v`, read-only (a copy of the simulation's state).
fn points<'py>(py: Python<'py>, v: &Soa) -> PyResult<Bound<'py, PyAny>> {
    let n = v.len();
    let mut flat = Vec::with_capacity(3 * n);
    for k in 0..n {
        flat.extend([v.x[k], v.y[k], v.z[k]]);
    }
    let a = PyArray1::from_vec(py, flat).reshape([n, 3])?;
    a.getattr("flags")?.setattr("writeable", false)?;
    Ok(a.into_any())
}

/// `metrics.csv`'s columns (without `frame`) for the state of `sim`.
pub fn metrics_dict<'py>(
    py: Python<'py>,
    sim: &wetcloth::Simulation,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, v) in COLUMNS.iter().zip(sim.metrics().values()) {
        if *name == "pocket_count" {
            d.set_item(*name, v as u64)?;
        } else {
            d.set_item(*name, v)?;
        }
    }
    Ok(d)
}

#[pymethods]
impl Simulation {
    /// A simulation of `scene` at t = 0, stepping on `threads` threads (results do not depend
    /// on it). Raises `SceneError` when the scene's values cannot make a simulation.
    #[new]
    #[pyo3(signature = (scene, threads = 1))]
    fn new(py: Python<'_>, scene: &Scene, threads: usize) -> PyResult<Self> {
        if threads == 0 {
            return Err(PyValueError::new_err("threads must be at least 1"));
        }
        let sim = wetcloth::Simulation::new(scene.inner.config.clone())
            .map_err(|e| scene_error(py, &scene.inner.locate(&e)))?;
        Ok(Self {
            inner: Mutex::new(Inner { sim, failed: None }),
            pool: pool(threads)?,
        })
    }

    /// Takes `n` time steps (the GIL is released meanwhile).
    #[pyo3(signature = (n = 1))]
    fn step(&self, py: Python<'_>, n: u64) -> PyResult<()> {
        self.run_steps(py, |_| n)
    }

    /// Advances by `seconds` of simulated time: the steps the command line takes for it (up to
    /// the first step at or after the current time + `seconds`).
    fn advance(&self, py: Python<'_>, seconds: f64) -> PyResult<()> {
        if !seconds.is_finite() || seconds < 0.0 {
            return Err(PyValueError::new_err(format!(
                "advance(seconds): seconds = {seconds} must be finite and >= 0"
            )));
        }
        self.run_steps(py, |sim| {
            let dt = sim.time_step();
            let now = sim.step_count();
            wetcloth_export::step_at(now as Real * dt + seconds, dt).saturating_sub(now)
        })
    }

    /// Simulated time, s.
    #[getter]
    fn time(&self) -> f64 {
        self.lock().sim.time()
    }

    /// Steps taken.
    #[getter]
    fn steps(&self) -> u64 {
        self.lock().sim.step_count()
    }

    /// The time step, s.
    #[getter]
    fn time_step(&self) -> f64 {
        self.lock().sim.time_step()
    }

    /// Grid size `(columns, rows)`: particle `[i, j]` is index `j * columns + i`. `None` for
    /// a mesh cloth (`[cloth] mesh`), whose particle `k` is its file's vertex `k`.
    #[getter]
    fn resolution(&self) -> Option<(usize, usize)> {
        let g = self.lock();
        g.sim.model().grid_size.map(|[nx, nz]| (nx, nz))
    }

    /// Particle positions, m: a read-only `(n, 3)` float64 copy (it does not follow the
    /// simulation; read it again after stepping).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let x = self.lock().sim.positions().clone();
        points(py, &x)
    }

    /// Particle velocities, m/s: a read-only `(n, 3)` float64 copy.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = self.lock().sim.velocities();
        points(py, &v)
    }

    /// The `metrics.csv` columns (but `frame`) for the current state: a dict of floats
    /// (`pocket_count` an int).
    fn metrics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        metrics_dict(py, &self.lock().sim)
    }

    /// The sealed air pockets now, one dict each with the `pockets.csv` columns (but `frame`):
    /// `time` s, `pocket` id, `volume` m^3, `amount` m^3 at atmospheric pressure, `pressure` Pa,
    /// `area` m^2, `particles`.
    fn pockets<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let g = self.lock();
        let time = g.sim.time();
        g.sim
            .pocket_reports()
            .iter()
            .map(|p| {
                let d = PyDict::new(py);
                d.set_item("time", time)?;
                d.set_item("pocket", p.id)?;
                d.set_item("volume", p.volume)?;
                d.set_item("amount", p.amount)?;
                d.set_item("pressure", p.pressure)?;
                d.set_item("area", p.area)?;
                d.set_item("particles", p.particles)?;
                Ok(d)
            })
            .collect()
    }

    /// Takes hold of `particle` (an index, or `[column, row]` on the grid) and moves it to
    /// `target` (an absolute position, m) from the next step on, at up to 2 m/s, holding it
    /// there; grabbing a held particle again moves its target.
    fn grab(&self, particle: &Bound<'_, PyAny>, target: [f64; 3]) -> PyResult<()> {
        let mut g = self.lock();
        let n = g.sim.particle_count();
        let grid = g.sim.model().grid_size.map(|[nx, nz]| (nx, nz));
        let index = match particle.extract::<usize>() {
            Ok(k) if k < n => k,
            Ok(k) => {
                return Err(PyIndexError::new_err(format!(
                    "particle {k} is not on the cloth: it has {n} particles (0..{})",
                    n - 1
                )));
            }
            Err(_) => {
                let Some((nx, nz)) = grid else {
                    return Err(PyValueError::new_err(
                        "a mesh cloth's particle is an index (its file's vertex, from 0)",
                    ));
                };
                let [i, j]: [usize; 2] = particle
                    .extract()
                    .map_err(|_| PyValueError::new_err("particle is an index or [column, row]"))?;
                if i >= nx || j >= nz {
                    return Err(PyIndexError::new_err(format!(
                        "particle [{i}, {j}] is not on the {nx} x {nz} grid"
                    )));
                }
                j * nx + i
            }
        };
        if !target.iter().all(|c| c.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "target {target:?} must be finite (m)"
            )));
        }
        let target = Vec3::new(target[0], target[1], target[2]);
        let motion = GrabMotion::Target {
            target,
            max_speed: GRAB_SPEED,
        };
        let held = g
            .sim
            .grabs()
            .iter()
            .position(|h| h.particle == index && matches!(h.motion, GrabMotion::Target { .. }));
        match held {
            Some(h) => g.sim.grab_mut(h).motion = motion,
            None => {
                g.sim.add_grab(Grab::new(index, motion));
            }
        }
        Ok(())
    }

    /// Lets go of `particle` (an index or `[column, row]`; every hand holding it, the scene's
    /// keyframed ones included), or of every particle when `None`.
    #[pyo3(signature = (particle = None))]
    fn release(&self, particle: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        let mut g = self.lock();
        let nx = g.sim.model().grid_size.map(|[nx, _]| nx);
        let index = match particle {
            None => None,
            Some(p) => Some(match p.extract::<usize>() {
                Ok(k) => k,
                Err(_) => {
                    let Some(nx) = nx else {
                        return Err(PyValueError::new_err(
                            "a mesh cloth's particle is an index (its file's vertex, from 0)",
                        ));
                    };
                    let [i, j]: [usize; 2] = p.extract().map_err(|_| {
                        PyValueError::new_err("particle is an index or [column, row]")
                    })?;
                    j * nx + i
                }
            }),
        };
        for h in (0..g.sim.grabs().len()).rev() {
            if index.is_none_or(|k| g.sim.grabs()[h].particle == k) {
                g.sim.remove_grab(h);
            }
        }
        Ok(())
    }

    /// The full state as bytes; `Simulation.restore(scene, data)` continues it bit for bit.
    fn checkpoint<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let ck = self.lock().sim.checkpoint();
        let mut bytes = CHECKPOINT_MAGIC.to_vec();
        let body = postcard::to_allocvec(&ck)
            .map_err(|e| PyRuntimeError::new_err(format!("cannot write the checkpoint: {e}")))?;
        bytes.extend(body);
        Ok(PyBytes::new(py, &bytes))
    }

    /// The simulation of `scene` continued from `data` (from `checkpoint()`); raises
    /// `ValueError` when the data is not a checkpoint or does not fit the scene.
    #[staticmethod]
    #[pyo3(signature = (scene, data, threads = 1))]
    fn restore(py: Python<'_>, scene: &Scene, data: &[u8], threads: usize) -> PyResult<Self> {
        let body = data
            .strip_prefix(CHECKPOINT_MAGIC.as_slice())
            .ok_or_else(|| {
                PyValueError::new_err("not a wetcloth checkpoint (from Simulation.checkpoint())")
            })?;
        let ck: wetcloth::Checkpoint = postcard::from_bytes(body)
            .map_err(|e| PyValueError::new_err(format!("damaged checkpoint: {e}")))?;
        let sim =
            wetcloth::Simulation::restore(scene.inner.config.clone(), ck).map_err(|e| match e {
                wetcloth::RestoreError::Config(c) => scene_error(py, &scene.inner.locate(&c)),
                e => PyValueError::new_err(e.to_string()),
            })?;
        if threads == 0 {
            return Err(PyValueError::new_err("threads must be at least 1"));
        }
        Ok(Self {
            inner: Mutex::new(Inner { sim, failed: None }),
            pool: pool(threads)?,
        })
    }

    fn __repr__(&self) -> String {
        let g = self.lock();
        format!(
            "Simulation(t={} s, {} particles{})",
            g.sim.time(),
            g.sim.particle_count(),
            if g.failed.is_some() { ", failed" } else { "" }
        )
    }
}
