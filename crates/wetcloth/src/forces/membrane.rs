//! The membrane element (`[cloth] model = "membrane"`): one orthotropic Saint Venant-Kirchhoff
//! triangle per face of the cloth, its axes the fabric's warp and weft.
//!
//! Each triangle keeps its rest shape in its own material frame (warp `a1`, weft `a2 = n x a1`,
//! both unit vectors in the rest triangle's plane). The deformation gradient `F` (3 x 2) maps
//! that frame to the deformed triangle; the Green strain `E = (F^T F - I) / 2` is zero for every
//! rigid motion, so a rotated cloth feels no force (frame invariance). The energy per unit rest
//! area is
//!
//! `W = 1/2 (Q11 E11^2 + 2 Q12 E11 E22 + Q22 E22^2) + 1/2 Q66 (2 E12)^2`
//!
//! with the plane-stress constants of an orthotropic sheet of warp and weft stiffness `E1`,
//! `E2` (N/m), in-plane shear stiffness `G` (N/m) and Poisson's ratio `nu12` (weft contraction
//! per unit warp strain): `Q11 = E1 / (1 - nu12 nu21)`, `Q22 = E2 / (1 - nu12 nu21)`,
//! `Q12 = nu12 E2 / (1 - nu12 nu21)`, `Q66 = G`, `nu21 = nu12 E2 / E1`. For small strains this
//! is the orthotropic linear membrane; at large strains it is Saint Venant-Kirchhoff: the second
//! Piola-Kirchhoff stress is linear in the Green strain, so a strip pulled to a stretch `s`
//! carries `E1 (s^2 - 1) s / 2` per unit width (0.75 % above `E1 (s - 1)` at 0.5 % strain), and
//! a triangle squeezed to less than `1 / sqrt(3)` of its size softens (cloth buckles long before).
//!
//! The stiffness the implicit integrator needs is the element's Hessian made positive
//! semi-definite: the material part `A J^T Q J` (`J` the strain's derivative, always positive
//! semi-definite) plus the geometric part `A (g_i^T S g_j) I` with the stress `S` replaced by its
//! positive part (a compressed direction adds no negative stiffness).

use crate::math::{Real, Soa, Vec3};
use glam::DMat3;

/// The plane-stress stiffness of an orthotropic membrane, N/m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orthotropic {
    /// `Q11`: warp stress per warp strain with the weft held, N/m.
    pub q11: Real,
    /// `Q12`: warp stress per weft strain, N/m.
    pub q12: Real,
    /// `Q22`: weft stress per weft strain with the warp held, N/m.
    pub q22: Real,
    /// `Q66`: shear stress per engineering shear strain, N/m.
    pub q66: Real,
}

impl Orthotropic {
    /// The constants of a sheet of warp and weft stiffness `warp`, `weft` (N/m, each with the
    /// other direction free), shear stiffness `shear` (N/m) and Poisson's ratio `poisson` (weft
    /// contraction per unit warp strain). Needs `poisson^2 weft / warp < 1`.
    pub fn new(warp: Real, weft: Real, shear: Real, poisson: Real) -> Self {
        let nu21 = if warp > 0.0 {
            poisson * weft / warp
        } else {
            0.0
        };
        let d = 1.0 - poisson * nu21;
        Self {
            q11: warp / d,
            q12: poisson * weft / d,
            q22: weft / d,
            q66: shear,
        }
    }

    /// The stress `(S11, S22, S12)` (N/m) of the Green strain `(E11, E22, E12)`.
    #[inline]
    pub fn stress(&self, e: [Real; 3]) -> [Real; 3] {
        [
            self.q11 * e[0] + self.q12 * e[1],
            self.q12 * e[0] + self.q22 * e[1],
            2.0 * self.q66 * e[2],
        ]
    }

    /// The energy per unit rest area of the Green strain `e`, J/m^2.
    #[inline]
    pub fn energy_density(&self, e: [Real; 3]) -> Real {
        0.5 * (self.q11 * e[0] * e[0] + 2.0 * self.q12 * e[0] * e[1] + self.q22 * e[1] * e[1])
            + 2.0 * self.q66 * e[2] * e[2]
    }
}

