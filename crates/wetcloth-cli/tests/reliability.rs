//! What `wetcloth` promises when things go wrong (docs/reliability.md): every exit status
//! means what it says, a run that is stopped says so in `run.json` and leaves only whole
//! files, links left in the output are never followed, thread pools that cannot start are
//! errors, and runs too large for the machine are refused before anything is written. Each
//! test is named after what was found from outside.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli-reliability")
        .join(test);
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn wetcloth(args: &[&str], envs: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(BIN);
    cmd.args(args).env_remove("RAYON_NUM_THREADS");
    for (k, v) in envs {
        cmd.env(k, v);
    }
    cmd.output().expect("the wetcloth binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// 0.25 s of a small pinch: 11 frames.
const SMALL: &str = "name = \"small\"\n[simulation]\nduration = 0.25\nframe_rate = 40\n\
    [cloth]\nresolution = [8, 8]\ndamping = 2.0\n[[grab]]\nparticle = [4, 4]\n\
    keys = [{ time = 0.05, offset = [0, 0, 0] }, { time = 0.2, offset = [0, 0.03, 0] }]\n";

/// A minute of a 40 x 40 cloth settling: long enough to be stopped part way. Ten frames a
/// second keep its estimated output (about 250 MB) small; the runs pass `--force` all the same,
/// as they are stopped after a few frames and a machine with little free disk must not refuse
/// them.
const LONG: &str = "name = \"long\"\n[simulation]\nduration = 60\nframe_rate = 10\n\
    [cloth]\nresolution = [40, 40]\n";

/// `LONG`'s frame rate, 1/s.
const LONG_RATE: f64 = 10.0;

fn run_json(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(dir.join("run.json")).unwrap()).unwrap()
}

/// The names in `dir/frames`, sorted.
fn frame_dir(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Every `.part` file anywhere under `dir`.
fn parts(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for e in fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if fs::symlink_metadata(&p).unwrap().is_dir() {
            found.extend(parts(&p));
        } else if p.to_string_lossy().ends_with(".part") {
            found.push(p);
        }
    }
    found
}

fn metrics_rows(dir: &Path) -> usize {
    fs::read_to_string(dir.join("metrics.csv"))
        .unwrap()
        .lines()
        .count()
        - 1
}

/// Starts a long run into `out` and waits until it has written `frames` frames.
fn start_long(dir: &Path, out: &Path, frames: usize) -> Child {
    let scene = write(dir, "long.toml", LONG);
    let mut child = Command::new(BIN)
        .args(["run", &scene, "--out", out.to_str().unwrap(), "--quiet"])
        .arg("--force")
        .env_remove("RAYON_NUM_THREADS")
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let last = out
        .join("frames")
        .join(format!("frame_{:04}.obj", frames - 1));
    let t = Instant::now();
    while !last.exists() {
        // A run that ended (refused, failed) will never get there: say why at once.
        if child.try_wait().unwrap().is_some() {
            let o = child.wait_with_output().unwrap();
            panic!(
                "the run ended before {frames} frames ({}): {}",
                o.status,
                stderr(&o)
            );
        }
        if t.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("the run never got to {frames} frames in 120 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child
}

fn signal(child: &Child, sig: &str) {
    let ok = Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill {sig}");
}

/// Found from outside: a stale `frame_0000.obj.part` symbolic link in the output folder was
/// followed and its target overwritten. Links at any temporary name, and at `metrics.csv`,
/// are replaced, never followed, and no `.part` is left.
#[cfg(unix)]
#[test]
fn stale_part_links_in_the_output_are_replaced_not_followed() {
    use std::os::unix::fs::symlink;
    let dir = scratch("part-links");
    let scene = write(&dir, "small.toml", SMALL);
    let out = dir.join("out");
    fs::create_dir_all(out.join("frames")).unwrap();
    let precious = dir.join("precious.txt");
    fs::write(&precious, "keep me").unwrap();
    for link in [
        "frames/frame_0000.obj.part",
        "frames/frame_0003.obj.part",
        "run.json.part",
        "scene.toml.part",
        "metrics.csv",
    ] {
        symlink(&precious, out.join(link)).unwrap();
    }
    symlink(dir.join("nowhere"), out.join("frames/frame_0001.obj.part")).unwrap();
    let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap(), "-q"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(fs::read_to_string(&precious).unwrap(), "keep me");
    assert!(!dir.join("nowhere").exists());
    assert_eq!(parts(&out), Vec::<PathBuf>::new());
    assert_eq!(frame_dir(&out).len(), 11);
    assert!(
        fs::symlink_metadata(out.join("metrics.csv"))
            .unwrap()
            .is_file()
    );
    assert_eq!(metrics_rows(&out), 11);
    assert_eq!(run_json(&out)["status"], "complete");
}

/// Found from outside: a run stopped by Ctrl-C left `run.json` behind its OBJ files with
/// nothing saying so, and `.part` files behind. It now stops after a whole frame (exit 130),
/// with `run.json` saying `interrupted`, how many frames and the time reached, as many frames
/// and metrics rows as it says, and no `.part` file. SIGTERM likewise.
#[cfg(unix)]
#[test]
fn ctrl_c_and_sigterm_stop_after_a_whole_frame_and_say_interrupted() {
    for sig in ["-INT", "-TERM"] {
        let dir = scratch(&format!("interrupt{sig}"));
        let out = dir.join("out");
        let child = start_long(&dir, &out, 3);
        signal(&child, sig);
        let o = child.wait_with_output().unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(130), "{sig}: {err}");
        assert!(err.contains("interrupted at t = "), "{err}");
        assert!(!err.contains("panicked"), "{err}");
        let json = run_json(&out);
        assert_eq!(json["status"], "interrupted", "{json}");
        assert_eq!(json["complete"], false);
        let frames = json["frames"].as_u64().unwrap() as usize;
        assert!(frames >= 3, "{json}");
        assert_eq!(frame_dir(&out).len(), frames, "{sig}");
        assert_eq!(metrics_rows(&out), frames);
        // The time reached is the last frame's.
        let t = json["time"].as_f64().unwrap();
        assert!((t - (frames - 1) as f64 / LONG_RATE).abs() < 1e-9, "{json}");
        assert_eq!(parts(&out), Vec::<PathBuf>::new());
        assert!(json.get("error").is_none());
    }
}

/// A run killed outright (SIGKILL cannot be caught) leaves `run.json` saying `running`: the
/// frames it counts are whole, at most one more frame file and metrics row may follow them.
/// A new run into the same folder starts clean.
#[cfg(unix)]
#[test]
fn a_killed_run_says_running_and_a_rerun_starts_clean() {
    let dir = scratch("kill");
    let out = dir.join("out");
    let mut child = start_long(&dir, &out, 4);
    signal(&child, "-KILL");
    let _ = child.wait();
    let json = run_json(&out);
    assert_eq!(json["status"], "running", "{json}");
    let frames = json["frames"].as_u64().unwrap() as usize;
    let objs: Vec<String> = frame_dir(&out)
        .into_iter()
        .filter(|n| n.ends_with(".obj"))
        .collect();
    assert!(
        objs.len() == frames || objs.len() == frames + 1,
        "{frames} vs {objs:?}"
    );
    let rows = metrics_rows(&out);
    assert!(
        rows == frames || rows == frames + 1,
        "{frames} vs {rows} rows"
    );

    let scene = write(&dir, "small.toml", SMALL);
    let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap(), "-q"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(run_json(&out)["status"], "complete");
    assert_eq!(frame_dir(&out).len(), 11);
    assert_eq!(parts(&out), Vec::<PathBuf>::new());
}

/// A blow-up exits 1 and `run.json` says `failed`, with the error and how far the run got.
#[test]
fn a_blow_up_says_failed_with_the_error_in_run_json() {
    let dir = scratch("failed");
    let scene = write(
        &dir,
        "boom.toml",
        "[simulation]\nduration = 1\ntime_step = 0.01\nframe_rate = 100\n\
         [cloth]\nresolution = [8, 8]\nstructural_stiffness = 1e5\n\
         [[grab]]\nparticle = [4, 4]\n\
         keys = [{ time = 0.05, offset = [0, 0, 0] }, { time = 0.2, offset = [0, 0.1, 0] }]\n",
    );
    let out = dir.join("out");
    let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap()], &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let json = run_json(&out);
    assert_eq!(json["status"], "failed", "{json}");
    assert!(
        json["error"].as_str().unwrap().contains("blew up"),
        "{json}"
    );
    let frames = json["frames"].as_u64().unwrap() as usize;
    assert_eq!(frame_dir(&out).len(), frames);
    assert_eq!(metrics_rows(&out), frames);
    assert!((json["time"].as_f64().unwrap() - (frames - 1) as f64 / 100.0).abs() < 1e-9);
    assert_eq!(parts(&out), Vec::<PathBuf>::new());
}

/// An output that cannot be written exits 1, and `run.json` says `failed` naming the file.
#[test]
fn an_output_error_says_failed_naming_the_file() {
    let dir = scratch("output-error");
    let scene = write(&dir, "small.toml", SMALL);
    let out = dir.join("out");
    fs::create_dir_all(out.join("metrics.csv")).unwrap();
    fs::write(out.join("metrics.csv/keep"), "a directory in the way").unwrap();
    let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap()], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("metrics.csv"), "{err}");
    let json = run_json(&out);
    assert_eq!(json["status"], "failed");
    assert!(
        json["error"].as_str().unwrap().contains("metrics.csv"),
        "{json}"
    );
    assert_eq!(json["frames"], 0);
    assert_eq!(parts(&out), Vec::<PathBuf>::new());
}

