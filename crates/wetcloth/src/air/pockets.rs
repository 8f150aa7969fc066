//! Sealed air pockets (`[air] model = "pockets"`): the air under a wet cloth as separate
//! pockets that form, merge, split, leak and open at the rim. The thesis treats all the air as
//! one bubble and names that as the limit to lift (ch. 5).
//!
//! # Sealing and regions
//!
//! A particle *seals* when it touches a collider (its centre within its radius plus
//! `seal_distance` of the surface) and its wetness is at least `seal_wetness`: water closes the
//! gap there. Dry cloth never seals. A particle inside a pocket whose air pushes out (pressure
//! above atmospheric) does not seal unless it is pressed onto the surface (its centre within
//! its radius plus [`TOUCH`] of it, see [`TOUCH`]): the air holds the cloth off the surface.
//!
//! The cloth's cells (the grid's quads) with an unsealed corner hold air. Air passes between
//! two neighbouring cells across their shared edge unless both of its particles are sealed, so
//! the air cells form connected regions (union-find, each step, linear cost). A region that
//! reaches the cloth's border across an edge with an unsealed particle is **open**: at
//! atmospheric pressure, no force. Every other region is a **sealed pocket** `k` with its amount
//! of air `N_k` (m^3 at atmospheric pressure), its volume `V_k` (eq. 3.10 over its cells, a
//! cell of negative signed volume, its cloth below the surface or wound the other way, counting
//! as no room) and its pressure `P_k = P_a N_k / V_k` (Boyle).
//!
//! # Events conserve air
//!
//! Each step the regions are found again and matched to the pockets of the step before by the
//! cells they share. A new pocket takes, from every old pocket, the old pocket's air in
//! proportion to the volume of the old pocket's cells it now holds, plus the volume of the cells
//! that were open to the room before (air enclosed now, at atmospheric pressure); cells that
//! held no air (sealed all round) bring none. So a pocket that
//! forms takes the air it encloses; pockets that merge add their amounts; a pocket that splits
//! shares its amount in proportion to the parts' volumes (the pressure stays continuous); the
//! share of a pocket that opens goes to the room. A pocket keeps its id while it persists: the
//! new pocket that shares most cells with an old one inherits its id.
//!
//! # Leaks
//!
//! Through the fabric (Darcy): `dN_k/dt = -kappa_k A_k (P_k - P_a)`, `A_k` the pocket's cloth
//! area and `kappa_k` its cells' mean permeability (from their wetness). With `P = P_a N / V` and
//! the volume held over the step this is an exponential, `N -> V + (N - V) exp(-kappa A P_a dt /
//! V)`, integrated exactly (so a dry cloth, which leaks fast, is stable at any step). Where a
//! pocket's rim is close to opening (a sealed particle of its rim off the surface but within
//! `seal_distance`), the border leak of `air::leak` lets air in (or out) along that length.
//!
//! # The pressure force
//!
//! A particle inside a pocket feels `(P_k - P_a) S N` (or by area, `[air] pressure_force`); a
//! sealed particle on a rim feels the mean pressure difference of the cells around it. With
//! `pressure_solve = "implicit"` each pocket's pressure is solved at the end of the step from
//! the integrator's coasting positions, as for the thesis' bubble (`air::bubble::EndOfStep`).

use super::boyle::MIN_GAP;
use super::bubble::solve_boyle;
use super::seeds::SeedLayout;
use super::{AirLoad, Timing};
use crate::control::Control;
use crate::math::{Real, Soa};
use crate::measure::Measures;
use crate::model::{ClothMesh, Layout, Model};
use crate::params::{AirParams, PressureSolve};
use crate::state::State;

/// No pocket (an open region, a sealed cell, a sealed particle).
pub const NONE: u32 = u32::MAX;

/// How far beyond its radius a particle's centre may lie from a surface and still be pressed
/// onto it (touching), m: [`MIN_GAP`], the weave's thickness, the room Boyle's law already
/// counts as none. A hand or the contact puts a particle at its radius only to round-off: a
/// column held on the table over a pocket at 102.6 kPa sat 7e-19 m above its radius, so an
/// exact test (`gap <= radius`) never let it seal and the pocket never split.
pub const TOUCH: Real = MIN_GAP;

/// A sealed pocket of air.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Pocket {
    /// Its id, kept while the pocket persists (ids are never reused).
    pub id: u32,
    /// Air in the pocket, m^3 at atmospheric pressure.
    pub amount: Real,
    /// Volume between its cells and the sticking surface (eq. 3.10), m^3.
    pub volume: Real,
    /// Pressure, Pa: Boyle's law on `amount` and `volume`.
    pub pressure: Real,
    /// Cloth area over the pocket (its cells at rest), m^2.
    pub area: Real,
    /// Unsealed particles inside it.
    pub particles: u32,
    /// Mean Darcy permeability of its cells' fabric, m/(s Pa).
    pub permeability: Real,
    /// Length of its rim close to opening (sealed particles off the surface), m.
    pub rim_open: Real,
}

impl Pocket {
    /// The volume Boyle's law uses, m^3: the measured volume, but at least a gap of
    /// [`MIN_GAP`] over the pocket's area (a pocket pressed flat, or seeded under a cloth lying
    /// on the surface, still has the weave's thickness of room). `pressure * effective_volume()
    /// = P_a * amount` exactly.
    pub fn effective_volume(&self) -> Real {
        self.volume.max(MIN_GAP * self.area)
    }
}

/// The pockets model's state.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Pockets {
    /// The sealed pockets of the current state.
    pub pockets: Vec<Pocket>,
    /// Whether each particle seals.
    pub sealed: Vec<bool>,
    /// The pocket (index into `pockets`) of each cell, or [`NONE`].
    pub cell_pocket: Vec<u32>,
    /// The pocket (index into `pockets`) of each unsealed particle, or [`NONE`].
    pub particle_pocket: Vec<u32>,
    /// Whether each cell holds air open to the room (its region reaches the border).
    pub cell_open: Vec<bool>,
    /// Gap volume of each cell, m^3 (cell `(i, j)` at `j * (nx - 1) + i`), measured against
    /// the sticking plane (eq. 3.10) or, with `surface`, against the nearest collider.
    pub cell_volume: Vec<Real>,
    /// Whether volumes are measured against the colliders' own surfaces (any shape, the
    /// nearest one under each particle) rather than the single sticking plane.
    pub surface: bool,
    /// Whether each particle touches a collider (within its radius plus [`TOUCH`]): a sealed
    /// particle that does not is where a rim is close to opening.
    touching: Vec<bool>,
    /// `sealed` before the last sealing, to skip the region search when nothing changed.
    previous_sealed: Vec<bool>,
    /// Whether any particle seals.
    any_sealed: bool,
    /// Whether the air force acts this step (the air switch).
    enabled: bool,
    /// Whether `delta_p` holds the water film's pull alone for the current sealing (no pockets),
    /// so that the next step without pockets need not spread again.
    spread_bare: bool,
    /// The pressure difference each particle feels during the step, Pa.
    delta_p: Vec<Real>,
    /// Whether the step's pressures are solved at its end (implicit), and its constants.
    pending: Option<Pending>,
    /// The next unused pocket id.
    next_id: u32,
    /// Scratch of the region search.
    scratch: Scratch,
}

/// An end-of-step pressure solve to do this step.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
struct Pending {
    dt: Real,
    first_step: bool,
    /// Time at the end of the step, s (where moving colliders are then).
    end: Real,
}

/// Scratch buffers, kept so that a step allocates nothing once warm.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
struct Scratch {
    /// Union-find parent of each cell.
    parent: Vec<u32>,
    /// The region of each cell (dense index), or NONE.
    region: Vec<u32>,
    /// (old pocket, new region, shared volume, shared cells), one per cell then merged.
    overlaps: Vec<(u32, u32, Real, u32)>,
    /// The region of each union-find root (by cell index), or NONE.
    root_region: Vec<u32>,
    /// Each particle's distance to the nearest collider surface, m.
    gap: Vec<Real>,
    /// That surface's outward normal (when measuring against the colliders' surfaces).
    normal: Vec<crate::math::Vec3>,
    /// The coasting positions' gaps beyond the contact distance, m, and cell volumes, m^3.
    coast_gap: Vec<Real>,
    coast_cells: Vec<Real>,
    /// Per pocket: the pressure difference of the step (Pa), the coasting volume of its cells
    /// (m^3), and its free particles; per particle, whether it stays unsealed (inside a pocket
    /// that pushes out). Rebuilt each step, so not part of a checkpoint.
    #[cfg_attr(feature = "serde", serde(skip))]
    pressures: Vec<Real>,
    #[cfg_attr(feature = "serde", serde(skip))]
    base: Vec<Real>,
    #[cfg_attr(feature = "serde", serde(skip))]
    members: Vec<Vec<usize>>,
    #[cfg_attr(feature = "serde", serde(skip))]
    keep_open: Vec<bool>,
}

