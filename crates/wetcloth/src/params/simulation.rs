//! `[simulation]`: time stepping, the integrator and gravity.

use crate::math::{Real, Vec3};

/// Time stepping and global fields (`[simulation]` in a scene file).
#[derive(Clone, Debug, PartialEq)]
pub struct SimulationParams {
    /// Simulated time to run, s. Default 3.0; range (0, 1e4]. Used by drivers, not by `step`.
    pub duration: Real,
    /// Integration step, s. Default 1/12000 (the thesis' value, 8.333e-5); range [1e-7, 1e-2]
    /// with `"verlet"`, [1e-7, 0.05] with `"implicit"` (see [`Integrator::max_time_step`]).
    pub time_step: Real,
    /// Time integrator. Default [`Integrator::Verlet`] (thesis eq. 3.1).
    pub integrator: Integrator,
    /// How much solving the implicit integrator does per step. Default
    /// [`SolveBudget::Converged`]; the explicit integrator ignores it.
    pub implicit_budget: SolveBudget,
    /// Frames (and metrics rows) written per simulated second, 1/s. Default 60; range [1, 10000].
    /// Used by drivers.
    pub frame_rate: Real,
    /// Gravitational acceleration, m/s^2. Default (0, -9.8, 0) (thesis eq. 3.3); each component
    /// in [-1000, 1000].
    pub gravity: Vec3,
}

impl Default for SimulationParams {
    fn default() -> Self {
        Self {
            duration: 3.0,
            time_step: 1.0 / 12000.0,
            integrator: Integrator::Verlet,
            implicit_budget: SolveBudget::Converged,
            frame_rate: 60.0,
            gravity: Vec3::new(0.0, -9.8, 0.0),
        }
    }
}

/// The time integrator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Position Verlet, thesis eq. 3.1: `x(t+dt) = 2 x(t) - x(t-dt) + F/m dt^2`.
    #[default]
    Verlet,
    /// Backward Euler with one Newton step solved by a conjugate gradient, contacts, hands and
    /// the trapped air's gas spring inside the solve: stable at large steps (1/600 s to 1/60 s).
    Implicit,
}

impl Integrator {
    /// All integrators, for tests that run one scenario table over each.
    pub const ALL: [Integrator; 2] = [Integrator::Verlet, Integrator::Implicit];

    /// The scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Verlet => "verlet",
            Integrator::Implicit => "implicit",
        }
    }

    /// The largest time step a scene may ask for with this integrator, s: 1e-2 for position
    /// Verlet (far above any stiff cloth's stability limit already), 0.05 for the implicit
    /// integrator (the viewer's slider reaches 1/60 s).
    pub fn max_time_step(self) -> Real {
        match self {
            Integrator::Verlet => 1e-2,
            Integrator::Implicit => 0.05,
        }
    }

    /// Parses a scene-file name.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.name() == s)
    }
}

/// How much solving the implicit integrator does in a step (`[simulation] implicit_budget`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SolveBudget {
    /// Solve until the contact set, the friction and the bubble's pressure settle (up to eight
    /// solves while contacts change, four more for the pressure), the last to a relative residual
    /// of 1e-5: the accuracy that agrees with the explicit integrator (docs/integrators.md).
    #[default]
    Converged,
    /// At most three solves a step, each to a hundredth of the smaller of the right-hand side
    /// and the step's first residual: one with the contacts
    /// the step starts with, one after the bubble's pressure correction, one after re-checking
    /// the contacts (pulling ones released, held ones outside the friction cone sliding);
    /// particles that reach a collider during the step are put on its surface after it, as the
    /// explicit integrator does; the first guess is the velocity plus the last step's
    /// acceleration. For interactive use (the viewer): the thesis demo pulled at
    /// 1/60 s in real time, its hand force within the explicit integrator's spread
    /// (docs/integrators.md measures what it gives up).
    Interactive,
}

impl SolveBudget {
    /// Both budgets.
    pub const ALL: [SolveBudget; 2] = [SolveBudget::Converged, SolveBudget::Interactive];

    /// The scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            SolveBudget::Converged => "converged",
            SolveBudget::Interactive => "interactive",
        }
    }
}
