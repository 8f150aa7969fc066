//! Runs that exit 0 must hold nothing that cannot be: every frame passed the checks, the files
//! stay small, a resume runs what the run read, and every refusal is located and readable.
//! Each test is named after what was found from outside.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli-honesty")
        .join(test);
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn wetcloth(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .expect("the wetcloth binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

fn run_json(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(dir.join("run.json")).unwrap()).unwrap()
}

/// A 10 x 10, 20 g cloth 5 cm above the table, air off, a 10 % strain limit, position Verlet at
/// 0.01 s (far above its stability limit), `steps` steps in frames of `frame_rate`.
fn unstable(steps: u32, frame_rate: u32) -> String {
    format!(
        "name = \"unstable\"\n[simulation]\nduration = {}\ntime_step = 0.01\nframe_rate = {frame_rate}\n\
         [cloth]\nresolution = [10, 10]\nmass = 0.02\nposition = [0, 0.05, 0]\nstrain_limit = 0.1\n\
         [air]\nenabled = false\n",
        f64::from(steps) * 0.01
    )
}

/// The energy audit ran every 128 steps only, so a run of 20 steps (or the last 127 steps of
/// any run) exited 0 with joules the fall cannot give. Now every frame passes it first.
#[test]
fn short_runs_are_audited() {
    let dir = scratch("short");
    for (steps, rate) in [(20, 50), (20, 5), (127, 10)] {
        let scene = write(&dir, "unstable.toml", &unstable(steps, rate));
        let out = dir.join(format!("out-{steps}-{rate}"));
        let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap(), "--quiet"]);
        assert_eq!(o.status.code(), Some(1), "{steps} steps: {}", stderr(&o));
        assert!(stderr(&o).contains("gained"), "{}", stderr(&o));
        let json = run_json(&out);
        assert_eq!(json["status"], "failed", "{json}");
        // Every frame written passed the audit: the kinetic energy in metrics.csv is within
        // what the fall gives (20 g from 5 cm: 0.01 J) and the audit's millijoule.
        let csv = fs::read_to_string(out.join("metrics.csv")).unwrap();
        let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
        let col = header.iter().position(|h| *h == "kinetic_energy").unwrap();
        for row in csv.lines().skip(1) {
            let e: f64 = row.split(',').nth(col).unwrap().parse().unwrap();
            assert!(e < 0.05, "a frame with {e} J was written: {row}");
        }
    }
}

/// A mesh of `n` x `n` quads over a square of side 1 (two triangles each), as OBJ text.
fn sheet_obj(n: usize) -> String {
    let mut s = String::new();
    for j in 0..=n {
        for i in 0..=n {
            s += &format!(
                "v {} 0 {}\n",
                i as f64 / n as f64 - 0.5,
                j as f64 / n as f64 - 0.5
            );
        }
    }
    let at = |i: usize, j: usize| j * (n + 1) + i + 1;
    for j in 0..n {
        for i in 0..n {
            s += &format!("f {} {} {}\n", at(i, j), at(i + 1, j + 1), at(i + 1, j));
            s += &format!("f {} {} {}\n", at(i, j), at(i, j + 1), at(i + 1, j + 1));
        }
    }
    s
}

/// A 4 x 4 cloth over a mesh sheet `mesh.obj`, two frames.
const ON_SHEET: &str = "name = \"sheet\"\n[simulation]\nduration = 0.02\nframe_rate = 50\n\
    [cloth]\nresolution = [4, 4]\nposition = [0, 0.01, 0]\n[air]\nenabled = false\n\
    [[collider]]\nshape = \"mesh\"\nfile = \"mesh.obj\"\n";