/// The root of `a`'s set in the union-find forest `parent`, halving the path on the way.
fn find(parent: &mut [u32], mut a: u32) -> u32 {
    while parent[a as usize] != a {
        let up = parent[parent[a as usize] as usize];
        parent[a as usize] = up;
        a = up;
    }
    a
}

/// Joins the sets of `a` and `b` in `parent`; the smaller index is the root, so roots are
/// canonical whatever the order of the joins.
fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra < rb {
        parent[rb as usize] = ra;
    } else if rb < ra {
        parent[ra as usize] = rb;
    }
}

/// What a resegmentation found of its regions, region by region: open to the room, room for
/// air (m^3), cells, summed permeability of the cells (its mean times the cells), area (m^2).
struct Regions {
    open: Vec<bool>,
    volume: Vec<Real>,
    count: Vec<u32>,
    kappa: Vec<Real>,
    area: Vec<Real>,
}

impl Pockets {
    /// The pockets of the cloth at t = 0 in `state`: sealed where it touches, pockets of the
    /// enclosed air at atmospheric pressure, and the seeded pockets of `air.pockets` holding
    /// their amounts (at atmospheric pressure where [`lift_seeds`] shaped the cloth over them),
    /// each particle's seed in `seed_of` (`air::seeds`).
    pub(crate) fn new(
        air: &AirParams,
        model: &Model,
        state: &State,
        measures: &Measures,
        seed_of: &[u32],
    ) -> Self {
        Self::at(air, model, &state.x, measures, seed_of)
    }

    /// [`Pockets::new`] for the cloth at `x` (m), measured in `measures`, each particle's seed
    /// in `seed_of`.
    fn at(air: &AirParams, model: &Model, x: &Soa, measures: &Measures, seed_of: &[u32]) -> Self {
        let n = model.len();
        let cells = match model.layout() {
            Layout::Grid(g) => (g.nx - 1) * (g.nz - 1),
            Layout::Mesh(m, _) => m.triangles.len(),
        };
        let mut p = Self {
            pockets: Vec::new(),
            sealed: vec![false; n],
            cell_pocket: vec![NONE; cells],
            particle_pocket: vec![NONE; n],
            cell_open: vec![false; cells],
            cell_volume: vec![0.0; cells],
            surface: !(model.colliders.len() == 1
                && model.colliders[0].as_plane().is_some()
                && model.colliders[0].sticky
                && !model.colliders[0].is_moving()),
            touching: vec![false; n],
            previous_sealed: vec![false; n],
            any_sealed: false,
            enabled: true,
            spread_bare: false,
            delta_p: vec![0.0; n],
            pending: None,
            next_id: 1,
            scratch: Scratch::default(),
        };
        // The seeded particles start unsealed, and their regions hold the seeds' air.
        p.gaps(model, x, 0.0);
        p.cell_volumes(model, x, measures);
        p.seal(air, model, |k, _| seed_of[k] == NONE);
        p.resegment(air, model, true);
        // Seeded regions: their air is the seeds' amount (a seed's pocket is that of its first
        // particle, in grid order, that lies in a pocket).
        let mut seeded = vec![0.0; p.pockets.len()];
        let mut has_seed = vec![false; p.pockets.len()];
        let mut seed_pocket = vec![NONE; air.pockets.len()];
        for (k, &si) in seed_of.iter().enumerate() {
            if si != NONE && seed_pocket[si as usize] == NONE && p.particle_pocket[k] != NONE {
                seed_pocket[si as usize] = p.particle_pocket[k];
            }
        }
        for (s, &q) in air.pockets.iter().zip(&seed_pocket) {
            if q != NONE {
                seeded[q as usize] += s.amount;
                has_seed[q as usize] = true;
            }
        }
        for (q, pocket) in p.pockets.iter_mut().enumerate() {
            if has_seed[q] {
                pocket.amount = seeded[q];
            }
        }
        p.update_pressures(air);
        p
    }

    /// Total volume of the sealed pockets ([`Pocket::effective_volume`]), m^3.
    pub fn volume(&self) -> Real {
        self.pockets.iter().map(Pocket::effective_volume).sum()
    }

    /// Total air in the sealed pockets, m^3 at atmospheric pressure.
    pub fn amount(&self) -> Real {
        self.pockets.iter().map(|p| p.amount).sum()
    }

    /// Volume-weighted mean pressure of the sealed pockets, Pa; atmospheric without any.
    pub fn mean_pressure(&self, atmosphere: Real) -> Real {
        let v = self.volume();
        if self.pockets.is_empty() || v <= 0.0 {
            return atmosphere;
        }
        self.pockets
            .iter()
            .map(|p| p.pressure * p.effective_volume())
            .sum::<Real>()
            / v
    }

    /// Phase 2: the pressures of the step. Known now (explicit: Boyle's law on the current
    /// volumes), or solved at its end from the coasting positions (implicit).
    pub(crate) fn begin_step(
        &mut self,
        air: &AirParams,
        model: &Model,
        state: &State,
        control: &Control,
        dt: Real,
    ) -> Timing {
        self.enabled = control.air_enabled;
        let implicit = control.air_enabled
            && air.pressure_solve == PressureSolve::Implicit
            && !self.pockets.is_empty();
        if !control.air_enabled {
            // The air switch turns off both pressures: the pockets' and the water film's.
            self.pending = None;
            self.spread_bare = false;
            return Timing::Now;
        }
        if implicit {
            self.pending = Some(Pending {
                dt,
                first_step: state.steps == 0,
                end: (state.steps + 1) as Real * dt,
            });
            Timing::EndOfStep
        } else {
            self.pending = None;
            if self.pockets.is_empty() && self.spread_bare {
                // No pockets and the same sealing: the film's pull is as last step.
                return Timing::Now;
            }
            let pa = air.atmospheric_pressure;
            let mut pressures = std::mem::take(&mut self.scratch.pressures);
            pressures.clear();
            pressures.extend(self.pockets.iter().map(|p| p.pressure - pa));
            self.spread(model, &pressures);
            self.scratch.pressures = pressures;
            Timing::Now
        }
    }

