//! A mesh cloth (`[cloth] mesh`) through every output, end to end: the frames and rest.obj
//! keep the file's faces (quads stay quads, corners in the file's order and winding) and its
//! texture coordinates with their seams; run.json describes the mesh; the copy of the mesh in
//! the run folder lets `export` and `--resume` work when the original is gone; every cache
//! format exports; grabs.csv's forces sum to metrics.csv's grab_force. The readers (USD,
//! Alembic, Blender) check the caches where they are installed (as in `export.rs`: skipped
//! unless `WETCLOTH_REQUIRE_TOOLS=1`).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

/// A 20 x 20 cm towel in centimetres: four quads, and two triangles beside them on a texture
/// island of their own (vertices 3 and 6 have one texture coordinate in the quads and another
/// in the triangles: a seam). Normals, a group and comments, which the outputs do not copy.
const TOWEL: &str = "# towel
o towel
v 0 0 0
v 10 0 0
v 20 0 0
v 0 0 10
v 10 0 10
v 20 0 10
v 0 0 20
v 10 0 20
v 20 0 20
v 30 0 0
v 30 0 10
vt 0 0
vt 0.5 0
vt 1 0
vt 0 0.5
vt 0.5 0.5
vt 1 0.5
vt 0 1
vt 0.5 1
vt 1 1
vt 0.8 0
vt 0.8 0.5
vt 1 0.5
vt 1 0
vn 0 1 0
g cloth
f 1/1/1 4/4/1 5/5/1 2/2/1
f 2/2/1 5/5/1 6/6/1 3/3/1
f 4/4/1 7/7/1 8/8/1 5/5/1
f 5/5/1 8/8/1 9/9/1 6/6/1
f 3/10/1 6/11/1 11/12/1
f 3/10/1 11/12/1 10/13/1
";

/// The towel's faces as 0-based vertex and texture-coordinate indices.
const FACES: [&[(u32, u32)]; 6] = [
    &[(0, 0), (3, 3), (4, 4), (1, 1)],
    &[(1, 1), (4, 4), (5, 5), (2, 2)],
    &[(3, 3), (6, 6), (7, 7), (4, 4)],
    &[(4, 4), (7, 7), (8, 8), (5, 5)],
    &[(2, 9), (5, 10), (10, 11)],
    &[(2, 9), (10, 11), (9, 12)],
];

/// The towel placed 2 cm above a table, turned 30 degrees about y, pinched at its middle
/// vertex and lifted while its corner is held: 11 frames at 100 per second.
const SCENE: &str = r#"
name = "towel"
[simulation]
duration = 0.1
frame_rate = 100
[cloth]
mesh = "towel.obj"
scale = 0.01
rotation = [0, 30, 0]
position = [0, 0.02, 0]
mass = 0.005
damping = 2.0
self_collision = false
[air]
enabled = false
[[collider]]
shape = "plane"
friction = 0.6
[[grab]]
vertex = 4
keys = [{ time = 0.0, offset = [0, 0, 0] }, { time = 0.1, offset = [0, 0.03, 0] }]
[[grab]]
vertex = 6
keys = [{ time = 0.0, offset = [0, 0, 0] }]
"#;

fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli-mesh-outputs")
        .join(test);
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn wetcloth(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Writes the towel and its scene into `dir/input` and runs it into `dir/run` with `extra`
/// arguments; returns the run folder.
fn run(dir: &Path, extra: &[&str]) -> PathBuf {
    let input = dir.join("input");
    fs::create_dir_all(&input).unwrap();
    fs::write(input.join("towel.obj"), TOWEL).unwrap();
    fs::write(input.join("scene.toml"), SCENE).unwrap();
    let out = dir.join("run");
    let scene = input.join("scene.toml");
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let o = wetcloth(&args);
    assert!(o.status.success(), "{}", text(&o));
    out
}

/// The `f` lines of an OBJ file as (vertex, texture coordinate) pairs, 0-based, and each
/// corner's normal index (which must be its vertex).
fn faces(obj: &str) -> Vec<Vec<(u32, u32)>> {
    obj.lines()
        .filter_map(|l| l.strip_prefix("f "))
        .map(|f| {
            f.split_whitespace()
                .map(|c| {
                    let p: Vec<u32> = c.split('/').map(|x| x.parse().unwrap()).collect();
                    assert_eq!(p.len(), 3, "{c}");
                    assert_eq!(p[2], p[0], "a corner's normal is its vertex's: {c}");
                    (p[0] - 1, p[1] - 1)
                })
                .collect()
        })
        .collect()
}

fn lines<'a>(obj: &'a str, tag: &str) -> Vec<&'a str> {
    obj.lines().filter(|l| l.starts_with(tag)).collect()
}

