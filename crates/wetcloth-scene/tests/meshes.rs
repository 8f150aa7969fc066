//! Mesh colliders and collider keys in scene files: loading relative to the scene, the errors
//! for bad meshes, and the shipped head mesh with a cloth draped over it.

use std::path::{Path, PathBuf};
use wetcloth::{Real, Shape, Simulation, Vec3};

/// A fresh folder for one test's files.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wetcloth-meshes-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("models")).unwrap();
    dir
}

const TETRA: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

fn scene_with(dir: &Path, collider: &str) -> Result<wetcloth_scene::Scene, String> {
    let text = format!(
        "[cloth]\nresolution = [4, 4]\nposition = [0.0, 2.0, 0.0]\n\n[air]\nenabled = false\n\n\
         [[collider]]\n{collider}\n"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    wetcloth_scene::load(&path).map_err(|e| e.to_string())
}

#[test]
fn a_mesh_loads_relative_to_the_scene_with_its_placement_keys_and_sticky() {
    let dir = folder("loads");
    std::fs::write(dir.join("models/tetra.obj"), TETRA).unwrap();
    let scene = scene_with(
        &dir,
        "shape = \"mesh\"\nfile = \"models/tetra.obj\"\nposition = [1.0, 0.0, 0.0]\n\
         rotation = [0.0, 90.0, 0.0]\nscale = 0.5\nfriction = 0.3\nsticky = false\n\
         keys = [ { time = 0.5, offset = [0.0, 0.0, 0.0] },\n\
         { time = 1.0, offset = [0.0, -0.05, 0.0], rotation = [0.0, 0.0, 10.0] } ]",
    )
    .unwrap();
    let c = &scene.config.colliders[0];
    let Shape::Mesh(m) = &c.shape else {
        panic!("not a mesh")
    };
    // Named by its absolute path, so a written scene reads it back from anywhere.
    assert!(Path::new(&m.file).is_absolute(), "{}", m.file);
    assert!(m.file.ends_with("models/tetra.obj"), "{}", m.file);
    assert_eq!(
        (m.position, m.rotation, m.scale),
        (Vec3::X, Vec3::new(0.0, 90.0, 0.0), 0.5)
    );
    assert_eq!((m.vertices().len(), m.triangles().len()), (4, 4));
    assert!(m.is_closed());
    assert!(!c.sticky);
    assert_eq!(c.keys.len(), 2);
    assert_eq!(c.keys[1].offset, Vec3::new(0.0, -0.05, 0.0));
    assert_eq!(c.keys[1].rotation, Vec3::new(0.0, 0.0, 10.0));
    assert_eq!(c.keys[0].rotation, Vec3::ZERO);
    // The model's corner (0, 0, 1) scaled by 0.5, turned 90 degrees about y to (0.5, 0, 0),
    // moved by (1, 0, 0): the surface passes through (1.5, 0, 0).
    assert!(c.distance(Vec3::new(1.5, 0.0, 0.0)).0.abs() < 1e-12);
    // Every collider is sticky by default, and a written scene reads back the same.
    let plain = scene_with(&dir, "shape = \"sphere\"\nradius = 0.1").unwrap();
    assert!(plain.config.colliders[0].sticky);
    let again = dir.join("again.toml");
    std::fs::write(&again, scene.to_toml()).unwrap();
    assert_eq!(wetcloth_scene::load(&again).unwrap().config, scene.config);
}

#[test]
fn bad_meshes_are_refused_with_file_line_and_key() {
    let dir = folder("bad");
    let bad = |obj: Option<&str>, extra: &str| {
        if let Some(obj) = obj {
            std::fs::write(dir.join("models/m.obj"), obj).unwrap();
        } else {
            let _ = std::fs::remove_file(dir.join("models/m.obj"));
        }
        scene_with(
            &dir,
            &format!("shape = \"mesh\"\nfile = \"models/m.obj\"{extra}"),
        )
        .unwrap_err()
    };
    let path = dir.join("models/m.obj").display().to_string();
    // Missing: the scene's line of `file`, the key, and the path looked at.
    let e = bad(None, "");
    assert!(
        e.contains("scene.toml:10:") && e.contains("collider[0].file"),
        "{e}"
    );
    assert!(e.contains(&path) && e.contains("cannot read"), "{e}");
    // No faces.
    let e = bad(Some("v 0 0 0\nv 1 0 0\n"), "");
    assert!(e.contains("no faces") && e.contains(&path), "{e}");
    // Non-finite vertex, with the mesh file's line.
    let e = bad(Some("v 0 0 0\nv 1 inf 0\nv 0 0 1\nf 1 2 3\n"), "");
    assert!(
        e.contains(&format!("{path}:2:")) && e.contains("not finite"),
        "{e}"
    );
    // An index out of range.
    let e = bad(Some("v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 7\n"), "");
    assert!(
        e.contains(&format!("{path}:4:")) && e.contains("out of range"),
        "{e}"
    );
    // A huge finite coordinate (it overflowed the contact queries), with its line and value.
    let e = bad(Some("v 0 0 0\nv 1 0 0\nv 0 -1e200 1\nf 1 2 3\n"), "");
    assert!(
        e.contains(&format!("{path}:3:")) && e.contains("-1e200, out of range"),
        "{e}"
    );
    // A scale of 0.
    let e = bad(Some(TETRA), "\nscale = 0.0");
    assert!(
        e.contains("collider[0].scale") && e.contains("scene.toml:11:"),
        "{e}"
    );
    // A mesh needs its file; keys must increase.
    let e = scene_with(&dir, "shape = \"mesh\"").unwrap_err();
    assert!(e.contains("collider[0].file"), "{e}");
    let e = bad(
        Some(TETRA),
        "\nkeys = [ { time = 1.0 }, { time = 0.5, offset = [0.0, 1.0, 0.0] } ]",
    );
    assert!(e.contains("collider[0].keys[1].time"), "{e}");
}

/// Whether `p` is inside the closed triangle mesh `tris` (world points): the parity of the
/// crossings of a ray from `p` in a fixed, generic direction (independent of the collider's
/// own pseudo-normal test).
fn inside(p: Vec3, tris: &[[Vec3; 3]]) -> bool {
    let dir = Vec3::new(0.5773, 0.5774, 0.5775).normalize();
    let mut crossings = 0;
    for [a, b, c] in tris {
        let (e1, e2) = (*b - *a, *c - *a);
        let h = dir.cross(e2);
        let det = e1.dot(h);
        if det.abs() < 1e-18 {
            continue;
        }
        let s = p - *a;
        let u = s.dot(h) / det;
        let q = s.cross(e1);
        let v = dir.dot(q) / det;
        let t = e2.dot(q) / det;
        if (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && t > 0.0 {
            crossings += 1;
        }
    }
    crossings % 2 == 1
}

/// The shipped head scene, shortened and coarsened: a cloth dropped over the head, then pressed
/// down onto it by a gravity of 5 g, is never found inside it (checked every 40 steps, by ray
/// parity against the mesh's triangles).
#[test]
fn no_particle_is_ever_inside_the_head() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut scene = wetcloth_scene::load(root.join("scenes/head-drape.toml")).unwrap();
    let cfg = &mut scene.config;
    cfg.cloth.resolution = [20, 20];
    cfg.cloth.self_collision = false;
    let Shape::Mesh(head) = &cfg.colliders[1].shape else {
        panic!("the head is a mesh")
    };
    assert!(head.is_closed());
    let tris: Vec<[Vec3; 3]> = head
        .triangles()
        .iter()
        .map(|t| t.map(|i| head.vertices()[i as usize] * head.scale + head.position))
        .collect();
    let mut sim = Simulation::new(cfg.clone()).unwrap();
    let n = sim.positions().len();
    let steps = (0.25 / sim.time_step()) as usize;
    for step in 0..2 * steps {
        if step == steps {
            let mut pressed = sim.config().clone();
            pressed.simulation.gravity = Vec3::new(0.0, -49.0, 0.0);
            let (x, v) = (sim.positions().clone(), sim.velocities());
            sim = Simulation::new(pressed).unwrap();
            sim.set_positions_and_velocities(x, &v).unwrap();
        }
        sim.step().unwrap();
        if step % 40 == 0 || step + 1 == 2 * steps {
            for k in 0..n {
                let p = sim.positions().get(k);
                assert!(!inside(p, &tris), "step {step}: particle {k} inside at {p}");
            }
        }
    }
    // It lies on the head: the centre particle rests on the crown.
    let top: Real = head
        .vertices()
        .iter()
        .map(|v| v.y)
        .fold(Real::NEG_INFINITY, Real::max);
    let centre = sim.positions().get(10 * 20 + 10);
    assert!(centre.y > 0.8 * top && centre.y < top + 0.01, "{centre}");
}

/// Closed meshes whose parts are wound opposite ways, or that enclose nothing (a square's two
/// faces), were taken to contain all of space: "the cloth starts inside this mesh". A cloth
/// 2 m above them starts clear.
#[test]
fn closed_meshes_wound_oppositely_or_flat_do_not_swallow_the_cloth() {
    let dir = folder("inside-out");
    // A tetrahedron wound outwards and one wound inwards beside it.
    let two =
        format!("{TETRA}v 5 0 0\nv 6 0 0\nv 5 1 0\nv 5 0 1\nf 5 6 7\nf 5 8 6\nf 5 7 8\nf 6 8 7\n");
    // A flat square, both faces: closed by its edges, no volume.
    let flat = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 2 3\nf 1 3 4\nf 2 1 4\nf 2 4 3\n";
    for obj in [two.as_str(), flat] {
        std::fs::write(dir.join("models/m.obj"), obj).unwrap();
        let scene = scene_with(&dir, "shape = \"mesh\"\nfile = \"models/m.obj\"");
        assert!(scene.is_ok(), "{obj}: {}", scene.unwrap_err());
    }
}
