//! Position Verlet (thesis eq. 3.1): `x(t+dt) = 2 x(t) - x(t-dt) + F/m dt^2`, with a Taylor
//! first step, in one fused pass over the rows.
//!
//! For each block of rows the pass sums the forces (gravity and damping, springs, pressure:
//! [`crate::forces`]), moves the particles, resolves their contacts (planes on a vectorised
//! row, other shapes through [`crate::collide::contact::resolve`]) and measures the cells it
//! has finished ([`crate::measure`]) while the rows are in cache; then the hand places the
//! grabbed particles and records its force (thesis 3.2 step 3). The new positions overwrite the
//! previous ones in place (Verlet needs nothing else), then the two swap.
//!
//! Every particle's result is a fixed sequence of operations on its neighbours' positions, so
//! the output is bit-identical however the rows are split between threads.

use super::Air;
use super::Fused;
use crate::air::{AirLoad, Timing};
use crate::checks;
use crate::collide::Collider;
use crate::collide::StickingPlane;
use crate::collide::contact;
use crate::collide::plane::{self, PlaneContact};
use crate::control::Control;
use crate::forces::spring::{self, RowSprings, SpringConsts};
use crate::forces::{gravity, pressure};
use crate::math::{Real, RowMut, RowRef, Soa, Vec3, row};
use crate::measure::{self, CellMeasures, LANES};
use crate::model::{Grid, Model};
use crate::params::PressureForce;
use crate::state::{Motion, State};
use rayon::prelude::*;

/// Scratch of position Verlet: the forces of the last step and the spring rows.
#[derive(Clone, Debug, Default)]
pub(crate) struct Verlet {
    /// Force on each particle during the last step (without the hand), N.
    force: Soa,
    /// Springs of the current and the previous row, for the calling thread.
    springs: RowPair,
    /// The grabbed particles' previous positions (the pass overwrites them), m.
    saved_prev: Vec<Vec3>,
    /// The cell measures of the coasting positions (for an end-of-step pressure).
    coast: measure::Measures,
    /// Each row's largest squared move from the self-collision reference, m^2.
    moved: Vec<Real>,
    /// The scratch of the general path, on a mesh cloth.
    mesh: Option<Box<super::verlet_mesh::MeshVerlet>>,
}

/// The springs of the current and the previous row, and a row of scratch.
#[derive(Clone, Debug, Default)]
struct RowPair {
    current: RowSprings,
    previous: RowSprings,
    /// A row's pressure force, N, when particles differ in mass.
    pressure: [Vec<Real>; 3],
}

impl RowPair {
    fn new(nx: usize) -> Self {
        Self {
            current: RowSprings::new(nx),
            previous: RowSprings::new(nx),
            pressure: [vec![0.0; nx], vec![0.0; nx], vec![0.0; nx]],
        }
    }

    fn fits(&self, nx: usize) -> bool {
        self.current.fits(nx)
    }
}

thread_local! {
    /// Spring rows of a pool thread, sized on first use (no allocation in later steps).
    static THREAD_SPRINGS: std::cell::RefCell<RowPair> = std::cell::RefCell::new(RowPair::default());
}