fn csv(path: &Path) -> (String, Vec<Vec<f64>>) {
    let t = fs::read_to_string(path).unwrap();
    let mut it = t.lines();
    let header = it.next().unwrap().to_string();
    let rows = it
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn frames_keep_the_files_faces_and_seams_and_every_cache_exports() {
    let dir = scratch("frames");
    let run = run(&dir, &["--export", "pc2,mdd,usda,usdc,abc"]);

    // Frames and rest.obj: the file's polygons and texture coordinates, 11 vertices in order.
    let frame0 = fs::read_to_string(run.join("frames/frame_0000.obj")).unwrap();
    let rest = fs::read_to_string(run.join("rest.obj")).unwrap();
    assert_eq!(rest, frame0);
    assert!(frame0.starts_with("# wetcloth cloth mesh: 11 particles, 6 faces\no cloth\n"));
    let want: Vec<Vec<(u32, u32)>> = FACES.iter().map(|f| f.to_vec()).collect();
    let vt_file = lines(TOWEL, "vt ");
    for k in [0, 5, 10] {
        let f = fs::read_to_string(run.join(format!("frames/frame_{k:04}.obj"))).unwrap();
        assert_eq!(faces(&f), want, "frame {k}");
        assert_eq!(lines(&f, "v ").len(), 11);
        assert_eq!(lines(&f, "vn ").len(), 11);
        let vt: Vec<[f64; 2]> = lines(&f, "vt ")
            .iter()
            .map(|l| {
                let w: Vec<f64> = l[3..].split(' ').map(|x| x.parse().unwrap()).collect();
                [w[0], w[1]]
            })
            .collect();
        let vt_want: Vec<[f64; 2]> = vt_file
            .iter()
            .map(|l| {
                let w: Vec<f64> = l[3..].split(' ').map(|x| x.parse().unwrap()).collect();
                [w[0], w[1]]
            })
            .collect();
        assert_eq!(vt, vt_want, "frame {k}");
    }
    // Frame 0 is the file placed: vertex k at position + R (0.01 v_k), R 30 degrees about y.
    let v0: Vec<Vec<f64>> = lines(&frame0, "v ")
        .iter()
        .map(|l| l[2..].split(' ').map(|x| x.parse().unwrap()).collect())
        .collect();
    let (s, c) = 30f64.to_radians().sin_cos();
    for (k, l) in lines(TOWEL, "v ").iter().enumerate() {
        let p: Vec<f64> = l[2..].split(' ').map(|x| x.parse().unwrap()).collect();
        let (x, z) = (0.01 * p[0], 0.01 * p[2]);
        let want = [c * x + s * z, 0.02, -s * x + c * z];
        for a in 0..3 {
            assert!(
                (v0[k][a] - want[a]).abs() < 1e-12,
                "vertex {k}: {:?}",
                v0[k]
            );
        }
    }
    // The lifted vertex 4 is above the held corner 6 at the end.
    let last = fs::read_to_string(run.join("frames/frame_0010.obj")).unwrap();
    let y: Vec<f64> = lines(&last, "v ")
        .iter()
        .map(|l| l.split(' ').nth(2).unwrap().parse().unwrap())
        .collect();
    assert!(y[4] > 0.045 && (y[6] - 0.02).abs() < 1e-9, "{y:?}");

    // run.json: the mesh instead of a resolution, and its copy in the folder.
    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(run.join("run.json")).unwrap()).unwrap();
    assert!(json.get("resolution").is_none() && json.get("size").is_none());
    let mesh = &json["mesh"];
    assert_eq!(mesh["vertices"], 11);
    assert_eq!(mesh["faces"], 6);
    assert_eq!(mesh["texture_coordinates"], 13);
    assert_eq!(mesh["scale"], 0.01);
    assert_eq!(mesh["rotation"], serde_json::json!([0.0, 30.0, 0.0]));
    assert!(mesh["file"].as_str().unwrap().ends_with("towel.obj"));
    let copy = mesh["copy"].as_str().unwrap();
    assert!(
        copy.starts_with("meshes/cloth-") && run.join(copy).is_file(),
        "{copy}"
    );
    assert_eq!(json["status"], "complete");
    assert_eq!(json["frames"], 11);

    // Every cache, each of the 11 vertices per frame.
    for ext in ["pc2", "mdd", "usda", "usdc", "abc"] {
        let f = run.join(format!("towel.{ext}"));
        assert!(fs::metadata(&f).unwrap().len() > 0, "{ext}");
    }
    let pc2 = fs::read(run.join("towel.pc2")).unwrap();
    assert_eq!(u32::from_le_bytes(pc2[16..20].try_into().unwrap()), 11);
    assert_eq!(pc2.len(), 32 + 11 * 11 * 12);
    // The USD text stage: the file's polygons and face-varying texture coordinates.
    let usda = fs::read_to_string(run.join("towel.usda")).unwrap();
    assert!(
        usda.contains("int[] faceVertexCounts = [4, 4, 4, 4, 3, 3]"),
        "{usda}"
    );
    assert!(usda.contains(
        "int[] faceVertexIndices = [0, 3, 4, 1, 1, 4, 5, 2, 3, 6, 7, 4, 4, 7, 8, 5, 2, 5, 10, 2, 10, 9]"
    ));
    assert!(usda.contains("interpolation = \"faceVarying\""));
    assert!(usda.contains(
        "int[] primvars:st:indices = [0, 3, 4, 1, 1, 4, 5, 2, 3, 6, 7, 4, 4, 7, 8, 5, 9, 10, 11, 9, 11, 12]"
    ));

    // `export` again from the folder with the original file gone: the same bytes.
    fs::remove_dir_all(dir.join("input")).unwrap();
    for ext in ["pc2", "usdc", "abc"] {
        let again = dir.join(format!("again.{ext}"));
        let o = wetcloth(&[
            "export",
            run.to_str().unwrap(),
            "-f",
            ext,
            "-o",
            again.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(o.status.success(), "{}", text(&o));
        assert!(
            fs::read(&again).unwrap() == fs::read(run.join(format!("towel.{ext}"))).unwrap(),
            "{ext}"
        );
    }
}

#[test]
fn grabs_csv_gives_each_grabs_force_and_they_sum_to_the_metrics() {
    let dir = scratch("grabs");
    let run = run(&dir, &[]);
    let (header, rows) = csv(&run.join("grabs.csv"));
    assert_eq!(header, "frame,time,grab,particles,force_x,force_y,force_z");
    assert_eq!(rows.len(), 2 * 11, "one row per grab per frame");
    let (_, metrics) = csv(&run.join("metrics.csv"));
    // The column of grab_force in metrics.csv.
    let grab_force = 8;
    for (k, m) in metrics.iter().enumerate() {
        let r: Vec<&Vec<f64>> = rows.iter().filter(|r| r[0] == k as f64).collect();
        assert_eq!(r.len(), 2);
        assert_eq!((r[0][2], r[1][2]), (0.0, 1.0), "grabs in scene order");
        assert_eq!((r[0][3], r[1][3]), (1.0, 1.0), "each holds one particle");
        assert_eq!(r[0][1], m[1], "the frame's time");
        let sum: Vec<f64> = (4..7).map(|a| r[0][a] + r[1][a]).collect();
        let norm = sum.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(
            (norm - m[grab_force]).abs() <= 1e-9 * m[grab_force].max(1e-12),
            "frame {k}: |{sum:?}| = {norm} vs grab_force {}",
            m[grab_force]
        );
    }
    // At the end the lifting grab pulls the cloth up, the corner held on the table down.
    let end: Vec<&Vec<f64>> = rows.iter().filter(|r| r[0] == 10.0).collect();
    assert!(end[0][5] > 0.0 && end[1][5] < 0.0, "{end:?}");

    // A grid run without grabs has the header alone.
    let grid = dir.join("grid.toml");
    fs::write(
        &grid,
        "[simulation]\nduration = 0.02\nframe_rate = 100\n[cloth]\nresolution = [4, 4]\n",
    )
    .unwrap();
    let out = dir.join("grid-run");
    let o = wetcloth(&[
        "run",
        grid.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        fs::read_to_string(out.join("grabs.csv")).unwrap(),
        "frame,time,grab,particles,force_x,force_y,force_z\n"
    );
}

/// Every file under `dir` with its bytes.
fn contents(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else {
                out.push((
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    fs::read(&p).unwrap(),
                ));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn a_resumed_mesh_run_reads_its_copy_and_matches_an_uninterrupted_one() {
    let dir = scratch("resume");
    let whole = run(&dir, &[]);
    let scene = dir.join("input/scene.toml");
    // A run that fails writing frame 5 (a folder stands where the file goes), after its
    // checkpoint at frame 4.
    let killed = dir.join("killed");
    let blocker = killed.join("frames/frame_0005.obj");
    fs::create_dir_all(blocker.join("x")).unwrap();
    let o = wetcloth(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        killed.to_str().unwrap(),
        "--quiet",
        "--checkpoint-every",
        "2",
    ]);
    assert!(!o.status.success());
    fs::remove_dir_all(&blocker).unwrap();
    // The original mesh moves away: the run goes on from its copy.
    fs::rename(dir.join("input"), dir.join("moved")).unwrap();
    let o = wetcloth(&["run", "--resume", killed.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", text(&o));
    let (a, b) = (contents(&whole), contents(&killed));
    assert_eq!(
        a.iter().map(|x| &x.0).collect::<Vec<_>>(),
        b.iter().map(|x| &x.0).collect::<Vec<_>>()
    );
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{} differs", name.display());
    }
    // A changed copy is refused.
    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(killed.join("run.json")).unwrap()).unwrap();
    let copy = killed.join(json["mesh"]["copy"].as_str().unwrap());
    let text0 = fs::read_to_string(&copy).unwrap();
    fs::write(&copy, text0.replacen("v 0.0 0.0 0.0", "v 0.0 1.0 0.0", 1)).unwrap();
    let o = wetcloth(&["export", killed.to_str().unwrap(), "-f", "pc2", "--quiet"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("the cloth's copy was changed"),
        "{}",
        text(&o)
    );
}

fn tools() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools")
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

fn runs(program: &str, args: &[&str]) -> bool {
    Command::new(program)
        .args(args)
        .output()
        .is_ok_and(|o| o.status.success())
}

/// USD itself reads both stages as the frames: the polygons, the indexed face-varying `st`
/// (flattened, each corner's `vt`), and the compliance checker finds no error.
#[test]
fn usd_reads_the_polygons_and_face_varying_uvs() {
    let py = python();
    let ok = runs(
        &py,
        &["-c", "from pxr import UsdUtils; UsdUtils.ComplianceChecker"],
    );
    if !have(
        ok,
        &format!("`{py}` cannot import pxr (pip install usd-core==26.5)"),
    ) {
        return;
    }
    let dir = scratch("usd");
    let run = run(&dir, &["--export", "usda,usdc"]);
    let o = Command::new(&py)
        .arg(tools().join("usd_check.py"))
        .arg(&run)
        .arg(run.join("towel.usda"))
        .arg(run.join("towel.usdc"))
        .output()
        .unwrap();
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("Mesh with 6 faces"), "{t}");
    assert!(t.contains("0 errors, 0 failed checks"), "{t}");
}

/// The reference Alembic library reads the polygons reversed and `uv` indexed per corner.
#[test]
fn alembic_reads_the_polygons_and_indexed_uvs() {
    let py = python();
    if !have(
        runs(&py, &["-c", "import alembic3d"]),
        &format!("`{py}` cannot import alembic3d (pip install alembic3d==1.8.12.1)"),
    ) {
        return;
    }
    let dir = scratch("abc");
    let run = run(&dir, &["--export", "abc"]);
    let o = Command::new(&py)
        .arg(tools().join("abc_check.py"))
        .arg(&run)
        .arg(run.join("towel.abc"))
        .output()
        .unwrap();
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("PolyMesh with 6 faces, 11 samples at 100 per second"),
        "{t}"
    );
}

/// Blender 3.4 imports the user's original towel.obj, and the Mesh Cache modifier with the
/// PC2 and then the MDD file moves its vertices to the frames' positions.
#[test]
fn blender_applies_the_point_caches_to_the_original_file() {
    if !have(
        runs("blender", &["--version"]),
        "`blender` is not installed (apt-get install blender)",
    ) {
        return;
    }
    let dir = scratch("blender");
    let run = run(&dir, &["--export", "pc2,mdd"]);
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
        .arg(&run)
        .args(["--frames", "0,1,5,10", "--obj"])
        .arg(dir.join("input/towel.obj"))
        .output()
        .unwrap();
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("towel.obj: 11 vertices, 6 faces"), "{t}");
    assert!(t.contains("Blender cache check passed"), "{t}");
    assert!(t.contains("pc2 (frame mode) frame 10: 11 vertices"), "{t}");
}