/// The membrane elements of a cloth.
#[derive(Clone, Debug, PartialEq)]
pub struct Membrane {
    /// The triangles (as the cloth mesh's).
    pub triangles: Vec<[u32; 3]>,
    /// Each triangle's shape gradients: corner `i`'s `(g_i1, g_i2)`, so that the deformed
    /// frame's columns are `f_a = sum_i x_i g_ia` (1/m).
    pub grad: Vec<[[Real; 2]; 3]>,
    /// Each triangle's rest area, m^2.
    pub area: Vec<Real>,
    /// The material.
    pub material: Orthotropic,
}

/// What one triangle's state gives: its frame's columns, strain and stress.
#[derive(Clone, Copy, Debug)]
struct Deformed {
    f1: Vec3,
    f2: Vec3,
    e: [Real; 3],
    s: [Real; 3],
}

impl Membrane {
    /// The elements of `triangles` at `rest` positions (m), each with its warp direction
    /// `warp[t]` (any vector not normal to the triangle; projected onto it) and `material`.
    pub fn new(
        rest: &[Vec3],
        triangles: &[[u32; 3]],
        warp: &[Vec3],
        material: Orthotropic,
    ) -> Self {
        let mut grad = Vec::with_capacity(triangles.len());
        let mut area = Vec::with_capacity(triangles.len());
        for (t, &[a, b, c]) in triangles.iter().enumerate() {
            let (p0, p1, p2) = (rest[a as usize], rest[b as usize], rest[c as usize]);
            let (a1, a2) = frame(p0, p1, p2, warp[t]);
            let (e1, e2) = (p1 - p0, p2 - p0);
            // The rest edges in the material frame, and the inverse of [X1 - X0, X2 - X0].
            let (u1, v1, u2, v2) = (e1.dot(a1), e1.dot(a2), e2.dot(a1), e2.dot(a2));
            let det = u1 * v2 - u2 * v1;
            let inv = [[v2 / det, -u2 / det], [-v1 / det, u1 / det]];
            // f_a = (x1 - x0) inv[0][a] + (x2 - x0) inv[1][a].
            let g1 = [inv[0][0], inv[0][1]];
            let g2 = [inv[1][0], inv[1][1]];
            let g0 = [-g1[0] - g2[0], -g1[1] - g2[1]];
            grad.push([g0, g1, g2]);
            area.push(0.5 * det.abs());
        }
        Self {
            triangles: triangles.to_vec(),
            grad,
            area,
            material,
        }
    }

    /// Triangle `t`'s deformation at positions `x`.
    #[inline]
    fn deformed(&self, x: &Soa, t: usize) -> Deformed {
        let [a, b, c] = self.triangles[t];
        let p = [x.get(a as usize), x.get(b as usize), x.get(c as usize)];
        deformation(&self.material, &self.grad[t], p)
    }

    /// Triangle `t`'s forces on its three corners at positions `x`, N.
    #[inline]
    pub fn forces(&self, x: &Soa, t: usize) -> [Vec3; 3] {
        corner_forces(&self.deformed(x, t), &self.grad[t], self.area[t])
    }

    /// The forces of triangles `first..first + out.len()` at positions `x` into `out`, the
    /// same bits as [`Membrane::forces`] gives each (the same arithmetic), over lanes of
    /// triangles (the corners gathered first, then the arithmetic, inlined and vectorised).
    pub fn forces_run(&self, x: &Soa, first: usize, out: &mut [[Vec3; 3]]) {
        const LANE: usize = 32;
        for (c, out) in out.chunks_mut(LANE).enumerate() {
            let t0 = first + c * LANE;
            let m = out.len();
            let mut p = [[Vec3::ZERO; LANE]; 3];
            for (i, tri) in self.triangles[t0..t0 + m].iter().enumerate() {
                for v in 0..3 {
                    p[v][i] = x.get(tri[v] as usize);
                }
            }
            let (grads, areas) = (&self.grad[t0..t0 + m], &self.area[t0..t0 + m]);
            let mut f = [[Vec3::ZERO; LANE]; 3];
            for i in 0..m {
                let g = &grads[i];
                let d = deformation(&self.material, g, [p[0][i], p[1][i], p[2][i]]);
                let fi = corner_forces(&d, g, areas[i]);
                for v in 0..3 {
                    f[v][i] = fi[v];
                }
            }
            for (i, o) in out.iter_mut().enumerate() {
                for v in 0..3 {
                    o[v] = f[v][i];
                }
            }
        }
    }