/// Constants of one step, shared by the row kernels.
struct StepConsts<'a> {
    grid: &'a Grid,
    planes: &'a [PlaneContact],
    non_planes: &'a [Collider],
    /// The moving colliders and where they are at the start and end of the step.
    moving: &'a [Collider],
    frames: &'a [contact::Frames],
    /// Summed magnitude of the moving colliders' work on the cloth during the step, pJ (an
    /// integer, so the sum does not depend on the order the threads add in).
    collider_work: &'a std::sync::atomic::AtomicU64,
    /// Summed magnitude of the pressure force's work during the step, pJ, row by row (an
    /// integer, as `collider_work`).
    air_work: &'a std::sync::atomic::AtomicU64,
    /// Whether to measure the pressure force's work: with a strain limit, whose projections
    /// let the thesis' pressure force (along each particle's normal, not the volume's
    /// gradient) do more work than `P dV` bounds; without one the audit's `P V` covers it.
    measure_air_work: bool,
    mass: Real,
    gravity: Vec3,
    /// `damping * m / dt`, kg/s^2: the damping force is `-damp * (x - x_prev)`.
    damp: Real,
    springs: SpringConsts,
    /// `P_b - P_a`, Pa, during the step, when every particle feels the same.
    pressure: Real,
    /// `(P_b - P_a) S`, N: the thesis' pressure force is this times the unit normal.
    pressure_area: Real,
    /// Each particle's pressure difference, Pa, when they differ (pockets).
    pressures: Option<&'a [Real]>,
    /// Cloth area per particle S, m^2.
    area: Real,
    /// Each particle's mass, kg, when they differ (painted wetness with water).
    masses: Option<&'a [Real]>,
    /// `dt^2` (halved on the first step), s^2: with `masses`, a force of 1 N moves particle
    /// `i` by `dt2 / m_i` over the step.
    dt2: Real,
    /// Damping rate over the step, `damping / dt`, 1/s^2: with `masses`, particle `i`'s damping
    /// force is `-m_i damping_per_dt (x - x_prev)`.
    damping_per_dt: Real,
    /// Each particle's share of the colliders' friction, when not 1 everywhere.
    friction_scale: Option<&'a [Real]>,
    /// Whether to keep each cell's gap volume in the measures.
    keep_cells: bool,
    /// How the pressure becomes forces.
    pressure_law: PressureForce,
    radius: Real,
    /// `dt^2 / m`, s^2/kg (halved on the first step: the Taylor start): a force of 1 N moves a
    /// particle by this many metres over the step.
    step_per_force: Real,
    /// Positions the self-collision lists were built at, if any (see [`step_rows`]).
    reference: Option<&'a Soa>,
    /// The sticking plane, for the volume measure.
    sticking: Option<StickingPlane>,
}

impl Verlet {
    /// Scratch for the particles of `model`: the grid's rows, or the mesh's general path.
    pub fn new(model: &Model) -> Self {
        let Some(grid) = &model.grid else {
            return Self {
                mesh: Some(Box::new(super::verlet_mesh::MeshVerlet::new(
                    model.layout(),
                    model.len(),
                ))),
                ..Self::default()
            };
        };
        let (n, nx) = (grid.len(), grid.nx);
        Self {
            force: Soa::zeros(n),
            springs: RowPair::new(nx),
            saved_prev: Vec::new(),
            coast: measure::Measures::for_grid(grid, false),
            moved: vec![0.0; n / nx],
            mesh: None,
        }
    }

    /// Heap bytes held (the pool threads' own spring rows, a few rows each, not counted).
    pub fn heap_bytes(&self) -> usize {
        self.force.heap_bytes()
            + self.springs.current.heap_bytes()
            + self.springs.previous.heap_bytes()
            + 3 * self.springs.pressure[0].capacity() * std::mem::size_of::<Real>()
            + self.saved_prev.capacity() * std::mem::size_of::<Vec3>()
            + self.coast.heap_bytes()
            + self.moved.capacity() * std::mem::size_of::<Real>()
            + self.mesh.as_ref().map_or(0, |m| m.heap_bytes())
    }

