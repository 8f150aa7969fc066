//! Position Verlet (thesis eq. 3.1) on a cloth of any shape: the general path of
//! [`super::verlet`], chosen once per step when the cloth is a mesh.
//!
//! The same step as the grid's, by blocks of particles instead of rows: the forces (gravity
//! and damping, the mesh's springs, the pressure over each particle's lumped area along its
//! area-weighted normal), the move, the contacts, then the hand. One pass does the forces,
//! the move and the plane contacts block by block, computing just before each block the
//! springs it needs (the springs ordered by their larger end, so that those are one run), while
//! the block and its springs are in cache; seams, soft attachments, a pressure of the step's
//! end and colliders other than planes take their own passes after it. Each particle's force
//! is gathered from its own springs in a fixed order (no scattered sums), so the passes split
//! over threads give the same bits as one thread.

use super::{Air, Fused};
use crate::air::{AirLoad, Timing};
use crate::checks;
use crate::collide::contact;
use crate::collide::plane;
use crate::control::Control;
use crate::forces::fabric::{Fabric, FabricScratch};
use crate::forces::gravity;
use crate::forces::mesh_spring::MeshSprings;
use crate::math::{Real, RowMut, Soa, Vec3, row};
use crate::measure::Measures;
use crate::model::{ClothMesh, Layout, Model};
use crate::params::PressureForce;
use crate::state::{Motion, State};
use rayon::prelude::*;

/// Particles per task when a pass is split over the pool.
const CHUNK: usize = 2048;

/// Particles per block of the fused pass: the springs a block needs are computed just before
/// it, so they and its particles are still in cache when it gathers them.
const BLOCK: usize = 64;

/// What the fused pass reads.
struct PassConsts<'a> {
    model: &'a Model,
    springs: &'a MeshSprings,
    /// Positions at the step's start, m.
    x: &'a Soa,
    /// The fabric and its elements' forces of the step, if any.
    fabric: Option<(&'a Fabric, &'a FabricScratch)>,
    /// The pressure forces to add before the move, N.
    pressure: Option<&'a Soa>,
    /// Whether the pass moves the particles (nothing else adds to their forces first).
    moves: bool,
    /// Whether the pass resolves the contacts (only planes, no exempt particles).
    collides: bool,
    /// `dt^2`, halved on a Taylor start, s^2.
    dt2: Real,
    /// `damping / dt`, 1/s^2.
    damping_per_dt: Real,
}

/// The fused pass over the particles `s..s + force.x.len()`: block by block, the springs
/// the block needs ([`MeshSprings::run_forces`] into `buf`, each computed once per part),
/// each particle's force (gravity and damping, springs, fabric, pressure, in that order) into
/// `force`, and, if `c.moves`, its move into `to` (holding the previous positions) and, if
/// `c.collides`, its contacts with the planes. Each particle's result does not depend on how
/// the particles are split into parts.
fn pass(
    c: &PassConsts<'_>,
    s: usize,
    force: RowMut<'_>,
    to: RowMut<'_>,
    contact: &mut [bool],
    buf: &mut Vec<Vec3>,
) {
    let e = s + force.x.len();
    let (model, springs, x) = (c.model, c.springs, c.x);
    let span = springs.run_span(s..e);
    if buf.len() < 2 * span.len() {
        buf.resize(2 * span.len(), Vec3::ZERO);
    }
    let mut done = span.start;
    let RowMut {
        x: fx,
        y: fy,
        z: fz,
    } = force;
    let RowMut {
        x: px,
        y: py,
        z: pz,
    } = to;
    let mut sums = [Vec3::ZERO; BLOCK];
    let mut b0 = s;
    while b0 < e {
        let b1 = (b0 + BLOCK).min(e);
        let need = springs.run_span(b0..b1).end;
        if need > done {
            springs.run_forces(x, done..need, &mut buf[2 * (done - span.start)..]);
            done = need;
        }
        let sums = &mut sums[..b1 - b0];
        springs.gather_block(buf, span.start, b0, sums);
        for k in b0..b1 {
            let i = k - s;
            let here = x.get(k);
            let before = Vec3::new(px[i], py[i], pz[i]);
            let m = model.mass(k);
            let mut f =
                gravity::weight_and_damping(m, model.gravity, c.damping_per_dt, here - before)
                    + sums[k - b0];
            if let Some((fabric, fs)) = c.fabric {
                f += fabric.gather(fs, k);
            }
            if let Some(p) = c.pressure {
                f += p.get(k);
            }
            (fx[i], fy[i], fz[i]) = (f.x, f.y, f.z);
            if c.moves {
                let h = c.dt2 / m;
                let next = here + (here - before) + f * h;
                (px[i], py[i], pz[i]) = (next.x, next.y, next.z);
            }
        }
        if c.collides {
            let (i0, i1) = (b0 - s, b1 - s);
            let hit = &mut contact[i0..i1];
            hit.fill(false);
            let here = crate::math::RowRef {
                x: &x.x[b0..b1],
                y: &x.y[b0..b1],
                z: &x.z[b0..b1],
            };
            let mut next = RowMut {
                x: &mut px[i0..i1],
                y: &mut py[i0..i1],
                z: &mut pz[i0..i1],
            };
            let scale = model.friction_scale.as_deref().map(|f| &f[b0..b1]);
            for p in &model.planes {
                plane::contact_row_scaled(p, here, &mut next, hit, scale);
            }
        }
        b0 = b1;
    }
}

