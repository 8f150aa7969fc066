//! Strain limiting after Provot (1995), "Deformation constraints in a mass-spring model to
//! describe rigid cloth behavior" (the thesis' reference \[2\]): no structural or shear spring
//! may end a step longer than `(1 + limit)` times its rest length.
//!
//! Each spring longer than that is a violated inequality constraint `|x_b - x_a| <= L`, projected
//! as position-based dynamics does: the spring's ends move towards each other along it by the
//! excess, shared in proportion to their inverse masses (a held end does not move). The springs
//! are swept Gauss-Seidel in a fixed order (row by row: along x, along z, then the two
//! diagonals), so each correction sees the previous ones, a chain
//! of stretched springs settles in a few sweeps, and the result does not depend on threads. After each sweep the particles
//! it moved are pushed back out of the colliders (normal only), so the limiter cannot press the
//! cloth into the table. Sweeps stop once no spring exceeds the limit by more than
//! [`TOLERANCE`] of it, or after the scene's `strain_limit_iterations`.
//!
//! Only positions change, so with position Verlet the velocity `(x - x_prev) / dt` loses the
//! part of the step's move that would have over-stretched the spring: the constraint is
//! inelastic and takes kinetic energy out, never in. Provot's original makes a few Jacobi passes
//! instead: Jacobi sums up to eight full corrections on a particle and overshoots, and a few
//! passes do not converge where a strong force (the atmosphere on a cloth lifted under a vacuum
//! moves a particle by millimetres a step) pulls against the limit every step. The stretch left
//! over is corrected at the next step, that correction becomes velocity, and the cloth is pumped
//! full of kinetic energy.

use crate::collide::{Collider, contact};
use crate::math::{Real, Vec3};
use crate::model::{Grid, Layout};
use crate::state::State;

/// Share of the limit by which a spring may still exceed it when the sweeps stop: the limit
/// holds to 1 % of its value (a spring limited to 10 % stretch ends at most at 10.1 %) with a
/// margin for the last sweep's own corrections.
pub const TOLERANCE: Real = 0.005;

/// What [`limit_strain`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Outcome {
    /// Gauss-Seidel position sweeps taken (the last one found nothing to correct beyond the
    /// tolerance, unless the cap was reached).
    pub sweeps: usize,
    /// Whether any particle moved.
    pub corrected: bool,
    /// Largest relative stretch (0.1 = 10 %) the last sweep found before correcting it.
    pub worst: Real,
}

/// The springs visited from particle (i, j): (i, j)-(i+1, j), (i, j)-(i, j+1),
/// (i, j)-(i+1, j+1), and (i+1, j)-(i, j+1), as (ai, aj, bi, bj) offsets of their ends.
const SPRINGS: [(usize, usize, usize, usize); 4] =
    [(0, 0, 1, 0), (0, 0, 0, 1), (0, 0, 1, 1), (1, 0, 0, 1)];

/// Calls `f(a, b, rest)` for every structural and shear spring (ends `a`, `b`, rest length
/// `rest`, m) in the sweep order: the grid's stencil row by row, or a mesh's springs along its
/// edges in edge order.
#[inline]
fn for_each_spring(layout: Layout<'_>, mut f: impl FnMut(usize, usize, Real)) {
    match layout {
        Layout::Grid(grid) => {
            let rest = rest_lengths(grid);
            let (nx, nz) = (grid.nx, grid.nz);
            for j in 0..nz {
                for i in 0..nx {
                    for (s, &(ai, aj, bi, bj)) in SPRINGS.iter().enumerate() {
                        let (ia, ja, ib, jb) = (i + ai, j + aj, i + bi, j + bj);
                        if ia < nx && ib < nx && jb < nz {
                            f(grid.index(ia, ja), grid.index(ib, jb), rest[s]);
                        }
                    }
                }
            }
        }
        Layout::Mesh(_, springs) => {
            for s in 0..springs.edge_count {
                let [a, b] = springs.ends[s];
                f(a as usize, b as usize, springs.rest[s]);
            }
        }
    }
}

/// Rest lengths of the four spring kinds, m.
fn rest_lengths(grid: &Grid) -> [Real; 4] {
    SPRINGS.map(|(ai, aj, bi, bj)| {
        let u = (bi as Real - ai as Real) * grid.dx;
        let v = (bj as Real - aj as Real) * grid.dz;
        (u * u + v * v).sqrt()
    })
}

/// Scratch of [`limit_strain`], kept between steps so a step allocates nothing.
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    /// The particles a sweep moved.
    moved: Vec<u32>,
    /// What the last call's projections pulled on held particles: per projection of a spring
    /// with one held end, that end and the free end's mass times its move towards it (kg m).
    pull: Vec<(u32, Vec3)>,
}