    /// One step of `dt` s: forces, position Verlet, contacts, the hand. Returns the largest
    /// squared distance (m^2) of a new position from `fused.reference` (0 without one).
    pub fn step(
        &mut self,
        model: &Model,
        state: &mut State,
        control: &mut Control,
        mut air: Air<'_>,
        dt: Real,
        fused: Fused<'_>,
    ) -> Real {
        // The path is chosen once per step: the grid's rows, or the mesh's particles.
        let grid = match model.layout() {
            crate::model::Layout::Grid(grid) => grid,
            crate::model::Layout::Mesh(mesh, springs) => {
                let scratch = self.mesh.as_mut().expect("a mesh cloth's scratch");
                return scratch.step(model, mesh, springs, state, control, air, dt, fused);
            }
        };
        state.use_previous_positions(dt);
        let mass = model.particle_mass;
        let Motion::Previous(prev) = &mut state.motion else {
            unreachable!("converted above")
        };
        self.saved_prev.clear();
        self.saved_prev
            .extend(control.grabs.iter().map(|g| prev.get(g.particle)));
        let first = if state.steps == 0 { 0.5 } else { 1.0 };
        let t = state.steps as Real * dt;
        let frames: Vec<contact::Frames> = model
            .moving
            .iter()
            .map(|c| contact::Frames::of(c, t, dt))
            .collect();
        let collider_work = std::sync::atomic::AtomicU64::new(0);
        let air_work = std::sync::atomic::AtomicU64::new(0);
        let mut consts = StepConsts {
            grid,
            planes: &model.planes,
            non_planes: &model.non_planes,
            moving: &model.moving,
            frames: &frames,
            collider_work: &collider_work,
            air_work: &air_work,
            measure_air_work: model.strain_limit > 0.0,
            mass,
            gravity: model.gravity,
            damp: model.damping * mass / dt,
            springs: model.springs,
            pressure: 0.0,
            pressure_area: 0.0,
            pressures: None,
            area: model.area_per_particle,
            masses: model.masses.as_deref(),
            dt2: dt * dt * first,
            damping_per_dt: model.damping / dt,
            friction_scale: model.friction_scale.as_deref(),
            keep_cells: fused.measures.keep_cells,
            pressure_law: model.pressure_force,
            radius: model.radius,
            step_per_force: dt * dt / mass * first,
            reference: fused.reference,
            sticking: model.sticking,
        };
        let nx = grid.nx;
        let x = &state.x;
        let rows = fused.rows_per_task;
        let mut blocks = Blocks {
            nx,
            rows,
            moved: &mut self.moved,
            force: &mut self.force,
            contact: &mut state.contact,
            measures: &mut fused.measures.rows,
            cells: &mut fused.measures.cells,
            springs: &mut self.springs,
        };
        let prev: &mut Soa = prev;
        fn set_load<'a>(consts: &mut StepConsts<'a>, load: AirLoad<'a>, area: Real) {
            match load {
                AirLoad::Uniform(pressure) => {
                    consts.pressure = pressure;
                    consts.pressure_area = pressure * area;
                }
                AirLoad::PerParticle(p) => {
                    // Any non-zero value marks that the pressure acts; each particle's is in `p`.
                    consts.pressure = if p.iter().any(|&d| d != 0.0) {
                        1.0
                    } else {
                        0.0
                    };
                    consts.pressures = Some(p);
                }
            }
        }
        match air.timing {
            Timing::Now => {
                // Forces, Verlet and contacts in one pass over the rows.
                set_load(
                    &mut consts,
                    air.model.load(air.params),
                    model.area_per_particle,
                );
                blocks.run(prev, |b, springs| step_rows(&consts, x, b, springs));
            }
            Timing::EndOfStep => {
                // Everything but the pressure first, to the coasting positions; the hands
                // carry their particles; then the pressure of the end of the step, and the
                // pressure's move and the contacts in a second pass.
                blocks.run(prev, |b, springs| coast_rows(&consts, x, b, springs));
                for (k, target) in control.active() {
                    prev.set(k, target);
                }
                air.solve_at_end(
                    model,
                    prev,
                    &mut self.coast,
                    consts.keep_cells,
                    &control.held,
                    rows,
                );
                set_load(
                    &mut consts,
                    air.model.load(air.params),
                    model.area_per_particle,
                );
                blocks.run(prev, |b, scratch| finish_rows(&consts, x, b, scratch));
            }
        }
        let p = prev;
        std::mem::swap(&mut state.x, p);
        let remeasure = |measures: &mut measure::Measures, x: &Soa, j: usize| {
            measures.remeasure_row(grid, x, j, model.sticking, model.radius);
        };
        // The measures of the cell rows that straddle two blocks (see `step_rows`).
        if let Some(rows) = rows {
            for j in (rows - 1..grid.nz - 1).step_by(rows) {
                remeasure(fused.measures, &state.x, j);
            }
        }

        // The hand (thesis 3.2 step 3): cancel the particle's own motion, carry it to its
        // target, and record the force that does so: m (target - 2 x + x_prev) / dt^2 - F.
        let m_dt2 = mass / (dt * dt);
        let m_dt2_of = |k: usize| match &model.masses {
            None => m_dt2,
            Some(m) => m[k] / (dt * dt),
        };
        let mut work = 0.0;
        for (g, (target, before)) in control
            .grabs
            .iter_mut()
            .zip(control.targets.iter().zip(&self.saved_prev))
        {
            let k = g.particle;
            match target {
                Some(target) => {
                    let accel = (*target - 2.0 * p.get(k) + *before) * m_dt2_of(k);
                    g.force = accel - self.force.get(k);
                    work += checks::work(g.force, p.get(k), *target).abs();
                    state.x.set(k, *target);
                }
                None => g.force = Vec3::ZERO,
            }
        }
        control.hand_work += work;
        control.collider_work += collider_work.into_inner() as Real * 1e-12;
        control.air_work += air_work.into_inner() as Real * 1e-12;
        // The measures of the cells around the particles the hand moved.
        for (k, _) in control.active() {
            let j = k / nx;
            remeasure(fused.measures, &state.x, j.saturating_sub(1));
            remeasure(fused.measures, &state.x, j);
        }
        // How far the particles moved from the self-collision lists' reference: the rows'
        // maxima, with a hand's particle left out of its row (its position in the pass was
        // free flight, which the hand overrode; the step measures the hand's own moves).
        match fused.reference {
            Some(reference) => {
                for (k, _) in control.active() {
                    let j = k / nx;
                    let r = j * nx..(j + 1) * nx;
                    self.moved[j] = max_distance2_free(
                        row(&state.x, nx, j),
                        row(reference, nx, j),
                        &control.held[r],
                    );
                }
                self.moved.iter().copied().fold(0.0, Real::max)
            }
            None => 0.0,
        }
    }
}

