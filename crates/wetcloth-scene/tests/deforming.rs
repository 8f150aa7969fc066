//! Deforming mesh colliders in scene files: an OBJ sequence and a PC2 / MDD point cache read
//! into the same motion, the resolved scene reading back the same, and every refusal naming the
//! file that is wrong.

use std::path::{Path, PathBuf};
use wetcloth::{Real, Shape, Vec3};

/// A fresh folder for one test's files.
fn folder(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("wetcloth-deforming-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("body")).unwrap();
    dir
}

const FACES: &str = "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

/// A tetrahedron's vertices raised by `lift` (frame `k` of a test motion).
fn tetra(lift: Real) -> Vec<Vec3> {
    [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3::from(*p) + Vec3::Y * lift)
    .collect()
}

fn obj(points: &[Vec3], faces: &str) -> String {
    let mut s = String::new();
    for p in points {
        s += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    s + faces
}

/// Writes frames `0..n` of the lifted tetrahedron as `body/frame_NNNN.obj`.
fn write_sequence(dir: &Path, n: usize) {
    for k in 0..n {
        std::fs::write(
            dir.join(format!("body/frame_{k:04}.obj")),
            obj(&tetra(0.1 * k as Real), FACES),
        )
        .unwrap();
    }
}

fn scene_with(dir: &Path, collider: &str) -> Result<wetcloth_scene::Scene, String> {
    let text = format!(
        "[cloth]\nresolution = [4, 4]\nposition = [0.0, 3.0, 0.0]\n\n[air]\nenabled = false\n\n\
         [[collider]]\nshape = \"mesh\"\n{collider}\n"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    wetcloth_scene::load(&path).map_err(|e| e.to_string())
}

fn pc2(frames: &[Vec<Vec3>]) -> Vec<u8> {
    let mut b = b"POINTCACHE2\0".to_vec();
    b.extend(1i32.to_le_bytes());
    b.extend((frames[0].len() as i32).to_le_bytes());
    b.extend(7.0f32.to_le_bytes()); // a start frame the reader ignores
    b.extend(1.0f32.to_le_bytes());
    b.extend((frames.len() as i32).to_le_bytes());
    for f in frames {
        for p in f {
            for c in p.to_array() {
                b.extend((c as f32).to_le_bytes());
            }
        }
    }
    b
}

fn mdd(frames: &[Vec<Vec3>]) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend((frames.len() as i32).to_be_bytes());
    b.extend((frames[0].len() as i32).to_be_bytes());
    for k in 0..frames.len() {
        b.extend((k as f32 * 0.5).to_be_bytes()); // times the reader ignores
    }
    for f in frames {
        for p in f {
            for c in p.to_array() {
                b.extend((c as f32).to_be_bytes());
            }
        }
    }
    b
}

/// The motion of a scene's first collider.
fn frames_of(scene: &wetcloth_scene::Scene) -> (Vec<Vec<Vec3>>, Real, Real) {
    let Shape::Mesh(m) = &scene.config.colliders[0].shape else {
        panic!("not a mesh")
    };
    let mo = m.motion().expect("a deforming mesh");
    (mo.frames.to_vec(), mo.frame_rate, mo.start)
}

/// A sequence without `file` takes frame 0 as its rest mesh; a PC2 and an MDD cache of the
/// same points read the same motion (to the caches' f32 round-off, 6e-8 relative); the
/// resolved scene reads back to the same configuration.
#[test]
fn a_sequence_and_caches_read_the_same_motion() {
    let dir = folder("same");
    write_sequence(&dir, 4);
    let scene = scene_with(
        &dir,
        "sequence = \"body/frame_####.obj\"\nframe_rate = 24\nstart = 0.5",
    )
    .unwrap();
    let (seq, rate, start) = frames_of(&scene);
    assert_eq!((seq.len(), rate, start), (4, 24.0, 0.5));
    assert_eq!(seq[3], tetra(0.1 * 3.0));
    assert!(scene.config.colliders[0].is_moving());
    let back = wetcloth_scene::parse(&scene.to_toml(), &dir.join("resolved.toml")).unwrap();
    assert_eq!(back.config, scene.config);

    std::fs::write(dir.join("body/rest.obj"), obj(&tetra(0.0), FACES)).unwrap();
    for (name, bytes) in [("body.pc2", pc2(&seq)), ("body.MDD", mdd(&seq))] {
        std::fs::write(dir.join(name), bytes).unwrap();
        let scene = scene_with(
            &dir,
            &format!("file = \"body/rest.obj\"\ncache = \"{name}\"\nframe_rate = 24"),
        )
        .unwrap();
        let (cached, rate, start) = frames_of(&scene);
        assert_eq!((cached.len(), rate, start), (4, 24.0, 0.0), "{name}");
        for (a, b) in cached.iter().flatten().zip(seq.iter().flatten()) {
            assert!((*a - *b).length() < 1e-6, "{name}: {a} against {b}");
        }
        let back = wetcloth_scene::parse(&scene.to_toml(), &dir.join("resolved.toml")).unwrap();
        assert_eq!(back.config, scene.config, "{name}");
    }
}

/// Each refusal names the key, the file and what is wrong with it.
#[test]
fn bad_motions_are_refused_naming_the_file() {
    let dir = folder("bad");
    write_sequence(&dir, 3);
    std::fs::rename(
        dir.join("body/frame_0001.obj"),
        dir.join("body/frame_0001.bak"),
    )
    .unwrap();
    let seq = "sequence = \"body/frame_####.obj\"\nframe_rate = 24";
    let e = scene_with(&dir, seq).unwrap_err();
    assert!(
        e.contains("collider[0].sequence")
            && e.contains("frame 1 of the sequence is missing")
            && e.contains("frame_0001.obj"),
        "{e}"
    );
    // A frame with a vertex more.
    std::fs::rename(
        dir.join("body/frame_0001.bak"),
        dir.join("body/frame_0001.obj"),
    )
    .unwrap();
    let mut more = tetra(0.2);
    more.push(Vec3::ONE);
    std::fs::write(dir.join("body/frame_0002.obj"), obj(&more, FACES)).unwrap();
    let e = scene_with(&dir, seq).unwrap_err();
    assert!(
        e.contains("frame_0002.obj") && e.contains("frame 2 has 5 vertices, but frame 0 has 4"),
        "{e}"
    );
    // A frame with other faces.
    std::fs::write(
        dir.join("body/frame_0002.obj"),
        obj(&tetra(0.2), "f 1 2 3\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"),
    )
    .unwrap();
    let e = scene_with(&dir, seq).unwrap_err();
    assert!(
        e.contains("frame_0002.obj") && e.contains("different faces"),
        "{e}"
    );
    // No frame_rate.
    let e = scene_with(&dir, "sequence = \"body/frame_####.obj\"").unwrap_err();
    assert!(e.contains("collider[0].frame_rate"), "{e}");
    // A frame_rate out of range.
    write_sequence(&dir, 3);
    let e = scene_with(&dir, "sequence = \"body/frame_####.obj\"\nframe_rate = 0").unwrap_err();
    assert!(
        e.contains("collider[0].frame_rate") && e.contains("[1e-3, 1e5]"),
        "{e}"
    );
    // A cache of another vertex count than its rest mesh.
    std::fs::write(dir.join("body/rest.obj"), obj(&tetra(0.0), FACES)).unwrap();
    let frames = vec![more.clone(), more];
    std::fs::write(dir.join("body.pc2"), pc2(&frames)).unwrap();
    let e = scene_with(
        &dir,
        "file = \"body/rest.obj\"\ncache = \"body.pc2\"\nframe_rate = 24",
    )
    .unwrap_err();
    assert!(
        e.contains("collider[0].cache")
            && e.contains("body.pc2")
            && e.contains("the cache has 5 points, but the rest mesh (`file`) has 4 vertices"),
        "{e}"
    );
    // A cache without its rest mesh; both motions at once; timing keys without a motion.
    let e = scene_with(&dir, "cache = \"body.pc2\"\nframe_rate = 24").unwrap_err();
    assert!(e.contains("collider[0].file"), "{e}");
    let e = scene_with(
        &dir,
        "file = \"body/rest.obj\"\nsequence = \"body/frame_####.obj\"\ncache = \"body.pc2\"\n\
         frame_rate = 24",
    )
    .unwrap_err();
    assert!(e.contains("not both"), "{e}");
    let e = scene_with(&dir, "file = \"body/rest.obj\"\nstart = 1.0").unwrap_err();
    assert!(
        e.contains("collider[0].start") && e.contains("needs `sequence"),
        "{e}"
    );
    // Timing keys on another shape.
    let text = "[[collider]]\nshape = \"sphere\"\nradius = 1.0\nframe_rate = 24\n";
    let e = wetcloth_scene::parse(text, Path::new("s.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("a sphere collider has no `frame_rate`"), "{e}");
}

/// `[[attach]]` reads its collider and particles as a grab's, writes back to the same, and
/// refuses a collider the scene lacks and a `stiffness` on the spring grid (a soft attachment
/// pulls a mesh cloth's particles); on the membrane grid it reads and writes back.
#[test]
fn attachments_read_and_refuse_by_key() {
    let text = "[cloth]\nresolution = [4, 4]\nposition = [0.0, 0.5, 0.0]\n\n[air]\nenabled = \
                false\n\n[[collider]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = \
                0.1\n\n[[attach]]\ncollider = 0\nwithin = { center = [0.0, 0.5, 0.0], radius = \
                0.05 }\n";
    let scene = wetcloth_scene::parse(text, Path::new("a.toml")).unwrap();
    assert_eq!(scene.config.attachments.len(), 1);
    assert_eq!(scene.config.attachments[0].collider, 0);
    let back = wetcloth_scene::parse(&scene.to_toml(), Path::new("b.toml")).unwrap();
    assert_eq!(back.config, scene.config);
    let e = wetcloth_scene::parse(
        &text.replace("collider = 0", "collider = 3"),
        Path::new("a.toml"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("attach[0].collider") && e.contains("[0, 0]"),
        "{e}"
    );
    let e = wetcloth_scene::parse(&format!("{text}stiffness = 10.0\n"), Path::new("a.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("attach[0].stiffness") && e.contains("a.toml:"),
        "{e}"
    );
    let soft =
        format!("{text}stiffness = 10.0\n").replace("[cloth]\n", "[cloth]\nmodel = \"membrane\"\n");
    let scene = wetcloth_scene::parse(&soft, Path::new("a.toml")).unwrap();
    assert_eq!(scene.config.attachments[0].stiffness, Some(10.0));
    let back = wetcloth_scene::parse(&scene.to_toml(), Path::new("b.toml")).unwrap();
    assert_eq!(back.config, scene.config);
    let e = wetcloth_scene::parse(&format!("{text}vertex = 1\n"), Path::new("a.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("exactly one of"), "{e}");
}

/// `[[cloth.seam]]` reads its pairs with the defaults, writes back to the same, and is refused
/// naming its key and line: on the spring grid, with lists of different lengths, a particle out
/// of range.
#[test]
fn seams_read_and_refuse_by_key() {
    let text = "[cloth]\nresolution = [4, 4]\nmodel = \"membrane\"\n\n[[cloth.seam]]\na = [0, 1]\nb \
                = [12, 13]\n\n[air]\nenabled = false\n";
    let scene = wetcloth_scene::parse(text, Path::new("s.toml")).unwrap();
    let seams = &scene.config.cloth.seams;
    assert_eq!(seams.len(), 1);
    assert_eq!(
        (seams[0].a.clone(), seams[0].b.clone()),
        (vec![0, 1], vec![12, 13])
    );
    assert_eq!(seams[0].stiffness, 50.0);
    assert_eq!(seams[0].max_force, 0.05);
    let back = wetcloth_scene::parse(&scene.to_toml(), Path::new("b.toml")).unwrap();
    assert_eq!(back.config, scene.config);
    for (bad, key, says) in [
        ("model = \"membrane\"\n", "cloth.seam", "mesh"),
        ("b \n= [12, 13]", "cloth.seam[0].b", "same"),
        ("[12, 13]", "cloth.seam[0].b", "16"),
    ] {
        let with = match bad {
            "b \n= [12, 13]" => text.replace("b = [12, 13]", "b = [12]"),
            "[12, 13]" => text.replace("[12, 13]", "[12, 16]"),
            _ => text.replace(bad, ""),
        };
        let e = wetcloth_scene::parse(&with, Path::new("s.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(key) && e.contains(says) && e.contains("s.toml"),
            "{e}"
        );
    }
}
