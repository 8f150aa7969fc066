//! The springs (thesis eq. 3.6) linearised at the step's start: per stencil direction a
//! [`SpringSet`] of directions, stiffnesses and forces, the grid's runs of springs ([`spans`]),
//! and the step's forces (gravity, springs, the pressure force per pascal).

use super::*;

/// The linearised springs of one stencil direction, indexed by the spring's first particle:
/// unit direction `d` and the two stiffnesses of `H_e = ks I + kd d d^T` (N/m).
#[derive(Clone, Debug, Default)]
pub(super) struct SpringSet {
    pub(super) d: Soa,
    pub(super) ks: Vec<Real>,
    pub(super) kd: Vec<Real>,
    /// Per spring: its force on its first particle (N), or `H_e (p_a - p_b)` in a product.
    pub(super) w: Soa,
    /// Per spring: its tension (N, along `d`) at its linearisation, kept for the next step's
    /// force where neither particle moved (`w = d f`).
    pub(super) f: Vec<Real>,
    /// Per spring: whether it is linearised on its strain limit's stiff branch this step.
    pub(super) taut: Vec<bool>,
}

impl SpringSet {
    pub(super) fn new(n: usize) -> Self {
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
    pub(super) fn set_range(
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
    pub(super) fn check_same(&self, whole: &SpringSet, range: std::ops::Range<usize>) {
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
    pub(super) fn kept_range(&mut self, range: std::ops::Range<usize>) {
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
    pub(super) fn tighten_range(
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
    pub(super) fn product_range(
        &mut self,
        p: &Soa,
        range: std::ops::Range<usize>,
        oa: usize,
        ob: usize,
    ) {
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
    pub(super) fn scatter_range(
        &self,
        out: &mut Soa,
        range: std::ops::Range<usize>,
        oa: usize,
        ob: usize,
    ) {
        self.scatter(out, range, oa, ob, -1.0);
    }

    pub(super) fn scatter(
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
    pub(super) fn diagonal_range(
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
    pub(super) fn apply(&self, e: usize, p: Vec3) -> Vec3 {
        let d = self.d.get(e);
        p * self.ks[e] + d * (self.kd[e] * d.dot(p))
    }

    pub(super) fn heap_bytes(&self) -> usize {
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
pub(super) fn linearise(
    k: Real,
    l: Real,
    kl: Real,
    len: Real,
    over: Real,
    stiff: bool,
) -> (Real, Real, Real) {
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
pub(super) struct Stencil {
    pub(super) right: SpringSet,
    pub(super) down: SpringSet,
    pub(super) diag: SpringSet,
    pub(super) anti: SpringSet,
}

/// A direction of [`Stencil`].
#[derive(Clone, Copy, Debug)]
pub(super) enum Dir {
    Right,
    Down,
    Diag,
    Anti,
}

impl Dir {
    /// The stiffness (N/m) and rest length (m) of this direction's springs.
    pub(super) fn constants(self, c: &crate::forces::spring::SpringConsts) -> (Real, Real) {
        match self {
            Dir::Right => (c.structural, c.rest_x),
            Dir::Down => (c.structural, c.rest_z),
            Dir::Diag | Dir::Anti => (c.shear, c.rest_diag),
        }
    }
}

impl Stencil {
    pub(super) fn get(&self, dir: Dir) -> &SpringSet {
        match dir {
            Dir::Right => &self.right,
            Dir::Down => &self.down,
            Dir::Diag => &self.diag,
            Dir::Anti => &self.anti,
        }
    }

    pub(super) fn get_mut(&mut self, dir: Dir) -> &mut SpringSet {
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
pub(super) type Run = (Dir, Range<usize>, usize, usize);

/// The springs of an `nx` x `nz` grid as contiguous runs of spring indices, in the order every
/// pass over them takes (so their sums are the same every time): per row its `right` springs,
/// then (all rows but the last) its `diag` and `anti` springs; then every `down` spring in one
/// run. Each item: the direction, the run, and the offsets of its two particles from the
/// spring's index.
pub(super) fn spans(nx: usize, nz: usize) -> impl Iterator<Item = Run> {
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

impl Implicit {
    /// Springs and their linearisation, gravity, damping-free forces and the pressure force per
    /// pascal at the positions `x`.
    pub(super) fn forces(&mut self, model: &Model, x: &Soa) {
        let (nx, nz) = (model.grid().nx, model.grid().nz);
        let c = &model.springs;
        let n = nx * nz;
        for k in 0..n {
            self.force.set(k, model.gravity * model.mass(k));
        }
        // The particles that moved since the springs' last linearisation (all, if it is
        // stale): on a cloth the vacuum pins, nearly none of them from one step to the next.
        let fresh = self.kept.lin_fresh;
        for k in 0..n {
            let moved = !fresh || !same_bits(x.get(k), self.kept.lin_x.get(k));
            self.kept.lin_moved[k] = moved;
        }
        // Each run of springs linearised where a particle of the spring moved (in stretches of
        // such springs, vectorised), its forces kept elsewhere, then scattered.
        for (dir, run, oa, ob) in self.runs.clone().iter().cloned() {
            let (k, l) = dir.constants(c);
            let limit = Limit::new(model.strain_limit, k, l);
            let set = self.springs.get_mut(dir);
            let moved = |e: usize| self.kept.lin_moved[e + oa] || self.kept.lin_moved[e + ob];
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
            (&mut self.kept.lin_x.x, &x.x),
            (&mut self.kept.lin_x.y, &x.y),
            (&mut self.kept.lin_x.z, &x.z),
        ] {
            to.clone_from(from);
        }
        self.kept.notify(Change::Linearised {
            kept_springs: fresh,
        });
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
}
