//! The strain constraint (`[cloth] strain_limit`): springs that stiffen
//! [`LIMIT_STIFFENING`] times past the limit, and the re-solve when a solution takes a spring
//! past it while it was linearised below.

use super::*;

/// How much stiffer than itself a spring gets beyond the strain limit (`[cloth]
/// strain_limit`): the implicit integrator's strain limiter. A spring pulled past the limit by
/// a tension `T` ends `(T - k limit l) / (LIMIT_STIFFENING k)` beyond it: a thousandth of the
/// stretch the plain spring would add.
pub const LIMIT_STIFFENING: Real = 1000.0;

/// The strain limit of one kind of spring: the length (m) beyond which it stiffens, and by
/// how much (N/m).
#[derive(Clone, Copy, Debug)]
pub(super) struct Limit {
    pub(super) length: Real,
    pub(super) stiffness: Real,
}

impl Limit {
    /// The limit `limit` (relative stretch, 0 = none) of springs of stiffness `k` (N/m) and
    /// rest length `l` (m).
    pub(super) fn new(limit: Real, k: Real, l: Real) -> Self {
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

impl Implicit {
    /// The strain limit inside the solve: the springs that the solution `v` takes past the
    /// limit while linearised below it go onto their stiff branch, and the right-hand side
    /// takes the change of their forces (held in `force`, which the step no longer needs once
    /// the right-hand side is built). Returns whether any spring changed.
    pub(super) fn tighten(&mut self, model: &Model, x: &Soa, dt: Real) -> bool {
        if model.strain_limit <= 0.0 {
            return false;
        }
        let (nx, nz) = (model.grid().nx, model.grid().nz);
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
        self.kept.notify(Change::Stiffened);
        for k in 0..nx * nz {
            self.rhs.set(k, self.rhs.get(k) + self.force.get(k) * dt);
        }
        true
    }

    /// After a step's final solve: a spring it takes past the strain limit goes onto its stiff
    /// branch and the step is solved once more (no other constraint changes).
    pub(super) fn limit_and_resolve(
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
}