/// The buffers a row pass writes, split into blocks of rows: one block per task on the pool
/// (`rows` rows each), or the whole grid on the calling thread.
struct Blocks<'a> {
    nx: usize,
    rows: Option<usize>,
    /// Each row's largest squared move from the self-collision reference, m^2.
    moved: &'a mut [Real],
    force: &'a mut Soa,
    contact: &'a mut [bool],
    measures: &'a mut [CellMeasures],
    /// Each cell's gap volume, `nx - 1` per row (written only when kept).
    cells: &'a mut [Real],
    /// Spring rows of the calling thread (pool threads keep their own).
    springs: &'a mut RowPair,
}

impl Blocks<'_> {
    /// Runs `pass` on every block of `prev` (the previous positions, new ones on exit) and the
    /// other buffers. The split never changes the result: every particle's value is a fixed
    /// sequence of operations.
    fn run<F>(&mut self, prev: &mut Soa, pass: F)
    where
        F: Fn(Block<'_, '_>, &mut RowPair) + Sync,
    {
        let nx = self.nx;
        let (p, f) = (prev, &mut *self.force);
        if let Some(rows) = self.rows {
            let block = nx * rows;
            (
                p.x.par_chunks_mut(block),
                p.y.par_chunks_mut(block),
                p.z.par_chunks_mut(block),
                f.x.par_chunks_mut(block),
                f.y.par_chunks_mut(block),
                f.z.par_chunks_mut(block),
                self.contact.par_chunks_mut(block),
                self.measures.par_chunks_mut(rows),
                self.moved.par_chunks_mut(rows),
                self.cells.par_chunks_mut((nx - 1) * rows),
            )
                .into_par_iter()
                .enumerate()
                .for_each(
                    |(b, (px, py, pz, fx, fy, fz, contact, measures, moved, cells))| {
                        THREAD_SPRINGS.with_borrow_mut(|springs| {
                            if !springs.fits(nx) {
                                *springs = RowPair::new(nx);
                            }
                            let block = Block {
                                j0: b * rows,
                                prev: &mut RowMut {
                                    x: px,
                                    y: py,
                                    z: pz,
                                },
                                force: &mut RowMut {
                                    x: fx,
                                    y: fy,
                                    z: fz,
                                },
                                contact,
                                measures,
                                moved,
                                cells,
                            };
                            pass(block, springs)
                        })
                    },
                );
        } else {
            let block = Block {
                j0: 0,
                prev: &mut RowMut {
                    x: &mut p.x,
                    y: &mut p.y,
                    z: &mut p.z,
                },
                force: &mut RowMut {
                    x: &mut f.x,
                    y: &mut f.y,
                    z: &mut f.z,
                },
                contact: self.contact,
                measures: self.measures,
                moved: self.moved,
                cells: self.cells,
            };
            pass(block, self.springs)
        }
    }
}

/// The rows of one block: its previous positions (new ones on exit), forces, contact flags,
/// cell measures and rows' moves, starting at row `j0`.
struct Block<'a, 'b> {
    j0: usize,
    prev: &'a mut RowMut<'b>,
    force: &'a mut RowMut<'b>,
    contact: &'a mut [bool],
    measures: &'a mut [CellMeasures],
    moved: &'a mut [Real],
    cells: &'a mut [Real],
}