    /// The load of the step: each particle's pressure difference.
    pub(crate) fn load(&self) -> AirLoad<'_> {
        if !self.enabled || (self.pockets.is_empty() && !self.any_sealed) {
            AirLoad::Uniform(0.0)
        } else {
            AirLoad::PerParticle(&self.delta_p)
        }
    }

    /// Solves each pocket's end-of-step pressure from the coasting positions `coast` (m) and
    /// their cell volumes in `coast_measures` (see the module docs and `air::bubble::EndOfStep`).
    /// Each free particle of a pocket moves off the surface by its response per pascal times
    /// the pocket's pressure difference: with `response` (m/s per Pa, the step's velocities
    /// answering one pascal on every pocket, from an implicit solve) `dt` times its normal
    /// part; without, or for a particle that solve held on a collider (marked in the slice
    /// beside it: a contact lets go when the pressure lifts it, which a linear solve cannot
    /// foresee), a lone particle's explicit step, `dt^2 S / m`.
    pub(crate) fn solve_end_of_step(
        &mut self,
        air: &AirParams,
        model: &Model,
        coast: &Soa,
        coast_measures: &Measures,
        held: &[bool],
        response: Option<(&Soa, &[bool])>,
    ) {
        let Some(pending) = self.pending.take() else {
            return;
        };
        // The coasting positions' gaps (m, beyond the contact distance) and cell volumes.
        let mut coast_gap = std::mem::take(&mut self.scratch.coast_gap);
        let mut coast_cells = std::mem::take(&mut self.scratch.coast_cells);
        coast_gap.clear();
        coast_cells.clear();
        if self.surface {
            self.gaps(model, coast, pending.end);
            coast_cells.resize(self.cell_volume.len(), 0.0);
            surface_volumes(
                model,
                coast,
                &self.scratch.gap,
                &self.scratch.normal,
                &mut coast_cells,
            );
            coast_gap.extend(self.scratch.gap.iter().map(|g| g - model.radius));
        } else if let Some(plane) = model.sticking {
            let up = plane.up;
            let contact = up.dot(plane.point) + model.radius;
            coast_gap.extend(
                (0..coast.len())
                    .map(|i| up.x * coast.x[i] + up.y * coast.y[i] + up.z * coast.z[i] - contact),
            );
            coast_cells.extend((0..self.cell_volume.len()).map(|c| coast_measures.cells[c]));
        } else {
            self.scratch.coast_gap = coast_gap;
            self.scratch.coast_cells = coast_cells;
            return;
        }
        let gap = |i: usize| coast_gap[i];
        let pa = air.atmospheric_pressure;
        // Each particle's area S (the uniform one on the grid).
        let s_of = |i: usize| model.area(i);
        let first = if pending.first_step { 0.5 } else { 1.0 };
        let h_of = |i: usize| pending.dt * pending.dt / model.mass(i) * first;
        // Each particle's move off the surface per pascal, m/Pa (see above).
        let up = model
            .sticking
            .map_or(crate::math::Vec3::Y, |plane| plane.up);
        let rate_of = |i: usize| match response {
            Some((w, touching)) if !touching[i] => {
                let normal = if self.surface {
                    self.scratch.normal[i]
                } else {
                    up
                };
                // The response to a pascal on every pocket at once: where a neighbouring
                // pocket's push moves a particle inward, its own pocket's pressure is taken to
                // hold it still (a volume that shrank as its pressure rose would have no
                // Boyle solution to find).
                (pending.dt * normal.dot(w.get(i))).max(0.0)
            }
            _ => h_of(i) * s_of(i),
        };
        // Each pocket's coasting volume: its cells', plus the depth of its particles coasting
        // into the surface (the contact pushes them back out).
        let mut base = std::mem::take(&mut self.scratch.base);
        base.clear();
        base.resize(self.pockets.len(), 0.0);
        for (c, &q) in self.cell_pocket.iter().enumerate() {
            if q != NONE {
                base[q as usize] += coast_cells[c];
            }
        }
        for (i, &q) in self.particle_pocket.iter().enumerate() {
            let g = gap(i);
            if q != NONE && g < 0.0 && !held[i] {
                base[q as usize] -= s_of(i) * g;
            }
        }
        // Each pocket's free particles, in index order.
        let mut members = std::mem::take(&mut self.scratch.members);
        members.resize_with(self.pockets.len(), Vec::new);
        members.iter_mut().for_each(Vec::clear);
        for (i, &q) in self.particle_pocket.iter().enumerate() {
            if q != NONE && !held[i] {
                members[q as usize].push(i);
            }
        }
        let mut pressures = std::mem::take(&mut self.scratch.pressures);
        pressures.clear();
        for (q, pocket) in self.pockets.iter().enumerate() {
            let k = pa * pocket.amount;
            let volume = |p: Real| {
                let (mut v, mut slope) = (base[q], 0.0);
                for &i in &members[q] {
                    let (rate, s) = (rate_of(i), s_of(i));
                    let push = rate * (p - pa);
                    let g = gap(i).max(0.0);
                    if push >= 0.0 || -push < g {
                        v += s * push;
                        slope += rate * s;
                    } else {
                        v -= s * g;
                    }
                }
                (v.max(MIN_GAP * pocket.area), slope)
            };
            let p = if k > 0.0 {
                solve_boyle(k, pa, pocket.pressure, volume)
            } else {
                0.0
            };
            pressures.push(p - pa);
        }
        self.scratch.coast_gap = coast_gap;
        self.scratch.coast_cells = coast_cells;
        self.scratch.base = base;
        self.scratch.members = members;
        self.spread(model, &pressures);
        self.scratch.pressures = pressures;
    }

    /// Sets each particle's pressure difference from the pockets' `pressures` (Pa, one per
    /// pocket): the pocket's for a particle inside it, the mean of the cells around it for a
    /// sealed particle.
    fn spread(&mut self, model: &Model, pressures: &[Real]) {
        self.spread_bare = pressures.is_empty();
        let grid = match model.layout() {
            Layout::Grid(grid) => grid,
            Layout::Mesh(mesh, _) => {
                for k in 0..model.len() {
                    let q = self.particle_pocket[k];
                    self.delta_p[k] = if q != NONE {
                        pressures[q as usize]
                    } else if self.sealed[k] {
                        // The mean over the triangles around it, as the grid's cells.
                        let around = mesh.triangles_of(k);
                        let sum: Real = around
                            .iter()
                            .map(|&t| match self.cell_pocket[t as usize] {
                                NONE => 0.0,
                                cq => pressures[cq as usize],
                            })
                            .sum();
                        sum / around.len().max(1) as Real - model.wet_adhesion * model.wetness[k]
                    } else {
                        0.0
                    };
                }
                return;
            }
        };
        let (nx, nz) = (grid.nx, grid.nz);
        for j in 0..nz {
            for i in 0..nx {
                let k = j * nx + i;
                let q = self.particle_pocket[k];
                self.delta_p[k] = if q != NONE {
                    pressures[q as usize]
                } else if self.sealed[k] {
                    let air = sealed_share(&self.cell_pocket, nx, nz, i, j, |q| pressures[q]);
                    // The water film holds the sealed particle on the surface.
                    air - model.wet_adhesion * model.wetness[k]
                } else {
                    0.0
                };
            }
        }
    }

    /// Phase 6: the air after the step. Each pocket leaks through its fabric and rim over the
    /// step with its new volume (measured in `measures`), then the cloth is sealed again, the
    /// regions found again, and the air shared among the new pockets.
    pub(crate) fn finish_step(
        &mut self,
        air: &AirParams,
        model: &Model,
        state: &State,
        measures: &Measures,
        dt: Real,
    ) {
        let pa = air.atmospheric_pressure;
        // New volumes of the old pockets, then their leaks over the step.
        self.gaps(model, &state.x, state.steps as Real * dt);
        self.cell_volumes(model, &state.x, measures);
        self.measure_volumes();
        for pocket in &mut self.pockets {
            let floor = MIN_GAP * pocket.area;
            let v = pocket.volume.max(floor);
            if pocket.permeability > 0.0 && pa > 0.0 {
                let rate = pocket.permeability * pocket.area * pa / v;
                pocket.amount = v + (pocket.amount - v) * (-rate * dt).exp();
            }
            if air.leak_conductance > 0.0 && pa > 0.0 && pocket.rim_open > 0.0 {
                // Relaxed exactly towards atmospheric pressure, never past it.
                pocket.amount =
                    super::leak::relax(pocket.amount, v, air.leak_conductance, pocket.rim_open, dt)
                        .max(0.0);
            }
        }
        self.update_pressures(air);
        // Seal again; a particle inside a pocket that pushes out stays unsealed unless it is
        // pressed onto the surface (within its radius plus `TOUCH`).
        std::mem::swap(&mut self.sealed, &mut self.previous_sealed);
        let mut keep_open = std::mem::take(&mut self.scratch.keep_open);
        keep_open.clear();
        keep_open.extend(
            self.particle_pocket
                .iter()
                .map(|&q| q != NONE && self.pockets[q as usize].pressure > pa),
        );
        self.seal(air, model, |k, touching| touching || !keep_open[k]);
        self.scratch.keep_open = keep_open;
        if self.sealed == self.previous_sealed {
            // The same sealed particles: the same regions and pockets, with their air (their
            // volumes are measured above); only the rims may have moved.
            self.measure_rims(model);
        } else {
            self.spread_bare = false;
            self.resegment(air, model, false);
        }
        self.update_pressures(air);
    }

    /// Each particle's distance from `x` to the nearest sticky collider's surface (m, in the
    /// scratch's `gap`; moving colliders where they are at time `t`, s) and, when measuring
    /// against the colliders' surfaces, that surface's outward normal (`normal`). A still
    /// plane's distance is a vectorised dot product.
    fn gaps(&mut self, model: &Model, x: &Soa, t: Real) {
        let n = x.len();
        let sc = &mut self.scratch;
        sc.gap.clear();
        sc.gap.resize(n, Real::INFINITY);
        if self.surface {
            sc.normal.clear();
            sc.normal.resize(n, crate::math::Vec3::Y);
            for c in model.colliders.iter().filter(|c| c.sticky) {
                // A deforming mesh is taken as it is at `t` whole (its pose and placement).
                let posed = c.is_deforming().then(|| c.at(t));
                let place = (c.is_moving() && posed.is_none()).then(|| c.placement_at(t));
                let nearest = |k: usize, gap: &mut Real, out: &mut crate::math::Vec3| {
                    let (d, normal) = match &place {
                        None => posed.as_ref().unwrap_or(c).distance(x.get(k)),
                        Some(at) => {
                            let (d, normal) = c.rest_distance(at.to_rest(x.get(k)));
                            (d, at.dir_to_world(normal))
                        }
                    };
                    if d < *gap {
                        *gap = d;
                        *out = normal;
                    }
                };
                // Each particle's query is its own (a mesh's closest point is most of the
                // cost): on the pool for a large cloth, the same bits.
                if crate::exec::use_pool(n) {
                    use rayon::prelude::*;
                    sc.gap
                        .par_iter_mut()
                        .zip(sc.normal.par_iter_mut())
                        .enumerate()
                        .with_min_len(256)
                        .for_each(|(k, (g, o))| nearest(k, g, o));
                } else {
                    for (k, (g, o)) in sc.gap.iter_mut().zip(sc.normal.iter_mut()).enumerate() {
                        nearest(k, g, o);
                    }
                }
            }
            return;
        }
        for c in model.colliders.iter().filter(|c| c.sticky) {
            if let (crate::collide::Shape::Plane(plane), false) = (&c.shape, c.is_moving()) {
                let (nv, o) = (plane.normal, plane.normal.dot(plane.point));
                for (k, g) in sc.gap.iter_mut().enumerate() {
                    *g = g.min(nv.x * x.x[k] + nv.y * x.y[k] + nv.z * x.z[k] - o);
                }
            } else {
                for (k, g) in sc.gap.iter_mut().enumerate() {
                    *g = g.min(c.distance(x.get(k)).0);
                }
            }
        }
    }

    /// The gap volume of every cell at `x` (whose gaps [`Pockets::gaps`] found): the fused
    /// pass's eq. 3.10 against the sticking plane from `measures`, or against the colliders'
    /// surfaces.
    fn cell_volumes(&mut self, model: &Model, x: &Soa, measures: &Measures) {
        if self.surface {
            surface_volumes(
                model,
                x,
                &self.scratch.gap,
                &self.scratch.normal,
                &mut self.cell_volume,
            );
        } else {
            let cells = self.cell_volume.len();
            self.cell_volume.copy_from_slice(&measures.cells[..cells]);
        }
    }

    /// Marks the particles that seal (from the gaps of [`Pockets::gaps`]): wet enough and
    /// within `seal_distance` beyond their radius of a collider's surface if they sealed
    /// before (`previous_sealed`), within `seal_distance * (1 - seal_hysteresis)` if not, where
    /// `may_seal(k, touching)` allows (`touching`: within the radius plus [`TOUCH`]).
    fn seal(&mut self, air: &AirParams, model: &Model, may_seal: impl Fn(usize, bool) -> bool) {
        // A sealed particle (in `previous_sealed`, the seal before this one) stays sealed out
        // to `seal_distance`; an open one seals within the hysteresis' share of it.
        let keep = model.radius + air.seal_distance;
        let close = model.radius + air.seal_distance * (1.0 - air.seal_hysteresis);
        let touch = model.radius + TOUCH;
        for k in 0..self.sealed.len() {
            let gap = self.scratch.gap[k];
            self.touching[k] = gap <= touch;
            let reach = if self.previous_sealed[k] { keep } else { close };
            self.sealed[k] = model.wetness[k] >= air.seal_wetness
                && gap <= reach
                && may_seal(k, self.touching[k]);
        }
        self.any_sealed = self.sealed.iter().any(|&s| s);
    }

    /// The volumes of the current pockets, from their cells'.
    fn measure_volumes(&mut self) {
        for p in &mut self.pockets {
            p.volume = 0.0;
        }
        for (c, &q) in self.cell_pocket.iter().enumerate() {
            if q != NONE {
                // A cell's room for air: none where its signed volume is negative.
                self.pockets[q as usize].volume += self.cell_volume[c].max(0.0);
            }
        }
    }

    /// Boyle's pressure of every pocket.
    fn update_pressures(&mut self, air: &AirParams) {
        let pa = air.atmospheric_pressure;
        for p in &mut self.pockets {
            p.pressure = pa * p.amount / p.effective_volume();
        }
    }

    /// Finds the regions of the sealed state, and the new pockets with their air (see the
    /// module docs). `fresh`: at t = 0, every pocket takes the air it encloses.
    fn resegment(&mut self, air: &AirParams, model: &Model, fresh: bool) {
        let grid = match model.layout() {
            Layout::Grid(grid) => grid,
            Layout::Mesh(mesh, _) => return self.resegment_mesh(air, model, mesh, fresh),
        };
        let (nx, nz) = (grid.nx, grid.nz);
        let m = nx - 1;
        let cells = m * (nz - 1);
        let sealed = &self.sealed;
        let corner = |i: usize, j: usize| !sealed[j * nx + i];
        let air_cell = |i: usize, j: usize| {
            corner(i, j) || corner(i + 1, j) || corner(i, j + 1) || corner(i + 1, j + 1)
        };
        // Union-find over the air cells.
        let sc = &mut self.scratch;
        sc.parent.clear();
        sc.parent.extend(0..cells as u32);
        for j in 0..nz - 1 {
            for i in 0..m {
                if !air_cell(i, j) {
                    continue;
                }
                let c = (j * m + i) as u32;
                // Across the right edge (i+1, j)-(i+1, j+1).
                if i + 1 < m && air_cell(i + 1, j) && (corner(i + 1, j) || corner(i + 1, j + 1)) {
                    union(&mut sc.parent, c, c + 1);
                }
                // Across the edge below (i, j+1)-(i+1, j+1).
                if j + 2 < nz && air_cell(i, j + 1) && (corner(i, j + 1) || corner(i + 1, j + 1)) {
                    union(&mut sc.parent, c, c + m as u32);
                }
            }
        }
        // Dense regions in order of their first cell; open if a border edge of one of their
        // cells has an unsealed particle.
        sc.region.clear();
        sc.region.resize(cells, NONE);
        // The region of each union-find root, by the root's cell index.
        sc.root_region.clear();
        sc.root_region.resize(cells, NONE);
        let mut open: Vec<bool> = Vec::new();
        for j in 0..nz - 1 {
            for i in 0..m {
                if !air_cell(i, j) {
                    continue;
                }
                let c = j * m + i;
                let root = find(&mut sc.parent, c as u32);
                let r = match sc.root_region[root as usize] {
                    NONE => {
                        let r = open.len() as u32;
                        sc.root_region[root as usize] = r;
                        open.push(false);
                        r
                    }
                    r => r,
                };
                sc.region[c] = r;
                let border = (j == 0 && (corner(i, 0) || corner(i + 1, 0)))
                    || (j + 2 == nz && (corner(i, nz - 1) || corner(i + 1, nz - 1)))
                    || (i == 0 && (corner(0, j) || corner(0, j + 1)))
                    || (i + 1 == m && (corner(nx - 1, j) || corner(nx - 1, j + 1)));
                open[r as usize] |= border;
            }
        }
        let regions = open.len();
        // Volumes, areas, permeabilities of the sealed regions.
        let cell_area = grid.dx * grid.dz;
        let mut volume = vec![0.0; regions];
        let mut count = vec![0u32; regions];
        let mut kappa = vec![0.0; regions];
        let wet_kappa = |k: usize| air.permeability_at(model.wetness[k]);
        for c in 0..cells {
            let r = sc.region[c];
            if r == NONE {
                continue;
            }
            let (i, j) = (c % m, c / m);
            volume[r as usize] += self.cell_volume[j * m + i].max(0.0);
            count[r as usize] += 1;
            let k = j * nx + i;
            kappa[r as usize] += 0.25
                * (wet_kappa(k) + wet_kappa(k + 1) + wet_kappa(k + nx) + wet_kappa(k + nx + 1));
        }
        let area: Vec<Real> = count.iter().map(|&c| Real::from(c) * cell_area).collect();
        let found = Regions {
            open,
            volume,
            count,
            kappa,
            area,
        };
        // A squeezed pocket's air goes to the nearest air within two cells, along the grid.
        let near = |c: usize, reach: usize, out: &mut Vec<usize>| {
            let (i, j, r) = ((c % m) as isize, (c / m) as isize, reach as isize);
            for (di, dj) in [(-r, 0), (r, 0), (0, -r), (0, r)] {
                let (a, b) = (i + di, j + dj);
                if a >= 0 && b >= 0 && a < m as isize && b < (nz - 1) as isize {
                    out.push(b as usize * m + a as usize);
                }
            }
        };
        let mut pockets = self.share_air(air, fresh, &found, near);
        // Each unsealed particle's pocket (all its cells share one region), and the rims.
        for j in 0..nz {
            for i in 0..nx {
                let k = j * nx + i;
                self.particle_pocket[k] = NONE;
                let cell = (i.min(m - 1), j.min(nz - 2));
                let c = cell.1 * m + cell.0;
                if !self.sealed[k] {
                    let q = self.cell_pocket[c];
                    self.particle_pocket[k] = q;
                    if q != NONE {
                        pockets[q as usize].particles += 1;
                    }
                }
            }
        }
        self.pockets = pockets;
        self.measure_rims(model);
    }

    /// [`Pockets::resegment`] on a mesh cloth: its triangles are the cells, air passes between
    /// two across their shared edge unless both of its particles are sealed, and a region is
    /// open where one of its triangles has a boundary edge with an unsealed particle.
    fn resegment_mesh(&mut self, air: &AirParams, model: &Model, mesh: &ClothMesh, fresh: bool) {
        let cells = mesh.triangles.len();
        let sealed = &self.sealed;
        let corner = |k: u32| !sealed[k as usize];
        let air_cell = |t: usize| mesh.triangles[t].iter().any(|&k| corner(k));
        let sc = &mut self.scratch;
        sc.parent.clear();
        sc.parent.extend(0..cells as u32);
        for (e, &[t, u]) in mesh.edge_faces.iter().enumerate() {
            let [a, b] = mesh.edges[e];
            if u == NONE || !(corner(a) || corner(b)) {
                continue;
            }
            if air_cell(t as usize) && air_cell(u as usize) {
                union(&mut sc.parent, t, u);
            }
        }
        sc.region.clear();
        sc.region.resize(cells, NONE);
        sc.root_region.clear();
        sc.root_region.resize(cells, NONE);
        let mut open: Vec<bool> = Vec::new();
        for t in 0..cells {
            if !air_cell(t) {
                continue;
            }
            let root = find(&mut sc.parent, t as u32);
            let r = match sc.root_region[root as usize] {
                NONE => {
                    let r = open.len() as u32;
                    sc.root_region[root as usize] = r;
                    open.push(false);
                    r
                }
                r => r,
            };
            sc.region[t] = r;
        }
        for (e, &[t, u]) in mesh.edge_faces.iter().enumerate() {
            let [a, b] = mesh.edges[e];
            if u == NONE && (corner(a) || corner(b)) {
                let r = sc.region[t as usize];
                if r != NONE {
                    open[r as usize] = true;
                }
            }
        }
        let regions = open.len();
        let mut volume = vec![0.0; regions];
        let mut count = vec![0u32; regions];
        let mut kappa = vec![0.0; regions];
        let mut area = vec![0.0; regions];
        for t in 0..cells {
            let r = sc.region[t];
            if r == NONE {
                continue;
            }
            let r = r as usize;
            volume[r] += self.cell_volume[t].max(0.0);
            count[r] += 1;
            area[r] += mesh.triangle_area[t];
            kappa[r] += mesh.triangles[t]
                .iter()
                .map(|&k| air.permeability_at(model.wetness[k as usize]))
                .sum::<Real>()
                / 3.0;
        }
        let found = Regions {
            open,
            volume,
            count,
            kappa,
            area,
        };
        // A squeezed pocket's air goes to the triangles around its corners (one ring, then
        // two).
        let near = |t: usize, reach: usize, out: &mut Vec<usize>| {
            let mut ring = vec![t];
            for _ in 0..reach {
                let mut next = Vec::new();
                for &c in &ring {
                    for &k in &mesh.triangles[c] {
                        next.extend(mesh.triangles_of(k as usize).iter().map(|&u| u as usize));
                    }
                }
                next.sort_unstable();
                next.dedup();
                ring = next;
            }
            out.extend(ring.into_iter().filter(|&c| c != t));
        };
        let mut pockets = self.share_air(air, fresh, &found, near);
        for k in 0..model.len() {
            self.particle_pocket[k] = NONE;
            if !self.sealed[k] {
                let q = self.cell_pocket[mesh.triangles_of(k)[0] as usize];
                self.particle_pocket[k] = q;
                if q != NONE {
                    pockets[q as usize].particles += 1;
                }
            }
        }
        self.pockets = pockets;
        self.measure_rims(model);
    }

    /// The air of the new regions (`found`, over the cells' regions in the scratch): each new
    /// pocket's share of the old pockets and the air it encloses (see the module docs), its id,
    /// and each cell's pocket and openness. `near(cell, reach, out)` lists the cells `reach`
    /// steps from a cell, where a pocket squeezed flat pushes its air. Returns the new pockets
    /// (their particle counts 0).
    fn share_air(
        &mut self,
        air: &AirParams,
        fresh: bool,
        found: &Regions,
        near: impl Fn(usize, usize, &mut Vec<usize>),
    ) -> Vec<Pocket> {
        let Regions {
            open,
            volume,
            count,
            kappa,
            area,
        } = found;
        let regions = open.len();
        let cells = self.cell_pocket.len();
        let sc = &mut self.scratch;
        // Air of the new pockets: shares of the old pockets, plus newly enclosed air.
        sc.overlaps.clear();
        let mut enclosed = vec![0.0; regions];
        let mut old_volume = vec![0.0; self.pockets.len()];
        let mut old_cells = vec![0u32; self.pockets.len()];
        for c in 0..cells {
            let (r, old) = (sc.region[c], self.cell_pocket[c]);
            // The air room of the cell: its gap volume, none where the cloth lies below the
            // surface (a negative signed prism). Counting such a cell's volume as enclosed air
            // or in an old pocket's shares made pockets of negative air.
            let v = self.cell_volume[c].max(0.0);
            if r == NONE {
                // The cell closed (sealed all round): its air is squeezed into the rest of
                // its pocket, so it takes no share.
                continue;
            }
            if old != NONE {
                old_volume[old as usize] += v;
                old_cells[old as usize] += 1;
            }
            if open[r as usize] {
                continue;
            }
            if fresh || (old == NONE && self.cell_open[c]) {
                // Air of the room (or, at the start, whatever is under the cloth) enclosed now.
                enclosed[r as usize] += v;
            } else if old != NONE {
                sc.overlaps.push((old, r, v, 1));
            }
            // A cell that held no air (all its corners sealed) brings none: lifting it off
            // the surface opens empty space that the pocket's air expands into.
        }
        sc.overlaps.sort_by_key(|a| (a.0, a.1));
        sc.overlaps.dedup_by(|later, first| {
            if (later.0, later.1) == (first.0, first.1) {
                first.2 += later.2;
                first.3 += later.3;
                true
            } else {
                false
            }
        });
        let mut amount = enclosed;
        for &(old, r, v, n) in &sc.overlaps {
            let o = &self.pockets[old as usize];
            let share = if old_volume[old as usize] > MIN_GAP * o.area {
                v / old_volume[old as usize]
            } else {
                Real::from(n) / Real::from(old_cells[old as usize].max(1))
            };
            amount[r as usize] += o.amount * share.clamp(0.0, 1.0);
        }
        // A pocket whose cells all closed (squeezed flat) pushes its air under the seal into
        // the nearest air (within two cells of where it was): a sealed pocket takes it, an
        // open region lets it out to the room.
        for (o, pocket) in self.pockets.iter().enumerate() {
            if old_cells[o] > 0 || pocket.amount <= 0.0 {
                continue;
            }
            let mut target = None;
            let mut around = Vec::new();
            'search: for reach in 1..=2 {
                for c in (0..cells).filter(|&c| self.cell_pocket[c] == o as u32) {
                    around.clear();
                    near(c, reach, &mut around);
                    for &a in &around {
                        let r = sc.region[a];
                        if r != NONE {
                            target = Some(r);
                            break 'search;
                        }
                    }
                }
            }
            if let Some(r) = target
                && !open[r as usize]
            {
                amount[r as usize] += pocket.amount;
            }
        }
        // Ids: an old pocket's id goes to the new pocket sharing most of its cells.
        let mut claims: Vec<(u32, u32, u32)> = sc
            .overlaps
            .iter()
            .map(|&(old, r, _, n)| (n, old, r))
            .collect();
        claims.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut region_id = vec![NONE; regions];
        let mut old_taken = vec![false; self.pockets.len()];
        for (_, old, r) in claims {
            if region_id[r as usize] == NONE && !old_taken[old as usize] {
                region_id[r as usize] = self.pockets[old as usize].id;
                old_taken[old as usize] = true;
            }
        }
        // The new pockets, in region order.
        let mut region_pocket = vec![NONE; regions];
        let mut pockets = Vec::new();
        for r in 0..regions {
            if open[r] {
                continue;
            }
            let id = if region_id[r] != NONE {
                region_id[r]
            } else {
                self.next_id += 1;
                self.next_id - 1
            };
            region_pocket[r] = pockets.len() as u32;
            pockets.push(Pocket {
                id,
                amount: amount[r],
                volume: volume[r],
                pressure: air.atmospheric_pressure,
                area: area[r],
                particles: 0,
                permeability: kappa[r] / Real::from(count[r].max(1)),
                rim_open: 0.0,
            });
        }
        for c in 0..cells {
            let r = sc.region[c];
            self.cell_open[c] = r != NONE && open[r as usize];
            self.cell_pocket[c] = if r == NONE {
                NONE
            } else {
                region_pocket[r as usize]
            };
        }
        pockets
    }

    /// The length of each pocket's rim close to opening: sealed corners of its cells that do
    /// not touch the surface.
    fn measure_rims(&mut self, model: &Model) {
        if self.pockets.is_empty() {
            return;
        }
        let grid = match model.layout() {
            Layout::Grid(grid) => grid,
            Layout::Mesh(mesh, _) => {
                for p in &mut self.pockets {
                    p.rim_open = 0.0;
                }
                for (c, &q) in self.cell_pocket.iter().enumerate() {
                    if q == NONE {
                        continue;
                    }
                    for k in mesh.triangles[c] {
                        let k = k as usize;
                        if self.sealed[k] && !self.touching[k] {
                            // A corner's length, the side of its lumped area, shared by the
                            // triangles around it.
                            let share = mesh.area[k].sqrt() / mesh.triangles_of(k).len() as Real;
                            self.pockets[q as usize].rim_open += share;
                        }
                    }
                }
                return;
            }
        };
        let (nx, m) = (grid.nx, grid.nx - 1);
        let spacing = 0.5 * (grid.dx + grid.dz);
        for p in &mut self.pockets {
            p.rim_open = 0.0;
        }
        for (c, &q) in self.cell_pocket.iter().enumerate() {
            if q == NONE {
                continue;
            }
            let (i, j) = (c % m, c / m);
            for k in [
                j * nx + i,
                j * nx + i + 1,
                (j + 1) * nx + i,
                (j + 1) * nx + i + 1,
            ] {
                if self.sealed[k] && !self.touching[k] {
                    // A corner is shared by up to four cells: a quarter of its length each.
                    self.pockets[q as usize].rim_open += 0.25 * spacing;
                }
            }
        }
    }
}

