//! CPU-side mesh helpers: smooth normals, and triangle meshes for the scene's solid colliders.

use glam::Vec3;
use wetcloth::{Collider, Surface, SurfaceMesh};

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

/// A solid obstacle drawn beside the cloth: a triangle mesh with a normal per vertex, made from
/// a collider's own description ([`wetcloth::Collider::surface`]), so every collider shape the
/// core knows is drawn the same way.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Solid {
    /// Vertex positions, m.
    pub positions: Vec<[f32; 3]>,
    /// Vertex normals (unit, outwards).
    pub normals: Vec<[f32; 3]>,
    /// Triangles, three indices each, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
}

impl Solid {
    /// The solid of a collider's surface mesh.
    pub fn from_surface(mesh: &SurfaceMesh) -> Self {
        let f32s = |v: &wetcloth::Vec3| v.as_vec3().to_array();
        Self {
            positions: mesh.positions.iter().map(f32s).collect(),
            normals: mesh.normals.iter().map(f32s).collect(),
            indices: mesh.triangles.iter().flatten().copied().collect(),
        }
    }

    /// Axis-aligned bounds `(min, max)` (a degenerate box at the origin when empty).
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        bounds_of(&self.positions).unwrap_or(([0.0; 3], [0.0; 3]))
    }

    /// Appends this solid's triangles to a vertex list of `(position, normal)` and an index
    /// list.
    pub(crate) fn append_mesh(&self, verts: &mut Vec<[[f32; 3]; 2]>, indices: &mut Vec<u32>) {
        let base = verts.len() as u32;
        verts.extend(
            self.positions
                .iter()
                .zip(&self.normals)
                .map(|(p, n)| [*p, *n]),
        );
        indices.extend(self.indices.iter().map(|i| base + i));
    }
}

/// The table: an infinite plane in the simulation, drawn as a large finite quad that fades
/// into the backdrop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundPlane {
    /// A point of the plane, m.
    pub point: [f32; 3],
    /// The plane's normal (the side the cloth lies on); need not be unit.
    pub normal: [f32; 3],
}

impl Default for GroundPlane {
    /// The plane y = 0, facing up.
    fn default() -> Self {
        Self {
            point: [0.0; 3],
            normal: [0.0, 1.0, 0.0],
        }
    }
}

/// The scene around the cloth from its colliders: the first plane as the ground (the thesis'
/// table, drawn with its backdrop and shadows), every other collider as a solid.
pub fn collider_scene(colliders: &[Collider]) -> (Option<GroundPlane>, Vec<Solid>) {
    let mut ground = None;
    let mut solids = Vec::new();
    for c in colliders {
        match c.surface() {
            Surface::Plane { point, normal } => {
                ground.get_or_insert(GroundPlane {
                    point: point.as_vec3().to_array(),
                    normal: normal.as_vec3().to_array(),
                });
            }
            Surface::Mesh(m) => solids.push(Solid::from_surface(&m)),
        }
    }
    (ground, solids)
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
        let cuboid = Collider::cuboid(
            wetcloth::Vec3::new(1.0, 2.0, 3.0),
            wetcloth::Vec3::new(0.5, 0.25, 1.0),
            0.6,
        );
        let (ground, solids) = collider_scene(&[cuboid]);
        assert!(ground.is_none());
        solids[0].append_mesh(&mut v, &mut i);
        assert_eq!(v.len(), 24);
        for t in i.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|k| Vec3::from(v[k as usize][0]));
            let n = (b - a).cross(c - a);
            let out = (a + b + c) / 3.0 - Vec3::new(1.0, 2.0, 3.0);
            assert!(n.dot(out) > 0.0);
            assert!(n.normalize().dot(Vec3::from(v[t[0] as usize][1])) > 0.999);
        }
    }

    /// The first plane is the ground, later planes are not drawn as solids, spheres are.
    #[test]
    fn colliders_become_the_ground_and_solids() {
        let o = wetcloth::Vec3::ZERO;
        let (ground, solids) = collider_scene(&[
            Collider::sphere(wetcloth::Vec3::new(0.0, 1.0, 0.0), 0.5, 0.6),
            Collider::plane(o, wetcloth::Vec3::Y, 0.6),
            Collider::plane(wetcloth::Vec3::new(0.0, 2.0, 0.0), wetcloth::Vec3::X, 0.6),
        ]);
        assert_eq!(ground.unwrap().normal, [0.0, 1.0, 0.0]);
        assert_eq!(solids.len(), 1);
        let (lo, hi) = solids[0].bounds();
        assert!((lo[1] - 0.5).abs() < 1e-6 && (hi[1] - 1.5).abs() < 1e-6);
    }
}