/// An earlier run's `complete` never outlives its frames: the first thing a run writes is
/// `run.json` saying `running`.
#[test]
fn a_rerun_replaces_a_complete_run_json_first() {
    let dir = scratch("rerun-status");
    let scene = write(&dir, "small.toml", SMALL);
    let out = dir.join("out");
    let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap(), "-q"], &[]);
    assert!(o.status.success());
    // A second run into the same folder that fails on its first frame.
    fs::remove_file(out.join("metrics.csv")).unwrap();
    fs::create_dir_all(out.join("metrics.csv")).unwrap();
    let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap(), "-q"], &[]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(run_json(&out)["status"], "failed");
    assert_eq!(run_json(&out)["complete"], false);
}

/// Found from outside: `--threads 4096` under a memory limit panicked, and
/// `RAYON_NUM_THREADS=100000` aborted. A pool that cannot start is an error (exit 1) naming
/// the count; a thread count out of range is bad input (exit 2).
#[cfg(unix)]
#[test]
fn thread_pool_failures_are_errors_not_panics() {
    let dir = scratch("threads");
    let scene = write(&dir, "small.toml", SMALL);
    let out = dir.join("out");
    // 1.5 GB of address space: 4096 thread stacks do not fit.
    let o = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 1500000 && exec \"{BIN}\" run \"{scene}\" --out \"{}\" --threads 4096 -q",
            out.display()
        ))
        .env_remove("RAYON_NUM_THREADS")
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("cannot start 4096 worker threads"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        !out.join("run.json").exists(),
        "nothing is written before the pool starts"
    );

    for bad in ["100000", "-3", "many", "4097"] {
        let o = wetcloth(
            &["run", &scene, "--out", out.to_str().unwrap(), "-q"],
            &[("RAYON_NUM_THREADS", bad)],
        );
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{bad}: {err}");
        assert!(
            err.contains("RAYON_NUM_THREADS") && err.contains("1 to 4096"),
            "{err}"
        );
    }
    let o = wetcloth(
        &["run", &scene, "--out", out.to_str().unwrap(), "-q"],
        &[("RAYON_NUM_THREADS", "1")],
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Found from outside: `wetcloth --threads N run`, as documented, was refused. Both places
/// work and give the same files; two different counts are refused.
#[test]
fn threads_may_be_given_before_the_command() {
    let dir = scratch("threads-first");
    let scene = write(&dir, "small.toml", SMALL);
    let (a, b) = (dir.join("a"), dir.join("b"));
    let o = wetcloth(
        &[
            "--threads",
            "1",
            "run",
            &scene,
            "--out",
            a.to_str().unwrap(),
            "-q",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = wetcloth(
        &[
            "run",
            &scene,
            "--out",
            b.to_str().unwrap(),
            "-q",
            "--threads",
            "2",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["metrics.csv", "run.json", "frames/frame_0010.obj"] {
        assert_eq!(
            fs::read(a.join(f)).unwrap(),
            fs::read(b.join(f)).unwrap(),
            "{f}"
        );
    }
    let o = wetcloth(
        &[
            "--threads",
            "1",
            "run",
            &scene,
            "--out",
            a.to_str().unwrap(),
            "--threads",
            "2",
        ],
        &[],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--threads is given twice"),
        "{}",
        stderr(&o)
    );
}

/// Found from outside: 4096 x 4096 (the documented maximum) took over 3.6 GB while still
/// writing frame 0, and a 200 x 200 cloth 1 mm across with thick particles exhausted memory.
/// Both are refused before anything is written, with what they need and the flag to go
/// ahead.
#[test]
fn runs_that_cannot_fit_are_refused_before_anything_is_written() {
    let dir = scratch("too-big");
    let out = dir.join("out");
    let huge = write(&dir, "huge.toml", "[cloth]\nresolution = [4096, 4096]\n");
    let o = wetcloth(&["run", &huge, "--out", out.to_str().unwrap()], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("of memory") && err.contains("--force"),
        "{err}"
    );
    assert!(err.contains("16777216 particles"), "{err}");
    assert!(!out.exists(), "nothing written");
    let thick = write(
        &dir,
        "thick.toml",
        "[cloth]\nresolution = [400, 400]\nsize = [0.001, 0.001]\nthickness = 0.01\nposition = [0, 0.01, 0]\n",
    );
    let o = wetcloth(&["run", &thick, "--out", out.to_str().unwrap()], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("self-collision candidate pairs") && err.contains("--force"),
        "{err}"
    );
    assert!(!out.exists());
}

/// The estimate of a large run is printed before it starts (and not with --quiet); a small
/// run prints none, and --force is accepted.
#[test]
fn the_estimate_of_a_large_run_is_printed_first() {
    let dir = scratch("estimate");
    let out = dir.join("out");
    // 20 000 frames of a small cloth: a long run that writes gigabytes; stopped at once by
    // an impossible first frame write (a directory in the way of metrics.csv).
    let scene = write(
        &dir,
        "long.toml",
        "name = \"many\"\n[simulation]\nduration = 2000\nframe_rate = 10\n[cloth]\nresolution = [100, 100]\n",
    );
    fs::create_dir_all(out.join("metrics.csv")).unwrap();
    let o = wetcloth(
        &["run", &scene, "--out", out.to_str().unwrap(), "--force"],
        &[],
    );
    let err = stderr(&o);
    assert!(err.contains("wetcloth: many needs about"), "{err}");
    assert!(err.contains("of disk (20001 frames of"), "{err}");
    let o = wetcloth(
        &[
            "run",
            &scene,
            "--out",
            out.to_str().unwrap(),
            "--force",
            "-q",
        ],
        &[],
    );
    assert!(!stderr(&o).contains("needs about"), "{}", stderr(&o));
    let small = write(&dir, "small.toml", SMALL);
    let o = wetcloth(
        &[
            "run",
            &small,
            "--out",
            dir.join("s").to_str().unwrap(),
            "--force",
        ],
        &[],
    );
    assert!(o.status.success());
    assert!(!stderr(&o).contains("needs about"), "{}", stderr(&o));
}

/// Found from outside: a scene file was read without a size limit (`run /dev/zero` never
/// ended).
#[cfg(unix)]
#[test]
fn run_dev_zero_is_refused() {
    let o = wetcloth(&["run", "/dev/zero"], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("/dev/zero") && err.contains("16 MiB"), "{err}");
}

/// Found from outside: `--wetness nan` was accepted, `render --frames 999` said "no frames"
/// although there are frames, and the help of `--no-video` and `--no-grabs` said the
/// opposite of what they do.
#[test]
fn render_options_say_what_they_do() {
    let o = wetcloth(&["render", "x", "--wetness", "nan"], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("0 (dry) to 1 (wet)"), "{}", stderr(&o));
    let help = String::from_utf8_lossy(&wetcloth(&["render", "--help"], &[]).stdout).into_owned();
    assert!(help.contains("Do not encode an MP4"), "{help}");
    assert!(help.contains("Do not mark the grabbed particles"), "{help}");
    assert!(!help.contains("Also encode an MP4"), "{help}");

    let dir = scratch("frames-999");
    let scene = write(&dir, "small.toml", SMALL);
    let out = dir.join("out");
    assert!(
        wetcloth(&["run", &scene, "--out", out.to_str().unwrap(), "-q"], &[])
            .status
            .success()
    );
    let o = wetcloth(&["render", out.to_str().unwrap(), "--frames", "999"], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("no frame of") && err.contains("11 frame(s), numbered 0 to 10"),
        "{err}"
    );
}

/// Found from outside: `bench --seconds` did not bound the run's time. Each measurement's
/// warm-up and windows now stop at their time (reported as `measured_seconds`).
#[test]
fn bench_seconds_bounds_each_measurement() {
    let dir = scratch("bench-seconds");
    let json = dir.join("b.json");
    let o = wetcloth(
        &[
            "bench",
            "--sizes",
            "10,60",
            "--threads",
            "1",
            "--seconds",
            "0.3",
            "--json",
            json.to_str().unwrap(),
            "-q",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&fs::read_to_string(&json).unwrap()).unwrap();
    for m in v.as_array().unwrap() {
        let measured = m["measured_seconds"].as_f64().unwrap();
        let step = 1.0 / m["steps_per_second"].as_f64().unwrap();
        // 1.2 S, plus a chunk of about a fortieth of a window per window and warm-up, plus
        // the odd descheduling on a busy machine.
        assert!(
            measured <= 1.2 * 0.3 + 8.0 * (0.3 / 7.0 / 20.0 + step) + 0.3,
            "{m}"
        );
        assert!(measured >= 0.3, "{m}");
    }
}

/// Found from outside: the docs listed 9 metrics columns where `metrics.csv` has 10.
#[test]
fn the_docs_list_every_metrics_column() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    for doc in ["README.md", "docs/cli.md"] {
        let text = fs::read_to_string(root.join(doc)).unwrap();
        assert!(
            text.contains(wetcloth_export::CSV_HEADER),
            "{doc} lacks the full header"
        );
    }
}

/// Found from outside: a plane 10 km above the cloth gave exit 0 and a cloth flung 2000 km.
/// A cloth that starts inside a collider is bad input (exit 2), located, with nothing written.
#[test]
fn a_cloth_inside_a_collider_is_refused_before_the_run() {
    let dir = scratch("inside");
    let scene = write(
        &dir,
        "above.toml",
        "[simulation]\nduration = 0.1\n\n[[collider]]\nshape = \"plane\"\npoint = [0, 10000, 0]\n",
    );
    let out = dir.join("out");
    let o = wetcloth(&["run", &scene, "--out", out.to_str().unwrap()], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("above.toml:6:9: collider[0].point"), "{err}");
    assert!(err.contains("10000 m inside"), "{err}");
    assert!(!out.exists());
}
