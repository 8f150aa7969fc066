//! `render_run` on a small run directory written here (OBJ frames and run.json in the format
//! of `wetcloth run`): the PNGs exist, have the asked size and show the cloth where it is.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use wetcloth_render::{
    CameraSpec, FrameSelection, ImageSize, RenderError, RenderOptions, VideoOutcome, render_run,
    render_run_with_progress, tented_grid,
};

const N: usize = 12;

/// A fresh directory under the test target directory.
fn fresh_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("wetcloth-render-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `frames` OBJ frames of a 30 cm cloth whose centre rises over time, like the export
/// writer does (v, vt, vn, faces v/vt/vn, 1-based), and a run.json unless `json` is false.
fn write_run(dir: &Path, frames: usize, json: bool) {
    std::fs::create_dir_all(dir.join("frames")).unwrap();
    for f in 0..frames {
        let lift = 0.08 * f as f32 / frames.max(2) as f32;
        let (p, idx) = tented_grid(N, 0.3, 0.002, lift);
        let mut s = String::from("# test frame\no cloth\n");
        for v in &p {
            writeln!(s, "v {} {} {}", v[0], v[1], v[2]).unwrap();
        }
        for k in 0..p.len() {
            writeln!(
                s,
                "vt {} {}",
                (k % N) as f32 / (N - 1) as f32,
                (k / N) as f32 / (N - 1) as f32
            )
            .unwrap();
            writeln!(s, "vn 0 1 0").unwrap();
        }
        for t in idx.chunks(3) {
            let [a, b, c] = [t[0] + 1, t[1] + 1, t[2] + 1];
            writeln!(s, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}").unwrap();
        }
        std::fs::write(dir.join(format!("frames/frame_{f:04}.obj")), s).unwrap();
    }
    if json {
        let text = format!(
            r#"{{
  "name": "test-tent",
  "resolution": [{N}, {N}],
  "size": [0.3, 0.3],
  "particle_radius": 0.002,
  "time_step": 0.0001,
  "frame_rate": 24.0,
  "duration": 1.0,
  "frames": {frames},
  "complete": true,
  "colliders": [
    {{"shape": "plane", "point": [0.0, 0.0, 0.0], "normal": [0.0, 1.0, 0.0], "friction": 0.6}},
    {{"shape": "sphere", "center": [0.3, 0.05, 0.0], "radius": 0.05, "friction": 0.5}}
  ],
  "grabs": [[6, 6]]
}}
"#
        );
        std::fs::write(dir.join("run.json"), text).unwrap();
    }
}

fn opts(dir: &Path) -> RenderOptions {
    RenderOptions {
        size: ImageSize {
            width: 160,
            height: 120,
        },
        ..RenderOptions::new(dir)
    }
}

#[test]
fn a_run_renders_to_pngs_showing_the_cloth_and_a_video_when_ffmpeg_is_there() {
    let dir = fresh_dir("run");
    write_run(&dir, 4, true);
    let mut calls = Vec::new();
    let summary =
        render_run_with_progress(opts(&dir), &mut |done, total| calls.push((done, total)))
            .expect("render_run failed (a graphics adapter is needed: mesa-vulkan-drivers)");
    println!("{summary}");
    assert_eq!(calls, vec![(1, 4), (2, 4), (3, 4), (4, 4)]);
    assert_eq!(summary.out_dir, dir.join("render"));
    assert_eq!(summary.images.len(), 4);
    for (k, png) in summary.images.iter().enumerate() {
        assert_eq!(png, &dir.join(format!("render/frame_{k:04}.png")));
        let img = image::open(png).unwrap().to_rgba8();
        assert_eq!(img.dimensions(), (160, 120));
        // A particle near the cloth's corner, projected with the run's camera, is drawn in the
        // satin's rose.
        let (p, _) = tented_grid(N, 0.3, 0.002, 0.08 * k as f32 / 4.0);
        let q = summary.camera.project(p[N + 1], [160, 120]).unwrap();
        let c = img.get_pixel(q[0] as u32, q[1] as u32).0;
        assert!(
            c[0] as i32 > c[1] as i32 + 12,
            "frame {k}: cloth drawn as {c:?}"
        );
        // run.json's sphere collider is drawn, blue-grey, where it is.
        let q = summary
            .camera
            .project([0.3, 0.05, 0.0], [160, 120])
            .unwrap();
        let c = img.get_pixel(q[0] as u32, q[1] as u32).0;
        assert!(
            c[2] as i32 > c[0] as i32 + 15,
            "frame {k}: sphere drawn as {c:?}"
        );
    }
    match (&summary.video, wetcloth_render::ffmpeg_available()) {
        (VideoOutcome::Written(p), true) => {
            assert_eq!(p, &dir.join("render/test-tent.mp4"));
            assert!(std::fs::metadata(p).unwrap().len() > 1000);
        }
        (VideoOutcome::FfmpegMissing, false) => {
            assert!(summary.to_string().contains("ffmpeg is not on the PATH"));
        }
        (v, has) => panic!("video {v:?} with ffmpeg available: {has}"),
    }
}

