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
//! iteration on the shift, see [`Relaxation`]), solving again while the shift moves it by more
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

use super::multigrid::{CENTRE, Multigrid, cholesky, cholesky_solve, neighbours, slot};
use super::{Air, Fused};
use crate::air::Timing;
use crate::air::region::Regions;
use crate::checks;
use crate::collide::contact::{self, Frames};
use crate::collide::Collider;
use crate::control::Control;
use crate::forces::pressure;
use crate::math::{Real, RowMut, Soa, Vec3, row};
use crate::model::Model;
use crate::params::{PressureForce, SolveBudget};
use crate::state::{Motion, Slide, State};
use glam::DMat3;
use std::ops::Range;

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

/// Sliding speed below which kinetic friction acts as a linear drag, m/s: friction on a slide
/// is `mu F_n vt / max(|vt|, SLIDE_EPSILON)` (see `Constraint::Normal` and
/// `Implicit::slide_drag`). Below it a slide that friction should stop creeps on at up to this
/// speed with less than Coulomb's friction. At 1 mm/s that creep showed: a dry cloth lifted
/// by a corner over 1.5 s (no air, 50 x 50, friction 0.6) slid 4.0 mm towards the hand against
/// the explicit integrator's 3.5 mm and peeled 317 particles off the table against 362, and
/// it crept more the smaller the step (1/2400 s: 4.1 mm, 305); at 0.01 mm/s it agrees (3.53
/// mm, 362 particles, at 1/2400 s).
pub const SLIDE_EPSILON: Real = 1e-5;

/// A slide's speed (m/s) below which the solve's result is round-off: the slide has stopped.
const STOPPED_SPEED: Real = 1e-12;

/// How much stiffer than itself a spring gets beyond the strain limit (`[cloth]
/// strain_limit`): the implicit integrator's strain limiter. A spring pulled past the limit by
/// a tension `T` ends `(T - k limit l) / (LIMIT_STIFFENING k)` beyond it: a thousandth of the
/// stretch the plain spring would add.
pub const LIMIT_STIFFENING: Real = 1000.0;

/// The strain limit of one kind of spring: the length (m) beyond which it stiffens, and by
/// how much (N/m).
#[derive(Clone, Copy, Debug)]
struct Limit {
    length: Real,
    stiffness: Real,
}

impl Limit {
    /// The limit `limit` (relative stretch, 0 = none) of springs of stiffness `k` (N/m) and
    /// rest length `l` (m).
    fn new(limit: Real, k: Real, l: Real) -> Self {
        if limit > 0.0 {
            Limit {
                length: l * (1.0 + limit),
                stiffness: LIMIT_STIFFENING * k,
            }
        } else {
            Limit {
                length: Real::INFINITY,
                stiffness: 0.0,
            }
        }
    }
}

/// A particle's constraint in the solve.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Constraint {
    /// Free.
    Free,
    /// Its velocity along the unit normal `n` is `vn` (m/s): a sliding contact, `mu` its
    /// friction coefficient. Kinetic friction, `mu F_n` against the slide, linearised at the
    /// slide's velocity of the solve before (a Newton step on Coulomb's law): the impulse
    /// `kinetic` (N s: `mu` times the normal impulse) against the slide's unit direction `t`,
    /// and across it a drag `drag` (kg: N s per m/s, `kinetic` over the sliding speed, at
    /// least [`SLIDE_EPSILON`]) that turns the friction with the slide. Along `t` the friction
    /// does not depend on the speed, so one solve finds a slide's speed whatever its
    /// neighbours do. A slide that a solve ends moving against `t` (friction stopped it within
    /// the step) becomes a drag-only slide: `t` zero, `kinetic` zero and `drag` over the whole
    /// tangent plane, friction that can slow a slide to rest but never reverse it and never do
    /// positive work. A particle landing sliding starts as one too.
    ///
    /// `u` (m/s) is the surface's velocity (zero on a still collider; its normal part is in `vn`): the
    /// slide, its direction `t` and its drag are relative to the surface, so a moving collider
    /// carries the cloth by friction (the drag's share of it is in [`Constraint::friction`]).
    Normal {
        n: Vec3,
        vn: Real,
        mu: Real,
        drag: Real,
        t: Vec3,
        kinetic: Real,
        u: Vec3,
    },
    /// A contact held by static friction: its velocity is `n vn` plus the surface's tangential
    /// velocity (`u`, m/s, the surface's whole velocity; zero on a still collider), as long as
    /// the force that holds it stays inside the friction cone.
    Stick { n: Vec3, vn: Real, mu: Real, u: Vec3 },
    /// Its velocity is fixed: a hand.
    Fixed(Vec3),
}

impl Constraint {
    /// `v` with the constrained directions removed.
    #[inline]
    fn filter(self, v: Vec3) -> Vec3 {
        match self {
            Constraint::Free => v,
            Constraint::Normal { n, .. } => v - n * n.dot(v),
            Constraint::Stick { .. } | Constraint::Fixed(_) => Vec3::ZERO,
        }
    }

    /// The friction drag of a sliding contact on `p`: `drag` times its tangential part across
    /// the slide (the whole tangential part for a drag-only slide).
    #[inline]
    fn drag(self, p: Vec3) -> Vec3 {
        match self {
            Constraint::Normal { n, drag, t, .. } => (p - n * n.dot(p) - t * t.dot(p)) * drag,
            _ => Vec3::ZERO,
        }
    }

    /// The kinetic friction impulse of a slide that does not depend on its speed (N s):
    /// `kinetic` against its direction `t`, and on a moving surface the drag's pull towards the
    /// surface's velocity `u` (the drag acts on the velocity relative to it).
    #[inline]
    fn friction(self) -> Vec3 {
        match self {
            Constraint::Normal { t, kinetic, u, .. } if u != Vec3::ZERO => {
                -t * kinetic + self.drag(u)
            }
            Constraint::Normal { t, kinetic, .. } => -t * kinetic,
            _ => Vec3::ZERO,
        }
    }

    /// The constrained part of the velocity.
    #[inline]
    fn value(self) -> Vec3 {
        match self {
            Constraint::Free => Vec3::ZERO,
            Constraint::Stick { n, vn, u, .. } if u != Vec3::ZERO => n * vn + u - n * n.dot(u),
            Constraint::Normal { n, vn, .. } | Constraint::Stick { n, vn, .. } => n * vn,
            Constraint::Fixed(v) => v,
        }
    }

    /// The tangential velocity of `v` relative to the surface of this contact (m/s): `v`
    /// without its normal part, less the surface's velocity.
    #[inline]
    fn slip(self, v: Vec3) -> Vec3 {
        match self {
            Constraint::Normal { n, u, .. } | Constraint::Stick { n, u, .. } => {
                let vt = v - n * n.dot(v);
                if u == Vec3::ZERO {
                    vt
                } else {
                    vt - (u - n * n.dot(u))
                }
            }
            _ => v,
        }
    }
}

/// The linearised springs of one stencil direction, indexed by the spring's first particle:
/// unit direction `d` and the two stiffnesses of `H_e = ks I + kd d d^T` (N/m).
#[derive(Clone, Debug, Default)]
struct SpringSet {
    d: Soa,
    ks: Vec<Real>,
    kd: Vec<Real>,
    /// Per spring: its force on its first particle (N), or `H_e (p_a - p_b)` in a product.
    w: Soa,
    /// Per spring: its tension (N, along `d`) at its linearisation, kept for the next step's
    /// force where neither particle moved (`w = d f`).
    f: Vec<Real>,
    /// Per spring: whether it is linearised on its strain limit's stiff branch this step.
    taut: Vec<bool>,
}

impl SpringSet {
    fn new(n: usize) -> Self {
        Self {
            d: Soa::zeros(n),
            ks: vec![0.0; n],
            kd: vec![0.0; n],
            w: Soa::zeros(n),
            f: vec![0.0; n],
            taut: vec![false; n],
        }
    }

    /// Linearises the springs `e` in `range` between particles `e + oa` and `e + ob` of `x`
    /// (stiffness `k`, rest length `l`), and stores each one's force on its first particle in
    /// `w`, over contiguous slices, which the compiler vectorises.
    fn set_range(
        &mut self,
        x: &Soa,
        range: std::ops::Range<usize>,
        oa: usize,
        ob: usize,
        (k, l): (Real, Real),
        limit: Limit,
    ) {
        let (e0, e1) = (range.start, range.end);
        let (lmax, kl) = (limit.length, limit.stiffness);
        let (a0, a1, b0, b1) = (e0 + oa, e1 + oa, e0 + ob, e1 + ob);
        let (xa, ya, za) = (&x.x[a0..a1], &x.y[a0..a1], &x.z[a0..a1]);
        let (xb, yb, zb) = (&x.x[b0..b1], &x.y[b0..b1], &x.z[b0..b1]);
        let (dx, dy, dz) = (
            &mut self.d.x[e0..e1],
            &mut self.d.y[e0..e1],
            &mut self.d.z[e0..e1],
        );
        let (ks, kd) = (&mut self.ks[e0..e1], &mut self.kd[e0..e1]);
        let tension = &mut self.f[e0..e1];
        let taut = &mut self.taut[e0..e1];
        let (wx, wy, wz) = (
            &mut self.w.x[e0..e1],
            &mut self.w.y[e0..e1],
            &mut self.w.z[e0..e1],
        );
        for e in 0..e1 - e0 {
            let (px, py, pz) = (xb[e] - xa[e], yb[e] - ya[e], zb[e] - za[e]);
            let len = (px * px + py * py + pz * pz).sqrt();
            let live = len >= 1e-12;
            let safe = if live { len } else { 1.0 };
            let (ux, uy, uz) = (px / safe, py / safe, pz / safe);
            // Beyond the strain limit the spring stiffens by `kl`.
            let over = (len - lmax).max(0.0);
            taut[e] = over > 0.0;
            let (f, hs, hd) = linearise(k, l, kl, safe, over, over > 0.0);
            dx[e] = if live { ux } else { 0.0 };
            dy[e] = if live { uy } else { 0.0 };
            dz[e] = if live { uz } else { 0.0 };
            ks[e] = if live { hs } else { 0.0 };
            kd[e] = if live { hd } else { 0.0 };
            tension[e] = if live { f } else { 0.0 };
            wx[e] = if live { ux * f } else { 0.0 };
            wy[e] = if live { uy * f } else { 0.0 };
            wz[e] = if live { uz * f } else { 0.0 };
        }
    }

    /// In the unit tests: the springs in `range` have the bits of `whole`'s.
    #[cfg(test)]
    fn check_same(&self, whole: &SpringSet, range: std::ops::Range<usize>) {
        for e in range {
            let same = same_bits(self.d.get(e), whole.d.get(e))
                && same_bits(self.w.get(e), whole.w.get(e))
                && self.ks[e].to_bits() == whole.ks[e].to_bits()
                && self.kd[e].to_bits() == whole.kd[e].to_bits()
                && self.f[e].to_bits() == whole.f[e].to_bits()
                && self.taut[e] == whole.taut[e];
            assert!(
                same,
                "spring {e}: kept {:?} {:?}, anew {:?} {:?}",
                self.d.get(e),
                self.w.get(e),
                whole.d.get(e),
                whole.w.get(e)
            );
        }
        KEPT_CHECKS.with(|c| c.set(c.get() + 1));
    }

    /// The forces `w = d f` of the springs `e` in `range` as their last linearisation left
    /// them (their particles have not moved since): the bits [`SpringSet::set_range`] gives.
    fn kept_range(&mut self, range: std::ops::Range<usize>) {
        let (e0, e1) = (range.start, range.end);
        for (w, d) in [
            (&mut self.w.x, &self.d.x),
            (&mut self.w.y, &self.d.y),
            (&mut self.w.z, &self.d.z),
        ] {
            for ((w, d), f) in w[e0..e1].iter_mut().zip(&d[e0..e1]).zip(&self.f[e0..e1]) {
                *w = d * f;
            }
        }
    }

