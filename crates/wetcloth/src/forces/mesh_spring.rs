//! The thesis' springs (eq. 3.6) on a cloth of any shape: one spring along every edge of the
//! mesh and one across every interior edge (between the two vertices opposite it), with
//! stiffnesses set so that the network has the in-plane stiffness of the material.
//!
//! # The material
//!
//! `structural_stiffness` `k_s` and `shear_stiffness` `k_h` (N/m) keep the meaning they have on
//! the built-in grid, as a membrane: a square grid with those springs has, whatever its spacing,
//! the in-plane stiffness `C11 = C22 = k_s + k_h`, `C12 = C66 = k_h` (N/m; stress per strain of
//! the sheet, axes along x and z). A spring of stiffness `k` and rest length `L` stores
//! `1/2 w (d . eps d)^2` under a small uniform strain `eps` (`w = k L^2`, `d` its unit
//! direction), so a triangle of area `A` matches the membrane when its springs' `w` sum, as
//! rank-one tensors `w q q^T` (`q` the Mandel vector `(dx^2, dz^2, sqrt 2 dx dz)`), to `A C`.
//!
//! Each spring across an edge takes `w = k_h (A_1 + A_2)` (the two triangles beside the edge),
//! half of it counted in each triangle; each triangle then sets the `w` of its three edges by
//! non-negative least squares on the rest of `A C` (Frobenius norm, in the triangle's own frame,
//! its first axis the world x projected onto it). An edge's stiffness is the sum of its
//! triangles' shares over `L^2`. A uniform strain of a regular or irregular mesh then stores
//! the membrane's energy: exactly for an isotropic material (`k_s = 2 k_h`) on equilateral
//! triangles, and close to it on any mesh whose triangles are not thin.
//!
//! What springs cannot do: a network of springs is a membrane with Poisson ratio 1/3
//! (`C12 = C66`, Cauchy's relation), so no spring stiffness gives a rubbery (0.5) or a paper-like
//! (0) sheet; an anisotropic material (`k_s != 2 k_h`) is reproduced only as closely as each
//! triangle's three directions allow; and there is no bending stiffness beyond what the springs
//! across edges give a folded sheet. Triangle elements (membrane and bending) lift these limits.

use crate::math::{Real, Soa, Vec3};
use crate::model::ClothMesh;
use rayon::prelude::*;

/// The springs of a mesh cloth.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshSprings {
    /// The two particles of each spring: first the mesh's edges (in [`ClothMesh::edges`]
    /// order), then the springs across interior edges.
    pub ends: Vec<[u32; 2]>,
    /// Rest length of each spring, m.
    pub rest: Vec<Real>,
    /// Stiffness of each spring, N/m.
    pub stiffness: Vec<Real>,
    /// How many of `ends` are the mesh's edges (the rest are across edges).
    pub edge_count: usize,
    /// The springs of particle `k`: `of[start[k]..start[k + 1]]`, in increasing order, each
    /// as `2 s + e` with `e` 0 where `k` is the spring's first end and 1 where its second.
    pub start: Vec<u32>,
    /// See [`MeshSprings::start`].
    pub of: Vec<u32>,
    /// The springs in the order the explicit step computes them ([`MeshSprings::run_forces`]):
    /// by their larger end, then by index, so that the springs a run of particles needs are
    /// one run of this order.
    run: SpringRun,
}

/// The springs in run order, as contiguous arrays (see [`MeshSprings::run_forces`]).
#[derive(Clone, Debug, Default, PartialEq)]
struct SpringRun {
    /// Each spring's first and second end.
    a: Vec<u32>,
    b: Vec<u32>,
    /// Rest length (m) and stiffness (N/m).
    rest: Vec<Real>,
    stiffness: Vec<Real>,
    /// The springs of particle `k` as [`MeshSprings::of`] lists them (spring order), each as
    /// `2 r + e` with `r` the spring's place in run order.
    of: Vec<u32>,
    /// `start[m]`: how many springs have their larger end below particle `m`.
    start: Vec<u32>,
    /// `ready[k]`: the largest end of a spring of particles `0..=k` (at least `k`).
    ready: Vec<u32>,
}