/// The cloth at t = 0 with each seeded pocket (`[[air.pocket]]`) holding its air at
/// atmospheric pressure, at rest: `x` (m, the cloth's rest positions) with the cloth over the
/// seeds lifted off the surface, along its normal, into a shallow spherical cap over each
/// seed's *footprint*, a disc about the seed's centre: in the grid's rest plane, or on a mesh
/// in the plane through the seed's centre across the mean normal of the surfaces under its
/// particles (`air::seeds`), distances from the centre measured in that plane.
///
/// The footprint is the seed's disc, widened where the amount needs a cap higher than
/// [`SEED_BULGE`] times its radius: a cap of height `b R` over radius `R` (m) holds
/// `pi R^3 b (3 + b^2) / 6` m^3, so 50 cm^3 widens a 4 cm disc to 6.8 cm (never closer than two
/// particle spacings to the cloth's border, [`SeedLayout::room`]). The cloth's meridians are stretched evenly (a
/// particle at rest distance `r` from the centre goes to arc length `r (1 + e)` from the cap's
/// top, the footprint's rim staying where it is); at a bulge of 0.1 the stretch `e` is 0.7 %.
/// A steeper cap does not stay: the seed's disc itself, 50 cm^3 under a 4 cm disc (a bulge of
/// 0.46, stretched 13.8 %), fell in within 3 ms, its top hit the table and lobes pinched off;
/// a paraboloid lifted straight up (41 % at its rim) likewise in 2 ms.
///
/// The bulge of each group of seeds whose footprints overlap (one for the group, each disc's
/// cap `b R` high; a particle in several follows the one it lies deepest in, largest `1 -
/// r^2 / R^2`) is solved by a safeguarded secant on the measured volume of the pockets the
/// lifted cloth makes there (eq. 3.10 over their cells as the model measures them, or the
/// frustums over the colliders' surfaces) until it is the group's amount to
/// [`SEED_TOLERANCE`]: the pockets start at atmospheric pressure (the cloth weighs a few
/// pascals). Without the lift a seeded cloth lying on the surface started with all its air in
/// the weave's thickness ([`MIN_GAP`]): 666 MPa for 50 cm^3 under a 4 cm disc, an explosion
/// that threw the cloth up and split the bubble into three pockets.
///
/// The bulge is at most 1 (hemispheres): a group that needs more (its footprint held in by
/// the border) starts above atmospheric pressure, as do seeds under a cloth already holding
/// more room than their air (nothing is lowered). Seeds whose disc is open to the room, and
/// every particle outside the footprints, stay where they are; without the pockets model or
/// seeds, `x` is returned unchanged.
pub(crate) fn lift_seeds(air: &AirParams, model: &Model, seeds: &SeedLayout, mut x: Soa) -> Soa {
    if air.model != crate::params::AirModelKind::Pockets || air.pockets.is_empty() {
        return x;
    }
    let n = model.len();
    let seed_of = &seeds.seed_of;
    let mut measures = Measures::for_layout(model.layout(), true);
    let remeasure = |m: &mut Measures, x: &Soa| {
        m.remeasure_layout(model.layout(), x, model.sticking, model.radius, None);
    };
    remeasure(&mut measures, &x);
    let flat = Pockets::at(air, model, &x, &measures, seed_of);
    // The seeds that make a sealed pocket (their air is kept), and their footprints' radii.
    let mut sealed = vec![false; air.pockets.len()];
    for k in 0..n {
        if seed_of[k] != NONE && flat.particle_pocket[k] != NONE {
            sealed[seed_of[k] as usize] = true;
        }
    }
    if !sealed.iter().any(|&s| s) {
        return x;
    }
    let footprint: Vec<Real> = air
        .pockets
        .iter()
        .enumerate()
        .map(|(d, s)| {
            let b = SEED_BULGE;
            let wide = (6.0 * s.amount / (std::f64::consts::PI * b * (3.0 + b * b))).cbrt();
            s.radius.max(wide.min(seeds.room(d)))
        })
        .collect();
    // Groups of sealed seeds whose footprints overlap (union-find, in seed order).
    let seeds_len = air.pockets.len();
    let mut group: Vec<usize> = (0..seeds_len).collect();
    fn root(g: &mut [usize], mut a: usize) -> usize {
        while g[a] != a {
            g[a] = g[g[a]];
            a = g[a];
        }
        a
    }
    for a in (0..seeds_len).filter(|&a| sealed[a]) {
        for b in (a + 1..seeds_len).filter(|&b| sealed[b]) {
            let reach = footprint[a] + footprint[b];
            if seeds.between(a, b).length_squared() < reach * reach {
                let (ra, rb) = (root(&mut group, a), root(&mut group, b));
                group[ra.max(rb)] = ra.min(rb);
            }
        }
    }
    let group: Vec<usize> = (0..seeds_len).map(|a| root(&mut group, a)).collect();
    // Each particle's footprint (the one it lies deepest in), 0 outside all.
    let mut disc = vec![NONE; n];
    let mut depth: Vec<Real> = vec![0.0; n];
    for k in 0..n {
        for d in (0..seeds_len).filter(|&d| sealed[d]) {
            let f = 1.0 - seeds.offset(k, d).length_squared() / (footprint[d] * footprint[d]);
            if f > depth[k] {
                depth[k] = f;
                disc[k] = d as u32;
            }
        }
    }
    let moved: Vec<usize> = (0..n).filter(|&k| disc[k] != NONE).collect();
    // The direction each particle is lifted along: the sticking plane's normal, or the nearest
    // surface's (found at `x`).
    let up: Vec<crate::math::Vec3> = moved
        .iter()
        .map(|&k| match (flat.surface, model.sticking) {
            (false, Some(plane)) => plane.up,
            _ => flat.scratch.normal[k],
        })
        .collect();
    // On a mesh, each footprint's plane: across the mean of its particles' lifting directions.
    let mut across = vec![crate::math::Vec3::ZERO; seeds_len];
    if seeds.on_mesh() {
        for (i, &k) in moved.iter().enumerate() {
            across[disc[k] as usize] += up[i];
        }
        for a in &mut across {
            *a = a.normalize_or_zero();
        }
    }
    let base = x.clone();
    // Particle `k` (the `i`-th moved) on its footprint's cap of bulge `b`: the sphere of
    // radius `R (1 + b^2) / (2 b)` through the rim, the particle at polar angle
    // `2 atan(b) r / R` from the top, `r` its distance from the centre across the surface's
    // normal.
    let place = |x: &mut Soa, i: usize, k: usize, b: Real| {
        let d = disc[k] as usize;
        let radius = footprint[d];
        let offset = seeds.across(seeds.offset(k, d), across[d]);
        let r = offset.length();
        let sphere = radius * (1.0 + b * b) / (2.0 * b);
        let phi = 2.0 * b.atan() * r / radius;
        let half = (0.5 * phi).sin();
        let height = b * radius - 2.0 * sphere * half * half;
        let inward = if r > 0.0 {
            sphere * phi.sin() / r - 1.0
        } else {
            0.0
        };
        x.set(k, base.get(k) + offset * inward + up[i] * height);
    };
    // Per group (by its root seed): its air, the bracket (a bulge with too little room and
    // one with too much, if found yet), its bulge, and whether it is solved.
    let mut target = vec![0.0; seeds_len];
    for a in (0..seeds_len).filter(|&a| sealed[a]) {
        target[group[a]] += air.pockets[a].amount;
    }
    let mut lo: Vec<(Real, Real)> = vec![(0.0, 0.0); seeds_len];
    let mut hi: Vec<Option<(Real, Real)>> = vec![None; seeds_len];
    let mut bulge = vec![0.0; seeds_len];
    let mut done: Vec<bool> = (0..seeds_len)
        .map(|a| !sealed[a] || group[a] != a)
        .collect();
    let mut volume = vec![0.0; seeds_len];
    let mut counted = Vec::new();
    for iteration in 0..=SEED_ITERATIONS {
        if done.iter().all(|&d| d) {
            break;
        }
        for (i, &k) in moved.iter().enumerate() {
            let b = bulge[group[disc[k] as usize]];
            x.set(k, base.get(k));
            if b > 0.0 {
                place(&mut x, i, k, b);
            }
        }
        // The pockets the cloth makes now; each group's volume, the pockets its particles lie
        // in (each counted once).
        remeasure(&mut measures, &x);
        let now = Pockets::at(air, model, &x, &measures, seed_of);
        volume.iter_mut().for_each(|v| *v = 0.0);
        counted.clear();
        counted.resize(now.pockets.len(), false);
        for &k in &moved {
            let q = now.particle_pocket[k];
            if q != NONE && !counted[q as usize] {
                counted[q as usize] = true;
                volume[group[disc[k] as usize]] += now.pockets[q as usize].volume;
            }
        }
        for a in 0..seeds_len {
            if done[a] {
                continue;
            }
            let (b, v, goal) = (bulge[a], volume[a], target[a]);
            if iteration == 0 {
                // The flat cloth's room; first guess: a cap of the footprints' bulge.
                lo[a] = (0.0, v);
                done[a] = goal <= v;
                bulge[a] = SEED_BULGE;
                continue;
            }
            if (v - goal).abs() <= SEED_TOLERANCE * goal || (v < goal && b >= MAX_BULGE) {
                // Solved, or the hemispheres hold too little: they stay, above atmospheric.
                done[a] = true;
                continue;
            }
            if v < goal {
                lo[a] = (b, v);
            } else {
                hi[a] = Some((b, v));
            }
            // The secant through the bracket's ends, kept inside it (bisection where not);
            // without an upper end yet, the secant from the bracket's low end, at least
            // doubling.
            let (b0, v0) = lo[a];
            let next = match hi[a] {
                Some((b1, v1)) => {
                    let t = b0 + (goal - v0) * (b1 - b0) / (v1 - v0);
                    if t > b0 && t < b1 { t } else { 0.5 * (b0 + b1) }
                }
                None if b > b0 => {
                    let t = b + (goal - v) * (b - b0) / (v - v0);
                    if t > b {
                        t.max(2.0 * b).min(4.0 * b)
                    } else {
                        2.0 * b
                    }
                }
                None => 2.0 * b,
            };
            bulge[a] = next.min(MAX_BULGE);
        }
    }
    x
}