    /// Puts the springs `e` in `range` (stiffness `k`, rest length `l`, as in
    /// [`SpringSet::set_range`]) that are linearised on
    /// the soft branch but would end the step (`x + dt v`) past the strain limit onto the stiff
    /// branch, linearised at `x` (its tangent there: `k (len - l) + kl (len - lmax)`), and adds
    /// the change of each one's force to `df` (N, both particles). Returns how many moved.
    #[allow(clippy::too_many_arguments)]
    fn tighten_range(
        &mut self,
        x: &Soa,
        v: &Soa,
        dt: Real,
        range: std::ops::Range<usize>,
        oa: usize,
        ob: usize,
        (k, l): (Real, Real),
        limit: Limit,
        df: &mut Soa,
    ) -> usize {
        let mut count = 0;
        for e in range {
            if self.taut[e] {
                continue;
            }
            let (a, b) = (e + oa, e + ob);
            let end = (x.get(b) + v.get(b) * dt) - (x.get(a) + v.get(a) * dt);
            if end.length() <= limit.length {
                continue;
            }
            let d = x.get(b) - x.get(a);
            let len = d.length();
            if len < 1e-12 {
                continue;
            }
            let u = d / len;
            // The force's change: the stiff branch's tangent below the limit pushes apart.
            let change = u * (limit.stiffness * (len - limit.length));
            df.set(a, df.get(a) + change);
            df.set(b, df.get(b) - change);
            (_, self.ks[e], self.kd[e]) =
                linearise(k, l, limit.stiffness, len, len - limit.length, true);
            self.taut[e] = true;
            count += 1;
        }
        count
    }

    /// `w_e = H_e (p_a - p_b)` for the springs `e` in `range` between particles `e + oa` and
    /// `e + ob`, over contiguous slices.
    fn product_range(&mut self, p: &Soa, range: std::ops::Range<usize>, oa: usize, ob: usize) {
        let (e0, e1) = (range.start, range.end);
        let (a0, a1, b0, b1) = (e0 + oa, e1 + oa, e0 + ob, e1 + ob);
        let (xa, ya, za) = (&p.x[a0..a1], &p.y[a0..a1], &p.z[a0..a1]);
        let (xb, yb, zb) = (&p.x[b0..b1], &p.y[b0..b1], &p.z[b0..b1]);
        let (dx, dy, dz) = (&self.d.x[e0..e1], &self.d.y[e0..e1], &self.d.z[e0..e1]);
        let (ks, kd) = (&self.ks[e0..e1], &self.kd[e0..e1]);
        let (wx, wy, wz) = (
            &mut self.w.x[e0..e1],
            &mut self.w.y[e0..e1],
            &mut self.w.z[e0..e1],
        );
        for e in 0..e1 - e0 {
            let (qx, qy, qz) = (xa[e] - xb[e], ya[e] - yb[e], za[e] - zb[e]);
            let along = kd[e] * (dx[e] * qx + dy[e] * qy + dz[e] * qz);
            wx[e] = qx * ks[e] + dx[e] * along;
            wy[e] = qy * ks[e] + dy[e] * along;
            wz[e] = qz * ks[e] + dz[e] * along;
        }
    }

    /// `out[e + oa] += w_e` and `out[e + ob] -= w_e` (or `+=` with `both`) for the springs
    /// `e` in `range`.
    fn scatter_range(&self, out: &mut Soa, range: std::ops::Range<usize>, oa: usize, ob: usize) {
        self.scatter(out, range, oa, ob, -1.0);
    }

    fn scatter(
        &self,
        out: &mut Soa,
        range: std::ops::Range<usize>,
        oa: usize,
        ob: usize,
        sign: Real,
    ) {
        let (e0, e1) = (range.start, range.end);
        for (o, w) in [
            (&mut out.x, &self.w.x),
            (&mut out.y, &self.w.y),
            (&mut out.z, &self.w.z),
        ] {
            let w = &w[e0..e1];
            for (o, w) in o[e0 + oa..e1 + oa].iter_mut().zip(w) {
                *o += w;
            }
            for (o, w) in o[e0 + ob..e1 + ob].iter_mut().zip(w) {
                *o += sign * w;
            }
        }
    }

    /// `w_e` = the diagonal of `H_e` for the springs `e` in `range`, added to both particles
    /// (`e + oa`, `e + ob`) of `out`.
    fn diagonal_range(
        &mut self,
        out: &mut Soa,
        range: std::ops::Range<usize>,
        oa: usize,
        ob: usize,
    ) {
        let (e0, e1) = (range.start, range.end);
        for (w, d) in [
            (&mut self.w.x, &self.d.x),
            (&mut self.w.y, &self.d.y),
            (&mut self.w.z, &self.d.z),
        ] {
            for (((w, d), ks), kd) in w[e0..e1]
                .iter_mut()
                .zip(&d[e0..e1])
                .zip(&self.ks[e0..e1])
                .zip(&self.kd[e0..e1])
            {
                *w = ks + d * d * kd;
            }
        }
        self.scatter(out, range, oa, ob, 1.0);
    }

    /// `H_e p` (N/m times m/s).
    #[inline(always)]
    fn apply(&self, e: usize, p: Vec3) -> Vec3 {
        let d = self.d.get(e);
        p * self.ks[e] + d * (self.kd[e] * d.dot(p))
    }

    fn heap_bytes(&self) -> usize {
        self.d.heap_bytes()
            + self.w.heap_bytes()
            + (self.ks.capacity() + self.kd.capacity()) * 8
            + self.taut.capacity()
    }
}

/// A spring of stiffness `k` (N/m) and rest length `l` (m) at length `len` (m), `over` (m)
/// along its strain limit's stiff branch of extra stiffness `kl` (N/m) when `stiff`: its
/// tension (N) and the two stiffnesses of `H_e = ks I + kd d d^T` (N/m; `ks`, the tension over
/// the length, none when compressed; `ks + kd` the stiffness along the spring).
#[inline(always)]
fn linearise(k: Real, l: Real, kl: Real, len: Real, over: Real, stiff: bool) -> (Real, Real, Real) {
    if stiff {
        let f = k * (len - l) + kl * over;
        let ks = (f / len).max(0.0);
        (f, ks, k + kl - ks)
    } else {
        let s = (1.0 - l / len).max(0.0);
        (k * (len - l), k * s, k * (1.0 - s))
    }
}

/// The springs of the 9-point stencil, one set per direction, each indexed by its spring's
/// first index: towards +x (`right`), +z (`down`), +x+z (`diag`), and from (i+1, j) towards
/// (i, j+1) (`anti`, indexed by (i, j)).
#[derive(Clone, Debug, Default)]
struct Stencil {
    right: SpringSet,
    down: SpringSet,
    diag: SpringSet,
    anti: SpringSet,
}

/// A direction of [`Stencil`].
#[derive(Clone, Copy, Debug)]
enum Dir {
    Right,
    Down,
    Diag,
    Anti,
}

impl Dir {
    /// The stiffness (N/m) and rest length (m) of this direction's springs.
    fn constants(self, c: &crate::forces::spring::SpringConsts) -> (Real, Real) {
        match self {
            Dir::Right => (c.structural, c.rest_x),
            Dir::Down => (c.structural, c.rest_z),
            Dir::Diag | Dir::Anti => (c.shear, c.rest_diag),
        }
    }
}

impl Stencil {
    fn get(&self, dir: Dir) -> &SpringSet {
        match dir {
            Dir::Right => &self.right,
            Dir::Down => &self.down,
            Dir::Diag => &self.diag,
            Dir::Anti => &self.anti,
        }
    }

    fn get_mut(&mut self, dir: Dir) -> &mut SpringSet {
        match dir {
            Dir::Right => &mut self.right,
            Dir::Down => &mut self.down,
            Dir::Diag => &mut self.diag,
            Dir::Anti => &mut self.anti,
        }
    }
}

/// A run of springs: their direction, their indices, and the offsets of their two particles
/// from a spring's index.
type Run = (Dir, Range<usize>, usize, usize);

/// The springs of an `nx` x `nz` grid as contiguous runs of spring indices, in the order every
/// pass over them takes (so their sums are the same every time): per row its `right` springs,
/// then (all rows but the last) its `diag` and `anti` springs; then every `down` spring in one
/// run. Each item: the direction, the run, and the offsets of its two particles from the
/// spring's index.
fn spans(nx: usize, nz: usize) -> impl Iterator<Item = Run> {
    (0..nz)
        .flat_map(move |j| {
            let row = j * nx..j * nx + nx - 1;
            let inner = (j + 1 < nz).then(|| {
                [
                    (Dir::Diag, row.clone(), 0, nx + 1),
                    (Dir::Anti, row.clone(), 1, nx),
                ]
            });
            std::iter::once((Dir::Right, row, 0, 1)).chain(inner.into_iter().flatten())
        })
        .chain(std::iter::once((Dir::Down, 0..(nz - 1) * nx, 0, nx)))
}

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
    /// Per particle: the pressure difference (Pa) of the pockets of air around it that its
    /// right-hand side holds so far this step, as a sealed particle on their rims
    /// ([`Implicit::rim_pressures`]); with `rim_target` the one the last solve asks for.
    rim_applied: Vec<Real>,
    rim_target: Vec<Real>,
    /// Per region, the difference to the atmosphere (Pa) of the end-of-step pressure the last
    /// solve found.
    end_pressure: Vec<Real>,
    /// End-of-step positions of the current velocities (for the bubble's volume).
    end: Soa,
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
    /// correction of its inverse (Woodbury): `w_r = V u_r` for each gas region's filtered
    /// pressure gradient `u_r`, and the Cholesky factor of `C^-1 + U^T V U`.
    mg: Multigrid,
    use_multigrid: bool,
    /// Whether `mg` (and the gas springs' correction) was built from the matrix as it is: no
    /// constraint, spring or step changed since. A solve that only moved the bubble's pressure
    /// (the right-hand side) reuses it.
    mg_built: bool,
    /// The corrected regions (indices into `regions.list`), and scratch for `G^-1 W^T r`.
    gas_regions: Vec<usize>,
    gas_u: Vec<Soa>,
    gas_w: Vec<Soa>,
    gas_chol: Vec<Real>,
    gas_y: Vec<Real>,
    /// `A v` of the last solve's `v` (`q` is the conjugate gradient's scratch): each
    /// contact's and hand's impulse is read from it. `av_of` is the `v` it was computed from
    /// while `av_fresh` holds (the matrix unchanged since but for the rows in `av_rows`, whose
    /// constraints changed); then only the rows around the particles whose velocity moved are
    /// computed again ([`Implicit::apply_v`]). `row_mark` and `row_stamp` mark the rows taken
    /// there and in [`Implicit::precondition`] ([`Implicit::next_stamp`]).
    av: Soa,
    av_of: Soa,
    av_fresh: bool,
    /// The `dt^2` (s^2) of the matrix `av` was taken with, and whether no gas spring acted in
    /// it: a step of the same size without gas springs keeps `av` ([`Implicit::keep_product`]).
    av_dt2: Real,
    av_gas_free: bool,
    /// The last step's final constraints (those of its last product), beside this step's.
    prev_constraints: Vec<Constraint>,
    av_rows: Vec<u32>,
    row_mark: Vec<u32>,
    row_stamp: u32,
    /// The positions the springs were last linearised at, while `lin_fresh` holds (no spring
    /// was put on its stiff branch since): a spring neither of whose particles moved keeps its
    /// linearisation ([`Implicit::forces`]). `lin_moved` marks the particles that moved.
    lin_x: Soa,
    lin_fresh: bool,
    lin_moved: Vec<bool>,
    /// Each particle's sum of its springs' diagonal blocks (N/m), and whether the next
    /// [`Implicit::precondition`] may take it again only around the particles that moved (the
    /// last `forces` kept the other springs).
    diag_springs: Soa,
    diag_kept: bool,
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

/// The step's constants the matrix needs.
struct System<'a> {
    nx: usize,
    nz: usize,
    dt2: Real,
    regions: &'a Regions,
}

