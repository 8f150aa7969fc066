//! The cloth's surface as the outputs write it (OBJ frames, caches): its faces in the order and
//! winding the user gave them, its texture coordinates and their seams.
//!
//! The physics triangulates and may flip a mesh cloth (`flip_normals`); the outputs do not:
//! a mesh cloth's faces are the file's polygons, corner for corner, with the file's texture
//! coordinates (`f v/vt`, seams kept), so a point cache of the run applies to the user's
//! original object. The built-in grid's surface is its two triangles per cell
//! ([`Grid::triangles`]) with one texture coordinate per particle ([`Grid::uvs`]).

use crate::math::{Real, Soa, Vec3};
use crate::model::Grid;
use crate::params::ClothParams;

/// The faces and texture coordinates of a cloth's outputs. Vertex `k` is particle `k`.
#[derive(Clone, Debug, PartialEq)]
pub struct ClothSurface {
    /// Vertices (particles).
    pub vertices: usize,
    /// The grid's particles along x and z, for the built-in grid; `None` for a mesh cloth.
    pub grid: Option<[usize; 2]>,
    /// Where each face's corners start in [`ClothSurface::face_vertices`]: face `f` is
    /// `face_vertices[face_start[f]..face_start[f + 1]]`. One more entry than faces, from 0.
    pub face_start: Vec<u32>,
    /// Every face's vertices (from 0), face after face, counter-clockwise seen from the side
    /// its normal points to (the file's winding for a mesh cloth).
    pub face_vertices: Vec<u32>,
    /// Texture coordinates: the grid's, one per vertex; a mesh cloth's file's `vt` list
    /// (possibly empty).
    pub uvs: Vec<[Real; 2]>,
    /// Each corner's index into [`ClothSurface::uvs`], aligned with
    /// [`ClothSurface::face_vertices`] (face-varying, seams kept); `None` on the grid (a
    /// corner has its vertex's texture coordinate) and for a mesh whose faces have none.
    pub face_uvs: Option<Vec<u32>>,
}

impl ClothSurface {
    /// The surface of `cloth`: the file's faces and texture coordinates for a mesh cloth, the
    /// grid's triangles and per-particle texture coordinates for the built-in grid.
    pub fn new(cloth: &ClothParams) -> Self {
        match &cloth.mesh {
            None => {
                let grid = Grid::new(cloth);
                let triangles = grid.triangles();
                Self {
                    vertices: grid.len(),
                    grid: Some([grid.nx, grid.nz]),
                    face_start: (0..=triangles.len() as u32).map(|f| 3 * f).collect(),
                    face_vertices: triangles.into_iter().flatten().collect(),
                    uvs: grid.uvs(),
                    face_uvs: None,
                }
            }
            Some(m) => {
                let mut face_start = Vec::with_capacity(m.faces.len() + 1);
                face_start.push(0u32);
                let mut face_vertices = Vec::new();
                for f in m.faces.iter() {
                    face_vertices.extend_from_slice(f);
                    face_start.push(face_vertices.len() as u32);
                }
                let face_uvs = (!m.face_uvs.is_empty())
                    .then(|| m.face_uvs.iter().flatten().copied().collect());
                Self {
                    vertices: m.vertices.len(),
                    grid: None,
                    face_start,
                    face_vertices,
                    uvs: m.uvs.to_vec(),
                    face_uvs,
                }
            }
        }
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.face_start.len().saturating_sub(1)
    }

    /// Face `f`'s vertices, in order.
    pub fn face(&self, f: usize) -> &[u32] {
        &self.face_vertices[self.face_start[f] as usize..self.face_start[f + 1] as usize]
    }

