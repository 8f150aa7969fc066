//! Mesh colliders in a run folder: `run.json` names each mesh by a copy of the model beside it
//! (`meshes/<digest>.obj`, [`wetcloth::collide::Mesh::copy_name`]) and its content digest,
//! instead of holding its triangles, so that `run.json` stays a few kilobytes whatever the
//! mesh (it is rewritten after every frame). [`write_mesh_copies`] writes the copies when a
//! run starts; [`read_run_json`] and [`read_colliders`] read `run.json` back with every mesh
//! rebuilt from its copy, the copy checked against the digest.

use std::fmt::Write as _;
use std::io::{self, BufRead, BufReader, Write};
use std::path::Path;

use wetcloth::collide::mesh::{copy_name, mesh_digest};
use wetcloth::collide::{Key, Mesh, PointMotion, PointSource};
use wetcloth::{ClothMeshSource, Collider, Real, Shape, Vec3};

use crate::RunInfo;
use crate::run_json::ClothMeshInfo;

/// FNV-1a (64 bit) of `bytes`.
fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The copy of a mesh cloth kept in the run folder: its name there
/// (`meshes/cloth-<digest>.obj`), the FNV-1a digest of its bytes, and the bytes. The copy is
/// the mesh as read, in the file's units: a `v` line per vertex, a `vt` line per texture
/// coordinate and an `f` line per face (`f v/vt` corners where the file has them), every
/// number the shortest decimal that reads back to the same value, so a cloth read from the copy
/// is the cloth the run read.
pub fn cloth_copy(m: &ClothMeshSource) -> (String, u64, Vec<u8>) {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# wetcloth cloth mesh: {} vertices, {} faces, {} texture coordinates, in the file's units",
        m.vertices.len(),
        m.faces.len(),
        m.uvs.len()
    );
    for v in m.vertices.iter() {
        let _ = writeln!(t, "v {:?} {:?} {:?}", v.x, v.y, v.z);
    }
    for [u, v] in m.uvs.iter() {
        let _ = writeln!(t, "vt {u:?} {v:?}");
    }
    for (k, f) in m.faces.iter().enumerate() {
        t.push('f');
        match m.face_uvs.get(k).filter(|u| u.len() == f.len()) {
            Some(uv) => {
                for (a, b) in f.iter().zip(uv) {
                    let _ = write!(t, " {}/{}", a + 1, b + 1);
                }
            }
            None => {
                for a in f {
                    let _ = write!(t, " {}", a + 1);
                }
            }
        }
        t.push('\n');
    }
    let digest = fnv1a(t.as_bytes());
    (
        format!("meshes/cloth-{digest:016x}.obj"),
        digest,
        t.into_bytes(),
    )
}

/// Writes the copy of a mesh cloth ([`cloth_copy`]) into `dir` unless it is there already.
pub fn write_cloth_copy(dir: &Path, m: &ClothMeshSource) -> io::Result<()> {
    let (name, _, bytes) = cloth_copy(m);
    let path = dir.join(name);
    if path.is_file() {
        return Ok(());
    }
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)?;
    }
    crate::write_atomically(&path, |w| w.write_all(&bytes))
}