/// How close a seeded pocket's volume at t = 0 comes to its amount, relative (`lift_seeds`):
/// its pressure starts within this share of atmospheric.
pub const SEED_TOLERANCE: Real = 1e-10;

/// The largest bulge (height over footprint radius) of a seeded pocket's cap before its
/// footprint widens beyond the seed's disc (`lift_seeds`): 0.1, the cloth stretched by 0.7 %.
pub const SEED_BULGE: Real = 0.1;

/// The largest bulge of a seeded pocket's caps ([`lift_seeds`]): hemispheres.
const MAX_BULGE: Real = 1.0;

/// Most measures of the cloth [`lift_seeds`] takes (a plane needs a handful).
const SEED_ITERATIONS: usize = 60;

/// The gap volume of each cell of `grid` at `x` against the colliders' surfaces, m^3, into
/// `out` (cell `(i, j)` at `j * (nx - 1) + i`), generalising eq. 3.10. Each of the cell's two
/// triangles is projected onto the contact surface (each corner moved by its height above
/// contact, `gap - radius`, along the surface's normal there), and the solid between the
/// triangle and its footprint is taken as a frustum: `h / 3 (A_t + A_b + sqrt(A_t A_b))`, `h`
/// the corners' mean height and `A_t`, `A_b` the triangle's and the footprint's areas projected
/// on their mean normal. On a plane the footprint has the triangle's projected area and this
/// is eq. 3.10's prism exactly; over a sphere, with the corners at one height, it is the
/// radial shell `Omega / 3 ((R + h)^3 - R^3)` of the footprint's cone up to the flat
/// triangles' sagitta, a relative error of order `(cell / R)^2`.
pub fn surface_cell_volumes(
    grid: &crate::model::Grid,
    x: &Soa,
    gap: &[Real],
    normal: &[crate::math::Vec3],
    radius: Real,
    out: &mut [Real],
) {
    let (nx, m) = (grid.nx, grid.nx - 1);
    let frustum = |a: usize, b: usize, c: usize| frustum(x, gap, normal, radius, a, b, c);
    for (c, v) in out.iter_mut().enumerate() {
        let (i, j) = (c % m, c / m);
        let a = j * nx + i;
        let (b, cc, d) = (a + 1, a + nx, a + nx + 1);
        // Counter-clockwise seen from above (+y for a cloth lying in x-z): (a, d, b), (a, c, d).
        *v = frustum(a, d, b) + frustum(a, cc, d);
    }
}

