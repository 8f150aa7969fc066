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

use super::Fused;
use crate::air::AirLoad;
use crate::air::gap::StickingPlane;
use crate::collide::Collider;
use crate::collide::contact;
use crate::collide::plane::{self, PlaneContact};
use crate::control::Control;
use crate::forces::spring::{self, RowSprings, SpringConsts};
use crate::forces::{gravity, pressure};
use crate::math::{Real, RowMut, RowRef, Soa, Vec3, row};
use crate::measure::{self, CellMeasures, LANES};
use crate::model::{Grid, Model};
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
}

/// The springs of the current and the previous row.
#[derive(Clone, Debug, Default)]
struct RowPair {
    current: RowSprings,
    previous: RowSprings,
}

impl RowPair {
    fn new(nx: usize) -> Self {
        Self {
            current: RowSprings::new(nx),
            previous: RowSprings::new(nx),
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
    mass: Real,
    gravity: Vec3,
    /// `damping * m / dt`, kg/s^2: the damping force is `-damp * (x - x_prev)`.
    damp: Real,
    springs: SpringConsts,
    /// `(P_b - P_a) S`, N: the pressure force is this times the unit normal.
    pressure_area: Real,
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
    /// Scratch for `n` particles in rows of `nx`.
    pub fn new(n: usize, nx: usize) -> Self {
        Self {
            force: Soa::zeros(n),
            springs: RowPair::new(nx),
            saved_prev: Vec::new(),
        }
    }

    /// Heap bytes held (the pool threads' own spring rows, a few rows each, not counted).
    pub fn heap_bytes(&self) -> usize {
        self.force.heap_bytes()
            + self.springs.current.heap_bytes()
            + self.springs.previous.heap_bytes()
            + self.saved_prev.capacity() * std::mem::size_of::<Vec3>()
    }

    /// One step of `dt` s: forces, position Verlet, contacts, the hand. Returns the largest
    /// squared distance (m^2) of a new position from `fused.reference` (0 without one).
    pub fn step(
        &mut self,
        model: &Model,
        state: &mut State,
        control: &mut Control,
        load: AirLoad,
        dt: Real,
        fused: Fused<'_>,
    ) -> Real {
        state.use_previous_positions(dt);
        let AirLoad::Uniform(pressure_area) = load;
        let grid = &model.grid;
        let mass = model.particle_mass;
        let Motion::Previous(prev) = &mut state.motion else {
            unreachable!("converted above")
        };
        self.saved_prev.clear();
        self.saved_prev
            .extend(control.grabs.iter().map(|g| prev.get(g.particle)));
        let consts = StepConsts {
            grid,
            planes: &model.planes,
            non_planes: &model.non_planes,
            mass,
            gravity: model.gravity,
            damp: model.damping * mass / dt,
            springs: model.springs,
            pressure_area,
            radius: model.radius,
            step_per_force: dt * dt / mass * if state.steps == 0 { 0.5 } else { 1.0 },
            reference: fused.reference,
            sticking: model.sticking,
        };
        let nx = grid.nx;
        let x = &state.x;
        let (p, f) = (prev, &mut self.force);
        let moved2 = if let Some(rows) = fused.rows_per_task {
            // Blocks of rows, one task each; the split never changes the result.
            let block = nx * rows;
            (
                p.x.par_chunks_mut(block),
                p.y.par_chunks_mut(block),
                p.z.par_chunks_mut(block),
                f.x.par_chunks_mut(block),
                f.y.par_chunks_mut(block),
                f.z.par_chunks_mut(block),
                state.contact.par_chunks_mut(block),
                fused.measures.rows.par_chunks_mut(rows),
            )
                .into_par_iter()
                .enumerate()
                .map(|(b, (px, py, pz, fx, fy, fz, contact, measures))| {
                    THREAD_SPRINGS.with_borrow_mut(|springs| {
                        if !springs.fits(nx) {
                            *springs = RowPair::new(nx);
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
                        let block = Block {
                            j0: b * rows,
                            prev: &mut prev,
                            force: &mut force,
                            contact,
                            measures,
                        };
                        step_rows(&consts, x, block, springs)
                    })
                })
                .reduce(|| 0.0, Real::max)
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
                contact: &mut state.contact,
                measures: &mut fused.measures.rows,
            };
            step_rows(&consts, x, block, &mut self.springs)
        };
        std::mem::swap(&mut state.x, p);
        let remeasure = |measures: &mut measure::Measures, x: &Soa, j: usize| {
            measures.remeasure_row(grid, x, j, model.sticking, model.radius);
        };
        // The measures of the cell rows that straddle two blocks (see `step_rows`).
        if let Some(rows) = fused.rows_per_task {
            for j in (rows - 1..grid.nz - 1).step_by(rows) {
                remeasure(fused.measures, &state.x, j);
            }
        }

        // The hand (thesis 3.2 step 3): cancel the particle's own motion, carry it to its
        // target, and record the force that does so: m (target - 2 x + x_prev) / dt^2 - F.
        let m_dt2 = mass / (dt * dt);
        for (g, (target, before)) in control
            .grabs
            .iter_mut()
            .zip(control.targets.iter().zip(&self.saved_prev))
        {
            let k = g.particle;
            match target {
                Some(target) => {
                    let accel = (*target - 2.0 * p.get(k) + *before) * m_dt2;
                    g.force = accel - self.force.get(k);
                    state.x.set(k, *target);
                }
                None => g.force = Vec3::ZERO,
            }
        }
        control.hold_targets();
        // The measures of the cells around the particles the hand moved.
        for (k, _) in control.active() {
            let j = k / nx;
            remeasure(fused.measures, &state.x, j.saturating_sub(1));
            remeasure(fused.measures, &state.x, j);
        }
        moved2
    }
}

/// The rows of one block: its previous positions (new ones on exit), forces, contact flags and
/// cell measures, starting at row `j0`.
struct Block<'a, 'b> {
    j0: usize,
    prev: &'a mut RowMut<'b>,
    force: &'a mut RowMut<'b>,
    contact: &'a mut [bool],
    measures: &'a mut [CellMeasures],
}

/// Forces, position Verlet and contacts for the block of rows `b` (as many rows as `b.prev`
/// holds). Reads the current positions of the block and one row around it.
///
/// Each spring is evaluated once: a row's springs towards the next row are kept for the next
/// row, and a block that does not start at row 0 first evaluates the row above it again. Every
/// particle adds its terms in the same fixed order whatever the blocks are, so the result does
/// not depend on how the rows are split between threads.
///
/// While the new positions are at hand it also measures them: `b.measures[k]` receives
/// [`measure::cells`] of rows `j0 + k` and `j0 + k + 1` for the cells inside the block (the
/// last entry, whose next row belongs to the next block, is left for the caller, except on the
/// grid's last row), and the return value is the largest squared distance (m^2) of a new
/// position from `c.reference` (0 without one): the self-collision lists' skin test.
fn step_rows(c: &StepConsts<'_>, x: &Soa, b: Block<'_, '_>, springs: &mut RowPair) -> Real {
    let mut moved: Real = 0.0;
    let nx = c.grid.nx;
    let (j0, prev, force) = (b.j0, b.prev, b.force);
    let rows = prev.x.len() / nx;
    if j0 > 0 {
        springs.previous.compute(&c.springs, x, j0 - 1, false);
    }
    for j in j0..j0 + rows {
        springs.current.compute(&c.springs, x, j, true);
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
        step_row(c, j, x, &mut p, &mut f, &mut b.contact[r], springs);
        if let Some(reference) = c.reference {
            moved = moved.max(max_distance2(p.as_ref(), row(reference, nx, j)));
        }
        std::mem::swap(&mut springs.current, &mut springs.previous);
        // The cells between the previous row and this one, both new now.
        let new_row = |k: usize| RowRef {
            x: &prev.x[k * nx..(k + 1) * nx],
            y: &prev.y[k * nx..(k + 1) * nx],
            z: &prev.z[k * nx..(k + 1) * nx],
        };
        let k = j - j0;
        if k > 0 {
            b.measures[k - 1] = measure::cells(
                c.grid,
                new_row(k - 1),
                Some(new_row(k)),
                c.sticking,
                c.radius,
            );
        }
        if j + 1 == c.grid.nz {
            b.measures[k] = measure::cells(c.grid, new_row(k), None, c.sticking, c.radius);
        }
    }
    moved
}

/// Largest squared distance between `a[i]` and `b[i]`, m^2, with lane-wise maxima (it
/// vectorises).
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
    springs: &RowPair,
) {
    let (nx, nz) = (c.grid.nx, c.grid.nz);
    let here = row(x, nx, j);

    // Gravity (eq. 3.3) and velocity damping, then the springs (eq. 3.6).
    gravity::set_row(force, here, prev.as_ref(), c.gravity * c.mass, c.damp);
    spring::add_row(force, &springs.current, &springs.previous, j, nx, nz);

    // Pressure force (eq. 3.7): (P_b - P_a) S N.
    if c.pressure_area != 0.0 {
        let below = row(x, nx, j.saturating_sub(1));
        let above = row(x, nx, (j + 1).min(nz - 1));
        pressure::add_row(force, here, below, above, c.pressure_area);
    }

    // Position Verlet (eq. 3.1), written as x + (x - x_prev) + F h: the step is added to x, not
    // to 2x, which halves the round-off for slow particles.
    {
        let h = c.step_per_force;
        let (fx, fy, fz) = (&force.x[..nx], &force.y[..nx], &force.z[..nx]);
        let (px, py, pz) = (&mut prev.x[..nx], &mut prev.y[..nx], &mut prev.z[..nx]);
        for i in 0..nx {
            px[i] = here.x[i] + (here.x[i] - px[i]) + fx[i] * h;
            py[i] = here.y[i] + (here.y[i] - py[i]) + fy[i] * h;
            pz[i] = here.z[i] + (here.z[i] - pz[i]) + fz[i] * h;
        }
    }

    // Contacts: normal force and Coulomb friction (eq. 3.4-3.5), see `collide::contact`.
    contact[..nx].fill(false);
    for p in c.planes {
        plane::contact_row(p, here, prev, &mut contact[..nx]);
    }
    if !c.non_planes.is_empty() {
        for i in 0..nx {
            let now = here.get(i);
            let next = Vec3::new(prev.x[i], prev.y[i], prev.z[i]);
            let (next, hit) = contact::resolve(c.non_planes, now, next, c.radius);
            (prev.x[i], prev.y[i], prev.z[i]) = (next.x, next.y, next.z);
            contact[i] |= hit;
        }
    }
}