    /// Triangle `t`'s elastic energy at positions `x`, J.
    #[inline]
    pub fn energy_of(&self, x: &Soa, t: usize) -> Real {
        self.area[t] * self.material.energy_density(self.deformed(x, t).e)
    }

    /// The elements' elastic energy at positions `x`, J.
    pub fn energy(&self, x: &Soa) -> Real {
        (0..self.triangles.len())
            .map(|t| self.energy_of(x, t))
            .sum()
    }

    /// Triangle `t`'s largest principal stretch at positions `x` (1 at rest): the larger
    /// singular value of its deformation gradient.
    #[inline]
    pub fn principal_stretch(&self, x: &Soa, t: usize) -> Real {
        let d = self.deformed(x, t);
        let (a, b, c) = (d.f1.dot(d.f1), d.f2.dot(d.f2), d.f1.dot(d.f2));
        let half = 0.5 * (a + b);
        let r = (0.25 * (a - b) * (a - b) + c * c).sqrt();
        (half + r).sqrt()
    }

    /// The largest principal stretch minus one of any triangle at positions `x` (NaN if a
    /// position is).
    pub fn max_stretch(&self, x: &Soa) -> Real {
        let mut worst = Real::NEG_INFINITY;
        for t in 0..self.triangles.len() {
            let s = self.principal_stretch(x, t) - 1.0;
            worst = if s > worst || s.is_nan() { s } else { worst };
        }
        worst
    }

    /// Triangle `t`'s stiffness blocks at positions `x` (N/m), positive semi-definite (see the
    /// module docs): `h[i][j]` couples corner `i`'s force to corner `j`'s move.
    pub fn hessian(&self, x: &Soa, t: usize) -> [[DMat3; 3]; 3] {
        let d = self.deformed(x, t);
        let g = &self.grad[t];
        let q = &self.material;
        let area = self.area[t];
        // The strain's derivative for corner i: rows dE11, dE22, d(2 E12) as vectors.
        let j: [[Vec3; 3]; 3] = std::array::from_fn(|i| {
            [
                d.f1 * g[i][0],
                d.f2 * g[i][1],
                d.f2 * g[i][0] + d.f1 * g[i][1],
            ]
        });
        // The stress's positive part (eigen-decomposition of the 2 x 2 S).
        let (s11, s22, s12) = (d.s[0], d.s[1], d.s[2]);
        let half = 0.5 * (s11 + s22);
        let r = (0.25 * (s11 - s22) * (s11 - s22) + s12 * s12).sqrt();
        let (l1, l2) = (half + r, half - r);
        let sp = if l2 >= 0.0 {
            [s11, s22, s12]
        } else if l1 <= 0.0 {
            [0.0; 3]
        } else {
            // Eigenvector of l1: (s12, l1 - s11) or (l1 - s22, s12).
            let (mut vx, mut vy) = (s12, l1 - s11);
            if vx * vx + vy * vy < 1e-30 {
                (vx, vy) = (l1 - s22, s12);
            }
            let nrm = (vx * vx + vy * vy).sqrt();
            if nrm == 0.0 {
                [l1.max(0.0), l1.max(0.0), 0.0]
            } else {
                let (vx, vy) = (vx / nrm, vy / nrm);
                [l1 * vx * vx, l1 * vy * vy, l1 * vx * vy]
            }
        };
        std::array::from_fn(|a| {
            std::array::from_fn(|b| {
                let (ja, jb) = (&j[a], &j[b]);
                // Q J_b: the stress change per move of corner b, one 3-vector per component.
                let qj = [
                    jb[0] * q.q11 + jb[1] * q.q12,
                    jb[0] * q.q12 + jb[1] * q.q22,
                    jb[2] * q.q66,
                ];
                let outer = |u: Vec3, v: Vec3| DMat3::from_cols(u * v.x, u * v.y, u * v.z);
                let material = outer(ja[0], qj[0]) + outer(ja[1], qj[1]) + outer(ja[2], qj[2]);
                let geo = g[a][0] * (sp[0] * g[b][0] + sp[2] * g[b][1])
                    + g[a][1] * (sp[2] * g[b][0] + sp[1] * g[b][1]);
                (material + DMat3::from_diagonal(Vec3::splat(geo))) * area
            })
        })
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.triangles.capacity() * 12 + self.grad.capacity() * 48 + self.area.capacity() * 8
    }
}

