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
use wetcloth::collide::{Key, Mesh};
use wetcloth::{Collider, Shape, Vec3};

use crate::RunInfo;

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
    Ok(())
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
