//! The gas springs' share of the preconditioner. Each sealed region of air `r` adds the
//! rank-one term `dt^2 k_r g_r g_r^T` to the system matrix (`k_r = P_r / V_r`, Pa/m^3; `g_r`
//! its particles' pressure force per pascal), which couples every particle of the region. The
//! multigrid is built without them; their inverse is added by the Woodbury identity,
//! `M^-1 = V - W (C^-1 + U^T W)^-1 W^T`, with `V` the V-cycle, `U` the regions' filtered `g_r`,
//! `W = V U` and `C` their `dt^2 k_r`.

use super::*;

/// Most gas regions whose rank-one term the multigrid preconditioner corrects for (Woodbury);
/// the others are left to the conjugate gradient.
pub(super) const MAX_GAS_CORRECTIONS: usize = 8;

/// The Woodbury correction of the multigrid's inverse for the gas springs.
#[derive(Clone, Debug, Default)]
pub(super) struct Woodbury {
    /// The corrected regions (indices into `Regions::list`).
    regions: Vec<usize>,
    /// Per corrected region: `u_r = S g_r` (m^2, the filtered pressure force per pascal) and
    /// `w_r = V u_r`.
    u: Vec<Soa>,
    w: Vec<Soa>,
    /// The Cholesky factor of `G = diag(1 / (dt^2 k_r)) + U^T W`, and scratch for
    /// `G^-1 W^T r`.
    chol: Vec<Real>,
    y: Vec<Real>,
}

impl Woodbury {
    /// Built for the regions with a gas spring (`gas[r] = dt^2 k_r > 0`, the first
    /// [`MAX_GAS_CORRECTIONS`]) of `regions`, with the V-cycle `mg` of the filtered matrix, the
    /// particles' `constraints` and pressure force per pascal `per_pascal`, over `n` particles.
    pub(super) fn build(
        &mut self,
        mg: &mut Multigrid,
        gas: &[Real],
        regions: &Regions,
        constraints: &[Constraint],
        per_pascal: &Soa,
        n: usize,
    ) {
        self.regions.clear();
        self.regions.extend(
            (0..gas.len())
                .filter(|&r| gas[r] > 0.0)
                .take(MAX_GAS_CORRECTIONS),
        );
        let m = self.regions.len();
        self.u.truncate(m);
        self.w.truncate(m);
        self.u.resize_with(m, || Soa::zeros(n));
        self.w.resize_with(m, || Soa::zeros(n));
        for ((&r, u), w) in self.regions.iter().zip(&mut self.u).zip(&mut self.w) {
            for k in 0..n {
                let g = if regions.of(k) == Some(r) {
                    constraints[k].filter(per_pascal.get(k))
                } else {
                    Vec3::ZERO
                };
                u.set(k, g);
            }
            mg.apply(|k| u.get(k), |k, x| w.set(k, constraints[k].filter(x)));
        }
        self.chol.clear();
        self.chol.resize(m * m, 0.0);
        for a in 0..m {
            for b in 0..m {
                let (u, w) = (&self.u[a], &self.w[b]);
                let mut dot = 0.0;
                for k in 0..n {
                    dot += u.get(k).dot(w.get(k));
                }
                let own = if a == b {
                    1.0 / gas[self.regions[a]]
                } else {
                    0.0
                };
                self.chol[a * m + b] = dot + own;
            }
        }
        cholesky(&mut self.chol, m);
    }

    /// `z -= W G^-1 W^T r` on the `active` particles (`z` the V-cycle of `r`).
    pub(super) fn correct(&mut self, active: &[u32], r: &Soa, z: &mut Soa) {
        if self.w.is_empty() {
            return;
        }
        let m = self.w.len();
        let y = &mut self.y;
        y.clear();
        y.extend(self.w.iter().map(|w| {
            active
                .iter()
                .map(|&k| w.get(k as usize).dot(r.get(k as usize)))
                .sum::<Real>()
        }));
        cholesky_solve(&self.chol, m, y);
        for &k in active {
            let k = k as usize;
            let mut c = z.get(k);
            for (w, y) in self.w.iter().zip(y.iter()) {
                c -= w.get(k) * *y;
            }
            z.set(k, c);
        }
    }

    /// Heap bytes held.
    pub(super) fn heap_bytes(&self) -> usize {
        self.u
            .iter()
            .chain(&self.w)
            .map(|s| s.heap_bytes())
            .sum::<usize>()
            + (self.chol.capacity() + self.y.capacity()) * 8
            + self.regions.capacity() * 8
    }
}