/// Forces, position Verlet and contacts for the block of rows `b` (as many rows as `b.prev`
/// holds), in one pass. Reads the current positions of the block and one row around it.
///
/// Each spring is evaluated once: a row's springs towards the next row are kept for the next
/// row, and a block that does not start at row 0 first evaluates the row above it again. Every
/// particle adds its terms in the same fixed order whatever the blocks are, so the result does
/// not depend on how the rows are split between threads.
///
/// While the new positions are at hand it also measures them (see [`walk_rows`]) and returns
/// the largest squared distance (m^2) of a new position from `c.reference`.
fn step_rows(c: &StepConsts<'_>, x: &Soa, b: Block<'_, '_>, springs: &mut RowPair) {
    if b.j0 > 0 {
        springs.previous.compute(&c.springs, x, b.j0 - 1, false);
    }
    walk_rows(c, b, true, |j, p, f, contact| {
        springs.current.compute(&c.springs, x, j, true);
        step_row(c, j, x, p, f, contact, springs);
        std::mem::swap(&mut springs.current, &mut springs.previous);
    })
}

/// The first pass of a step with an end-of-step pressure: every force but the pressure, and
/// the Verlet move to the coasting positions (no contacts yet), for the block of rows `b`.
fn coast_rows(c: &StepConsts<'_>, x: &Soa, b: Block<'_, '_>, springs: &mut RowPair) {
    if b.j0 > 0 {
        springs.previous.compute(&c.springs, x, b.j0 - 1, false);
    }
    walk_rows(c, b, false, |j, p, f, _| {
        springs.current.compute(&c.springs, x, j, true);
        let (nx, nz) = (c.grid.nx, c.grid.nz);
        let here = row(x, nx, j);
        set_weight_and_damping(c, j, here, p.as_ref(), f);
        spring::add_row(f, &springs.current, &springs.previous, j, nx, nz);
        verlet_move(c, j, here, p, f.as_ref());
        std::mem::swap(&mut springs.current, &mut springs.previous);
    });
}

/// The second pass of a step with an end-of-step pressure: the pressure force (added to
/// `b.force`) and its move from the coasting positions in `b.prev`, then the contacts, for the
/// block of rows `b`; measures like [`step_rows`].
fn finish_rows(c: &StepConsts<'_>, x: &Soa, b: Block<'_, '_>, scratch: &mut RowPair) {
    walk_rows(c, b, true, |j, next, f, contact| {
        let here = row(x, c.grid.nx, j);
        // The pressure force, into the forces (for the hand's force) and, times h, into the
        // move.
        match c.masses {
            None => {
                add_pressure(c, j, x, f, 1.0);
                // The move before the pressure is kept, so that the pressure's work can be
                // measured from what it added to it.
                let measure = c.pressure != 0.0 && c.measure_air_work;
                if measure {
                    keep_row(&mut scratch.pressure, next.as_ref());
                }
                add_pressure(c, j, x, next, c.step_per_force);
                if measure {
                    // The pressure's move, as a force: what it added over dt^2 / m.
                    added(&mut scratch.pressure, next.as_ref(), c.step_per_force);
                }
            }
            Some(m) => {
                // The pressure force alone in the row scratch, then into the forces and, times
                // each particle's own dt^2 / m, into the move.
                let nx = c.grid.nx;
                let [tx, ty, tz] = &mut scratch.pressure;
                for v in [&mut *tx, &mut *ty, &mut *tz] {
                    v[..nx].fill(0.0);
                }
                let mut t = RowMut {
                    x: &mut tx[..nx],
                    y: &mut ty[..nx],
                    z: &mut tz[..nx],
                };
                add_pressure(c, j, x, &mut t, 1.0);
                let m = &m[j * nx..(j + 1) * nx];
                for i in 0..nx {
                    let h = c.dt2 / m[i];
                    f.x[i] += t.x[i];
                    f.y[i] += t.y[i];
                    f.z[i] += t.z[i];
                    next.x[i] += t.x[i] * h;
                    next.y[i] += t.y[i] * h;
                    next.z[i] += t.z[i] * h;
                }
            }
        }
        contact_row(c, j, here, next, contact);
        if c.pressure != 0.0 && c.measure_air_work {
            // The pressure force is in the row scratch: its work over the whole move.
            add_air_work(c, &scratch.pressure, here, next.as_ref());
        }
    })
}

