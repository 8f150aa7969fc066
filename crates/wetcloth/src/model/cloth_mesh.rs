//! A cloth of any shape: the topology and rest geometry of a triangle mesh.
//!
//! Particle `k` is the mesh's vertex `k`. From the triangles the mesh derives, once, everything
//! a step reads: the unique edges, the pair of vertices across each interior edge, the boundary
//! loops (a towel has one, a tube two, a shirt several), each particle's lumped area (a third of
//! every triangle around it) and the triangles around each vertex in a fixed order (so sums over
//! them do not depend on threads). The built-in grid keeps its own fast path
//! ([`super::Grid`]); every cloth read from a file takes this one.

use crate::math::{Real, Soa, Vec3};
use std::collections::HashMap;

/// The most particles a mesh cloth may have (4 194 304 = 2^22).
pub const MAX_MESH_PARTICLES: usize = 1 << 22;

/// Why a triangle mesh cannot be a cloth. Triangles are numbered from 0 in the order given;
/// the scene reader turns them into the file's lines.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ClothMeshError {
    /// No triangles.
    #[error("the cloth mesh has no faces (it needs at least one triangle)")]
    NoFaces,
    /// More vertices than [`MAX_MESH_PARTICLES`].
    #[error("the cloth mesh has {count} vertices; a cloth may have at most 4194304")]
    TooManyVertices {
        /// Vertex count.
        count: usize,
    },
    /// A NaN or infinite coordinate.
    #[error("vertex {vertex} (counting from 0) is not finite")]
    NonFinite {
        /// Vertex index.
        vertex: usize,
    },
    /// A corner naming a vertex that does not exist.
    #[error("a face uses vertex {index} (counting from 0), but the mesh has {count} vertices")]
    IndexOutOfRange {
        /// The triangle.
        triangle: usize,
        /// The index it names.
        index: u32,
        /// Number of vertices.
        count: usize,
    },
    /// A triangle of zero area (two corners the same, or all three on a line).
    #[error("a face has zero area (repeated or collinear corners)")]
    Degenerate {
        /// The triangle.
        triangle: usize,
    },
    /// An edge shared by more than two triangles.
    #[error(
        "the edge between vertices {a} and {b} (counting from 0) is shared by more than two \
         faces: a cloth must be a manifold surface"
    )]
    NonManifold {
        /// The third triangle on the edge.
        triangle: usize,
        /// One end.
        a: u32,
        /// The other end.
        b: u32,
    },
    /// Two triangles that run along their shared edge in the same direction.
    #[error(
        "a face is wound against its neighbour across the edge between vertices {a} and {b} \
         (counting from 0): the faces of a piece must be wound consistently (their normals \
         all on one side)"
    )]
    InconsistentWinding {
        /// The triangle found second.
        triangle: usize,
        /// One end of the shared edge.
        a: u32,
        /// The other end.
        b: u32,
    },
    /// A vertex that no triangle uses (it would be a particle with no mass and no springs).
    #[error("vertex {vertex} (counting from 0) is used by no face")]
    UnusedVertex {
        /// The vertex.
        vertex: usize,
    },
}

impl ClothMeshError {
    /// The triangle the error is about, if any (0-based, in the order given).
    pub fn triangle(&self) -> Option<usize> {
        match *self {
            Self::IndexOutOfRange { triangle, .. }
            | Self::Degenerate { triangle }
            | Self::NonManifold { triangle, .. }
            | Self::InconsistentWinding { triangle, .. } => Some(triangle),
            _ => None,
        }
    }
}

