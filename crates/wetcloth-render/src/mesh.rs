//! CPU-side mesh helpers: smooth normals, and triangle meshes for the scene's solid colliders.

use glam::Vec3;

/// Area-weighted smooth vertex normals of a triangle mesh: each vertex gets the normalised sum
/// of the (un-normalised) cross products of the triangles around it, so larger triangles count
/// more. Triangles are `indices` in threes, wound so that `(p1 - p0) x (p2 - p0)` is the front
/// side; indices out of range are skipped. A vertex with no area around it gets +Y.
pub fn smooth_normals(positions: &[[f32; 3]], indices: &[u32]) -> Vec<[f32; 3]> {
    let mut acc = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
        if a >= positions.len() || b >= positions.len() || c >= positions.len() {
            continue;
        }
        let pa = Vec3::from(positions[a]);
        let w = (Vec3::from(positions[b]) - pa).cross(Vec3::from(positions[c]) - pa);
        acc[a] += w;
        acc[b] += w;
        acc[c] += w;
    }
    acc.into_iter()
        .map(|n| n.normalize_or(Vec3::Y).to_array())
        .collect()
}

/// A solid obstacle drawn beside the cloth (the run's sphere and box colliders).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Solid {
    /// A sphere, m.
    Sphere {
        /// Centre, m.
        center: [f32; 3],
        /// Radius, m.
        radius: f32,
    },
    /// An axis-aligned box, m.
    Box {
        /// Centre, m.
        center: [f32; 3],
        /// Half the edge lengths along x, y and z, m.
        half_extents: [f32; 3],
    },
}

impl Solid {
    /// Axis-aligned bounds `(min, max)`.
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let (c, h) = match *self {
            Solid::Sphere { center, radius } => (Vec3::from(center), Vec3::splat(radius)),
            Solid::Box {
                center,
                half_extents,
            } => (Vec3::from(center), Vec3::from(half_extents)),
        };
        ((c - h).to_array(), (c + h).to_array())
    }

    /// Appends this solid's triangles (flat-shaded box, smooth UV sphere) to a vertex list of
    /// `(position, normal)` and an index list.
    pub(crate) fn append_mesh(&self, verts: &mut Vec<[[f32; 3]; 2]>, indices: &mut Vec<u32>) {
        match *self {
            Solid::Sphere { center, radius } => {
                // A UV sphere: 48 segments around, 24 rings from pole to pole.
                let (seg, rings) = (48u32, 24u32);
                let base = verts.len() as u32;
                for r in 0..=rings {
                    let theta = std::f32::consts::PI * r as f32 / rings as f32;
                    for s in 0..=seg {
                        let phi = std::f32::consts::TAU * s as f32 / seg as f32;
                        let n = Vec3::new(
                            theta.sin() * phi.cos(),
                            theta.cos(),
                            theta.sin() * phi.sin(),
                        );
                        let p = Vec3::from(center) + n * radius.abs();
                        verts.push([p.to_array(), n.to_array()]);
                    }
                }
                for r in 0..rings {
                    for s in 0..seg {
                        let a = base + r * (seg + 1) + s;
                        let b = a + seg + 1;
                        indices.extend_from_slice(&[a, a + 1, b, a + 1, b + 1, b]);
                    }
                }
            }
            Solid::Box {
                center,
                half_extents,
            } => {
                let c = Vec3::from(center);
                let h = Vec3::from(half_extents).abs();
                // Each face: its normal and two tangents with t1 x t2 = n (front side out).
                for axis in 0..3 {
                    for sign in [-1.0f32, 1.0] {
                        let mut n = Vec3::ZERO;
                        n[axis] = sign;
                        let mut t1 = Vec3::ZERO;
                        t1[(axis + 1) % 3] = 1.0;
                        let t2 = n.cross(t1);
                        let base = verts.len() as u32;
                        for (u, v) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                            let p = c + (n + t1 * u + t2 * v) * h;
                            verts.push([p.to_array(), n.to_array()]);
                        }
                        indices.extend_from_slice(&[
                            base,
                            base + 1,
                            base + 2,
                            base,
                            base + 2,
                            base + 3,
                        ]);
                    }
                }
            }
        }
    }
}

/// A square cloth of `n` x `n` particles and side `size` (m) centred on the origin in the
/// plane y = `rest_height`, with a smooth tent of height `lift` (m) raised at its centre;
/// wound like the simulator's grid (front side up). Demo and test geometry.
pub fn tented_grid(n: usize, size: f32, rest_height: f32, lift: f32) -> (Vec<[f32; 3]>, Vec<u32>) {
    let n = n.max(2);
    let mut positions = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let x = (i as f32 / (n - 1) as f32 - 0.5) * size;
            let z = (j as f32 / (n - 1) as f32 - 0.5) * size;
            let r = (x * x + z * z).sqrt() / (0.3 * size);
            let y = rest_height + lift * (-r * r).exp();
            positions.push([x, y, z]);
        }
    }
    let mut indices = Vec::with_capacity(6 * (n - 1) * (n - 1));
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (j * n + i) as u32;
            let b = a + 1;
            let c = a + n as u32 + 1;
            let d = a + n as u32;
            indices.extend_from_slice(&[a, c, b, a, d, c]);
        }
    }
    (positions, indices)
}

/// Axis-aligned bounds of a point set, or `None` when it has no finite point.
pub(crate) fn bounds_of(points: &[[f32; 3]]) -> Option<([f32; 3], [f32; 3])> {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for p in points {
        let p = Vec3::from(*p);
        if p.is_finite() {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    lo.cmple(hi).all().then(|| (lo.to_array(), hi.to_array()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_grid_normals_point_up_and_are_unit() {
        // Two triangles of the unit square in the x-z plane, wound like the core's grid.
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 0.0, 1.0],
            [0.0, 0.0, 1.0],
        ];
        let n = smooth_normals(&p, &[0, 2, 1, 0, 3, 2]);
        for v in n {
            assert!((Vec3::from(v) - Vec3::Y).length() < 1e-6, "{v:?}");
        }
    }

    #[test]
    fn box_faces_point_outwards() {
        let mut v = Vec::new();
        let mut i = Vec::new();
        Solid::Box {
            center: [1.0, 2.0, 3.0],
            half_extents: [0.5, 0.25, 1.0],
        }
        .append_mesh(&mut v, &mut i);
        assert_eq!(v.len(), 24);
        for t in i.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|k| Vec3::from(v[k as usize][0]));
            let n = (b - a).cross(c - a);
            let out = (a + b + c) / 3.0 - Vec3::new(1.0, 2.0, 3.0);
            assert!(n.dot(out) > 0.0);
            assert!(n.normalize().dot(Vec3::from(v[t[0] as usize][1])) > 0.999);
        }
    }
}
