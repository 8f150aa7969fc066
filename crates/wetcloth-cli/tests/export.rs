//! `wetcloth export` and `wetcloth run --export` end to end: the files, their bytes against the
//! frames, errors and exit codes, and the programs that read the caches: USD (`usd-core`,
//! `tools/usd_check.py`), Alembic (`alembic3d`, `tools/abc_check.py`) and Blender
//! (`tools/blender_cache_check.py`).
//!
//! The reader tests skip with a message when the reader is not installed, and fail instead when
//! `WETCLOTH_REQUIRE_TOOLS=1` (as CI sets it). Python is `python3`, or `WETCLOTH_PYTHON`.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli-export")
        .join(test);
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn tools() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools")
}

fn wetcloth(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("the wetcloth binary runs")
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// An 8 x 8 cloth pinched up on a plane, with a sphere and a box beside it: 11 frames.
const SMALL: &str = r#"
name = "small-pinch"
[simulation]
duration = 0.25
frame_rate = 40
[cloth]
resolution = [8, 8]
damping = 2.0
[air]
trapped_air = 0.0
[[collider]]
shape = "plane"
friction = 0.6
[[collider]]
shape = "sphere"
center = [0.3, 0.1, 0.0]
radius = 0.05
[[collider]]
shape = "box"
center = [-0.3, 0.05, 0.1]
half_extents = [0.05, 0.05, 0.1]
[[grab]]
particle = [4, 4]
keys = [{ time = 0.05, offset = [0, 0, 0] }, { time = 0.2, offset = [0, 0.03, 0] }]
"#;
const SMALL_FRAMES: usize = 11;
const SMALL_VERTICES: usize = 64;

/// Runs `scene` into `dir/run` with the extra arguments, and returns the run folder.
fn run(dir: &Path, scene: &str, extra: &[&str]) -> PathBuf {
    let scene_path = dir.join("scene.toml");
    fs::write(&scene_path, scene).unwrap();
    let out = dir.join("run");
    let mut args = vec![
        "run",
        scene_path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let o = wetcloth(&args);
    assert!(o.status.success(), "{}", text(&o));
    out
}

/// The `v` lines of an OBJ frame as f32, as the caches store them.
fn obj_positions(path: &Path) -> Vec<[f32; 3]> {
    fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f64> = l.split(' ').map(|w| w.parse().unwrap()).collect();
            [v[0] as f32, v[1] as f32, v[2] as f32]
        })
        .collect()
}

fn frame(run: &Path, k: usize) -> PathBuf {
    run.join("frames").join(format!("frame_{k:04}.obj"))
}