/// Scratch of the mesh path.
#[derive(Clone, Debug, Default)]
pub(crate) struct MeshVerlet {
    /// Force on each particle during the last step (without the hand), N.
    pub force: Soa,
    /// The pressure force of the step, N (end-of-step pressure).
    pressure: Soa,
    /// Each part's springs' forces on their two ends (run order), N.
    bufs: Vec<Vec<Vec3>>,
    /// The membrane and bending elements' forces (`model = "membrane"`).
    fabric: FabricScratch,
    /// The grabbed particles' previous positions, m.
    saved_prev: Vec<Vec3>,
    /// The measures of the coasting positions.
    coast: Measures,
}

/// Applies `f(k) -> Vec3` to every particle, writing into `out`, on the pool for large cloths.
fn for_each(out: &mut Soa, parallel: bool, f: impl Fn(usize) -> Vec3 + Sync) {
    let n = out.len();
    if parallel && n > CHUNK {
        let (xs, ys, zs) = (&mut out.x, &mut out.y, &mut out.z);
        xs.par_chunks_mut(CHUNK)
            .zip(ys.par_chunks_mut(CHUNK))
            .zip(zs.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, ((x, y), z))| {
                for i in 0..x.len() {
                    let v = f(c * CHUNK + i);
                    (x[i], y[i], z[i]) = (v.x, v.y, v.z);
                }
            });
    } else {
        for k in 0..n {
            let v = f(k);
            out.set(k, v);
        }
    }
}

/// The pressure force on particle `k` at positions `x` per pascal of `P_b - P_a`, N/Pa: the
/// thesis' `S N` (lumped area, area-weighted unit normal), or the area vector (a third of
/// each triangle's vector area around it) by `[air] pressure_force = "area"`.
#[inline]
pub(crate) fn pressure_per_pascal(mesh: &ClothMesh, law: PressureForce, x: &Soa, k: usize) -> Vec3 {
    match law {
        PressureForce::Thesis => mesh.normal(x, k) * mesh.area[k],
        PressureForce::Area => {
            let mut a = Vec3::ZERO;
            for &t in mesh.triangles_of(k) {
                a += mesh.triangle_cross(x, t as usize);
            }
            a / 6.0
        }
    }
}