/// [`surface_cell_volumes`] for the cloth of `model`: the grid's cells, or a mesh's triangles
/// (each the frustum between it and its footprint on the surfaces).
fn surface_volumes(
    model: &Model,
    x: &Soa,
    gap: &[Real],
    normal: &[crate::math::Vec3],
    out: &mut [Real],
) {
    match model.layout() {
        Layout::Grid(grid) => surface_cell_volumes(grid, x, gap, normal, model.radius, out),
        Layout::Mesh(mesh, _) => {
            for (t, v) in out.iter_mut().enumerate() {
                let [a, b, c] = mesh.triangles[t].map(|k| k as usize);
                *v = frustum(x, gap, normal, model.radius, a, b, c);
            }
        }
    }
}

/// The solid between triangle `(a, b, c)` of `x` and its footprint on the surfaces (see
/// [`surface_cell_volumes`]), m^3.
fn frustum(
    x: &Soa,
    gap: &[Real],
    normal: &[crate::math::Vec3],
    radius: Real,
    a: usize,
    b: usize,
    c: usize,
) -> Real {
    // No sticky surface under a particle (an infinite gap): no volume to measure there.
    let height = |k: usize| {
        if gap[k].is_finite() {
            gap[k] - radius
        } else {
            0.0
        }
    };
    let (ha, hb, hc) = (height(a), height(b), height(c));
    let (na, nb, nc) = (normal[a], normal[b], normal[c]);
    let (pa, pb, pc) = (x.get(a), x.get(b), x.get(c));
    let (qa, qb, qc) = (pa - na * ha, pb - nb * hb, pc - nc * hc);
    let n = (na + nb + nc).normalize_or_zero();
    let top = 0.5 * (pb - pa).cross(pc - pa).dot(n);
    let bottom = 0.5 * (qb - qa).cross(qc - qa).dot(n);
    let mean = if top * bottom > 0.0 {
        top.signum() * (top * bottom).sqrt()
    } else {
        0.0
    };
    (ha + hb + hc) / 3.0 * (top + bottom + mean) / 3.0
}

