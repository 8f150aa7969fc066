//! Damaged run folders are refused before anything is drawn, with the file and what is wrong:
//! truncated, empty or faceless frames, non-finite vertices, wrong vertex counts, frames that
//! disagree with each other, missing frames, and nonsense `run.json` values. Found from outside:
//! `wetcloth render` drew all of these without a word (exit 0, a frame with no cloth).
//!
//! Every case here fails while reading, before a graphics device is opened, so these tests
//! need no GPU.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use wetcloth_render::{
    RenderError, RenderOptions, read_obj, read_run_info, render_run, tented_grid,
};

const N: usize = 6;

fn fresh_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("wetcloth-damaged-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("frames")).unwrap();
    dir
}

/// One frame as `wetcloth run` writes it: header comment, v, vt, vn, faces v/vt/vn.
fn frame_text(lift: f32) -> String {
    let (p, idx) = tented_grid(N, 0.3, 0.002, lift);
    let mut s = format!("# wetcloth cloth mesh: {N} x {N} particles\no cloth\n");
    for v in &p {
        writeln!(s, "v {} {} {}", v[0], v[1], v[2]).unwrap();
    }
    for _ in &p {
        writeln!(s, "vt 0.5 0.5").unwrap();
    }
    for _ in &p {
        writeln!(s, "vn 0 1 0").unwrap();
    }
    for t in idx.chunks(3) {
        let [a, b, c] = [t[0] + 1, t[1] + 1, t[2] + 1];
        writeln!(s, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}").unwrap();
    }
    s
}

fn run_json(frames: u64, edit: impl FnOnce(&mut serde_json::Value)) -> String {
    let mut v = serde_json::json!({
        "name": "damaged",
        "resolution": [N, N],
        "size": [0.3, 0.3],
        "particle_radius": 0.002,
        "time_step": 0.0001,
        "frame_rate": 24.0,
        "duration": 1.0,
        "frames": frames,
        "complete": true,
        "status": "complete",
        "time": 1.0,
        "colliders": [
            {"shape": "plane", "point": [0.0, 0.0, 0.0], "normal": [0.0, 1.0, 0.0], "friction": 0.6},
            {"shape": "sphere", "center": [0.3, 0.05, 0.0], "radius": 0.05, "friction": 0.5},
            {"shape": "box", "center": [0.0, 0.05, 0.3], "half_extents": [0.05, 0.05, 0.05], "friction": 0.5}
        ],
        "grabs": [[3, 3]]
    });
    edit(&mut v);
    serde_json::to_string_pretty(&v).unwrap()
}

/// A sound three-frame run.
fn good_run(name: &str) -> PathBuf {
    let dir = fresh_dir(name);
    for f in 0..3 {
        std::fs::write(
            dir.join(format!("frames/frame_{f:04}.obj")),
            frame_text(0.02 * f as f32),
        )
        .unwrap();
    }
    std::fs::write(dir.join("run.json"), run_json(3, |_| {})).unwrap();
    dir
}

fn frame(dir: &Path, k: u64) -> PathBuf {
    dir.join(format!("frames/frame_{k:04}.obj"))
}

/// The error of rendering `dir` (every case must fail before a device is needed).
fn refused(dir: &Path) -> String {
    let opts = RenderOptions {
        video: false,
        ..RenderOptions::new(dir)
    };
    match render_run(opts) {
        Ok(_) => panic!("{} was rendered", dir.display()),
        Err(e) => {
            assert!(
                !matches!(e, RenderError::NoAdapter(_) | RenderError::Device(_)),
                "reached the device: {e}"
            );
            e.to_string()
        }
    }
}

fn assert_has(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "missing {p:?} in: {msg}");
    }
}

#[test]
fn the_sound_run_reads() {
    let dir = good_run("sound");
    let info = read_run_info(&dir).unwrap().unwrap();
    assert_eq!(info.resolution, [N, N]);
    assert_eq!(info.frames, Some(3));
    assert_eq!(info.status.as_deref(), Some("complete"));
    let mesh = read_obj(&frame(&dir, 1)).unwrap();
    assert_eq!(mesh.positions.len(), N * N);
    assert_eq!(mesh.indices.len(), 6 * (N - 1) * (N - 1));
    assert_eq!(mesh.header_resolution, Some([N, N]));
}

#[test]
fn an_empty_frame_is_refused() {
    let dir = good_run("empty");
    std::fs::write(frame(&dir, 1), "").unwrap();
    assert_has(
        &refused(&dir),
        &["frame_0001.obj", "no vertices", "empty or truncated"],
    );
}

#[test]
fn a_frame_cut_in_the_middle_of_a_line_is_refused() {
    let dir = good_run("cut");
    let text = frame_text(0.01);
    std::fs::write(frame(&dir, 2), &text[..text.len() / 2 - 3]).unwrap();
    assert_has(&refused(&dir), &["frame_0002.obj:", "truncated"]);
}