impl SpringRun {
    fn new(n: usize, ends: &[[u32; 2]], rest: &[Real], stiffness: &[Real], of: &[u32]) -> Self {
        let mut order: Vec<u32> = (0..ends.len() as u32).collect();
        order.sort_by_key(|&s| (ends[s as usize][0].max(ends[s as usize][1]), s));
        let mut place = vec![0u32; ends.len()];
        for (r, &s) in order.iter().enumerate() {
            place[s as usize] = r as u32;
        }
        let mut start = vec![0u32; n + 1];
        for &[a, b] in ends {
            start[a.max(b) as usize + 1] += 1;
        }
        for k in 0..n {
            start[k + 1] += start[k];
        }
        let mut ready: Vec<u32> = (0..n as u32).collect();
        for &[a, b] in ends {
            let top = a.max(b);
            for v in [a, b] {
                ready[v as usize] = ready[v as usize].max(top);
            }
        }
        for k in 1..n {
            ready[k] = ready[k].max(ready[k - 1]);
        }
        let pick = |v: &[Real]| order.iter().map(|&s| v[s as usize]).collect();
        Self {
            a: order.iter().map(|&s| ends[s as usize][0]).collect(),
            b: order.iter().map(|&s| ends[s as usize][1]).collect(),
            rest: pick(rest),
            stiffness: pick(stiffness),
            of: of
                .iter()
                .map(|&e| 2 * place[(e >> 1) as usize] + (e & 1))
                .collect(),
            start,
            ready,
        }
    }

    fn heap_bytes(&self) -> usize {
        (self.a.capacity()
            + self.b.capacity()
            + self.of.capacity()
            + self.start.capacity()
            + self.ready.capacity())
            * 4
            + (self.rest.capacity() + self.stiffness.capacity()) * 8
    }
}

/// The springs across edges' share of the shear membrane: each takes `w = ACROSS_SHARE k_h
/// (A_1 + A_2)` and the edges the rest (see the module docs). A smaller share leaves the
/// membrane to the edges and softens folds (the springs across an edge are what resists a fold
/// along it): at 0.5 a regular and an irregular mesh hang alike to 0.01 % (1.0: 2.4 %) and a
/// drape over a sphere hangs 1.5 mm lower, but a pocket trapped as a cloth lands differs more
/// from the grid's (10 % against 8 %); 1 is kept until triangle elements take the membrane.
const ACROSS_SHARE: Real = 1.0;

/// Springs per task when the springs' forces are computed on the pool.
const SPRINGS_PER_TASK: usize = 4096;

/// The membrane `C` (Mandel form, N/m) of a grid with springs `k_s`, `k_h`.
fn membrane(structural: Real, shear: Real) -> [[Real; 3]; 3] {
    let (c11, c12, c66) = (structural + shear, shear, shear);
    [[c11, c12, 0.0], [c12, c11, 0.0], [0.0, 0.0, 2.0 * c66]]
}

/// The Mandel vector of a unit direction `(u, v)`.
fn mandel(u: Real, v: Real) -> [Real; 3] {
    [u * u, v * v, std::f64::consts::SQRT_2 * u * v]
}

fn dot3(a: [Real; 3], b: [Real; 3]) -> Real {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn quad(t: &[[Real; 3]; 3], q: [Real; 3]) -> Real {
    let mut s = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            s += q[i] * t[i][j] * q[j];
        }
    }
    s
}

