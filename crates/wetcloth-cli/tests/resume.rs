//! Resumable bakes (docs/reliability.md, "Resume"): a run killed (SIGKILL) at random moments,
//! or stopped by SIGINT, and continued with `wetcloth run --resume DIR` on another thread
//! count, leaves a folder byte for byte equal to an uninterrupted run's; `--resume` refuses
//! (exit 2, naming the file) a folder with nothing to resume, a changed scene and a damaged
//! checkpoint.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

/// 2 s of a 14 x 14 cloth pinched and lifted off the table, air leaking under its border, 40 frames a second: about a second
/// of work, so that kills land all along it.
const SCENE: &str = "name = \"resumable\"\n[simulation]\nduration = 2.0\nframe_rate = 40\n\
    [cloth]\nresolution = [14, 14]\ndamping = 2.0\n[air]\nleak_conductance = 0.01\n\
    [[grab]]\nparticle = [4, 4]\n\
    keys = [{ time = 0.05, offset = [0, 0, 0] }, { time = 0.5, offset = [0, 0.03, 0] }]\n";

fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli-resume")
        .join(test);
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn wetcloth(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .env_remove("RAYON_NUM_THREADS")
        .output()
        .expect("the wetcloth binary runs")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every file under `dir` with its bytes, by path relative to `dir`.
fn contents(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else {
                out.insert(
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    fs::read(&p).unwrap(),
                );
            }
        }
    }
    out
}

fn assert_same(a: &Path, b: &Path, what: &str) {
    let (x, y) = (contents(a), contents(b));
    assert_eq!(
        x.keys().collect::<Vec<_>>(),
        y.keys().collect::<Vec<_>>(),
        "{what}: other files"
    );
    for (k, v) in &x {
        assert!(v == &y[k], "{what}: {} differs", k.display());
    }
}

fn run_json(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(dir.join("run.json")).unwrap()).unwrap()
}