/// Walks the rows of block `b`: `row_fn(j, prev, force, contact)` on each row's slices, then,
/// if `measure`, measures the new positions while they are at hand: `b.measures[k]` receives
/// [`measure::cells`] of rows `j0 + k` and `j0 + k + 1` for the cells inside the block (the
/// last entry, whose next row belongs to the next block, is left for the caller, except on the
/// grid's last row), and `b.moved[k]` the largest squared distance (m^2) of row `j0 + k`'s new
/// positions from `c.reference` (without one, nothing): the self-collision lists' skin test.
fn walk_rows(
    c: &StepConsts<'_>,
    b: Block<'_, '_>,
    measure: bool,
    mut row_fn: impl FnMut(usize, &mut RowMut<'_>, &mut RowMut<'_>, &mut [bool]),
) {
    let nx = c.grid.nx;
    let (j0, prev, force) = (b.j0, b.prev, b.force);
    let rows = prev.x.len() / nx;
    for j in j0..j0 + rows {
        let r = (j - j0) * nx..(j - j0 + 1) * nx;
        let mut p = RowMut {
            x: &mut prev.x[r.clone()],
            y: &mut prev.y[r.clone()],
            z: &mut prev.z[r.clone()],
        };
        let mut f = RowMut {
            x: &mut force.x[r.clone()],
            y: &mut force.y[r.clone()],
            z: &mut force.z[r.clone()],
        };
        row_fn(j, &mut p, &mut f, &mut b.contact[r.clone()]);
        if !measure {
            continue;
        }
        if let Some(reference) = c.reference {
            b.moved[j - j0] = max_distance2(p.as_ref(), row(reference, nx, j));
        }
        // The cells between the previous row and this one, both new now.
        let new_row = |k: usize| RowRef {
            x: &prev.x[k * nx..(k + 1) * nx],
            y: &prev.y[k * nx..(k + 1) * nx],
            z: &prev.z[k * nx..(k + 1) * nx],
        };
        let k = j - j0;
        let m = nx - 1;
        if k > 0 {
            let cells = c.keep_cells.then(|| &mut b.cells[(k - 1) * m..k * m]);
            b.measures[k - 1] = measure::cells(
                c.grid,
                new_row(k - 1),
                Some(new_row(k)),
                c.sticking,
                c.radius,
                cells,
            );
        }
        if j + 1 == c.grid.nz {
            b.measures[k] = measure::cells(c.grid, new_row(k), None, c.sticking, c.radius, None);
        }
    }
}

/// Largest squared distance between `a[i]` and `b[i]`, m^2, over the `i` not `held`.
fn max_distance2_free(a: RowRef<'_>, b: RowRef<'_>, held: &[bool]) -> Real {
    (0..a.x.len())
        .filter(|&i| !held[i])
        .map(|i| (a.get(i) - b.get(i)).length_squared())
        .fold(0.0, Real::max)
}

/// Largest squared distance between `a[i]` and `b[i]`, m^2, with lane-wise maxima (it
/// vectorises).
#[inline(always)]
fn max_distance2(a: RowRef<'_>, b: RowRef<'_>) -> Real {
    let n = a.x.len();
    let (bx, by, bz) = (&b.x[..n], &b.y[..n], &b.z[..n]);
    let mut lanes = [0.0 as Real; LANES];
    let full = n - n % LANES;
    for base in (0..full).step_by(LANES) {
        for (l, m) in lanes.iter_mut().enumerate() {
            let i = base + l;
            let (dx, dy, dz) = (a.x[i] - bx[i], a.y[i] - by[i], a.z[i] - bz[i]);
            let d = dx * dx + dy * dy + dz * dz;
            *m = if d > *m { d } else { *m };
        }
    }
    for i in full..n {
        let (dx, dy, dz) = (a.x[i] - bx[i], a.y[i] - by[i], a.z[i] - bz[i]);
        lanes[0] = lanes[0].max(dx * dx + dy * dy + dz * dz);
    }
    lanes.into_iter().fold(0.0, Real::max)
}

/// One row of [`step_rows`], with the row's springs in `springs.current` and the previous
/// row's in `springs.previous`.
fn step_row(
    c: &StepConsts<'_>,
    j: usize,
    x: &Soa,
    prev: &mut RowMut<'_>,
    force: &mut RowMut<'_>,
    contact: &mut [bool],
    springs: &mut RowPair,
) {
    let (nx, nz) = (c.grid.nx, c.grid.nz);
    let here = row(x, nx, j);

    // Gravity (eq. 3.3) and velocity damping, then the springs (eq. 3.6).
    set_weight_and_damping(c, j, here, prev.as_ref(), force);
    spring::add_row(force, &springs.current, &springs.previous, j, nx, nz);

    // Pressure force (eq. 3.7): (P_b - P_a) S N; the forces before it are kept in the row
    // scratch, so that its work can be measured.
    let acts = c.pressure != 0.0 && c.measure_air_work;
    if acts {
        keep_row(&mut springs.pressure, force.as_ref());
    }
    add_pressure(c, j, x, force, 1.0);

    verlet_move(c, j, here, prev, force.as_ref());
    contact_row(c, j, here, prev, contact);
    if acts {
        // The pressure force is what it added to the forces.
        added(&mut springs.pressure, force.as_ref(), 1.0);
        add_air_work(c, &springs.pressure, here, prev.as_ref());
    }
}

