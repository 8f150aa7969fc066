//! Reading a cloth of any shape from a Wavefront OBJ file (`[cloth] mesh`).
//!
//! Unlike a collider's mesh, a cloth keeps what its outputs give back: the faces as the file
//! has them (polygons stay polygons, the same corners in the same order) and the texture
//! coordinates with their seams (`vt`, and each corner's `f v/vt` index), so a point cache of
//! the run applies to the user's original object. Particle `k` is the `k`-th `v` line.
//! Normals, groups, materials and comments are skipped. Errors name the line.

use crate::obj::ObjError;
use wetcloth::model::MAX_MESH_PARTICLES;
use wetcloth::{Real, Vec3};

/// The largest cloth mesh file read, bytes (1 GiB).
pub const MAX_CLOTH_BYTES: u64 = 1 << 30;

/// A cloth mesh read from an OBJ file.
#[derive(Debug, Default, PartialEq)]
pub struct ClothObj {
    /// Vertex positions, in the file's units.
    pub vertices: Vec<Vec3>,
    /// Faces: each a polygon of vertex indices from 0.
    pub faces: Vec<Vec<u32>>,
    /// Texture coordinates.
    pub uvs: Vec<[Real; 2]>,
    /// Each face's texture-coordinate indices from 0, corner by corner; empty when no face has
    /// any (then every face has none), else one list per face.
    pub face_uvs: Vec<Vec<u32>>,
    /// The 1-based line of each face.
    pub face_lines: Vec<usize>,
}

/// Resolves an OBJ index (`1..=count`, or negative from the last) to one from 0.
fn index(word: &str, count: usize, what: &str) -> Result<u32, String> {
    let i: i64 = word
        .parse()
        .map_err(|_| format!("{what} index `{word}` is not an integer"))?;
    let count = count as i64;
    let k = if i > 0 { i - 1 } else { count + i };
    if i == 0 || k < 0 || k >= count {
        return Err(format!(
            "{what} index {i} is out of range: {count} {what}s are defined before this line \
             (indices count from 1, or back from -1)"
        ));
    }
    Ok(k as u32)
}

/// Parses the OBJ text of a cloth.
pub fn parse_cloth(text: &str) -> Result<ClothObj, ObjError> {
    let mut m = ClothObj::default();
    let mut with_uv = 0usize;
    for (n, raw) in text.lines().enumerate() {
        let line = n + 1;
        let err = |message: String| ObjError { line, message };
        let content = raw.split('#').next().unwrap_or("").trim();
        let mut words = content.split_whitespace();
        match words.next() {
            Some("v") => {
                let v = crate::obj::vertex(&mut words, content, m.vertices.len()).map_err(err)?;
                if m.vertices.len() == MAX_MESH_PARTICLES {
                    return Err(err(format!(
                        "more than {MAX_MESH_PARTICLES} vertices: a cloth may have at most \
                         {MAX_MESH_PARTICLES} particles"
                    )));
                }
                m.vertices.push(v);
            }
            Some("vt") => {
                let mut c = [0.0; 2];
                for (i, slot) in c.iter_mut().enumerate() {
                    let w = words.next().ok_or_else(|| {
                        err(format!(
                            "a texture coordinate needs 2 numbers, found {i}: `{content}`"
                        ))
                    })?;
                    *slot = w
                        .parse::<Real>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| {
                            err(format!("texture coordinate `{w}` is not a finite number"))
                        })?;
                }
                m.uvs.push(c);
            }
            Some("f") => {
                let mut corners = Vec::new();
                let mut uvs = Vec::new();
                for w in words {
                    let mut parts = w.split('/');
                    let v = parts.next().unwrap_or("");
                    corners.push(index(v, m.vertices.len(), "vertex").map_err(err)?);
                    if let Some(t) = parts.next().filter(|t| !t.is_empty()) {
                        uvs.push(index(t, m.uvs.len(), "texture coordinate").map_err(err)?);
                    }
                }
                if corners.len() < 3 {
                    return Err(err(format!(
                        "a face needs at least 3 vertices, found {}",
                        corners.len()
                    )));
                }
                if !uvs.is_empty() && uvs.len() != corners.len() {
                    return Err(err(
                        "some corners of this face have a texture coordinate and some do not"
                            .into(),
                    ));
                }
                if !uvs.is_empty() {
                    with_uv += 1;
                }
                m.faces.push(corners);
                m.face_uvs.push(uvs);
                m.face_lines.push(line);
            }
            _ => {}
        }
    }
    if m.faces.is_empty() {
        return Err(ObjError {
            line: 0,
            message: format!(
                "no faces (`f` lines): {} vertices and no triangles; a cloth mesh needs at least \
                 one face",
                m.vertices.len()
            ),
        });
    }
    if with_uv == 0 {
        m.face_uvs.clear();
    } else if with_uv != m.faces.len() {
        let k = m.face_uvs.iter().position(Vec::is_empty).unwrap_or(0);
        return Err(ObjError {
            line: m.face_lines[k],
            message: "this face has no texture coordinates while others have: give every face \
                      `v/vt` corners, or none"
                .into(),
        });
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_polygons_and_texture_seams() {
        let m = parse_cloth(
            "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 2 0 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
             vt 0.5 0\nf 1/1 4/4 3/3 2/2\nf 2/5 3/3 5/2\n",
        )
        .unwrap();
        assert_eq!(m.faces, vec![vec![0, 3, 2, 1], vec![1, 2, 4]]);
        assert_eq!(m.face_uvs, vec![vec![0, 3, 2, 1], vec![4, 2, 1]]);
        assert_eq!(m.face_lines, vec![11, 12]);
    }

    #[test]
    fn errors_name_their_line() {
        let e = parse_cloth("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap_err();
        assert_eq!(e.line, 4);
        let e =
            parse_cloth("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf 1 2 3\n").unwrap_err();
        assert_eq!(e.line, 6);
        assert_eq!(parse_cloth("v 0 0 0\n").unwrap_err().line, 0);
    }
}
