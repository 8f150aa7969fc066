//! `wetcloth run` end to end: the files it writes, its errors and exit codes, and determinism.
//! Scenes are tiny (8 x 8 particles, fractions of a second) so the suite stays fast.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

/// A fresh scratch directory for one test.
fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli-run")
        .join(test);
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn wetcloth(args: &[&str], envs: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(BIN);
    cmd.args(args);
    for (k, v) in envs {
        cmd.env(k, v);
    }
    cmd.output().expect("the wetcloth binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn write_scene(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// A small pinch: an 8 x 8 cloth on the ground, its middle lifted, air force on (no trapped air,
/// as in the thesis demo).
const PINCH: &str = r#"
name = "pinch"
[simulation]
duration = 0.25
frame_rate = 40
[cloth]
resolution = [8, 8]
damping = 2.0
[air]
trapped_air = 0.0
[[grab]]
particle = [4, 4]
keys = [{ time = 0.05, offset = [0, 0, 0] }, { time = 0.2, offset = [0, 0.03, 0] }]
"#;

/// Counts the `v`, `vt`, `vn` and `f` lines of an OBJ file, and checks its numbers and indices.
fn obj_counts(path: &Path, particles: usize) -> [usize; 4] {
    let text = fs::read_to_string(path).unwrap();
    let mut n = [0; 4];
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                n[0] += 1;
                let xyz: Vec<f64> = words.map(|w| w.parse().unwrap()).collect();
                assert!(
                    xyz.len() == 3 && xyz.iter().all(|x| x.is_finite()),
                    "{line}"
                );
            }
            Some("vt") => n[1] += 1,
            Some("vn") => n[2] += 1,
            Some("f") => {
                n[3] += 1;
                for corner in words {
                    let idx: Vec<usize> = corner.split('/').map(|i| i.parse().unwrap()).collect();
                    assert!(idx.len() == 3 && idx[0] == idx[1] && idx[1] == idx[2]);
                    assert!((1..=particles).contains(&idx[0]));
                }
            }
            _ => {}
        }
    }
    n
}

