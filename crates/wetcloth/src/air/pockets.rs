//! Sealed air pockets (`[air] model = "pockets"`): the air under a wet cloth as separate
//! pockets that form, merge, split, leak and open at the rim. The thesis treats all the air as
//! one bubble and names that as the limit to lift (ch. 5).
//!
//! # Sealing and regions
//!
//! A particle *seals* when it touches a collider (its centre within its radius plus
//! `seal_distance` of the surface) and its wetness is at least `seal_wetness`: water closes the
//! gap there. Dry cloth never seals. A particle inside a pocket whose air pushes out (pressure
//! above atmospheric) does not seal: the air holds the cloth off the surface.
//!
//! The cloth's cells (the grid's quads) with an unsealed corner hold air. Air passes between
//! two neighbouring cells across their shared edge unless both of its particles are sealed, so
//! the air cells form connected regions (union-find, each step, linear cost). A region that
//! reaches the cloth's border across an edge with an unsealed particle is **open**: at
//! atmospheric pressure, no force. Every other region is a **sealed pocket** `k` with its amount
//! of air `N_k` (m^3 at atmospheric pressure), its volume `V_k` (eq. 3.10 over its cells) and
//! its pressure `P_k = P_a N_k / V_k` (Boyle).
//!
//! # Events conserve air
//!
//! Each step the regions are found again and matched to the pockets of the step before by the
//! cells they share. A new pocket takes, from every old pocket, the old pocket's air in
//! proportion to the volume of the old pocket's cells it now holds, plus the volume of the cells
//! that held no sealed air before (air enclosed now, at atmospheric pressure). So a pocket that
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
use super::{AirLoad, Timing};
use crate::control::Control;
use crate::math::{Real, Soa};
use crate::measure::Measures;
use crate::model::Model;
use crate::params::{AirParams, PressureSolve};
use crate::state::State;

/// No pocket (an open region, a sealed cell, a sealed particle).
pub const NONE: u32 = u32::MAX;

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
    /// Whether each particle touches a collider (within its radius): a sealed particle that
    /// does not is where a rim is close to opening.
    touching: Vec<bool>,
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
}

