//! Backward Euler with one Newton step and a matrix-free, preconditioned conjugate gradient on
//! the 9-point stencil: a large-step integrator for stiff cloth under trapped air.
//!
//! The unknown is the velocity at the end of the step, `v+`, with `x+ = x + dt v+`. Linearising
//! the forces at the start of the step, backward Euler `M (v+ - v) = dt f(x+, v+)` becomes
//!
//! ```text
//! [ M (1 + dt c) + dt^2 H + dt^2 sum_r k_r g_r g_r^T ] v+ = M v + dt f(x)
//! ```
//!
//! with `c` the damping rate (1/s), `H = -df/dx` of the springs (eq. 3.6; each spring's
//! `k [d d^T + max(0, 1 - l/|d|) (I - d d^T)]`, the transverse part dropped for a compressed
//! spring so that `H` stays positive semi-definite), and for each sealed region of air `r`
//! (`air::region`: the thesis' bubble, or a pocket) its gas spring, the rank-one term with
//! `k_r = P_r / V_r` (Pa/m^3, minus Boyle's `dP/dV`) and `g_r` the pressure force per pascal of
//! its particles (`S N_i`, eq. 3.7; `dV/dx_i` as the thesis spreads it). That spread is not the
//! gradient of the volume the pressure comes from (eq. 3.10 gives a border particle half an
//! inner one's share), so for the thesis' bubble the step also measures the volume at its end
//! and shifts the pressure by the gas spring times the miss beyond `g . v+ dt` (a relaxed
//! iteration on the shift, see [`Relaxation`](crate::air::solve::Relaxation)), solving again while the shift moves it by more
//! than 0.01 Pa. The system matrix is
//! symmetric positive definite; the conjugate gradient applies it row by row (the springs of
//! each particle's 8 neighbours, then one dot product per region for the rank-one terms), never
//! forming it. Its preconditioner is the diagonal where most particles are held (a cloth
//! pressed onto the table: the solve runs over the free ones alone), and where most of a cloth
//! of at least 400 particles is free, a multigrid V-cycle on the grid
//! ([`super::multigrid`]) for the springs, with the gas springs' rank-one terms added to its
//! inverse by the Woodbury identity: `M^-1 = V - W (C^-1 + U^T W)^-1 W^T`, `W = V U`, `U`
//! the regions' filtered `g_r`, `C` their `dt^2 k_r`.
//!
//! Constraints are filtered out of the solve (Baraff and Witkin 1998): a particle a hand holds
//! has its velocity fixed to reach the hand's target; a particle touching a collider has its
//! normal velocity fixed to land on the surface. The force each constraint needs is the
//! residual `(A v+ - b) / dt` at its particle: for a hand, the hand's force (thesis 3.2 step 3);
//! for a contact, the normal force of eq. 3.4. A contact that would have to pull is released
//! and a particle that would land inside a collider is constrained, and the system solved
//! again. Coulomb friction (eq. 3.5) is in the solve: a touching particle starts held (its
//! tangential velocity zero) and slides once the force that holds it leaves the cone
//! `|F_t| <= mu F_n`; a slide feels kinetic friction `mu F_n` against its velocity,
//! linearised at the velocity of the solve before (see [`Constraint::Normal`]), so on a slope
//! of angle theta it accelerates at `g (sin theta - mu cos theta)` at any step. A slide that
//! friction stops within the step goes on against a drag that cannot reverse it, so friction
//! never does positive work. A contact still sliding at the end of a step starts the next one
//! sliding ([`crate::state::Slide`]), not held.
//!
//! A strain limit (`[cloth] strain_limit`) is part of the springs: past `(1 + limit)` times its
//! rest length a spring is [`LIMIT_STIFFENING`] times stiffer, so the solve (and the friction
//! that answers its forces) sees the limit; a spring the solution takes past it while
//! linearised below it is put on the stiff branch and the step solved again. Provot's
//! projection, the explicit integrator's limiter, is not applied after this integrator.
//!
//! Every sum (the dot products of the gradient, the regions' dot products) runs over the
//! particles in index order, so the result does not depend on the thread count.

mod caches;
mod contacts;
mod gas;
mod lying;
mod matrix;
mod solver;
mod springs;
mod strain;

