//! Time integrators: one file per integrator, all behind one shape,
//! `step(model, state, control, air, dt)`.
//!
//! An integrator takes the state at `t` to `t + dt` under the forces of [`crate::forces`] and
//! the air's load, resolves contacts with the colliders (eq. 3.4-3.5), and places the grabbed
//! particles on their targets, recording the hand's force (thesis 3.2 steps 2-4). Position
//! corrections (strain limiting, self-collision) and the air's bookkeeping come after it, in
//! [`crate::Simulation::step`].
//!
//! | file | integrator | scene name |
//! |---|---|---|
//! | `verlet.rs` | position Verlet, thesis eq. 3.1 (explicit), the grid's fused row pass | `"verlet"` |
//! | `verlet_mesh.rs` | the same on a cloth of any shape, by blocks of particles | `"verlet"` |
//! | `implicit/` | backward Euler, one Newton step, conjugate gradient (large steps), the grid's stencil matrix and `multigrid.rs` | `"implicit"` |
//! | `implicit_mesh.rs` | the same on a cloth of any shape: the block-sparse matrix and aggregation multigrid of `sparse.rs` | `"implicit"` |
//!
//! A new integrator is a new file here, a variant of [`crate::params::Integrator`] (its scene
//! name) and of `IntegratorState`; it must pass the scenario table of `tests/physics.rs`.

pub(crate) mod implicit;
pub(crate) mod implicit_mesh;
pub(crate) mod multigrid;
pub(crate) mod sparse;
pub(crate) mod verlet;
pub(crate) mod verlet_mesh;

use crate::air::{AirModel, Timing};
use crate::control::Control;
use crate::math::{Real, Soa};
use crate::measure::Measures;
use crate::model::Model;
use crate::params::{AirParams, Integrator, SolveBudget};
use crate::state::State;

/// The air as the integrator sees it during one step.
pub(crate) struct Air<'a> {
    /// The `[air]` parameters.
    pub params: &'a AirParams,
    /// The air model, which gives the load and, for [`Timing::EndOfStep`], solves it from the
    /// integrator's coasting positions.
    pub model: &'a mut AirModel,
    /// When the step's pressure is known.
    pub timing: Timing,
}

impl Air<'_> {
    /// The pressure of the step's end ([`Timing::EndOfStep`]) from the coasting positions
    /// `coast` of the explicit step: measured into `measures` (each cell's volume kept when
    /// `keep_cells`; `parallel`: rows, or on a mesh any count, to a task on the pool), then
    /// solved by the air model (which then gives the load).
    pub fn solve_at_end(
        &mut self,
        model: &Model,
        coast: &Soa,
        measures: &mut Measures,
        keep_cells: bool,
        held: &[bool],
        parallel: Option<usize>,
    ) {
        measures.keep_cells = keep_cells;
        measures.remeasure_layout(
            model.layout(),
            coast,
            model.sticking,
            model.radius,
            parallel,
        );
        self.model
            .solve_end_of_step(self.params, model, coast, measures, held, None);
    }
}

/// What the step asks an integrator to measure while it has the new positions at hand.
pub(crate) struct Fused<'a> {
    /// Positions the self-collision lists were built at, if any: the integrator returns the
    /// largest squared distance (m^2) of a new position from them.
    pub reference: Option<&'a Soa>,
    /// The cell measures of the new state (volume, stretch, finiteness), every row valid on
    /// return.
    pub measures: &'a mut Measures,
    /// Rows per task when the pass is split over the thread pool, `None` on the calling thread.
    pub rows_per_task: Option<usize>,
    /// The time at the step's start, s: where the moving colliders are (the implicit
    /// integrator's; the explicit one counts its steps).
    pub start: Real,
}

/// An integrator and its scratch.
/// Position Verlet is kept inline (the thesis path, unchanged); the implicit scratch is boxed.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub(crate) enum IntegratorState {
    /// Position Verlet.
    Verlet(verlet::Verlet),
    /// Backward Euler with a conjugate gradient.
    Implicit(Box<implicit::Implicit>),
    /// Backward Euler on a mesh cloth (block-sparse matrix, aggregation multigrid).
    ImplicitMesh(Box<implicit_mesh::ImplicitMesh>),
}

impl IntegratorState {
    /// The integrator `kind` for `model`, the implicit one solving to `budget`.
    pub fn new(kind: Integrator, budget: SolveBudget, model: &Model) -> Self {
        match kind {
            Integrator::Verlet => IntegratorState::Verlet(verlet::Verlet::new(model)),
            Integrator::Implicit if model.mesh.is_some() => IntegratorState::ImplicitMesh(
                Box::new(implicit_mesh::ImplicitMesh::new(model, budget)),
            ),
            Integrator::Implicit => {
                IntegratorState::Implicit(Box::new(implicit::Implicit::new(model, budget)))
            }
        }
    }

    /// One step of `dt` s (see the module docs). Returns the largest squared distance (m^2) of
    /// a new position from `fused.reference`.
    pub fn step(
        &mut self,
        model: &Model,
        state: &mut State,
        control: &mut Control,
        air: Air<'_>,
        dt: Real,
        fused: Fused<'_>,
    ) -> Real {
        match self {
            IntegratorState::Verlet(v) => v.step(model, state, control, air, dt, fused),
            IntegratorState::Implicit(i) => i.step(model, state, control, air, dt, fused),
            IntegratorState::ImplicitMesh(i) => {
                let crate::model::Layout::Mesh(mesh, springs) = model.layout() else {
                    unreachable!("built for a mesh cloth")
                };
                i.step(model, mesh, springs, state, control, air, dt, fused)
            }
        }
    }

    /// Conjugate-gradient iterations of every step so far (all their solves); 0 for Verlet.
    pub fn solver_iterations(&self) -> u64 {
        match self {
            IntegratorState::Verlet(_) => 0,
            IntegratorState::Implicit(i) => i.total_iterations,
            IntegratorState::ImplicitMesh(i) => i.total_iterations,
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        match self {
            IntegratorState::Verlet(v) => v.heap_bytes(),
            IntegratorState::Implicit(i) => i.heap_bytes(),
            IntegratorState::ImplicitMesh(i) => i.heap_bytes(),
        }
    }
}
