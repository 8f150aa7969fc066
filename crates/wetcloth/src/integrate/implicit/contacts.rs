//! The contacts inside the solve (thesis eq. 3.4-3.5): each particle's [`Constraint`]
//! (free, a hand, held by static friction, sliding against kinetic friction), how a contact
//! lands, holds, slides, stops or pulls free between solves, and the colliders as the step's
//! contacts see them ([`Surface`]: still, or moving between their placements at the step's two
//! ends, friction then acting on the velocity relative to the surface).

use super::*;

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
pub(super) const STOPPED_SPEED: Real = 1e-12;

/// A particle's constraint in the solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::integrate) enum Constraint {
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
    Stick {
        n: Vec3,
        vn: Real,
        mu: Real,
        u: Vec3,
    },
    /// Its velocity is fixed: a hand.
    Fixed(Vec3),
}

impl Constraint {
    /// `v` with the constrained directions removed.
    #[inline]
    pub(super) fn filter(self, v: Vec3) -> Vec3 {
        match self {
            Constraint::Free => v,
            Constraint::Normal { n, .. } => v - n * n.dot(v),
            Constraint::Stick { .. } | Constraint::Fixed(_) => Vec3::ZERO,
        }
    }

    /// The friction drag of a sliding contact on `p`: `drag` times its tangential part across
    /// the slide (the whole tangential part for a drag-only slide).
    #[inline]
    pub(super) fn drag(self, p: Vec3) -> Vec3 {
        match self {
            Constraint::Normal { n, drag, t, .. } => (p - n * n.dot(p) - t * t.dot(p)) * drag,
            _ => Vec3::ZERO,
        }
    }

    /// The kinetic friction impulse of a slide that does not depend on its speed (N s):
    /// `kinetic` against its direction `t`, and on a moving surface the drag's pull towards the
    /// surface's velocity `u` (the drag acts on the velocity relative to it).
    #[inline]
    pub(super) fn friction(self) -> Vec3 {
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
    pub(super) fn value(self) -> Vec3 {
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
    pub(super) fn slip(self, v: Vec3) -> Vec3 {
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

/// A slide (contact normal, normal velocity, friction coefficient) that friction stopped
/// within the step, its kinetic impulse `kinetic` (N s), at the tangential speed `speed` (m/s):
/// a drag-only slide (see [`Constraint::Normal`]), its drag giving that impulse at that speed.
pub(super) fn stopped_slide(
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

/// How far from a deforming mesh (m) a point still sees the surface's own velocity (the nearest
/// triangle's); beyond it the surface is still there, which no contact of the step can tell
/// apart: a particle that far cannot reach the surface within a step at the speeds a body
/// moves (10 cm in a step).
const DEFORM_VELOCITY_REACH: Real = 0.1;

/// A collider as one step's contacts see it: where it is at the step's start (the collider
/// itself if still) and, if it moves, where it is at both ends of the step.
#[derive(Clone, Debug)]
pub(in crate::integrate) struct Surface {
    pub(in crate::integrate) collider: Collider,
    pub(in crate::integrate) frames: Option<Frames>,
}

impl Surface {
    /// The colliders of `model` over the step from `t` to `t + dt` (s); empty where none moves
    /// (the contacts then read `model.colliders` as they are).
    pub(in crate::integrate) fn of_step(model: &Model, t: Real, dt: Real, out: &mut Vec<Surface>) {
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
    pub(in crate::integrate) fn velocity(&self, x: Vec3, dt: Real) -> Vec3 {
        match &self.frames {
            Some(f) if f.sweep.is_some() => {
                (f.carry(&self.collider, x, DEFORM_VELOCITY_REACH) - x) / dt
            }
            Some(f) => (f.end.to_world(f.start.to_rest(x)) - x) / dt,
            None => Vec3::ZERO,
        }
    }

    /// The contact query of a particle moving from `x` to `to` over the step: in the moving
    /// frame for a moving collider (see [`contact::resolve_moving`]), the normal in the world
    /// at the step's end.
    pub(in crate::integrate) fn contact(
        &self,
        x: Vec3,
        to: Vec3,
        radius: Real,
    ) -> Option<(Real, Vec3)> {
        match &self.frames {
            Some(f) if f.sweep.is_some() => f.contact(&self.collider, x, to, radius),
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
pub(super) fn resolve_surfaces(
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
            None => contact::resolve_scaled(
                std::slice::from_ref(&s.collider),
                x,
                to,
                model.radius,
                scale,
            ),
        };
        to = p;
        touched |= hit;
    }
    (to, touched, work)
}

/// Calls `each` with every collider of the step (`surfaces`, or the model's own when none
/// moves) and its surface velocity at `x` (m/s).
#[inline]
pub(in crate::integrate) fn each_surface(
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
pub(in crate::integrate) fn contact_constraint(
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
pub(in crate::integrate) fn stick(n: Vec3, gap: Real, dt: Real, mu: Real, u: Vec3) -> Constraint {
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
pub(in crate::integrate) fn landing_constraint(
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

impl Implicit {
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
    pub(super) fn landing_friction(&self, k: usize, stick: Constraint) -> Constraint {
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
    pub(super) fn held_change(
        &self,
        k: usize,
        (n, vn, mu, u): (Vec3, Real, Real, Vec3),
        state: &State,
        dt: Real,
    ) -> Option<Constraint> {
        let lambda = self.kept.av.get(k) - self.rhs.get(k);
        let push = lambda.dot(n);
        let shear = (lambda - n * push).length();
        if push < 0.0 {
            return Some(Constraint::Free);
        }
        if shear <= mu * push {
            return None;
        }
        let v0 = state.velocity(k, dt);
        let vt =
            self.constraints[k]
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
    pub(super) fn slip_speed(&self, k: usize, normal: Vec3, excess: Real) -> Real {
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
    pub(super) fn slide_drag(
        &self,
        k: usize,
        normal: Vec3,
        friction: Real,
        vt: Real,
        drag: Real,
    ) -> Real {
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
    pub(super) fn slide_change(
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

    /// After a solve of the contact passes: contacts that pull go free, slides follow their
    /// speed ([`Implicit::slide_change`]), particles that would land inside a collider are
    /// constrained ([`landing_constraint`], marked in `landed` where they went through its
    /// surface), held ones outside the friction cone slide ([`Implicit::held_change`]).
    /// Returns whether the contact set changed enough to solve again.
    pub(super) fn update_contacts(
        &mut self,
        model: &Model,
        state: &State,
        surfaces: &[Surface],
        dt: Real,
    ) -> bool {
        let n = state.len();
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
                    // The normal impulse: the residual's normal part (friction is tangential).
                    let v = self.v.get(k);
                    let lambda = self.kept.av.get(k) - self.rhs.get(k);
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
                    if let Some((c, through)) = landing_constraint(model, surfaces, k, x, to, dt) {
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
        changed
    }

    /// After the step's last solve: every slide that it moved against its direction (whose
    /// friction would push it on) becomes a drag-only slide. Returns whether any did.
    pub(super) fn stop_reversed_slides(&mut self) -> bool {
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
    pub(super) fn recheck_contacts(&mut self, state: &State, dt: Real) -> bool {
        let mut changed = false;
        for k in 0..self.constraints.len() {
            let lambda = self.kept.av.get(k) - self.rhs.get(k);
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
}