/// The contacts (eq. 3.4-3.5: normal force and Coulomb friction, planes on the vectorised row,
/// other shapes and moving ones particle by particle) of the moves from `x` to `next`, which
/// they correct; `contact` flags the particles that touched. Returns the moving colliders'
/// work on the cloth (magnitudes summed, J; `dt2` the step's `dt^2`, halved on a Taylor start).
pub(crate) fn resolve_contacts(
    model: &Model,
    x: &Soa,
    next: &mut Soa,
    contact: &mut [bool],
    frames: &[contact::Frames],
    dt2: Real,
) -> Real {
    let n = x.len();
    let scale = model.friction_scale.as_deref();
    let [plane_ids, still_ids, moving_ids] = &model.contact_ids;
    contact.fill(false);
    // A soft attachment's particles keep their moves through the collider they are attached to.
    let mut kept: Vec<(usize, Vec3, bool)> = Vec::new();
    for (p, &id) in model.planes.iter().zip(plane_ids) {
        kept.clear();
        kept.extend(
            (0..model.contact_exempt.len())
                .filter(|&k| model.contact_exempt[k] == id)
                .map(|k| (k, next.get(k), contact[k])),
        );
        let here = row(x, n, 0);
        let mut to = RowMut {
            x: &mut next.x[..],
            y: &mut next.y[..],
            z: &mut next.z[..],
        };
        plane::contact_row_scaled(p, here, &mut to, contact, scale);
        for &(k, v, c) in &kept {
            next.set(k, v);
            contact[k] = c;
        }
    }
    let mut work = 0.0;
    if !model.non_planes.is_empty() || !model.moving.is_empty() {
        for k in 0..n {
            let now = x.get(k);
            let mut to = next.get(k);
            let f = scale.map_or(1.0, |s| s[k]);
            let skip = model.exempt_collider(k).map(|c| c as u32);
            if !model.non_planes.is_empty() {
                // Each collider corrects the move in turn: without the exempt one, the two
                // runs around it.
                let split = skip
                    .and_then(|c| still_ids.iter().position(|&i| i == c))
                    .unwrap_or(model.non_planes.len());
                let (before, after) = model.non_planes.split_at(split);
                let after = after.get(1..).unwrap_or(&[]);
                for part in [before, after] {
                    let (moved, hit) = contact::resolve_scaled(part, now, to, model.radius, f);
                    to = moved;
                    contact[k] |= hit;
                }
            }
            for ((col, frames), &id) in model.moving.iter().zip(frames).zip(moving_ids) {
                if skip == Some(id) {
                    continue;
                }
                let (moved, hit, w) = contact::resolve_moving(
                    col,
                    frames,
                    now,
                    to,
                    model.radius,
                    f,
                    model.mass(k),
                    dt2,
                );
                to = moved;
                contact[k] |= hit;
                work += w.abs();
            }
            next.set(k, to);
        }
    }
    // Rounded to the picojoule, as the grid's pass sums it.
    (work * 1e12).round() * 1e-12
}

/// The end of a mesh step: the new positions `x` measured into `fused.measures`, and the largest
/// squared distance (m^2) of a particle no hand holds (`held`) from `fused.reference` (0
/// without one).
pub(crate) fn finish_step(model: &Model, x: &Soa, held: &[bool], fused: Fused<'_>) -> Real {
    fused.measures.remeasure_mesh(
        model.layout(),
        x,
        model.sticking,
        model.radius,
        crate::exec::use_pool(x.len()),
    );
    match fused.reference {
        Some(reference) => (0..x.len())
            .filter(|&k| !held[k])
            .map(|k| (x.get(k) - reference.get(k)).length_squared())
            .fold(0.0, Real::max),
        None => 0.0,
    }
}