impl Scratch {
    /// The pull of the last call's projections on each held particle, kg m (see
    /// [`limit_strain`]): over a step of `dt` the hand holding it pulls `sum / dt^2` more (N)
    /// than the springs alone ask.
    pub fn pulls(&self) -> &[(u32, Vec3)] {
        &self.pull
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.moved.capacity() * 4 + self.pull.capacity() * std::mem::size_of::<(u32, Vec3)>()
    }
}

/// Limits every structural and shear spring of `grid` in `state` to `(1 + limit)` times its
/// rest length (see the module docs). `inv_mass` weighs the moves (1/kg); `held` particles do
/// not move; `colliders` (particle radius `radius`, m) are re-imposed after each sweep; at most
/// `max_sweeps` sweeps. A sweep compares squared lengths first, so a step where nothing is over
/// the limit costs one light pass over the springs. What the projections pulled on the held
/// particles is left in `scratch` ([`Scratch::pulls`]): their hands' share of the limit.
#[allow(clippy::too_many_arguments)] // the cloth, its constraint and its colliders
pub fn limit_strain(
    layout: Layout<'_>,
    state: &mut State,
    inv_mass: &[Real],
    held: &[bool],
    limit: Real,
    max_sweeps: usize,
    colliders: &[Collider],
    radius: Real,
    scratch: &mut Scratch,
) -> Outcome {
    let w = |k: usize| if held[k] { 0.0 } else { inv_mass[k] };
    let mut out = Outcome::default();
    let moved = &mut scratch.moved;
    let pull = &mut scratch.pull;
    pull.clear();
    while out.sweeps < max_sweeps {
        out.sweeps += 1;
        moved.clear();
        let mut worst: Real = 0.0;
        for_each_spring(layout, |a, b, rest| {
            let max_len = rest * (1.0 + limit);
            let d = state.x.get(b) - state.x.get(a);
            let len2 = d.length_squared();
            if len2 <= max_len * max_len {
                return;
            }
            let len = len2.sqrt();
            worst = worst.max(len / rest - 1.0);
            let (wa, wb) = (w(a), w(b));
            if wa + wb == 0.0 {
                return;
            }
            let corr = d * ((len - max_len) / (len * (wa + wb)));
            state.x.set(a, state.x.get(a) + corr * wa);
            state.x.set(b, state.x.get(b) - corr * wb);
            // A held end does not move: its hand holds it against the pull that moved the free
            // end (mass 1 / w times a move of w corr).
            if held[a] {
                pull.push((a as u32, -corr));
            } else if held[b] {
                pull.push((b as u32, corr));
            }
            moved.extend([a as u32, b as u32]);
        });
        out.worst = worst;
        if moved.is_empty() {
            break;
        }
        out.corrected = true;
        for &k in moved.iter() {
            let k = k as usize;
            if !held[k] {
                state
                    .x
                    .set(k, contact::project(colliders, state.x.get(k), radius));
            }
        }
        if worst <= limit * (1.0 + TOLERANCE) {
            break;
        }
    }
    out
}