/// The mesh cloth `run.json` describes (`mesh`), read from its copy in the run folder `dir`
/// and checked against its digest and counts. `Err` says what is wrong, naming the file and
/// line.
pub fn read_cloth_copy(dir: &Path, info: &ClothMeshInfo) -> Result<ClothMeshSource, String> {
    let expected = u64::from_str_radix(&info.digest, 16)
        .ok()
        .filter(|_| info.digest.len() == 16)
        .ok_or_else(|| format!("mesh.digest = {:?} is not 16 hex digits", info.digest))?;
    let name = format!("meshes/cloth-{expected:016x}.obj");
    if info.copy != name {
        return Err(format!(
            "mesh.copy = {:?} is not the copy of a cloth of digest {} ({name})",
            info.copy, info.digest
        ));
    }
    let path = dir.join(&name);
    if std::fs::metadata(&path).is_ok_and(|m| !m.is_file()) {
        return Err(format!(
            "{}: the cloth's copy is not a regular file",
            path.display()
        ));
    }
    let bytes = std::fs::read(&path)
        .map_err(|e| format!("{}: cannot read the cloth's copy: {e}", path.display()))?;
    let found = fnv1a(&bytes);
    if found != expected {
        return Err(format!(
            "{}: the cloth's copy was changed (its digest is {found:016x}, run.json records {})",
            path.display(),
            info.digest
        ));
    }
    let text = String::from_utf8(bytes)
        .map_err(|_| format!("{}: the cloth's copy is not UTF-8 text", path.display()))?;
    let (mut vertices, mut uvs, mut faces, mut face_uvs) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (n, line) in text.lines().enumerate() {
        let bad = || {
            format!(
                "{}:{}: not a wetcloth cloth copy line: {line:?}",
                path.display(),
                n + 1
            )
        };
        let mut words = line.split_ascii_whitespace();
        match words.next() {
            Some("v") => {
                let mut c = [0.0; 3];
                for x in &mut c {
                    *x = words.next().and_then(|w| w.parse().ok()).ok_or_else(bad)?;
                }
                vertices.push(Vec3::from(c));
            }
            Some("vt") => {
                let mut c: [Real; 2] = [0.0; 2];
                for x in &mut c {
                    *x = words.next().and_then(|w| w.parse().ok()).ok_or_else(bad)?;
                }
                uvs.push(c);
            }
            Some("f") => {
                let (mut f, mut fu) = (Vec::new(), Vec::new());
                for w in words.by_ref() {
                    let mut parts = w.split('/');
                    let index = |p: Option<&str>, count: usize| {
                        p.and_then(|p| p.parse::<u32>().ok())
                            .filter(|&k| k >= 1 && (k as usize) <= count)
                            .map(|k| k - 1)
                    };
                    f.push(index(parts.next(), vertices.len()).ok_or_else(bad)?);
                    if let Some(t) = parts.next() {
                        fu.push(index(Some(t), uvs.len()).ok_or_else(bad)?);
                    }
                }
                if f.len() < 3 || !(fu.is_empty() || fu.len() == f.len()) {
                    return Err(bad());
                }
                faces.push(f);
                face_uvs.push(fu);
            }
            Some(w) if w.starts_with('#') => continue,
            None => continue,
            Some(_) => return Err(bad()),
        }
        if words.next().is_some() {
            return Err(bad());
        }
    }
    let with_uv = face_uvs.iter().filter(|u| !u.is_empty()).count();
    if with_uv == 0 {
        face_uvs.clear();
    } else if with_uv != faces.len() {
        return Err(format!(
            "{}: some faces have texture coordinates and some do not",
            path.display()
        ));
    }
    if (vertices.len(), faces.len(), uvs.len())
        != (info.vertices, info.faces, info.texture_coordinates)
    {
        return Err(format!(
            "{}: {} vertices, {} faces and {} texture coordinates where run.json's mesh says \
             {}, {} and {}",
            path.display(),
            vertices.len(),
            faces.len(),
            uvs.len(),
            info.vertices,
            info.faces,
            info.texture_coordinates
        ));
    }
    Ok(ClothMeshSource {
        file: info.file.clone(),
        vertices: std::sync::Arc::new(vertices),
        faces: std::sync::Arc::new(faces),
        uvs: std::sync::Arc::new(uvs),
        face_uvs: std::sync::Arc::new(face_uvs),
        rotation: Vec3::from(info.rotation),
        scale: info.scale,
        flip_normals: info.flip_normals,
    })
}

/// Writes `dir/meshes/<digest>.obj` for every mesh collider of `colliders` that has no copy
/// there yet: its vertices (`v x y z`, every coordinate as the shortest decimal that reads
/// back to the same number) and triangles (`f a b c`, from 1), exactly the model the run read.
pub fn write_mesh_copies(dir: &Path, colliders: &[Collider]) -> io::Result<()> {
    for c in colliders {
        if let Shape::Mesh(m) = &c.shape {
            let path = dir.join(m.copy_name());
            if path.is_file() {
                continue;
            }
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent)?;
            }
            crate::write_atomically(&path, |w| write_model(w, m))?;
        }
    }
    for c in colliders {
        if let Shape::Mesh(m) = &c.shape
            && let (Some(name), Some(motion)) = (m.points_copy_name(), m.motion())
        {
            let path = dir.join(name);
            if !path.is_file() {
                crate::write_atomically(&path, |w| write_points(w, &motion.frames))?;
            }
        }
    }
    Ok(())
}

