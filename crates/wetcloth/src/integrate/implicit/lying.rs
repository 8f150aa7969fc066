//! The pressure on cloth that lies on a surface at the step's end. The pressure force acts
//! along the cloth's normal (eq. 3.7); the step takes it at the step's start (`S N_k` of the
//! positions then, [`Implicit::forces`]), which stands for the normal over the step where the
//! cloth's shape changes little within it. Where the cloth lands during the step it does not:
//! a cloth slammed onto a tilted table by the vacuum is still flat and level at the step's
//! start, and its pressure force, vertical, has a share along the table (`tan 10 deg` = 0.18 of
//! the normal one on `settle.toml`'s table) that the vacuum's own normal force, far above the
//! cloth's weight, cannot hold at friction 0.15: at 1/60 s the cloth slid 3 m down the table in
//! its landing step (364.6 J at the first frame), at 1/600 s 3 cm (8.8 J). In continuous time
//! the atmosphere presses the cloth onto the table along the table's normal from the moment
//! it lies there.
//!
//! So a particle that ends the step on a surface together with every neighbour of its stencil
//! (the cloth around it lies on the surface: its normal there is the surface's) feels the
//! pressure along the contact normal, the end-of-step direction backward Euler asks for, with
//! the magnitude it had (`S` for the thesis' spread). Only where the particle or a neighbour
//! lands during the step (it did not touch at the step's start): a cloth lying on the surface
//! from the step's start already has the surface's normal. The pressure force per pascal `g_k`
//! changes everywhere at once: the right-hand side (by the pressure applied to the particle so
//! far, the start's, the bubble's shift and a rim's share), the gas springs (the matrix's
//! rank-one terms, their diagonal and the multigrid's Woodbury correction) and the bubble's
//! volume prediction and shifts (`air/solve.rs`, which read `g`). A particle that stops lying so
//! (a contact released) gets its start direction back.

use super::*;

impl Implicit {
    /// At the step's start, after [`Implicit::constrain`]: the particles that may land this step
    /// or lie beside one that may (`near_landing`: not touching at the step's start, and their
    /// stencil neighbours), none turned yet. None where no pressure acts or no collider is.
    pub(super) fn begin_lying(&mut self, model: &Model, state: &State) {
        for &k in &self.near_landing {
            self.lying[k as usize] = None;
        }
        self.near_landing.clear();
        for &k in &self.turned {
            self.is_turned[k as usize] = false;
        }
        self.turned.clear();
        let pressed = !self.regions.list.is_empty() || !self.regions.extra.is_empty();
        if !pressed || model.colliders.is_empty() || state.contact.iter().all(|&c| c) {
            return;
        }
        let (nx, nz) = (model.grid().nx, model.grid().nz);
        let n = nx * nz;
        self.lying.resize(n, None);
        self.is_turned.resize(n, false);
        self.start_g.resize(n, Vec3::ZERO);
        let stamp = self.next_stamp();
        let mut mark = std::mem::take(&mut self.kept.row_mark);
        for k in (0..n).filter(|&k| !state.contact[k]) {
            each_new_neighbour(nx, nz, k, &mut mark, stamp, |_| {});
        }
        self.near_landing
            .extend((0..n).filter(|&k| mark[k] == stamp).map(|k| k as u32));
        self.kept.row_mark = mark;
    }

    /// The normal (unit, out of the surface) of the surface particle `k` ends the step on: its
    /// contact's, or, with `predict`, where a free particle's velocity takes it into a collider
    /// (the interactive budget leaves such landings to the end-of-step projection).
    fn end_surface(
        &self,
        model: &Model,
        state: &State,
        surfaces: &[Surface],
        k: usize,
        dt: Real,
        predict: bool,
    ) -> Option<Vec3> {
        match self.constraints[k] {
            Constraint::Stick { n, .. } | Constraint::Normal { n, .. } => Some(n),
            Constraint::Free if predict => {
                let x = state.x.get(k);
                let to = x + self.v.get(k) * dt;
                match landing_constraint(model, surfaces, k, x, to, dt)? {
                    (Constraint::Stick { n, .. }, _) => Some(n),
                    _ => None,
                }
            }
            _ => None,
        }
    }

