//! The fabric of `[cloth] model = "membrane"`: the membrane elements ([`super::membrane`]) and
//! the bending elements ([`super::bending`]) of a cloth, with the per-particle gather that sums
//! their forces in a fixed order (so the bits do not depend on the thread count).

use super::bending::{Bending, Rigidity};
use super::membrane::{Membrane, Orthotropic};
use crate::math::{Real, Soa, Vec3};
use crate::model::ClothMesh;
use rayon::prelude::*;

/// Elements per task when the elements' forces are computed on the pool.
const PER_TASK: usize = 4096;

/// The membrane and bending elements of a cloth.
#[derive(Clone, Debug, PartialEq)]
pub struct Fabric {
    /// One membrane element per triangle.
    pub membrane: Membrane,
    /// One bending element per interior edge; `None` for a bending stiffness of 0.
    pub bending: Option<Bending>,
    /// The membrane corners of particle `k`: `tri_of[tri_start[k]..tri_start[k + 1]]`, each
    /// `3 t + corner`, in increasing order.
    tri_start: Vec<u32>,
    tri_of: Vec<u32>,
    /// The hinge slots of particle `k` (`4 h + slot`), as for the corners.
    hinge_start: Vec<u32>,
    hinge_of: Vec<u32>,
    /// Each hinge's triangles with its slot in each (`[t, slot]`, `t = u32::MAX` for none).
    hinge_tris: Vec<[[u32; 2]; 2]>,
}

/// Scratch of [`Fabric::forces_into`], kept between steps.
#[derive(Clone, Debug, Default)]
pub struct FabricScratch {
    /// Each triangle's forces on its corners, N.
    pub tri: Vec<[Vec3; 3]>,
    /// Each hinge's angle change from rest (rad) and the angle's gradient (1/m).
    pub angles: Vec<(Real, [Vec3; 4])>,
    /// Each hinge's moment, J per rad.
    pub moments: Vec<Real>,
}

impl FabricScratch {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.tri.capacity() * 72 + self.angles.capacity() * 104 + self.moments.capacity() * 8
    }
}

/// A compressed list: for each of `n` owners, the items `f` gives, in item order.
fn csr(n: usize, items: impl Iterator<Item = (usize, u32)> + Clone) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; n + 1];
    for (k, _) in items.clone() {
        start[k + 1] += 1;
    }
    for k in 0..n {
        start[k + 1] += start[k];
    }
    let mut fill = start.clone();
    let mut of = vec![0u32; start[n] as usize];
    for (k, item) in items {
        of[fill[k] as usize] = item;
        fill[k] += 1;
    }
    (start, of)
}

impl Fabric {
    /// The fabric of `mesh` with each triangle's warp direction `warp[t]`, the membrane
    /// `material` and the bending rigidity `bending` (none when both are 0); `rest_flat` takes
    /// the bending's rest angles as zero.
    pub fn new(
        mesh: &ClothMesh,
        warp: &[Vec3],
        material: Orthotropic,
        bending: Rigidity,
        rest_flat: bool,
    ) -> Self {
        let n = mesh.len();
        let membrane = Membrane::new(&mesh.rest, &mesh.triangles, warp, material);
        let bending = (bending.warp > 0.0 || bending.weft > 0.0)
            .then(|| Bending::new(mesh, warp, bending, rest_flat));
        let (tri_start, tri_of) = csr(
            n,
            mesh.triangles
                .iter()
                .enumerate()
                .flat_map(|(t, tri)| (0..3).map(move |c| (tri[c] as usize, (3 * t + c) as u32))),
        );
        let hinges: &[[u32; 4]] = bending.as_ref().map_or(&[], |b| &b.hinges);
        let (hinge_start, hinge_of) = csr(
            n,
            hinges
                .iter()
                .enumerate()
                .flat_map(|(h, hg)| (0..4).map(move |s| (hg[s] as usize, (4 * h + s) as u32))),
        );
        let mut hinge_tris = vec![[[u32::MAX; 2]; 2]; hinges.len()];
        if let Some(b) = &bending {
            for (t, th) in b.tri_hinges.iter().enumerate() {
                for (slot, &h) in th.iter().enumerate() {
                    if h != u32::MAX {
                        let e = &mut hinge_tris[h as usize];
                        let i = usize::from(e[0][0] != u32::MAX);
                        e[i] = [t as u32, slot as u32];
                    }
                }
            }
        }
        Self {
            membrane,
            bending,
            tri_start,
            tri_of,
            hinge_start,
            hinge_of,
            hinge_tris,
        }
    }

