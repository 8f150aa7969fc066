//! The bending element (`[cloth.bending]`): the curvature of each triangle from the dihedral
//! angles of its three edges, and an energy with the fabric's bending rigidity along the warp
//! and the weft.
//!
//! **Curvature.** Each interior edge is a hinge whose dihedral angle `theta` (0 where the two
//! triangles are flat) measures how far the normal turns from one triangle's centroid to the
//! other's. On a smooth surface with second fundamental form `S` (2 x 2, in a triangle's
//! material frame), crossing edge `i` from the triangle's centroid to its neighbour's (a step
//! `dc_i` in the triangle's plane, the neighbour unfolded about the edge) turns the normal by
//! `theta_i = t_i^T S dc_i` to first order, `t_i` the edge's outward normal in the plane. Three
//! edges give three such equations for the three components of `S`: each triangle solves them
//! once at rest (`S = M^-1 theta`), so `S` is exact for any constant curvature on any mesh,
//! regular or not. A boundary edge has no neighbour: its angle counts as its rest value (the
//! curvature across a free edge is taken as the rest curvature), which is exact for a strip
//! bent along its length.
//!
//! **Energy.** Per unit rest area `1/2 (B_w S_ww^2 + B_f S_ff^2 + 2 B_t S_wf^2)`: `B_w` and
//! `B_f` the rigidity for curvature along the warp and along the weft (N m), `B_t =
//! sqrt(B_w B_f)` for twist. No term couples the warp's curvature to the weft's, so a strip's
//! measured rigidity is `B` whatever its width, and an isotropic cloth (`B_w = B_f = B`) stores
//! `B/2 (k1^2 + k2^2)` for principal curvatures `k1`, `k2`. The rest angles are the rest mesh's
//! (`rest = "mesh"`: a garment modelled curved keeps its shape) or zero (`"flat"`).
//!
//! **Stiffness.** The implicit integrator takes the Gauss-Newton part `sum_h k_h grad theta_h
//! grad theta_h^T` (each hinge's `k_h` the absolute row sum of the energy's coefficients on it,
//! an upper bound of the coupling between a triangle's hinges), positive semi-definite; the
//! angles' own second derivatives are left out.

use super::fabric::wrap;
use crate::math::{Real, Soa, Vec3};
use crate::model::ClothMesh;

/// A hinge: an interior edge `a b` with the vertex `c` of the triangle where the edge runs from
/// `a` to `b` (in the triangles' winding) and the vertex `d` of the other.
pub type Hinge = [u32; 4];

/// The bending elements of a cloth.
#[derive(Clone, Debug, PartialEq)]
pub struct Bending {
    /// The hinges.
    pub hinges: Vec<Hinge>,
    /// Each hinge's rest angle, rad.
    pub rest_angle: Vec<Real>,
    /// Each triangle's hinges (`u32::MAX` for a boundary edge), edge `i` opposite corner `i`.
    pub tri_hinges: Vec<[u32; 3]>,
    /// Each triangle's energy coefficients `K` (J per rad^2): the triangle stores
    /// `1/2 sum_ij K_ij dtheta_i dtheta_j` over its hinges (`dtheta` the angle's change from rest).
    pub coeff: Vec<[[Real; 3]; 3]>,
    /// Each hinge's Gauss-Newton stiffness, J per rad^2 (see the module docs).
    pub hinge_stiffness: Vec<Real>,
}

/// The bending rigidity of a fabric, N m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigidity {
    /// For curvature along the warp, N m.
    pub warp: Real,
    /// For curvature along the weft, N m.
    pub weft: Real,
}

/// The dihedral angle of hinge `[a, b, c, d]` at positions `x` (rad, 0 flat, in (-pi, pi]) and
/// its gradient with respect to the four vertices (1/m).
#[inline]
pub fn angle_and_gradient(x: &Soa, h: Hinge) -> (Real, [Vec3; 4]) {
    let [a, b, c, d] = h.map(|i| x.get(i as usize));
    let k = hinge_geometry(a, b, c, d);
    let grad = if k.ok { k.grad } else { [Vec3::ZERO; 4] };
    (angle_of(k.ok, k.sin, k.cos), grad)
}