    /// Turns the pressure force of each particle near a landing that now lies on a surface
    /// with its whole stencil (see the module docs) to that surface's normal, and back where
    /// it no longer does, correcting the right-hand side and, in a region with a gas spring,
    /// the matrix's row (once the matrix is `prepared`). Returns whether any turn changed the
    /// system.
    #[allow(clippy::too_many_arguments)] // the step's pieces
    pub(super) fn turn_lying(
        &mut self,
        sys: &System<'_>,
        prepared: bool,
        model: &Model,
        state: &State,
        surfaces: &[Surface],
        dt: Real,
        predict: bool,
    ) -> bool {
        if self.near_landing.is_empty() {
            return false;
        }
        let (nx, nz) = (model.grid().nx, model.grid().nz);
        // Each particle's end-of-step surface normal, near a landing (`None` elsewhere: there
        // the constraint tells).
        let near = std::mem::take(&mut self.near_landing);
        for &k in &near {
            let k = k as usize;
            self.lying[k] = self.end_surface(model, state, surfaces, k, dt, predict);
        }
        let mut any = false;
        for &k in &near {
            let k = k as usize;
            let (i, j) = (k % nx, k / nx);
            // Lying with its whole stencil. A neighbour outside `near` touched at the step's
            // start and is constrained as a contact unless released.
            let lies = self.lying[k].is_some()
                && (j.saturating_sub(1)..(j + 2).min(nz)).all(|jj| {
                    (i.saturating_sub(1)..(i + 2).min(nx)).all(|ii| {
                        let m = jj * nx + ii;
                        self.lying[m].is_some()
                            || matches!(
                                self.constraints[m],
                                Constraint::Stick { .. } | Constraint::Normal { .. }
                            )
                    })
                });
            let g = self.per_pascal.get(k);
            let to = match (lies, self.is_turned[k]) {
                (true, turned) => {
                    // From the start's force per pascal, so that a particle turned again to
                    // the same normal keeps its bits.
                    let g0 = if turned { self.start_g[k] } else { g };
                    if !turned {
                        self.turned.push(k as u32);
                        self.is_turned[k] = true;
                        self.start_g[k] = g;
                    }
                    let normal = self.lying[k].unwrap_or(Vec3::ZERO);
                    normal * (g0.length() * g0.dot(normal).signum())
                }
                (false, true) => {
                    self.is_turned[k] = false;
                    self.start_g[k]
                }
                (false, false) => continue,
            };
            if same_bits(to, g) {
                continue;
            }
            // The pressure difference the right-hand side holds on `k` so far (as `dp g dt`).
            let dp = self.pressure_on(sys.regions, k);
            self.per_pascal.set(k, to);
            if dp != 0.0 {
                self.rhs.set(k, self.rhs.get(k) + (to - g) * (dp * dt));
                any = true;
            }
            if let Some(r) = sys.regions.of(k)
                && self.gas[r] != 0.0
            {
                any = true;
                if !prepared {
                    continue;
                }
                // The gas spring's diagonal share of the row, as `precondition` takes it.
                let d = Vec3::splat(self.inertia[k])
                    + self.kept.diag_springs.get(k) * sys.dt2
                    + to * to * self.gas[r];
                self.diag_base.set(k, d);
                self.precondition_one(k);
            }
        }
        self.turned.retain(|&k| self.is_turned[k as usize]);
        self.near_landing = near;
        any
    }

    /// The pressure difference (Pa) particle `k`'s right-hand side holds so far this step: its
    /// region's (or, in none, its own: the water film's pull and the vacuums beside it) at the
    /// step's start, and the air's share of the solve (the bubble's shift, a rim's share).
    fn pressure_on(&self, regions: &Regions, k: usize) -> Real {
        let start = match regions.of(k) {
            Some(r) => regions.list[r].pressure - regions.atmosphere,
            None => regions.extra.get(k).copied().unwrap_or(0.0),
        };
        start + self.air.applied(regions, k)
    }
}
