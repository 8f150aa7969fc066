//! The simulation and its step (thesis 3.2, fig. 3.4).

use crate::air;
use crate::cloth::Grid;
use crate::collider::Collider;
use crate::contact;
use crate::error::{ConfigError, StepError};
use crate::forces::RowMut;
use crate::grab::{Grab, GrabMotion};
use crate::kernels::{self, PlaneContact, RowCheck, StepConsts, StepScratch};
use crate::math::{Real, Soa, Vec3};
use crate::metrics::FrameMetrics;
use crate::params::{PressureSolve, SimConfig};
use crate::self_collision::SelfCollision;
use crate::strain;
use rayon::prelude::*;

/// A structural spring longer than this many rest lengths means the run has blown up: cloth
/// tears long before, while strong suction legitimately stretches springs by tens of percent.
pub const BLOWUP_STRETCH: Real = 10.0;

/// Fewest rows handed to one parallel task. Results never depend on how rows are split (every
/// particle's sum has a fixed order).
const MIN_ROWS_PER_TASK: usize = 4;

pub use crate::exec::{PARALLEL_MIN_PARTICLES, PARALLEL_MIN_PARTICLES_IN_POOL};

/// A wet cloth on its colliders, with trapped air and grabs.
///
/// Holds the static description (grid, parameters) and the state (positions at this and the
/// previous step, as position Verlet needs). [`Simulation::step`] advances by one time step.
#[derive(Clone, Debug)]
pub struct Simulation {
    config: SimConfig,
    grid: Grid,
    /// Mass of one particle, kg.
    mass: Real,
    /// Cloth area per particle S, m^2 (rest area / particle count, thesis 3.4).
    area_per_particle: Real,
    /// Rest area of the whole cloth, m^2.
    cloth_area: Real,
    radius: Real,
    sticking: Option<(Vec3, Vec3)>,
    air_enabled: bool,
    /// Positions at the current step, m.
    x: Soa,
    /// Positions at the previous step, m.
    prev: Soa,
    /// Force on each particle during the last step (without the hand), N.
    force: Soa,
    contact: Vec<bool>,
    fixed: Vec<bool>,
    grabs: Vec<Grab>,
    targets: Vec<Option<Vec3>>,
    saved_prev: Vec<Vec3>,
    self_collision: Option<SelfCollision>,
    scratch: Soa,
    row_checks: Vec<RowCheck>,
    /// Trapped air v0 now (m^3 at atmospheric pressure): the scene's value, changed by leaks.
    trapped_air: Real,
    /// Border particles in order around the cloth (for the leak's open length).
    border: Vec<u32>,
    step_scratch: StepScratch,
    planes: Vec<PlaneContact>,
    others: Vec<Collider>,
    volume: Real,
    /// Bubble volume one step earlier, m^3 (for the implicit pressure's prediction).
    prev_volume: Real,
    /// The bubble pressure the last step's pressure force used, Pa.
    applied_pressure: Real,
    steps: u64,
}

impl Simulation {
    /// Builds a simulation at t = 0 from a validated configuration.
    pub fn new(config: SimConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let grid = Grid::new(&config.cloth);
        let n = grid.len();
        let x = grid.rest_positions(config.cloth.position);
        let cloth_area = config.cloth.size[0] * config.cloth.size[1];
        let radius = config.cloth.particle_radius();
        let grabs = config
            .grabs
            .iter()
            .map(|g| {
                Grab::new(
                    grid.index(g.particle[0], g.particle[1]),
                    GrabMotion::Path(g.clone()),
                )
            })
            .collect();
        let self_collision = config
            .cloth
            .self_collision
            .then(|| SelfCollision::new(n, 2.0 * radius));
        let mut sim = Self {
            mass: config.cloth.mass / n as Real,
            area_per_particle: cloth_area / n as Real,
            cloth_area,
            radius,
            sticking: config.sticking_plane(),
            air_enabled: config.air.enabled,
            prev: x.clone(),
            x,
            force: Soa::zeros(n),
            contact: vec![false; n],
            fixed: vec![false; n],
            grabs,
            targets: Vec::new(),
            saved_prev: Vec::new(),
            self_collision,
            scratch: Soa::zeros(n),
            row_checks: vec![RowCheck::default(); grid.nz],
            trapped_air: config.air.trapped_air,
            border: border_loop(&grid),
            step_scratch: StepScratch::new(grid.nx),
            planes: config
                .colliders
                .iter()
                .filter_map(|c| {
                    c.as_plane().map(|(point, normal)| PlaneContact {
                        normal,
                        offset: normal.dot(point) + radius,
                        friction: c.friction,
                    })
                })
                .collect(),
            others: config
                .colliders
                .iter()
                .filter(|c| c.as_plane().is_none())
                .copied()
                .collect(),
            volume: 0.0,
            prev_volume: 0.0,
            applied_pressure: 0.0,
            steps: 0,
            grid,
            config,
        };
        sim.update_air_and_check()
            .map_err(|e| ConfigError::Invalid {
                key: "cloth.position".into(),
                message: e.to_string(),
            })?;
        sim.prev_volume = sim.volume;
        sim.applied_pressure = sim.air_pressure();
        Ok(sim)
    }

