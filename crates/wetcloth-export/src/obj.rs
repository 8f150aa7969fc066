//! Wavefront OBJ frames.

use std::io::{self, Write};
use wetcloth::{Grid, Real, Soa, Vec3};

/// Writes one frame of the cloth as an OBJ mesh: object `cloth`, then a `v x y z` line per
/// particle (m, Y up), a `vt u v` and a `vn x y z` line per particle, and an `f a/a/a b/b/b
/// c/c/c` line per triangle of [`Grid::triangles`] (1-based; vertex, texture coordinate and
/// normal share the index). Vertex `k` is particle `k`.
///
/// `positions` are the particle positions, `normals` one per particle (e.g.
/// [`Grid::vertex_normals`]) and `uvs` one per particle (e.g. [`Grid::uvs`]). Numbers are written
/// in full precision. The writer is not flushed; wrap a file in a [`io::BufWriter`].
///
/// # Errors
///
/// The writer's I/O errors, or [`io::ErrorKind::InvalidInput`] when the array lengths do not
/// match the grid.
pub fn write_obj(
    mut w: impl Write,
    grid: &Grid,
    positions: &Soa,
    normals: &[Vec3],
    uvs: &[[Real; 2]],
) -> io::Result<()> {
    let n = grid.len();
    if positions.len() != n || normals.len() != n || uvs.len() != n {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "OBJ export: {n} particles but {} positions, {} normals, {} uvs",
                positions.len(),
                normals.len(),
                uvs.len()
            ),
        ));
    }
    writeln!(
        w,
        "# wetcloth cloth mesh: {} x {} particles",
        grid.nx, grid.nz
    )?;
    writeln!(w, "o cloth")?;
    for k in 0..n {
        let p = positions.get(k);
        writeln!(w, "v {:?} {:?} {:?}", p.x, p.y, p.z)?;
    }
    for [u, v] in uvs {
        writeln!(w, "vt {u:?} {v:?}")?;
    }
    for nrm in normals {
        writeln!(w, "vn {:?} {:?} {:?}", nrm.x, nrm.y, nrm.z)?;
    }
    for [a, b, c] in grid.triangles() {
        let (a, b, c) = (a + 1, b + 1, c + 1);
        writeln!(w, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use wetcloth::ClothParams;

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
        write_obj(&mut out, &grid, &p, &grid.vertex_normals(&p), &grid.uvs()).unwrap();
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
        let short = write_obj(&mut Vec::new(), &grid, &p, &[], &grid.uvs());
        assert_eq!(short.unwrap_err().kind(), io::ErrorKind::InvalidInput);
    }
}