#[test]
fn options_select_frames_camera_and_output_and_run_json_may_be_missing() {
    let dir = fresh_dir("options");
    write_run(&dir, 6, false);
    let out = dir.join("elsewhere");
    let o = RenderOptions {
        out_dir: Some(out.clone()),
        frames: Some("1..=5:2".parse::<FrameSelection>().unwrap()),
        camera: Some("yaw=0;pitch=89;distance=0.7".parse::<CameraSpec>().unwrap()),
        particles: true,
        video: false,
        ..opts(&dir)
    };
    let summary = render_run(o).unwrap();
    let names: Vec<String> = summary
        .images
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        ["frame_0001.png", "frame_0003.png", "frame_0005.png"]
    );
    assert!(out.join("frame_0003.png").exists());
    assert_eq!(summary.video, VideoOutcome::Disabled);
    // Looking straight down from 0.7 m: the cloth's centre is the image centre, and the table
    // (the default plane y = 0 without run.json) surrounds it.
    let img = image::open(out.join("frame_0001.png")).unwrap().to_rgba8();
    let c = img.get_pixel(80, 60).0;
    assert!(c[0] as i32 > c[1] as i32 + 12, "centre drawn as {c:?}");
    let t = img.get_pixel(3, 60).0;
    assert!(
        (t[0] as i32 - t[2] as i32).abs() < 12,
        "table drawn as {t:?}"
    );
}

#[test]
fn missing_and_malformed_inputs_are_reported_with_their_file() {
    let dir = fresh_dir("errors");
    let e = render_run(opts(&dir)).unwrap_err();
    assert!(matches!(e, RenderError::NoFrames(_)), "{e}");
    assert!(e.to_string().contains("frames/frame_NNNN.obj"), "{e}");

    write_run(&dir, 1, true);
    std::fs::write(
        dir.join("run.json"),
        "{\n  \"name\": \"x\",\n  \"frame_rate\": oops\n}\n",
    )
    .unwrap();
    let e = render_run(opts(&dir)).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("run.json:3"), "{msg}");

    std::fs::remove_file(dir.join("run.json")).unwrap();
    std::fs::write(dir.join("frames/frame_0000.obj"), "v 1 2\nf 1 2 3\n").unwrap();
    let msg = render_run(opts(&dir)).unwrap_err().to_string();
    assert!(msg.contains("frame_0000.obj"), "{msg}");

    let e = render_run(RenderOptions {
        frames: Some("50..60".parse().unwrap()),
        ..opts(&dir)
    })
    .unwrap_err();
    assert!(matches!(e, RenderError::NoFramesSelected { .. }), "{e}");
}

/// A cloth of any shape: five vertices, a quad and a triangle beside it (front side up), 2 mm
/// above the table; the triangle's far corner rises with `lift` (m).
fn mesh_frame(lift: f32) -> ([[f32; 3]; 5], String) {
    let y = 0.002;
    let p = [
        [-0.1, y, -0.1],
        [-0.1, y, 0.1],
        [0.1, y, 0.1],
        [0.1, y, -0.1],
        [0.3, y + lift, 0.0],
    ];
    let mut s = String::from("# wetcloth cloth mesh: 5 particles, 2 faces\no cloth\n");
    for v in &p {
        writeln!(s, "v {} {} {}", v[0], v[1], v[2]).unwrap();
    }
    for uv in ["0 0", "0 1", "1 1", "1 0", "1.5 0.5"] {
        writeln!(s, "vt {uv}").unwrap();
    }
    for _ in &p {
        writeln!(s, "vn 0 1 0").unwrap();
    }
    s += "f 1/1/1 2/2/2 3/3/3 4/4/4\nf 4/4/4 3/3/3 5/5/5\n";
    (p, s)
}