/// Non-negative least squares: the weights `w >= 0` whose `sum w_i q_i q_i^T` is nearest
/// `target` in the Frobenius norm, over every subset of free weights (three unknowns).
fn fit(q: [[Real; 3]; 3], target: &[[Real; 3]; 3]) -> [Real; 3] {
    let g = |i: usize, j: usize| dot3(q[i], q[j]).powi(2);
    let b = |i: usize| quad(target, q[i]);
    let residual = |w: [Real; 3]| {
        let mut r = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let mut m = target[i][j];
                for (k, wk) in w.iter().enumerate() {
                    m -= wk * q[k][i] * q[k][j];
                }
                r += m * m;
            }
        }
        r
    };
    let mut best = ([0.0; 3], residual([0.0; 3]));
    for mask in 1u8..8 {
        let free: Vec<usize> = (0..3).filter(|i| mask & (1 << i) != 0).collect();
        let n = free.len();
        // Solve the normal equations of the free weights (Gaussian elimination, n <= 3).
        let mut a = [[0.0; 4]; 3];
        for (r, &i) in free.iter().enumerate() {
            for (c, &j) in free.iter().enumerate() {
                a[r][c] = g(i, j);
            }
            a[r][3] = b(i);
        }
        let mut ok = true;
        for c in 0..n {
            let p = (c..n)
                .max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))
                .unwrap_or(c);
            a.swap(c, p);
            if a[c][c].abs() < 1e-300 {
                ok = false;
                break;
            }
            for r in 0..n {
                if r != c {
                    let f = a[r][c] / a[c][c];
                    for k in c..4 {
                        a[r][k] -= f * a[c][k];
                    }
                }
            }
        }
        if !ok {
            continue;
        }
        let mut w = [0.0; 3];
        for (r, &i) in free.iter().enumerate() {
            w[i] = a[r][3] / a[r][r];
        }
        if w.iter().any(|&x| x < 0.0) {
            continue;
        }
        let res = residual(w);
        if res < best.1 {
            best = (w, res);
        }
    }
    best.0
}

/// A triangle's own frame: its first axis the world x projected onto its plane (the world z
/// if x is nearly along its normal), the second the normal crossed with it.
fn frame(a: Vec3, b: Vec3, c: Vec3) -> (Vec3, Vec3) {
    let n = (b - a).cross(c - a).normalize_or_zero();
    let mut e1 = Vec3::X - n * n.x;
    if e1.length_squared() < 0.25 {
        e1 = Vec3::Z - n * n.z;
    }
    let e1 = e1.normalize_or_zero();
    (e1, n.cross(e1))
}

impl MeshSprings {
    /// The springs of `mesh` for a material of grid springs `structural` and `shear` (N/m).
    pub fn new(mesh: &ClothMesh, structural: Real, shear: Real) -> Self {
        let c = membrane(structural, shear);
        let edge_count = mesh.edges.len();
        let mut ends: Vec<[u32; 2]> = mesh.edges.clone();
        ends.extend(mesh.across.iter().copied());
        let p = |i: u32| mesh.rest[i as usize];
        let rest: Vec<Real> = ends.iter().map(|&[a, b]| (p(b) - p(a)).length()).collect();
        let mut w = vec![0.0; ends.len()];
        // Where each edge is in `edges`, and the across spring of each interior edge.
        let edge_index = |a: u32, b: u32| -> usize {
            let key = [a.min(b), a.max(b)];
            mesh.edges.binary_search(&key).unwrap_or(0)
        };
        let mut across_of = vec![u32::MAX; edge_count];
        for (s, &e) in mesh.across_edge.iter().enumerate() {
            across_of[e as usize] = s as u32;
        }
        // The across springs: k_h (A_1 + A_2) each.
        let mut diamond = vec![0.0; edge_count];
        for (tri, &area) in mesh.triangles.iter().zip(&mesh.triangle_area) {
            for e in 0..3 {
                diamond[edge_index(tri[e], tri[(e + 1) % 3])] += area;
            }
        }
        for (s, &e) in mesh.across_edge.iter().enumerate() {
            w[edge_count + s] = ACROSS_SHARE * shear * diamond[e as usize];
        }
        for (tri, &area) in mesh.triangles.iter().zip(&mesh.triangle_area) {
            let [a, b, cc] = tri.map(p);
            let (e1, e2) = frame(a, b, cc);
            let dir = |v: Vec3| {
                let (u, t) = (v.dot(e1), v.dot(e2));
                let l = u.hypot(t);
                mandel(u / l, t / l)
            };
            let mut target = c.map(|r| r.map(|x| x * area));
            let mut q = [[0.0; 3]; 3];
            let mut idx = [0usize; 3];
            for e in 0..3 {
                let (i, j) = (tri[e], tri[(e + 1) % 3]);
                idx[e] = edge_index(i, j);
                q[e] = dir(p(j) - p(i));
                let s = across_of[idx[e]];
                if s != u32::MAX {
                    let [x, y] = ends[edge_count + s as usize];
                    let qc = dir(p(y) - p(x));
                    let half = 0.5 * w[edge_count + s as usize];
                    for r in 0..3 {
                        for k in 0..3 {
                            target[r][k] -= half * qc[r] * qc[k];
                        }
                    }
                }
            }
            let share = fit(q, &target);
            for e in 0..3 {
                w[idx[e]] += share[e];
            }
        }
        let stiffness: Vec<Real> = w.iter().zip(&rest).map(|(&w, &l)| w / (l * l)).collect();
        let n = mesh.len();
        let mut start = vec![0u32; n + 1];
        for &[a, b] in &ends {
            start[a as usize + 1] += 1;
            start[b as usize + 1] += 1;
        }
        for k in 0..n {
            start[k + 1] += start[k];
        }
        let mut fill = start.clone();
        let mut of = vec![0u32; 2 * ends.len()];
        for (s, &[a, b]) in ends.iter().enumerate() {
            for (e, v) in [a, b].into_iter().enumerate() {
                of[fill[v as usize] as usize] = 2 * s as u32 + e as u32;
                fill[v as usize] += 1;
            }
        }
        let run = SpringRun::new(n, &ends, &rest, &stiffness, &of);
        Self {
            ends,
            rest,
            stiffness,
            edge_count,
            start,
            of,
            run,
        }
    }