/// What the corners of a hinge give: the sine and cosine of its dihedral angle, both scaled by
/// the product of the two triangles' doubled areas, and the angle's gradient.
#[derive(Clone, Copy, Debug)]
struct HingeGeometry {
    /// Whether the hinge has an angle: its edge has a length and both triangles an area.
    ok: bool,
    /// The angle's sine times `|n1| |n2|`, m^4.
    sin: Real,
    /// The angle's cosine times `|n1| |n2|`, m^4.
    cos: Real,
    /// The angle's gradient with respect to the four corners (1/m); not finite unless `ok`.
    grad: [Vec3; 4],
}

/// The dihedral angle of a hinge's [`HingeGeometry`] (rad, in (-pi, pi]): 0 where `ok` is false.
#[inline(always)]
fn angle_of(ok: bool, sin: Real, cos: Real) -> Real {
    if ok {
        // atan2 is scale-free: the unnormalised normals give the same angle.
        sin.atan2(cos)
    } else {
        0.0
    }
}

/// The geometry of the hinge with corners `a`, `b` (the edge), `c` and `d` (m), computed without
/// a branch, so that a loop over hinges vectorises: a degenerate hinge's divisions run too and
/// `ok` says to discard them.
#[inline(always)]
fn hinge_geometry(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> HingeGeometry {
    let e = b - a;
    let le = e.length();
    // The two triangles' normals, both with the cloth's winding: (a, b, c) and (b, a, d).
    let n1 = (b - a).cross(c - a);
    let n2 = (a - b).cross(d - b);
    let (q1, q2) = (n1.length_squared(), n2.length_squared());
    let ok = !(le == 0.0 || q1 == 0.0 || q2 == 0.0);
    let ue = e / le;
    // Bridson, Marino and Fedkiw (2003): the four bending modes are the angle's gradient.
    let gc = n1 * (le / q1);
    let gd = n2 * (le / q2);
    let ga = n1 * ((c - b).dot(ue) / q1) + n2 * ((d - b).dot(ue) / q2);
    let gb = -(n1 * ((c - a).dot(ue) / q1) + n2 * ((d - a).dot(ue) / q2));
    HingeGeometry {
        ok,
        sin: n1.cross(n2).dot(ue),
        cos: n1.dot(n2),
        // Their modes point along the angle's decrease: the gradient is their negative.
        grad: [-ga, -gb, -gc, -gd],
    }
}

impl Bending {
    /// The elements of `mesh` with rigidity `b` and each triangle's warp direction `warp[t]`;
    /// `rest_flat` takes every rest angle as zero.
    pub fn new(mesh: &ClothMesh, warp: &[Vec3], b: Rigidity, rest_flat: bool) -> Self {
        let rest = Soa::from_vec3(&mesh.rest);
        let mut hinges = Vec::new();
        let mut hinge_of_edge = vec![u32::MAX; mesh.edges.len()];
        for (e, &[a, b]) in mesh.edges.iter().enumerate() {
            let [t0, t1] = mesh.edge_faces[e];
            if t1 == u32::MAX {
                continue;
            }
            // The triangle where the edge runs from its first vertex to its second.
            let runs = |t: u32, p: u32, q: u32| {
                let tri = mesh.triangles[t as usize];
                (0..3).any(|i| tri[i] == p && tri[(i + 1) % 3] == q)
            };
            let (ta, tb) = if runs(t0, a, b) { (t0, t1) } else { (t1, t0) };
            let third = |t: u32| {
                let tri = mesh.triangles[t as usize];
                *tri.iter()
                    .find(|&&v| v != a && v != b)
                    .expect("a triangle's third corner")
            };
            hinge_of_edge[e] = hinges.len() as u32;
            hinges.push([a, b, third(ta), third(tb)]);
        }
        let rest_angle: Vec<Real> = hinges
            .iter()
            .map(|&h| {
                if rest_flat {
                    0.0
                } else {
                    angle_and_gradient(&rest, h).0
                }
            })
            .collect();
        let edge_index = |p: u32, q: u32| {
            let key = [p.min(q), p.max(q)];
            mesh.edges.binary_search(&key).expect("a triangle's edge")
        };
        let bt = (b.warp * b.weft).max(0.0).sqrt();
        let mut tri_hinges = Vec::with_capacity(mesh.triangles.len());
        let mut coeff = Vec::with_capacity(mesh.triangles.len());
        for (t, &tri) in mesh.triangles.iter().enumerate() {
            let p = tri.map(|v| mesh.rest[v as usize]);
            let (a1, a2) = super::membrane::frame(p[0], p[1], p[2], warp[t]);
            let to2 = |v: Vec3| [v.dot(a1), v.dot(a2)];
            let mut th = [u32::MAX; 3];
            let mut m = [[0.0; 3]; 3];
            for i in 0..3 {
                // Edge i is opposite corner i.
                let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                let (pj, pk) = (p[j], p[k]);
                let ue = (pk - pj).normalize();
                let out = {
                    let v = pj - p[i];
                    (v - ue * ue.dot(v)).normalize()
                };
                let e = edge_index(tri[j], tri[k]);
                th[i] = hinge_of_edge[e];
                // The neighbour's far corner unfolded into this triangle's plane.
                let s = if th[i] == u32::MAX {
                    // The mirror image of the corner across the edge: its normal curvature
                    // across the free edge is what the edge's rest angle pins.
                    let foot = pj + ue * ue.dot(p[i] - pj);
                    2.0 * foot - p[i]
                } else {
                    let h = hinges[th[i] as usize];
                    let other = if h[2] == tri[i] { h[3] } else { h[2] };
                    let q = mesh.rest[other as usize] - pj;
                    let along = q.dot(ue);
                    let across = (q - ue * along).length();
                    pj + ue * along + out * across
                };
                // For a height field h = p^T S p / 2 over the triangle's plane, the turn of the
                // normal across the edge is the change of the linear interpolant's gradient
                // along `out`: linear in S, one column per component of S.
                let q = [to2(p[i]), to2(pj), to2(pk), to2(s)];
                let t2 = to2(out);
                for (c, basis) in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
                    .iter()
                    .enumerate()
                {
                    let h = |v: [Real; 2]| {
                        0.5 * (basis[0] * v[0] * v[0] + basis[1] * v[1] * v[1])
                            + basis[2] * v[0] * v[1]
                    };
                    let g_this = interpolant_gradient([q[0], q[1], q[2]], h);
                    let g_other = interpolant_gradient([q[3], q[1], q[2]], h);
                    m[i][c] = (g_other[0] - g_this[0]) * t2[0] + (g_other[1] - g_this[1]) * t2[1];
                }
            }
            let inv = invert3(m);
            // Energy density 1/2 s^T D s, s = inv theta: K = A inv^T D inv.
            let dg = [b.warp, b.weft, 2.0 * bt];
            let area = mesh.triangle_area[t];
            let mut k = [[0.0; 3]; 3];
            if let Some(inv) = inv {
                for (r, kr) in k.iter_mut().enumerate() {
                    for (c, kc) in kr.iter_mut().enumerate() {
                        let mut v = 0.0;
                        for (q, dq) in dg.iter().enumerate() {
                            v += inv[q][r] * dq * inv[q][c];
                        }
                        *kc = area * v;
                    }
                }
            }
            tri_hinges.push(th);
            coeff.push(k);
        }
        let mut hinge_stiffness = vec![0.0; hinges.len()];
        for (th, k) in tri_hinges.iter().zip(&coeff) {
            for i in 0..3 {
                if th[i] == u32::MAX {
                    continue;
                }
                let row: Real = (0..3)
                    .filter(|&j| th[j] != u32::MAX)
                    .map(|j| k[i][j].abs())
                    .sum();
                hinge_stiffness[th[i] as usize] += row;
            }
        }
        Self {
            hinges,
            rest_angle,
            tri_hinges,
            coeff,
            hinge_stiffness,
        }
    }

    /// Hinge `h`'s angle change from rest at positions `x` (rad, in (-pi, pi]) and the angle's
    /// gradient (1/m).
    #[inline]
    pub fn angle_change(&self, x: &Soa, h: usize) -> (Real, [Vec3; 4]) {
        let (theta, g) = angle_and_gradient(x, self.hinges[h]);
        (wrap(theta - self.rest_angle[h]), g)
    }

    /// The angle changes of hinges `first..first + out.len()` at positions `x` into `out`, the
    /// same bits as [`Bending::angle_change`] gives each (the same arithmetic): over lanes of
    /// hinges, the geometry first (the kernel inlined and vectorised: no call and no branch),
    /// then the `atan2`s.
    pub fn angles_run(&self, x: &Soa, first: usize, out: &mut [(Real, [Vec3; 4])]) {
        const LANE: usize = 32;
        for (c, out) in out.chunks_mut(LANE).enumerate() {
            let h0 = first + c * LANE;
            let m = out.len();
            let mut p = [[Vec3::ZERO; LANE]; 4];
            for (i, h) in self.hinges[h0..h0 + m].iter().enumerate() {
                for v in 0..4 {
                    p[v][i] = x.get(h[v] as usize);
                }
            }
            let (mut sin, mut cos) = ([0.0; LANE], [0.0; LANE]);
            let mut ok = [false; LANE];
            let mut g = [[Vec3::ZERO; LANE]; 4];
            for i in 0..LANE {
                let k = hinge_geometry(p[0][i], p[1][i], p[2][i], p[3][i]);
                (ok[i], sin[i], cos[i]) = (k.ok, k.sin, k.cos);
                for v in 0..4 {
                    g[v][i] = k.grad[v];
                }
            }
            // Field by field: no tuple composed on the stack and copied.
            for (i, o) in out.iter_mut().enumerate() {
                let h = h0 + i;
                o.0 = wrap(angle_of(ok[i], sin[i], cos[i]) - self.rest_angle[h]);
                if ok[i] {
                    for v in 0..4 {
                        o.1[v] = g[v][i];
                    }
                } else {
                    o.1 = [Vec3::ZERO; 4];
                }
            }
        }
    }

    /// Each hinge's angle change from rest at positions `x` into `out` (rad).
    pub fn angles_into(&self, x: &Soa, out: &mut Vec<(Real, [Vec3; 4])>) {
        out.clear();
        out.extend((0..self.hinges.len()).map(|h| self.angle_change(x, h)));
    }

    /// The elastic energy at positions `x`, J.
    pub fn energy(&self, x: &Soa) -> Real {
        let mut a = Vec::new();
        self.angles_into(x, &mut a);
        self.energy_of(&a)
    }

    /// The elastic energy of the angle changes `dtheta`, J.
    pub fn energy_of(&self, dtheta: &[(Real, [Vec3; 4])]) -> Real {
        let mut e = 0.0;
        for (th, k) in self.tri_hinges.iter().zip(&self.coeff) {
            let d = th.map(|h| {
                if h == u32::MAX {
                    0.0
                } else {
                    dtheta[h as usize].0
                }
            });
            for i in 0..3 {
                for j in 0..3 {
                    e += 0.5 * k[i][j] * d[i] * d[j];
                }
            }
        }
        e
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.hinges.capacity() * 16
            + self.rest_angle.capacity() * 8
            + self.tri_hinges.capacity() * 12
            + self.coeff.capacity() * 72
            + self.hinge_stiffness.capacity() * 8
    }
}

/// The gradient of the linear function through the values `h` takes at the corners of the
/// triangle `p` (2D).
fn interpolant_gradient(p: [[Real; 2]; 3], h: impl Fn([Real; 2]) -> Real) -> [Real; 2] {
    let (a, b) = (
        [p[1][0] - p[0][0], p[1][1] - p[0][1]],
        [p[2][0] - p[0][0], p[2][1] - p[0][1]],
    );
    let (da, db) = (h(p[1]) - h(p[0]), h(p[2]) - h(p[0]));
    let det = a[0] * b[1] - a[1] * b[0];
    [(da * b[1] - db * a[1]) / det, (a[0] * db - b[0] * da) / det]
}

/// The inverse of a 3 x 3 matrix (rows), `None` when it is singular.
fn invert3(m: [[Real; 3]; 3]) -> Option<[[Real; 3]; 3]> {
    let c = |r: usize, s: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (s1, s2) = ((s + 1) % 3, (s + 2) % 3);
        m[r1][s1] * m[r2][s2] - m[r1][s2] * m[r2][s1]
    };
    let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
    let scale = m.iter().flatten().map(|v| v.abs()).fold(0.0, Real::max);
    if det.abs() <= 1e-12 * scale * scale * scale || !det.is_finite() {
        return None;
    }
    // inv[i][j] = cofactor(j, i) / det.
    Some(std::array::from_fn(|i| {
        std::array::from_fn(|j| c(j, i) / det)
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square of `n x n` cells of side `h` in the xz plane, split along one diagonal, wound
    /// with the normal up; `jitter` moves interior vertices in the plane.
    pub(crate) fn sheet(n: usize, h: Real, jitter: Real) -> ClothMesh {
        let mut rest = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let interior = i > 0 && j > 0 && i < n && j < n;
                let s = (i * 7 + j * 13) as Real;
                let (dx, dz) = if interior {
                    (jitter * h * (1.3 * s).sin(), jitter * h * (0.7 * s).cos())
                } else {
                    (0.0, 0.0)
                };
                rest.push(Vec3::new(i as Real * h + dx, 0.0, j as Real * h + dz));
            }
        }
        let v = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut tris = Vec::new();
        for j in 0..n {
            for i in 0..n {
                tris.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
                tris.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
            }
        }
        ClothMesh::new(rest, tris).expect("a valid sheet")
    }

    #[test]
    fn the_angle_gradient_matches_central_differences() {
        let mesh = sheet(2, 0.1, 0.0);
        let mut x = Soa::from_vec3(&mesh.rest);
        for k in 0..x.len() {
            let p = x.get(k);
            x.set(
                k,
                p + Vec3::new(0.0, 0.3 * (p.x * 9.0).sin() + 0.2 * p.z * p.x * 20.0, 0.0),
            );
        }
        let b = Bending::new(
            &mesh,
            &vec![Vec3::X; mesh.triangles.len()],
            Rigidity {
                warp: 1.0,
                weft: 1.0,
            },
            true,
        );
        for &hinge in &b.hinges {
            let (_, g) = angle_and_gradient(&x, hinge);
            for (s, &v) in hinge.iter().enumerate() {
                for c in 0..3 {
                    let mut e = Vec3::ZERO;
                    e[c] = 1e-7;
                    let (mut xp, mut xm) = (x.clone(), x.clone());
                    xp.set(v as usize, x.get(v as usize) + e);
                    xm.set(v as usize, x.get(v as usize) - e);
                    let d = (angle_and_gradient(&xp, hinge).0 - angle_and_gradient(&xm, hinge).0)
                        / 2e-7;
                    assert!(
                        (d - g[s][c]).abs() < 1e-5 * (1.0 + d.abs()),
                        "{d} vs {}",
                        g[s][c]
                    );
                }
            }
        }
    }

    /// The lanes give every hinge's angle change and gradient with the same bits as the hinge
    /// alone, over whole lanes, a part lane and a run starting inside a lane, degenerate hinges
    /// (an edge of no length, a triangle of no area) included.
    #[test]
    fn the_lanes_give_the_bits_of_one_hinge() {
        let mesh = sheet(12, 0.01, 0.25);
        let b = Bending::new(
            &mesh,
            &vec![Vec3::X; mesh.triangles.len()],
            Rigidity {
                warp: 1e-4,
                weft: 2e-4,
            },
            false,
        );
        let mut x = Soa::from_vec3(&mesh.rest);
        for k in 0..x.len() {
            let p = x.get(k);
            let s = k as Real;
            x.set(
                k,
                p + Vec3::new(
                    0.001 * (1.7 * s).sin(),
                    0.02 * (p.x * 40.0).sin() * (p.z * 25.0).cos(),
                    0.001 * (0.9 * s).cos(),
                ),
            );
        }
        // Vertex 20 onto its neighbour 21 (an edge of no length), and the corners 59, 60, 73 of
        // one triangle on a line, exactly (a triangle of no area).
        x.set(20, x.get(21));
        for (k, px) in [(59, 0.0703125), (60, 0.078125), (73, 0.0859375)] {
            x.set(k, Vec3::new(px, 0.0, 0.0390625));
        }
        let n = b.hinges.len();
        assert!(n > 3 * 32, "{n} hinges");
        let bits = |a: &(Real, [Vec3; 4])| {
            let mut v = vec![a.0.to_bits()];
            v.extend(a.1.iter().flat_map(|g| g.to_array().map(Real::to_bits)));
            v
        };
        let mut degenerate = 0;
        for (first, len) in [(0, n), (5, 70), (n - 3, 3)] {
            let mut out = vec![(Real::NAN, [Vec3::NAN; 4]); len];
            b.angles_run(&x, first, &mut out);
            for (i, o) in out.iter().enumerate() {
                let one = b.angle_change(&x, first + i);
                assert_eq!(bits(o), bits(&one), "hinge {}", first + i);
                degenerate += usize::from(one.1 == [Vec3::ZERO; 4]);
            }
        }
        assert!(degenerate > 0);
    }

    /// Bent onto a cylinder of curvature `k` about an axis in the sheet, every interior
    /// triangle's energy density is `B k^2 / 2`, on a regular and on an irregular mesh, whatever
    /// the axis' direction (for an isotropic rigidity).
    #[test]
    fn a_cylinder_stores_half_b_k_squared_per_area_on_any_mesh() {
        for jitter in [0.0, 0.25] {
            let mesh = sheet(12, 0.01, jitter);
            let b = Bending::new(
                &mesh,
                &vec![Vec3::X; mesh.triangles.len()],
                Rigidity {
                    warp: 2e-5,
                    weft: 2e-5,
                },
                true,
            );
            for angle in [0.0, 0.5, 1.2] {
                let k = 4.0;
                let dir = Vec3::new((angle as Real).cos(), 0.0, (angle as Real).sin());
                let mut x = Soa::from_vec3(&mesh.rest);
                for v in 0..x.len() {
                    let p = mesh.rest[v] - Vec3::new(0.06, 0.0, 0.06);
                    let s = p.dot(dir);
                    let along = p - dir * s;
                    // The arc of length s on a circle of radius 1/k.
                    let q =
                        along + dir * ((k * s).sin() / k) + Vec3::Y * ((1.0 - (k * s).cos()) / k);
                    x.set(v, q);
                }
                let mut a = Vec::new();
                b.angles_into(&x, &mut a);
                // Interior triangles: all three edges interior.
                let (mut e, mut area) = (0.0, 0.0);
                for (t, th) in b.tri_hinges.iter().enumerate() {
                    if th.iter().all(|&h| h != u32::MAX) {
                        let d = th.map(|h| a[h as usize].0);
                        let kk = &b.coeff[t];
                        for i in 0..3 {
                            for j in 0..3 {
                                e += 0.5 * kk[i][j] * d[i] * d[j];
                            }
                        }
                        area += mesh.triangle_area[t];
                    }
                }
                let want = 0.5 * 2e-5 * k * k * area;
                assert!(
                    (e / want - 1.0).abs() < 0.02,
                    "jitter {jitter} angle {angle}: {}",
                    e / want
                );
            }
        }
    }
}