/// The topology and rest geometry of a cloth mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct ClothMesh {
    /// Rest positions, m (scene coordinates at t = 0).
    pub rest: Vec<Vec3>,
    /// Triangles, wound so that the right-hand normal points away from the surface the cloth
    /// lies on (the air's side is below it).
    pub triangles: Vec<[u32; 3]>,
    /// Unique edges `[a, b]` with `a < b`, sorted.
    pub edges: Vec<[u32; 2]>,
    /// For every interior edge (in `edges` order), the two vertices opposite it.
    pub across: Vec<[u32; 2]>,
    /// For every interior edge of `across`, its index in `edges`.
    pub across_edge: Vec<u32>,
    /// The triangles on each side of every edge (in `edges` order): `[t, u32::MAX]` on the
    /// boundary.
    pub edge_faces: Vec<[u32; 2]>,
    /// The boundary loops, each in order along the boundary (the mesh on its left walking
    /// with the triangles' winding), each vertex once; sorted by their first vertex.
    pub boundary: Vec<Vec<u32>>,
    /// Lumped area of each particle, m^2: a third of each triangle around it.
    pub area: Vec<Real>,
    /// Rest area of each triangle, m^2.
    pub triangle_area: Vec<Real>,
    /// The triangles around vertex `k`: `vertex_triangles[vertex_start[k]..vertex_start[k+1]]`,
    /// in increasing order.
    pub vertex_start: Vec<u32>,
    /// See [`ClothMesh::vertex_start`].
    pub vertex_triangles: Vec<u32>,
}