/// The air's pressure difference (Pa) on the sealed particle `(i, j)` of an `nx` x `nz` grid:
/// the mean over the (up to four) cells around it of their pocket's difference (`pressure` of
/// the pocket's index), 0 for a cell in no pocket. The explicit step spreads the pockets'
/// pressures so; the implicit one too, a vacuum's as a known pressure and a pocket of air's as
/// its pressure at the step's end (`air::region`, `integrate::implicit`).
pub(crate) fn sealed_share(
    cell_pocket: &[u32],
    nx: usize,
    nz: usize,
    i: usize,
    j: usize,
    pressure: impl Fn(usize) -> Real,
) -> Real {
    let mut sum = 0.0;
    let mut count = 0.0;
    for c in cells_around(nx, nz, i, j) {
        count += 1.0;
        let cq = cell_pocket[c];
        if cq != NONE {
            sum += pressure(cq as usize);
        }
    }
    if count > 0.0 { sum / count } else { 0.0 }
}

/// The weights of [`sealed_share`]: `each(pocket, weight)` for every cell around particle
/// `(i, j)` that is in a pocket (a pocket met in two cells is named twice), the weight being
/// one over the number of cells around the particle (4 inside, 2 on a border, 1 at a corner).
pub(crate) fn sealed_weights(
    cell_pocket: &[u32],
    nx: usize,
    nz: usize,
    i: usize,
    j: usize,
    mut each: impl FnMut(usize, Real),
) {
    let count = cells_around(nx, nz, i, j).count();
    if count == 0 {
        return;
    }
    let w = 1.0 / count as Real;
    for c in cells_around(nx, nz, i, j) {
        let cq = cell_pocket[c];
        if cq != NONE {
            each(cq as usize, w);
        }
    }
}