#[test]
fn a_frame_cut_at_a_line_end_is_refused_by_its_triangle_count() {
    let dir = good_run("cut-line");
    let text = frame_text(0.01);
    let cut = text[..text.len() - 40].rfind('\n').unwrap() + 1;
    std::fs::write(frame(&dir, 1), &text[..cut]).unwrap();
    assert_has(
        &refused(&dir),
        &[
            "frame_0001.obj",
            "triangles where a 6 x 6 cloth",
            "truncated",
        ],
    );
    // Without run.json the header comment gives the resolution.
    std::fs::remove_file(dir.join("run.json")).unwrap();
    assert_has(&refused(&dir), &["frame_0001.obj", "the header of"]);
}

#[test]
fn a_frame_without_faces_is_refused() {
    let dir = good_run("faceless");
    let text: String = frame_text(0.0)
        .lines()
        .filter(|l| !l.starts_with("f "))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(frame(&dir, 0), text).unwrap();
    assert_has(&refused(&dir), &["frame_0000.obj", "no faces"]);
}

#[test]
fn non_finite_vertices_are_refused_with_their_line() {
    for (k, bad) in ["NaN", "inf", "-inf", "1e39"].into_iter().enumerate() {
        let dir = good_run(&format!("nan-{k}"));
        let text = frame_text(0.0).replacen("\nv ", &format!("\nv {bad} 0 0\nv "), 1);
        // One vertex too many as well; the non-finite one is found first, on line 3.
        std::fs::write(frame(&dir, 1), text).unwrap();
        assert_has(
            &refused(&dir),
            &["frame_0001.obj:3:", "vertex 1", "not finite"],
        );
    }
}

#[test]
fn a_wrong_vertex_count_is_refused() {
    let dir = good_run("count");
    // A valid mesh of another cloth: 7 x 7 vertices in a 6 x 6 run.
    let (p, idx) = tented_grid(N + 1, 0.3, 0.002, 0.0);
    let mut s = String::new();
    for v in &p {
        writeln!(s, "v {} {} {}", v[0], v[1], v[2]).unwrap();
    }
    for t in idx.chunks(3) {
        writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1).unwrap();
    }
    std::fs::write(frame(&dir, 2), &s).unwrap();
    assert_has(
        &refused(&dir),
        &["frame_0002.obj", "49 vertices where a 6 x 6 cloth"],
    );
    // Without run.json or header, frames are held to the first one.
    std::fs::remove_file(dir.join("run.json")).unwrap();
    for k in 0..2 {
        let t =
            frame_text(0.0).replace(&format!("# wetcloth cloth mesh: {N} x {N} particles\n"), "");
        std::fs::write(frame(&dir, k), t).unwrap();
    }
    assert_has(
        &refused(&dir),
        &[
            "frame_0002.obj",
            "49 vertices where",
            "frame_0000.obj has 36",
        ],
    );
}

#[test]
fn faces_naming_missing_vertices_are_refused() {
    let dir = good_run("bad-face");
    let text = frame_text(0.0).replacen("\nf 1/1/1", "\nf 99/99/99", 1);
    std::fs::write(frame(&dir, 0), text).unwrap();
    assert_has(
        &refused(&dir),
        &["frame_0000.obj:", "\"99/99/99\" names no vertex"],
    );
    let text = frame_text(0.0).replacen("\nf 1/1/1", "\nf 0", 1);
    std::fs::write(frame(&dir, 0), text).unwrap();
    assert_has(&refused(&dir), &["names no vertex"]);
}

#[test]
fn a_missing_frame_below_the_count_in_run_json_is_refused() {
    let dir = good_run("missing");
    std::fs::write(dir.join("run.json"), run_json(5, |_| {})).unwrap();
    assert_has(
        &refused(&dir),
        &["run.json", "wrote 5 frame(s)", "frame_0003.obj is missing"],
    );
    std::fs::write(dir.join("run.json"), run_json(3, |_| {})).unwrap();
    std::fs::remove_file(frame(&dir, 1)).unwrap();
    assert_has(&refused(&dir), &["frame_0001.obj is missing"]);
}

