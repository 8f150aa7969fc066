//! Work a step need not repeat, each kept with the bits of the whole computation: the product
//! `A v` taken again only around the rows that changed, and the marks of the rows a change
//! reaches.

use super::*;

#[cfg(test)]
thread_local! {
    /// Partial products `A v` taken (and checked against the whole) on this thread.
    pub(super) static PARTIAL_PRODUCTS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    /// Runs of springs whose kept linearisation was checked against a new one on this thread.
    pub(super) static KEPT_CHECKS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    /// Steps that kept the last step's product `A v` on this thread.
    pub(super) static KEPT_PRODUCTS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// Work the implicit step keeps from one step or solve to the next, every piece with the bits
/// the whole computation would give, and the flags that say what is still current. Only
/// [`Kept::notify`] clears them: a change names what happened, and the one place below decides
/// which kept work it makes stale.
#[derive(Clone, Debug, Default)]
pub(super) struct Kept {
    /// `A v` of the last solve's `v` (`q` is the conjugate gradient's scratch): each
    /// contact's and hand's impulse is read from it. `av_of` is the `v` it was computed from
    /// while `av_fresh` holds (the matrix unchanged since but for the rows in `av_rows`, whose
    /// constraints changed); then only the rows around the particles whose velocity moved are
    /// computed again ([`Implicit::apply_v`]). `row_mark` and `row_stamp` mark the rows taken
    /// there and in [`Implicit::precondition`] ([`Implicit::next_stamp`]).
    pub(super) av: Soa,
    pub(super) av_of: Soa,
    pub(super) av_fresh: bool,
    /// The `dt^2` (s^2) of the matrix `av` was taken with, and whether no gas spring acted in
    /// it: a step of the same size without gas springs keeps `av` ([`Implicit::keep_product`]).
    pub(super) av_dt2: Real,
    pub(super) av_gas_free: bool,
    pub(super) av_rows: Vec<u32>,
    pub(super) row_mark: Vec<u32>,
    pub(super) row_stamp: u32,
    /// The positions the springs were last linearised at, while `lin_fresh` holds (no spring
    /// was put on its stiff branch since): a spring neither of whose particles moved keeps its
    /// linearisation ([`Implicit::forces`]). `lin_moved` marks the particles that moved.
    pub(super) lin_x: Soa,
    pub(super) lin_fresh: bool,
    pub(super) lin_moved: Vec<bool>,
    /// Each particle's sum of its springs' diagonal blocks (N/m), and whether the next
    /// [`Implicit::precondition`] may take it again only around the particles that moved (the
    /// last `forces` kept the other springs).
    pub(super) diag_springs: Soa,
    pub(super) diag_kept: bool,
    /// Whether the multigrid hierarchy (and the gas springs' correction) was built from the
    /// matrix as it is: no constraint, spring or step changed since. A solve that only moved the
    /// bubble's pressure (the right-hand side) reuses it.
    pub(super) mg_built: bool,
}

/// What happened to the implicit step's system, for [`Kept::notify`].
#[derive(Clone, Copy, Debug)]
pub(super) enum Change {
    /// The springs were linearised for a new step; `kept_springs` where those whose particles
    /// did not move kept their linearisation (and with it their share of the diagonal).
    Linearised { kept_springs: bool },
    /// The matrix's diagonal was taken anew (a new step, or springs past the strain limit):
    /// the product `A v` is stale.
    Matrix,
    /// Particle `k`'s constraint (and with it its row's drag) changed.
    Row(usize),
    /// Springs went onto their strain limit's stiff branch: the next step linearises all anew.
    Stiffened,
    /// The multigrid hierarchy was built from the matrix as it is.
    MultigridBuilt,
}

impl Kept {
    /// Nothing kept yet, for `n` particles.
    pub(super) fn new(n: usize) -> Self {
        Self {
            av: Soa::zeros(n),
            av_of: Soa::zeros(n),
            row_mark: vec![0; n],
            lin_x: Soa::zeros(n),
            lin_moved: vec![true; n],
            diag_springs: Soa::zeros(n),
            ..Default::default()
        }
    }

    /// Records `change`, marking stale what it invalidates.
    pub(super) fn notify(&mut self, change: Change) {
        match change {
            Change::Linearised { kept_springs } => {
                self.diag_kept = kept_springs;
                self.lin_fresh = true;
            }
            Change::Matrix => self.av_fresh = false,
            Change::Row(k) => {
                self.mg_built = false;
                if self.av_fresh {
                    self.av_rows.push(k as u32);
                }
            }
            Change::Stiffened => self.lin_fresh = false,
            Change::MultigridBuilt => self.mg_built = true,
        }
    }
}

/// Calls `f` on every particle of the 3 x 3 block around particle `k` of an `nx` x `nz` grid
/// (the rows a change at `k` reaches through the 9-point stencil) that `mark` does not yet hold
/// at `stamp`, and marks it.
pub(super) fn each_new_neighbour(
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
pub(super) fn same_bits(a: Vec3, b: Vec3) -> bool {
    a.x.to_bits() == b.x.to_bits()
        && a.y.to_bits() == b.y.to_bits()
        && a.z.to_bits() == b.z.to_bits()
}

/// Whether the constraints `a` and `b` add the same friction drag to a row of the matrix
/// (only a slide's does: its normal, direction and drag, to the bit).
pub(super) fn same_drag(a: Constraint, b: Constraint) -> bool {
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

impl Implicit {
    /// In the unit tests: the diagonal's spring sums `h` taken around the moved particles have
    /// the bits of the whole pass.
    #[cfg(test)]
    pub(super) fn check_diagonal(&mut self, sys: &System<'_>, h: &Soa) {
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

    /// A stamp no row of `row_mark` holds yet (the marks of earlier passes then read as
    /// unmarked).
    pub(super) fn next_stamp(&mut self) -> u32 {
        self.kept.row_stamp = self.kept.row_stamp.wrapping_add(1);
        if self.kept.row_stamp == 0 {
            self.kept.row_mark.fill(0);
            self.kept.row_stamp = 1;
        }
        self.kept.row_stamp
    }

    /// `av = A v`. Without gas springs (whose rank-one terms couple every particle of a
    /// region) and while the matrix is unchanged since the last product but for the rows whose
    /// constraints changed, only the rows around the particles whose velocity moved are taken
    /// again, each summed in the order of the whole product's passes ([`Implicit::row_exact`]),
    /// so the result has the same bits: a cloth pressed flat moves a few dozen particles a solve
    /// and the product cost as much as the rest of its step. Otherwise (or where more than an
    /// eighth of the particles moved) the whole product.
    pub(super) fn apply_v(&mut self, sys: &System<'_>) {
        let (nx, nz) = (sys.nx, sys.nz);
        let n = nx * nz;
        if self.kept.av_fresh && self.gas.iter().all(|&g| g == 0.0) {
            let mut moved = 0;
            let stamp = self.next_stamp();
            let mut rows = std::mem::take(&mut self.kept.av_rows);
            for &k in &rows {
                self.kept.row_mark[k as usize] = stamp;
            }
            for k in 0..n {
                if same_bits(self.v.get(k), self.kept.av_of.get(k)) {
                    continue;
                }
                moved += 1;
                if 8 * moved > n {
                    break;
                }
                each_new_neighbour(nx, nz, k, &mut self.kept.row_mark, stamp, |m| {
                    rows.push(m as u32)
                });
                self.kept.av_of.set(k, self.v.get(k));
            }
            if 8 * moved <= n {
                for &m in &rows {
                    let y = self.row_exact(sys, m as usize);
                    self.kept.av.set(m as usize, y);
                }
                rows.clear();
                self.kept.av_rows = rows;
                #[cfg(test)]
                self.check_partial_product(sys);
                return;
            }
            rows.clear();
            self.kept.av_rows = rows;
        }
        self.apply(sys, Which::V, None);
        std::mem::swap(&mut self.q, &mut self.kept.av);
        self.kept.av_of.clone_from(&self.v);
        self.kept.av_rows.clear();
        self.kept.av_fresh = true;
        self.kept.av_dt2 = sys.dt2;
        self.kept.av_gas_free = self.gas.iter().all(|&g| g == 0.0);
    }

    /// At a step's start, after [`Implicit::precondition`]: keeps the last step's product
    /// `av` (taken at its final velocities and constraints; `fresh`: it was current then and
    /// this step's `forces` kept the springs whose particles did not move) as this step's, marking for the next [`Implicit::apply_v`] only the rows whose matrix
    /// changed: around the particles whose springs were linearised anew, and where a slide's
    /// drag changed. That holds where the springs elsewhere kept their linearisation, the step
    /// has the last one's size (the inertia and `dt^2` the same) and no gas spring acts now or
    /// then; on a cloth the vacuum pins, a step's first product then costs a few dozen rows
    /// instead of the whole grid.
    pub(super) fn keep_product(&mut self, sys: &System<'_>, fresh: bool) {
        let gas_free = self.gas.iter().all(|&g| g == 0.0);
        if !(fresh
            && gas_free
            && self.kept.av_gas_free
            && sys.dt2.to_bits() == self.kept.av_dt2.to_bits())
        {
            return;
        }
        let (nx, nz) = (sys.nx, sys.nz);
        let n = nx * nz;
        let stamp = self.next_stamp();
        let mut mark = std::mem::take(&mut self.kept.row_mark);
        let mut rows = std::mem::take(&mut self.kept.av_rows);
        rows.clear();
        for k in (0..n).filter(|&k| self.kept.lin_moved[k]) {
            each_new_neighbour(nx, nz, k, &mut mark, stamp, |m| rows.push(m as u32));
        }
        for k in 0..n {
            if mark[k] != stamp && !same_drag(self.constraints[k], self.prev_constraints[k]) {
                mark[k] = stamp;
                rows.push(k as u32);
            }
        }
        self.kept.row_mark = mark;
        // Where many rows changed the whole product is as cheap.
        self.kept.av_fresh = 8 * rows.len() <= n;
        if !self.kept.av_fresh {
            rows.clear();
        }
        #[cfg(test)]
        if self.kept.av_fresh {
            KEPT_PRODUCTS.with(|c| c.set(c.get() + 1));
        }
        self.kept.av_rows = rows;
    }

    /// In the unit tests: the partial product just taken has the bits of the whole one.
    #[cfg(test)]
    pub(super) fn check_partial_product(&mut self, sys: &System<'_>) {
        self.apply(sys, Which::V, None);
        for k in 0..self.v.len() {
            assert!(
                same_bits(self.q.get(k), self.kept.av.get(k)),
                "row {k}: partial {} whole {}",
                self.kept.av.get(k),
                self.q.get(k)
            );
        }
        PARTIAL_PRODUCTS.with(|c| c.set(c.get() + 1));
    }

    /// Row `a` of `A v` where no gas spring acts, with the bits of the whole product
    /// ([`Implicit::apply_all`]; its springs' terms summed by [`Implicit::stencil_sum`]).
    #[inline]
    pub(super) fn row_exact(&self, sys: &System<'_>, a: usize) -> Vec3 {
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
}