    /// No springs, for a cloth whose membrane and bending elements carry its mechanics
    /// (`model = "membrane"`): the mesh's edges are kept, with no stiffness, for what measures
    /// them (the blow-up check's stretch).
    pub fn none(mesh: &ClothMesh) -> Self {
        let ends = mesh.edges.clone();
        let p = |i: u32| mesh.rest[i as usize];
        let rest = ends.iter().map(|&[a, b]| (p(b) - p(a)).length()).collect();
        Self {
            stiffness: vec![0.0; ends.len()],
            edge_count: ends.len(),
            ends,
            rest,
            start: vec![0; mesh.len() + 1],
            of: Vec::new(),
            run: SpringRun::default(),
        }
    }

    /// Whether the springs carry any force (not [`MeshSprings::none`]).
    #[inline]
    pub fn active(&self) -> bool {
        !self.of.is_empty()
    }

    /// The springs of particle `k`, each as `2 s + e` (`e` 1 where `k` is its second end).
    #[inline]
    pub fn springs_of(&self, k: usize) -> &[u32] {
        &self.of[self.start[k] as usize..self.start[k + 1] as usize]
    }

    /// Every spring's force on its first end at positions `x` into `out` (N), on the pool when
    /// `parallel`; each spring is computed once, in chunks whose arithmetic vectorises (the
    /// ends gathered first, then `k (l - L) / l` over the chunk).
    pub fn forces_into(&self, x: &Soa, out: &mut Vec<Vec3>, parallel: bool) {
        if !self.active() {
            out.clear();
            return;
        }
        out.resize(self.ends.len(), Vec3::ZERO);
        let chunk = |start: usize, o: &mut [Vec3]| {
            const LANE: usize = 64;
            let (mut dx, mut dy, mut dz) = ([0.0; LANE], [0.0; LANE], [0.0; LANE]);
            let mut f = [0.0; LANE];
            for (c, o) in o.chunks_mut(LANE).enumerate() {
                let s0 = start + c * LANE;
                let m = o.len();
                for i in 0..m {
                    let [a, b] = self.ends[s0 + i];
                    let (a, b) = (a as usize, b as usize);
                    dx[i] = x.x[b] - x.x[a];
                    dy[i] = x.y[b] - x.y[a];
                    dz[i] = x.z[b] - x.z[a];
                }
                let (k, l0) = (&self.stiffness[s0..s0 + m], &self.rest[s0..s0 + m]);
                for i in 0..m {
                    let l = (dx[i] * dx[i] + dy[i] * dy[i] + dz[i] * dz[i]).sqrt();
                    // A spring of no length has no direction: no force.
                    f[i] = if l > 0.0 { k[i] * (l - l0[i]) / l } else { 0.0 };
                }
                for i in 0..m {
                    o[i] = Vec3::new(dx[i] * f[i], dy[i] * f[i], dz[i] * f[i]);
                }
            }
        };
        if parallel && self.ends.len() > 2 * SPRINGS_PER_TASK {
            use rayon::prelude::*;
            out.par_chunks_mut(SPRINGS_PER_TASK)
                .enumerate()
                .for_each(|(c, o)| chunk(c * SPRINGS_PER_TASK, o));
        } else {
            chunk(0, out);
        }
    }