#[test]
fn export_writes_each_format_under_its_default_name_with_the_frames_positions() {
    let dir = scratch("formats");
    let run = run(&dir, SMALL, &[]);
    // `run` writes rest.obj itself: frame 0, byte for byte.
    assert_eq!(
        fs::read(run.join("rest.obj")).unwrap(),
        fs::read(frame(&run, 0)).unwrap()
    );
    fs::remove_file(run.join("rest.obj")).unwrap();
    for format in ["pc2", "mdd", "usda", "usdc"] {
        let o = wetcloth(&["export", run.to_str().unwrap(), "--format", format]);
        assert!(o.status.success(), "{format}: {}", text(&o));
        let file = run.join(format!("small-pinch.{format}"));
        assert!(
            text(&o).contains(&format!("wrote {}", file.display())),
            "{}",
            text(&o)
        );
        assert!(file.is_file(), "{}", file.display());
        assert!(!run.join(format!("small-pinch.{format}.part")).exists());
    }
    assert_eq!(
        fs::read(run.join("rest.obj")).unwrap(),
        fs::read(frame(&run, 0)).unwrap(),
        "export writes rest.obj too"
    );

    // Point caches: header, then every frame's positions exactly as f32 of the OBJ's.
    let pc2 = fs::read(run.join("small-pinch.pc2")).unwrap();
    let mdd = fs::read(run.join("small-pinch.mdd")).unwrap();
    let per_frame = SMALL_VERTICES * 12;
    assert_eq!(pc2.len(), 32 + SMALL_FRAMES * per_frame);
    assert_eq!(mdd.len(), 8 + 4 * SMALL_FRAMES + SMALL_FRAMES * per_frame);
    assert_eq!(&pc2[..12], b"POINTCACHE2\0");
    assert_eq!(pc2[20..24], 0f32.to_le_bytes(), "start frame 0");
    assert_eq!(pc2[24..28], 1f32.to_le_bytes(), "one sample per frame");
    assert_eq!(pc2[28..32], (SMALL_FRAMES as i32).to_le_bytes());
    assert_eq!(mdd[..4], (SMALL_FRAMES as i32).to_be_bytes());
    assert_eq!(mdd[4..8], (SMALL_VERTICES as i32).to_be_bytes());
    let t10 = f32::from_be_bytes(mdd[8 + 40..8 + 44].try_into().unwrap());
    assert_eq!(t10, 0.25, "frame 10 at 10 / 40 s");
    for k in [0, 5, SMALL_FRAMES - 1] {
        let want = obj_positions(&frame(&run, k));
        for (v, p) in want.iter().enumerate() {
            for a in 0..3 {
                let i = (k * SMALL_VERTICES + v) * 12 + a * 4;
                let le = f32::from_le_bytes(pc2[32 + i..36 + i].try_into().unwrap());
                let mdd_at = 8 + 4 * SMALL_FRAMES + i;
                let be = f32::from_be_bytes(mdd[mdd_at..mdd_at + 4].try_into().unwrap());
                assert_eq!((le, be), (p[a], p[a]), "frame {k} vertex {v} axis {a}");
            }
        }
    }

    // USD text: the stage's key lines.
    let usda = fs::read_to_string(run.join("small-pinch.usda")).unwrap();
    for want in [
        "upAxis = \"Y\"",
        "metersPerUnit = 1.0",
        "timeCodesPerSecond = 40.0",
        "endTimeCode = 10.0",
        "def Mesh \"cloth\"",
        "point3f[] points.timeSamples = {",
        "def Mesh \"plane_0\"",
        "def Sphere \"sphere_1\"",
        "def Cube \"box_2\"",
        "custom int2 wetcloth:cloth:resolution = (8, 8)",
    ] {
        assert!(usda.contains(want), "{want}");
    }
    let usdc = fs::read(run.join("small-pinch.usdc")).unwrap();
    assert_eq!(&usdc[..8], b"PXR-USDC");

    // --out puts the file elsewhere.
    let elsewhere = dir.join("cache.bin");
    let o = wetcloth(&[
        "export",
        run.to_str().unwrap(),
        "--format",
        "pc2",
        "--out",
        elsewhere.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(o.stdout.is_empty(), "--quiet prints nothing");
    assert_eq!(fs::read(&elsewhere).unwrap(), pc2);
}

#[test]
fn run_export_writes_the_same_bytes_as_export_run_after_run() {
    let dir = scratch("run-export");
    let run = run(&dir, SMALL, &["--export", "usdc,pc2"]);
    let usdc = fs::read(run.join("small-pinch.usdc")).unwrap();
    let pc2 = fs::read(run.join("small-pinch.pc2")).unwrap();
    assert!(!run.join("small-pinch.mdd").exists());
    for (format, bytes) in [("usdc", &usdc), ("pc2", &pc2)] {
        let again = dir.join(format!("again.{format}"));
        let o = wetcloth(&[
            "export",
            run.to_str().unwrap(),
            "-f",
            format,
            "-o",
            again.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
        assert!(fs::read(&again).unwrap() == *bytes, "{format} differs");
    }
    // A second run, on one thread, gives identical caches.
    let dir2 = scratch("run-export-2");
    let run2 = run_threads(&dir2, SMALL);
    assert!(fs::read(run2.join("small-pinch.usdc")).unwrap() == usdc);
    assert!(fs::read(run2.join("small-pinch.pc2")).unwrap() == pc2);
}

fn run_threads(dir: &Path, scene: &str) -> PathBuf {
    run(dir, scene, &["--export", "pc2,usdc", "--threads", "1"])
}

#[test]
fn a_bad_format_list_is_refused_before_running() {
    let dir = scratch("bad-list");
    let scene = dir.join("s.toml");
    fs::write(&scene, SMALL).unwrap();
    let o = wetcloth(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        dir.join("run").to_str().unwrap(),
        "--export",
        "usdc,fbx",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("unknown cache format `fbx`"),
        "{}",
        text(&o)
    );
    assert!(!dir.join("run").exists(), "nothing ran");
    let o = wetcloth(&["export", dir.to_str().unwrap(), "--format", "fbx"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("pc2, mdd, usda, usdc, abc"),
        "{}",
        text(&o)
    );
}

/// Runs `wetcloth export` on a damaged copy of `run` and returns its output, checking exit 2.
fn export_damaged(run: &Path, damage: impl FnOnce(&Path)) -> String {
    let copy = run.with_file_name(format!(
        "{}-damaged",
        run.file_name().unwrap().to_string_lossy()
    ));
    let _ = fs::remove_dir_all(&copy);
    fs::create_dir_all(copy.join("frames")).unwrap();
    for entry in fs::read_dir(run).unwrap().flatten() {
        if entry.path().is_file() {
            fs::copy(entry.path(), copy.join(entry.file_name())).unwrap();
        }
    }
    for entry in fs::read_dir(run.join("frames")).unwrap().flatten() {
        fs::copy(entry.path(), copy.join("frames").join(entry.file_name())).unwrap();
    }
    damage(&copy);
    let o = wetcloth(&["export", copy.to_str().unwrap(), "--format", "usdc"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(!t.contains("panicked"), "{t}");
    assert!(
        !copy.join("small-pinch.usdc").exists(),
        "no cache named as complete"
    );
    t
}

#[test]
fn bad_run_folders_exit_2_naming_the_file_and_what_is_wrong() {
    let dir = scratch("bad-input");
    let missing = dir.join("nowhere");
    let o = wetcloth(&["export", missing.to_str().unwrap(), "--format", "pc2"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("nowhere: no such run folder"),
        "{}",
        text(&o)
    );

    let run = run(&dir, SMALL, &[]);
    // A frame cut short: it names the frame and says it is truncated.
    let t = export_damaged(&run, |d| {
        let f = frame(d, 7);
        let bytes = fs::read(&f).unwrap();
        fs::write(&f, &bytes[..bytes.len() / 3]).unwrap();
    });
    assert!(t.contains("frame_0007.obj"), "{t}");
    assert!(t.contains("truncated"), "{t}");
    // A damaged number: file and line.
    let t = export_damaged(&run, |d| {
        let f = frame(d, 3);
        let s = fs::read_to_string(&f).unwrap();
        let mut lines: Vec<String> = s.lines().map(String::from).collect();
        lines[4] = "v 0.1 x 0.2".into();
        fs::write(&f, lines.join("\n")).unwrap();
    });
    assert!(t.contains("frame_0003.obj:5:"), "{t}");
    assert!(t.contains("`v 0.1 x 0.2`"), "{t}");
    // run.json with another resolution than the frames.
    let t = export_damaged(&run, |d| {
        let p = d.join("run.json");
        let s = fs::read_to_string(&p).unwrap();
        fs::write(&p, s.replacen("8,\n    8", "8,\n    9", 1)).unwrap();
    });
    assert!(t.contains("frame_0000.obj"), "{t}");
    assert!(
        t.contains("has 64 vertices (v lines) where run.json's resolution means 72"),
        "{t}"
    );
    // A frame missing.
    let t = export_damaged(&run, |d| fs::remove_file(frame(d, 10)).unwrap());
    assert!(t.contains("frame_0010.obj: cannot read"), "{t}");
    assert!(t.contains("run.json says the run wrote 11 frames"), "{t}");
    // No run.json, or a broken one.
    let t = export_damaged(&run, |d| fs::remove_file(d.join("run.json")).unwrap());
    assert!(t.contains("run.json: cannot read"), "{t}");
    let t = export_damaged(&run, |d| {
        fs::write(d.join("run.json"), "{\"name\": 1}").unwrap()
    });
    assert!(
        t.contains("run.json:1:") && t.contains("not a wetcloth run.json"),
        "{t}"
    );
}

/// Whether a reader is installed; when it is not, skip with `why`, or fail when
/// `WETCLOTH_REQUIRE_TOOLS=1`.
fn have(available: bool, why: &str) -> bool {
    if available {
        return true;
    }
    assert!(
        std::env::var("WETCLOTH_REQUIRE_TOOLS").as_deref() != Ok("1"),
        "WETCLOTH_REQUIRE_TOOLS=1 but {why}"
    );
    eprintln!("skipping: {why} (set WETCLOTH_REQUIRE_TOOLS=1 to make this a failure)");
    false
}

fn python() -> String {
    std::env::var("WETCLOTH_PYTHON").unwrap_or_else(|_| "python3".into())
}

#[test]
fn usd_reads_both_usd_files_as_the_frames_and_finds_them_compliant() {
    let py = python();
    let ok = Command::new(&py)
        .args(["-c", "from pxr import UsdUtils; UsdUtils.ComplianceChecker"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !have(
        ok,
        &format!(
            "`{py}` cannot import pxr with UsdUtils.ComplianceChecker (pip install usd-core==26.5)"
        ),
    ) {
        return;
    }
    let dir = scratch("usd");
    let run = run(&dir, SMALL, &["--export", "usda,usdc"]);
    let o = Command::new(&py)
        .arg(tools().join("usd_check.py"))
        .arg(&run)
        .arg(run.join("small-pinch.usda"))
        .arg(run.join("small-pinch.usdc"))
        .output()
        .unwrap();
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("USD check passed"), "{t}");
    assert!(t.contains("2 files hold the same layer data"), "{t}");
    assert!(t.contains("0 errors, 0 failed checks"), "{t}");
}

/// The small pinch with moving colliders: the sphere slides along x, the box rises and turns
/// about y and z (its keys' rotations), the plane stays: 11 frames at 40 per second.
const MOVING: &str = r#"
name = "moving-pinch"
[simulation]
duration = 0.25
frame_rate = 40
[cloth]
resolution = [8, 8]
damping = 2.0
[air]
trapped_air = 0.0
[[collider]]
shape = "plane"
friction = 0.6
[[collider]]
shape = "sphere"
center = [0.3, 0.1, 0.0]
radius = 0.05
keys = [{ time = 0.0, offset = [0, 0, 0] }, { time = 0.25, offset = [0.1, 0, 0] }]
[[collider]]
shape = "box"
center = [-0.3, 0.05, 0.1]
half_extents = [0.05, 0.05, 0.1]
keys = [
  { time = 0.05, offset = [0, 0, 0] },
  { time = 0.2, offset = [0, 0.02, 0], rotation = [0, 30, 10] },
]
[[grab]]
particle = [4, 4]
keys = [{ time = 0.05, offset = [0, 0, 0] }, { time = 0.2, offset = [0, 0.03, 0] }]
"#;

/// The reference Alembic library (`alembic3d`, its Python bindings) reads the archive as the
/// frames: one PolyMesh with constant topology, rest.obj's faces (clockwise), the UVs, every
/// frame's points as float32, the time sampling at the frame rate, the colliders where
/// run.json puts them (the moving ones at every checked frame) and the scene's parameters.
#[test]
fn alembic_reads_the_archive_as_the_frames() {
    let py = python();
    let ok = Command::new(&py)
        .args(["-c", "import alembic3d"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !have(
        ok,
        &format!("`{py}` cannot import alembic3d (pip install alembic3d==1.8.12.1)"),
    ) {
        return;
    }
    let check = |run: &Path, file: &str| {
        let o = Command::new(&py)
            .arg(tools().join("abc_check.py"))
            .arg(run)
            .arg(run.join(file))
            .output()
            .unwrap();
        let t = text(&o);
        assert!(o.status.success(), "{t}");
        assert!(t.contains("Alembic check passed"), "{t}");
        t
    };
    let dir = scratch("abc-moving");
    let moving = run(&dir, MOVING, &["--export", "abc"]);
    let t = check(&moving, "moving-pinch.abc");
    assert!(t.contains("sphere_1: moving, 11 transform samples"), "{t}");
    assert!(t.contains("box_2: moving, 11 transform samples"), "{t}");
    assert!(
        t.contains("PolyMesh with 98 faces, 11 samples at 40 per second"),
        "{t}"
    );
    // `export` writes the same bytes as `run --export`.
    let again = dir.join("again.abc");
    let o = wetcloth(&[
        "export",
        moving.to_str().unwrap(),
        "-f",
        "abc",
        "-o",
        again.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(fs::read(&again).unwrap() == fs::read(moving.join("moving-pinch.abc")).unwrap());

    let dir = scratch("abc-drape");
    let drape = run(&dir, DRAPE, &["--export", "abc"]);
    let t = check(&drape, "drape-100.abc");
    assert!(
        t.contains("PolyMesh with 19602 faces, 100 samples at 500 per second"),
        "{t}"
    );
}

/// A 100 x 100 cloth dropped over a sphere: 100 frames (about 270 MB of output by the run's
/// estimate, so that a machine with little free disk still runs it).
const DRAPE: &str = r#"
name = "drape-100"
[simulation]
duration = 0.198
frame_rate = 500
time_step = 1e-4
[cloth]
resolution = [100, 100]
size = [0.6, 0.6]
position = [0.0, 0.2, 0.0]
mass = 0.2
damping = 1.0
self_collision = false
[air]
enabled = false
[[collider]]
shape = "plane"
friction = 0.5
[[collider]]
shape = "sphere"
center = [0.0, 0.08, 0.0]
radius = 0.08
friction = 0.3
"#;

#[test]
fn blender_applies_pc2_and_mdd_as_the_frames() {
    let ok = Command::new("blender")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !have(ok, "`blender` is not installed (apt-get install blender)") {
        return;
    }
    let blender = |run: &Path, frames: &str| {
        let o = Command::new("blender")
            .args([
                "-b",
                "--factory-startup",
                "--python-exit-code",
                "1",
                "--python",
            ])
            .arg(tools().join("blender_cache_check.py"))
            .arg("--")
            .arg(run)
            .args(["--frames", frames])
            .output()
            .unwrap();
        let t = text(&o);
        assert!(o.status.success(), "{t}");
        assert!(t.contains("Blender cache check passed"), "{t}");
        t
    };
    let dir = scratch("blender-small");
    let small = run(&dir, SMALL, &["--export", "pc2,mdd"]);
    let t = blender(&small, "0,1,5,10");
    assert!(t.contains("mdd (time mode) frame 10"), "{t}");

    let dir = scratch("blender-drape");
    let drape = run(&dir, DRAPE, &["--export", "pc2,mdd"]);
    let t = blender(&drape, "0,1,50,99");
    assert!(
        t.contains("pc2 (frame mode) frame 99: 10000 vertices"),
        "{t}"
    );
}
