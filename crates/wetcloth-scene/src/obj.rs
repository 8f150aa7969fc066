//! Reading the triangle meshes of mesh colliders from Wavefront OBJ files.
//!
//! Only geometry is read: `v x y z` vertices and `f` faces (`f 1 2 3`, `f 1/1 2/2 3/3`,
//! `f 1//1 ...`, `f 1/1/1 ...`, negative indices counting back from the last vertex), polygons
//! split into a fan of triangles. Everything else (normals, texture coordinates, groups,
//! materials, comments) is skipped. Errors name the line.

use wetcloth::{Real, Vec3};

/// The largest mesh file read, bytes (256 MiB: millions of triangles).
pub const MAX_MESH_BYTES: u64 = 256 << 20;

/// The largest vertex coordinate read, in the file's units (1e9: a model a million kilometres
/// across in metres). Coordinates near 1e155 and beyond overflow the squared distances the
/// contact queries take, so a mesh must be refused long before them; no model needs more.
pub const MAX_COORDINATE: Real = wetcloth::collide::mesh::MAX_COORDINATE;

/// A mesh read from an OBJ file.
#[derive(Debug, Default, PartialEq)]
pub struct ObjMesh {
    /// Vertex positions, in the file's units.
    pub vertices: Vec<Vec3>,
    /// Triangles, indices from 0 into `vertices`.
    pub triangles: Vec<[u32; 3]>,
}

/// What is wrong with an OBJ text, and on which line (1-based; 0 for the whole file).
#[derive(Debug, PartialEq)]
pub struct ObjError {
    /// 1-based line, 0 when the problem is the whole file.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

/// The `v` line `content` whose words after `v` are `words`: three finite coordinates within
/// [`MAX_COORDINATE`] (`count` vertices read before it, for the message).
pub(crate) fn vertex<'a>(
    words: &mut impl Iterator<Item = &'a str>,
    content: &str,
    count: usize,
) -> Result<Vec3, String> {
    let mut c = [0.0; 3];
    for (i, slot) in c.iter_mut().enumerate() {
        let w = words
            .next()
            .ok_or_else(|| format!("a vertex needs 3 coordinates, found {i}: `{content}`"))?;
        *slot = w
            .parse::<Real>()
            .map_err(|_| format!("vertex coordinate `{w}` is not a number"))?;
    }
    let v = Vec3::from(c);
    if !v.is_finite() {
        return Err(format!(
            "vertex {} is not finite: [{}, {}, {}]",
            count + 1,
            v.x,
            v.y,
            v.z
        ));
    }
    if let Some(&x) = c.iter().find(|x| x.abs() > MAX_COORDINATE) {
        return Err(format!(
            "vertex {} has the coordinate {x:e}, out of range: allowed each in \
             [-{MAX_COORDINATE:e}, {MAX_COORDINATE:e}] (the file's units; `scale` converts \
             them to metres)",
            count + 1
        ));
    }
    Ok(v)
}

/// Parses OBJ text.
pub fn parse(text: &str) -> Result<ObjMesh, ObjError> {
    let mut m = ObjMesh::default();
    for (n, raw) in text.lines().enumerate() {
        let line = n + 1;
        let err = |message: String| ObjError { line, message };
        let content = raw.split('#').next().unwrap_or("").trim();
        let mut words = content.split_whitespace();
        match words.next() {
            Some("v") => {
                let v = vertex(&mut words, content, m.vertices.len()).map_err(err)?;
                m.vertices.push(v);
            }
            Some("f") => {
                let mut corners = Vec::new();
                for w in words {
                    let first = w.split('/').next().unwrap_or("");
                    let i: i64 = first
                        .parse()
                        .map_err(|_| err(format!("face index `{w}` is not an integer")))?;
                    let count = m.vertices.len() as i64;
                    // OBJ counts from 1; -1 is the last vertex read so far.
                    let index = if i > 0 { i - 1 } else { count + i };
                    if i == 0 || index < 0 || index >= count {
                        return Err(err(format!(
                            "face index {i} is out of range: {count} vertices are defined \
                             before this line (indices count from 1, or back from -1)"
                        )));
                    }
                    corners.push(index as u32);
                }
                if corners.len() < 3 {
                    return Err(err(format!(
                        "a face needs at least 3 vertices, found {}",
                        corners.len()
                    )));
                }
                for k in 1..corners.len() - 1 {
                    m.triangles.push([corners[0], corners[k], corners[k + 1]]);
                }
            }
            _ => {}
        }
    }
    if m.triangles.is_empty() {
        return Err(ObjError {
            line: 0,
            message: format!(
                "no faces (`f` lines): {} vertices and no triangles; a mesh collider needs at \
                 least one face",
                m.vertices.len()
            ),
        });
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_vertices_faces_and_fans() {
        let m = parse(
            "# a quad\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nvn 0 1 0\nf 1//1 2//1 3//1 4//1\n\
             f -4/1/1 -2 -1\n",
        )
        .unwrap();
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 2, 3]]);
    }

    #[test]
    fn errors_name_their_line() {
        let e = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap_err();
        assert_eq!(e.line, 4);
        assert!(e.message.contains("out of range"), "{}", e.message);
        let e = parse("v 0 0 0\nv nan 0 0\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.message.contains("not finite"), "{}", e.message);
        let e = parse("v 0 0 0\n").unwrap_err();
        assert_eq!(e.line, 0);
        assert!(e.message.contains("no faces"), "{}", e.message);
        let e = parse("v 0 0\n").unwrap_err();
        assert_eq!(e.line, 1);
    }
}
