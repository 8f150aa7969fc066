//! Backward Euler on a cloth of any shape: the implicit integrator's general path, chosen
//! once per step when the cloth is a mesh (the grid keeps `implicit/`, with its stencil
//! matrix, geometric multigrid and friction inside the solve).
//!
//! One linearised step (Baraff and Witkin): with `H` the springs' stiffness (each spring's
//! `k (1 - L / l) (I - d d^T) + k d d^T`, its first term dropped while the spring is shorter
//! than its rest length, so `H` is positive semi-definite) the new velocity solves
//!
//! `(M (1 + dt c) + dt^2 H) v+ = M v + dt f(x)`
//!
//! (`c` the damping rate, `f` gravity, springs and the pressure), assembled in a block-sparse
//! matrix ([`super::sparse::BlockCsr`]) and solved by a preconditioned conjugate gradient
//! (block-Jacobi, or aggregation multigrid on the vertex graph; `[simulation]
//! implicit_budget` sets the tolerance). Hands fix their particles' velocities (their rows are
//! filtered out of the solve); their force is the residual of their rows.
//!
//! The thesis' bubble with its end-of-step pressure (eq. 3.8-3.9 at `t + dt`): the pressure
//! force is linear in the pressure difference `dP`, so the step solves twice, `v_f` without it
//! and `w` per pascal (`A w = dt S N`), and `v+ = v_f + dP w`; Boyle's law on the volume this
//! predicts (each particle moving by `dt (v_f + dP w)` along the plane's normal, capped at the
//! surface as for the explicit integrator) gives `dP` ([`crate::air::bubble::solve_boyle`]). The
//! trapped air is then a spring solved with the cloth, stable at large steps.
//!
//! Contacts: the move `x -> x + dt v+` is corrected by the colliders as in the explicit step
//! (eq. 3.4-3.5, normal force and Coulomb friction on the move), and the velocity is what the
//! corrected move implies.

use super::implicit::{Constraint, Surface, contact_constraint, landing_constraint};
use super::sparse::{BlockCsr, CgScratch, Preconditioner, pcg};
use super::verlet_mesh::{pressure_per_pascal, resolve_contacts};
use super::{Air, Fused};
use crate::air::pockets::NONE;
use crate::air::{AirLoad, Timing};
use crate::checks;
use crate::collide::contact;
use crate::control::Control;
use crate::forces::fabric::FabricScratch;
use crate::forces::gravity;
use crate::forces::mesh_spring::MeshSprings;
use crate::math::{Real, Soa, Vec3};
use crate::model::{ClothMesh, Layout, Model};
use crate::params::SolveBudget;
use crate::state::{Motion, State};
use glam::DMat3;
use rayon::prelude::*;

/// Scratch of the mesh's implicit step.
#[derive(Clone, Debug, Default)]
pub(crate) struct ImplicitMesh {
    /// The system matrix.
    a: BlockCsr,
    /// For each spring, where its blocks `(a, b)` and `(b, a)` are in `a.val`.
    slots: Vec<[u32; 2]>,
    pre: Preconditioner,
    cg: CgScratch,
    /// The springs' forces on their first ends, N.
    spring_force: Vec<Vec3>,
    /// The membrane and bending elements' forces (`model = "membrane"`).
    fabric: FabricScratch,
    /// For each triangle, where its corners' blocks `(i, j)` are in `a.val` (`model =
    /// "membrane"`).
    tri_slots: Vec<[[u32; 3]; 3]>,
    /// For each hinge, where its vertices' blocks are in `a.val`.
    hinge_slots: Vec<[[u32; 4]; 4]>,
    /// For each seam pair, where its blocks `(a, b)` and `(b, a)` are in `a.val`.
    seam_slots: Vec<[u32; 2]>,
    budget: Option<SolveBudget>,
    rhs: Soa,
    v: Soa,
    w: Soa,
    per_pascal: Soa,
    /// The velocities' answer to one pascal on every pocket (m/s per Pa), and the particles
    /// a contact held in that solve.
    response: Soa,
    touching: Vec<bool>,
    force: Soa,
    /// The pressure force of the step, N (for the energy audit's count of its work).
    pressure: Soa,
    fixed: Vec<bool>,
    /// Which particles a hand holds this step.
    hand: Vec<bool>,
    /// Each particle's contact in the solve.
    contacts: Vec<Contact>,
    /// Each particle's contact after a solve, if it changes (scratch of `update_contacts`).
    next_contacts: Vec<Option<(Contact, bool)>>,
    /// Each sliding contact's normal, zero elsewhere (the solve's filter).
    normals: Vec<Vec3>,
    /// The velocities the constraints fix (m/s): a hand's, a held contact's, a slide's along
    /// its normal; zero elsewhere.
    known: Soa,
    /// The colliders over the step (empty where none moves).
    surfaces: Vec<Surface>,
    /// Scratch kept between steps (a step allocates none): the free unknowns, a pressure's
    /// right-hand side, the coasting positions and their measures, the new positions.
    free: Soa,
    rhs_p: Soa,
    coast: Soa,
    coast_measures: crate::measure::Measures,
    next: Soa,
    /// CG iterations over every step.
    pub total_iterations: u64,
}