impl Implicit {
    /// Scratch for the particles of `model`, solving each step to `budget`.
    pub fn new(model: &Model, budget: SolveBudget) -> Self {
        let n = model.grid.len();
        Self {
            springs: Stencil {
                right: SpringSet::new(n),
                down: SpringSet::new(n),
                diag: SpringSet::new(n),
                anti: SpringSet::new(n),
            },
            runs: spans(model.grid.nx, model.grid.nz).collect(),
            force: Soa::zeros(n),
            per_pascal: Soa::zeros(n),
            landed: vec![false; n],
            rim_applied: vec![0.0; n],
            rim_target: vec![0.0; n],
            end_pressure: Vec::new(),
            end: Soa::zeros(n),
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
            mg_built: false,
            gas_regions: Vec::new(),
            gas_u: Vec::new(),
            gas_w: Vec::new(),
            gas_chol: Vec::new(),
            gas_y: Vec::new(),
            av: Soa::zeros(n),
            av_of: Soa::zeros(n),
            av_fresh: false,
            av_dt2: 0.0,
            av_gas_free: false,
            prev_constraints: vec![Constraint::Free; n],
            av_rows: Vec::new(),
            row_mark: vec![0; n],
            row_stamp: 0,
            lin_x: Soa::zeros(n),
            lin_fresh: false,
            lin_moved: vec![true; n],
            diag_springs: Soa::zeros(n),
            diag_kept: false,
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
                &self.end,
                &self.av,
                &self.av_of,
                &self.lin_x,
                &self.diag_springs,
            ]
            .iter()
            .map(|s| s.heap_bytes())
            .sum::<usize>()
            + self.mg.heap_bytes()
            + self.gas_w.iter().map(|s| s.heap_bytes()).sum::<usize>()
            + self.gas_u.iter().map(|s| s.heap_bytes()).sum::<usize>()
            + self.constraints.capacity() * std::mem::size_of::<Constraint>()
            + self.inertia.capacity() * 8
            + self.landed.capacity()
            + (self.rim_applied.capacity() + self.rim_target.capacity()) * 8
            + self.end_pressure.capacity() * 8
            + (self.av_rows.capacity() + self.row_mark.capacity()) * 4
            + self.prev_constraints.capacity() * std::mem::size_of::<Constraint>()
            + self.lin_moved.capacity()
            + self.runs.len() * std::mem::size_of::<Run>()
    }

    /// Springs and their linearisation, gravity, damping-free forces and the pressure force per
    /// pascal at the positions `x`.
    fn forces(&mut self, model: &Model, x: &Soa) {
        let (nx, nz) = (model.grid.nx, model.grid.nz);
        let c = &model.springs;
        let n = nx * nz;
        for k in 0..n {
            self.force.set(k, model.gravity * model.mass(k));
        }
        // The particles that moved since the springs' last linearisation (all, if it is
        // stale): on a cloth the vacuum pins, nearly none of them from one step to the next.
        let fresh = self.lin_fresh;
        for k in 0..n {
            let moved = !fresh || !same_bits(x.get(k), self.lin_x.get(k));
            self.lin_moved[k] = moved;
        }
        // Each run of springs linearised where a particle of the spring moved (in stretches of
        // such springs, vectorised), its forces kept elsewhere, then scattered.
        for (dir, run, oa, ob) in self.runs.clone().iter().cloned() {
            let (k, l) = dir.constants(c);
            let limit = Limit::new(model.strain_limit, k, l);
            let set = self.springs.get_mut(dir);
            let moved = |e: usize| self.lin_moved[e + oa] || self.lin_moved[e + ob];
            let mut e = run.start;
            while e < run.end {
                let m = moved(e);
                let mut f = e + 1;
                while f < run.end && moved(f) == m {
                    f += 1;
                }
                if m {
                    set.set_range(x, e..f, oa, ob, (k, l), limit);
                } else {
                    set.kept_range(e..f);
                }
                e = f;
            }
            #[cfg(test)]
            if fresh {
                let mut whole = set.clone();
                whole.set_range(x, run.clone(), oa, ob, (k, l), limit);
                set.check_same(&whole, run.clone());
            }
            set.scatter_range(&mut self.force, run, oa, ob);
        }
        for (to, from) in [
            (&mut self.lin_x.x, &x.x),
            (&mut self.lin_x.y, &x.y),
            (&mut self.lin_x.z, &x.z),
        ] {
            to.clone_from(from);
        }
        self.diag_kept = fresh;
        self.lin_fresh = true;
        // The pressure force of 1 Pa on every particle: S N_i (or by area).
        if self.regions.list.is_empty() && self.regions.extra.is_empty() {
            return;
        }
        let pp = &mut self.per_pascal;
        for v in [&mut pp.x, &mut pp.y, &mut pp.z] {
            v.fill(0.0);
        }
        for j in 0..nz {
            let r = j * nx..(j + 1) * nx;
            let mut out = RowMut {
                x: &mut pp.x[r.clone()],
                y: &mut pp.y[r.clone()],
                z: &mut pp.z[r.clone()],
            };
            let here = row(x, nx, j);
            match model.pressure_force {
                PressureForce::Thesis => {
                    let below = row(x, nx, j.saturating_sub(1));
                    let above = row(x, nx, (j + 1).min(nz - 1));
                    pressure::add_row(&mut out, here, below, above, model.area_per_particle);
                }
                PressureForce::Area => {
                    let below = (j > 0).then(|| row(x, nx, j - 1));
                    let above = (j + 1 < nz).then(|| row(x, nx, j + 1));
                    pressure::add_row_area(&mut out, here, below, above, |_| 1.0);
                }
            }
        }
        for k in 0..n {
            let dp = match self.regions.of(k) {
                Some(r) => self.regions.list[r].pressure - self.regions.atmosphere,
                None => self.regions.extra.get(k).copied().unwrap_or(0.0),
            };
            if dp != 0.0 {
                let f = self.force.get(k) + self.per_pascal.get(k) * dp;
                self.force.set(k, f);
            }
        }
    }

    /// `q = A p` (unfiltered) on every particle, or with `only` on those particles (`p` zero on
    /// the others).
    fn apply(&mut self, sys: &System<'_>, which: Which, only: Option<&[u32]>) {
        let n = sys.nx * sys.nz;
        let p = match which {
            Which::P => &self.p,
            Which::V => &self.v,
        };
        // The regions' dot products g_r . p, in particle order.
        self.dots.clear();
        self.dots.resize(sys.regions.list.len(), 0.0);
        // A region without a gas spring (a vacuum, or the pressure known now) needs none.
        if self.gas.iter().any(|&g| g != 0.0) {
            let mut add = |k: usize| {
                if let Some(r) = sys.regions.of(k) {
                    self.dots[r] += self.per_pascal.get(k).dot(p.get(k));
                }
            };
            // `p` is zero off the list, `v` is not.
            match (only, which) {
                (Some(list), Which::P) => list.iter().for_each(|&k| add(k as usize)),
                _ => (0..n).for_each(add),
            }
        }
        match only {
            Some(list) => {
                for &k in list {
                    let y = self.row_apply(sys, p, k as usize);
                    self.q.set(k as usize, y);
                }
            }
            None => self.apply_all(sys, which),
        }
    }

    /// `q = A p` on every particle, a direction of springs at a time (vectorised), with the
    /// regions' dot products in `self.dots`.
    fn apply_all(&mut self, sys: &System<'_>, which: Which) {
        let (nx, nz) = (sys.nx, sys.nz);
        let p = match which {
            Which::P => &self.p,
            Which::V => &self.v,
        };
        // q = H p first (in `q`), then scaled and the inertia and gas added.
        for v in [&mut self.q.x, &mut self.q.y, &mut self.q.z] {
            v.fill(0.0);
        }
        for (dir, run, oa, ob) in self.runs.clone().iter().cloned() {
            let set = self.springs.get_mut(dir);
            set.product_range(p, run.clone(), oa, ob);
            set.scatter_range(&mut self.q, run, oa, ob);
        }
        let dt2 = sys.dt2;
        for (q, p) in [
            (&mut self.q.x, &p.x),
            (&mut self.q.y, &p.y),
            (&mut self.q.z, &p.z),
        ] {
            for ((q, p), m) in q.iter_mut().zip(p).zip(&self.inertia) {
                *q = p * m + *q * dt2;
            }
        }
        for a in 0..nx * nz {
            let c = self.constraints[a];
            let mut y = self.q.get(a) + c.drag(p.get(a));
            if let Some(r) = sys.regions.of(a) {
                y += self.per_pascal.get(a) * (self.gas[r] * self.dots[r]);
            }
            if y != self.q.get(a) {
                self.q.set(a, y);
            }
        }
    }

    /// Row `a` of `A p`, with the regions' dot products in `self.dots`.
    #[inline(always)]
    fn row_apply(&self, sys: &System<'_>, p: &Soa, a: usize) -> Vec3 {
        let (nx, nz) = (sys.nx, sys.nz);
        let (i, j) = (a % nx, a / nx);
        let pa = p.get(a);
        let st = &self.springs;
        let mut h = Vec3::ZERO;
        if i + 1 < nx {
            h += st.right.apply(a, pa - p.get(a + 1));
        }
        if i > 0 {
            h += st.right.apply(a - 1, pa - p.get(a - 1));
        }
        if j + 1 < nz {
            h += st.down.apply(a, pa - p.get(a + nx));
            if i + 1 < nx {
                h += st.diag.apply(a, pa - p.get(a + nx + 1));
            }
            if i > 0 {
                h += st.anti.apply(a - 1, pa - p.get(a + nx - 1));
            }
        }
        if j > 0 {
            h += st.down.apply(a - nx, pa - p.get(a - nx));
            if i > 0 {
                h += st.diag.apply(a - nx - 1, pa - p.get(a - nx - 1));
            }
            if i + 1 < nx {
                h += st.anti.apply(a - nx, pa - p.get(a - nx + 1));
            }
        }
        let mut y = pa * self.inertia[a] + h * sys.dt2 + self.constraints[a].drag(pa);
        if let Some(r) = sys.regions.of(a) {
            y += self.per_pascal.get(a) * (self.gas[r] * self.dots[r]);
        }
        y
    }

    /// The strain limit inside the solve: the springs that the solution `v` takes past the
    /// limit while linearised below it go onto their stiff branch, and the right-hand side
    /// takes the change of their forces (held in `force`, which the step no longer needs once
    /// the right-hand side is built). Returns whether any spring changed.
    fn tighten(&mut self, model: &Model, x: &Soa, dt: Real) -> bool {
        if model.strain_limit <= 0.0 {
            return false;
        }
        let (nx, nz) = (model.grid.nx, model.grid.nz);
        let c = &model.springs;
        for f in [&mut self.force.x, &mut self.force.y, &mut self.force.z] {
            f.fill(0.0);
        }
        let mut count = 0;
        // The velocities to judge the springs by (in `z`, free between solves): a particle this
        // solve drove through a collider's surface (a free particle under a pocket's sudden
        // vacuum: metres a second into the table) keeps its tangential velocity but lands, as
        // its new contact will have it, instead of stiffening every spring around it.
        for k in 0..nx * nz {
            let v = self.v.get(k);
            let v = match self.constraints[k] {
                Constraint::Stick { n, vn, .. } if self.landed[k] => v - n * n.dot(v) + n * vn,
                _ => v,
            };
            self.z.set(k, v);
        }
        for (dir, run, oa, ob) in self.runs.clone().iter().cloned() {
            let (k, l) = dir.constants(c);
            let limit = Limit::new(model.strain_limit, k, l);
            count += self.springs.get_mut(dir).tighten_range(
                x,
                &self.z,
                dt,
                run,
                oa,
                ob,
                (k, l),
                limit,
                &mut self.force,
            );
        }
        if count == 0 {
            return false;
        }
        // Springs on their stiff branch: the next step linearises every spring anew.
        self.lin_fresh = false;
        for k in 0..nx * nz {
            self.rhs.set(k, self.rhs.get(k) + self.force.get(k) * dt);
        }
        true
    }

