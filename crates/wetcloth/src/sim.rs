//! The simulation and its step (thesis 3.2, fig. 3.4).

use crate::air;
use crate::cloth::{Grid, STENCIL};
use crate::collider::Collider;
use crate::contact;
use crate::error::{ConfigError, StepError};
use crate::forces::{RowMut, RowRef};
use crate::grab::{Grab, GrabMotion};
use crate::math::{Real, Soa, Vec3};
use crate::metrics::FrameMetrics;
use crate::params::SimConfig;
use crate::self_collision::SelfCollision;
use crate::strain;
use rayon::prelude::*;

/// A structural spring longer than this many rest lengths means the run has blown up: cloth
/// tears long before, while strong suction legitimately stretches springs by tens of percent.
pub const BLOWUP_STRETCH: Real = 10.0;

/// Rows handed to one parallel task: enough work per task to hide the scheduling cost.
/// Results never depend on it (every particle's sum has a fixed order).
const ROWS_PER_TASK: usize = 8;

/// Constants of one step, shared by the row kernels.
struct StepConsts<'a> {
    grid: &'a Grid,
    colliders: &'a [Collider],
    mass: Real,
    gravity: Vec3,
    /// `damping * m / dt`: the damping force is `-damp * (x - x_prev)`.
    damp: Real,
    structural: Real,
    shear: Real,
    rest: [Real; 8],
    /// `(P_b - P_a) S`, N: the pressure force is this times the unit normal.
    pressure_area: Real,
    radius: Real,
    /// `dt^2 / m`, halved on the first step (see [`Simulation::step`]).
    h: Real,
}

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
    row_volume: Vec<Real>,
    row_stretch: Vec<Real>,
    volume: Real,
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
            row_volume: vec![0.0; grid.nz],
            row_stretch: vec![0.0; grid.nz],
            volume: 0.0,
            steps: 0,
            grid,
            config,
        };
        sim.update_air_and_check()
            .map_err(|e| ConfigError::Invalid {
                key: "cloth.position".into(),
                message: e.to_string(),
            })?;
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
                a.trapped_air,
                self.volume,
                self.cloth_area,
            )
        } else {
            a.atmospheric_pressure
        }
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
        self.update_air_and_check()
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
    /// 6. measure the new bubble volume (eq. 3.10) and check the state for a blow-up.
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
        let pressure_area = if self.air_enabled {
            (self.air_pressure() - c.air.atmospheric_pressure) * self.area_per_particle
        } else {
            0.0
        };
        let consts = StepConsts {
            grid: &self.grid,
            colliders: &c.colliders,
            mass: self.mass,
            gravity: c.simulation.gravity,
            damp: c.cloth.damping * self.mass / dt,
            structural: c.cloth.structural_stiffness,
            shear: c.cloth.shear_stiffness,
            rest: STENCIL.map(|n| self.grid.rest_length(n)),
            pressure_area,
            radius: self.radius,
            h: dt * dt / self.mass * if self.steps == 0 { 0.5 } else { 1.0 },
        };
        let nx = self.grid.nx;
        let x = &self.x;
        (
            self.prev.x.par_chunks_mut(nx),
            self.prev.y.par_chunks_mut(nx),
            self.prev.z.par_chunks_mut(nx),
            self.force.x.par_chunks_mut(nx),
            self.force.y.par_chunks_mut(nx),
            self.force.z.par_chunks_mut(nx),
            self.contact.par_chunks_mut(nx),
        )
            .into_par_iter()
            .enumerate()
            .with_min_len(ROWS_PER_TASK)
            .for_each(|(j, (px, py, pz, fx, fy, fz, contact))| {
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
                step_row(&consts, j, x, &mut prev, &mut force, contact);
            });
        std::mem::swap(&mut self.x, &mut self.prev);

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

        // 5. Position corrections.
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
            corrected |= sc.solve(&self.grid, &mut self.x, &self.fixed) > 0;
        }
        if corrected && !self.config.colliders.is_empty() {
            let (colliders, r, fixed) = (&self.config.colliders, self.radius, &self.fixed);
            let p = &mut self.x;
            p.x.par_iter_mut()
                .zip(p.y.par_iter_mut())
                .zip(p.z.par_iter_mut())
                .enumerate()
                .with_min_len(1024)
                .for_each(|(k, ((x, y), z))| {
                    if !fixed[k] {
                        let q = contact::project(colliders, Vec3::new(*x, *y, *z), r);
                        (*x, *y, *z) = (q.x, q.y, q.z);
                    }
                });
        }

        self.steps += 1;
        // 6. Bubble volume and blow-up check.
        self.update_air_and_check()
    }

    /// Recomputes the bubble volume of the current state and checks for non-finite positions
    /// and over-stretched structural springs, in one pass over the rows.
    fn update_air_and_check(&mut self) -> Result<(), StepError> {
        let (grid, x, sticking) = (&self.grid, &self.x, self.sticking);
        let offset = self.radius;
        let (rx, rz) = (grid.dx * grid.dx, grid.dz * grid.dz);
        self.row_volume
            .par_iter_mut()
            .zip(self.row_stretch.par_iter_mut())
            .enumerate()
            .with_min_len(ROWS_PER_TASK)
            .for_each(|(j, (vol, stretch))| {
                *vol = match sticking {
                    Some(plane) if j + 1 < grid.nz => air::row_volume(grid, x, j, plane, offset),
                    _ => 0.0,
                };
                // Largest squared length ratio of this row's structural springs (to the right
                // and to the next row); NaN positions make it NaN.
                let mut worst: Real = 0.0;
                for i in 0..grid.nx {
                    let k = grid.index(i, j);
                    let p = x.get(k);
                    if !p.is_finite() {
                        worst = Real::NAN;
                        break;
                    }
                    if i + 1 < grid.nx {
                        worst = worst.max((x.get(k + 1) - p).length_squared() / rx);
                    }
                    if j + 1 < grid.nz {
                        worst = worst.max((x.get(k + grid.nx) - p).length_squared() / rz);
                    }
                }
                *stretch = worst;
            });
        let time = self.time();
        let mut worst: Real = 0.0;
        for s in &self.row_stretch {
            if s.is_nan() {
                return Err(StepError::NonFinite { time });
            }
            worst = worst.max(*s);
        }
        if worst > BLOWUP_STRETCH * BLOWUP_STRETCH {
            return Err(StepError::OverStretch {
                time,
                ratio: worst.sqrt(),
                limit: BLOWUP_STRETCH,
            });
        }
        self.volume = self.row_volume.iter().sum();
        Ok(())
    }
}