impl MeshVerlet {
    /// Scratch for `n` particles of `layout`.
    pub fn new(layout: Layout<'_>, n: usize) -> Self {
        Self {
            force: Soa::zeros(n),
            pressure: Soa::zeros(n),
            bufs: Vec::new(),
            fabric: FabricScratch::default(),
            saved_prev: Vec::new(),
            coast: Measures::for_layout(layout, false),
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.force.heap_bytes()
            + self.pressure.heap_bytes()
            + self.bufs.iter().map(|b| b.capacity() * 24).sum::<usize>()
            + self.fabric.heap_bytes()
            + self.saved_prev.capacity() * 24
            + self.coast.heap_bytes()
    }

    /// One step of `dt` s on a mesh cloth (see the module docs). Returns the largest squared
    /// distance (m^2) of a new position from `fused.reference` (0 without one).
    #[allow(clippy::too_many_arguments)] // the step's parts, as the grid's pass takes them
    pub fn step(
        &mut self,
        model: &Model,
        mesh: &ClothMesh,
        springs: &MeshSprings,
        state: &mut State,
        control: &mut Control,
        mut air: Air<'_>,
        dt: Real,
        fused: Fused<'_>,
    ) -> Real {
        state.use_previous_positions(dt);
        let Motion::Previous(prev) = &mut state.motion else {
            unreachable!("converted above")
        };
        let n = mesh.len();
        let parallel = fused.rows_per_task.is_some() || n >= 4 * CHUNK;
        self.saved_prev.clear();
        self.saved_prev
            .extend(control.grabs.iter().map(|g| prev.get(g.particle)));
        let first = if state.steps == 0 { 0.5 } else { 1.0 };
        let dt2 = dt * dt * first;
        let t = state.steps as Real * dt;
        let frames: Vec<contact::Frames> = model
            .moving
            .iter()
            .map(|c| contact::Frames::of(c, t, dt))
            .collect();
        let x = &state.x;
        let damping_per_dt = model.damping / dt;
        let law = model.pressure_force;
        // The membrane and bending elements' forces, element by element (gathered below).
        if let Some(fabric) = &model.fabric {
            fabric.forces_into(x, &mut self.fabric, parallel);
        }
        // The pressure (eq. 3.7): of the step's start, or of its end from the coasting
        // positions.
        // The load borrowed from the air model, no copy: one difference, or one per particle.
        fn load_of<'b>(air: &'b Air<'_>) -> (Real, Option<&'b [Real]>) {
            match air.model.load(air.params) {
                AirLoad::Uniform(p) => (p, None),
                AirLoad::PerParticle(p) => (1.0, Some(p)),
            }
        }
        let pressure_now = |pressure: &mut Soa, p: Real, each: Option<&[Real]>| {
            for_each(pressure, parallel, |k| {
                let dp = each.map_or(p, |e| e[k]);
                if dp == 0.0 {
                    Vec3::ZERO
                } else {
                    pressure_per_pascal(mesh, law, x, k) * dp
                }
            });
        };
        let now = matches!(air.timing, Timing::Now);
        let mut pressure_acts = true;
        if now {
            let (p, each) = load_of(&air);
            pressure_acts = p != 0.0 || each.is_some();
            if pressure_acts {
                pressure_now(&mut self.pressure, p, each);
            }
        }
        // Every force but the seams', the attachments' and a pressure of the step's end
        // (gravity and damping, eq. 3.3; springs, eq. 3.6) in one pass over blocks of
        // particles; when nothing else adds to a particle's force before its move, the pass
        // moves it too, and when only planes are there to meet, resolves its contacts.
        let moves = now && model.seams.is_none() && control.tethers.is_empty();
        let collides = moves
            && model.non_planes.is_empty()
            && model.moving.is_empty()
            && model.contact_exempt.is_empty();
        {
            let c = PassConsts {
                model,
                springs,
                x,
                fabric: model.fabric.as_deref().map(|f| (f, &self.fabric)),
                pressure: (moves && pressure_acts).then_some(&self.pressure),
                moves,
                collides,
                dt2,
                damping_per_dt,
            };
            let parts = if parallel {
                rayon::current_num_threads().max(1)
            } else {
                1
            };
            let per = n.div_ceil(parts).max(1);
            self.bufs.resize_with(parts, Vec::new);
            let force = &mut self.force;
            let prev: &mut Soa = prev;
            if parts == 1 {
                pass(
                    &c,
                    0,
                    RowMut {
                        x: &mut force.x[..],
                        y: &mut force.y[..],
                        z: &mut force.z[..],
                    },
                    RowMut {
                        x: &mut prev.x[..],
                        y: &mut prev.y[..],
                        z: &mut prev.z[..],
                    },
                    &mut state.contact,
                    &mut self.bufs[0],
                );
            } else {
                (
                    force.x.par_chunks_mut(per),
                    force.y.par_chunks_mut(per),
                    force.z.par_chunks_mut(per),
                    prev.x.par_chunks_mut(per),
                    prev.y.par_chunks_mut(per),
                    prev.z.par_chunks_mut(per),
                    state.contact.par_chunks_mut(per),
                    self.bufs.par_iter_mut(),
                )
                    .into_par_iter()
                    .enumerate()
                    .for_each(|(i, (fx, fy, fz, px, py, pz, contact, buf))| {
                        let f = RowMut {
                            x: fx,
                            y: fy,
                            z: fz,
                        };
                        let to = RowMut {
                            x: px,
                            y: py,
                            z: pz,
                        };
                        pass(&c, i * per, f, to, contact, buf);
                    });
            }
        }
        if !moves {
            // The seams' springs and damping (velocities as the damping above takes them).
            if let Some(seams) = &model.seams {
                let prev: &Soa = prev;
                seams.add_forces(x, |k| (x.get(k) - prev.get(k)) / dt, &mut self.force);
            }
            // The soft attachments' springs to their points at the step's start.
            for t in &mut control.tethers {
                let k = t.particle;
                t.force = t.pull(x.get(k), t.points[0]);
                self.force.set(k, self.force.get(k) + t.force);
            }
            match air.timing {
                Timing::Now => {
                    for k in 0..n {
                        let mut f = self.force.get(k);
                        if pressure_acts {
                            f += self.pressure.get(k);
                            self.force.set(k, f);
                        }
                        let h = dt2 / model.mass(k);
                        let (here, before) = (x.get(k), prev.get(k));
                        prev.set(k, here + (here - before) + f * h);
                    }
                }
                Timing::EndOfStep => {
                    for k in 0..n {
                        let h = dt2 / model.mass(k);
                        let (here, before) = (x.get(k), prev.get(k));
                        prev.set(k, here + (here - before) + self.force.get(k) * h);
                    }
                    for (k, target) in control.active() {
                        prev.set(k, target);
                    }
                    air.solve_at_end(
                        model,
                        prev,
                        &mut self.coast,
                        fused.measures.keep_cells,
                        &control.held,
                        crate::exec::use_pool(n).then_some(CHUNK),
                    );
                    let (p, each) = load_of(&air);
                    pressure_now(&mut self.pressure, p, each);
                    for k in 0..n {
                        let fp = self.pressure.get(k);
                        self.force.set(k, self.force.get(k) + fp);
                        prev.set(k, prev.get(k) + fp * (dt2 / model.mass(k)));
                    }
                }
            }
        }
        // Contacts (eq. 3.4-3.5) of the moves from `x` to `prev`, unless the pass took them.
        if !collides {
            control.collider_work +=
                resolve_contacts(model, x, prev, &mut state.contact, &frames, dt2);
        }
        let p = prev;
        std::mem::swap(&mut state.x, p);
        if pressure_acts {
            // The pressure force's work over the step's moves (its share of the energy audit).
            let mut w = 0.0;
            for k in 0..n {
                w += self.pressure.get(k).dot(state.x.get(k) - p.get(k));
            }
            control.air_work += (w.abs() * 1e12).round() * 1e-12;
        }
        // The hand (thesis 3.2 step 3).
        let mut hand = 0.0;
        for (g, (target, before)) in control
            .grabs
            .iter_mut()
            .zip(control.targets.iter().zip(&self.saved_prev))
        {
            let k = g.particle;
            match target {
                Some(target) => {
                    let accel = (*target - 2.0 * p.get(k) + *before) * (model.mass(k) / (dt * dt));
                    g.force = accel - self.force.get(k);
                    hand += checks::work(g.force, p.get(k), *target).abs();
                    state.x.set(k, *target);
                }
                None => g.force = Vec3::ZERO,
            }
        }
        for t in &control.tethers {
            let k = t.particle;
            hand += checks::work(t.force, p.get(k), state.x.get(k)).abs();
        }
        control.hand_work += hand;
        finish_step(model, &state.x, &control.held, fused)
    }
}