impl ClothMesh {
    /// The mesh of `rest` positions (m) and `triangles` (indices from 0), refusing what cannot
    /// be a cloth (see [`ClothMeshError`]).
    pub fn new(rest: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Self, ClothMeshError> {
        let n = rest.len();
        if triangles.is_empty() {
            return Err(ClothMeshError::NoFaces);
        }
        if n > MAX_MESH_PARTICLES {
            return Err(ClothMeshError::TooManyVertices { count: n });
        }
        if let Some(vertex) = rest.iter().position(|v| !v.is_finite()) {
            return Err(ClothMeshError::NonFinite { vertex });
        }
        let mut triangle_area = Vec::with_capacity(triangles.len());
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= n) {
                return Err(ClothMeshError::IndexOutOfRange {
                    triangle: t,
                    index,
                    count: n,
                });
            }
            let [a, b, c] = tri.map(|i| rest[i as usize]);
            let cross = (b - a).cross(c - a);
            let scale = (b - a).length_squared().max((c - a).length_squared());
            let area = 0.5 * cross.length();
            // Zero area, or so thin that its normal is round-off.
            if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] || area <= 1e-12 * scale {
                return Err(ClothMeshError::Degenerate { triangle: t });
            }
            triangle_area.push(area);
        }
        // Directed half-edges: each (from, to) at most once; its twin (to, from) at most once.
        let mut half: HashMap<(u32, u32), u32> = HashMap::with_capacity(3 * triangles.len());
        let mut undirected: HashMap<(u32, u32), u8> = HashMap::with_capacity(2 * triangles.len());
        for (t, tri) in triangles.iter().enumerate() {
            for e in 0..3 {
                let (a, b) = (tri[e], tri[(e + 1) % 3]);
                let key = (a.min(b), a.max(b));
                let count = undirected.entry(key).or_insert(0);
                *count += 1;
                if *count > 2 {
                    return Err(ClothMeshError::NonManifold {
                        triangle: t,
                        a: key.0,
                        b: key.1,
                    });
                }
                if half.insert((a, b), t as u32).is_some() {
                    return Err(ClothMeshError::InconsistentWinding {
                        triangle: t,
                        a: key.0,
                        b: key.1,
                    });
                }
            }
        }
        let mut used = vec![false; n];
        for tri in &triangles {
            for &i in tri {
                used[i as usize] = true;
            }
        }
        if let Some(vertex) = used.iter().position(|&u| !u) {
            return Err(ClothMeshError::UnusedVertex { vertex });
        }
        let mut edges: Vec<[u32; 2]> = undirected.keys().map(|&(a, b)| [a, b]).collect();
        edges.sort_unstable();
        // The vertex opposite half-edge (a, b) in its triangle.
        let opposite = |a: u32, b: u32| -> Option<u32> {
            half.get(&(a, b)).map(|&t| {
                let tri = triangles[t as usize];
                tri.into_iter().find(|&v| v != a && v != b).unwrap_or(a)
            })
        };
        let edge_faces: Vec<[u32; 2]> = edges
            .iter()
            .map(|&[a, b]| match (half.get(&(a, b)), half.get(&(b, a))) {
                (Some(&t), Some(&u)) => [t.min(u), t.max(u)],
                (Some(&t), None) | (None, Some(&t)) => [t, u32::MAX],
                (None, None) => [u32::MAX, u32::MAX],
            })
            .collect();
        let mut across = Vec::new();
        let mut across_edge = Vec::new();
        for (e, &[a, b]) in edges.iter().enumerate() {
            if let (Some(c), Some(d)) = (opposite(a, b), opposite(b, a)) {
                across.push([c, d]);
                across_edge.push(e as u32);
            }
        }
        // Boundary: half-edges without a twin, chained head to tail.
        let mut next: HashMap<u32, u32> = HashMap::new();
        for &(a, b) in half.keys() {
            if !half.contains_key(&(b, a)) {
                next.insert(a, b);
            }
        }
        let mut starts: Vec<u32> = next.keys().copied().collect();
        starts.sort_unstable();
        let mut seen = vec![false; n];
        let mut boundary = Vec::new();
        for s in starts {
            if seen[s as usize] {
                continue;
            }
            let mut lp = vec![s];
            seen[s as usize] = true;
            let mut v = s;
            while let Some(&w) = next.get(&v) {
                if w == s || seen[w as usize] {
                    break;
                }
                seen[w as usize] = true;
                lp.push(w);
                v = w;
            }
            boundary.push(lp);
        }
        let mut area = vec![0.0; n];
        for (tri, &a) in triangles.iter().zip(&triangle_area) {
            for &i in tri {
                area[i as usize] += a / 3.0;
            }
        }
        let mut vertex_start = vec![0u32; n + 1];
        for tri in &triangles {
            for &i in tri {
                vertex_start[i as usize + 1] += 1;
            }
        }
        for k in 0..n {
            vertex_start[k + 1] += vertex_start[k];
        }
        let mut fill = vertex_start.clone();
        let mut vertex_triangles = vec![0u32; 3 * triangles.len()];
        for (t, tri) in triangles.iter().enumerate() {
            for &i in tri {
                vertex_triangles[fill[i as usize] as usize] = t as u32;
                fill[i as usize] += 1;
            }
        }
        Ok(Self {
            rest,
            triangles,
            edges,
            across,
            across_edge,
            edge_faces,
            boundary,
            area,
            triangle_area,
            vertex_start,
            vertex_triangles,
        })
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.rest.len()
    }

    /// True for a mesh without particles (never, for a validated one).
    pub fn is_empty(&self) -> bool {
        self.rest.is_empty()
    }

    /// Rest area of the whole cloth, m^2.
    pub fn total_area(&self) -> Real {
        self.triangle_area.iter().sum()
    }

    /// Rest positions as an SoA.
    pub fn rest_positions(&self) -> Soa {
        Soa::from_vec3(&self.rest)
    }

    /// The triangles around vertex `k`.
    #[inline]
    pub fn triangles_of(&self, k: usize) -> &[u32] {
        &self.vertex_triangles[self.vertex_start[k] as usize..self.vertex_start[k + 1] as usize]
    }

    /// Twice the area-weighted normal of triangle `t` at positions `x` (its cross product).
    #[inline]
    pub fn triangle_cross(&self, x: &Soa, t: usize) -> Vec3 {
        let [a, b, c] = self.triangles[t].map(|i| x.get(i as usize));
        (b - a).cross(c - a)
    }

    /// Unit normal of particle `k` at positions `x`: the normalised sum of the cross products of
    /// the triangles around it (area-weighted), summed in triangle order; zero if they cancel.
    #[inline]
    pub fn normal(&self, x: &Soa, k: usize) -> Vec3 {
        let mut n = Vec3::ZERO;
        for &t in self.triangles_of(k) {
            n += self.triangle_cross(x, t as usize);
        }
        n.normalize_or_zero()
    }

    /// The boundary particles, loop after loop (the leaks' border).
    pub fn border(&self) -> Vec<u32> {
        self.boundary.iter().flatten().copied().collect()
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.rest.capacity() * 24
            + self.triangles.capacity() * 12
            + (self.edges.capacity() + self.across.capacity() + self.edge_faces.capacity()) * 8
            + (self.across_edge.capacity()
                + self.vertex_start.capacity()
                + self.vertex_triangles.capacity())
                * 4
            + (self.area.capacity() + self.triangle_area.capacity()) * 8
            + self
                .boundary
                .iter()
                .map(|b| b.capacity() * 4)
                .sum::<usize>()
    }
}

