//! `wetcloth run --set KEY=VALUE`: a scene key overridden for one run, checked as the file is.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli-set")
        .join(test);
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn wetcloth(args: &[&str]) -> Output {
    Command::new(BIN)
        .arg("--quiet")
        .args(args)
        .output()
        .expect("the wetcloth binary runs")
}

const SCENE: &str = r#"
name = "small"
[simulation]
duration = 0.02
frame_rate = 100.0
[cloth]
size = [0.1, 0.1]
resolution = [6, 6]
[air]
trapped_air = 2e-5
"#;

#[test]
fn set_values_reach_the_run_and_its_scene_toml() {
    let dir = scratch("reach");
    let scene = dir.join("small.toml");
    fs::write(&scene, SCENE).unwrap();
    let out = dir.join("out");
    let o = wetcloth(&[
        "run",
        scene.to_str().unwrap(),
        "--set",
        "air.trapped_air=4e-5",
        "--set",
        "air.model=pockets",
        "--set",
        "cloth.size=[0.12,0.12]",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let resolved = wetcloth_scene::load(out.join("scene.toml")).unwrap();
    assert_eq!(resolved.config.air.trapped_air, 4e-5);
    assert_eq!(resolved.config.cloth.size, [0.12, 0.12]);
    assert_eq!(resolved.config.air.model, wetcloth::AirModelKind::Pockets);
    // The rest is the file's.
    assert_eq!(resolved.config.cloth.resolution, [6, 6]);
    // The run ran it: the pockets model writes its pocket labels beside the frames.
    assert!(out.join("frames").join("frame_0000.pockets").is_file());
}

#[test]
fn a_bad_set_is_refused_before_anything_runs() {
    let dir = scratch("bad");
    let out = dir.join("out");
    let run = |args: &[&str]| {
        let mut all = vec!["run"];
        all.extend_from_slice(args);
        all.extend_from_slice(&["--out", out.to_str().unwrap()]);
        wetcloth(&all)
    };
    let o = run(&["--set", "cloth.masss=0.1"]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.starts_with("error: set cloth.masss: unknown key `cloth.masss`; did you mean `mass`?"),
        "{e}"
    );
    let o = run(&["--set", "cloth.mass"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("expected KEY=VALUE"));
    let o = run(&["--set", "cloth.mass=heavy"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("cloth.mass = \"heavy\" has the wrong type")
    );
    assert!(!out.exists(), "nothing is written for a refused scene");
    // A resumed run is the run it was: no overrides.
    let o = wetcloth(&[
        "run",
        "--resume",
        out.to_str().unwrap(),
        "--set",
        "cloth.mass=0.1",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("--set"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}