    /// The inverse diagonal of `A` (a direction of springs at a time, vectorised), with each
    /// sliding contact's drag.
    fn precondition(&mut self, sys: &System<'_>) {
        // The matrix changed (a new step's, or springs past the strain limit): `av` is stale.
        self.av_fresh = false;
        let (nx, nz) = (sys.nx, sys.nz);
        let n = nx * nz;
        let mut h = std::mem::take(&mut self.diag_springs);
        if std::mem::take(&mut self.diag_kept) {
            // Only the springs around moved particles changed: their particles' sums again.
            let stamp = self.next_stamp();
            let mut mark = std::mem::take(&mut self.row_mark);
            for k in (0..n).filter(|&k| self.lin_moved[k]) {
                each_new_neighbour(nx, nz, k, &mut mark, stamp, |m| {
                    h.set(m, self.diag_exact(sys, m));
                });
            }
            self.row_mark = mark;
            #[cfg(test)]
            self.check_diagonal(sys, &h);
        } else {
            for v in [&mut h.x, &mut h.y, &mut h.z] {
                v.fill(0.0);
            }
            for (dir, run, oa, ob) in self.runs.clone().iter().cloned() {
                self.springs
                    .get_mut(dir)
                    .diagonal_range(&mut h, run, oa, ob);
            }
        }
        let mut base = std::mem::take(&mut self.diag_base);
        for a in 0..n {
            let mut d = Vec3::splat(self.inertia[a]) + h.get(a) * sys.dt2;
            if let Some(r) = sys.regions.of(a) {
                let g = self.per_pascal.get(a);
                d += g * g * self.gas[r];
            }
            base.set(a, d);
        }
        self.diag_base = base;
        self.diag_springs = h;
        for a in 0..n {
            self.precondition_one(a);
        }
    }

    /// Particle `a`'s sum over its springs of `term(springs, e, oa, ob, first)` (spring `e` of
    /// a direction's `springs`, between particles `e + oa` and `e + ob`; `first` where `a` is
    /// `e + oa`), added in the order the passes over the runs ([`spans`]) add a spring's terms to
    /// its two particles: the runs row by row, each run's first particles before its second
    /// ones, the `down` springs last. So a row taken alone has the bits of the whole pass's.
    #[inline]
    fn stencil_sum(
        &self,
        sys: &System<'_>,
        a: usize,
        term: impl Fn(&SpringSet, usize, usize, usize, bool) -> Vec3,
    ) -> Vec3 {
        let (nx, nz) = (sys.nx, sys.nz);
        let (i, j) = (a % nx, a / nx);
        let st = &self.springs;
        let mut h = Vec3::ZERO;
        if j > 0 && i > 0 {
            h += term(&st.diag, a - nx - 1, 0, nx + 1, false);
        }
        if j > 0 && i + 1 < nx {
            h += term(&st.anti, a - nx, 1, nx, false);
        }
        if i + 1 < nx {
            h += term(&st.right, a, 0, 1, true);
        }
        if i > 0 {
            h += term(&st.right, a - 1, 0, 1, false);
        }
        if j + 1 < nz && i + 1 < nx {
            h += term(&st.diag, a, 0, nx + 1, true);
        }
        if j + 1 < nz && i > 0 {
            h += term(&st.anti, a - 1, 1, nx, true);
        }
        if j + 1 < nz {
            h += term(&st.down, a, 0, nx, true);
        }
        if j > 0 {
            h += term(&st.down, a - nx, 0, nx, false);
        }
        h
    }

    /// Particle `a`'s sum of its springs' diagonal blocks with the bits of the whole pass
    /// ([`SpringSet::diagonal_range`] over the runs).
    #[inline]
    fn diag_exact(&self, sys: &System<'_>, a: usize) -> Vec3 {
        self.stencil_sum(sys, a, |set, e, _, _, _| {
            let d = set.d.get(e);
            Vec3::splat(set.ks[e]) + d * d * set.kd[e]
        })
    }

    /// In the unit tests: the diagonal's spring sums `h` taken around the moved particles have
    /// the bits of the whole pass.
    #[cfg(test)]
    fn check_diagonal(&mut self, sys: &System<'_>, h: &Soa) {
        let n = sys.nx * sys.nz;
        let mut whole = Soa::zeros(n);
        for (dir, run, oa, ob) in self.runs.clone().iter().cloned() {
            self.springs
                .get_mut(dir)
                .diagonal_range(&mut whole, run, oa, ob);
        }
        for k in 0..n {
            assert!(
                same_bits(whole.get(k), h.get(k)),
                "diagonal {k}: kept {} whole {}",
                h.get(k),
                whole.get(k)
            );
        }
        KEPT_CHECKS.with(|c| c.set(c.get() + 1));
    }

    /// The contact of a particle that the last solve found landing on a collider (`stick`, its
    /// landing constraint), with Coulomb friction for the impact (thesis eq. 3.5, as the
    /// explicit step's collision response has it): stopping its normal velocity takes an
    /// impulse `m dv_n`, whose friction can take `mu m dv_n` of its tangential momentum. If that
    /// stops its slide it lands held (static friction; the next solve's friction-cone test
    /// decides whether it stays); otherwise it lands sliding, against a drag that takes just
    /// that much (`m mu dv_n / (|v_t| - mu dv_n)`), until the next solve measures its normal
    /// force. Holding every landing particle (as before) stopped its slide with an impulse of
    /// any size, and a particle landing in a step's last solve stayed held through the step
    /// whatever pulled it: a lifted cloth that sinks onto the table as it is pulled in was pinned
    /// there, ring by ring.
    fn landing_friction(&self, k: usize, stick: Constraint) -> Constraint {
        let Constraint::Stick { n, vn, mu, u } = stick else {
            return stick;
        };
        let v = self.v.get(k);
        let stopped = (vn - v.dot(n)).max(0.0);
        let vt = stick.slip(v).length();
        let held = mu * stopped;
        if held >= vt {
            stick
        } else {
            Constraint::Normal {
                n,
                vn,
                mu,
                drag: self.inertia[k] * held / (vt - held),
                t: Vec3::ZERO,
                kinetic: 0.0,
                u,
            }
        }
    }

    /// What a contact held by static friction at particle `k` (contact normal, normal
    /// velocity, friction coefficient) becomes after the last solve, if it changes: free if its
    /// normal impulse pulls; sliding if its tangential impulse left the friction cone, away
    /// from that impulse against Coulomb's `mu F_n`, its drag across the slide for the speed it
    /// had at the step's start or, if faster, the speed the impulse beyond the cone gives it
    /// against its own row's stiffness ([`Implicit::slip_speed`]).
    /// Inlined: the contact passes test every held particle with it (not inlined, the call
    /// cost an eighth of a settled cloth's step).
    #[inline(always)]
    fn held_change(
        &self,
        k: usize,
        (n, vn, mu, u): (Vec3, Real, Real, Vec3),
        state: &State,
        dt: Real,
    ) -> Option<Constraint> {
        let lambda = self.av.get(k) - self.rhs.get(k);
        let push = lambda.dot(n);
        let shear = (lambda - n * push).length();
        if push < 0.0 {
            return Some(Constraint::Free);
        }
        if shear <= mu * push {
            return None;
        }
        let v0 = state.velocity(k, dt);
        let vt = self.constraints[k]
            .slip(v0)
            .length()
            .max(self.slip_speed(k, n, shear - mu * push));
        Some(Constraint::Normal {
            n,
            vn,
            mu,
            drag: mu * push / vt.max(SLIDE_EPSILON),
            t: (n * push - lambda) / shear,
            kinetic: mu * push,
            u,
        })
    }

    /// The tangential speed (m/s) at which a held particle `k` starts to slide when the
    /// tangential impulse holding it exceeds the friction cone by `excess` (N s): that impulse
    /// over its row's tangential diagonal (inertia and its springs' `dt^2` stiffness, kg), as
    /// if its neighbours stood still. A lower bound (they give way too), so the slide's first
    /// drag across it, `mu F_n` over this speed, is at least the true slide's. (While the
    /// whole of kinetic friction was such a drag, starting a slide at the speed it had at the
    /// step's start alone, at rest [`SLIDE_EPSILON`], made a slide's first solve a thousand
    /// times too stiff, and at coarse steps the slide came out short: the vacuum pinch's hand
    /// force 3.7 % high at 1/120 s.)
    fn slip_speed(&self, k: usize, normal: Vec3, excess: Real) -> Real {
        let a = self.diag_base.get(k);
        let tangential = 0.5 * (a.x + a.y + a.z - (a * normal).dot(normal));
        excess / tangential
    }

    /// The drag (kg) for the next solve of a drag-only slide of particle `k` (see
    /// [`Constraint::Normal`]) that the last solve moved at the tangential speed `vt` (m/s)
    /// against the drag `drag`, with `friction` its Coulomb friction `mu F_n` (N s).
    /// Coulomb's friction over that speed (the drag lagged one solve),
    /// unless the slide's friction `drag vt` came out above `friction` (a slide that sped up
    /// within the step): then the drag a Newton step gives on the particle's own row, as if
    /// its neighbours stood still, which takes a faster slide's friction back to Coulomb's in
    /// one solve where the lagged drag takes several. With `a` the row's tangential diagonal,
    /// the slide's speed against a drag `D` is `f / (a + D)`, `f = vt (a + drag)`, and `D
    /// f / (a + D) = friction` at `D = a friction / (f - friction)`; never below the drag of a
    /// slide at the frictionless speed `f / a`. Measured before (the lagged drag alone, with
    /// [`SLIDE_EPSILON`] 1 mm/s): a strain-limited pinch peeling off the table ended steps with
    /// slides pulling 2 to 5 times Coulomb's friction, and with a smaller `SLIDE_EPSILON` its
    /// threads passed the 10 % limit by 7 %.
    fn slide_drag(&self, k: usize, normal: Vec3, friction: Real, vt: Real, drag: Real) -> Real {
        let lagged = friction / vt.max(SLIDE_EPSILON);
        // The row's tangential diagonal (kg), as `slip_speed` divides by it.
        let a = self.slip_speed(k, normal, 1.0).recip();
        let f = vt * (a + drag);
        if f > friction {
            lagged
                .min(a * friction / (f - friction))
                .max(a * friction / f)
        } else {
            lagged
        }
    }

    /// The constraint for the next solve of particle `k`'s slide (contact normal, normal
    /// velocity and friction coefficient; drag, direction and kinetic impulse, as in
    /// [`Constraint::Normal`]) that the last solve moved at the tangential velocity `vt` (m/s)
    /// with the normal impulse `push` (N s), if it changes, and whether the change calls for
    /// another solve:
    /// - moving on along `t`: Coulomb's friction linearised anew at `vt` (its direction, `mu`
    ///   times `push`, the drag across it), solved again when the friction impulse moved by more
    ///   than a quarter of its size;
    /// - moving against `t` (friction stopped it within the step, and would push it back), or
    ///   at a speed of round-off size: a drag-only slide at its speed, solved again;
    /// - a drag-only slide: the drag for its speed ([`Implicit::slide_drag`]) if that moved
    ///   by more than a quarter, solved again.
    fn slide_change(
        &self,
        k: usize,
        (n, vn, mu, u): (Vec3, Real, Real, Vec3),
        (drag, t, kinetic): (Real, Vec3, Real),
        vt: Vec3,
        push: Real,
    ) -> Option<(Constraint, bool)> {
        let speed = vt.length();
        let friction = mu * push;
        if t == Vec3::ZERO {
            let new = self.slide_drag(k, n, friction, speed, drag);
            return ((new - drag).abs() > 0.25 * drag.max(new)).then_some((
                Constraint::Normal {
                    n,
                    vn,
                    mu,
                    drag: new,
                    t,
                    kinetic,
                    u,
                },
                true,
            ));
        }
        // At a speed of round-off size its direction is round-off too, off the tangent plane
        // (found on a cloth over a ball: a friction the filtered solve cannot balance, 4000
        // iterations): stopped, as a slide that reverses; and the direction is taken in the
        // plane.
        let vt = vt - n * n.dot(vt);
        let speed = vt.length();
        if vt.dot(t) <= 0.0 || speed <= STOPPED_SPEED {
            return Some((stopped_slide((n, vn, mu, u), kinetic, speed), true));
        }
        let dir = vt / speed;
        let moved = (dir * friction - t * kinetic).length() > 0.25 * friction.max(kinetic);
        let c = Constraint::Normal {
            n,
            vn,
            mu,
            drag: friction / speed.max(SLIDE_EPSILON),
            t: dir,
            kinetic: friction,
            u,
        };
        Some((c, moved))
    }