fn frame_files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn a_run_writes_frames_metrics_the_resolved_scene_and_run_json() {
    let dir = scratch("outputs");
    let scene = write_scene(&dir, "pinch.toml", PINCH);
    let out = dir.join("out");
    let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap()], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary = String::from_utf8_lossy(&o.stdout);
    for part in ["steps/s", "particle-steps/s", "air_pressure", "grab_force"] {
        assert!(summary.contains(part), "summary lacks {part}:\n{summary}");
    }

    // floor(0.25 * 40) + 1 = 11 frames and rows, frame 0 at t = 0.
    let csv = fs::read_to_string(out.join("metrics.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    // The contract fixes the first nine columns; more may follow.
    assert!(
        lines[0].starts_with(
            "frame,time,air_volume,air_pressure,kinetic_energy,max_stretch,contact_fraction,max_height,grab_force"
        ),
        "{}",
        lines[0]
    );
    let width = lines[0].split(',').count();
    assert_eq!(lines.len(), 1 + 11);
    for (k, line) in lines[1..].iter().enumerate() {
        let cols: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        assert_eq!(cols.len(), width);
        assert_eq!(cols[0], k as f64);
        // Frame k is the state at k / 40 s, up to the round-off of the step's time.
        assert!((cols[1] - k as f64 / 40.0).abs() < 1e-12, "{line}");
    }
    assert!(
        lines[1].starts_with("0,0.0,"),
        "frame 0 at t = 0: {}",
        lines[1]
    );

    let frames = frame_files(&out);
    let expected: Vec<String> = (0..11).map(|k| format!("frame_{k:04}.obj")).collect();
    assert_eq!(frames, expected);
    for name in &frames {
        // 64 particles, 2 triangles per cell of the 7 x 7 cells.
        assert_eq!(
            obj_counts(&out.join("frames").join(name), 64),
            [64, 64, 64, 98]
        );
    }

    // The resolved scene parses back to what ran.
    let resolved = wetcloth_scene::load(out.join("scene.toml")).unwrap();
    let original = wetcloth_scene::load(&scene).unwrap();
    assert_eq!(resolved.name, "pinch");
    assert_eq!(resolved.config, original.config);

    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(json["name"], "pinch");
    assert_eq!(json["resolution"], serde_json::json!([8, 8]));
    assert_eq!(json["frames"], 11);
    assert_eq!(json["complete"], true);
    assert_eq!(json["grabs"], serde_json::json!([[4, 4]]));
    assert_eq!(json["colliders"][0]["shape"], "plane");
    assert_eq!(
        json["colliders"][0]["normal"],
        serde_json::json!([0.0, 1.0, 0.0])
    );
    assert_eq!(json["particle_radius"], 0.00075);
}

#[test]
fn the_default_output_directory_is_out_slash_the_scene_name() {
    let dir = scratch("default-out");
    write_scene(
        &dir,
        "tiny.toml",
        "[simulation]\nduration = 0.01\nframe_rate = 100\n[cloth]\nresolution = [4, 4]\n",
    );
    let o = Command::new(BIN)
        .args(["run", "tiny.toml", "--quiet"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stdout.is_empty(), "--quiet prints nothing");
    assert_eq!(frame_files(&dir.join("out/tiny")).len(), 2);
}

#[test]
fn a_rerun_removes_the_frames_of_a_longer_run() {
    let dir = scratch("stale");
    let out = dir.join("out");
    let long = write_scene(
        &dir,
        "long.toml",
        &PINCH.replace("duration = 0.25", "duration = 0.2"),
    );
    let short = write_scene(
        &dir,
        "short.toml",
        &PINCH.replace("duration = 0.25", "duration = 0.05"),
    );
    fs::create_dir_all(out.join("frames")).unwrap();
    fs::write(out.join("frames/notes.txt"), "kept").unwrap();
    for scene in [&long, &short] {
        let o = wetcloth(&["run", scene, "--out", out.to_str().unwrap(), "-q"], &[]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(
        frame_files(&out),
        [
            "frame_0000.obj",
            "frame_0001.obj",
            "frame_0002.obj",
            "notes.txt"
        ]
    );
    let rows = fs::read_to_string(out.join("metrics.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, 1 + 3);
}

#[test]
fn a_blow_up_exits_1_and_keeps_complete_frames_and_metrics() {
    let dir = scratch("blow-up");
    // A 1 cm step with stiff springs: far past the stability limit once the grab pulls.
    let scene = write_scene(
        &dir,
        "boom.toml",
        "[simulation]\nduration = 1\ntime_step = 0.01\nframe_rate = 100\n\
         [cloth]\nresolution = [8, 8]\nstructural_stiffness = 1e5\n\
         [[grab]]\nparticle = [4, 4]\n\
         keys = [{ time = 0.05, offset = [0, 0, 0] }, { time = 0.2, offset = [0, 0.1, 0] }]\n",
    );
    let out = dir.join("out");
    let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap()], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("blew up at t = "), "{err}");
    assert!(err.contains("smaller time_step"), "{err}");
    assert!(!err.contains("panicked"), "{err}");

    let frames = frame_files(&out);
    assert!(frames.len() >= 5 && frames.len() < 101, "{frames:?}");
    for name in &frames {
        assert!(name.ends_with(".obj"), "no partial files: {name}");
        assert_eq!(
            obj_counts(&out.join("frames").join(name), 64),
            [64, 64, 64, 98]
        );
    }
    let csv = fs::read_to_string(out.join("metrics.csv")).unwrap();
    assert!(csv.ends_with('\n'));
    assert_eq!(csv.lines().count(), 1 + frames.len());
    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(json["frames"], frames.len() as u64);
    assert_eq!(json["complete"], false);
}

/// The explicit stability warning is for the explicit integrator: the same large step warns
/// with Verlet and not with the implicit integrator (it printed "will probably blow up" on
/// every implicit run).
#[test]
fn only_explicit_runs_warn_about_the_explicit_stability_limit() {
    let dir = scratch("stability-warning");
    for (integrator, warns) in [("verlet", true), ("implicit", false)] {
        let scene = write_scene(
            &dir,
            &format!("{integrator}.toml"),
            &format!(
                "[simulation]\nduration = 0.02\ntime_step = 0.005\nframe_rate = 100\n\
                 integrator = \"{integrator}\"\n[cloth]\nresolution = [6, 6]\n\
                 self_collision = false\n[air]\nenabled = false\n"
            ),
        );
        let out = dir.join(integrator);
        let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap(), "-q"], &[]);
        let err = stderr(&o);
        assert_eq!(
            err.contains("stability limit"),
            warns,
            "{integrator}: {err}"
        );
    }
}

#[test]
fn outputs_are_byte_identical_whatever_the_thread_count() {
    let dir = scratch("determinism");
    // Large enough for the core to use its thread pool (128 x 128 particles), short enough to
    // stay fast: soft springs keep the default step stable, and the grab pulls from t = 0.
    let n = 128;
    assert!(n * n >= wetcloth::sim::PARALLEL_MIN_PARTICLES);
    let scene = write_scene(
        &dir,
        "big.toml",
        &format!(
            "[simulation]\nduration = 0.02\nframe_rate = 100\n\
             [cloth]\nresolution = [{n}, {n}]\nstructural_stiffness = 50.0\n\
             shear_stiffness = 12.5\ndamping = 2.0\n\
             [[grab]]\nparticle = [64, 64]\n\
             keys = [{{ time = 0.0, offset = [0, 0, 0] }}, {{ time = 0.02, offset = [0, 0.002, 0] }}]\n"
        ),
    );
    for (threads, name) in [("1", "t1"), ("2", "t2")] {
        let out = dir.join(name);
        let o = wetcloth(
            &["run", &scene, "--out", out.to_str().unwrap(), "-q"],
            &[("RAYON_NUM_THREADS", threads)],
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let t3 = dir.join("t3");
    let o = wetcloth(
        &[
            "run",
            &scene,
            "--out",
            t3.to_str().unwrap(),
            "-q",
            "--threads",
            "3",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let mut files = vec![
        PathBuf::from("metrics.csv"),
        "scene.toml".into(),
        "run.json".into(),
    ];
    files.extend(
        frame_files(&dir.join("t1"))
            .iter()
            .map(|f| Path::new("frames").join(f)),
    );
    assert_eq!(files.len(), 3 + 3);
    // Something happened: the grab pulled.
    let csv = fs::read_to_string(dir.join("t1/metrics.csv")).unwrap();
    let last: Vec<f64> = csv
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert!(last[8] > 0.0, "grab force in {csv}");
    for other in ["t2", "t3"] {
        assert_eq!(frame_files(&dir.join("t1")), frame_files(&dir.join(other)));
        for f in &files {
            let a = fs::read(dir.join("t1").join(f)).unwrap();
            let b = fs::read(dir.join(other).join(f)).unwrap();
            assert!(
                a == b,
                "{} differs between 1 thread and {other}",
                f.display()
            );
        }
    }
}

#[test]
fn bad_input_exits_2_with_a_located_message() {
    let dir = scratch("bad-input");
    let missing = dir.join("nope.toml");
    let o = wetcloth(&["run", missing.to_str().unwrap()], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("nope.toml"), "{}", stderr(&o));
    assert!(stderr(&o).contains("cannot read"), "{}", stderr(&o));

    let cases: [(&str, &[&str]); 5] = [
        (
            "[cloth]\nresolution = [8, 8]\nmasss = 1\n",
            &["typo.toml:3:1:", "unknown key", "did you mean `mass`?"],
        ),
        (
            "[cloth]\nmass = -1\n",
            &[
                "typo.toml:2:8:",
                "cloth.mass = -1",
                "out of range",
                "allowed [",
            ],
        ),
        ("[cloth\n", &["typo.toml:1:", "TOML syntax error"]),
        (
            "[cloth]\nmass = \"heavy\"\n",
            &["typo.toml:2:8:", "cloth.mass", "expected a number"],
        ),
        (
            "[simulation]\nintegrator = \"euler\"\n",
            &["typo.toml:2:14:", "\"verlet\""],
        ),
    ];
    for (text, parts) in cases {
        let scene = write_scene(&dir, "typo.toml", text);
        let out = dir.join("out");
        let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap()], &[]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(!err.contains("panicked"), "{err}");
        for p in parts {
            assert!(err.contains(p), "stderr lacks {p:?}:\n{err}");
        }
    }
    assert!(
        !dir.join("out").exists(),
        "nothing is written for a bad scene"
    );

    let o = wetcloth(&["run", "--threads", "0"], &[]);
    assert_eq!(o.status.code(), Some(2));
    let o = wetcloth(&["walk"], &[]);
    assert_eq!(o.status.code(), Some(2));
}

/// The README's first command: no scene runs the thesis demo into out/thesis-demo/. This is the
/// one full-size run of the suite (2500 particles, 3 s simulated, a few seconds of wall time).
#[test]
fn without_a_scene_the_thesis_demo_runs_into_out_thesis_demo() {
    let dir = scratch("default-scene");
    let o = Command::new(BIN)
        .args(["run", "--quiet"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.join("out/thesis-demo");
    assert_eq!(frame_files(&out).len(), 181);
    let resolved = wetcloth_scene::load(out.join("scene.toml")).unwrap();
    assert_eq!(resolved.name, "thesis-demo");
    assert_eq!(resolved.config, wetcloth::SimConfig::thesis_demo());
    let rows = fs::read_to_string(out.join("metrics.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, 1 + 181);
}

/// A seeded pocket under a small wet cloth (pockets model), pressed at its middle.
const POCKET: &str = r#"
name = "pocket"
[simulation]
duration = 0.2
frame_rate = 40
[cloth]
resolution = [15, 15]
size = [0.14, 0.14]
mass = 0.005
position = [0.0, 0.00075, 0.0]
damping = 2.0
self_collision = false
[air]
model = "pockets"
[[air.pocket]]
center = [0.0, 0.0]
radius = 0.03
amount = 5e-6
"#;

#[test]
fn pockets_csv_lists_each_sealed_pocket_per_frame() {
    let dir = scratch("pockets-csv");
    let scene = write_scene(&dir, "pocket.toml", POCKET);
    let mut texts = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.join(format!("t{threads}"));
        let o = wetcloth(
            &[
                "run",
                &scene,
                "--out",
                out.to_str().unwrap(),
                "--threads",
                threads,
            ],
            &[],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        texts.push(fs::read_to_string(out.join("pockets.csv")).unwrap());
        let metrics = fs::read_to_string(out.join("metrics.csv")).unwrap();
        let header: Vec<&str> = metrics.lines().next().unwrap().split(',').collect();
        let col = header.iter().position(|c| *c == "pocket_count").unwrap();
        let trapped = header.iter().position(|c| *c == "trapped_air").unwrap();
        for line in metrics.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            assert_eq!(f[col], "1", "{line}");
            let t: f64 = f[trapped].parse().unwrap();
            assert!((t - 5e-6).abs() < 1e-15, "{line}");
        }
    }
    assert_eq!(
        texts[0], texts[1],
        "pockets.csv depends on the thread count"
    );
    let lines: Vec<&str> = texts[0].lines().collect();
    assert_eq!(
        lines[0],
        "frame,time,pocket,volume,amount,pressure,area,particles"
    );
    // One pocket in each of the 9 frames, keeping its id, with P V = P_a N.
    assert_eq!(lines.len(), 1 + 9);
    for (k, line) in lines[1..].iter().enumerate() {
        let f: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        assert_eq!(f[0], k as f64);
        assert_eq!(f[2], 1.0, "the pocket keeps its id: {line}");
        let (v, n, p) = (f[3], f[4], f[5]);
        assert!((n - 5e-6).abs() < 1e-15, "{line}");
        assert!(
            (p * v - 101_325.0 * n).abs() < 1e-9 * 101_325.0 * n,
            "{line}"
        );
        assert!(f[6] > 0.0 && f[7] >= 1.0, "{line}");
    }
}

#[test]
fn pockets_csv_has_the_single_bubble_with_the_thesis_model() {
    let dir = scratch("pockets-csv-thesis");
    let scene = write_scene(&dir, "pinch.toml", PINCH);
    let out = dir.join("out");
    let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap()], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = fs::read_to_string(out.join("pockets.csv")).unwrap();
    let metrics = fs::read_to_string(out.join("metrics.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 1 + 11, "one row per frame");
    for (row, m) in lines[1..].iter().zip(metrics.lines().skip(1)) {
        let f: Vec<&str> = row.split(',').collect();
        let g: Vec<&str> = m.split(',').collect();
        assert_eq!(f[0], g[0]);
        assert_eq!(f[2], "0", "the thesis' bubble is pocket 0");
        // Its volume and pressure are metrics.csv's air_volume and air_pressure.
        assert_eq!(f[3], g[2]);
        assert_eq!(f[5], g[3]);
        assert_eq!(f[7], "64");
    }
}
