//! Wavefront OBJ frames.

use std::io::{self, Write};
use wetcloth::{ClothSurface, Soa, Vec3};

/// Writes one frame of the cloth as an OBJ mesh: a comment, object `cloth`, a `v x y z` line
/// per particle (m, Y up; vertex `k` is particle `k`), the texture coordinates, a `vn x y z`
/// line per particle, and an `f` line per face of `surface` (1-based):
///
/// - the built-in grid: a `vt u v` line per particle and `f a/a/a b/b/b c/c/c` per triangle of
///   [`wetcloth::Grid::triangles`] (vertex, texture coordinate and normal share the index);
/// - a mesh cloth: the file's `vt` lines and its faces as the file has them (the same corners
///   in the same order, polygons kept), `f v/vt/vn` with the file's texture-coordinate
///   indices (seams kept), or `f v//vn` when the file's faces have none.
///
/// `normals` are one per particle (e.g. [`ClothSurface::vertex_normals`]). Numbers are written
/// in full precision. The writer is not flushed; wrap a file in a [`io::BufWriter`].
///
/// # Errors
///
/// The writer's I/O errors, or [`io::ErrorKind::InvalidInput`] when the array lengths do not
/// match the surface.
pub fn write_obj(
    mut w: impl Write,
    surface: &ClothSurface,
    positions: &Soa,
    normals: &[Vec3],
) -> io::Result<()> {
    let n = surface.vertices;
    if positions.len() != n || normals.len() != n {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "OBJ export: {n} particles but {} positions and {} normals",
                positions.len(),
                normals.len(),
            ),
        ));
    }
    match surface.grid {
        Some([nx, nz]) => writeln!(w, "# wetcloth cloth mesh: {nx} x {nz} particles")?,
        None => writeln!(
            w,
            "# wetcloth cloth mesh: {n} particles, {} faces",
            surface.face_count()
        )?,
    }
    writeln!(w, "o cloth")?;
    for k in 0..n {
        let p = positions.get(k);
        writeln!(w, "v {:?} {:?} {:?}", p.x, p.y, p.z)?;
    }
    for [u, v] in &surface.uvs {
        writeln!(w, "vt {u:?} {v:?}")?;
    }
    for nrm in normals {
        writeln!(w, "vn {:?} {:?} {:?}", nrm.x, nrm.y, nrm.z)?;
    }
    let mut line = String::new();
    for f in 0..surface.face_count() {
        use std::fmt::Write as _;
        line.clear();
        line.push('f');
        let corners = surface.face(f);
        match (surface.face_uv(f), surface.grid) {
            (Some(t), _) => {
                for (&v, &t) in corners.iter().zip(t) {
                    let _ = write!(line, " {}/{}/{}", v + 1, t + 1, v + 1);
                }
            }
            (None, Some(_)) => {
                for &v in corners {
                    let v = v + 1;
                    let _ = write!(line, " {v}/{v}/{v}");
                }
            }
            (None, None) => {
                for &v in corners {
                    let _ = write!(line, " {}//{}", v + 1, v + 1);
                }
            }
        }
        line.push('\n');
        w.write_all(line.as_bytes())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use wetcloth::{ClothMeshSource, ClothParams, Grid, Real};

    #[test]
    fn a_two_by_two_cloth_is_four_vertices_and_two_faces_in_full_precision() {
        let cloth = ClothParams {
            resolution: [2, 2],
            size: [1.0, 1.0],
            ..Default::default()
        };
        let grid = Grid::new(&cloth);
        let mut p = grid.rest_positions(Vec3::new(0.0, 0.1 + 0.2, 0.0));
        p.x[3] = 1.0 / 3.0;
        let mut out = Vec::new();
        let surface = ClothSurface::new(&cloth);
        write_obj(&mut out, &surface, &p, &grid.vertex_normals(&p)).unwrap();
        let text = String::from_utf8(out).unwrap();
        let count = |tag: &str| text.lines().filter(|l| l.starts_with(tag)).count();
        assert_eq!(
            (count("v "), count("vt "), count("vn "), count("f ")),
            (4, 4, 4, 2)
        );
        assert!(text.contains("v -0.5 0.30000000000000004 -0.5\n"));
        assert!(text.contains("v 0.3333333333333333 0.30000000000000004 0.5\n"));
        assert!(text.contains("vt 1.0 1.0\n"));
        assert!(text.contains("f 1/1/1 4/4/4 2/2/2\n"));
        let short = write_obj(&mut Vec::new(), &surface, &p, &[]);
        assert_eq!(short.unwrap_err().kind(), io::ErrorKind::InvalidInput);
    }

    /// A quad and a triangle sharing an edge, with a texture seam along it.
    pub(crate) fn quad_and_triangle(face_uvs: bool) -> ClothParams {
        let v = |x: Real, z: Real| Vec3::new(x, 0.0, z);
        ClothParams {
            mesh: Some(ClothMeshSource {
                file: "towel.obj".into(),
                vertices: Arc::new(vec![
                    v(0.0, 0.0),
                    v(1.0, 0.0),
                    v(1.0, 1.0),
                    v(0.0, 1.0),
                    v(2.0, 0.0),
                ]),
                faces: Arc::new(vec![vec![0, 3, 2, 1], vec![1, 2, 4]]),
                uvs: Arc::new(vec![
                    [0.0, 0.0],
                    [0.5, 0.0],
                    [0.5, 1.0],
                    [0.0, 1.0],
                    [0.6, 1.0],
                    [0.6, 0.0],
                    [1.0, 0.0],
                ]),
                face_uvs: Arc::new(if face_uvs {
                    vec![vec![0, 3, 2, 1], vec![5, 4, 6]]
                } else {
                    Vec::new()
                }),
                rotation: Vec3::ZERO,
                scale: 1.0,
                flip_normals: false,
            }),
            ..Default::default()
        }
    }

    #[test]
    fn a_mesh_cloth_keeps_the_files_polygons_and_seams() {
        let cloth = quad_and_triangle(true);
        let surface = ClothSurface::new(&cloth);
        let mut p = Soa::zeros(5);
        for (k, v) in cloth.mesh.as_ref().unwrap().vertices.iter().enumerate() {
            p.set(k, *v);
        }
        let mut out = Vec::new();
        write_obj(&mut out, &surface, &p, &surface.vertex_normals(&p)).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.starts_with("# wetcloth cloth mesh: 5 particles, 2 faces\no cloth\n"));
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.iter().filter(|l| l.starts_with("vt ")).count(), 7);
        assert_eq!(lines.iter().filter(|l| l.starts_with("vn ")).count(), 5);
        assert_eq!(
            lines[lines.len() - 2..],
            ["f 1/1/1 4/4/4 3/3/3 2/2/2", "f 2/6/2 3/5/3 5/7/5"]
        );
        let plain = ClothSurface::new(&quad_and_triangle(false));
        let mut out = Vec::new();
        write_obj(&mut out, &plain, &p, &plain.vertex_normals(&p)).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(
            text.ends_with("f 1//1 4//4 3//3 2//2\nf 2//2 3//3 5//5\n"),
            "{text}"
        );
    }
}