    /// The force on particle `k` of the springs' forces `forces` ([`MeshSprings::forces_into`]),
    /// summed in spring order.
    #[inline]
    pub fn gather(&self, forces: &[Vec3], k: usize) -> Vec3 {
        let mut f = Vec3::ZERO;
        for &e in self.springs_of(k) {
            // +1 on the spring's first end, -1 on its second (exact: a sign flip).
            let sign = 1.0 - 2.0 * (e & 1) as Real;
            f += forces[(e >> 1) as usize] * sign;
        }
        f
    }

    /// The springs, in run order, that particles `particles` need: every spring of theirs is
    /// in it (empty without springs).
    #[inline]
    pub fn run_span(&self, particles: std::ops::Range<usize>) -> std::ops::Range<usize> {
        if !self.active() || particles.is_empty() {
            return 0..0;
        }
        let r = &self.run;
        let last = r.ready[particles.end - 1] as usize;
        r.start[particles.start] as usize..r.start[last + 1] as usize
    }

    /// The forces of the springs `springs` (run order, see [`MeshSprings::run_span`]) at
    /// positions `x` into `out` (N), two per spring: on its first end, then on its second (the
    /// same bits as [`MeshSprings::forces_into`] gives each, and their sign flipped); the
    /// arithmetic vectorises over lanes of springs.
    pub fn run_forces(&self, x: &Soa, springs: std::ops::Range<usize>, out: &mut [Vec3]) {
        const LANE: usize = 64;
        let r = &self.run;
        let (mut dx, mut dy, mut dz) = ([0.0; LANE], [0.0; LANE], [0.0; LANE]);
        let mut f = [0.0; LANE];
        for (c, o) in out[..2 * springs.len()].chunks_mut(2 * LANE).enumerate() {
            let s0 = springs.start + c * LANE;
            let m = o.len() / 2;
            let (a, b) = (&r.a[s0..s0 + m], &r.b[s0..s0 + m]);
            for i in 0..m {
                let (a, b) = (a[i] as usize, b[i] as usize);
                dx[i] = x.x[b] - x.x[a];
                dy[i] = x.y[b] - x.y[a];
                dz[i] = x.z[b] - x.z[a];
            }
            let (k, l0) = (&r.stiffness[s0..s0 + m], &r.rest[s0..s0 + m]);
            for i in 0..m {
                let l = (dx[i] * dx[i] + dy[i] * dy[i] + dz[i] * dz[i]).sqrt();
                // A spring of no length has no direction: no force.
                f[i] = if l > 0.0 { k[i] * (l - l0[i]) / l } else { 0.0 };
            }
            for (i, o) in o.chunks_exact_mut(2).enumerate() {
                let v = Vec3::new(dx[i] * f[i], dy[i] * f[i], dz[i] * f[i]);
                o[0] = v;
                o[1] = -v;
            }
        }
    }

    /// The force on particle `k` of the springs' forces `forces` ([`MeshSprings::run_forces`]
    /// of a span starting at run place `first`), summed in spring order: the same bits as
    /// [`MeshSprings::gather`].
    #[inline]
    pub fn gather_run(&self, forces: &[Vec3], first: usize, k: usize) -> Vec3 {
        let mut f = Vec3::ZERO;
        let base = 2 * first;
        for &e in &self.run.of[self.start[k] as usize..self.start[k + 1] as usize] {
            f += forces[e as usize - base];
        }
        f
    }