    /// After the step's last solve: every slide that it moved against its direction (whose
    /// friction would push it on) becomes a drag-only slide. Returns whether any did.
    fn stop_reversed_slides(&mut self) -> bool {
        let mut any = false;
        for k in 0..self.constraints.len() {
            let c = self.constraints[k];
            if let Constraint::Normal {
                n,
                vn,
                mu,
                t,
                kinetic,
                u,
                ..
            } = c
            {
                let vt = c.slip(self.v.get(k));
                if t != Vec3::ZERO && vt.dot(t) <= 0.0 {
                    self.constraints[k] = stopped_slide((n, vn, mu, u), kinetic, vt.length());
                    self.precondition_one(k);
                    any = true;
                }
            }
        }
        any
    }

    /// After solves that kept the contact set (the bubble's pressure passes): contacts that
    /// pull go free, held ones outside the friction cone slide (their first drag as in the
    /// contact passes). Returns whether any changed.
    fn recheck_contacts(&mut self, state: &State, dt: Real) -> bool {
        let mut changed = false;
        for k in 0..self.constraints.len() {
            let lambda = self.av.get(k) - self.rhs.get(k);
            match self.constraints[k] {
                Constraint::Normal { n, .. } if lambda.dot(n) < 0.0 => {
                    self.constraints[k] = Constraint::Free;
                    self.precondition_one(k);
                    changed = true;
                }
                Constraint::Stick { n, vn, mu, u } => {
                    if let Some(c) = self.held_change(k, (n, vn, mu, u), state, dt) {
                        self.constraints[k] = c;
                        self.precondition_one(k);
                        changed = true;
                    }
                }
                _ => {}
            }
        }
        changed
    }

    /// The inverse diagonal at particle `k` after its constraint changed (a slide's drag).
    fn precondition_one(&mut self, k: usize) {
        // The multigrid's matrix has this row as it was.
        self.mg_built = false;
        // Its constraint changed, and with it its row's drag.
        if self.av_fresh {
            self.av_rows.push(k as u32);
        }
        let d = self.diag_base.get(k);
        let d = match self.constraints[k] {
            Constraint::Normal { n, drag, t, .. } => d + (Vec3::ONE - n * n - t * t) * drag,
            _ => d,
        };
        self.inv_diag.set(k, Vec3::ONE / d);
    }

    /// `z = M^-1 r` on the active particles: the diagonal, or the multigrid V-cycle with the
    /// gas springs' Woodbury correction, filtered.
    fn precondition_residual(&mut self, active: &[u32]) {
        if !self.use_multigrid {
            for &k in active {
                let k = k as usize;
                let z = self.constraints[k].filter(self.r.get(k) * self.inv_diag.get(k));
                self.z.set(k, z);
            }
            return;
        }
        let (r, z, constraints) = (&self.r, &mut self.z, &self.constraints);
        let free =
            |k: usize| matches!(constraints[k], Constraint::Free | Constraint::Normal { .. });
        self.mg.apply(
            |k| if free(k) { r.get(k) } else { Vec3::ZERO },
            |k, x| z.set(k, constraints[k].filter(x)),
        );
        if self.gas_w.is_empty() {
            return;
        }
        // z -= W G^-1 W^T r.
        let m = self.gas_w.len();
        let y = &mut self.gas_y;
        y.clear();
        y.extend(self.gas_w.iter().map(|w| {
            active
                .iter()
                .map(|&k| w.get(k as usize).dot(r.get(k as usize)))
                .sum::<Real>()
        }));
        cholesky_solve(&self.gas_chol, m, y);
        for &k in active {
            let k = k as usize;
            let mut c = z.get(k);
            for (w, y) in self.gas_w.iter().zip(y.iter()) {
                c -= w.get(k) * *y;
            }
            z.set(k, c);
        }
    }

    /// The multigrid hierarchy of the filtered system matrix (without the gas springs'
    /// rank-one terms), and their Woodbury correction.
    fn build_multigrid(&mut self, sys: &System<'_>) {
        let (nx, nz) = (sys.nx, sys.nz);
        let dt2 = sys.dt2;
        let blocks = self.mg.fine(nx, nz);
        for (dir, run, oa, ob) in self.runs.clone().iter().cloned() {
            let (sa, sb) = match dir {
                Dir::Right => (slot(1, 0), slot(-1, 0)),
                Dir::Down => (slot(0, 1), slot(0, -1)),
                Dir::Diag => (slot(1, 1), slot(-1, -1)),
                Dir::Anti => (slot(-1, 1), slot(1, -1)),
            };
            let set = self.springs.get(dir);
            for e in run {
                let d = set.d.get(e);
                let h = (DMat3::from_diagonal(Vec3::splat(set.ks[e])) + outer(d) * set.kd[e]) * dt2;
                let (a, b) = (e + oa, e + ob);
                blocks[a][CENTRE] += h;
                blocks[b][CENTRE] += h;
                blocks[a][sa] -= h;
                blocks[b][sb] -= h;
            }
        }
        let proj = |c: Constraint| match c {
            Constraint::Free => DMat3::IDENTITY,
            Constraint::Normal { n, .. } => DMat3::IDENTITY - outer(n),
            Constraint::Stick { .. } | Constraint::Fixed(_) => DMat3::ZERO,
        };
        for a in 0..nx * nz {
            let c = self.constraints[a];
            let (i, j) = (a % nx, a / nx);
            let sa = proj(c);
            let mut centre = blocks[a][CENTRE] + DMat3::from_diagonal(Vec3::splat(self.inertia[a]));
            if let Constraint::Normal { n, drag, t, .. } = c {
                centre += (DMat3::IDENTITY - outer(n) - outer(t)) * drag;
            }
            let free = c == Constraint::Free;
            blocks[a][CENTRE] = if free {
                centre
            } else {
                // A constrained direction keeps only its own diagonal (the solve never sees it).
                let scale = (centre.x_axis.x + centre.y_axis.y + centre.z_axis.z) / 3.0;
                sa * centre * sa + (DMat3::IDENTITY - sa) * scale
            };
            // Off-diagonal blocks: S_a A_ab S_b.
            for (s, b) in neighbours(i, j, nx, nz) {
                let cb = self.constraints[b];
                if !(free && cb == Constraint::Free) {
                    blocks[a][s] = sa * blocks[a][s] * proj(cb);
                }
            }
        }
        self.mg.build();
        // The gas springs: u_r = S g_r over the region, w_r = S V u_r, and the Cholesky
        // factor of G = diag(1 / (dt^2 k_r)) + U^T W.
        let n = nx * nz;
        let regions = &mut self.gas_regions;
        regions.clear();
        regions.extend(
            (0..self.gas.len())
                .filter(|&r| self.gas[r] > 0.0)
                .take(MAX_GAS_CORRECTIONS),
        );
        let m = regions.len();
        self.gas_u.truncate(m);
        self.gas_w.truncate(m);
        self.gas_u.resize_with(m, || Soa::zeros(n));
        self.gas_w.resize_with(m, || Soa::zeros(n));
        for ((&r, u), w) in regions.iter().zip(&mut self.gas_u).zip(&mut self.gas_w) {
            for k in 0..n {
                let g = if sys.regions.of(k) == Some(r) {
                    self.constraints[k].filter(self.per_pascal.get(k))
                } else {
                    Vec3::ZERO
                };
                u.set(k, g);
            }
            let constraints = &self.constraints;
            self.mg
                .apply(|k| u.get(k), |k, x| w.set(k, constraints[k].filter(x)));
        }
        self.gas_chol.clear();
        self.gas_chol.resize(m * m, 0.0);
        for a in 0..m {
            for b in 0..m {
                let (u, w) = (&self.gas_u[a], &self.gas_w[b]);
                let mut dot = 0.0;
                for k in 0..n {
                    dot += u.get(k).dot(w.get(k));
                }
                let own = if a == b {
                    1.0 / self.gas[regions[a]]
                } else {
                    0.0
                };
                self.gas_chol[a * m + b] = dot + own;
            }
        }
        cholesky(&mut self.gas_chol, m);
    }

    /// [`Implicit::solve`] to `tolerance`, counting its iterations, then `q = A v+` (the
    /// constraint forces are `(A v+ - b) / dt`).
    fn solve_and_apply(&mut self, sys: &System<'_>, tolerance: Real) {
        self.iterations += self.solve(sys, tolerance);
        self.apply_v(sys);
    }

    /// A stamp no row of `row_mark` holds yet (the marks of earlier passes then read as
    /// unmarked).
    fn next_stamp(&mut self) -> u32 {
        self.row_stamp = self.row_stamp.wrapping_add(1);
        if self.row_stamp == 0 {
            self.row_mark.fill(0);
            self.row_stamp = 1;
        }
        self.row_stamp
    }

    /// `av = A v`. Without gas springs (whose rank-one terms couple every particle of a
    /// region) and while the matrix is unchanged since the last product but for the rows whose
    /// constraints changed, only the rows around the particles whose velocity moved are taken
    /// again, each summed in the order of the whole product's passes ([`Implicit::row_exact`]),
    /// so the result has the same bits: a cloth pressed flat moves a few dozen particles a solve
    /// and the product cost as much as the rest of its step. Otherwise (or where more than an
    /// eighth of the particles moved) the whole product.
    fn apply_v(&mut self, sys: &System<'_>) {
        let (nx, nz) = (sys.nx, sys.nz);
        let n = nx * nz;
        if self.av_fresh && self.gas.iter().all(|&g| g == 0.0) {
            let mut moved = 0;
            let stamp = self.next_stamp();
            let mut rows = std::mem::take(&mut self.av_rows);
            for &k in &rows {
                self.row_mark[k as usize] = stamp;
            }
            for k in 0..n {
                if same_bits(self.v.get(k), self.av_of.get(k)) {
                    continue;
                }
                moved += 1;
                if 8 * moved > n {
                    break;
                }
                each_new_neighbour(nx, nz, k, &mut self.row_mark, stamp, |m| {
                    rows.push(m as u32)
                });
                self.av_of.set(k, self.v.get(k));
            }
            if 8 * moved <= n {
                for &m in &rows {
                    let y = self.row_exact(sys, m as usize);
                    self.av.set(m as usize, y);
                }
                rows.clear();
                self.av_rows = rows;
                #[cfg(test)]
                self.check_partial_product(sys);
                return;
            }
            rows.clear();
            self.av_rows = rows;
        }
        self.apply(sys, Which::V, None);
        std::mem::swap(&mut self.q, &mut self.av);
        self.av_of.clone_from(&self.v);
        self.av_rows.clear();
        self.av_fresh = true;
        self.av_dt2 = sys.dt2;
        self.av_gas_free = self.gas.iter().all(|&g| g == 0.0);
    }

    /// At a step's start, after [`Implicit::precondition`]: keeps the last step's product
    /// `av` (taken at its final velocities and constraints; `fresh`: it was current then and
    /// this step's `forces` kept the springs whose particles did not move) as this step's, marking for the next [`Implicit::apply_v`] only the rows whose matrix
    /// changed: around the particles whose springs were linearised anew, and where a slide's
    /// drag changed. That holds where the springs elsewhere kept their linearisation, the step
    /// has the last one's size (the inertia and `dt^2` the same) and no gas spring acts now or
    /// then; on a cloth the vacuum pins, a step's first product then costs a few dozen rows
    /// instead of the whole grid.
    fn keep_product(&mut self, sys: &System<'_>, fresh: bool) {
        let gas_free = self.gas.iter().all(|&g| g == 0.0);
        if !(fresh && gas_free && self.av_gas_free && sys.dt2.to_bits() == self.av_dt2.to_bits()) {
            return;
        }
        let (nx, nz) = (sys.nx, sys.nz);
        let n = nx * nz;
        let stamp = self.next_stamp();
        let mut mark = std::mem::take(&mut self.row_mark);
        let mut rows = std::mem::take(&mut self.av_rows);
        rows.clear();
        for k in (0..n).filter(|&k| self.lin_moved[k]) {
            each_new_neighbour(nx, nz, k, &mut mark, stamp, |m| rows.push(m as u32));
        }
        for k in 0..n {
            if mark[k] != stamp && !same_drag(self.constraints[k], self.prev_constraints[k]) {
                mark[k] = stamp;
                rows.push(k as u32);
            }
        }
        self.row_mark = mark;
        // Where many rows changed the whole product is as cheap.
        self.av_fresh = 8 * rows.len() <= n;
        if !self.av_fresh {
            rows.clear();
        }
        #[cfg(test)]
        if self.av_fresh {
            KEPT_PRODUCTS.with(|c| c.set(c.get() + 1));
        }
        self.av_rows = rows;
    }

