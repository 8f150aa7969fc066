//! The filtered, preconditioned conjugate gradient and its preconditioners: the diagonal
//! (with each slide's drag), the grid's multigrid V-cycle, and the gas springs' low-rank
//! Woodbury correction of the multigrid's inverse.

use super::*;

/// Fewest particles for the multigrid preconditioner (below, the diagonal is as fast).
pub(super) const MULTIGRID_MIN_PARTICLES: usize = 400;

impl Implicit {
    /// The inverse diagonal of `A` (a direction of springs at a time, vectorised), with each
    /// sliding contact's drag.
    pub(super) fn precondition(&mut self, sys: &System<'_>) {
        // The matrix changed (a new step's, or springs past the strain limit): `av` is stale.
        self.kept.notify(Change::Matrix);
        let (nx, nz) = (sys.nx, sys.nz);
        let n = nx * nz;
        let mut h = std::mem::take(&mut self.kept.diag_springs);
        if std::mem::take(&mut self.kept.diag_kept) {
            // Only the springs around moved particles changed: their particles' sums again.
            let stamp = self.next_stamp();
            let mut mark = std::mem::take(&mut self.kept.row_mark);
            for k in (0..n).filter(|&k| self.kept.lin_moved[k]) {
                each_new_neighbour(nx, nz, k, &mut mark, stamp, |m| {
                    h.set(m, self.diag_exact(sys, m));
                });
            }
            self.kept.row_mark = mark;
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
        self.kept.diag_springs = h;
        for a in 0..n {
            self.precondition_one(a);
        }
    }

    /// The inverse diagonal at particle `k` after its constraint changed (a slide's drag).
    pub(super) fn precondition_one(&mut self, k: usize) {
        // The multigrid's matrix and the kept product have this row as it was.
        self.kept.notify(Change::Row(k));
        let d = self.diag_base.get(k);
        let d = match self.constraints[k] {
            Constraint::Normal { n, drag, t, .. } => d + (Vec3::ONE - n * n - t * t) * drag,
            _ => d,
        };
        self.inv_diag.set(k, Vec3::ONE / d);
    }

    /// `z = M^-1 r` on the active particles: the diagonal, or the multigrid V-cycle with the
    /// gas springs' Woodbury correction, filtered.
    pub(super) fn precondition_residual(&mut self, active: &[u32]) {
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
        self.woodbury.correct(active, r, z);
    }

    /// The multigrid hierarchy of the filtered system matrix (without the gas springs'
    /// rank-one terms), and their Woodbury correction.
    pub(super) fn build_multigrid(&mut self, sys: &System<'_>) {
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
        let n = nx * nz;
        self.woodbury.build(
            &mut self.mg,
            &self.gas,
            sys.regions,
            &self.constraints,
            &self.per_pascal,
            n,
        );
    }

    /// [`Implicit::solve`] to `tolerance`, counting its iterations, then `q = A v+` (the
    /// constraint forces are `(A v+ - b) / dt`).
    pub(super) fn solve_and_apply(&mut self, sys: &System<'_>, tolerance: Real) {
        self.iterations += self.solve(sys, tolerance);
        self.apply_v(sys);
    }

    /// Solves `A v = rhs` for the free directions, the constrained ones fixed at their values,
    /// by the filtered, preconditioned conjugate gradient from the current `v`, to the relative
    /// residual `tolerance`. Returns the iterations taken.
    pub(super) fn solve(&mut self, sys: &System<'_>, tolerance: Real) -> usize {
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
        if self.use_multigrid && !self.kept.mg_built {
            self.build_multigrid(sys);
            self.kept.notify(Change::MultigridBuilt);
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
}