    /// The configuration the simulation was built from.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// The particle grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Particle positions at the current time, m (structure of arrays).
    pub fn positions(&self) -> &Soa {
        &self.x
    }

    /// Particle positions at the previous step, m.
    pub fn previous_positions(&self) -> &Soa {
        &self.prev
    }

    /// Mass of one particle, kg.
    pub fn particle_mass(&self) -> Real {
        self.mass
    }

    /// Radius of a particle's collision sphere, m.
    pub fn particle_radius(&self) -> Real {
        self.radius
    }

    /// Cloth area per particle S, m^2.
    pub fn area_per_particle(&self) -> Real {
        self.area_per_particle
    }

    /// Simulated time, s.
    pub fn time(&self) -> Real {
        self.steps as Real * self.config.simulation.time_step
    }

    /// Steps taken since t = 0.
    pub fn step_count(&self) -> u64 {
        self.steps
    }

    /// The time step, s.
    pub fn time_step(&self) -> Real {
        self.config.simulation.time_step
    }

    /// Bubble volume (eq. 3.10) of the current state, m^3; 0 without a sticking plane.
    pub fn air_volume(&self) -> Real {
        self.volume
    }

    /// Bubble pressure P_b by Boyle's law, Pa. With the air force off the cloth is treated as
    /// permeable, and the pressure under it is atmospheric.
    pub fn air_pressure(&self) -> Real {
        let a = &self.config.air;
        if self.air_enabled {
            air::boyle_pressure(
                a.atmospheric_pressure,
                self.trapped_air,
                self.volume,
                self.cloth_area,
            )
        } else {
            a.atmospheric_pressure
        }
    }

    /// Trapped air now, m^3 at atmospheric pressure: the scene's `trapped_air` plus what has
    /// leaked in since (see `AirParams::leak_conductance`).
    pub fn trapped_air(&self) -> Real {
        self.trapped_air
    }

    /// Length of the cloth's border lifted off every collider during the last step, m: a border
    /// edge counts fully when neither of its particles touched anything, and half when one of
    /// them did (the gap opens somewhere along it).
    pub fn open_border_length(&self) -> Real {
        let n = self.border.len();
        (0..n)
            .map(|e| {
                let (a, b) = (self.border[e] as usize, self.border[(e + 1) % n] as usize);
                let lifted = u8::from(!self.contact[a]) + u8::from(!self.contact[b]);
                0.5 * Real::from(lifted) * self.grid.rest_distance(a, b)
            })
            .sum()
    }

    /// Whether the pressure force acts.
    pub fn air_enabled(&self) -> bool {
        self.air_enabled
    }

    /// Turns the pressure force on or off (the demo's button 1). Turning it on needs a sticking
    /// plane; without one the call is ignored and returns false.
    pub fn set_air_enabled(&mut self, on: bool) -> bool {
        self.air_enabled = on && self.sticking.is_some();
        self.air_enabled == on
    }

    /// Whether particle `k` touched a collider during the last step.
    pub fn in_contact(&self, k: usize) -> bool {
        self.contact[k]
    }

    /// The grabs.
    pub fn grabs(&self) -> &[Grab] {
        &self.grabs
    }

    /// Adds a grab; returns its index.
    pub fn add_grab(&mut self, grab: Grab) -> usize {
        self.grabs.push(grab);
        self.grabs.len() - 1
    }

    /// Removes grab `index` (the particle is released with its current velocity).
    pub fn remove_grab(&mut self, index: usize) -> Grab {
        let g = self.grabs.remove(index);
        self.fixed[g.particle] = false;
        g
    }

    /// Mutable access to grab `index` (to move an interactive target).
    pub fn grab_mut(&mut self, index: usize) -> &mut Grab {
        &mut self.grabs[index]
    }