    /// In the unit tests: the partial product just taken has the bits of the whole one.
    #[cfg(test)]
    fn check_partial_product(&mut self, sys: &System<'_>) {
        self.apply(sys, Which::V, None);
        for k in 0..self.v.len() {
            assert!(
                same_bits(self.q.get(k), self.av.get(k)),
                "row {k}: partial {} whole {}",
                self.av.get(k),
                self.q.get(k)
            );
        }
        PARTIAL_PRODUCTS.with(|c| c.set(c.get() + 1));
    }

    /// Row `a` of `A v` where no gas spring acts, with the bits of the whole product
    /// ([`Implicit::apply_all`]; its springs' terms summed by [`Implicit::stencil_sum`]).
    #[inline]
    fn row_exact(&self, sys: &System<'_>, a: usize) -> Vec3 {
        let p = &self.v;
        // Spring `e`'s `H_e (p_a - p_b)`, added to its first particle and taken from its second.
        let h = self.stencil_sum(sys, a, |set, e, oa, ob, first| {
            let w = set.apply(e, p.get(e + oa) - p.get(e + ob));
            if first { w } else { -w }
        });
        let pa = p.get(a);
        let q = pa * self.inertia[a] + h * sys.dt2;
        let mut y = q + self.constraints[a].drag(pa);
        if let Some(r) = sys.regions.of(a) {
            y += self.per_pascal.get(a) * (self.gas[r] * self.dots[r]);
        }
        // As the whole product keeps `q` where the sum compares equal (a zero's sign).
        if y != q { y } else { q }
    }

    /// After a step's final solve: a spring it takes past the strain limit goes onto its stiff
    /// branch and the step is solved once more (no other constraint changes).
    fn limit_and_resolve(
        &mut self,
        sys: &System<'_>,
        model: &Model,
        x: &Soa,
        dt: Real,
        tolerance: Real,
    ) {
        if self.tighten(model, x, dt) {
            self.precondition(sys);
            self.solve_and_apply(sys, tolerance);
        }
    }

    /// Solves `A v = rhs` for the free directions, the constrained ones fixed at their values,
    /// by the filtered, preconditioned conjugate gradient from the current `v`, to the relative
    /// residual `tolerance`. Returns the iterations taken.
    fn solve(&mut self, sys: &System<'_>, tolerance: Real) -> usize {
        let n = self.v.len();
        // The particles with a free direction: the solve runs over them alone.
        let mut active = std::mem::take(&mut self.active);
        active.clear();
        // `p` is read at the neighbours of the active particles, so it is zero elsewhere; `r`
        // and `z` are only read on the active ones, which set them below.
        for v in [&mut self.p.x, &mut self.p.y, &mut self.p.z] {
            v.fill(0.0);
        }
        for k in 0..n {
            let c = self.constraints[k];
            self.v.set(k, c.filter(self.v.get(k)) + c.value());
            if matches!(c, Constraint::Free | Constraint::Normal { .. }) {
                active.push(k as u32);
            }
        }
        self.apply(sys, Which::V, Some(&active));
        let mut bb = 0.0;
        let mut rz = 0.0;
        let mut rr = 0.0;
        for &k in &active {
            let k = k as usize;
            let c = self.constraints[k];
            let b = c.filter(self.rhs.get(k)) + c.friction();
            bb += b.length_squared();
            let r = c.filter(self.rhs.get(k) - self.q.get(k)) + c.friction();
            self.r.set(k, r);
            rr += r.length_squared();
        }
        // The V-cycle runs over the whole grid, the diagonal over the free particles alone: the
        // multigrid pays where most of a large cloth is free.
        self.use_multigrid = n >= MULTIGRID_MIN_PARTICLES && 2 * active.len() >= n;
        if self.use_multigrid && !self.mg_built {
            self.build_multigrid(sys);
            self.mg_built = true;
        }
        self.precondition_residual(&active);
        for &k in &active {
            let k = k as usize;
            let z = self.z.get(k);
            self.p.set(k, z);
            rz += self.r.get(k).dot(z);
        }
        // The converged budget's residual is relative to the right-hand side; the interactive
        // one's to the smaller of that and the residual the step's first solve started from
        // (see `INTERACTIVE_TOLERANCE`).
        let scale = match self.budget {
            SolveBudget::Converged => bb,
            SolveBudget::Interactive => bb.min(*self.first_residual.get_or_insert(rr)),
        };
        let goal = tolerance * tolerance * scale.max(Real::MIN_POSITIVE);
        let mut it = 0;
        // Where most particles are free, the whole grid's product (vectorised, a direction of
        // springs at a time) is faster than the list's rows.
        let whole = 4 * active.len() >= 3 * n;
        while rr > goal && it < CG_MAX_ITERATIONS {
            self.apply(sys, Which::P, (!whole).then_some(&active[..]));
            let mut pq = 0.0;
            for &k in &active {
                let k = k as usize;
                let q = self.constraints[k].filter(self.q.get(k));
                self.q.set(k, q);
                pq += self.p.get(k).dot(q);
            }
            if pq.is_nan() || pq <= 0.0 {
                break;
            }
            let alpha = rz / pq;
            let (mut rz_new, mut rr_new) = (0.0, 0.0);
            for &k in &active {
                let k = k as usize;
                self.v.set(k, self.v.get(k) + self.p.get(k) * alpha);
                let r = self.r.get(k) - self.q.get(k) * alpha;
                self.r.set(k, r);
                rr_new += r.length_squared();
            }
            self.precondition_residual(&active);
            for &k in &active {
                let k = k as usize;
                rz_new += self.r.get(k).dot(self.z.get(k));
            }
            let beta = rz_new / rz;
            for &k in &active {
                let k = k as usize;
                self.p.set(k, self.z.get(k) + self.p.get(k) * beta);
            }
            rz = rz_new;
            rr = rr_new;
            it += 1;
        }
        self.active = active;
        it
    }

    /// How much the bubble's volume (eq. 3.10) at the end of the step, with the current
    /// velocities, differs from its linear prediction `now + sum of g_k . v_k dt` (m^3;
    /// `now` its volume at the step's start, the same eq. 3.10 at `x`). The
    /// thesis' pressure force `g_k = S N_k` is not the volume's gradient (a border particle's
    /// share of the volume is half an inner one's, its force the same), so a lift that raises
    /// the middle while the rim comes down changes the volume otherwise than `g` predicts.
    fn volume_miss(&mut self, model: &Model, x: &Soa, now: Real, dt: Real) -> Real {
        let Some(plane) = model.sticking else {
            return 0.0;
        };
        let n = x.len();
        let end = &mut self.end;
        end.x.resize(n, 0.0);
        end.y.resize(n, 0.0);
        end.z.resize(n, 0.0);
        let mut linear = 0.0;
        for k in 0..n {
            let v = self.v.get(k);
            end.set(k, x.get(k) + v * dt);
            linear += self.per_pascal.get(k).dot(v) * dt;
        }
        let then = crate::air::volume(&model.grid, end, plane, model.radius);
        then - now - linear
    }

    /// The rims of the pockets of air: a sealed particle beside a pocket feels its share of the
    /// pocket's pressure difference (the mean over the cells around it, as the explicit step
    /// spreads it, `pockets::sealed_share`). A pocket's pressure at the step's end is what the
    /// solve finds (its gas spring: `P - (P / V) g . v dt`), so the share is applied from the
    /// last solve and the step solved again while it moves by more than
    /// [`PRESSURE_TOLERANCE`]: the rim lags the pocket by a solve, not by a step. (The rim's own
    /// motion does not enter the pocket's volume: a sealed particle lies on the surface.) With
    /// `start`, before the first solve of a step, the rims start from nothing applied and take
    /// the pockets' pressures now. Returns whether any particle's share changed.
    fn rim_pressures(&mut self, model: &Model, regions: &Regions, dt: Real, start: bool) -> bool {
        let n = self.v.len();
        let count = regions.list.len();
        self.end_pressure.clear();
        self.end_pressure.resize(count, 0.0);
        if start {
            for &(k, _, _) in &regions.rim {
                self.rim_applied[k as usize] = 0.0;
            }
        } else {
            for k in 0..n {
                if let Some(r) = regions.of(k) {
                    self.end_pressure[r] += self.per_pascal.get(k).dot(self.v.get(k));
                }
            }
        }
        for (r, p) in self.end_pressure.iter_mut().enumerate() {
            let region = regions.list[r];
            *p = region.pressure - regions.atmosphere - region.stiffness * dt * *p;
        }
        for &(k, _, _) in &regions.rim {
            self.rim_target[k as usize] = 0.0;
        }
        for &(k, r, w) in &regions.rim {
            self.rim_target[k as usize] += w * self.end_pressure[r as usize];
        }
        let mut changed = false;
        for &(k, _, _) in &regions.rim {
            let k = k as usize;
            // At most the particle's water film's pull: a sealed particle is one the film holds,
            // so the air never pushes it off within a step (a pocket's pressure at its first
            // steps, its air placed under a flat cloth, is 1e8 Pa); the pressure beyond lifts the
            // cloth inside, and the sealing at the step's end decides where the rim now runs.
            let pull = model.wet_adhesion * model.wetness[k];
            self.rim_target[k] = self.rim_target[k].min(pull);
            let dp = self.rim_target[k] - self.rim_applied[k];
            if dp.abs() > PRESSURE_TOLERANCE {
                let f = self.rhs.get(k) + self.per_pascal.get(k) * (dp * dt);
                self.rhs.set(k, f);
                self.rim_applied[k] = self.rim_target[k];
                changed = true;
            }
        }
        changed
    }

    /// Adds to the right-hand side the pressure force of a drop `dp` (Pa) of the bubble's
    /// pressure: `-dp g_k dt` on every particle.
    fn shift_pressure(&mut self, dp: Real, dt: Real) {
        for k in 0..self.rhs.len() {
            let f = self.rhs.get(k) - self.per_pascal.get(k) * (dp * dt);
            self.rhs.set(k, f);
        }
    }