/// Relative residual of the converged budget's solves: the grid's (a tighter 1e-8 cost a
/// fifth of the step and no closed form needed it).
const TOLERANCE_CONVERGED: Real = super::implicit::CG_TOLERANCE;
/// Relative residual of the interactive budget's solves.
const TOLERANCE_INTERACTIVE: Real = 1e-3;
/// Most CG iterations of one solve.
const MAX_ITERATIONS: usize = 2000;

/// Most solves of one step while its contacts change (as the grid's step).
const MAX_CONTACT_SOLVES: usize = 4;

/// Particles per task when the contacts' queries run on the pool.
const CONTACTS_PER_TASK: usize = 256;

/// A particle's contact in the solve (thesis eq. 3.4-3.5 inside it, as the grid's step has
/// them): `n` the surface's outward unit normal, `vn` the normal velocity that lands the
/// particle on it (m/s), `mu` the friction coefficient, `u` the surface's velocity (m/s).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Contact {
    /// No contact.
    Free,
    /// Held by static friction: its velocity is `n vn` plus the surface's tangential velocity.
    Stick {
        n: Vec3,
        vn: Real,
        mu: Real,
        u: Vec3,
    },
    /// Sliding: its normal velocity is `vn`, and kinetic friction `kinetic` (N, `mu` times the
    /// normal force of the solve before) acts along `dir`, the direction of the force that held
    /// it when it left the friction cone (against the slide).
    Slide {
        n: Vec3,
        vn: Real,
        mu: Real,
        u: Vec3,
        dir: Vec3,
        kinetic: Real,
    },
}

/// Sets every vector of `v` to zero.
fn zero(v: &mut Soa) {
    for c in [&mut v.x, &mut v.y, &mut v.z] {
        c.fill(0.0);
    }
}

