//! The built-in grid as a mesh cloth, shared by the mesh tests (`#[path]`-included by
//! `tests/cloth_mesh.rs`, `tests/implicit_energy.rs` and `tests/seeded_mesh.rs`).

use std::sync::Arc;
use wetcloth::{ClothMeshSource, Real, Vec3};

/// A mesh source of `vertices` and triangular `faces`.
pub fn source(vertices: Vec<Vec3>, faces: Vec<[u32; 3]>) -> ClothMeshSource {
    ClothMeshSource {
        file: "test.obj".into(),
        vertices: Arc::new(vertices),
        faces: Arc::new(faces.into_iter().map(|f| f.to_vec()).collect()),
        uvs: Arc::new(Vec::new()),
        face_uvs: Arc::new(Vec::new()),
        rotation: Vec3::ZERO,
        scale: 1.0,
        flip_normals: false,
    }
}

/// The built-in grid's particles and triangles as a mesh: `n x n` particles over `size` (m)
/// in the xz plane centred on the origin, particle `(i, j)` at `j * n + i`, one diagonal per
/// cell wound with the normal up (as `Grid::triangles`).
pub fn grid_mesh(n: usize, size: Real) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let h = size / (n - 1) as Real;
    let mut v = Vec::new();
    for j in 0..n {
        for i in 0..n {
            v.push(Vec3::new(
                i as Real * h - 0.5 * size,
                0.0,
                j as Real * h - 0.5 * size,
            ));
        }
    }
    let mut t = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (j * n + i) as u32;
            let (b, c, d) = (a + 1, a + 1 + n as u32, a + n as u32);
            t.push([a, c, b]);
            t.push([a, d, c]);
        }
    }
    (v, t)
}