/// Steps one row of particles (phases 2-3): forces, Verlet, contacts. Reads the current
/// positions of rows `j - 1 ..= j + 1`, and overwrites the row's previous positions with the
/// new ones.
#[inline]
fn step_row(
    c: &StepConsts<'_>,
    j: usize,
    x: &Soa,
    prev: &mut RowMut<'_>,
    force: &mut RowMut<'_>,
    contact: &mut [bool],
) {
    let grid = c.grid;
    let nx = grid.nx;
    let row = |r: usize| RowRef {
        x: &x.x[r * nx..(r + 1) * nx],
        y: &x.y[r * nx..(r + 1) * nx],
        z: &x.z[r * nx..(r + 1) * nx],
    };
    let here = row(j);
    let weight = c.gravity * c.mass;

    // Gravity and velocity damping.
    for i in 0..nx {
        force.x[i] = weight.x - c.damp * (here.x[i] - prev.x[i]);
        force.y[i] = weight.y - c.damp * (here.y[i] - prev.y[i]);
        force.z[i] = weight.z - c.damp * (here.z[i] - prev.z[i]);
    }

    // Springs, one stencil direction at a time over the run of the row that has that neighbour.
    for (n, &rest) in STENCIL.iter().zip(&c.rest) {
        let jj = j as isize + n.dj;
        if jj < 0 || jj >= grid.nz as isize {
            continue;
        }
        let i0 = (-n.di).max(0) as usize;
        let len = nx - n.di.unsigned_abs();
        let k = if n.structural { c.structural } else { c.shear };
        let a = here.slice(i0, len);
        let b = row(jj as usize).slice((i0 as isize + n.di) as usize, len);
        crate::forces::add_springs(force, i0, a, b, k, rest);
    }

    // Pressure force along the cloth normal.
    if c.pressure_area != 0.0 {
        for i in 0..nx {
            let f = crate::forces::pressure_force(
                c.pressure_area,
                0.0,
                1.0,
                grid.normal(x, grid.index(i, j)),
            );
            force.x[i] += f.x;
            force.y[i] += f.y;
            force.z[i] += f.z;
        }
    }

    // Position Verlet (eq. 3.1) and contacts.
    let h = c.h;
    for i in 0..nx {
        let now = Vec3::new(here.x[i], here.y[i], here.z[i]);
        let before = Vec3::new(prev.x[i], prev.y[i], prev.z[i]);
        let f = Vec3::new(force.x[i], force.y[i], force.z[i]);
        // Written as x + (x - x_prev) + F dt^2 / m: the step is added to x, not to 2x, which
        // halves the round-off for slow particles.
        let next = now + (now - before) + f * h;
        let (next, hit) = contact::resolve(c.colliders, now, next, c.radius);
        prev.x[i] = next.x;
        prev.y[i] = next.y;
        prev.z[i] = next.z;
        contact[i] = hit;
    }
}