    /// Summed force of all grabs on the cloth during the last step, N.
    pub fn grab_force(&self) -> Vec3 {
        self.grabs.iter().map(|g| g.force).sum()
    }

    /// Heap memory the simulation holds, bytes: particle state, forces, flags, scratch and the
    /// self-collision lists (the thread pool's own per-thread spring scratch, a few rows, is
    /// not counted).
    pub fn memory_bytes(&self) -> usize {
        let n = self.grid.len();
        self.x.heap_bytes()
            + self.prev.heap_bytes()
            + self.force.heap_bytes()
            + self.scratch.heap_bytes()
            + 2 * n // contact and fixed flags
            + self.row_checks.capacity() * std::mem::size_of::<RowCheck>()
            + self.border.capacity() * 4
            + self.step_scratch.heap_bytes()
            + self.self_collision.as_ref().map_or(0, SelfCollision::heap_bytes)
    }

    /// Number of self-collision neighbour-list rebuilds so far.
    pub fn self_collision_rebuilds(&self) -> u64 {
        self.self_collision.as_ref().map_or(0, |s| s.rebuilds)
    }

    /// Replaces the particle positions (m) at the current and the previous step, e.g. to start
    /// from a draped or folded shape; the velocity is `(positions - previous) / dt`. Both must
    /// have one entry per particle.
    pub fn set_state(&mut self, positions: Soa, previous: Soa) -> Result<(), StepError> {
        assert_eq!(
            positions.len(),
            self.grid.len(),
            "one position per particle"
        );
        assert_eq!(
            previous.len(),
            self.grid.len(),
            "one previous position per particle"
        );
        self.x = positions;
        self.prev = previous;
        if let Some(sc) = &mut self.self_collision {
            *sc = SelfCollision::new(self.grid.len(), 2.0 * self.radius);
        }
        self.update_air_and_check()?;
        self.prev_volume = self.volume;
        Ok(())
    }

    /// The bubble pressure the last step's pressure force used, Pa: Boyle's law at the start of
    /// the step ([`PressureSolve::Explicit`]) or the predicted end-of-step pressure
    /// ([`PressureSolve::Implicit`]); [`Simulation::air_pressure`] is Boyle's law on the current
    /// state.
    pub fn applied_pressure(&self) -> Real {
        self.applied_pressure
    }

    /// The bubble pressure this step's pressure force uses, Pa (see [`PressureSolve`]).
    fn step_pressure(&self, dt: Real) -> Real {
        let a = &self.config.air;
        let k = a.atmospheric_pressure * self.trapped_air;
        if a.pressure_solve == PressureSolve::Explicit || k == 0.0 {
            return self.air_pressure();
        }
        // The bubble as a single degree of freedom: over one Verlet step a pressure P moves
        // every particle not held by a contact by h (P - P_a) S along its normal (h = dt^2/m,
        // halved on the Taylor first step), which changes the volume by c (P - P_a) with
        // c = h S^2 n_free. Inertia (damped), gravity and that term predict the volume at the
        // end of the step; P solves P * v(P) = K = P_a v0:
        //   c P^2 + a0 P - K = 0,  a0 = v_coast - c P_a,
        // whose positive root, written without cancellation, is 2K / (a0 + sqrt(a0^2 + 4cK)).
        let first = self.steps == 0;
        let h = dt * dt / self.mass * if first { 0.5 } else { 1.0 };
        let s = self.area_per_particle;
        let held = self
            .contact
            .iter()
            .zip(&self.fixed)
            .filter(|(c, f)| **c || **f)
            .count();
        let free = (self.grid.len() - held) as Real;
        let c = h * s * s * free;
        let up = self.sticking.map_or(Vec3::Y, |(_, n)| n);
        let keep = (1.0 - self.config.cloth.damping * dt).max(0.0);
        let gravity = h * self.mass * self.config.simulation.gravity.dot(up) * s * free;
        let coast = self.volume + keep * (self.volume - self.prev_volume) + gravity;
        let a0 = coast - c * a.atmospheric_pressure;
        let root = (a0 * a0 + 4.0 * c * k).sqrt();
        if a0 + root > 0.0 {
            2.0 * k / (a0 + root)
        } else {
            self.air_pressure()
        }
    }

    /// Resets to the state at t = 0 (the demo's button 3), keeping the air switch.
    pub fn reset(&mut self) -> Result<(), ConfigError> {
        let air = self.air_enabled;
        *self = Self::new(self.config.clone())?;
        self.set_air_enabled(air);
        Ok(())
    }

