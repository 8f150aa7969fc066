//! The system matrix `A = M (1 + dt c) + dt^2 H + dt^2 sum_r k_r g_r g_r^T` and its products,
//! matrix-free on the 9-point stencil: the whole product a direction of springs at a time,
//! a row alone in the whole product's order.

use super::*;

/// The step's constants the matrix needs.
pub(super) struct System<'a> {
    pub(super) nx: usize,
    pub(super) nz: usize,
    pub(super) dt2: Real,
    pub(super) regions: &'a Regions,
}

/// Which vector [`Implicit::apply`] multiplies.
#[derive(Clone, Copy)]
pub(super) enum Which {
    P,
    V,
}

/// `d d^T`.
#[inline]
pub(super) fn outer(d: Vec3) -> DMat3 {
    DMat3::from_cols(d * d.x, d * d.y, d * d.z)
}

impl Implicit {
    /// `q = A p` (unfiltered) on every particle, or with `only` on those particles (`p` zero on
    /// the others).
    pub(super) fn apply(&mut self, sys: &System<'_>, which: Which, only: Option<&[u32]>) {
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
    pub(super) fn apply_all(&mut self, sys: &System<'_>, which: Which) {
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
    pub(super) fn row_apply(&self, sys: &System<'_>, p: &Soa, a: usize) -> Vec3 {
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

    /// Particle `a`'s sum over its springs of `term(springs, e, oa, ob, first)` (spring `e` of
    /// a direction's `springs`, between particles `e + oa` and `e + ob`; `first` where `a` is
    /// `e + oa`), added in the order the passes over the runs ([`spans`]) add a spring's terms to
    /// its two particles: the runs row by row, each run's first particles before its second
    /// ones, the `down` springs last. So a row taken alone has the bits of the whole pass's.
    #[inline]
    pub(super) fn stencil_sum(
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
    pub(super) fn diag_exact(&self, sys: &System<'_>, a: usize) -> Vec3 {
        self.stencil_sum(sys, a, |set, e, _, _, _| {
            let d = set.d.get(e);
            Vec3::splat(set.ks[e]) + d * d * set.kd[e]
        })
    }
}