/// The deformation of a triangle with shape gradients `g` (1/m) and corners at `p` (m), of
/// `material`.
#[inline(always)]
fn deformation(material: &Orthotropic, g: &[[Real; 2]; 3], p: [Vec3; 3]) -> Deformed {
    let f1 = p[0] * g[0][0] + p[1] * g[1][0] + p[2] * g[2][0];
    let f2 = p[0] * g[0][1] + p[1] * g[1][1] + p[2] * g[2][1];
    let e = [
        0.5 * (f1.dot(f1) - 1.0),
        0.5 * (f2.dot(f2) - 1.0),
        0.5 * f1.dot(f2),
    ];
    let s = material.stress(e);
    Deformed { f1, f2, e, s }
}

/// The forces on its three corners (N) of a triangle deformed as `d`, with shape gradients `g`
/// (1/m) and rest area `area` (m^2).
#[inline(always)]
fn corner_forces(d: &Deformed, g: &[[Real; 2]; 3], area: Real) -> [Vec3; 3] {
    // The first Piola-Kirchhoff stress P = F S, column by column.
    let p1 = d.f1 * d.s[0] + d.f2 * d.s[2];
    let p2 = d.f1 * d.s[2] + d.f2 * d.s[1];
    let a = -area;
    [
        (p1 * g[0][0] + p2 * g[0][1]) * a,
        (p1 * g[1][0] + p2 * g[1][1]) * a,
        (p1 * g[2][0] + p2 * g[2][1]) * a,
    ]
}