/// A mesh run as `wetcloth run` writes it for a cloth of any shape: run.json's `mesh` gives the
/// vertex and face counts (a stale `resolution` and `grabs` beside it mean nothing), the frames
/// keep the file's polygons.
fn write_mesh_run(dir: &Path, frames: usize) {
    std::fs::create_dir_all(dir.join("frames")).unwrap();
    for f in 0..frames {
        let (_, text) = mesh_frame(0.05 * f as f32);
        std::fs::write(dir.join(format!("frames/frame_{f:04}.obj")), text).unwrap();
    }
    let json = serde_json::json!({
        "name": "test-mesh",
        "resolution": [40, 40],
        "mesh": {"file": "/somewhere/patch.obj", "copy": "meshes/cloth-0.obj", "vertices": 5,
                 "faces": 2, "texture_coordinates": 5},
        "particle_radius": 0.002,
        "time_step": 0.0001,
        "frame_rate": 24.0,
        "duration": 1.0,
        "frames": frames,
        "complete": true,
        "status": "complete",
        "colliders": [
            {"shape": "plane", "point": [0.0, 0.0, 0.0], "normal": [0.0, 1.0, 0.0], "friction": 0.6}
        ],
        "grabs": [[39, 39]]
    });
    std::fs::write(
        dir.join("run.json"),
        serde_json::to_string_pretty(&json).unwrap(),
    )
    .unwrap();
}

#[test]
fn a_mesh_run_renders_its_polygons() {
    let dir = fresh_dir("mesh");
    write_mesh_run(&dir, 2);
    let check = wetcloth_render::check_run(&dir).unwrap();
    assert_eq!(
        (check.frames, check.vertices, check.faces, check.triangles),
        (2, 5, 2, 3)
    );
    let info = check.info.unwrap();
    assert_eq!(
        info.mesh.as_ref().map(|m| (m.vertices, m.faces)),
        Some((5, 2))
    );
    assert_eq!(
        info.resolution,
        [0, 0],
        "a mesh run's resolution means nothing"
    );
    assert!(info.grabs.is_empty());
    let summary = render_run(RenderOptions {
        video: false,
        particles: true,
        show_grabs: true,
        ..opts(&dir)
    })
    .expect("render_run failed (a graphics adapter is needed: mesa-vulkan-drivers)");
    assert_eq!(summary.images.len(), 2);
    for (k, png) in summary.images.iter().enumerate() {
        let img = image::open(png).unwrap().to_rgba8();
        let (p, _) = mesh_frame(0.05 * k as f32);
        // The quad's middle and the triangle's are the satin's rose.
        let centroid = |v: &[usize]| {
            let mut c = [0.0f32; 3];
            for &i in v {
                for a in 0..3 {
                    c[a] += p[i][a] / v.len() as f32;
                }
            }
            c
        };
        for (what, at) in [
            ("quad", centroid(&[0, 1, 2, 3])),
            ("triangle", centroid(&[3, 2, 4])),
        ] {
            let q = summary.camera.project(at, [160, 120]).unwrap();
            let c = img.get_pixel(q[0] as u32, q[1] as u32).0;
            assert!(
                c[0] as i32 > c[1] as i32 + 12,
                "frame {k}: the {what} drawn as {c:?}"
            );
        }
        // Beside the quad is table.
        let q = summary
            .camera
            .project([-0.16, 0.0, 0.0], [160, 120])
            .unwrap();
        let c = img.get_pixel(q[0] as u32, q[1] as u32).0;
        assert!(
            (c[0] as i32 - c[2] as i32).abs() < 12,
            "frame {k}: table drawn as {c:?}"
        );
    }
}

#[test]
fn a_mesh_run_without_run_json_is_checked_against_its_header() {
    let dir = fresh_dir("mesh-header");
    write_mesh_run(&dir, 2);
    std::fs::remove_file(dir.join("run.json")).unwrap();
    let check = wetcloth_render::check_run(&dir).unwrap();
    assert_eq!((check.vertices, check.faces), (5, 2));
    // A frame with a face too many for its header is refused, naming the file.
    let (_, text) = mesh_frame(0.0);
    std::fs::write(
        dir.join("frames/frame_0001.obj"),
        text + "f 1/1/1 2/2/2 3/3/3\n",
    )
    .unwrap();
    let msg = wetcloth_render::check_run(&dir).unwrap_err().to_string();
    for part in ["frame_0001.obj", "3 faces", "has 2", "the header of"] {
        assert!(msg.contains(part), "missing {part:?} in: {msg}");
    }
}

/// `plot` reads only `metrics.csv` (and the name from run.json): a mesh run's plots the same.
#[test]
fn a_mesh_run_plots_its_metrics() {
    let dir = fresh_dir("mesh-plot");
    write_mesh_run(&dir, 2);
    let header = wetcloth_export::csv_header();
    let columns = header.split(',').count();
    let mut csv = header + "\n";
    for frame in 0..3 {
        let mut row = vec![frame.to_string(), format!("{}", frame as f64 / 24.0)];
        row.extend((2..columns).map(|c| format!("{}", 0.1 * (c + frame) as f64)));
        csv += &(row.join(",") + "\n");
    }
    std::fs::write(dir.join("metrics.csv"), csv).unwrap();
    let png = wetcloth_render::plot_run(&dir).unwrap();
    assert_eq!(png, dir.join("metrics.png"));
    assert!(image::open(&png).unwrap().width() > 100);
}