    /// Every element's forces at positions `x` into `scratch` (on the pool when `parallel`);
    /// [`Fabric::gather`] then sums them per particle.
    pub fn forces_into(&self, x: &Soa, scratch: &mut FabricScratch, parallel: bool) {
        let m = &self.membrane;
        let nt = m.triangles.len();
        scratch.tri.resize(nt, [Vec3::ZERO; 3]);
        if parallel && nt > 2 * PER_TASK {
            scratch
                .tri
                .par_chunks_mut(PER_TASK)
                .enumerate()
                .for_each(|(c, out)| m.forces_run(x, c * PER_TASK, out));
        } else {
            m.forces_run(x, 0, &mut scratch.tri);
        }
        let Some(b) = &self.bending else {
            scratch.angles.clear();
            scratch.moments.clear();
            return;
        };
        let nh = b.hinges.len();
        scratch.angles.resize(nh, (0.0, [Vec3::ZERO; 4]));
        if parallel && nh > 2 * PER_TASK {
            scratch
                .angles
                .par_chunks_mut(PER_TASK)
                .enumerate()
                .for_each(|(c, out)| b.angles_run(x, c * PER_TASK, out));
        } else {
            b.angles_run(x, 0, &mut scratch.angles);
        }
        scratch.moments.resize(nh, 0.0);
        let angles = &scratch.angles;
        let moment = |h: usize| {
            let mut sum = 0.0;
            for &[t, slot] in &self.hinge_tris[h] {
                if t == u32::MAX {
                    continue;
                }
                let th = b.tri_hinges[t as usize];
                let k = &b.coeff[t as usize][slot as usize];
                for j in 0..3 {
                    if th[j] != u32::MAX {
                        sum += k[j] * angles[th[j] as usize].0;
                    }
                }
            }
            sum
        };
        for (h, o) in scratch.moments.iter_mut().enumerate() {
            *o = moment(h);
        }
    }

    /// The elements' force on particle `k` from [`Fabric::forces_into`]'s `scratch`, N, summed
    /// in element order.
    #[inline]
    pub fn gather(&self, scratch: &FabricScratch, k: usize) -> Vec3 {
        let mut f = Vec3::ZERO;
        for &e in &self.tri_of[self.tri_start[k] as usize..self.tri_start[k + 1] as usize] {
            f += scratch.tri[(e / 3) as usize][(e % 3) as usize];
        }
        for &e in &self.hinge_of[self.hinge_start[k] as usize..self.hinge_start[k + 1] as usize] {
            let h = (e / 4) as usize;
            f -= scratch.angles[h].1[(e % 4) as usize] * scratch.moments[h];
        }
        f
    }

    /// The elastic energy at positions `x`, J: membrane plus bending.
    pub fn energy(&self, x: &Soa) -> Real {
        self.membrane.energy(x) + self.bending.as_ref().map_or(0.0, |b| b.energy(x))
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.membrane.heap_bytes()
            + self.bending.as_ref().map_or(0, Bending::heap_bytes)
            + (self.tri_start.capacity()
                + self.tri_of.capacity()
                + self.hinge_start.capacity()
                + self.hinge_of.capacity())
                * 4
            + self.hinge_tris.capacity() * 16
    }
}

/// An angle difference brought into (-pi, pi].
#[inline]
pub(crate) fn wrap(a: Real) -> Real {
    use std::f64::consts::PI;
    if a > PI {
        a - 2.0 * PI
    } else if a <= -PI {
        a + 2.0 * PI
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The gathered forces are the fabric energy's negative gradient (central differences).
    #[test]
    fn forces_are_the_energy_gradient() {
        let n = 5;
        let h = 0.02;
        let (rest, tris) = crate::model::test_square(n, h * (n - 1) as Real);
        let mesh = ClothMesh::new(rest.clone(), tris).unwrap();
        let fabric = Fabric::new(
            &mesh,
            &vec![Vec3::X; mesh.triangles.len()],
            Orthotropic::new(300.0, 200.0, 40.0, 0.2),
            Rigidity {
                warp: 1e-4,
                weft: 2e-4,
            },
            true,
        );
        let mut x = Soa::from_vec3(&rest);
        for k in 0..x.len() {
            let p = x.get(k);
            let s = k as Real;
            x.set(
                k,
                p + Vec3::new(
                    0.001 * (1.7 * s).sin(),
                    0.01 * (p.x * 40.0).sin() + 0.004 * (2.3 * s).cos(),
                    0.001 * (0.9 * s).cos(),
                ),
            );
        }
        let mut scratch = FabricScratch::default();
        fabric.forces_into(&x, &mut scratch, false);
        for k in 0..x.len() {
            let f = fabric.gather(&scratch, k);
            for c in 0..3 {
                let mut e = Vec3::ZERO;
                e[c] = 1e-7;
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp.set(k, x.get(k) + e);
                xm.set(k, x.get(k) - e);
                let g = (fabric.energy(&xp) - fabric.energy(&xm)) / 2e-7;
                assert!(
                    (f[c] + g).abs() < 1e-5 * (1.0 + g.abs()),
                    "{k} {c}: {} vs {}",
                    f[c],
                    -g
                );
            }
        }
    }
}