    /// One step of `dt` s (see the module docs). Returns the largest squared distance (m^2) of
    /// a new position of a particle no hand holds from `fused.reference`.
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
        let n = state.len();
        let (nx, nz) = (model.grid.nx, model.grid.nz);
        // The air as regions; a pressure known now (explicit) is no gas spring in the solve.
        air.model
            .regions(air.params, model, control.air_enabled, &mut self.regions);
        let implicit_air = air.timing == Timing::EndOfStep;
        self.gas.clear();
        self.gas.extend(self.regions.list.iter().map(|r| {
            if implicit_air {
                dt * dt * r.stiffness
            } else {
                0.0
            }
        }));
        self.forces(model, &state.x);
        // The colliders where they are over the step (for moving ones).
        let mut surfaces = std::mem::take(&mut self.surfaces);
        Surface::of_step(model, fused.start, dt, &mut surfaces);
        let c = model.damping;
        let Motion::Previous(prev) = &state.motion else {
            unreachable!("converted above")
        };
        for k in 0..n {
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
            // The velocity at the start, for the contacts below (`r` is free until the solve).
            self.r.set(k, v);
        }
        // Constraints: the hands, then contacts where a particle touches or would reach a
        // collider during the step at its current speed. A contact that ended the last step
        // sliding and still moves starts sliding against the friction it had; any other starts
        // held (the friction cone decides after the first solve). Starting every contact held,
        // a cloth sliding over the table was gripped anew at each step's start: the thesis
        // demo lifted at 1/60 s pulled the hand with 0.26 N against the explicit 0.14 N.
        // The last step's final constraints are kept beside this step's (`keep_product`).
        std::mem::swap(&mut self.constraints, &mut self.prev_constraints);
        self.constraints.fill(Constraint::Free);
        for (k, target) in control.active() {
            self.constraints[k] = Constraint::Fixed((target - state.x.get(k)) / dt);
        }
        for k in 0..n {
            if self.constraints[k] != Constraint::Free {
                continue;
            }
            let (x, v) = (state.x.get(k), self.r.get(k));
            let c = contact_constraint(model, &surfaces, k, x, v, dt, state.contact[k]);
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
        // `System` borrows the regions; the rest of `self` is used mutably below.
        let regions = std::mem::take(&mut self.regions);
        let sys = System {
            nx,
            nz,
            dt2: dt * dt,
            regions: &regions,
        };
        // Read before `precondition` consumes them.
        let product_current = self.av_fresh && self.diag_kept;
        self.precondition(&sys);
        self.keep_product(&sys, product_current);
        self.iterations = 0;
        self.first_residual = None;
        // The thesis bubble's gas spring (Pa/m^3), whose pressure the solve predicts from the
        // volume at the step's end: its miss beyond the linear prediction (`volume_miss`) shifts
        // the pressure, and the step is solved again while the shift moves.
        let stiff = match (&air.model, regions.list.first()) {
            (crate::air::AirModel::Thesis(_), Some(r)) if implicit_air => r.stiffness,
            _ => 0.0,
        };
        let mut miss = 0.0;
        let mut shift = Relaxation::default();
        // The bubble's volume now (m^3): measured once, the miss is measured after each solve.
        let start_volume = match model.sticking {
            Some(plane) if stiff > 0.0 => {
                crate::air::volume(&model.grid, &state.x, plane, model.radius)
            }
            _ => 0.0,
        };
        if stiff > 0.0 {
            miss = self.volume_miss(model, &state.x, start_volume, dt);
            self.shift_pressure(stiff * miss, dt);
        }
        // The rims start from their pockets' pressures now (a pocket at rest keeps them: no
        // second solve), and follow the solves' end-of-step pressures.
        if implicit_air && !regions.rim.is_empty() {
            self.rim_pressures(model, &regions, dt, true);
        }
        // The budget: solves while the contacts change, solves that only correct the bubble's
        // pressure, and the tolerance of the final ones. The interactive budget takes one solve
        // with the contacts the step starts with (landings are resolved after the step), one
        // pressure correction and one re-check of the contacts, all to its coarse tolerance.
        let interactive = self.budget == SolveBudget::Interactive;
        let (passes, pressure_passes, tolerance) = if interactive {
            (1, 1, INTERACTIVE_TOLERANCE)
        } else {
            (CONTACT_PASSES, PRESSURE_PASSES, CG_TOLERANCE)
        };
        for pass in 0..passes {
            let last = pass + 1 == passes;
            self.solve_and_apply(
                &sys,
                if last {
                    tolerance
                } else {
                    CG_CONTACT_TOLERANCE
                },
            );
            if last {
                self.limit_and_resolve(&sys, model, &state.x, dt, tolerance);
                break;
            }
            // Release contacts that pull or slip; constrain particles that would land inside
            // a collider.
            let mut changed = false;
            self.landed.clear();
            self.landed.resize(n, false);
            for k in 0..n {
                let c = self.constraints[k];
                match c {
                    Constraint::Normal {
                        n: normal,
                        vn,
                        mu,
                        drag,
                        t,
                        kinetic,
                        u,
                    } => {
                        // The normal impulse: the residual's normal part (friction is
                        // tangential).
                        let v = self.v.get(k);
                        let lambda = self.av.get(k) - self.rhs.get(k);
                        let push = lambda.dot(normal);
                        if push < 0.0 {
                            self.constraints[k] = Constraint::Free;
                            self.precondition_one(k);
                            changed = true;
                        } else if let Some(c) = self.slide_change(
                            k,
                            (normal, vn, mu, u),
                            (drag, t, kinetic),
                            c.slip(v),
                            push,
                        ) {
                            self.constraints[k] = c.0;
                            self.precondition_one(k);
                            changed |= c.1;
                        }
                    }
                    Constraint::Free => {
                        let x = state.x.get(k);
                        let to = x + self.v.get(k) * dt;
                        if let Some((c, through)) = landing_constraint(model, &surfaces, k, x, to, dt) {
                            self.constraints[k] = self.landing_friction(k, c);
                            self.precondition_one(k);
                            self.landed[k] = through;
                            changed = true;
                        }
                    }
                    Constraint::Stick {
                        n: normal,
                        vn,
                        mu,
                        u,
                    } => {
                        // Inside the friction cone, or sliding, or pulling free.
                        if let Some(c) = self.held_change(k, (normal, vn, mu, u), state, dt) {
                            self.constraints[k] = c;
                            self.precondition_one(k);
                            changed = true;
                        }
                    }
                    Constraint::Fixed(_) => {}
                }
            }
            if stiff > 0.0 {
                let now = self.volume_miss(model, &state.x, start_volume, dt);
                let dp = shift.next(stiff * miss, stiff * now);
                if dp.abs() > PRESSURE_TOLERANCE {
                    self.shift_pressure(dp, dt);
                    miss += dp / stiff;
                    changed = true;
                }
            }
            if implicit_air
                && !regions.rim.is_empty()
                && self.rim_pressures(model, &regions, dt, false)
            {
                changed = true;
            }
            // The strain limit: springs this solve takes past it go onto their stiff branch.
            if self.tighten(model, &state.x, dt) {
                self.precondition(&sys);
                changed = true;
            }
            if !changed {
                // The contact set holds: finish this solve to the full tolerance (and, as after
                // the last allowed solve, once more if that takes a spring past the limit).
                self.solve_and_apply(&sys, tolerance);
                self.limit_and_resolve(&sys, model, &state.x, dt, tolerance);
                break;
            }
        }
        // The bubble's pressure, once more from the last (accurate) solve: the passes above
        // measure the miss after solves stopped at CG_CONTACT_TOLERANCE and never after the
        // last one. The contact set is kept.
        let mut shifted = false;
        if stiff > 0.0 {
            for _ in 0..pressure_passes {
                let now = self.volume_miss(model, &state.x, start_volume, dt);
                let dp = shift.next(stiff * miss, stiff * now);
                if dp.abs() <= PRESSURE_TOLERANCE {
                    break;
                }
                self.shift_pressure(dp, dt);
                miss += dp / stiff;
                self.solve_and_apply(&sys, tolerance);
                shifted = true;
            }
        }
        // Those solves kept the contact set while the pressure moved, and with it every
        // contact's normal force: one held at the friction cone's edge (a rim that friction
        // barely holds against the tent's pull) may now be outside it, one barely pressed may
        // pull. They slide or go free and the step is solved once more. Without it the held
        // `air-400` (1/600 s) crept: its rim slid inwards by 0.8 mm in 0.37 s, ratcheted by
        // the pressure's few pascals from step to step, and its contact fraction flickered
        // between 0.415 and 0.45 (the explicit integrator's stays at 0.457).
        if interactive {
            // The interactive budget's single pass over the contacts and the pockets' rims,
            // whether or not the pressure moved. (Without the rims' pressures here they kept
            // those of the step's start, and `pockets-bubbles` and `pockets-merge` blew up at
            // 1/60 s.)
            let mut changed = self.recheck_contacts(state, dt);
            if implicit_air && !regions.rim.is_empty() {
                changed |= self.rim_pressures(model, &regions, dt, false);
            }
            if changed {
                self.solve_and_apply(&sys, tolerance);
            }
        } else if shifted && self.recheck_contacts(state, dt) {
            self.solve_and_apply(&sys, tolerance);
        }
        // A slide the last solve moved against its direction would have its friction push it
        // on: it becomes a drag-only slide and the step is solved again.
        for _ in 0..passes {
            if !self.stop_reversed_slides() {
                break;
            }
            self.solve_and_apply(&sys, tolerance);
        }
        self.total_iterations += self.iterations as u64;
        // The constraint forces of the final solution (in `av`): the hands' and the contacts'.
        self.regions = regions;
        let Motion::Previous(prev) = &mut state.motion else {
            unreachable!("converted above")
        };
        let mut work = 0.0;
        for (g, target) in control.grabs.iter_mut().zip(&control.targets) {
            let k = g.particle;
            match target {
                Some(target) => {
                    g.force = (self.av.get(k) - self.rhs.get(k)) / dt;
                    work += checks::work(g.force, state.x.get(k), *target).abs();
                }
                None => g.force = Vec3::ZERO,
            }
        }
        control.hand_work += work;
        // Friction, the move, and any contact the solve did not foresee.
        let mut moved: Real = 0.0;
        let single_still = model.colliders.len() == 1 && model.moving.is_empty();
        // The thesis' bubble's volume change over the step, m^3 (its pressure below).
        let bubble = matches!(air.model, crate::air::AirModel::Thesis(_));
        let mut volume_change = 0.0;
        // The moving colliders' work on the cloth over the step, J (magnitudes summed, as the
        // explicit integrator's).
        let mut surface_work = 0.0;
        for k in 0..n {
            let x = state.x.get(k);
            let v = self.v.get(k);
            let mut touched = false;
            if let Constraint::Normal { n: normal, .. } | Constraint::Stick { n: normal, .. } =
                self.constraints[k]
            {
                // Touching while the surface pushes.
                let lambda = self.av.get(k) - self.rhs.get(k);
                touched = lambda.dot(normal) > 0.0;
                // A moving surface works on the cloth it pushes and carries: the contact's
                // impulse (N s) times the surface's velocity (m/s).
                if let Constraint::Normal { u, .. } | Constraint::Stick { u, .. } =
                    self.constraints[k]
                    && u != Vec3::ZERO
                {
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
                            resolve_surfaces(&surfaces, x, to, model, k, scale, dt * dt);
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
            // first guess above started from) to the one it ends with.
            let v0 = (x - prev.get(k)) / dt;
            state.acceleration.set(k, ((to - x) / dt - v0) / dt);
            prev.set(k, to);
        }
        std::mem::swap(prev, &mut state.x);
        control.collider_work += surface_work;
        self.surfaces = surfaces;
        // The pressure the step applied: the gas spring's, linearised at the end of the step.
        if let crate::air::AirModel::Thesis(b) = air.model
            && control.air_enabled
            && let Some(r) = self.regions.list.first()
        {
            b.applied_pressure = if implicit_air {
                (r.pressure - r.stiffness * (volume_change + miss)).max(0.0)
            } else {
                r.pressure
            };
        }
        fused.measures.remeasure_all(
            &model.grid,
            &state.x,
            model.sticking,
            model.radius,
            fused.rows_per_task,
        );
        moved
    }
}

/// Pressure change (Pa) of the bubble's volume correction that calls for another solve.
const PRESSURE_TOLERANCE: Real = 1e-2;

/// Most solves after the contact set is settled that only correct the bubble's pressure.
const PRESSURE_PASSES: usize = 4;

/// The bubble's pressure shift inside a step, by a relaxed fixed-point iteration whose
/// relaxation is set from the slope it measures. The shift `s` (Pa) the solve applied should
/// equal the gas spring times the volume miss it leads to, `k miss(s)`: a root of
/// `F(s) = k miss(s) - s`. Taking `s = k miss` (the plain fixed-point step `s += F`) converges
/// only while the miss answers a shift by less than the shift itself; at large steps it does
/// not (the thesis' force `S N_k` and the volume's gradient differ on a tent's slopes, and the
/// gas spring is stiff), and the pressure swung by tens of pascals from step to step at 1/60 s.
/// Here the step is `F / (1 - F')`, `F'` measured from the last two solves and the scale kept
/// within [`Relaxation::MIN_SCALE`] and [`Relaxation::MAX_SCALE`]. For a miss linear in the
/// shift, `k miss = a + G' s`, that shrinks the error by `1 / (2 - G')` a solve for every slope
/// `G' < 1` down to `-8`, the oscillating ones (`G' < -1`) where the plain step diverges
/// included; below `-8` the scale's floor binds and the error is multiplied by
/// `1 - 0.1 (1 - G')` a solve, which still shrinks it down to `G' = -19` and no further (the
/// unit test measures both regimes). (It is not the secant step `-F / F'`, which would land on
/// a linear miss's root at once; the measurements in docs/integrators.md are of this one.)
#[derive(Clone, Copy, Debug, Default)]
struct Relaxation {
    /// The last shift (Pa) and its residual `F` (Pa), if any.
    last: Option<(Real, Real)>,
}

impl Relaxation {
    /// Smallest and largest scale of the fixed-point step: a slope that would ask for less or
    /// more is taken as measured through the noise of a changing contact set.
    const MIN_SCALE: Real = 0.1;
    const MAX_SCALE: Real = 1.5;

    /// The change of shift (Pa) after a solve with shift `s` (Pa) whose miss asks for
    /// `target` (Pa, the gas spring times the miss).
    fn next(&mut self, s: Real, target: Real) -> Real {
        let f = target - s;
        let scale = match self.last {
            Some((s0, f0)) if s != s0 => {
                let slope = (f - f0) / (s - s0);
                (1.0 / (1.0 - slope)).clamp(Self::MIN_SCALE, Self::MAX_SCALE)
            }
            _ => 1.0,
        };
        self.last = Some((s, f));
        scale * f
    }
}

#[cfg(test)]
thread_local! {
    /// Partial products `A v` taken (and checked against the whole) on this thread.
    static PARTIAL_PRODUCTS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    /// Runs of springs whose kept linearisation was checked against a new one on this thread.
    static KEPT_CHECKS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    /// Steps that kept the last step's product `A v` on this thread.
    static KEPT_PRODUCTS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// Calls `f` on every particle of the 3 x 3 block around particle `k` of an `nx` x `nz` grid
/// (the rows a change at `k` reaches through the 9-point stencil) that `mark` does not yet hold
/// at `stamp`, and marks it.
fn each_new_neighbour(
    nx: usize,
    nz: usize,
    k: usize,
    mark: &mut [u32],
    stamp: u32,
    mut f: impl FnMut(usize),
) {
    let (i, j) = (k % nx, k / nx);
    for jj in j.saturating_sub(1)..(j + 2).min(nz) {
        for ii in i.saturating_sub(1)..(i + 2).min(nx) {
            let m = jj * nx + ii;
            if mark[m] != stamp {
                mark[m] = stamp;
                f(m);
            }
        }
    }
}

/// Whether `a` and `b` are the same bits (a zero's sign included).
#[inline]
fn same_bits(a: Vec3, b: Vec3) -> bool {
    a.x.to_bits() == b.x.to_bits()
        && a.y.to_bits() == b.y.to_bits()
        && a.z.to_bits() == b.z.to_bits()
}

/// Whether the constraints `a` and `b` add the same friction drag to a row of the matrix
/// (only a slide's does: its normal, direction and drag, to the bit).
fn same_drag(a: Constraint, b: Constraint) -> bool {
    match (a, b) {
        (
            Constraint::Normal {
                n: n1,
                drag: d1,
                t: t1,
                ..
            },
            Constraint::Normal {
                n: n2,
                drag: d2,
                t: t2,
                ..
            },
        ) => same_bits(n1, n2) && same_bits(t1, t2) && d1.to_bits() == d2.to_bits(),
        (Constraint::Normal { .. }, _) | (_, Constraint::Normal { .. }) => false,
        _ => true,
    }
}

/// `d d^T`.
#[inline]
fn outer(d: Vec3) -> DMat3 {
    DMat3::from_cols(d * d.x, d * d.y, d * d.z)
}

/// Fewest particles for the multigrid preconditioner (below, the diagonal is as fast).
const MULTIGRID_MIN_PARTICLES: usize = 400;

/// Most gas regions whose rank-one term the multigrid preconditioner corrects for (Woodbury);
/// the others are left to the conjugate gradient.
const MAX_GAS_CORRECTIONS: usize = 8;

/// Which vector [`Implicit::apply`] multiplies.
#[derive(Clone, Copy)]
enum Which {
    P,
    V,
}

/// A slide (contact normal, normal velocity, friction coefficient) that friction stopped
/// within the step, its kinetic impulse `kinetic` (N s), at the tangential speed `speed` (m/s):
/// a drag-only slide (see [`Constraint::Normal`]), its drag giving that impulse at that speed.
fn stopped_slide(
    (n, vn, mu, u): (Vec3, Real, Real, Vec3),
    kinetic: Real,
    speed: Real,
) -> Constraint {
    Constraint::Normal {
        n,
        vn,
        mu,
        drag: kinetic / speed.max(SLIDE_EPSILON),
        t: Vec3::ZERO,
        kinetic: 0.0,
        u,
    }
}

/// A collider as one step's contacts see it: where it is at the step's start (the collider
/// itself if still) and, if it moves, where it is at both ends of the step.
#[derive(Clone, Debug)]
struct Surface {
    collider: Collider,
    frames: Option<Frames>,
}

impl Surface {
    /// The colliders of `model` over the step from `t` to `t + dt` (s); empty where none moves
    /// (the contacts then read `model.colliders` as they are).
    fn of_step(model: &Model, t: Real, dt: Real, out: &mut Vec<Surface>) {
        out.clear();
        if model.moving.is_empty() {
            return;
        }
        out.extend(model.colliders.iter().map(|c| Surface {
            collider: c.at(t),
            frames: c.is_moving().then(|| Frames::of(c, t, dt)),
        }));
    }

    /// The velocity (m/s) over the step of `dt` s of the surface point at `x` (zero if still).
    fn velocity(&self, x: Vec3, dt: Real) -> Vec3 {
        match &self.frames {
            Some(f) => (f.end.to_world(f.start.to_rest(x)) - x) / dt,
            None => Vec3::ZERO,
        }
    }

    /// The contact query of a particle moving from `x` to `to` over the step: in the moving
    /// frame for a moving collider (see [`contact::resolve_moving`]), the normal in the world
    /// at the step's end.
    fn contact(&self, x: Vec3, to: Vec3, radius: Real) -> Option<(Real, Vec3)> {
        match &self.frames {
            Some(f) => {
                let (d, n) =
                    self.collider
                        .rest_contact(f.start.to_rest(x), f.end.to_rest(to), radius)?;
                Some((d, f.end.dir_to_world(n)))
            }
            None => self.collider.contact(x, to, radius),
        }
    }
}

/// [`contact::resolve_scaled`] against the colliders of a step with moving ones: each in turn,
/// a moving one in its moving frame ([`contact::resolve_moving`]) for particle `k` over a step
/// whose forces move it by `F dt2 / m`. Returns the corrected end of the move from `x` to
/// `to`, whether it touched, and the moving colliders' work on it (J, magnitude).
fn resolve_surfaces(
    surfaces: &[Surface],
    x: Vec3,
    mut to: Vec3,
    model: &Model,
    k: usize,
    scale: Real,
    dt2: Real,
) -> (Vec3, bool, Real) {
    let mut touched = false;
    let mut work = 0.0;
    for s in surfaces {
        let (p, hit) = match &s.frames {
            Some(f) => {
                let (p, hit, w) = contact::resolve_moving(
                    &s.collider,
                    f,
                    x,
                    to,
                    model.radius,
                    scale,
                    model.mass(k),
                    dt2,
                );
                work += w.abs();
                (p, hit)
            }
            None => {
                contact::resolve_scaled(std::slice::from_ref(&s.collider), x, to, model.radius, scale)
            }
        };
        to = p;
        touched |= hit;
    }
    (to, touched, work)
}

/// Calls `each` with every collider of the step (`surfaces`, or the model's own when none
/// moves) and its surface velocity at `x` (m/s).
#[inline]
fn each_surface(
    model: &Model,
    surfaces: &[Surface],
    x: Vec3,
    dt: Real,
    mut each: impl FnMut(&Collider, Option<&Surface>, Vec3),
) {
    if surfaces.is_empty() {
        for c in &model.colliders {
            each(c, None, Vec3::ZERO);
        }
    } else {
        for s in surfaces {
            each(&s.collider, Some(s), s.velocity(x, dt));
        }
    }
}

/// The contact constraint of particle `k` at `x` moving at `v` (m/s) over a step of `dt` s:
/// against the collider it is nearest to penetrating, if it touches one (`touching` last
/// step, within its radius plus a 1 % skin) or would reach it at its current speed relative
/// to the surface. On a moving collider the constraint moves with the surface: its normal
/// velocity lands the particle on the surface where the surface is at the step's end, and
/// static friction holds it to the surface's tangential velocity.
fn contact_constraint(
    model: &Model,
    surfaces: &[Surface],
    k: usize,
    x: Vec3,
    v: Vec3,
    dt: Real,
    touching: bool,
) -> Constraint {
    let mut best = Constraint::Free;
    let mut nearest = Real::INFINITY;
    let scale = model.friction_scale.as_ref().map_or(1.0, |s| s[k]);
    each_surface(model, surfaces, x, dt, |c, _, u| {
        let (d, n) = c.distance(x);
        let gap = d - model.radius;
        let skin = if touching { 0.01 * model.radius } else { 0.0 };
        let reach = (-(v - u).dot(n)).max(0.0) * dt;
        if gap <= skin.max(reach) && gap < nearest {
            nearest = gap;
            best = stick(n, gap, dt, c.friction * scale, u);
        }
    });
    best
}

/// A contact held by static friction against a surface of normal `n` moving at `u` (m/s),
/// `gap` (m) away at the step's start, friction coefficient `mu`.
#[inline]
fn stick(n: Vec3, gap: Real, dt: Real, mu: Real, u: Vec3) -> Constraint {
    if u == Vec3::ZERO {
        Constraint::Stick {
            n,
            vn: -gap / dt,
            mu,
            u,
        }
    } else {
        Constraint::Stick {
            n,
            vn: n.dot(u) - gap / dt,
            mu,
            u,
        }
    }
}

/// The contact constraint of a free particle moving from `x` to `to` in a step of `dt` s, if it
/// would end inside a collider, and whether the move took it through the surface (not merely
/// within its radius of it).
fn landing_constraint(
    model: &Model,
    surfaces: &[Surface],
    k: usize,
    x: Vec3,
    to: Vec3,
    dt: Real,
) -> Option<(Constraint, bool)> {
    let scale = model.friction_scale.as_ref().map_or(1.0, |s| s[k]);
    let mut best = None;
    let mut deepest = 0.0;
    each_surface(model, surfaces, x, dt, |c, surface, u| {
        // Measured on the side the particle comes from: an open mesh (a two-sided sheet, whose
        // plain distance has no inside) stops a particle driven through it as a plane does.
        let hit = match surface {
            Some(s) => s.contact(x, to, model.radius),
            None => c.contact(x, to, model.radius),
        };
        let Some((d, n)) = hit else {
            return;
        };
        let depth = model.radius - d;
        if depth > deepest {
            deepest = depth;
            let gap = c.distance(x).0 - model.radius;
            best = Some((stick(n, gap, dt, c.friction * scale, u), d < 0.0));
        }
    });
    best
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
        let x = model.grid.rest_positions(Vec3::ZERO);
        imp.forces(&model, &x);
        let soft = (imp.springs.right.ks[0], imp.springs.right.kd[0]);
        // Particles 0 and 1 (the first `right` spring) pulled apart at 0.3 rest lengths a step.
        let l = model.grid.rest_distance(0, 1);
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

    /// A miss that answers a shift linearly, `k miss(s) = a - b s` (`G' = -b`), root `a / (1 +
    /// b)`. With `b = 2` the plain fixed-point step multiplies the error by `-b` and diverges;
    /// the relaxed one, after its first (plain) step, shrinks it by `1 / (2 - G') = 1 / 4` a
    /// solve. With `b = 20` the scale `1 / 22` is below [`Relaxation::MIN_SCALE`] and clamped:
    /// the error is multiplied by `1 - 0.1 (1 + b) = -1.1` a solve.
    #[test]
    fn relaxation_converges_where_the_fixed_point_diverges() {
        let errors = |b: Real, plain: bool| {
            let (a, root) = (10.0, 10.0 / (1.0 + b));
            let mut shift = Relaxation::default();
            let mut s: Real = 0.0;
            let mut out = Vec::new();
            for _ in 0..6 {
                let target = a - b * s;
                s += if plain {
                    target - s
                } else {
                    shift.next(s, target)
                };
                out.push(s - root);
            }
            out
        };
        let plain = errors(2.0, true);
        let relaxed = errors(2.0, false);
        for w in plain.windows(2) {
            assert!((w[1] / w[0] + 2.0).abs() < 1e-9, "plain: {plain:?}");
        }
        for w in relaxed[1..].windows(2) {
            assert!((w[1] / w[0] - 0.25).abs() < 1e-9, "relaxed: {relaxed:?}");
        }
        let clamped = errors(20.0, false);
        for w in clamped[1..].windows(2) {
            assert!((w[1] / w[0] + 1.1).abs() < 1e-9, "clamped: {clamped:?}");
        }
    }
}