/// Copies `row` into the scratch `keep`.
#[inline(always)]
fn keep_row(keep: &mut [Vec<Real>; 3], row: RowRef<'_>) {
    let n = row.x.len();
    keep[0][..n].copy_from_slice(row.x);
    keep[1][..n].copy_from_slice(row.y);
    keep[2][..n].copy_from_slice(row.z);
}

/// Turns the row `kept` by [`keep_row`] into what was added to it since: `(after - kept) /
/// scale` (the pressure force, N, from the forces or, with `scale = dt^2 / m`, from the move).
#[inline(always)]
fn added(kept: &mut [Vec<Real>; 3], after: RowRef<'_>, scale: Real) {
    let n = after.x.len();
    for (k, a) in kept.iter_mut().zip([after.x, after.y, after.z]) {
        for i in 0..n {
            k[i] = (a[i] - k[i]) / scale;
        }
    }
}

/// Adds the magnitude of the work of the row's pressure force `force` (N) over its move from
/// `here` to `next` to `c.air_work` (pJ).
#[inline(always)]
fn add_air_work(c: &StepConsts<'_>, force: &[Vec<Real>; 3], here: RowRef<'_>, next: RowRef<'_>) {
    let n = here.x.len();
    let mut w = 0.0;
    for i in 0..n {
        w += force[0][i] * (next.x[i] - here.x[i])
            + force[1][i] * (next.y[i] - here.y[i])
            + force[2][i] * (next.z[i] - here.z[i]);
    }
    let pj = (w.abs() * 1e12).round();
    if pj.is_finite() && pj > 0.0 {
        c.air_work
            .fetch_add(pj as u64, std::sync::atomic::Ordering::Relaxed);
    }
}

/// Starts row `j`'s forces with gravity and damping: [`gravity::set_row`] for the uniform
/// mass, particle by particle with [`StepConsts::masses`].
#[inline(always)]
fn set_weight_and_damping(
    c: &StepConsts<'_>,
    j: usize,
    here: RowRef<'_>,
    prev: RowRef<'_>,
    force: &mut RowMut<'_>,
) {
    match c.masses {
        None => gravity::set_row(force, here, prev, c.gravity * c.mass, c.damp),
        Some(m) => {
            let nx = here.x.len();
            let m = &m[j * nx..(j + 1) * nx];
            for i in 0..nx {
                let v = here.get(i) - prev.get(i);
                let f = gravity::weight_and_damping(m[i], c.gravity, c.damping_per_dt, v);
                (force.x[i], force.y[i], force.z[i]) = (f.x, f.y, f.z);
            }
        }
    }
}

/// Position Verlet for row `j` ([`verlet_row`]), with each particle's own `dt^2 / m_i` when
/// masses differ.
#[inline(always)]
fn verlet_move(
    c: &StepConsts<'_>,
    j: usize,
    here: RowRef<'_>,
    prev: &mut RowMut<'_>,
    force: RowRef<'_>,
) {
    match c.masses {
        None => verlet_row(here, prev, force, c.step_per_force),
        Some(m) => {
            let nx = here.x.len();
            let m = &m[j * nx..(j + 1) * nx];
            for i in 0..nx {
                let h = c.dt2 / m[i];
                prev.x[i] = here.x[i] + (here.x[i] - prev.x[i]) + force.x[i] * h;
                prev.y[i] = here.y[i] + (here.y[i] - prev.y[i]) + force.y[i] * h;
                prev.z[i] = here.z[i] + (here.z[i] - prev.z[i]) + force.z[i] * h;
            }
        }
    }
}