/// A flat square of `n x n` particles, `size` m a side in the xz plane, two triangles a cell
/// (the diagonal from `(i, j)` to `(i + 1, j + 1)`): the tests' sheet.
#[cfg(test)]
pub(crate) fn test_square(n: usize, size: Real) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let h = size / (n - 1) as Real;
    let mut v = Vec::new();
    for j in 0..n {
        for i in 0..n {
            v.push(Vec3::new(i as Real * h, 0.0, j as Real * h));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_has_one_boundary_loop_and_lumped_areas_summing_to_its_area() {
        let (v, t) = test_square(5, 0.4);
        let m = ClothMesh::new(v, t).unwrap();
        assert_eq!(m.boundary.len(), 1);
        assert_eq!(m.boundary[0].len(), 16);
        let total: Real = m.area.iter().sum();
        assert!((total - 0.16).abs() < 1e-15, "{total}");
        // 4x4 cells: 40 grid edges + 16 diagonals; interior edges = all but the 16 on the border.
        assert_eq!(m.edges.len(), 56);
        assert_eq!(m.across.len(), 40);
        // An interior particle's normal points +Y for the grid's winding.
        let x = m.rest_positions();
        assert!((m.normal(&x, 12) - Vec3::Y).length() < 1e-15);
    }

    #[test]
    fn a_tube_has_two_boundary_loops() {
        // A ring of 8 columns, 3 rows.
        let (cols, rows) = (8u32, 3u32);
        let mut v = Vec::new();
        for j in 0..rows {
            for i in 0..cols {
                let a = i as Real / cols as Real * std::f64::consts::TAU;
                v.push(Vec3::new(a.cos(), j as Real * 0.5, a.sin()));
            }
        }
        let mut t = Vec::new();
        for j in 0..rows - 1 {
            for i in 0..cols {
                let a = j * cols + i;
                let b = j * cols + (i + 1) % cols;
                t.push([a, b + cols, b]);
                t.push([a, a + cols, b + cols]);
            }
        }
        let m = ClothMesh::new(v, t).unwrap();
        assert_eq!(m.boundary.len(), 2);
        assert!(m.boundary.iter().all(|b| b.len() == 8));
    }

    #[test]
    fn bad_meshes_are_refused_with_the_face() {
        let (v, mut t) = test_square(3, 1.0);
        t[3] = [t[3][0], t[3][2], t[3][1]];
        assert!(matches!(
            ClothMesh::new(v.clone(), t),
            Err(ClothMeshError::InconsistentWinding { .. })
        ));
        let (_, t) = test_square(3, 1.0);
        let mut t2 = t.clone();
        t2.push([0, 1, 4]);
        assert!(matches!(
            ClothMesh::new(v.clone(), t2),
            Err(ClothMeshError::NonManifold { .. } | ClothMeshError::InconsistentWinding { .. })
        ));
        let mut v2 = v.clone();
        v2.push(Vec3::ONE);
        assert_eq!(
            ClothMesh::new(v2, t.clone()),
            Err(ClothMeshError::UnusedVertex { vertex: 9 })
        );
        let mut t3 = t.clone();
        t3[2] = [0, 1, 2];
        assert_eq!(
            ClothMesh::new(v.clone(), t3).unwrap_err().triangle(),
            Some(2)
        );
        let mut t4 = t;
        t4[5][1] = 40;
        assert!(matches!(
            ClothMesh::new(v, t4),
            Err(ClothMeshError::IndexOutOfRange {
                triangle: 5,
                index: 40,
                ..
            })
        ));
    }
}