#[test]
fn nonsense_run_json_values_are_refused_naming_the_key() {
    type Edit = fn(&mut serde_json::Value);
    let cases: [(Edit, &[&str]); 12] = [
        (
            |v| v["resolution"] = serde_json::json!([0, 0]),
            &["resolution = [0, 0]", "[2, 4096]"],
        ),
        (
            |v| v["resolution"] = serde_json::json!([1, 100000]),
            &["resolution"],
        ),
        (
            |v| v["particle_radius"] = serde_json::json!(-1.0),
            &["particle_radius = -1.0"],
        ),
        (
            |v| v["frame_rate"] = serde_json::json!(0.0),
            &["frame_rate = 0.0", "[1, 10000]"],
        ),
        (
            |v| v["frame_rate"] = serde_json::json!(1e300),
            &["frame_rate = 1e300"],
        ),
        (
            |v| v["colliders"][0]["normal"] = serde_json::json!([0, 0, 0]),
            &["colliders[0].normal", "non-zero"],
        ),
        (
            |v| v["colliders"][0]["point"] = serde_json::json!([0, 1e300, 0]),
            &["colliders[0].point"],
        ),
        (
            |v| v["colliders"][1]["radius"] = serde_json::json!(-0.5),
            &["colliders[1].radius = -0.5"],
        ),
        (
            |v| v["colliders"][2]["half_extents"] = serde_json::json!([0.1, 0, 0.1]),
            &["colliders[2].half_extents"],
        ),
        (
            |v| v["grabs"] = serde_json::json!([[6, 0]]),
            &["grabs[0] = [6, 0]", "outside the 6 x 6 cloth"],
        ),
        (
            |v| v["status"] = serde_json::json!("done"),
            &["status = \"done\"", "\"interrupted\""],
        ),
        (
            |v| v["resolution"] = serde_json::json!("big"),
            &["run.json:", "invalid type"],
        ),
    ];
    for (k, (edit, parts)) in cases.into_iter().enumerate() {
        let dir = good_run(&format!("json-{k}"));
        std::fs::write(dir.join("run.json"), run_json(3, edit)).unwrap();
        let msg = refused(&dir);
        assert!(msg.contains("run.json"), "{msg}");
        assert_has(&msg, parts);
    }
}

/// Found from outside: `render --frames 999` said "no frames" although the run has frames.
#[test]
fn a_selection_matching_no_frame_names_the_frames_there_are() {
    let dir = good_run("select");
    let msg = render_run(RenderOptions {
        frames: Some("999".parse().unwrap()),
        ..RenderOptions::new(&dir)
    })
    .unwrap_err()
    .to_string();
    assert_has(&msg, &["--frames 999", "3 frame(s), numbered 0 to 2"]);
}

#[test]
fn two_files_for_one_frame_are_refused() {
    let dir = good_run("twice");
    std::fs::copy(frame(&dir, 1), dir.join("frames/frame_00001.obj")).unwrap();
    assert_has(&refused(&dir), &["frame 1 again"]);
}

#[cfg(unix)]
#[test]
fn a_run_json_that_is_not_a_regular_file_is_refused() {
    let dir = good_run("device");
    std::fs::remove_file(dir.join("run.json")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.join("run.json")).unwrap();
    assert_has(&refused(&dir), &["run.json", "not a regular file"]);
}

#[test]
fn wetness_out_of_range_is_refused_by_the_library_too() {
    let dir = good_run("wetness");
    let msg = render_run(RenderOptions {
        wetness: f32::NAN,
        ..RenderOptions::new(&dir)
    })
    .unwrap_err()
    .to_string();
    assert_has(&msg, &["wetness = NaN", "0 (dry) to 1 (wet)"]);
}

/// A frame of a cloth of any shape as `wetcloth run` writes it: the header, the vertices of a
/// 3 x 3 patch, and its four cells as quads, but the last cell as two triangles (`f v/vt/vn`).
fn mesh_frame_text(lift: f32) -> String {
    let mut s = String::from("# wetcloth cloth mesh: 9 particles, 5 faces\no cloth\n");
    for j in 0..3 {
        for i in 0..3 {
            let y = if (i, j) == (1, 1) {
                0.002 + lift
            } else {
                0.002
            };
            writeln!(s, "v {} {y} {}", 0.1 * i as f32, 0.1 * j as f32).unwrap();
        }
    }
    for _ in 0..9 {
        s += "vt 0.5 0.5\nvn 0 1 0\n";
    }
    s += "f 1/1/1 4/4/4 5/5/5 2/2/2\nf 2/2/2 5/5/5 6/6/6 3/3/3\nf 4/4/4 7/7/7 8/8/8 5/5/5\n\
          f 5/5/5 8/8/8 9/9/9\nf 5/5/5 9/9/9 6/6/6\n";
    s
}

/// A sound three-frame run of a cloth of any shape: run.json's `mesh` and no resolution.
fn good_mesh_run(name: &str) -> PathBuf {
    let dir = fresh_dir(name);
    for f in 0..3 {
        std::fs::write(frame(&dir, f), mesh_frame_text(0.01 * f as f32)).unwrap();
    }
    std::fs::write(dir.join("run.json"), mesh_run_json(|_| {})).unwrap();
    dir
}