/// Limits every membrane triangle of `membrane` (`model = "membrane"`) in `state` to a largest
/// principal stretch of `1 + limit`, as [`limit_strain`] limits springs: each triangle over the
/// limit has its deformation scaled back along its over-stretched principal direction about
/// its mass-weighted centroid (about its held corners where it has any), the moves weighed by
/// inverse masses, swept Gauss-Seidel in triangle order until every triangle is within
/// [`TOLERANCE`] of the limit or after `max_sweeps`. What the projections pulled on the held
/// particles is left in `scratch`.
#[allow(clippy::too_many_arguments)] // as limit_strain
pub fn limit_triangle_strain(
    membrane: &crate::forces::membrane::Membrane,
    state: &mut State,
    inv_mass: &[Real],
    held: &[bool],
    limit: Real,
    max_sweeps: usize,
    colliders: &[Collider],
    radius: Real,
    scratch: &mut Scratch,
) -> Outcome {
    let mut out = Outcome::default();
    let moved = &mut scratch.moved;
    let pull = &mut scratch.pull;
    pull.clear();
    let cap = 1.0 + limit;
    while out.sweeps < max_sweeps {
        out.sweeps += 1;
        moved.clear();
        let mut worst: Real = 0.0;
        for t in 0..membrane.triangles.len() {
            let s1 = membrane.principal_stretch(&state.x, t);
            if s1 <= cap {
                continue;
            }
            worst = worst.max(s1 - 1.0);
            let tri = membrane.triangles[t].map(|v| v as usize);
            let g = &membrane.grad[t];
            let p = tri.map(|v| state.x.get(v));
            let f1 = p[0] * g[0][0] + p[1] * g[1][0] + p[2] * g[2][0];
            let f2 = p[0] * g[0][1] + p[1] * g[1][1] + p[2] * g[2][1];
            // Principal directions of F^T F, then the deformed ones u_k = F v_k / s_k.
            let (a, b, c) = (f1.dot(f1), f2.dot(f2), f1.dot(f2));
            let half = 0.5 * (a + b);
            let r = (0.25 * (a - b) * (a - b) + c * c).sqrt();
            let (l1, l2) = (half + r, (half - r).max(0.0));
            let v1 = if c.abs() > 1e-300 {
                let (x, y) = (c, l1 - a);
                let n = x.hypot(y);
                [x / n, y / n]
            } else if a >= b {
                [1.0, 0.0]
            } else {
                [0.0, 1.0]
            };
            let v2 = [-v1[1], v1[0]];
            let scale = |l: Real| {
                let s = l.sqrt();
                if s > cap { cap / s } else { 1.0 }
            };
            let dirs = [
                ((f1 * v1[0] + f2 * v1[1]).normalize_or_zero(), scale(l1)),
                ((f1 * v2[0] + f2 * v2[1]).normalize_or_zero(), scale(l2)),
            ];
            let w = tri.map(|v| if held[v] { 0.0 } else { inv_mass[v] });
            let held_here = tri.map(|v| held[v]);
            let centre = if held_here.iter().any(|&h| h) {
                let (sum, count) = (0..3)
                    .filter(|&i| held_here[i])
                    .fold((Vec3::ZERO, 0.0), |(s, c), i| (s + p[i], c + 1.0));
                sum / count
            } else {
                let m = w.map(|w| 1.0 / w);
                (p[0] * m[0] + p[1] * m[1] + p[2] * m[2]) / (m[0] + m[1] + m[2])
            };
            let mut momentum = Vec3::ZERO;
            for i in 0..3 {
                if w[i] == 0.0 {
                    continue;
                }
                let d = p[i] - centre;
                let mut target = centre;
                // The component normal to the triangle's plane is none (d lies in it).
                for &(u, k) in &dirs {
                    target += u * (u.dot(d) * k);
                }
                let shift = target - p[i];
                state.x.set(tri[i], target);
                momentum += shift / w[i];
                moved.push(tri[i] as u32);
            }
            let holders = held_here.iter().filter(|&&h| h).count();
            if holders > 0 {
                for i in 0..3 {
                    if held_here[i] {
                        pull.push((tri[i] as u32, momentum / holders as Real));
                    }
                }
            }
        }
        out.worst = worst;
        if moved.is_empty() {
            break;
        }
        out.corrected = true;
        for &k in moved.iter() {
            let k = k as usize;
            state
                .x
                .set(k, contact::project(colliders, state.x.get(k), radius));
        }
        if worst <= limit * (1.0 + TOLERANCE) {
            break;
        }
    }
    out
}

/// Largest relative stretch of a structural or shear spring of `grid` in `x` (0.1 = 10 %).
pub fn max_stretch(layout: Layout<'_>, x: &crate::math::Soa) -> Real {
    let mut worst = Real::NEG_INFINITY;
    for_each_spring(layout, |a, b, rest| {
        worst = worst.max((x.get(b) - x.get(a)).length() / rest - 1.0);
    });
    worst
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ClothParams;

    /// A cloth within the limit, moving so that its springs stretch, ends its step within the
    /// tolerance of the limit; a held particle stays where it is; the correction only takes
    /// kinetic energy out.
    #[test]
    fn sweeps_bring_every_spring_within_the_limit_and_take_energy_out() {
        let grid = Grid::new(&ClothParams {
            resolution: [12, 9],
            ..Default::default()
        });
        let dt = 1e-3;
        let before = grid.rest_positions(Vec3::ZERO);
        let mut state = State::at_rest(before.clone());
        // One step of a motion that stretches the cloth by up to 50 %.
        for k in 0..grid.len() {
            let s = k as Real;
            let p = before.get(k);
            let v = Vec3::new(
                p.x * (8.0 + 2.0 * (0.7 * s).sin()),
                0.3 * (1.9 * s).cos(),
                p.z,
            );
            state.x.set(k, p + v * 50.0 * dt);
        }
        let mut held = vec![false; grid.len()];
        held[17] = true;
        let pinned = state.x.get(17);
        let inv = vec![1.0; grid.len()];
        let energy = state.kinetic_energy(1.0, dt);
        let stretched = max_stretch(Layout::Grid(&grid), &state.x);
        let out = limit_strain(
            Layout::Grid(&grid),
            &mut state,
            &inv,
            &held,
            0.1,
            1000,
            &[],
            0.0,
            &mut Scratch::default(),
        );
        let after = max_stretch(Layout::Grid(&grid), &state.x);
        assert!(stretched > 0.3, "{stretched}");
        assert!(out.corrected && out.sweeps < 1000, "{out:?}");
        assert!(after <= 0.1 * 1.01, "{after} after {} sweeps", out.sweeps);
        assert_eq!(state.x.get(17), pinned);
        let after_energy = state.kinetic_energy(1.0, dt);
        assert!(
            after_energy < energy,
            "{after_energy} J after, {energy} J before"
        );
    }
}