impl ImplicitMesh {
    /// Scratch for `model`'s mesh.
    pub fn new(model: &Model, budget: SolveBudget) -> Self {
        let Layout::Mesh(_, springs) = model.layout() else {
            return Self::default();
        };
        let n = model.len();
        let seam_pairs = model.seams.as_ref().map_or(&[][..], |s| &s.pairs[..]);
        let a = match &model.fabric {
            // Every pair of a triangle's corners, and the two vertices across each edge.
            Some(_) => {
                let mesh = model.mesh.as_deref().expect("a mesh cloth's mesh");
                BlockCsr::pattern(
                    n,
                    mesh.edges
                        .iter()
                        .chain(&mesh.across)
                        .chain(seam_pairs)
                        .copied(),
                )
            }
            None => BlockCsr::pattern(n, springs.ends.iter().chain(seam_pairs).copied()),
        };
        let find =
            |a: &BlockCsr, p: u32, q: u32| a.find(p as usize, q as usize).unwrap_or(0) as u32;
        let (tri_slots, hinge_slots) = match &model.fabric {
            Some(f) => (
                f.membrane
                    .triangles
                    .iter()
                    .map(|t| t.map(|p| t.map(|q| find(&a, p, q))))
                    .collect(),
                f.bending.as_ref().map_or(Vec::new(), |b| {
                    b.hinges
                        .iter()
                        .map(|h| h.map(|p| h.map(|q| find(&a, p, q))))
                        .collect()
                }),
            ),
            None => (Vec::new(), Vec::new()),
        };
        let pair_slots = |&[p, q]: &[u32; 2]| [find(&a, p, q), find(&a, q, p)];
        let seam_slots = seam_pairs.iter().map(pair_slots).collect();
        let slots = springs
            .ends
            .iter()
            .map(|&[p, q]| {
                let (p, q) = (p as usize, q as usize);
                [
                    a.find(p, q).unwrap_or(0) as u32,
                    a.find(q, p).unwrap_or(0) as u32,
                ]
            })
            .collect();
        let mut pre = Preconditioner::default();
        pre.setup(&a, true);
        Self {
            a,
            slots,
            pre,
            cg: CgScratch::default(),
            spring_force: Vec::new(),
            fabric: FabricScratch::default(),
            tri_slots,
            hinge_slots,
            seam_slots,
            budget: Some(budget),
            rhs: Soa::zeros(n),
            v: Soa::zeros(n),
            w: Soa::zeros(n),
            per_pascal: Soa::zeros(n),
            response: Soa::zeros(n),
            touching: vec![false; n],
            force: Soa::zeros(n),
            pressure: Soa::zeros(n),
            free: Soa::zeros(n),
            rhs_p: Soa::zeros(n),
            coast: Soa::zeros(n),
            coast_measures: crate::measure::Measures::for_layout(model.layout(), true),
            next: Soa::zeros(n),
            fixed: vec![false; n],
            hand: vec![false; n],
            contacts: vec![Contact::Free; n],
            next_contacts: Vec::new(),
            normals: vec![Vec3::ZERO; n],
            known: Soa::zeros(n),
            surfaces: Vec::new(),
            total_iterations: 0,
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.a.heap_bytes()
            + self.slots.capacity() * 8
            + self.pre.heap_bytes()
            + self.cg.heap_bytes()
            + self.spring_force.capacity() * 24
            + self.fabric.heap_bytes()
            + self.tri_slots.capacity() * 36
            + self.hinge_slots.capacity() * 64
            + self.seam_slots.capacity() * 8
            + [
                &self.rhs,
                &self.v,
                &self.w,
                &self.per_pascal,
                &self.response,
                &self.force,
                &self.pressure,
                &self.free,
                &self.rhs_p,
                &self.coast,
                &self.next,
            ]
            .iter()
            .map(|s| s.heap_bytes())
            .sum::<usize>()
            + self.coast_measures.heap_bytes()
            + self.fixed.capacity() * 2
            + self.touching.capacity()
            + self.contacts.capacity() * std::mem::size_of::<Contact>()
            + self.next_contacts.capacity() * std::mem::size_of::<Option<(Contact, bool)>>()
            + self.normals.capacity() * 24
            + self.known.heap_bytes()
    }

    /// The coasting positions `x + dt v` (m) into the scratch.
    fn coast_at(&mut self, x: &Soa, dt: Real) {
        for k in 0..x.len() {
            self.coast.set(k, x.get(k) + self.v.get(k) * dt);
        }
    }

    /// Solves the step's system for `rhs` into `x` (the free rows; the known ones zero) with the
    /// preconditioned conjugate gradient, counting its iterations.
    fn solve(&mut self, rhs: &Soa, x: &mut Soa, tolerance: Real, parallel: bool) {
        let iters = pcg(
            &self.a,
            &mut self.pre,
            rhs,
            x,
            &self.fixed,
            if self.normals.iter().any(|&m| m != Vec3::ZERO) {
                &self.normals
            } else {
                &[]
            },
            tolerance,
            MAX_ITERATIONS,
            parallel,
            &mut self.cg,
        );
        self.total_iterations += iters as u64;
    }

    /// The solve's constraints from the hands and the contacts: the rows whose velocity is
    /// known (`fixed`), the slides' normals, and the velocities they fix (`known`; a hand's
    /// was set by the step, in `v`).
    fn constrain(&mut self) {
        for k in 0..self.contacts.len() {
            let (fixed, normal, known) = match self.contacts[k] {
                _ if self.hand[k] => (true, Vec3::ZERO, self.known.get(k)),
                Contact::Free => (false, Vec3::ZERO, Vec3::ZERO),
                Contact::Stick { n, vn, u, .. } => (true, Vec3::ZERO, n * vn + (u - n * n.dot(u))),
                Contact::Slide { n, vn, .. } => (false, n, n * vn),
            };
            self.fixed[k] = fixed;
            self.normals[k] = normal;
            self.known.set(k, known);
        }
    }

    /// The right-hand side of particle `k`'s row without the constraints, `M v + dt f` (N s).
    fn row_rhs(&self, model: &Model, x: &Soa, prev: &Soa, dt: Real, k: usize) -> Vec3 {
        let v0 = (x.get(k) - prev.get(k)) / dt;
        v0 * model.mass(k) + self.force.get(k) * dt
    }

    /// The force the constraints put on particle `k` (N): the residual of its row.
    fn residual(&self, model: &Model, x: &Soa, prev: &Soa, dt: Real, k: usize) -> Vec3 {
        (self.a.row_times(k, &self.v) - self.row_rhs(model, x, prev, dt, k)) / dt
    }

    /// Solves the step's system with the current constraints into `v`, from the `v` given.
    fn solve_velocities(
        &mut self,
        model: &Model,
        x: &Soa,
        prev: &Soa,
        dt: Real,
        tolerance: Real,
        parallel: bool,
    ) {
        let n = model.len();
        // The right-hand side M v + dt f, the slides' friction, the known velocities' columns
        // moved over.
        for k in 0..n {
            let mut b = self.row_rhs(model, x, prev, dt, k);
            if let Contact::Slide { dir, kinetic, .. } = self.contacts[k] {
                b += dir * (kinetic * dt);
            }
            self.rhs.set(k, b);
        }
        let sliding = self.normals.iter().any(|&m| m != Vec3::ZERO);
        if sliding || self.fixed.iter().any(|&f| f) {
            for k in 0..n {
                if self.fixed[k] {
                    continue;
                }
                let mut c = Vec3::ZERO;
                for s in self.a.start[k] as usize..self.a.start[k + 1] as usize {
                    let j = self.a.col[s] as usize;
                    if self.fixed[j] || self.normals[j] != Vec3::ZERO {
                        c += self.a.val[s] * self.known.get(j);
                    }
                }
                self.rhs.set(k, self.rhs.get(k) - c);
            }
        }
        let sliding = if self.normals.iter().any(|&m| m != Vec3::ZERO) {
            &self.normals[..]
        } else {
            &[]
        };
        self.pre.refresh(&self.a, &self.fixed, sliding);
        // The solve sees the known velocities as fixed; their columns are in the rhs, so the
        // product is of the free unknowns only.
        let mut free_v = std::mem::take(&mut self.free);
        free_v.clone_from(&self.v);
        for k in 0..n {
            let m = self.normals[k];
            if self.fixed[k] {
                free_v.set(k, Vec3::ZERO);
            } else if m != Vec3::ZERO {
                let v = free_v.get(k);
                free_v.set(k, v - m * m.dot(v));
            }
        }
        let rhs = std::mem::take(&mut self.rhs);
        self.solve(&rhs, &mut free_v, tolerance, parallel);
        self.rhs = rhs;
        for k in 0..n {
            self.v.set(k, free_v.get(k) + self.known.get(k));
        }
        self.free = free_v;
    }

    /// The contacts after a solve: one that pulls goes free, a held one outside the friction
    /// cone slides, a slide that friction reversed is held, and a free particle that would
    /// end inside a collider lands held. Each particle's on the pool if `parallel` (each reads
    /// only its own row and contact). Returns whether any changed.
    fn update_contacts(
        &mut self,
        model: &Model,
        x: &Soa,
        prev: &Soa,
        dt: Real,
        parallel: bool,
    ) -> bool {
        let mut next = std::mem::take(&mut self.next_contacts);
        next.resize(self.contacts.len(), None);
        {
            let this = &*self;
            let of = |k: usize| this.next_contact(model, x, prev, dt, k);
            if parallel {
                next.par_iter_mut()
                    .enumerate()
                    .with_min_len(CONTACTS_PER_TASK)
                    .for_each(|(k, o)| *o = of(k));
            } else {
                for (k, o) in next.iter_mut().enumerate() {
                    *o = of(k);
                }
            }
        }
        let mut changed = false;
        for (c, o) in self.contacts.iter_mut().zip(&next) {
            if let Some((to, counts)) = *o {
                *c = to;
                changed |= counts;
            }
        }
        self.next_contacts = next;
        changed
    }

    /// Particle `k`'s contact after a solve ([`ImplicitMesh::update_contacts`]): `None` if it
    /// stays, else the new one and whether it is a change of kind (a slide's friction taken
    /// again from its normal force is not).
    fn next_contact(
        &self,
        model: &Model,
        x: &Soa,
        prev: &Soa,
        dt: Real,
        k: usize,
    ) -> Option<(Contact, bool)> {
        if self.hand[k] {
            return None;
        }
        let next = match self.contacts[k] {
            Contact::Free => {
                if model.colliders.is_empty() || model.exempt_collider(k).is_some() {
                    return None;
                }
                let (p, v) = (x.get(k), self.v.get(k));
                match landing_constraint(model, &self.surfaces, k, p, p + v * dt, dt) {
                    Some((Constraint::Stick { n, vn, mu, u }, _)) => {
                        Contact::Stick { n, vn, mu, u }
                    }
                    _ => return None,
                }
            }
            Contact::Stick { n, vn, mu, u } => {
                let lambda = self.residual(model, x, prev, dt, k);
                let push = lambda.dot(n);
                let shear = lambda - n * push;
                if push < 0.0 {
                    Contact::Free
                } else if shear.length() > mu * push {
                    Contact::Slide {
                        n,
                        vn,
                        mu,
                        u,
                        dir: shear.normalize(),
                        kinetic: mu * push,
                    }
                } else {
                    return None;
                }
            }
            Contact::Slide {
                n, vn, mu, u, dir, ..
            } => {
                let push = self.residual(model, x, prev, dt, k).dot(n);
                let v = self.v.get(k);
                let slip = (v - n * n.dot(v)) - (u - n * n.dot(u));
                if push < 0.0 {
                    Contact::Free
                } else if slip.dot(dir) > 0.0 {
                    Contact::Stick { n, vn, mu, u }
                } else {
                    // The friction of the next solve from this one's normal force.
                    return Some((
                        Contact::Slide {
                            n,
                            vn,
                            mu,
                            u,
                            dir,
                            kinetic: mu * push,
                        },
                        false,
                    ));
                }
            }
        };
        Some((next, true))
    }

    /// Assembles `M (1 + dt c) + dt^2 H` at positions `x`.
    fn assemble(&mut self, model: &Model, springs: &MeshSprings, x: &Soa, dt: Real) {
        for v in &mut self.a.val {
            *v = DMat3::ZERO;
        }
        let dt2 = dt * dt;
        let active = if springs.active() {
            springs.ends.len()
        } else {
            0
        };
        for (s, &[p, q]) in springs.ends[..active].iter().enumerate() {
            let d = x.get(q as usize) - x.get(p as usize);
            let l = d.length();
            if l == 0.0 {
                continue;
            }
            let u = d / l;
            let k = springs.stiffness[s];
            let outer = DMat3::from_cols(u * u.x, u * u.y, u * u.z);
            let bend = (1.0 - springs.rest[s] / l).max(0.0);
            let h = (outer * k + (DMat3::IDENTITY - outer) * (k * bend)) * dt2;
            let [pq, qp] = self.slots[s];
            self.a.val[pq as usize] -= h;
            self.a.val[qp as usize] -= h;
            self.a.val[self.a.diag[p as usize] as usize] += h;
            self.a.val[self.a.diag[q as usize] as usize] += h;
        }
        if let Some(fabric) = &model.fabric {
            for (t, slots) in self.tri_slots.iter().enumerate() {
                let h = fabric.membrane.hessian(x, t);
                for i in 0..3 {
                    for j in 0..3 {
                        self.a.val[slots[i][j] as usize] += h[i][j] * dt2;
                    }
                }
            }
            if let Some(b) = &fabric.bending {
                // The Gauss-Newton term k grad theta grad theta^T of each hinge.
                for (h, slots) in self.hinge_slots.iter().enumerate() {
                    let k = b.hinge_stiffness[h] * dt2;
                    if k == 0.0 {
                        continue;
                    }
                    let g = self.fabric.angles[h].1;
                    for i in 0..4 {
                        let gi = g[i] * k;
                        for j in 0..4 {
                            let gj = g[j];
                            self.a.val[slots[i][j] as usize] +=
                                DMat3::from_cols(gi * gj.x, gi * gj.y, gi * gj.z);
                        }
                    }
                }
            }
        }
        if let Some(seams) = &model.seams {
            // Each pair's spring (linearised below or beyond its cap) and its damping.
            for (i, (&[p, q], &[pq, qp])) in seams.pairs.iter().zip(&self.seam_slots).enumerate() {
                let d = x.get(q as usize) - x.get(p as usize);
                let h = DMat3::from_diagonal(Vec3::splat(
                    seams.stiffness_at(i, d) * dt2 + seams.damping[i] * dt,
                ));
                self.a.val[pq as usize] -= h;
                self.a.val[qp as usize] -= h;
                self.a.val[self.a.diag[p as usize] as usize] += h;
                self.a.val[self.a.diag[q as usize] as usize] += h;
            }
        }
        let damp = 1.0 + dt * model.damping;
        for k in 0..model.len() {
            let slot = self.a.diag[k] as usize;
            self.a.val[slot] += DMat3::from_diagonal(Vec3::splat(model.mass(k) * damp));
        }
    }

    /// One step of `dt` s on a mesh cloth. Returns the largest squared distance (m^2) of a new
    /// position from `fused.reference`.
    #[allow(clippy::too_many_arguments)] // the step's parts, as the grid's takes them
    pub fn step(
        &mut self,
        model: &Model,
        mesh: &ClothMesh,
        springs: &MeshSprings,
        state: &mut State,
        control: &mut Control,
        air: Air<'_>,
        dt: Real,
        fused: Fused<'_>,
    ) -> Real {
        state.use_previous_positions(dt);
        let Motion::Previous(prev) = &mut state.motion else {
            unreachable!("converted above")
        };
        let n = model.len();
        let parallel = crate::exec::use_pool(n);
        let x = &state.x;
        let law = model.pressure_force;
        // Forces at the step's start: gravity, springs (damping is in the matrix).
        springs.forces_into(x, &mut self.spring_force, parallel);
        if let Some(fabric) = &model.fabric {
            fabric.forces_into(x, &mut self.fabric, parallel);
        }
        for k in 0..n {
            let mut f = gravity::weight_and_damping(model.mass(k), model.gravity, 0.0, Vec3::ZERO)
                + springs.gather(&self.spring_force, k);
            if let Some(fabric) = &model.fabric {
                f += fabric.gather(&self.fabric, k);
            }
            self.force.set(k, f);
            self.pressure.set(k, Vec3::ZERO);
            self.per_pascal.set(k, pressure_per_pascal(mesh, law, x, k));
        }
        // The seams' springs (their damping is in the matrix).
        if let Some(seams) = &model.seams {
            seams.add_forces(x, |_| Vec3::ZERO, &mut self.force);
        }
        // The soft attachments' springs to their points at the step's end (backward Euler:
        // `k (p(t + dt) - x - dt v+)`, the `k dt^2` in the matrix below).
        for t in &control.tethers {
            let k = t.particle;
            self.force
                .set(k, self.force.get(k) + t.pull(x.get(k), t.points[1]));
        }
        let pressure_now = match air.timing {
            Timing::Now => Some(()),
            Timing::EndOfStep => None,
        };
        if pressure_now.is_some() {
            match air.model.load(air.params) {
                AirLoad::Uniform(dp) if dp != 0.0 => {
                    for k in 0..n {
                        self.force
                            .set(k, self.force.get(k) + self.per_pascal.get(k) * dp);
                        self.pressure.set(k, self.per_pascal.get(k) * dp);
                    }
                }
                AirLoad::Uniform(_) => {}
                AirLoad::PerParticle(dp) => {
                    for k in 0..n {
                        self.force
                            .set(k, self.force.get(k) + self.per_pascal.get(k) * dp[k]);
                        self.pressure.set(k, self.per_pascal.get(k) * dp[k]);
                    }
                }
            }
        }
        self.assemble(model, springs, x, dt);
        for t in &control.tethers {
            let slot = self.a.diag[t.particle] as usize;
            self.a.val[slot] += DMat3::from_diagonal(Vec3::splat(t.stiffness * dt * dt));
        }
        // Hands: their particles' velocities are known.
        self.hand.fill(false);
        for (k, target) in control.active() {
            self.hand[k] = true;
            self.v.set(k, (target - x.get(k)) / dt);
            self.known.set(k, (target - x.get(k)) / dt);
        }
        for k in 0..n {
            if !self.hand[k] {
                self.v.set(k, (x.get(k) - prev.get(k)) / dt);
            }
        }
        // Contacts: a particle touching a collider, or reaching one at its speed, starts held
        // (the friction cone decides after the first solve).
        Surface::of_step(model, fused.start, dt, &mut self.surfaces);
        {
            let (hand, surfaces, v) = (&self.hand, &self.surfaces, &self.v);
            let touching = &state.contact;
            let first = |k: usize, c: &mut Contact| {
                *c = Contact::Free;
                if hand[k] || model.colliders.is_empty() || model.exempt_collider(k).is_some() {
                    return;
                }
                let at =
                    contact_constraint(model, surfaces, k, x.get(k), v.get(k), dt, touching[k]);
                if let Constraint::Stick { n, vn, mu, u } = at {
                    *c = Contact::Stick { n, vn, mu, u };
                }
            };
            // Each particle's query is its own: on the pool for a large cloth.
            if parallel {
                self.contacts
                    .par_iter_mut()
                    .enumerate()
                    .with_min_len(CONTACTS_PER_TASK)
                    .for_each(|(k, c)| first(k, c));
            } else {
                for (k, c) in self.contacts.iter_mut().enumerate() {
                    first(k, c);
                }
            }
        }
        let budget = self.budget.unwrap_or_default();
        let tolerance = match budget {
            SolveBudget::Converged => TOLERANCE_CONVERGED,
            SolveBudget::Interactive => TOLERANCE_INTERACTIVE,
        };
        // The solves that only decide which contacts hold, slide or let go stop at the grid's
        // contact tolerance; the last (its contacts unchanged, or the last allowed) is taken on
        // to the budget's tolerance from where it stopped.
        let deciding = tolerance.max(super::implicit::CG_CONTACT_TOLERANCE);
        for pass in 0..MAX_CONTACT_SOLVES {
            self.constrain();
            self.solve_velocities(model, x, prev, dt, deciding, parallel);
            // The pressures at the step's end, solved once from the first solve (their force
            // is then part of the right-hand side of any solve after it).
            if pass == 0 {
                // The pockets' end-of-step pressures: solved by the air model from the coasting
                // positions, then their force's response added by one more solve.
                if pressure_now.is_none()
                    && let Some(pockets) = air.model.pockets()
                {
                    // The velocities' answer to one pascal on every pocket's free particles
                    // (`A w = dt S N` there): how far the cloth over a pocket, held by its
                    // springs and its contacts, moves with the pressure, for the pressures'
                    // Boyle's law. (With a lone particle's `dt^2 S / m` instead, which leaves
                    // the springs and contacts out, the predicted volume missed the one the
                    // cloth came to; the air is stiff, a pascal is 1e-5 of its volume, so at
                    // 1/600 s a pocket at rest felt 17 Pa while its air was at 1.1 kPa,
                    // squeezed into 1 % less room.)
                    let mut rhs_p = std::mem::take(&mut self.rhs_p);
                    for k in 0..n {
                        let f = if !self.fixed[k] && pockets.particle_pocket[k] != NONE {
                            self.per_pascal.get(k) * dt
                        } else {
                            Vec3::ZERO
                        };
                        rhs_p.set(k, f);
                    }
                    let mut response = std::mem::take(&mut self.response);
                    zero(&mut response);
                    self.solve(&rhs_p, &mut response, tolerance, parallel);
                    self.rhs_p = rhs_p;
                    self.response = response;
                    for (t, c) in self.touching.iter_mut().zip(&self.contacts) {
                        *t = *c != Contact::Free;
                    }
                    self.coast_at(x, dt);
                    self.coast_measures.keep_cells = true;
                    self.coast_measures.remeasure_mesh(
                        model.layout(),
                        &self.coast,
                        model.sticking,
                        model.radius,
                        crate::exec::use_pool(n),
                    );
                    air.model.solve_end_of_step(
                        air.params,
                        model,
                        &self.coast,
                        &self.coast_measures,
                        &control.held,
                        Some((&self.response, &self.touching)),
                    );
                    if let AirLoad::PerParticle(dp) = air.model.load(air.params) {
                        let mut rhs_p = std::mem::take(&mut self.rhs_p);
                        for k in 0..n {
                            let f = if !self.fixed[k] && dp[k] != 0.0 {
                                self.per_pascal.get(k) * (dp[k] * dt)
                            } else {
                                Vec3::ZERO
                            };
                            rhs_p.set(k, f);
                            self.force
                                .set(k, self.force.get(k) + self.per_pascal.get(k) * dp[k]);
                            self.pressure
                                .set(k, self.pressure.get(k) + self.per_pascal.get(k) * dp[k]);
                        }
                        // The pressures' move, added to the velocities: a start for the
                        // solves after it, whose right-hand side has the pressures' force (a
                        // last solve to the budget's tolerance always follows one at
                        // `deciding`), so `deciding` is enough here (on the wet shirt 30 -> 17
                        // iterations, the step's total 7 % fewer).
                        let mut w = std::mem::take(&mut self.w);
                        zero(&mut w);
                        self.solve(&rhs_p, &mut w, deciding, parallel);
                        self.w = w;
                        self.rhs_p = rhs_p;
                        for k in 0..n {
                            if !self.fixed[k] {
                                self.v.set(k, self.v.get(k) + self.w.get(k));
                            }
                        }
                    }
                }
                // The end-of-step pressure: the response per pascal, then Boyle on the predicted volume.
                if pressure_now.is_none()
                    && let Some(solve) = air.model.take_end_of_step()
                {
                    let mut rhs_p = std::mem::take(&mut self.rhs_p);
                    for k in 0..n {
                        let f = if self.fixed[k] {
                            Vec3::ZERO
                        } else {
                            self.per_pascal.get(k) * dt
                        };
                        rhs_p.set(k, f);
                    }
                    let mut w = std::mem::take(&mut self.w);
                    zero(&mut w);
                    self.solve(&rhs_p, &mut w, tolerance, parallel);
                    self.w = w;
                    self.rhs_p = rhs_p;
                    let dp = match model.sticking {
                        Some(plane) => {
                            let up = plane.up;
                            let contact = up.dot(plane.point) + model.radius;
                            self.coast_at(x, dt);
                            self.coast_measures.keep_cells = false;
                            self.coast_measures.remeasure_mesh(
                                model.layout(),
                                &self.coast,
                                model.sticking,
                                model.radius,
                                crate::exec::use_pool(n),
                            );
                            let (coast, measures) = (&self.coast, &self.coast_measures);
                            // Each free particle ends `g_k + r_k dP` above contact (its coasting gap
                            // plus its move per pascal along the normal), or on the surface if that is
                            // below it: the volume is the coasting one plus the area times the change.
                            let base = measures.totals().volume;
                            let gap = |k: usize| up.dot(coast.get(k)) - contact;
                            let pa = solve.atmosphere;
                            let volume = |p: Real| {
                                let (mut v, mut slope) = (base, 0.0);
                                for k in 0..n {
                                    if self.fixed[k] {
                                        continue;
                                    }
                                    let rate = dt * up.dot(self.w.get(k));
                                    let g = gap(k);
                                    let end = g + rate * (p - pa);
                                    if end > 0.0 {
                                        v += mesh.area[k] * (end - g);
                                        slope += mesh.area[k] * rate;
                                    } else {
                                        v -= mesh.area[k] * g;
                                    }
                                }
                                (v, slope)
                            };
                            crate::air::bubble::solve_boyle(solve.trapped, pa, solve.start, volume)
                                - pa
                        }
                        None => solve.start - solve.atmosphere,
                    };
                    air.model.set_applied_pressure(solve.atmosphere + dp);
                    for k in 0..n {
                        if !self.fixed[k] {
                            self.v.set(k, self.v.get(k) + self.w.get(k) * dp);
                        }
                        self.force
                            .set(k, self.force.get(k) + self.per_pascal.get(k) * dp);
                        self.pressure
                            .set(k, self.pressure.get(k) + self.per_pascal.get(k) * dp);
                    }
                }
            }
            if pass + 1 == MAX_CONTACT_SOLVES || !self.update_contacts(model, x, prev, dt, parallel)
            {
                if deciding > tolerance {
                    self.solve_velocities(model, x, prev, dt, tolerance, parallel);
                }
                break;
            }
        }
        // The hands' forces: the residual of their rows.
        let mut work = 0.0;
        for (g, target) in control.grabs.iter_mut().zip(&control.targets) {
            let k = g.particle;
            match target {
                Some(target) => {
                    g.force = self.residual(model, x, prev, dt, k);
                    work += checks::work(g.force, x.get(k), *target).abs();
                }
                None => g.force = Vec3::ZERO,
            }
        }
        control.hand_work += work;
        // The move, corrected by the contacts.
        let t = fused.start;
        let frames: Vec<contact::Frames> = model
            .moving
            .iter()
            .map(|c| contact::Frames::of(c, t, dt))
            .collect();
        let mut next = std::mem::take(&mut self.next);
        for k in 0..n {
            next.set(k, x.get(k) + self.v.get(k) * dt);
        }
        control.collider_work +=
            resolve_contacts(model, x, &mut next, &mut state.contact, &frames, dt * dt);
        // The solve's contacts touch while the surface pushes; a moving surface works on the
        // cloth it pushes and carries (the contact's impulse times the surface's velocity).
        let mut surface_work = 0.0;
        for k in 0..n {
            if let Contact::Stick { n: normal, u, .. } | Contact::Slide { n: normal, u, .. } =
                self.contacts[k]
            {
                let lambda = self.residual(model, x, prev, dt, k);
                state.contact[k] |= lambda.dot(normal) > 0.0;
                surface_work += (lambda * dt).dot(u).abs();
            }
        }
        control.collider_work += (surface_work * 1e12).round() * 1e-12;
        for (k, target) in control.active() {
            next.set(k, target);
        }
        // The pressure force's work over the step's moves (its share of the energy audit: the
        // thesis' force along each particle's normal is not the volume's gradient).
        let mut air_work = 0.0;
        for k in 0..n {
            air_work += self.pressure.get(k).dot(next.get(k) - x.get(k));
        }
        control.air_work += (air_work.abs() * 1e12).round() * 1e-12;
        // The soft attachments' pulls at the step's end, and their work over its moves.
        let mut work = 0.0;
        for t in &mut control.tethers {
            let k = t.particle;
            t.force = t.pull(next.get(k), t.points[1]);
            work += checks::work(t.force, x.get(k), next.get(k)).abs();
        }
        control.hand_work += work;
        for k in 0..n {
            let v0 = (x.get(k) - prev.get(k)) / dt;
            state
                .acceleration
                .set(k, ((next.get(k) - x.get(k)) / dt - v0) / dt);
        }
        // The new positions in, the old ones to the previous; the previous' room is kept.
        std::mem::swap(&mut state.x, &mut next);
        std::mem::swap(prev, &mut next);
        self.next = next;
        super::verlet_mesh::finish_step(model, &state.x, &control.held, fused)
    }
}