use super::multigrid::{CENTRE, Multigrid, cholesky, cholesky_solve, neighbours, slot};
use super::{Air, Fused};
use crate::air::region::Regions;
use crate::air::solve::{PRESSURE_PASSES, SolveShare};
use crate::checks;
use crate::collide::Collider;
use crate::collide::contact::{self, Frames};
use crate::control::Control;
use crate::forces::pressure;
use crate::math::{Real, RowMut, Soa, Vec3, row};
use crate::model::Model;
use crate::params::{PressureForce, SolveBudget};
use crate::state::{Motion, Slide, State};
use caches::*;
use contacts::*;
// The mesh's implicit step finds its contacts as this one does.
pub(in crate::integrate) use contacts::{
    Constraint, Surface, contact_constraint, landing_constraint,
};
use gas::*;
use glam::DMat3;
use matrix::*;
use springs::*;
use std::ops::Range;
use strain::*;

/// Relative residual at which the conjugate gradient stops: `|r| <= CG_TOLERANCE |b|`.
pub const CG_TOLERANCE: Real = 1e-5;

/// Most conjugate-gradient iterations per solve.
pub const CG_MAX_ITERATIONS: usize = 4000;

/// Relative residual of every solve of the interactive budget ([`SolveBudget::Interactive`]),
/// relative to the smaller of the right-hand side and the residual the step's first solve
/// started from. On the thesis demo pulled at 1/60 s (first guesses from the gravity alone):
/// 1e-3 took 65 iterations a step (0.95 times real time on one thread), 1e-2 32 (1.65 times),
/// with the hand force, the bubble and the contact fraction as close to the explicit
/// integrator's (docs/integrators.md).
pub const INTERACTIVE_TOLERANCE: Real = 1e-2;

/// Relative residual at which the solves before the last one stop. Those only decide which
/// contacts hold, stick or slide; the last solve (the one whose constraints no longer change, or
/// the last allowed) is taken on to [`CG_TOLERANCE`] from where they left off. A thousandth
/// decides the contact set as well as `CG_TOLERANCE` does, in half the iterations on a cloth
/// dragged over the table; a hundredth (tried) does not: on the thesis demo held lifted at
/// 1/60 s the bubble's volume then jumped by up to 20 cm^3 from one step to the next.
pub const CG_CONTACT_TOLERANCE: Real = 1e-3;

/// Most solves per step while the contact set changes. With 4, a dry cloth lifted at its
/// centre (`pinch-dry`) ran out of solves while its rim changed from held to sliding and the
/// hand pulled twice the explicit integrator's peak force at 1/600 s; with 8 it agrees.
const CONTACT_PASSES: usize = 8;

/// Scratch of the implicit integrator.
#[derive(Clone, Debug, Default)]
pub(crate) struct Implicit {
    /// The linearised springs of the four stencil directions.
    springs: Stencil,
    /// The grid's runs of springs ([`spans`]), listed once: walking the iterator cost 4 % of
    /// a pressed-flat cloth's step.
    runs: std::sync::Arc<[Run]>,
    /// Forces at the start of the step (without the hands and contacts), N; once the
    /// right-hand side is built, the change of the forces of springs the strain limit tightens
    /// ([`Implicit::tighten`]).
    force: Soa,
    /// Pressure force per pascal of each particle, m^2 (`S N_i`).
    per_pascal: Soa,
    /// Per particle: whether the solve just taken drove it through a collider's surface (its
    /// end-of-step position is then no guide to its springs' stretch).
    landed: Vec<bool>,
    /// The air's share of the solve (the bubble's pressure correction, the pockets' rims).
    air: SolveShare,
    /// The particles near a landing this step (`lying.rs`), each one's end-of-step surface
    /// normal where it lies on one, and those whose pressure force turned to it (listed and
    /// marked), with their pressure force per pascal at the step's start.
    near_landing: Vec<u32>,
    lying: Vec<Option<Vec3>>,
    turned: Vec<u32>,
    is_turned: Vec<bool>,
    start_g: Vec<Vec3>,
    /// The air's regions.
    regions: Regions,
    /// Each region's gas-spring term `dt^2 k_r`, and scratch for its dot product.
    gas: Vec<Real>,
    dots: Vec<Real>,
    constraints: Vec<Constraint>,
    /// The particles with a free direction in the current solve.
    active: Vec<u32>,
    /// Mass times `1 + dt c`, kg, per particle.
    inertia: Vec<Real>,
    /// Right-hand side `M v + dt f`, and the unknown `v+`.
    rhs: Soa,
    v: Soa,
    /// Conjugate-gradient vectors: residual, preconditioned residual, direction, `A p`.
    r: Soa,
    z: Soa,
    p: Soa,
    q: Soa,
    /// Inverse of the diagonal of the system matrix, and the diagonal without friction drag.
    inv_diag: Soa,
    diag_base: Soa,
    /// The multigrid preconditioner (when in use) and, for the gas springs, the low-rank
    /// correction of its inverse ([`Woodbury`]).
    mg: Multigrid,
    use_multigrid: bool,
    woodbury: Woodbury,
    /// The last step's final constraints (those of its last product), beside this step's.
    prev_constraints: Vec<Constraint>,
    /// Work kept from step to step and solve to solve with the bits of the whole computation,
    /// and what invalidates it ([`Kept::notify`]).
    kept: Kept,
    /// Conjugate-gradient iterations of the last step (all solves), and of every step since
    /// this scratch was made.
    pub iterations: usize,
    pub total_iterations: u64,
    /// How much solving a step does.
    budget: SolveBudget,
    /// The colliders of the step where any moves ([`Surface::of_step`]).
    surfaces: Vec<Surface>,
    /// The squared residual the step's first solve started from (the interactive budget's
    /// reference, with the right-hand side's).
    first_residual: Option<Real>,
}