    /// Per-frame metrics of the current state (the `metrics.csv` columns).
    pub fn metrics(&self) -> FrameMetrics {
        FrameMetrics::measure(self)
    }

    /// Advances by one time step (thesis fig. 3.4):
    ///
    /// 1. read the grabs' targets for `t + dt` (the user's input, 3.2 step 1);
    /// 2. sum the forces on every particle: gravity (eq. 3.3), springs (eq. 3.6), damping, and
    ///    the pressure force `(P_b - P_a) S N` (eq. 3.7, physical sign) with `P_b` from Boyle's
    ///    law on the current bubble volume (3.4-3.5);
    /// 3. integrate with position Verlet (eq. 3.1) and resolve contacts with the colliders:
    ///    (the first step is the Taylor start `x1 = x0 + v0 dt + a dt^2 / 2`, with `v0 dt` given
    ///    by `x0 - x_prev`, which makes the scheme exact for constant acceleration);
    ///    normal force and Coulomb friction (eq. 3.4-3.5), all in one pass over the rows;
    /// 4. move grabbed particles onto their targets and record the hand's force (3.2 step 3);
    /// 5. optional Provot strain limiting, then self-collision (3.1), then push anything those
    ///    corrections moved back out of the colliders;
    /// 6. measure the new bubble volume (eq. 3.10) and check the state for a blow-up (in the
    ///    pass of phases 2-3 where nothing moved the particles afterwards).
    pub fn step(&mut self) -> Result<(), StepError> {
        let dt = self.config.simulation.time_step;
        let t_next = (self.steps + 1) as Real * dt;

        // 1. Grab targets.
        self.targets.clear();
        self.saved_prev.clear();
        for g in &mut self.grabs {
            self.fixed[g.particle] = false;
        }
        for g in &mut self.grabs {
            let target = g.target(t_next, self.x.get(g.particle), dt);
            self.targets.push(target);
            self.saved_prev.push(self.prev.get(g.particle));
        }

        // 2-3. Forces, Verlet, contacts: one pass; x(t+dt) overwrites x(t-dt) in place.
        let c = &self.config;
        self.applied_pressure = if self.air_enabled {
            self.step_pressure(dt)
        } else {
            c.air.atmospheric_pressure
        };
        let pressure_area =
            (self.applied_pressure - c.air.atmospheric_pressure) * self.area_per_particle;
        let consts = StepConsts {
            grid: &self.grid,
            planes: &self.planes,
            others: &self.others,
            mass: self.mass,
            gravity: c.simulation.gravity,
            damp: c.cloth.damping * self.mass / dt,
            structural: c.cloth.structural_stiffness,
            shear: c.cloth.shear_stiffness,
            rest_x: self.grid.dx,
            rest_z: self.grid.dz,
            rest_diag: self.grid.dx.hypot(self.grid.dz),
            pressure_area,
            radius: self.radius,
            h: dt * dt / self.mass * if self.steps == 0 { 0.5 } else { 1.0 },
            reference: self
                .self_collision
                .as_ref()
                .and_then(SelfCollision::reference),
            sticking: self.sticking,
        };
        let nx = self.grid.nx;
        let x = &self.x;
        let parallel = self.parallel();
        let rows = self.rows_per_task();
        let (p, f) = (&mut self.prev, &mut self.force);
        let moved2 = if parallel {
            // Blocks of rows, one task each; the split never changes the result.
            let block = nx * rows;
            (
                p.x.par_chunks_mut(block),
                p.y.par_chunks_mut(block),
                p.z.par_chunks_mut(block),
                f.x.par_chunks_mut(block),
                f.y.par_chunks_mut(block),
                f.z.par_chunks_mut(block),
                self.contact.par_chunks_mut(block),
                self.row_checks.par_chunks_mut(rows),
            )
                .into_par_iter()
                .enumerate()
                .map(|(b, (px, py, pz, fx, fy, fz, contact, checks))| {
                    THREAD_SCRATCH.with_borrow_mut(|scratch| {
                        if !scratch.fits(nx) {
                            *scratch = StepScratch::new(nx);
                        }
                        let mut prev = RowMut {
                            x: px,
                            y: py,
                            z: pz,
                        };
                        let mut force = RowMut {
                            x: fx,
                            y: fy,
                            z: fz,
                        };
                        let j0 = b * rows;
                        kernels::step_rows(
                            &consts, j0, x, &mut prev, &mut force, contact, checks, scratch,
                        )
                    })
                })
                .reduce(|| 0.0, Real::max)
        } else {
            let mut prev = RowMut {
                x: &mut p.x,
                y: &mut p.y,
                z: &mut p.z,
            };
            let mut force = RowMut {
                x: &mut f.x,
                y: &mut f.y,
                z: &mut f.z,
            };
            let scratch = &mut self.step_scratch;
            kernels::step_rows(
                &consts,
                0,
                x,
                &mut prev,
                &mut force,
                &mut self.contact,
                &mut self.row_checks,
                scratch,
            )
        };
        std::mem::swap(&mut self.x, &mut self.prev);
        // The checks of the cell rows that straddle two blocks (see `kernels::step_rows`).
        if parallel {
            for j in (rows - 1..self.grid.nz - 1).step_by(rows) {
                self.recheck_row(j);
            }
        }

        // Air leaking in (or out) where the border is lifted off the surface, at the pressure of
        // the step's start (explicit Euler on the amount of air).
        let a = &self.config.air;
        if self.air_enabled && a.leak_conductance > 0.0 && a.atmospheric_pressure > 0.0 {
            let pa = a.atmospheric_pressure;
            let flow =
                a.leak_conductance * self.open_border_length() * (pa - self.air_pressure()) / pa;
            self.trapped_air = (self.trapped_air + flow * dt).max(0.0);
        }

        // 4. Grabs: cancel the particle's own motion, carry it to its target, and record the
        // force of the hand that does so.
        let m_dt2 = self.mass / (dt * dt);
        for (g, (target, before)) in self
            .grabs
            .iter_mut()
            .zip(self.targets.iter().zip(&self.saved_prev))
        {
            let k = g.particle;
            match target {
                Some(target) => {
                    let accel = (*target - 2.0 * self.prev.get(k) + *before) * m_dt2;
                    g.force = accel - self.force.get(k);
                    self.x.set(k, *target);
                    self.fixed[k] = true;
                }
                None => g.force = Vec3::ZERO,
            }
        }
        // The checks of the cells around the particles the grabs moved.
        for i in 0..self.grabs.len() {
            if self.targets[i].is_some() {
                let j = self.grabs[i].particle / self.grid.nx;
                self.recheck_row(j.saturating_sub(1));
                self.recheck_row(j);
            }
        }

        // 5. Position corrections. How far the particles moved from where the self-collision
        // lists were built: measured in the main pass, plus the grabbed particles' moves.
        let mut moved2 = moved2;
        if let Some(r) = self
            .self_collision
            .as_ref()
            .and_then(SelfCollision::reference)
        {
            for g in &self.grabs {
                moved2 = moved2.max((self.x.get(g.particle) - r.get(g.particle)).length_squared());
            }
        }
        let mut corrected = false;
        let cloth = &self.config.cloth;
        if cloth.strain_limit > 0.0 {
            corrected |= strain::limit_strain(
                &self.grid,
                &mut self.x,
                &mut self.scratch,
                &self.fixed,
                cloth.strain_limit,
                cloth.strain_limit_iterations,
            ) > 0;
        }
        if let Some(sc) = &mut self.self_collision {
            // Strain limiting moves particles after the main pass: then measure again.
            let moved = (!corrected).then_some(moved2);
            corrected |= sc.solve_moved(&self.grid, &mut self.x, &self.fixed, moved) > 0;
        }
        if corrected && !self.config.colliders.is_empty() {
            let (colliders, r, fixed) = (&self.config.colliders, self.radius, &self.fixed);
            crate::exec::map_in_place(&mut self.x, |k, p| {
                if fixed[k] {
                    p
                } else {
                    contact::project(colliders, p, r)
                }
            });
        }

        self.steps += 1;
        // 6. Bubble volume and blow-up check: measured in the main pass unless a correction
        // moved particles since.
        if corrected {
            self.recheck_all();
        }
        self.finish_checks()
    }