/// A reference run, uninterrupted, on one thread; returns its folder and wall time.
fn reference(root: &Path, scene: &str) -> (PathBuf, Duration) {
    let out = root.join("reference");
    let t0 = Instant::now();
    let o = wetcloth(&["run", "-q", scene, "--out", s(&out), "--threads", "1"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (out, t0.elapsed())
}

/// Starts a run and kills it (SIGKILL) after `after`; returns whether it was still running.
fn run_and_kill(args: &[&str], after: Duration) -> bool {
    let mut child = Command::new(BIN)
        .args(args)
        .env_remove("RAYON_NUM_THREADS")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(after);
    let killed = child.try_wait().unwrap().is_none();
    let _ = child.kill();
    child.wait().unwrap();
    killed
}

/// A fixed sequence of pseudo-random fractions in [0.02, 0.95).
fn fractions(n: usize) -> Vec<f64> {
    let mut x: u64 = 0x005e_ed0f_c107;
    (0..n)
        .map(|_| {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            0.02 + 0.93 * ((x >> 11) as f64 / (1u64 << 53) as f64)
        })
        .collect()
}

/// Two seeded air pockets under a wet 14 x 14 cloth (the pockets air model), the seam between
/// them lifted: pockets.csv and the pocket label files must resume to the same bytes too.
const POCKETS_SCENE: &str = "name = \"resumable-pockets\"\n[simulation]\nduration = 2.0\n\
    frame_rate = 40\n[cloth]\nresolution = [14, 14]\nsize = [0.14, 0.14]\nmass = 0.005\n\
    position = [0.0, 0.00075, 0.0]\ndamping = 2.0\n[air]\nmodel = \"pockets\"\n\
    [[air.pocket]]\ncenter = [-0.035, 0.0]\nradius = 0.02\namount = 2e-6\n\
    [[air.pocket]]\ncenter = [0.035, 0.0]\nradius = 0.02\namount = 2e-6\n\
    [[grab]]\nparticle = [7, 7]\n\
    keys = [{ time = 0.2, offset = [0, 0, 0] }, { time = 0.8, offset = [0, 0.01, 0] }]\n";

/// A cloth hung from a box by an attachment while the box is carried sideways:
/// attachments.csv and metrics.csv's attach_force must resume to the same bytes too.
const ATTACH_SCENE: &str = "name = \"resumable-attach\"\n[simulation]\nduration = 1.0\n\
    frame_rate = 40\ntime_step = 2e-4\n[cloth]\nresolution = [10, 10]\nsize = [0.1, 0.1]\n\
    mass = 0.005\nposition = [0.0, 0.5, 0.0]\nself_collision = false\n[air]\nenabled = false\n\
    [[collider]]\nshape = \"box\"\ncenter = [0.0, 0.5, -0.07]\nhalf_extents = [0.08, 0.01, 0.01]\n\
    keys = [{ time = 0.0, offset = [0, 0, 0] }, { time = 1.0, offset = [0.05, 0, 0] }]\n\
    [[attach]]\ncollider = 0\nwithin = { center = [0.0, 0.5, -0.05], half_size = [0.1, 0.01, 0.001] }\n";

#[test]
fn attachment_runs_killed_at_random_moments_resume_to_the_same_bytes() {
    killed_runs_resume_to_the_same_bytes("killed-attach", ATTACH_SCENE);
    let out = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli-resume")
        .join("killed-attach")
        .join("run0");
    let text = fs::read_to_string(out.join("attachments.csv")).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(
        rows[0],
        "frame,time,attach,particles,force_x,force_y,force_z"
    );
    assert_eq!(rows.len(), 1 + 41, "one row per frame");
    let fields: Vec<&str> = rows[5].split(',').collect();
    assert_eq!(
        (fields[0], fields[2], fields[3]),
        ("4", "0", "10"),
        "{}",
        rows[5]
    );
}

#[test]
fn runs_killed_at_random_moments_resume_to_the_same_bytes() {
    killed_runs_resume_to_the_same_bytes("killed", SCENE);
}

#[test]
fn pockets_runs_killed_at_random_moments_resume_to_the_same_bytes() {
    killed_runs_resume_to_the_same_bytes("killed-pockets", POCKETS_SCENE);
}

fn killed_runs_resume_to_the_same_bytes(name: &str, text: &str) {
    let root = scratch(name);
    let scene = root.join("scene.toml");
    fs::write(&scene, text).unwrap();
    let (want, wall) = reference(&root, s(&scene));
    let mut killed = 0;
    for (i, f) in fractions(6).into_iter().enumerate() {
        let out = root.join(format!("run{i}"));
        let threads = ["1", "2"][i % 2];
        let every = ["1", "3", "10"][i % 3];
        let args = [
            "run",
            "-q",
            s(&scene),
            "--out",
            s(&out),
            "--threads",
            threads,
            "--checkpoint-every",
            every,
        ];
        if run_and_kill(&args, wall.mul_f64(f)) {
            killed += 1;
        }
        // The resumed run is killed too, now and then, and resumed again.
        let other = ["2", "1"][i % 2];
        let resume = ["run", "-q", "--resume", s(&out), "--threads", other];
        if i % 2 == 1 && fs::metadata(out.join("checkpoint.bin")).is_ok() {
            run_and_kill(&resume, wall.mul_f64(0.3 * f));
        }
        // Killed before its first checkpoint, or after the end (a resumed run killed between
        // its last run.json, "complete", and removing its checkpoint): nothing to resume.
        if fs::metadata(out.join("checkpoint.bin")).is_err()
            || run_json(&out)["status"] == "complete"
        {
            let o = wetcloth(&resume);
            if run_json(&out)["status"] == "complete" {
                assert_same(&want, &out, &format!("run {i}, complete"));
            } else {
                assert_eq!(o.status.code(), Some(2));
            }
            continue;
        }
        let o = wetcloth(&resume);
        assert!(
            o.status.success(),
            "resume {i}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert_same(&want, &out, &format!("run {i} killed at {f:.2} of the run"));
    }
    assert!(killed >= 3, "only {killed} of 6 runs were killed part way");
}

#[test]
fn a_run_stopped_by_sigint_resumes_to_the_same_bytes() {
    let root = scratch("sigint");
    let scene = root.join("scene.toml");
    fs::write(&scene, SCENE).unwrap();
    let (want, _) = reference(&root, s(&scene));
    let out = root.join("stopped");
    let child = Command::new(BIN)
        .args(["run", "-q", s(&scene), "--out", s(&out), "--threads", "2"])
        .env_remove("RAYON_NUM_THREADS")
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Stop it once a few frames are out.
    let t0 = Instant::now();
    while fs::read_to_string(out.join("run.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .is_none_or(|v| v["frames"].as_u64().unwrap_or(0) < 5)
    {
        assert!(t0.elapsed() < Duration::from_secs(60), "no frames");
        std::thread::sleep(Duration::from_millis(5));
    }
    let pid = child.id().to_string();
    Command::new("kill").args(["-INT", &pid]).status().unwrap();
    let o = child.wait_with_output().unwrap();
    if o.status.code() == Some(0) {
        // Finished before the signal came: nothing to test on this machine.
        assert_same(&want, &out, "complete");
        return;
    }
    assert_eq!(
        o.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let info = run_json(&out);
    assert_eq!(info["status"], "interrupted");
    let note = &info["checkpoint"];
    assert_eq!(note["file"], "checkpoint.bin");
    assert!(note["frames"].as_u64().unwrap() >= info["frames"].as_u64().unwrap());
    assert!(note["step"].as_u64().unwrap() > 0);
    let o = wetcloth(&["run", "-q", "--resume", s(&out), "--threads", "1"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_same(&want, &out, "after SIGINT");
    // Complete: no checkpoint left, and nothing more to resume.
    assert!(run_json(&out).get("checkpoint").is_none());
    let o = wetcloth(&["run", "-q", "--resume", s(&out)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("complete"));
}

/// A run folder with a checkpoint: the run killed (SIGKILL) once its first one is on disk.
fn stopped_run(root: &Path) -> (PathBuf, PathBuf) {
    let scene = root.join("scene.toml");
    fs::write(&scene, SCENE).unwrap();
    let out = root.join("run");
    let mut child = Command::new(BIN)
        .args(["run", "-q", s(&scene), "--out", s(&out), "--threads", "1"])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    while fs::metadata(out.join("checkpoint.bin")).is_err() {
        std::thread::sleep(Duration::from_millis(2));
    }
    let _ = child.kill();
    child.wait().unwrap();
    (scene, out)
}

fn refused(args: &[&str], names: &str) -> String {
    let o = wetcloth(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(err.contains(names), "{args:?} should name {names}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

#[test]
fn resume_refuses_folders_with_nothing_to_resume_changed_scenes_and_damaged_checkpoints() {
    let root = scratch("refusals");
    let empty = root.join("empty");
    fs::create_dir_all(&empty).unwrap();
    refused(&["run", "--resume", s(&empty)], "nothing to resume");
    refused(
        &["run", "--resume", s(&root.join("absent"))],
        "nothing to resume",
    );

    let (scene, out) = stopped_run(&root);
    let ckpt = out.join("checkpoint.bin");
    let good = fs::read(&ckpt).unwrap();

    // A damaged checkpoint: a flipped byte anywhere, a truncated file, an empty one.
    for (name, bytes) in [
        ("flipped header", {
            let mut b = good.clone();
            b[3] ^= 1;
            b
        }),
        ("flipped payload", {
            let mut b = good.clone();
            let i = b.len() / 2;
            b[i] ^= 0x40;
            b
        }),
        ("truncated", good[..good.len() - 7].to_vec()),
        ("empty", Vec::new()),
    ] {
        fs::write(&ckpt, &bytes).unwrap();
        let err = refused(&["run", "--resume", s(&out)], "checkpoint.bin");
        assert!(err.contains("damaged"), "{name}: {err}");
    }
    fs::write(&ckpt, &good).unwrap();

    // Another scene given beside the folder, or the folder's scene changed.
    let other = root.join("other.toml");
    fs::write(&other, SCENE.replace("damping = 2.0", "damping = 3.0")).unwrap();
    refused(&["run", s(&other), "--resume", s(&out)], "is not the scene");
    let toml = out.join("scene.toml");
    let text = fs::read_to_string(&toml).unwrap();
    fs::write(&toml, text.replace("damping = 2", "damping = 2.5")).unwrap();
    refused(&["run", "--resume", s(&out)], "scene.toml");
    fs::write(&toml, &text).unwrap();

    // No checkpoint at all.
    fs::remove_file(&ckpt).unwrap();
    refused(&["run", "--resume", s(&out)], "nothing to resume");
    fs::write(&ckpt, &good).unwrap();

    // The same scene given beside the folder is fine, and the run completes.
    let o = wetcloth(&["run", "-q", s(&scene), "--resume", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(run_json(&out)["status"], "complete");
    assert!(
        fs::metadata(&ckpt).is_err(),
        "a complete run keeps no checkpoint"
    );
}

#[test]
fn checkpoint_every_zero_writes_none_until_interrupted() {
    let root = scratch("every-zero");
    let scene = root.join("scene.toml");
    fs::write(&scene, SCENE.replace("duration = 2.0", "duration = 0.2")).unwrap();
    let out = root.join("run");
    let o = wetcloth(&[
        "run",
        "-q",
        s(&scene),
        "--out",
        s(&out),
        "--checkpoint-every",
        "0",
    ]);
    assert!(o.status.success());
    assert!(fs::metadata(out.join("checkpoint.bin")).is_err());
    assert!(run_json(&out).get("checkpoint").is_none());
}