    /// [`MeshSprings::gather_run`] of the particles `k0..k0 + out.len()` into `out`, four
    /// particles side by side (four independent sums, each in its own spring order).
    pub fn gather_block(&self, forces: &[Vec3], first: usize, k0: usize, out: &mut [Vec3]) {
        let base = 2 * first;
        let of = &self.run.of;
        let mut quads = out.chunks_exact_mut(4);
        for (q, o) in (&mut quads).enumerate() {
            let k = k0 + 4 * q;
            let s: [usize; 5] = std::array::from_fn(|j| self.start[k + j] as usize);
            let common = (0..4).map(|j| s[j + 1] - s[j]).min().unwrap_or(0);
            let mut f = [Vec3::ZERO; 4];
            for t in 0..common {
                for j in 0..4 {
                    f[j] += forces[of[s[j] + t] as usize - base];
                }
            }
            for j in 0..4 {
                for &e in &of[s[j] + common..s[j + 1]] {
                    f[j] += forces[e as usize - base];
                }
            }
            o.copy_from_slice(&f);
        }
        let rest = quads.into_remainder().len();
        let done = out.len() - rest;
        for (i, o) in out[done..].iter_mut().enumerate() {
            *o = self.gather_run(forces, first, k0 + done + i);
        }
    }

    /// Hooke's force of spring `s` on its first particle at positions `x`, N (eq. 3.6).
    #[inline]
    pub fn force(&self, x: &Soa, s: usize) -> Vec3 {
        let [a, b] = self.ends[s];
        let d = x.get(b as usize) - x.get(a as usize);
        let l = d.length();
        if l == 0.0 {
            return Vec3::ZERO;
        }
        d * (self.stiffness[s] * (l - self.rest[s]) / l)
    }

    /// The springs' force on particle `k`, N, summed in spring order.
    #[inline]
    pub fn force_on(&self, x: &Soa, k: usize) -> Vec3 {
        let mut f = Vec3::ZERO;
        for &s in self.springs_of(k) {
            let s = s as usize;
            let fs = self.force(x, s);
            f += if self.ends[s][0] as usize == k {
                fs
            } else {
                -fs
            };
        }
        f
    }

    /// Largest `(length / rest length)^2` of a spring along an edge at positions `x` (NaN if
    /// a position is not finite).
    pub fn max_stretch2(&self, x: &Soa) -> Real {
        self.max_stretch2_of(x, 0..self.edge_count)
    }

    /// [`MeshSprings::max_stretch2`] on the pool, `task` springs to a task: the same value (a
    /// largest value does not depend on the order it is taken in).
    pub fn max_stretch2_parallel(&self, x: &Soa, task: usize) -> Real {
        let tasks = self.edge_count.div_ceil(task.max(1));
        (0..tasks)
            .into_par_iter()
            .map(|i| self.max_stretch2_of(x, i * task..((i + 1) * task).min(self.edge_count)))
            .reduce(|| 0.0, larger)
    }

    /// The largest stretch of the edge springs `range`, in independent lanes (no chain of
    /// comparisons from one spring to the next).
    fn max_stretch2_of(&self, x: &Soa, range: std::ops::Range<usize>) -> Real {
        const LANE: usize = 4;
        let (ends, rest) = (&self.ends[range.clone()], &self.rest[range]);
        let stretch = |[a, b]: [u32; 2], r: Real| {
            let (a, b) = (a as usize, b as usize);
            let (dx, dy, dz) = (x.x[b] - x.x[a], x.y[b] - x.y[a], x.z[b] - x.z[a]);
            (dx * dx + dy * dy + dz * dz) / (r * r)
        };
        let mut worst = [0.0; LANE];
        let (mut e, mut r) = (ends.chunks_exact(LANE), rest.chunks_exact(LANE));
        for (e, r) in (&mut e).zip(&mut r) {
            for l in 0..LANE {
                worst[l] = larger(worst[l], stretch(e[l], r[l]));
            }
        }
        let tail = e
            .remainder()
            .iter()
            .zip(r.remainder())
            .fold(0.0, |w, (&e, &r)| larger(w, stretch(e, r)));
        worst.into_iter().fold(tail, larger)
    }