/// A PC2 cache of `frames` (each the same count of points): the header (`POINTCACHE2\0`,
/// version 1, the point count, start frame 0, sampling 1, the frame count), then every
/// frame's points as little-endian single-precision triples.
fn write_points(mut w: impl Write, frames: &[Vec<Vec3>]) -> io::Result<()> {
    let points = frames.first().map_or(0, Vec::len);
    w.write_all(b"POINTCACHE2\0")?;
    for v in [1i32, points as i32] {
        w.write_all(&v.to_le_bytes())?;
    }
    for v in [0f32, 1f32] {
        w.write_all(&v.to_le_bytes())?;
    }
    w.write_all(&(frames.len() as i32).to_le_bytes())?;
    let mut buf = Vec::with_capacity(points * 12);
    for f in frames {
        buf.clear();
        for p in f {
            for c in p.to_array() {
                buf.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        w.write_all(&buf)?;
    }
    w.flush()
}

/// The frames of the point copy `dir/name` written by [`write_mesh_copies`] for a mesh of
/// `vertices` vertices, or what is wrong with it (naming the file).
fn read_points(dir: &Path, name: &str, vertices: usize) -> Result<Vec<Vec<Vec3>>, String> {
    // Only the names write_mesh_copies gives: no path leaves the run folder.
    let ok_name = name.strip_prefix("meshes/").is_some_and(|rest| {
        rest.len() == 16 + 1 + 16 + 4
            && rest.ends_with(".pc2")
            && rest[..33].chars().enumerate().all(|(i, c)| {
                if i == 16 {
                    c == '-'
                } else {
                    c.is_ascii_hexdigit()
                }
            })
    });
    if !ok_name {
        return Err(format!("points_copy = {name:?} is not a point copy's name"));
    }
    let path = dir.join(name);
    if std::fs::metadata(&path).is_ok_and(|m| !m.is_file()) {
        return Err(format!(
            "{}: the points' copy is not a regular file",
            path.display()
        ));
    }
    let bytes = std::fs::read(&path)
        .map_err(|e| format!("{}: cannot read the points' copy: {e}", path.display()))?;
    let bad = |what: &str| format!("{}: not a point copy: {what}", path.display());
    if bytes.len() < 32 || &bytes[..12] != b"POINTCACHE2\0" {
        return Err(bad("no PC2 header"));
    }
    let int = |at: usize| i32::from_le_bytes(bytes[at..at + 4].try_into().unwrap_or_default());
    let (points, count) = (int(16), int(28));
    if points < 0 || points as usize != vertices {
        return Err(bad(&format!(
            "{points} points, the mesh has {vertices} vertices"
        )));
    }
    let count = usize::try_from(count).map_err(|_| bad("a negative frame count"))?;
    if count == 0 || bytes.len() != 32 + count * vertices * 12 {
        return Err(bad(&format!(
            "{} bytes for {count} frames of {vertices} points",
            bytes.len()
        )));
    }
    let value = |at: usize| {
        Real::from(f32::from_le_bytes(
            bytes[at..at + 4].try_into().unwrap_or_default(),
        ))
    };
    Ok((0..count)
        .map(|f| {
            (0..vertices)
                .map(|v| {
                    let at = 32 + (f * vertices + v) * 12;
                    Vec3::new(value(at), value(at + 4), value(at + 8))
                })
                .collect()
        })
        .collect())
}

fn write_model(mut w: impl Write, m: &Mesh) -> io::Result<()> {
    writeln!(
        w,
        "# wetcloth mesh collider: a copy of {} as read ({} vertices, {} triangles)",
        m.file.replace('\n', " "),
        m.vertices().len(),
        m.triangles().len()
    )?;
    let mut line = String::new();
    for v in m.vertices() {
        line.clear();
        let _ = writeln!(line, "v {} {} {}", v.x, v.y, v.z);
        w.write_all(line.as_bytes())?;
    }
    for t in m.triangles() {
        line.clear();
        let _ = writeln!(line, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
        w.write_all(line.as_bytes())?;
    }
    w.flush()
}

/// Reads the copy `dir/copy` written by [`write_mesh_copies`] and checks it against `digest`
/// (16 hex digits): the model's vertices and triangles, or what is wrong (naming the file
/// and line).
fn read_copy(dir: &Path, copy: &str, digest: &str) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), String> {
    // Only the names write_mesh_copies gives: no path leaves the run folder.
    let expected = u64::from_str_radix(digest, 16)
        .map_err(|_| format!("digest = {digest:?} is not 16 hex digits"))?;
    if copy != copy_name(expected) {
        return Err(format!(
            "copy = {copy:?} is not the copy of a mesh of digest {digest} ({})",
            copy_name(expected)
        ));
    }
    let path = dir.join(copy);
    // Not a FIFO or a device: opening one could wait for ever.
    if std::fs::metadata(&path).is_ok_and(|m| !m.is_file()) {
        return Err(format!(
            "{}: the mesh's copy is not a regular file",
            path.display()
        ));
    }
    let file = std::fs::File::open(&path)
        .map_err(|e| format!("{}: cannot read the mesh's copy: {e}", path.display()))?;
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    for (n, line) in BufReader::new(file).lines().enumerate() {
        let line = line.map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        let bad = || {
            format!(
                "{}:{}: not a wetcloth mesh copy line: {line:?}",
                path.display(),
                n + 1
            )
        };
        let mut words = line.split_ascii_whitespace();
        match words.next() {
            Some("v") => {
                let mut c = [0.0; 3];
                for x in &mut c {
                    *x = words.next().and_then(|w| w.parse().ok()).ok_or_else(bad)?;
                }
                vertices.push(Vec3::from(c));
            }
            Some("f") => {
                let mut t = [0u32; 3];
                for i in &mut t {
                    let k: u32 = words.next().and_then(|w| w.parse().ok()).ok_or_else(bad)?;
                    *i = k.checked_sub(1).ok_or_else(bad)?;
                }
                triangles.push(t);
            }
            Some(w) if w.starts_with('#') => continue,
            None => continue,
            Some(_) => return Err(bad()),
        }
        if words.next().is_some() {
            return Err(bad());
        }
    }
    let found = mesh_digest(&vertices, &triangles);
    if found != expected {
        return Err(format!(
            "{}: the mesh's copy was changed (its digest is {found:016x}, run.json records \
             {digest})",
            path.display()
        ));
    }
    Ok((vertices, triangles))
}

/// The colliders of `run.json` (the JSON array `colliders`, in run folder `dir`): every shape
/// as the core reads it, a mesh rebuilt from its copy in the folder (checked against its
/// digest), or one written inline by an older version. `Err` says which collider and why.
pub fn read_colliders(dir: &Path, colliders: &serde_json::Value) -> Result<Vec<Collider>, String> {
    let Some(list) = colliders.as_array() else {
        return Err("colliders is not a list".into());
    };
    let mut out = Vec::with_capacity(list.len());
    for (i, c) in list.iter().enumerate() {
        let at = |e: String| format!("colliders[{i}]: {e}");
        let by_reference = c.get("shape").and_then(|s| s.as_str()) == Some("mesh")
            && c.get("triangles").is_none()
            && c.get("copy").is_some();
        if !by_reference {
            out.push(serde_json::from_value(c.clone()).map_err(|e| at(e.to_string()))?);
            continue;
        }
        let text = |key: &str| {
            c.get(key)
                .and_then(|v| v.as_str())
                .map(str::to_string)
                .ok_or_else(|| at(format!("{key} is missing or not a string")))
        };
        let number3 = |key: &str| -> Result<Vec3, String> {
            let v: [f64; 3] = serde_json::from_value(c.get(key).cloned().unwrap_or_default())
                .map_err(|e| at(format!("{key}: {e}")))?;
            Ok(Vec3::from(v))
        };
        let number = |key: &str| {
            c.get(key)
                .and_then(|v| v.as_f64())
                .ok_or_else(|| at(format!("{key} is missing or not a number")))
        };
        let (copy, digest) = (text("copy")?, text("digest")?);
        let (vertices, triangles) = read_copy(dir, &copy, &digest).map_err(at)?;
        let mesh = Mesh::new(
            text("file")?,
            vertices,
            triangles,
            number3("position")?,
            number3("rotation")?,
            number("scale")?,
        )
        .map_err(|e| at(format!("{copy}: {e}")))?;
        // A deforming mesh: its motion from the copy of its frames, timed as the scene timed it.
        let mesh = match c.get("points_copy").and_then(|v| v.as_str()) {
            None => mesh,
            Some(name) => {
                let frames = read_points(dir, name, mesh.vertices().len()).map_err(at)?;
                let source = match (text("sequence"), text("cache")) {
                    (Ok(s), _) => PointSource::Sequence(s),
                    (_, Ok(c)) => PointSource::Cache(c),
                    _ => PointSource::Cache(name.to_string()),
                };
                let motion = PointMotion {
                    source,
                    frame_rate: number("frame_rate")?,
                    start: c.get("start").and_then(|v| v.as_f64()).unwrap_or(0.0),
                    frames: std::sync::Arc::new(frames),
                };
                mesh.with_motion(motion)
                    .map_err(|e| at(format!("{name}: {e}")))?
            }
        };
        let keys: Vec<Key> = match c.get("keys") {
            None => Vec::new(),
            Some(k) => serde_json::from_value(k.clone()).map_err(|e| at(format!("keys: {e}")))?,
        };
        out.push(Collider {
            shape: Shape::Mesh(mesh),
            friction: number("friction")?,
            sticky: c.get("sticky").and_then(|s| s.as_bool()).unwrap_or(true),
            keys,
            placement: None,
        });
    }
    Ok(out)
}

/// Reads the text `text` of `dir/run.json` as a [`RunInfo`], every mesh collider rebuilt from
/// its copy ([`read_colliders`]). `Err` says what is wrong, naming `run.json` (with the line
/// for JSON errors).
pub fn read_run_json(dir: &Path, text: &str) -> Result<RunInfo, String> {
    let json = dir.join("run.json");
    let json = json.display();
    let at_line = |e: serde_json::Error| {
        format!(
            "{json}:{}:{}: not a wetcloth run.json: {e}",
            e.line(),
            e.column()
        )
    };
    let mut value: serde_json::Value = serde_json::from_str(text).map_err(at_line)?;
    let by_reference = value
        .get("colliders")
        .and_then(|c| c.as_array())
        .is_some_and(|list| {
            list.iter()
                .any(|c| c.get("copy").is_some() && c.get("triangles").is_none())
        });
    if !by_reference {
        // Read from the text, so that an error names its line.
        return serde_json::from_str(text).map_err(at_line);
    }
    let colliders = match value.get_mut("colliders") {
        Some(c) => read_colliders(dir, &std::mem::take(c)).map_err(|e| format!("{json}: {e}"))?,
        None => Vec::new(),
    };
    if let Some(c) = value.get_mut("colliders") {
        *c = serde_json::Value::Array(Vec::new());
    }
    let mut info: RunInfo = serde_json::from_value(value)
        .map_err(|e| format!("{json}: not a wetcloth run.json: {e}"))?;
    info.colliders = colliders;
    Ok(info)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    /// A deforming mesh collider written to a run folder reads back deforming: the same rest
    /// mesh and timing, its frames to single precision (the copy's; 1e-6 m at a metre), so a
    /// renderer of the run draws the body where it was.
    #[test]
    fn a_deforming_mesh_reads_back_with_its_motion() {
        let v = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let t = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let frames: Vec<Vec<Vec3>> = (0..5)
            .map(|f| v.iter().map(|p| *p * (1.0 + 0.1 * f as Real)).collect())
            .collect();
        let mesh = Mesh::new("tet.obj", v, t, Vec3::ZERO, Vec3::ZERO, 1.0)
            .unwrap()
            .with_motion(PointMotion {
                source: PointSource::Cache("/abs/tet.pc2".into()),
                frame_rate: 24.0,
                start: 0.5,
                frames: Arc::new(frames.clone()),
            })
            .unwrap();
        let collider = Collider::mesh(mesh, 0.6);
        let dir = std::env::temp_dir().join(format!("wetcloth-points-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        write_mesh_copies(&dir, std::slice::from_ref(&collider)).unwrap();
        let json = serde_json::to_value(vec![collider.clone()]).unwrap();
        let back = read_colliders(&dir, &json).unwrap();
        let Shape::Mesh(m) = &back[0].shape else {
            panic!("not a mesh")
        };
        let motion = m.motion().expect("the motion read back");
        assert_eq!(motion.frame_rate, 24.0);
        assert_eq!(motion.start, 0.5);
        assert_eq!(motion.source, PointSource::Cache("/abs/tet.pc2".into()));
        for (a, b) in motion.frames.iter().zip(&frames) {
            for (p, q) in a.iter().zip(b) {
                assert!((*p - *q).length() < 1e-6, "{p} against {q}");
            }
        }
        // A damaged copy is refused naming it.
        let Shape::Mesh(original) = &collider.shape else {
            unreachable!()
        };
        let name = original.points_copy_name().unwrap();
        std::fs::write(dir.join(&name), b"POINTCACHE2\0short").unwrap();
        let e = read_colliders(&dir, &json).unwrap_err();
        assert!(e.contains(".pc2") && e.contains("colliders[0]"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