    /// Recomputes the bubble volume of the current state and checks for non-finite positions
    /// and over-stretched structural springs, in one pass over the rows.
    fn update_air_and_check(&mut self) -> Result<(), StepError> {
        self.recheck_all();
        self.finish_checks()
    }

    /// Recomputes the check of the cells between row `j` and the next (or of the last row).
    fn recheck_row(&mut self, j: usize) {
        self.row_checks[j] = kernels::check_row(&self.grid, &self.x, j, self.sticking, self.radius);
    }

    /// Recomputes every row's check from the current positions.
    fn recheck_all(&mut self) {
        let parallel = self.parallel();
        let (grid, x, sticking, offset) = (&self.grid, &self.x, self.sticking, self.radius);
        let check = |(j, out): (usize, &mut RowCheck)| {
            *out = kernels::check_row(grid, x, j, sticking, offset);
        };
        if parallel {
            let rows = self.rows_per_task();
            self.row_checks
                .par_iter_mut()
                .enumerate()
                .with_min_len(rows)
                .for_each(check);
        } else {
            self.row_checks.iter_mut().enumerate().for_each(check);
        }
    }

    /// Sums the rows' checks: the new bubble volume, and an error if the state blew up.
    fn finish_checks(&mut self) -> Result<(), StepError> {
        let time = self.time();
        let mut worst: Real = 0.0;
        for r in &self.row_checks {
            if !r.finite_probe.is_finite() || r.stretch2.is_nan() {
                return Err(StepError::NonFinite { time });
            }
            worst = worst.max(r.stretch2);
        }
        if worst > BLOWUP_STRETCH * BLOWUP_STRETCH {
            return Err(StepError::OverStretch {
                time,
                ratio: worst.sqrt(),
                limit: BLOWUP_STRETCH,
            });
        }
        self.prev_volume = self.volume;
        self.volume = self.row_checks.iter().map(|r| r.volume).sum();
        Ok(())
    }