    /// The elastic energy stored at positions `x`, J.
    pub fn energy(&self, x: &Soa) -> Real {
        (0..self.ends.len())
            .map(|s| {
                let [a, b] = self.ends[s];
                let l = (x.get(b as usize) - x.get(a as usize)).length();
                0.5 * self.stiffness[s] * (l - self.rest[s]).powi(2)
            })
            .sum()
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.ends.capacity() * 8
            + (self.rest.capacity() + self.stiffness.capacity()) * 8
            + (self.start.capacity() + self.of.capacity()) * 4
            + self.run.heap_bytes()
    }
}

/// The larger of two stretches, NaN if either is (a non-finite position shows as a NaN
/// stretch, whatever the order the springs are taken in).
#[inline]
fn larger(a: Real, b: Real) -> Real {
    if a.is_nan() {
        a
    } else if b > a || b.is_nan() {
        b
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Energy of the springs under a uniform strain `eps` (xx, zz, xz) of the rest positions,
    /// per unit area, to first order (small strain), as `1/2 m^T C m`'s `C` read back.
    fn stored(springs: &MeshSprings, mesh: &ClothMesh, eps: [Real; 3]) -> Real {
        let mut e = 0.0;
        for (s, &[a, b]) in springs.ends.iter().enumerate() {
            let d = mesh.rest[b as usize] - mesh.rest[a as usize];
            let l = d.length();
            let (u, v) = (d.x / l, d.z / l);
            let strain = u * u * eps[0] + v * v * eps[1] + 2.0 * u * v * eps[2];
            e += 0.5 * springs.stiffness[s] * l * l * strain * strain;
        }
        e / mesh.total_area()
    }

    fn hexagonal(n: usize, h: Real) -> ClothMesh {
        // Equilateral triangles: rows offset by half a spacing.
        let dz = h * (3.0 as Real).sqrt() / 2.0;
        let mut v = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let off = if j % 2 == 1 { 0.5 * h } else { 0.0 };
                v.push(Vec3::new(i as Real * h + off, 0.0, j as Real * dz));
            }
        }
        let mut t = Vec::new();
        let id = |i: usize, j: usize| (j * n + i) as u32;
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                if j % 2 == 0 {
                    t.push([id(i, j), id(i, j + 1), id(i + 1, j)]);
                    t.push([id(i + 1, j), id(i, j + 1), id(i + 1, j + 1)]);
                } else {
                    t.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
                    t.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
                }
            }
        }
        ClothMesh::new(v, t).unwrap()
    }

    /// Far from the border, an equilateral mesh of an isotropic material stores the membrane's
    /// energy under uniaxial and shear strains (the border's cells lack across springs).
    #[test]
    fn equilateral_springs_store_the_membrane_energy() {
        let (ks, kh) = (200.0, 100.0);
        let mesh = hexagonal(40, 0.01);
        let springs = MeshSprings::new(&mesh, ks, kh);
        let c = membrane(ks, kh);
        for (eps, want) in [
            ([1e-3, 0.0, 0.0], 0.5 * c[0][0] * 1e-6),
            ([0.0, 1e-3, 0.0], 0.5 * c[1][1] * 1e-6),
            ([0.0, 0.0, 1e-3], 0.5 * c[2][2] * 2e-6),
        ] {
            let got = stored(&springs, &mesh, eps);
            assert!(
                (got / want - 1.0).abs() < 0.06,
                "strain {eps:?}: {got} J/m^2 against {want}"
            );
        }
    }

    #[test]
    fn every_stiffness_is_finite_and_not_negative() {
        let mesh = hexagonal(6, 0.1);
        let s = MeshSprings::new(&mesh, 500.0, 125.0);
        assert!(s.stiffness.iter().all(|k| k.is_finite() && *k >= 0.0));
        assert_eq!(s.ends.len(), mesh.edges.len() + mesh.across.len());
    }
}