impl Implicit {
    /// Scratch for the particles of `model`, solving each step to `budget`.
    pub fn new(model: &Model, budget: SolveBudget) -> Self {
        let n = model.grid().len();
        Self {
            springs: Stencil {
                right: SpringSet::new(n),
                down: SpringSet::new(n),
                diag: SpringSet::new(n),
                anti: SpringSet::new(n),
            },
            runs: spans(model.grid().nx, model.grid().nz).collect(),
            force: Soa::zeros(n),
            per_pascal: Soa::zeros(n),
            landed: vec![false; n],
            air: SolveShare::new(n),
            near_landing: Vec::new(),
            lying: Vec::new(),
            turned: Vec::new(),
            is_turned: Vec::new(),
            start_g: Vec::new(),
            regions: Regions::default(),
            gas: Vec::new(),
            dots: Vec::new(),
            constraints: vec![Constraint::Free; n],
            active: Vec::with_capacity(n),
            inertia: vec![0.0; n],
            rhs: Soa::zeros(n),
            v: Soa::zeros(n),
            r: Soa::zeros(n),
            z: Soa::zeros(n),
            p: Soa::zeros(n),
            q: Soa::zeros(n),
            inv_diag: Soa::zeros(n),
            diag_base: Soa::zeros(n),
            mg: Multigrid::default(),
            use_multigrid: false,
            woodbury: Woodbury::default(),
            prev_constraints: vec![Constraint::Free; n],
            kept: Kept::new(n),
            iterations: 0,
            total_iterations: 0,
            budget,
            first_residual: None,
            surfaces: Vec::new(),
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let st = &self.springs;
        [&st.right, &st.down, &st.diag, &st.anti]
            .iter()
            .map(|s| s.heap_bytes())
            .sum::<usize>()
            + [
                &self.force,
                &self.per_pascal,
                &self.rhs,
                &self.v,
                &self.r,
                &self.z,
                &self.p,
                &self.q,
                &self.inv_diag,
                &self.diag_base,
                &self.kept.av,
                &self.kept.av_of,
                &self.kept.lin_x,
                &self.kept.diag_springs,
            ]
            .iter()
            .map(|s| s.heap_bytes())
            .sum::<usize>()
            + self.mg.heap_bytes()
            + self.woodbury.heap_bytes()
            + self.constraints.capacity() * std::mem::size_of::<Constraint>()
            + self.inertia.capacity() * 8
            + self.landed.capacity()
            + self.near_landing.capacity() * 4
            + self.lying.capacity() * std::mem::size_of::<Option<Vec3>>()
            + self.turned.capacity() * 4
            + self.is_turned.capacity()
            + self.start_g.capacity() * std::mem::size_of::<Vec3>()
            + self.air.heap_bytes()
            + (self.kept.av_rows.capacity() + self.kept.row_mark.capacity()) * 4
            + self.prev_constraints.capacity() * std::mem::size_of::<Constraint>()
            + self.kept.lin_moved.capacity()
            + self.runs.len() * std::mem::size_of::<Run>()
    }

    /// One step of `dt` s (see the module docs), as its phases. Returns the largest squared
    /// distance (m^2) of a new position of a particle no hand holds from `fused.reference`.
    pub fn step(
        &mut self,
        model: &Model,
        state: &mut State,
        control: &mut Control,
        air: Air<'_>,
        dt: Real,
        fused: Fused<'_>,
    ) -> Real {
        state.use_previous_positions(dt);
        self.begin_air(model, state, control, &air, dt);
        self.forces(model, &state.x);
        let surfaces = self.place_colliders(model, fused.start, dt);
        self.right_hand_side(model, state, dt);
        self.constrain(model, state, control, &surfaces, dt);
        self.begin_lying(model, state);
        // `System` borrows the regions; the rest of `self` is used mutably below.
        let regions = std::mem::take(&mut self.regions);
        let sys = System {
            nx: model.grid().nx,
            nz: model.grid().nz,
            dt2: dt * dt,
            regions: &regions,
        };
        self.turn_lying(&sys, false, model, state, &surfaces, dt, false);
        self.prepare_matrix(&sys);
        self.air.start(
            model,
            &regions,
            &state.x,
            &self.v,
            &self.per_pascal,
            &mut self.rhs,
            dt,
        );
        let budget = Budget::of(self.budget);
        self.solve_contacts(&sys, model, state, &surfaces, dt, budget);
        let shifted = self.solve_pressure(&sys, model, state, dt, budget);
        self.settle_contacts(&sys, model, state, &surfaces, dt, budget, shifted);
        self.total_iterations += self.iterations as u64;
        self.regions = regions;
        self.hand_forces(state, control, dt);
        let (moved, volume_change) =
            self.move_particles(model, state, control, &surfaces, &fused, dt);
        self.surfaces = surfaces;
        self.air
            .finish(air.model, control.air_enabled, &self.regions, volume_change);
        fused.measures.remeasure_all(
            model.grid(),
            &state.x,
            model.sticking,
            model.radius,
            fused.rows_per_task,
        );
        moved
    }

    /// The air as regions (a pressure known now, the explicit timing, is no gas spring in the
    /// solve), each region's gas spring `dt^2 k_r`, and the air's share of the step.
    fn begin_air(
        &mut self,
        model: &Model,
        state: &State,
        control: &Control,
        air: &Air<'_>,
        dt: Real,
    ) {
        air.model
            .regions(air.params, model, control.air_enabled, &mut self.regions);
        self.air
            .begin(air.model, &self.regions, air.timing, model, &state.x);
        let end_of_step = self.air.end_of_step;
        self.gas.clear();
        self.gas.extend(self.regions.list.iter().map(|r| {
            if end_of_step {
                dt * dt * r.stiffness
            } else {
                0.0
            }
        }));
    }

    /// The colliders where they are over the step (empty where none moves: the contacts read
    /// the model's own).
    fn place_colliders(&mut self, model: &Model, start: Real, dt: Real) -> Vec<Surface> {
        let mut surfaces = std::mem::take(&mut self.surfaces);
        Surface::of_step(model, start, dt, &mut surfaces);
        surfaces
    }

    /// The inertia `M (1 + dt c)`, the right-hand side `M v + dt f`, the first guess of `v+`,
    /// and (in `r`, free until the solve) the velocity at the step's start.
    fn right_hand_side(&mut self, model: &Model, state: &State, dt: Real) {
        let c = model.damping;
        let Motion::Previous(prev) = &state.motion else {
            unreachable!("converted by the step")
        };
        for k in 0..state.len() {
            let m = model.mass(k);
            self.inertia[k] = m * (1.0 + dt * c);
            let v = (state.x.get(k) - prev.get(k)) / dt;
            self.rhs.set(k, v * m + self.force.get(k) * dt);
            // First guess: the velocity after gravity alone (exact in free fall); with the
            // interactive budget, after the last step's acceleration (its few coarse solves
            // start closer: 22 iterations a step instead of 32 on the pulled demo).
            let a = match self.budget {
                SolveBudget::Converged => model.gravity,
                SolveBudget::Interactive => state.acceleration.get(k),
            };
            self.v.set(k, v + a * dt);
            self.r.set(k, v);
        }
    }

    /// The step's first constraints: the hands, then contacts where a particle touches or would
    /// reach a collider during the step at its current speed. A contact that ended the last
    /// step sliding and still moves starts sliding against the friction it had; any other
    /// starts held (the friction cone decides after the first solve). Starting every contact
    /// held, a cloth sliding over the table was gripped anew at each step's start: the thesis
    /// demo lifted at 1/60 s pulled the hand with 0.26 N against the explicit 0.14 N. The last
    /// step's final constraints are kept beside this step's (`keep_product`).
    fn constrain(
        &mut self,
        model: &Model,
        state: &State,
        control: &Control,
        surfaces: &[Surface],
        dt: Real,
    ) {
        std::mem::swap(&mut self.constraints, &mut self.prev_constraints);
        self.constraints.fill(Constraint::Free);
        for (k, target) in control.active() {
            self.constraints[k] = Constraint::Fixed((target - state.x.get(k)) / dt);
        }
        for k in 0..state.len() {
            if self.constraints[k] != Constraint::Free {
                continue;
            }
            let (x, v) = (state.x.get(k), self.r.get(k));
            let c = contact_constraint(model, surfaces, k, x, v, dt, state.contact[k]);
            let Constraint::Stick { n, vn, mu, u } = c else {
                self.constraints[k] = c;
                continue;
            };
            let vt = c.slip(v);
            let speed = vt.length();
            self.constraints[k] = match state.slides[k] {
                _ if speed <= SLIDE_EPSILON => c,
                Slide::None => c,
                Slide::Kinetic(f) => Constraint::Normal {
                    n,
                    vn,
                    mu,
                    drag: f * dt / speed,
                    t: vt / speed,
                    kinetic: f * dt,
                    u,
                },
                Slide::Drag(rate) => Constraint::Normal {
                    n,
                    vn,
                    mu,
                    drag: rate * dt,
                    t: Vec3::ZERO,
                    kinetic: 0.0,
                    u,
                },
            };
        }
    }

    /// The step's diagonal (the preconditioner's), and the last step's product `A v` kept
    /// where it still holds.
    fn prepare_matrix(&mut self, sys: &System<'_>) {
        // Read before `precondition` consumes them.
        let product_current = self.kept.av_fresh && self.kept.diag_kept;
        self.precondition(sys);
        self.keep_product(sys, product_current);
        self.iterations = 0;
        self.first_residual = None;
    }

    /// The solves while the contact set changes: after each, contacts that pull go free, held
    /// ones outside the friction cone slide, slides follow their speed, particles that would
    /// land inside a collider are constrained, the air's pressures follow the solve, and springs
    /// the solve takes past the strain limit stiffen; the solve whose changes are none (or the
    /// last allowed) is finished to the full tolerance.
    fn solve_contacts(
        &mut self,
        sys: &System<'_>,
        model: &Model,
        state: &State,
        surfaces: &[Surface],
        dt: Real,
        budget: Budget,
    ) {
        for pass in 0..budget.passes {
            let last = pass + 1 == budget.passes;
            self.solve_and_apply(
                sys,
                if last {
                    budget.tolerance
                } else {
                    CG_CONTACT_TOLERANCE
                },
            );
            if last {
                self.limit_and_resolve(sys, model, &state.x, dt, budget.tolerance);
                break;
            }
            let mut changed = self.update_contacts(model, state, surfaces, dt);
            changed |= self.turn_lying(sys, true, model, state, surfaces, dt, false);
            changed |= self.air.correct_bubble(
                model,
                &state.x,
                &self.v,
                &self.per_pascal,
                &mut self.rhs,
                dt,
            );
            changed |= self.air.correct_rims(
                model,
                sys.regions,
                &self.v,
                &self.per_pascal,
                &mut self.rhs,
                dt,
            );
            // The strain limit: springs this solve takes past it go onto their stiff branch.
            if self.tighten(model, &state.x, dt) {
                self.precondition(sys);
                changed = true;
            }
            if !changed {
                // The contact set holds: finish this solve to the full tolerance (and, as after
                // the last allowed solve, once more if that takes a spring past the limit).
                self.solve_and_apply(sys, budget.tolerance);
                self.limit_and_resolve(sys, model, &state.x, dt, budget.tolerance);
                break;
            }
        }
    }

    /// The bubble's pressure, once more from the last (accurate) solve: the contact passes
    /// measure the miss after solves stopped at [`CG_CONTACT_TOLERANCE`] and never after the
    /// last one. The contact set is kept. Returns whether the pressure moved.
    fn solve_pressure(
        &mut self,
        sys: &System<'_>,
        model: &Model,
        state: &State,
        dt: Real,
        budget: Budget,
    ) -> bool {
        let mut shifted = false;
        for _ in 0..budget.pressure_passes {
            if !self.air.correct_bubble(
                model,
                &state.x,
                &self.v,
                &self.per_pascal,
                &mut self.rhs,
                dt,
            ) {
                break;
            }
            self.solve_and_apply(sys, budget.tolerance);
            shifted = true;
        }
        shifted
    }

    /// The contacts once more after the pressure moved (`shifted`), and slides stopped where
    /// the last solve reversed them. The pressure passes kept the contact set while the
    /// pressure moved, and with it every contact's normal force: one held at the friction
    /// cone's edge (a rim that friction barely holds against the tent's pull) may now be
    /// outside it, one barely pressed may pull. They slide or go free and the step is solved
    /// once more. Without it the held `air-400` (1/600 s) crept: its rim slid inwards by 0.8 mm
    /// in 0.37 s, ratcheted by the pressure's few pascals from step to step, and its contact
    /// fraction flickered between 0.415 and 0.45 (the explicit integrator's stays at 0.457).
    #[allow(clippy::too_many_arguments)] // the step's pieces
    fn settle_contacts(
        &mut self,
        sys: &System<'_>,
        model: &Model,
        state: &State,
        surfaces: &[Surface],
        dt: Real,
        budget: Budget,
        shifted: bool,
    ) {
        if budget.interactive {
            // The interactive budget's single pass over the contacts and the pockets' rims,
            // whether or not the pressure moved. (Without the rims' pressures here they kept
            // those of the step's start, and `pockets-bubbles` and `pockets-merge` blew up at
            // 1/60 s.)
            let mut changed = self.recheck_contacts(state, dt);
            // Its landings are left to the end-of-step projection: where the cloth would land
            // with its whole stencil, its pressure turns as a contact's would.
            changed |= self.turn_lying(sys, true, model, state, surfaces, dt, true);
            changed |= self.air.correct_rims(
                model,
                sys.regions,
                &self.v,
                &self.per_pascal,
                &mut self.rhs,
                dt,
            );
            if changed {
                self.solve_and_apply(sys, budget.tolerance);
            }
        } else if shifted && self.recheck_contacts(state, dt) {
            // Released contacts give their neighbours' pressure its start direction back.
            self.turn_lying(sys, true, model, state, surfaces, dt, false);
            self.solve_and_apply(sys, budget.tolerance);
        }
        // A slide the last solve moved against its direction would have its friction push it
        // on: it becomes a drag-only slide and the step is solved again.
        for _ in 0..budget.passes {
            if !self.stop_reversed_slides() {
                break;
            }
            self.solve_and_apply(sys, budget.tolerance);
        }
    }

    /// The hands' forces from the final solution's residual (thesis 3.2 step 3), and their
    /// work.
    fn hand_forces(&mut self, state: &State, control: &mut Control, dt: Real) {
        let mut work = 0.0;
        for (g, target) in control.grabs.iter_mut().zip(&control.targets) {
            let k = g.particle;
            match target {
                Some(target) => {
                    g.force = (self.kept.av.get(k) - self.rhs.get(k)) / dt;
                    work += checks::work(g.force, state.x.get(k), *target).abs();
                }
                None => g.force = Vec3::ZERO,
            }
        }
        control.hand_work += work;
    }

    /// The move `x+ = x + dt v+`: the hands' particles to their targets, any contact the solve
    /// did not foresee resolved, the contact flags and slides carried to the next step, the
    /// moving colliders' work. Returns the largest squared distance (m^2) from
    /// `fused.reference` and the thesis bubble's volume change by its pressure force's measure
    /// (m^3).
    fn move_particles(
        &mut self,
        model: &Model,
        state: &mut State,
        control: &mut Control,
        surfaces: &[Surface],
        fused: &Fused<'_>,
        dt: Real,
    ) -> (Real, Real) {
        let Motion::Previous(prev) = &mut state.motion else {
            unreachable!("converted by the step")
        };
        let mut moved: Real = 0.0;
        let single_still = model.colliders.len() == 1 && model.moving.is_empty();
        let bubble = self.air.measures_bubble();
        let mut volume_change = 0.0;
        // The moving colliders' work on the cloth over the step, J (magnitudes summed, as the
        // explicit integrator's).
        let mut surface_work = 0.0;
        for k in 0..self.v.len() {
            let x = state.x.get(k);
            let v = self.v.get(k);
            let mut touched = false;
            if let Constraint::Normal { n: normal, u, .. }
            | Constraint::Stick { n: normal, u, .. } = self.constraints[k]
            {
                // Touching while the surface pushes.
                let lambda = self.kept.av.get(k) - self.rhs.get(k);
                touched = lambda.dot(normal) > 0.0;
                // A moving surface works on the cloth it pushes and carries: the contact's
                // impulse (N s) times the surface's velocity (m/s).
                if u != Vec3::ZERO {
                    surface_work += lambda.dot(u).abs();
                }
            }
            let mut to = x + v * dt;
            if let Constraint::Fixed(_) = self.constraints[k] {
                to = control
                    .active()
                    .find(|&(p, _)| p == k)
                    .map_or(to, |(_, t)| t);
            } else if !model.colliders.is_empty() {
                // A contact of the solve against the only (still) collider already ends on its
                // surface; anything else is checked.
                let settled = single_still
                    && matches!(
                        self.constraints[k],
                        Constraint::Stick { .. } | Constraint::Normal { .. }
                    );
                if !settled {
                    let scale = model.friction_scale.as_ref().map_or(1.0, |s| s[k]);
                    let (p, hit) = if surfaces.is_empty() {
                        contact::resolve_scaled(&model.colliders, x, to, model.radius, scale)
                    } else {
                        let (p, hit, w) =
                            resolve_surfaces(surfaces, x, to, model, k, scale, dt * dt);
                        surface_work += w;
                        (p, hit)
                    };
                    to = p;
                    touched |= hit;
                }
                if let Some(reference) = fused.reference {
                    moved = moved.max((to - reference.get(k)).length_squared());
                }
            }
            if bubble && self.regions.of(k).is_some() {
                volume_change += self.per_pascal.get(k).dot(to - x);
            }
            state.contact[k] = touched;
            state.slides[k] = match self.constraints[k] {
                Constraint::Normal { t, kinetic, .. } if touched && t != Vec3::ZERO => {
                    Slide::Kinetic(kinetic / dt)
                }
                Constraint::Normal { drag, .. } if touched => Slide::Drag(drag / dt),
                _ => Slide::None,
            };
            // The step's mean acceleration: from the velocity at its start (the bits the
            // first guess started from) to the one it ends with.
            let v0 = (x - prev.get(k)) / dt;
            state.acceleration.set(k, ((to - x) / dt - v0) / dt);
            prev.set(k, to);
        }
        std::mem::swap(prev, &mut state.x);
        control.collider_work += surface_work;
        (moved, volume_change)
    }
}

/// How much a step solves ([`SolveBudget`]): solves while the contacts change, solves that only
/// correct the bubble's pressure, and the tolerance of the final ones. The interactive budget
/// takes one solve with the contacts the step starts with (landings are resolved after the
/// step), one pressure correction and one re-check of the contacts, all to its coarse
/// tolerance.
#[derive(Clone, Copy, Debug)]
struct Budget {
    interactive: bool,
    passes: usize,
    pressure_passes: usize,
    tolerance: Real,
}

impl Budget {
    fn of(budget: SolveBudget) -> Self {
        match budget {
            SolveBudget::Interactive => Budget {
                interactive: true,
                passes: 1,
                pressure_passes: 1,
                tolerance: INTERACTIVE_TOLERANCE,
            },
            SolveBudget::Converged => Budget {
                interactive: false,
                passes: CONTACT_PASSES,
                pressure_passes: PRESSURE_PASSES,
                tolerance: CG_TOLERANCE,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A spring the strain limit put on its stiff branch during a step (`tighten`, at positions
    /// that then do not move) is linearised anew the next step, not kept: two particles of a
    /// 3 x 3 cloth whose velocities would stretch their spring 20 % past a 10 % limit.
    #[test]
    fn springs_put_on_their_stiff_branch_are_linearised_anew() {
        let mut cfg = crate::SimConfig::thesis_demo();
        cfg.cloth.resolution = [3, 3];
        cfg.cloth.strain_limit = 0.1;
        let model = Model::new(&cfg);
        let mut imp = Implicit::new(&model, SolveBudget::Converged);
        let x = model.grid().rest_positions(Vec3::ZERO);
        imp.forces(&model, &x);
        let soft = (imp.springs.right.ks[0], imp.springs.right.kd[0]);
        // Particles 0 and 1 (the first `right` spring) pulled apart at 0.3 rest lengths a step.
        let l = model.grid().rest_distance(0, 1);
        let dt = 1.0 / 600.0;
        imp.v = Soa::zeros(x.len());
        imp.v.set(0, Vec3::new(-0.15 * l / dt, 0.0, 0.0));
        imp.v.set(1, Vec3::new(0.15 * l / dt, 0.0, 0.0));
        assert!(imp.tighten(&model, &x, dt));
        assert_ne!(imp.springs.right.kd[0], soft.1, "tightened");
        imp.forces(&model, &x);
        assert_eq!((imp.springs.right.ks[0], imp.springs.right.kd[0]), soft);
    }

    /// The products `A v` taken only around the particles a solve moved have the bits of the
    /// whole product (`check_partial_product` compares every one; a step's first one carried
    /// from the last step's, `keep_product`, included), and the springs whose
    /// particles did not move keep the bits a new linearisation gives (`check_same`, on every
    /// run of every step after the first), and so does the diagonal summed again only around
    /// the moved particles (`check_diagonal`): a stiff cloth pressed flat
    /// by the vacuum and pinched up at its centre, at 1/600 s, strain-limited (springs going
    /// onto their stiff branch change the matrix, and at 2 % they do: the next step must
    /// linearise them anew), over a table and over a ball (curved contact normals), with and
    /// without friction's slides.
    #[test]
    fn partial_products_and_kept_springs_have_the_bits_of_the_whole() {
        use crate::{Collider, GrabSpec, Integrator, SimConfig, Simulation, Vec3};
        for (ball, friction, limit) in [
            (false, 0.6, 0.1),
            (false, 0.1, 0.1),
            (true, 0.6, 0.1),
            (false, 0.6, 0.02),
        ] {
            let mut cfg = SimConfig::thesis_demo();
            cfg.cloth.resolution = [20, 20];
            cfg.cloth.size = [0.12, 0.12];
            cfg.cloth.mass = 0.02 * 0.16;
            cfg.cloth.structural_stiffness = 5000.0;
            cfg.cloth.shear_stiffness = 1250.0;
            cfg.cloth.strain_limit = limit;
            cfg.cloth.self_collision = false;
            cfg.air.trapped_air = 0.0;
            cfg.simulation.integrator = Integrator::Implicit;
            cfg.simulation.time_step = 1.0 / 600.0;
            cfg.colliders = if ball {
                cfg.air.enabled = false;
                cfg.cloth.position.y = 0.1;
                vec![Collider::sphere(Vec3::ZERO, 0.08, friction)]
            } else {
                cfg.cloth.position.y = cfg.cloth.particle_radius();
                vec![Collider::plane(Vec3::ZERO, Vec3::Y, friction)]
            };
            cfg.grabs = vec![GrabSpec::lift([10, 10], 0.05, 0.5, 0.02)];
            let mut sim = Simulation::new(cfg).unwrap();
            let before = PARTIAL_PRODUCTS.with(|c| c.get());
            let kept_before = KEPT_CHECKS.with(|c| c.get());
            let products_before = KEPT_PRODUCTS.with(|c| c.get());
            sim.advance(300).unwrap();
            let carried = KEPT_PRODUCTS.with(|c| c.get()) - products_before;
            // On the ball the draped cloth keeps moving: too many rows change to keep it.
            assert!(
                ball || carried > 20,
                "ball {ball}, friction {friction}: {carried} steps kept the last product"
            );
            let kept = KEPT_CHECKS.with(|c| c.get()) - kept_before;
            assert!(
                kept > 1000,
                "ball {ball}, friction {friction}: {kept} kept runs checked"
            );
            let taken = PARTIAL_PRODUCTS.with(|c| c.get()) - before;
            assert!(
                taken > 20,
                "ball {ball}, friction {friction}: {taken} partial products"
            );
        }
    }
}