    /// Every face's vertices, in order.
    pub fn faces(&self) -> impl ExactSizeIterator<Item = &[u32]> + '_ {
        (0..self.face_count()).map(move |f| self.face(f))
    }

    /// Face `f`'s texture-coordinate indices, corner by corner, when the surface has
    /// face-varying ones.
    pub fn face_uv(&self, f: usize) -> Option<&[u32]> {
        self.face_uvs
            .as_ref()
            .map(|u| &u[self.face_start[f] as usize..self.face_start[f + 1] as usize])
    }

    /// Whether every face is a triangle.
    pub fn all_triangles(&self) -> bool {
        self.face_start.windows(2).all(|w| w[1] - w[0] == 3)
    }

    /// Whether its faces have texture coordinates (every grid's do; a mesh cloth's when its
    /// file's faces have `v/vt` corners).
    pub fn has_uvs(&self) -> bool {
        self.face_uvs.is_some() || self.grid.is_some()
    }

    /// Smooth vertex normals at positions `p`, on the output winding: the sum over the faces
    /// around each vertex of the face's area vector (for a triangle `[a, b, c]`,
    /// `(b - a) x (c - a)`; for a polygon the sum of its fan from the first corner), normalised
    /// (+Y where the sum vanishes). On the grid these are [`Grid::vertex_normals`], bit for bit.
    pub fn vertex_normals(&self, p: &Soa) -> Vec<Vec3> {
        let mut n = vec![Vec3::ZERO; self.vertices];
        for f in self.faces() {
            let a = p.get(f[0] as usize);
            let mut w = Vec3::ZERO;
            for k in 1..f.len() - 1 {
                let c = (p.get(f[k] as usize) - a).cross(p.get(f[k + 1] as usize) - a);
                w = if k == 1 { c } else { w + c };
            }
            for &v in f {
                n[v as usize] += w;
            }
        }
        for v in &mut n {
            *v = v.normalize_or(Vec3::Y);
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ClothMeshSource;
    use std::sync::Arc;

    #[test]
    fn the_grid_surface_is_its_triangles_and_normals_bit_for_bit() {
        let cloth = ClothParams {
            resolution: [5, 4],
            ..Default::default()
        };
        let grid = Grid::new(&cloth);
        let s = ClothSurface::new(&cloth);
        assert_eq!(s.face_count(), grid.triangles().len());
        for (f, t) in s.faces().zip(grid.triangles()) {
            assert_eq!(f, &t[..]);
        }
        assert_eq!(s.uvs, grid.uvs());
        assert!(s.face_uvs.is_none() && s.all_triangles() && s.has_uvs());
        let mut p = grid.rest_positions(Vec3::new(0.0, 0.1, 0.0));
        for k in 0..p.len() {
            p.y[k] += 0.01 * ((k * 7919) % 13) as Real / 13.0;
            p.x[k] += 1e-3 * ((k * 104_729) % 7) as Real;
        }
        let (a, b) = (s.vertex_normals(&p), grid.vertex_normals(&p));
        for (a, b) in a.iter().zip(&b) {
            assert_eq!(
                a.to_array().map(Real::to_bits),
                b.to_array().map(Real::to_bits)
            );
        }
    }

    #[test]
    fn a_mesh_keeps_its_polygons_and_seams() {
        let src = ClothMeshSource {
            file: "quad.obj".into(),
            vertices: Arc::new(vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(2.0, 0.0, 0.0),
            ]),
            faces: Arc::new(vec![vec![0, 3, 2, 1], vec![1, 2, 4]]),
            uvs: Arc::new(vec![
                [0.0, 0.0],
                [1.0, 0.0],
                [1.0, 1.0],
                [0.0, 1.0],
                [0.5, 0.0],
            ]),
            face_uvs: Arc::new(vec![vec![0, 3, 2, 1], vec![4, 2, 1]]),
            rotation: Vec3::ZERO,
            scale: 1.0,
            flip_normals: true,
        };
        let cloth = ClothParams {
            mesh: Some(src),
            ..Default::default()
        };
        let s = ClothSurface::new(&cloth);
        assert_eq!(s.face_start, [0, 4, 7]);
        assert_eq!(s.face(0), [0, 3, 2, 1]);
        assert_eq!(s.face_uv(1), Some(&[4, 2, 1][..]));
        assert!(!s.all_triangles() && s.has_uvs() && s.grid.is_none());
        // The file's winding (flip_normals is for the physics): (0, 3, 2, 1) in the xz plane
        // faces +Y, and so does (1, 2, 4).
        let mut p = Soa::zeros(5);
        for (k, v) in cloth.mesh.as_ref().unwrap().vertices.iter().enumerate() {
            p.set(k, *v);
        }
        for n in s.vertex_normals(&p) {
            assert_eq!(n, Vec3::Y);
        }
    }
}