fn mesh_run_json(edit: impl FnOnce(&mut serde_json::Value)) -> String {
    run_json(3, |v| {
        let o = v.as_object_mut().unwrap();
        o.remove("resolution");
        o.remove("size");
        o.insert("grabs".into(), serde_json::json!([]));
        o.insert(
            "mesh".into(),
            serde_json::json!({"file": "/scenes/patch.obj", "vertices": 9, "faces": 5}),
        );
        edit(v);
    })
}

#[test]
fn the_sound_mesh_run_reads() {
    let dir = good_mesh_run("mesh-sound");
    let info = read_run_info(&dir).unwrap().unwrap();
    let mesh = info.mesh.clone().unwrap();
    assert_eq!(
        (mesh.file.as_str(), mesh.vertices, mesh.faces),
        ("/scenes/patch.obj", 9, 5)
    );
    assert_eq!(info.resolution, [0, 0]);
    let obj = read_obj(&frame(&dir, 1)).unwrap();
    assert_eq!(
        (obj.positions.len(), obj.faces, obj.indices.len()),
        (9, 5, 3 * 8)
    );
    assert_eq!(
        (obj.header_mesh, obj.header_resolution),
        (Some([9, 5]), None)
    );
    let check = wetcloth_render::check_run(&dir).unwrap();
    assert_eq!((check.vertices, check.faces, check.triangles), (9, 5, 8));
}

#[test]
fn a_mesh_frame_with_a_wrong_count_is_refused() {
    // A face lost at a line end: counted against run.json's mesh, then the header.
    let dir = good_mesh_run("mesh-faces");
    let text = mesh_frame_text(0.0);
    let cut = text[..text.len() - 1].rfind('\n').unwrap() + 1;
    std::fs::write(frame(&dir, 1), &text[..cut]).unwrap();
    assert_has(
        &refused(&dir),
        &[
            "frame_0001.obj",
            "4 faces where the mesh cloth patch.obj (run.json's mesh) has 5",
        ],
    );
    std::fs::remove_file(dir.join("run.json")).unwrap();
    assert_has(
        &refused(&dir),
        &["frame_0001.obj", "4 faces where", "the header of"],
    );
    // A vertex too many.
    let dir = good_mesh_run("mesh-vertices");
    let text = mesh_frame_text(0.0).replacen("\nv ", "\nv 0 0 0\nv ", 1);
    std::fs::write(frame(&dir, 2), text).unwrap();
    assert_has(
        &refused(&dir),
        &[
            "frame_0002.obj",
            "10 vertices where the mesh cloth",
            "has 9",
        ],
    );
    // The same counts, other faces.
    let dir = good_mesh_run("mesh-other");
    let text = mesh_frame_text(0.0).replace("f 5/5/5 9/9/9 6/6/6", "f 5/5/5 9/9/9 3/3/3");
    std::fs::write(frame(&dir, 2), text).unwrap();
    assert_has(
        &refused(&dir),
        &["frame_0002.obj", "faces differ from those of"],
    );
}

#[test]
fn nonsense_mesh_values_in_run_json_are_refused_naming_the_key() {
    type Edit = fn(&mut serde_json::Value);
    let cases: [(Edit, &[&str]); 6] = [
        (
            |v| {
                v["mesh"].as_object_mut().unwrap().remove("vertices");
            },
            &["mesh.vertices is missing"],
        ),
        (
            |v| {
                v["mesh"].as_object_mut().unwrap().remove("faces");
            },
            &["mesh.faces is missing"],
        ),
        (
            |v| v["mesh"]["vertices"] = serde_json::json!(2),
            &["mesh.vertices = 2", "[3, 4194304]"],
        ),
        (
            |v| v["mesh"]["faces"] = serde_json::json!(0),
            &["mesh.faces = 0"],
        ),
        (
            |v| v["mesh"]["faces"] = serde_json::json!(-3),
            &["run.json:", "invalid value"],
        ),
        (
            |v| v["mesh"] = serde_json::json!([9, 5]),
            &["run.json:", "invalid type"],
        ),
    ];
    for (k, (edit, parts)) in cases.into_iter().enumerate() {
        let dir = good_mesh_run(&format!("mesh-json-{k}"));
        std::fs::write(dir.join("run.json"), mesh_run_json(edit)).unwrap();
        let msg = refused(&dir);
        assert!(msg.contains("run.json"), "{msg}");
        assert_has(&msg, parts);
    }
    // The counts of another mesh: the frames are refused.
    let dir = good_mesh_run("mesh-json-other");
    std::fs::write(
        dir.join("run.json"),
        mesh_run_json(|v| v["mesh"]["vertices"] = serde_json::json!(609)),
    )
    .unwrap();
    assert_has(
        &refused(&dir),
        &[
            "frame_0000.obj",
            "9 vertices where the mesh cloth patch.obj",
            "has 609",
        ],
    );
}