/// The material frame of the rest triangle `p0 p1 p2`: the warp `warp` projected onto the
/// triangle (the projection of the x axis, then of the z axis, where `warp` is nearly normal to
/// it) and the weft, the triangle's normal crossed with the warp.
pub fn frame(p0: Vec3, p1: Vec3, p2: Vec3, warp: Vec3) -> (Vec3, Vec3) {
    let n = (p1 - p0).cross(p2 - p0).normalize_or_zero();
    let project = |w: Vec3| {
        let v = w - n * n.dot(w);
        let l = v.length();
        (l > 1e-3 * w.length()).then(|| v / l)
    };
    let a1 = project(warp)
        .or_else(|| project(Vec3::X))
        .or_else(|| project(Vec3::Z))
        .unwrap_or(Vec3::X);
    (a1, n.cross(a1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(material: Orthotropic) -> (Membrane, Soa) {
        let rest = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.1, 0.0, 0.02),
            Vec3::new(0.03, 0.0, -0.08),
        ];
        let tri = [[0, 1, 2]];
        let m = Membrane::new(&rest, &tri, &[Vec3::X], material);
        (m, Soa::from_vec3(&rest))
    }

    /// The forces are the energy's negative gradient (central differences), and the positive
    /// part of the Hessian matches the gradient's derivative where the stress is tension.
    #[test]
    fn forces_are_the_energy_gradient_and_the_hessian_its_derivative_in_tension() {
        let (m, rest) = one(Orthotropic::new(800.0, 300.0, 50.0, 0.3));
        let mut x = rest.clone();
        // A stretch in both directions with a shear and a rotation.
        let r = DMat3::from_rotation_y(0.7) * DMat3::from_rotation_x(0.3);
        for k in 0..3 {
            let p = rest.get(k);
            x.set(
                k,
                r * Vec3::new(1.04 * p.x + 0.01 * p.z, p.y, 1.03 * p.z) + Vec3::ONE,
            );
        }
        let f = m.forces(&x, 0);
        let h = 1e-7;
        for k in 0..3 {
            for c in 0..3 {
                let mut xp = x.clone();
                let mut xm = x.clone();
                let mut e = Vec3::ZERO;
                e[c] = h;
                xp.set(k, x.get(k) + e);
                xm.set(k, x.get(k) - e);
                let g = (m.energy(&xp) - m.energy(&xm)) / (2.0 * h);
                assert!(
                    (f[k][c] + g).abs() < 1e-6 * (1.0 + g.abs()),
                    "{k} {c}: {} vs {g}",
                    f[k][c]
                );
                // Hessian column: the force's change with the move.
                let (fp, fm) = (m.forces(&xp, 0), m.forces(&xm, 0));
                let hess = m.hessian(&x, 0);
                for j in 0..3 {
                    let col = -(fp[j] - fm[j]) / (2.0 * h);
                    let got = hess[j][k].col(c);
                    assert!(
                        (col - got).length() < 1e-5 * (1.0 + col.length()),
                        "{j} {k} {c}: {col} vs {got}"
                    );
                }
            }
        }
    }

    /// The lanes give every triangle's forces with the same bits as the triangle alone, over
    /// whole lanes, a part lane and a run starting inside a lane.
    #[test]
    fn the_lanes_give_the_bits_of_one_triangle() {
        let (n, h) = (10, 0.01);
        let (rest, tris) = crate::model::test_square(n, h * (n - 1) as Real);
        let warp = vec![Vec3::new(1.0, 0.0, 0.3); tris.len()];
        let m = Membrane::new(
            &rest,
            &tris,
            &warp,
            Orthotropic::new(800.0, 300.0, 50.0, 0.3),
        );
        let mut x = Soa::from_vec3(&rest);
        for k in 0..x.len() {
            let p = x.get(k);
            let s = k as Real;
            x.set(
                k,
                p * 1.03
                    + Vec3::new(
                        0.001 * (1.7 * s).sin(),
                        0.01 * (p.x * 40.0).sin(),
                        0.001 * (0.9 * s).cos(),
                    ),
            );
        }
        let nt = tris.len();
        assert!(nt > 3 * 32, "{nt} triangles");
        for (first, len) in [(0, nt), (5, 70), (nt - 3, 3)] {
            let mut out = vec![[Vec3::NAN; 3]; len];
            m.forces_run(&x, first, &mut out);
            for (i, o) in out.iter().enumerate() {
                let one = m.forces(&x, first + i);
                for c in 0..3 {
                    assert_eq!(
                        o[c].to_array().map(Real::to_bits),
                        one[c].to_array().map(Real::to_bits),
                        "triangle {} corner {c}",
                        first + i
                    );
                }
            }
        }
    }

    /// A rigid motion makes no force and no energy.
    #[test]
    fn a_rigid_motion_makes_no_force() {
        let (m, rest) = one(Orthotropic::new(800.0, 300.0, 50.0, 0.3));
        let r = DMat3::from_rotation_z(1.1) * DMat3::from_rotation_x(-0.4);
        let mut x = rest.clone();
        for k in 0..3 {
            x.set(k, r * rest.get(k) + Vec3::new(3.0, -2.0, 1.0));
        }
        for f in m.forces(&x, 0) {
            assert!(f.length() < 1e-12, "{f}");
        }
        assert!(m.energy(&x).abs() < 1e-16);
        assert!((m.principal_stretch(&x, 0) - 1.0).abs() < 1e-12);
    }

    /// A uniaxial warp strain `eps` with the weft free: the stress along the warp is `E1 eps`
    /// (to first order) and the weft contracts by `nu12 eps`, from the constants.
    #[test]
    fn the_constants_are_the_orthotropic_sheet() {
        let q = Orthotropic::new(800.0, 300.0, 50.0, 0.3);
        let eps = 1e-6;
        // Weft free: S22 = 0 -> E22 = -Q12 / Q22 E11.
        let e22 = -q.q12 / q.q22 * eps;
        let s = q.stress([eps, e22, 0.0]);
        assert!((s[0] / eps - 800.0).abs() < 1e-9, "{}", s[0] / eps);
        assert!((e22 / eps + 0.3).abs() < 1e-12);
        let s = q.stress([0.0, 0.0, 0.5 * eps]);
        assert!((s[2] / eps - 50.0).abs() < 1e-9);
    }
}