/// The (up to four) cells around particle `(i, j)` of an `nx` x `nz` grid, by cell index.
fn cells_around(nx: usize, nz: usize, i: usize, j: usize) -> impl Iterator<Item = usize> + Clone {
    let m = nx - 1;
    [(i, j), (i.wrapping_sub(1), j), (i, j.wrapping_sub(1))]
        .into_iter()
        .chain([(i.wrapping_sub(1), j.wrapping_sub(1))])
        .filter(move |&(ci, cj)| ci < m && cj < nz - 1)
        .map(move |(ci, cj)| cj * m + ci)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::model::Grid;

    /// Solid angle of the flat triangle (a, b, c) seen from the origin (Van Oosterom and
    /// Strackee), sr.
    fn solid_angle(a: Vec3, b: Vec3, c: Vec3) -> Real {
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
        2.0 * num.atan2(den)
    }

    /// A cloth patch at one height `h` over a sphere of radius `big_r` (its particles of radius
    /// `r` touching at `big_r + r`): the cells' volumes add up to the radial shell
    /// `Omega / 3 ((R' + h)^3 - R'^3)`, `R' = big_r + r` and `Omega` the patch's solid angle.
    /// The flat triangles cut the sphere's cap by their sagitta: for cells of angular size
    /// `theta` the relative error is of order `theta^2`, below `theta^2` here.
    #[test]
    fn volume_over_a_sphere_is_the_radial_shell() {
        let (big_r, r, h) = (0.1, 0.001, 0.004);
        for n in [9, 17, 33] {
            let grid = Grid {
                nx: n,
                nz: n,
                dx: 1.0,
                dz: 1.0,
            };
            let half = 0.5; // the patch spans tan(angle) in [-0.5, 0.5] both ways
            let dir = |i: usize, j: usize| {
                let u = -half + 2.0 * half * i as Real / (n - 1) as Real;
                let v = -half + 2.0 * half * j as Real / (n - 1) as Real;
                Vec3::new(u, 1.0, v).normalize()
            };
            let top = big_r + r + h;
            let mut pts = Vec::new();
            let mut normal = Vec::new();
            let mut gap = Vec::new();
            for j in 0..n {
                for i in 0..n {
                    pts.push(dir(i, j) * top);
                    normal.push(dir(i, j));
                    gap.push(top - big_r);
                }
            }
            let x = Soa::from_vec3(&pts);
            let mut cells = vec![0.0; (n - 1) * (n - 1)];
            surface_cell_volumes(&grid, &x, &gap, &normal, r, &mut cells);
            let volume: Real = cells.iter().sum();
            let mut omega = 0.0;
            for j in 0..n - 1 {
                for i in 0..n - 1 {
                    let (a, b, c, d) = (dir(i, j), dir(i + 1, j), dir(i, j + 1), dir(i + 1, j + 1));
                    omega += solid_angle(a, d, b).abs() + solid_angle(a, c, d).abs();
                }
            }
            let rp = big_r + r;
            let shell = omega / 3.0 * ((rp + h).powi(3) - rp.powi(3));
            let theta = (2.0 * half).atan() / (n - 1) as Real;
            let error = (volume - shell).abs() / shell;
            assert!(
                error < theta * theta,
                "{n}: {volume} m^3 against the shell's {shell} ({error:.2e}, bound {:.2e})",
                theta * theta
            );
        }
    }

    /// On a plane the frustum is eq. 3.10's prism: a tilted, uneven triangle's volume is its
    /// projected area times its mean height.
    #[test]
    fn volume_over_a_plane_is_the_prism() {
        let grid = Grid {
            nx: 2,
            nz: 2,
            dx: 1.0,
            dz: 1.0,
        };
        let pts = [
            Vec3::new(0.0, 0.003, 0.0),
            Vec3::new(0.01, 0.005, 0.001),
            Vec3::new(-0.001, 0.002, 0.012),
            Vec3::new(0.011, 0.004, 0.01),
        ];
        let x = Soa::from_vec3(&pts);
        let gap: Vec<Real> = pts.iter().map(|p| p.y).collect();
        let r = 0.0005;
        let mut v = [0.0];
        surface_cell_volumes(&grid, &x, &gap, &[Vec3::Y; 4], r, &mut v);
        let prism = |a: Vec3, b: Vec3, c: Vec3| {
            0.5 * (b - a).cross(c - a).y * ((a.y + b.y + c.y) / 3.0 - r)
        };
        let expect = prism(pts[0], pts[3], pts[1]) + prism(pts[0], pts[2], pts[3]);
        assert!((v[0] - expect).abs() < 1e-15, "{} against {expect}", v[0]);
    }

    /// A sealed particle's share of the pockets around it, by weights (the implicit step's
    /// rims) and by the mean over its cells (the explicit step's): the same, to round-off, on
    /// a 5 x 4 grid of cells labelled by three pockets and none, at every particle (inner: four
    /// cells, border: two, corner: one). With every cell in one pocket the weights sum to one.
    #[test]
    fn sealed_weights_give_the_sealed_share() {
        let (nx, nz) = (6, 5);
        let cells: Vec<u32> = (0..(nx - 1) * (nz - 1))
            .map(|c| match (c * 7) % 4 {
                3 => NONE,
                q => q as u32,
            })
            .collect();
        let pressure = |q: usize| [120.0, -101_325.0, 35.5][q];
        for j in 0..nz {
            for i in 0..nx {
                let mut by_weights = 0.0;
                sealed_weights(&cells, nx, nz, i, j, |q, w| by_weights += w * pressure(q));
                let mean = sealed_share(&cells, nx, nz, i, j, pressure);
                assert!(
                    (by_weights - mean).abs() <= 1e-12 * mean.abs().max(1.0),
                    "({i}, {j}): {by_weights} against {mean}"
                );
                let one = vec![0; cells.len()];
                let mut total = 0.0;
                sealed_weights(&one, nx, nz, i, j, |_, w| total += w);
                assert!((total - 1.0).abs() < 1e-15, "({i}, {j}): {total}");
            }
        }
    }
}