/// `run.json` held a mesh's triangles, about three times the OBJ's size, rewritten after every
/// frame (111 MB for a million triangles), and `render` refused it beyond about 150 000. Now
/// it names a copy of the model beside it with its digest: a few kilobytes whatever the mesh,
/// and `export` reads the mesh back from the copy.
#[test]
fn run_json_stays_small_with_large_meshes() {
    let dir = scratch("small-json");
    // 2 x 200 x 200 = 80 000 triangles: a 4 MB OBJ.
    fs::write(dir.join("mesh.obj"), sheet_obj(200)).unwrap();
    let scene = write(&dir, "sheet.toml", ON_SHEET);
    let out = dir.join("out");
    let o = wetcloth(&[
        "run",
        &scene,
        "--out",
        out.to_str().unwrap(),
        "-q",
        "--export",
        "usda",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let len = fs::metadata(out.join("run.json")).unwrap().len();
    assert!(len < 10_000, "run.json is {len} bytes");
    let json = run_json(&out);
    let mesh = &json["colliders"][0];
    assert_eq!(mesh["triangle_count"], 80_000);
    let copy = out.join(mesh["copy"].as_str().unwrap());
    assert!(fs::metadata(&copy).unwrap().len() > 1_000_000);
    // The exporter drew the mesh from the copy: 80 000 triangles.
    let usda = fs::read_to_string(out.join("sheet.usda")).unwrap();
    assert!(usda.contains("def Mesh \"mesh_0\""), "no mesh prim");
    // A copy changed after the run is refused, naming it.
    let text = fs::read_to_string(&copy)
        .unwrap()
        .replacen("v -0.5", "v -0.25", 1);
    fs::write(&copy, text).unwrap();
    let o = wetcloth(&["export", out.to_str().unwrap(), "--format", "usda"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the mesh's copy was changed") && stderr(&o).contains(".obj"),
        "{}",
        stderr(&o)
    );
}

/// `run --resume` went on after the mesh file was replaced, and the folder ended with frames
/// from two meshes. The checkpoint records what the run read; a resume refuses a changed
/// mesh, naming the file.
#[test]
fn resume_refuses_a_changed_mesh() {
    let dir = scratch("resume-mesh");
    fs::write(dir.join("mesh.obj"), sheet_obj(2)).unwrap();
    // A run that stops part way with a checkpoint: a grab tears the cloth after a few frames.
    let failing = ON_SHEET.replace("duration = 0.02", "duration = 1").replace(
        "[air]",
        "structural_stiffness = 1e5\n[[grab]]\nparticle = [1, 1]\n\
         keys = [{ time = 0.05, offset = [0, 0, 0] }, { time = 0.06, offset = [0, 100, 0] }]\n[air]",
    );
    let scene = write(&dir, "tear.toml", &failing);
    let out = dir.join("tear");
    let o = wetcloth(&[
        "run",
        &scene,
        "--out",
        out.to_str().unwrap(),
        "-q",
        "--checkpoint-every",
        "1",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(out.join("checkpoint.bin").is_file());
    // The mesh is replaced: the resume is refused, naming it.
    fs::write(dir.join("mesh.obj"), sheet_obj(3)).unwrap();
    let o = wetcloth(&["run", "--resume", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("mesh.obj changed since the run"), "{err}");
    // Put back, it resumes (and fails again, where it failed).
    fs::write(dir.join("mesh.obj"), sheet_obj(2)).unwrap();
    let o = wetcloth(&["run", "--resume", out.to_str().unwrap(), "-q"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
}

/// A FIFO given as a mesh blocked the run forever (opening it waits for a writer). It is
/// refused as not a regular file, naming the key and the file.
#[cfg(unix)]
#[test]
fn a_fifo_mesh_is_refused_not_waited_for() {
    let dir = scratch("fifo");
    let fifo = dir.join("mesh.obj");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let scene = write(&dir, "sheet.toml", ON_SHEET);
    let start = std::time::Instant::now();
    let o = wetcloth(&["run", &scene, "--out", dir.join("out").to_str().unwrap()]);
    assert!(start.elapsed().as_secs() < 30);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("collider[0].file") && err.contains("not a regular file"),
        "{err}"
    );
}

/// A cloth inside the default plane of a scene without any `[[collider]]` was refused as
/// `collider[0].point = (default)` with no line. The error now points at `cloth.position`,
/// with its line, and says where the plane comes from.
#[test]
fn a_cloth_below_the_default_plane_is_located() {
    let dir = scratch("default-plane");
    let scene = write(
        &dir,
        "below.toml",
        "[simulation]\nduration = 0.1\n[cloth]\nresolution = [4, 4]\nposition = [0, -1, 0]\n",
    );
    let o = wetcloth(&["run", &scene, "--out", dir.join("out").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("below.toml:5:12: cloth.position"), "{err}");
    assert!(err.contains("no [[collider]] table"), "{err}");
}

/// `export` of a run folder that did not complete exited 0 without a word. It still exits
/// 0, and says on stderr (and in the USD stage's documentation) that the cache is partial.
#[test]
fn export_of_an_incomplete_run_says_so() {
    let dir = scratch("export-incomplete");
    let scene = write(&dir, "unstable.toml", &unstable(200, 50));
    let out = dir.join("out");
    let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap(), "-q"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let o = wetcloth(&["export", out.to_str().unwrap(), "--format", "usda"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("is incomplete") && err.contains("the run failed"),
        "{err}"
    );
    let usda = fs::read_to_string(out.join("unstable.usda")).unwrap();
    assert!(
        usda.contains("INCOMPLETE: the run failed"),
        "no word in the stage"
    );
    // A complete run's export says nothing of the kind.
    let scene = write(
        &dir,
        "fine.toml",
        &unstable(4, 50).replace("0.01", "0.0001"),
    );
    let fine = dir.join("fine");
    let o = wetcloth(&["run", &scene, "--out", fine.to_str().unwrap(), "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = wetcloth(&["export", fine.to_str().unwrap(), "--format", "usda"]);
    assert!(o.status.success());
    assert!(!stderr(&o).contains("incomplete"), "{}", stderr(&o));
}

/// A grab key's offset of 1e308 was printed as a 309-digit number. Values are printed as
/// written, or in scientific notation.
#[test]
fn messages_print_huge_values_in_scientific_notation() {
    let dir = scratch("huge-values");
    for (name, text) in [
        (
            "grab.toml",
            "[[grab]]\nparticle = [1, 1]\nkeys = [{ time = 0, offset = [0, 0, 0] }, \
             { time = 1e308, offset = [0, 1e308, 0] }]\n",
        ),
        (
            "scale.toml",
            "[air]\nenabled = false\n[[collider]]\nshape = \"sphere\"\ncenter = [0, -2, 0]\n\
             radius = 1e308\n",
        ),
    ] {
        let scene = write(&dir, name, text);
        let o = wetcloth(&["run", &scene, "--out", dir.join("out").to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        let err = stderr(&o);
        assert!(err.contains("1e308"), "{err}");
        assert!(!err.contains("0000000000000000"), "{err}");
    }
}