impl Pockets {
    /// The pockets of the cloth at t = 0 in `state`: sealed where it touches, pockets of the
    /// enclosed air at atmospheric pressure, and the seeded pockets of `air.pockets` holding
    /// their amounts.
    pub(crate) fn new(air: &AirParams, model: &Model, state: &State, measures: &Measures) -> Self {
        let n = model.grid.len();
        let cells = (model.grid.nx - 1) * (model.grid.nz - 1);
        let mut p = Self {
            pockets: Vec::new(),
            sealed: vec![false; n],
            cell_pocket: vec![NONE; cells],
            particle_pocket: vec![NONE; n],
            touching: vec![false; n],
            delta_p: vec![0.0; n],
            pending: None,
            next_id: 1,
            scratch: Scratch::default(),
        };
        // The seeded particles start unsealed, and their regions hold the seeds' air.
        let rest = model.grid.rest_positions(crate::math::Vec3::ZERO);
        let seed_of = |k: usize| {
            air.pockets.iter().position(|s| {
                let (dx, dz) = (rest.x[k] - s.center[0], rest.z[k] - s.center[1]);
                dx * dx + dz * dz <= s.radius * s.radius
            })
        };
        p.seal(air, model, state, |k| seed_of(k).is_none());
        p.resegment(air, model, measures, true);
        // Seeded regions: their air is the seeds' amount.
        let mut seeded = vec![0.0; p.pockets.len()];
        let mut has_seed = vec![false; p.pockets.len()];
        for (si, s) in air.pockets.iter().enumerate() {
            let pocket = (0..n)
                .filter(|&k| seed_of(k) == Some(si))
                .map(|k| p.particle_pocket[k])
                .find(|&q| q != NONE);
            if let Some(q) = pocket {
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

    /// Total volume of the sealed pockets, m^3.
    pub fn volume(&self) -> Real {
        self.pockets.iter().map(|p| p.volume).sum()
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
            .map(|p| p.pressure * p.volume)
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
        let implicit = control.air_enabled
            && air.pressure_solve == PressureSolve::Implicit
            && !self.pockets.is_empty();
        if implicit {
            self.pending = Some(Pending {
                dt,
                first_step: state.steps == 0,
            });
            Timing::EndOfStep
        } else {
            self.pending = None;
            let pa = air.atmospheric_pressure;
            let pressures: Vec<Real> = self
                .pockets
                .iter()
                .map(|p| {
                    if control.air_enabled {
                        p.pressure - pa
                    } else {
                        0.0
                    }
                })
                .collect();
            self.spread(model, &pressures);
            Timing::Now
        }
    }

    /// The load of the step: each particle's pressure difference.
    pub(crate) fn load(&self) -> AirLoad<'_> {
        if self.pockets.is_empty() {
            AirLoad::Uniform(0.0)
        } else {
            AirLoad::PerParticle(&self.delta_p)
        }
    }

    /// Solves each pocket's end-of-step pressure from the coasting positions `coast` (m) and
    /// their cell volumes in `coast_measures` (see the module docs and `air::bubble::EndOfStep`).
    pub(crate) fn solve_end_of_step(
        &mut self,
        air: &AirParams,
        model: &Model,
        coast: &Soa,
        coast_measures: &Measures,
        held: &[bool],
    ) {
        let Some(pending) = self.pending.take() else {
            return;
        };
        let Some(plane) = model.sticking else {
            return;
        };
        let pa = air.atmospheric_pressure;
        let s = model.area_per_particle;
        let up = plane.up;
        let contact = up.dot(plane.point) + model.radius;
        let gap = |i: usize| up.x * coast.x[i] + up.y * coast.y[i] + up.z * coast.z[i] - contact;
        let first = if pending.first_step { 0.5 } else { 1.0 };
        let h_of = |i: usize| pending.dt * pending.dt / model.mass(i) * first;
        let m = model.grid.nx - 1;
        // Each pocket's coasting volume: its cells', plus the depth of its particles coasting
        // into the surface (the contact pushes them back out).
        let mut base = vec![0.0; self.pockets.len()];
        for (c, &q) in self.cell_pocket.iter().enumerate() {
            if q != NONE {
                base[q as usize] += coast_measures.cells[(c / m) * m + c % m];
            }
        }
        for (i, &q) in self.particle_pocket.iter().enumerate() {
            let g = gap(i);
            if q != NONE && g < 0.0 && !held[i] {
                base[q as usize] -= s * g;
            }
        }
        let mut pressures = Vec::with_capacity(self.pockets.len());
        for (q, pocket) in self.pockets.iter().enumerate() {
            let k = pa * pocket.amount;
            let members = |i: &usize| self.particle_pocket[*i] == q as u32 && !held[*i];
            let volume = |p: Real| {
                let (mut v, mut slope) = (base[q], 0.0);
                for i in (0..coast.len()).filter(members) {
                    let h = h_of(i);
                    let push = h * s * (p - pa);
                    let g = gap(i).max(0.0);
                    if push >= 0.0 || -push < g {
                        v += s * push;
                        slope += h * s * s;
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
        self.spread(model, &pressures);
    }

    /// Sets each particle's pressure difference from the pockets' `pressures` (Pa, one per
    /// pocket): the pocket's for a particle inside it, the mean of the cells around it for a
    /// sealed particle.
    fn spread(&mut self, model: &Model, pressures: &[Real]) {
        let (nx, nz) = (model.grid.nx, model.grid.nz);
        let m = nx - 1;
        for j in 0..nz {
            for i in 0..nx {
                let k = j * nx + i;
                let q = self.particle_pocket[k];
                self.delta_p[k] = if q != NONE {
                    pressures[q as usize]
                } else if self.sealed[k] {
                    let mut sum = 0.0;
                    let mut count = 0.0;
                    for (ci, cj) in [(i, j), (i.wrapping_sub(1), j), (i, j.wrapping_sub(1))]
                        .into_iter()
                        .chain([(i.wrapping_sub(1), j.wrapping_sub(1))])
                    {
                        if ci < m && cj < nz - 1 {
                            count += 1.0;
                            let cq = self.cell_pocket[cj * m + ci];
                            if cq != NONE {
                                sum += pressures[cq as usize];
                            }
                        }
                    }
                    if count > 0.0 { sum / count } else { 0.0 }
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
        self.measure_volumes(model, measures);
        for pocket in &mut self.pockets {
            let floor = MIN_GAP * pocket.area;
            let v = pocket.volume.max(floor);
            if pocket.permeability > 0.0 && pa > 0.0 {
                let rate = pocket.permeability * pocket.area * pa / v;
                pocket.amount = v + (pocket.amount - v) * (-rate * dt).exp();
            }
            if air.leak_conductance > 0.0 && pa > 0.0 && pocket.rim_open > 0.0 {
                let p = pa * pocket.amount / v;
                let flow = super::leak::border_flow(air.leak_conductance, pocket.rim_open, pa, p);
                pocket.amount = (pocket.amount + flow * dt).max(0.0);
            }
        }
        self.update_pressures(air);
        // Seal again; a particle inside a pocket that pushes out stays unsealed.
        let pushing: Vec<bool> = self.pockets.iter().map(|p| p.pressure > pa).collect();
        let old_pocket = self.particle_pocket.clone();
        self.seal(air, model, state, |k| {
            old_pocket[k] == NONE || !pushing[old_pocket[k] as usize]
        });
        self.resegment(air, model, measures, false);
        self.update_pressures(air);
    }

    /// Marks the particles that seal in `state`: wet enough and within `seal_distance` beyond
    /// their radius of a collider's surface, where `may_seal(k)` allows.
    fn seal(
        &mut self,
        air: &AirParams,
        model: &Model,
        state: &State,
        may_seal: impl Fn(usize) -> bool,
    ) {
        let reach = model.radius + air.seal_distance;
        for k in 0..state.len() {
            let p = state.x.get(k);
            let gap = model
                .colliders
                .iter()
                .map(|c| c.distance(p).0)
                .fold(Real::INFINITY, Real::min);
            self.touching[k] = gap <= model.radius;
            self.sealed[k] = model.wetness[k] >= air.seal_wetness && gap <= reach && may_seal(k);
        }
    }

    /// The volumes of the current pockets' cells in `measures`, and their rims' open length.
    fn measure_volumes(&mut self, model: &Model, measures: &Measures) {
        let m = model.grid.nx - 1;
        for p in &mut self.pockets {
            p.volume = 0.0;
        }
        for (c, &q) in self.cell_pocket.iter().enumerate() {
            if q != NONE {
                self.pockets[q as usize].volume += measures.cells[(c / m) * m + c % m];
            }
        }
    }

    /// Boyle's pressure of every pocket.
    fn update_pressures(&mut self, air: &AirParams) {
        let pa = air.atmospheric_pressure;
        for p in &mut self.pockets {
            p.pressure = pa * p.amount / p.volume.max(MIN_GAP * p.area);
        }
    }

    /// Finds the regions of the sealed state, and the new pockets with their air (see the
    /// module docs). `fresh`: at t = 0, every pocket takes the air it encloses.
    fn resegment(&mut self, air: &AirParams, model: &Model, measures: &Measures, fresh: bool) {
        let grid = &model.grid;
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
        fn find(parent: &mut [u32], mut a: u32) -> u32 {
            while parent[a as usize] != a {
                let up = parent[parent[a as usize] as usize];
                parent[a as usize] = up;
                a = up;
            }
            a
        }
        fn union(parent: &mut [u32], a: u32, b: u32) {
            let (ra, rb) = (find(parent, a), find(parent, b));
            // The smaller index is the root, so roots are canonical whatever the order.
            if ra < rb {
                parent[rb as usize] = ra;
            } else if rb < ra {
                parent[ra as usize] = rb;
            }
        }
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
        let mut root_region: Vec<(u32, u32)> = Vec::new(); // (root, region)
        let mut open: Vec<bool> = Vec::new();
        for j in 0..nz - 1 {
            for i in 0..m {
                if !air_cell(i, j) {
                    continue;
                }
                let c = j * m + i;
                let root = find(&mut sc.parent, c as u32);
                let r = match root_region.iter().find(|(rt, _)| *rt == root) {
                    Some(&(_, r)) => r,
                    None => {
                        let r = open.len() as u32;
                        root_region.push((root, r));
                        open.push(false);
                        r
                    }
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
            volume[r as usize] += measures.cells[j * m + i];
            count[r as usize] += 1;
            let k = j * nx + i;
            kappa[r as usize] += 0.25
                * (wet_kappa(k) + wet_kappa(k + 1) + wet_kappa(k + nx) + wet_kappa(k + nx + 1));
        }
        // Air of the new pockets: shares of the old pockets, plus newly enclosed air.
        sc.overlaps.clear();
        let mut enclosed = vec![0.0; regions];
        let mut old_volume = vec![0.0; self.pockets.len()];
        for c in 0..cells {
            let (r, old) = (sc.region[c], self.cell_pocket[c]);
            let v = measures.cells[c];
            if old != NONE {
                old_volume[old as usize] += v;
            }
            if r == NONE || open[r as usize] {
                continue;
            }
            if old == NONE || fresh {
                enclosed[r as usize] += v;
            } else {
                sc.overlaps.push((old, r, v, 1));
            }
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
        let mut old_cells = vec![0u32; self.pockets.len()];
        for c in 0..cells {
            let old = self.cell_pocket[c];
            if old != NONE {
                old_cells[old as usize] += 1;
            }
        }
        for &(old, r, v, n) in &sc.overlaps {
            let o = &self.pockets[old as usize];
            let share = if old_volume[old as usize] > MIN_GAP * o.area {
                v / old_volume[old as usize]
            } else {
                Real::from(n) / Real::from(old_cells[old as usize].max(1))
            };
            amount[r as usize] += o.amount * share.clamp(0.0, 1.0);
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
                area: Real::from(count[r]) * cell_area,
                particles: 0,
                permeability: kappa[r] / Real::from(count[r].max(1)),
                rim_open: 0.0,
            });
        }
        for c in 0..cells {
            let r = sc.region[c];
            self.cell_pocket[c] = if r == NONE {
                NONE
            } else {
                region_pocket[r as usize]
            };
        }
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
        // Rims close to opening: sealed corners of a pocket's cells that do not touch.
        let spacing = 0.5 * (grid.dx + grid.dz);
        for c in 0..cells {
            let q = self.cell_pocket[c];
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
                    pockets[q as usize].rim_open += 0.25 * spacing;
                }
            }
        }
        self.pockets = pockets;
    }
}