/// Adds `scale` times the pressure force (eq. 3.7, by `c.pressure_law`) on row `j` of `x` to
/// `out`; nothing when the pressure difference is 0.
#[inline(always)]
fn add_pressure(c: &StepConsts<'_>, j: usize, x: &Soa, out: &mut RowMut<'_>, scale: Real) {
    if c.pressure == 0.0 {
        return;
    }
    let (nx, nz) = (c.grid.nx, c.grid.nz);
    let here = row(x, nx, j);
    let each = c.pressures.map(|p| &p[j * nx..(j + 1) * nx]);
    match c.pressure_law {
        PressureForce::Thesis => {
            let below = row(x, nx, j.saturating_sub(1));
            let above = row(x, nx, (j + 1).min(nz - 1));
            match each {
                None => {
                    let area = if scale == 1.0 {
                        c.pressure_area
                    } else {
                        c.pressure_area * scale
                    };
                    pressure::add_row(out, here, below, above, area);
                }
                Some(p) => pressure::add_row_each(out, here, below, above, p, c.area * scale),
            }
        }
        PressureForce::Area => {
            let below = (j > 0).then(|| row(x, nx, j - 1));
            let above = (j + 1 < nz).then(|| row(x, nx, j + 1));
            match each {
                None => {
                    let p = c.pressure * scale;
                    pressure::add_row_area(out, here, below, above, |_| p);
                }
                Some(p) => pressure::add_row_area(out, here, below, above, |i| p[i] * scale),
            }
        }
    }
}

/// Position Verlet (eq. 3.1) for a row: `prev` holds `x(t - dt)` on entry and `x(t + dt)` on
/// exit, written as `x + (x - x_prev) + F h` (`h` in s^2/kg): the step is added to `x`, not
/// to `2x`, which halves the round-off for slow particles.
#[inline(always)]
fn verlet_row(here: RowRef<'_>, prev: &mut RowMut<'_>, force: RowRef<'_>, h: Real) {
    let nx = here.x.len();
    let (fx, fy, fz) = (&force.x[..nx], &force.y[..nx], &force.z[..nx]);
    let (px, py, pz) = (&mut prev.x[..nx], &mut prev.y[..nx], &mut prev.z[..nx]);
    for i in 0..nx {
        px[i] = here.x[i] + (here.x[i] - px[i]) + fx[i] * h;
        py[i] = here.y[i] + (here.y[i] - py[i]) + fy[i] * h;
        pz[i] = here.z[i] + (here.z[i] - pz[i]) + fz[i] * h;
    }
}

/// Contacts of a row moving from `here` to `next`: normal force and Coulomb friction
/// (eq. 3.4-3.5, see `collide::contact`), planes on the vectorised row, other shapes one
/// particle at a time; `contact` flags the particles that touched.
#[inline(always)]
fn contact_row(
    c: &StepConsts<'_>,
    j: usize,
    here: RowRef<'_>,
    next: &mut RowMut<'_>,
    contact: &mut [bool],
) {
    let nx = here.x.len();
    contact[..nx].fill(false);
    let scale = c.friction_scale.map(|s| &s[j * nx..(j + 1) * nx]);
    for p in c.planes {
        plane::contact_row_scaled(p, here, next, &mut contact[..nx], scale);
    }
    if !c.non_planes.is_empty() {
        for i in 0..nx {
            let now = here.get(i);
            let to = Vec3::new(next.x[i], next.y[i], next.z[i]);
            let f = scale.map_or(1.0, |s| s[i]);
            let (to, hit) = contact::resolve_scaled(c.non_planes, now, to, c.radius, f);
            (next.x[i], next.y[i], next.z[i]) = (to.x, to.y, to.z);
            contact[i] |= hit;
        }
    }
    if !c.moving.is_empty() {
        let mut work = 0.0;
        for i in 0..nx {
            let now = here.get(i);
            let mut to = Vec3::new(next.x[i], next.y[i], next.z[i]);
            let f = scale.map_or(1.0, |s| s[i]);
            let mass = c.masses.map_or(c.mass, |m| m[j * nx + i]);
            for (col, frames) in c.moving.iter().zip(c.frames) {
                let (moved, hit, w) =
                    contact::resolve_moving(col, frames, now, to, c.radius, f, mass, c.dt2);
                to = moved;
                contact[i] |= hit;
                work += w.abs();
            }
            (next.x[i], next.y[i], next.z[i]) = (to.x, to.y, to.z);
        }
        // Rounded to the picojoule: far below any energy the audit compares it with.
        let pj = (work * 1e12).round() as u64;
        c.collider_work
            .fetch_add(pj, std::sync::atomic::Ordering::Relaxed);
    }
}