    /// Whether the row passes go to the thread pool (results are identical either way).
    fn parallel(&self) -> bool {
        crate::exec::use_pool(self.grid.len())
    }

    /// Rows per parallel task: one block of rows per thread, at least [`MIN_ROWS_PER_TASK`].
    /// Every block recomputes the springs of the row above it and leaves one row of cells to
    /// check after the join, so fewer, larger blocks do less extra work; on a quiet machine
    /// that measured 3 % faster than two blocks per thread at 50 x 50 and 100 x 100.
    fn rows_per_task(&self) -> usize {
        let tasks = rayon::current_num_threads();
        self.grid.nz.div_ceil(tasks).max(MIN_ROWS_PER_TASK)
    }

    /// Takes `steps` steps (see [`Simulation::step`]), on the thread pool when the cloth is big
    /// enough to share out: the whole loop runs inside the pool, so each step's parallel passes
    /// cost tens of nanoseconds to start instead of microseconds. Stops at the first error.
    pub fn advance(&mut self, steps: u64) -> Result<(), StepError> {
        let pooled = rayon::current_num_threads() > 1
            && rayon::current_thread_index().is_none()
            && self.grid.len() >= PARALLEL_MIN_PARTICLES_IN_POOL;
        let run = |sim: &mut Self| (0..steps).try_for_each(|_| sim.step());
        if pooled {
            rayon::scope(|_| run(self))
        } else {
            run(self)
        }
    }
}

thread_local! {
    /// Spring scratch of a pool thread, sized on first use (no allocation in later steps).
    static THREAD_SCRATCH: std::cell::RefCell<StepScratch> =
        std::cell::RefCell::new(StepScratch::default());
}

/// The border particles of `grid` in order around it (each once).
fn border_loop(grid: &Grid) -> Vec<u32> {
    let (nx, nz) = (grid.nx, grid.nz);
    let mut b = Vec::with_capacity(2 * (nx + nz));
    b.extend((0..nx).map(|i| grid.index(i, 0)));
    b.extend((1..nz).map(|j| grid.index(nx - 1, j)));
    b.extend((0..nx - 1).rev().map(|i| grid.index(i, nz - 1)));
    b.extend((1..nz - 1).rev().map(|j| grid.index(0, j)));
    b.into_iter().map(|k| k as u32).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Memory grows linearly with the particle count, at under 256 bytes a particle (so a
    /// million-particle cloth fits in a quarter of a gigabyte).
    #[test]
    fn memory_per_particle_is_small_and_constant() {
        let per_particle = |side: usize| {
            let mut sim = Simulation::new(crate::bench::thesis_workload(side)).unwrap();
            sim.advance(3).unwrap();
            sim.memory_bytes() as f64 / (side * side) as f64
        };
        let (small, large) = (per_particle(40), per_particle(160));
        assert!(large < 256.0, "{large} bytes per particle");
        assert!((small - large).abs() < 0.25 * large, "{small} vs {large}");
    }
}
