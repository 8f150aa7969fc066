//! Fuzzing `wetcloth run` end to end: short runs of generated scenes across the documented
//! ranges (and now and then beyond them: refused), into output folders that are sometimes
//! already damaged (stale `.part` links pointing outside, a directory where a frame goes).
//! Properties: the exit status is 0, 1 or 2 and never a panic, an abort or a hang; a run that
//! exits 0 wrote as many frames and metrics rows as `run.json` says, all finite, and says
//! `complete`; one that exits 1 says `failed`, with the error, and keeps what it wrote, all
//! finite; one that exits 2 wrote nothing; no run writes through a link or leaves a `.part`;
//! no pocket in `pockets.csv` holds negative air or has a negative pressure; `run.json` stays
//! under a megabyte; and a run that stopped part way, its checkpoint then damaged in one bit,
//! is refused by `--resume` (exit 2, naming the checkpoint). The scenes use every key of the
//! format (pockets, paint, seeds, both integrators and budgets, both pressure forces, still,
//! moving and mesh colliders, grabs), and the meshes include damaged and odd ones (`MESHES`).
//!
//! A short campaign runs with the test suite; the long one (10 000 runs) is
//! `cargo test --release -p wetcloth-cli --test fuzz -- --ignored`. `WETCLOTH_FUZZ_CASES` and
//! `WETCLOTH_FUZZ_SEED` set the cases and the seed (docs/reliability.md). A failure prints the
//! smallest scene found: keep it as a regression test named after what it found.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

/// A run that takes longer than this is a hang.
const HANG: Duration = Duration::from_secs(120);

fn cases(default: u32) -> u32 {
    std::env::var("WETCLOTH_FUZZ_CASES")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(default)
}

fn runner(cases: u32) -> TestRunner {
    let seed: u64 = std::env::var("WETCLOTH_FUZZ_SEED")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(0x72_756e);
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let config = Config {
        cases,
        max_shrink_iters: 200,
        failure_persistence: None,
        ..Config::default()
    };
    eprintln!("fuzz: {cases} runs, seed {seed}");
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &bytes))
}

/// Log-uniform in `[lo, hi]`, with 0 now and then when `lo` is 0.
fn log_range(lo: f64, hi: f64) -> BoxedStrategy<f64> {
    let a = lo.max(hi * 1e-9).ln();
    let b = hi.ln();
    let log = (a..=b).prop_map(move |x| x.exp().clamp(lo, hi));
    if lo == 0.0 {
        prop_oneof![5 => log, 1 => Just(0.0), 1 => Just(hi)].boxed()
    } else {
        prop_oneof![5 => log, 1 => Just(lo), 1 => Just(hi)].boxed()
    }
}

fn f(v: f64) -> String {
    format!("{v:?}")
}

/// A value now and then pushed out of its range (the scene is then refused, exit 2).
fn maybe_out(s: BoxedStrategy<f64>) -> BoxedStrategy<f64> {
    prop_oneof![
        30 => s,
        1 => prop::sample::select(vec![-1.0, 1e308, -1e-300, 2e7, f64::NAN, f64::INFINITY]),
    ]
    .boxed()
}

/// A value rarely pushed out of its range.
fn rarely_out(s: BoxedStrategy<f64>) -> BoxedStrategy<f64> {
    prop_oneof![
        100 => s,
        1 => prop::sample::select(vec![-1.0, 1e308, f64::NAN]),
    ]
    .boxed()
}

fn toml(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        f(v)
    }
}

/// The meshes beside the fuzzed scenes, by file name: an octahedron of radius 1, and damaged or
/// odd ones (the octahedron with a second one wound the other way, a square's two faces, a
/// triangle 1e200 m away, a cut file with a NaN and a missing vertex, and one that is missing).
const MESHES: [(&str, &str); 6] = [
    ("mesh.obj", OCTAHEDRON),
    (
        "inside-out.obj",
        "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n\
         f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n\
         v 4 0 0\nv 2 0 0\nv 3 1 0\nv 3 -1 0\nv 3 0 1\nv 3 0 -1\n\
         f 7 11 9\nf 9 11 8\nf 8 11 10\nf 10 11 7\nf 9 12 7\nf 8 12 9\nf 10 12 8\nf 7 12 10\n",
    ),
    (
        "flat.obj",
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 2 3\nf 1 3 4\nf 2 1 4\nf 2 4 3\n",
    ),
    (
        "huge.obj",
        "v 0 -1e200 0\nv 1e200 -1e200 0\nv 0 -1e200 1e200\nf 1 2 3\n",
    ),
    ("damaged.obj", "v 0 0 0\nv nan 1 0\nv 0 0\nf 1 2 9\nf 1"),
    ("missing.obj", ""),
];

/// An octahedron of radius 1.
const OCTAHEDRON: &str = "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n\
    f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";

#[derive(Clone, Debug)]
struct Shape {
    text: String,
}

fn collider() -> impl Strategy<Value = Shape> {
    let friction = log_range(0.0, 10.0);
    prop_oneof![
        (-0.5f64..0.0, -1.0f64..1.0, 0.2f64..1.0, -1.0f64..1.0, friction.clone()).prop_map(
            |(y, nx, ny, nz, mu)| Shape {
                text: format!(
                    "[[collider]]\nshape = \"plane\"\npoint = [0, {}, 0]\nnormal = [{}, {}, {}]\nfriction = {}\n",
                    f(y), f(nx), f(ny), f(nz), f(mu)
                )
            }
        ),
        (-2.0f64..2.0, -2.0f64..-0.05, -2.0f64..2.0, log_range(1e-3, 1e4), friction.clone())
            .prop_map(|(x, y, z, r, mu)| Shape {
                text: format!(
                    "[[collider]]\nshape = \"sphere\"\ncenter = [{}, {}, {}]\nradius = {}\nfriction = {}\n",
                    f(x), f(y - r), f(z), f(r), f(mu)
                )
            }),
        (-2.0f64..2.0, -2.0f64..-0.05, -2.0f64..2.0, 0.01f64..1.0, 0.01f64..1.0, friction.clone())
            .prop_map(|(x, y, z, hx, hy, mu)| Shape {
                text: format!(
                    "[[collider]]\nshape = \"box\"\ncenter = [{}, {}, {}]\nhalf_extents = [{}, {}, {}]\nfriction = {}\n",
                    f(x), f(y - hy), f(z), f(hx), f(hy), f(hx), f(mu)
                )
            }),
        // The octahedron of `mesh.obj` (written beside the scene: radius 1 before `scale`), or
        // now and then a damaged or odd mesh (see `MESHES`).
        (
            -2.0f64..2.0,
            -2.0f64..-0.05,
            -2.0f64..2.0,
            log_range(1e-3, 10.0),
            (-180.0f64..180.0, -180.0f64..180.0),
            friction,
            prop_oneof![6 => Just("mesh.obj"), 1 => prop::sample::select(MESHES.iter().map(|m| m.0).collect::<Vec<_>>())],
        )
            .prop_map(|(x, y, z, r, (rx, ry), mu, file)| Shape {
                text: format!(
                    "[[collider]]\nshape = \"mesh\"\nfile = \"{file}\"\nposition = [{}, {}, {}]\nrotation = [{}, {}, 0]\nscale = {}\nfriction = {}\n",
                    f(x), f(y - r), f(z), f(rx), f(ry), f(r), f(mu)
                )
            }),
    ]
    .prop_flat_map(|shape| (Just(shape), any::<bool>(), prop::option::weighted(0.2, motion())))
    .prop_map(|(shape, sticky, motion)| Shape {
        text: format!("{}sticky = {sticky}\n{}", shape.text, motion.unwrap_or_default()),
    })
}

/// A collider's motion: up to three keys within 30 ms, moving up to 20 cm and turning.
fn motion() -> impl Strategy<Value = String> {
    prop::collection::vec(
        (
            0.0f64..0.01,
            prop::collection::vec(-0.2f64..0.2, 3),
            prop::collection::vec(-90.0f64..90.0, 3),
        ),
        1..4,
    )
    .prop_map(|keys| {
        let mut t = 0.0;
        let keys: Vec<String> = keys
            .iter()
            .map(|(dt, o, r)| {
                t += dt;
                format!(
                    "{{ time = {}, offset = [{}, {}, {}], rotation = [{}, {}, {}] }}",
                    f(t),
                    f(o[0]),
                    f(o[1]),
                    f(o[2]),
                    f(r[0]),
                    f(r[1]),
                    f(r[2])
                )
            })
            .collect();
        format!("keys = [{}]\n", keys.join(", "))
    })
}

/// Wetness, the pockets air model and its keys, painted regions and seeded pockets: the text
/// to add to `[cloth]` and `[air]`, and the tables that follow each.
#[derive(Clone, Debug)]
struct Wet {
    cloth: String,
    paint: String,
    air: String,
    pockets: String,
}

fn wet() -> impl Strategy<Value = Wet> {
    let cloth = (
        0.0f64..=1.0,
        log_range(0.0, 100.0),
        log_range(0.0, 10.0),
        log_range(0.0, 1e6),
    );
    let paint = prop::collection::vec(
        (
            (-0.6f64..0.6, -0.6f64..0.6),
            0.0f64..=1.0,
            any::<bool>(),
            log_range(1e-3, 1.0),
        ),
        0..3,
    );
    let air = (
        prop::bool::weighted(0.6),
        log_range(0.0, 0.1),
        maybe_out((0.01f64..=1.0).boxed()),
        (log_range(0.0, 1.0), log_range(0.0, 1.0)),
    );
    let pockets = prop::collection::vec(
        (
            (-0.6f64..0.6, -0.6f64..0.6),
            log_range(1e-3, 1.0),
            log_range(0.0, 1e-2),
        ),
        0..3,
    );
    (prop::bool::weighted(0.5), cloth, paint, air, pockets).prop_map(
        |(on, (wetness, water, dry, adhesion), paint, (pockets_model, seal, seal_wet, (perm, dry_perm)), seeds)| {
            if !on {
                return Wet { cloth: String::new(), paint: String::new(), air: String::new(), pockets: String::new() };
            }
            let cloth = format!(
                "wetness = {}\nwater_mass = {}\ndry_friction_factor = {}\nwet_adhesion = {}\n",
                f(wetness), f(water), f(dry), f(adhesion)
            );
            let paint = paint
                .iter()
                .map(|((x, z), w, disc, r)| {
                    let shape = if *disc {
                        format!("radius = {}", f(*r))
                    } else {
                        format!("half_size = [{}, {}]", f(*r), f(r * 0.5))
                    };
                    format!("[[cloth.paint]]\ncenter = [{}, {}]\n{shape}\nwetness = {}\n", f(*x), f(*z), f(*w))
                })
                .collect();
            if !pockets_model {
                return Wet { cloth, paint, air: String::new(), pockets: String::new() };
            }
            let air = format!(
                "model = \"pockets\"\nseal_distance = {}\nseal_wetness = {}\npermeability = {}\ndry_permeability = {}\nseal_hysteresis = {}\n",
                f(seal), toml(seal_wet), f(perm), f(dry_perm), f((seal * 1e3).fract())
            );
            let pockets = seeds
                .iter()
                .map(|((x, z), r, amount)| {
                    format!("[[air.pocket]]\ncenter = [{}, {}]\nradius = {}\namount = {}\n", f(*x), f(*z), f(*r), f(*amount))
                })
                .collect();
            Wet { cloth, paint, air, pockets }
        },
    )
}

/// A short scene anywhere in the documented ranges.
fn scene() -> impl Strategy<Value = String> {
    let sim = (
        1e-3f64..0.03,
        log_range(1e-6, 1e-3),
        log_range(1.0, 1e4),
        prop::collection::vec(rarely_out(log_range(0.0, 1000.0)), 3),
    );
    let cloth = (
        (2usize..10, 2usize..10),
        (log_range(1e-3, 10.0), log_range(1e-3, 10.0)),
        maybe_out(log_range(1e-6, 1e4)),
        (maybe_out(log_range(0.0, 1e7)), log_range(0.0, 1e7)),
        maybe_out(log_range(0.0, 1e4)),
        (log_range(0.0, 0.1), log_range(0.0, 0.1)),
        any::<bool>(),
        (log_range(0.0, 10.0), 1usize..=100),
        0.0f64..0.5,
    );
    let air = (
        any::<bool>(),
        log_range(0.0, 1e7),
        log_range(0.0, 1e3),
        log_range(0.0, 10.0),
        (any::<bool>(), any::<bool>()),
    );
    let grabs = prop::collection::vec(
        (
            (0.0f64..1.0, 0.0f64..1.0),
            prop::collection::vec(
                (0.0f64..0.02, -1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
                1..4,
            ),
        ),
        0..3,
    );
    let integrator = prop_oneof![
        3 => Just(None),
        1 => (log_range(1.0 / 2400.0, 0.05), any::<bool>()).prop_map(Some)
    ];
    (sim, cloth, air, prop::collection::vec(collider(), 0..3), grabs, prop::bool::weighted(0.9), (wet(), integrator))
        .prop_map(|(sim, cloth, air, colliders, grabs, ground, (wet, implicit))| {
            let (duration, dt, rate, gravity) = sim;
            // At most about 3000 steps; the implicit integrator at its large steps.
            let (implicit, budget) = match implicit {
                Some((dt, interactive)) => (Some(dt), interactive),
                None => (None, false),
            };
            let dt = implicit.unwrap_or(dt).max(duration / 3000.0);
            let (res, size, mass, (ks, kh), damping, (thick, margin), sc, (limit, iters), lift) = cloth;
            let radius = 0.5 * (thick + margin);
            let mut s = format!(
                "name = \"fuzz\"\n[simulation]\nduration = {}\ntime_step = {}\nframe_rate = {}\ngravity = [{}]\nintegrator = \"{}\"\nimplicit_budget = \"{}\"\n",
                f(duration),
                f(dt),
                f(rate),
                gravity.iter().map(|g| toml(*g)).collect::<Vec<_>>().join(", "),
                if implicit.is_some() { "implicit" } else { "verlet" },
                if budget { "interactive" } else { "converged" }
            );
            s += &format!(
                "[cloth]\nresolution = [{}, {}]\nsize = [{}, {}]\nposition = [0, {}, 0]\nmass = {}\n\
                 structural_stiffness = {}\nshear_stiffness = {}\ndamping = {}\nthickness = {}\n\
                 collision_margin = {}\nself_collision = {sc}\nstrain_limit = {}\n\
                 strain_limit_iterations = {iters}\n",
                res.0, res.1, f(size.0), f(size.1), f(radius + 1e-6 + lift), toml(mass), toml(ks), f(kh),
                toml(damping), f(thick), f(margin), f(limit)
            );
            s += &wet.cloth;
            s += &wet.paint;
            let (enabled, pa, v0, leak, (implicit, area)) = air;
            s += &format!(
                "[air]\nenabled = {enabled}\natmospheric_pressure = {}\ntrapped_air = {}\n\
                 leak_conductance = {}\npressure_solve = \"{}\"\npressure_force = \"{}\"\n",
                f(pa), f(v0), f(leak), if implicit { "implicit" } else { "explicit" },
                if area { "area" } else { "thesis" }
            );
            s += &wet.air;
            s += &wet.pockets;
            if ground {
                s += "[[collider]]\nshape = \"plane\"\n";
            }
            for c in colliders {
                s += &c.text;
            }
            for ((fi, fj), keys) in grabs {
                // A particle of the grid (the scene reader refuses others).
                let (i, j) = ((fi * res.0 as f64) as usize, (fj * res.1 as f64) as usize);
                let mut t = 0.0;
                let keys: Vec<String> = keys
                    .iter()
                    .map(|(dt, x, y, z)| {
                        t += dt;
                        format!("{{ time = {}, offset = [{}, {}, {}] }}", f(t), f(*x), f(*y), f(*z))
                    })
                    .collect();
                s += &format!("[[grab]]\nparticle = [{i}, {j}]\nkeys = [{}]\n", keys.join(", "));
            }
            s
        })
}

/// Damage already in the output folder before the run.
#[derive(Clone, Debug)]
enum Before {
    Nothing,
    /// Stale `.part` links to a file outside the folder.
    PartLinks,
    /// A directory where frame 1 goes.
    DirectoryForAFrame,
    /// Stale frames of another run.
    OldFrames,
}

fn before() -> impl Strategy<Value = Before> {
    prop_oneof![
        6 => Just(Before::Nothing),
        1 => Just(Before::PartLinks),
        1 => Just(Before::DirectoryForAFrame),
        1 => Just(Before::OldFrames),
    ]
}

fn prepare(out: &Path, sentinel: &Path, b: &Before) {
    let _ = fs::remove_dir_all(out);
    fs::write(sentinel, "outside").unwrap();
    match b {
        Before::Nothing => {}
        Before::PartLinks => {
            fs::create_dir_all(out.join("frames")).unwrap();
            #[cfg(unix)]
            for name in [
                "frames/frame_0000.obj.part",
                "run.json.part",
                "scene.toml.part",
                "metrics.csv",
            ] {
                std::os::unix::fs::symlink(sentinel, out.join(name)).unwrap();
            }
        }
        Before::DirectoryForAFrame => {
            fs::create_dir_all(out.join("frames/frame_0001.obj/x")).unwrap();
        }
        Before::OldFrames => {
            fs::create_dir_all(out.join("frames")).unwrap();
            for k in 0..50 {
                fs::write(out.join(format!("frames/frame_{k:04}.obj")), "old").unwrap();
            }
        }
    }
}

/// Every number of a text file (words that parse as numbers, in `v`, `vn` lines of an OBJ and
/// every field of a CSV) is finite.
fn all_finite(path: &Path) -> bool {
    let text = fs::read_to_string(path).unwrap_or_default();
    text.lines().all(|line| {
        let line = line.trim();
        if line.starts_with('#') || line.starts_with("f ") || line.starts_with("frame,") {
            return true;
        }
        line.split([' ', ','])
            .filter_map(|w| {
                w.parse::<f64>().ok().or_else(|| {
                    (w.eq_ignore_ascii_case("nan") || w.contains("inf")).then_some(f64::NAN)
                })
            })
            .all(f64::is_finite)
    })
}

fn parts(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    if let Ok(rd) = fs::read_dir(dir) {
        for e in rd.flatten() {
            let p = e.path();
            if fs::symlink_metadata(&p).is_ok_and(|m| m.is_dir()) {
                found.extend(parts(&p));
            } else if p.to_string_lossy().ends_with(".part") {
                found.push(p);
            }
        }
    }
    found
}

fn run_case(dir: &Path, scene: &str, b: &Before, damage: usize) -> Result<(), TestCaseError> {
    let path = dir.join("fuzz.toml");
    fs::write(&path, scene).unwrap();
    let out = dir.join("out");
    let sentinel = dir.join("sentinel.txt");
    prepare(&out, &sentinel, b);
    let mut child = Command::new(BIN)
        .args([
            "run",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ])
        .env_remove("RAYON_NUM_THREADS")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > HANG {
            let _ = child.kill();
            let _ = child.wait();
            return Err(TestCaseError::fail(format!("hung for {HANG:?}")));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    prop_assert!(!err.contains("panicked"), "{}", err);
    let code = status.code();
    prop_assert!(matches!(code, Some(0..=2)), "exit {:?}: {}", status, err);
    tally(scene, code.unwrap_or(3) as usize, &err);
    prop_assert_eq!(
        fs::read_to_string(&sentinel).unwrap(),
        "outside",
        "wrote through a link"
    );
    if code == Some(2) {
        // Refused before anything was written (a prepared folder stays as it was).
        if matches!(b, Before::Nothing) {
            prop_assert!(!out.exists(), "exit 2 but wrote: {}", err);
        }
        return Ok(());
    }
    prop_assert_eq!(parts(&out), Vec::<PathBuf>::new(), "{}", err);
    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("run.json")).unwrap())
            .map_err(|e| TestCaseError::fail(format!("run.json: {e}; {err}")))?;
    let frames = json["frames"].as_u64().unwrap() as usize;
    let objs: Vec<PathBuf> = fs::read_dir(out.join("frames"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "obj"))
        .collect();
    if code == Some(0) {
        prop_assert_eq!(&json["status"], "complete", "{}", err);
        prop_assert_eq!(objs.len(), frames);
        prop_assert!(frames >= 1);
    } else {
        prop_assert_eq!(&json["status"], "failed", "{}", err);
        prop_assert!(json["error"].as_str().is_some_and(|e| !e.is_empty()));
        // Frames of this run only: frame 1 may be the prepared directory.
        prop_assert!(objs.len() >= frames.min(1));
    }
    if out.join("metrics.csv").is_file() {
        let rows = fs::read_to_string(out.join("metrics.csv"))
            .unwrap()
            .lines()
            .count()
            - 1;
        prop_assert_eq!(rows, frames, "{}", err);
        prop_assert!(
            all_finite(&out.join("metrics.csv")),
            "non-finite metrics: {}",
            err
        );
    }
    for p in &objs {
        prop_assert!(all_finite(p), "non-finite numbers in {}", p.display());
    }
    prop_assert!(json["time"].as_f64().is_some_and(f64::is_finite));
    // No pocket ever holds negative air or a negative absolute pressure.
    if let Ok(text) = fs::read_to_string(out.join("pockets.csv")) {
        for row in text.lines().skip(1) {
            let v: Vec<f64> = row.split(',').filter_map(|x| x.parse().ok()).collect();
            // frame,time,pocket,volume,amount,pressure,area,particles
            prop_assert!(
                v.len() == 8 && v[4] >= -1e-15 && v[5] >= -1e-3,
                "pockets.csv: {}; {}",
                row,
                err
            );
        }
    }
    // run.json stays small whatever the meshes.
    prop_assert!(fs::metadata(out.join("run.json")).unwrap().len() < 1 << 20);
    // A damaged checkpoint of a run that stopped part way is refused, naming it.
    let ckpt = out.join("checkpoint.bin");
    if code == Some(1)
        && let Ok(mut bytes) = fs::read(&ckpt)
        && !bytes.is_empty()
    {
        let k = damage % bytes.len();
        bytes[k] ^= 1 << (damage % 8);
        fs::write(&ckpt, &bytes).unwrap();
        let o = Command::new(BIN)
            .args(["run", "--resume", out.to_str().unwrap(), "-q"])
            .env_remove("RAYON_NUM_THREADS")
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        prop_assert!(!e.contains("panicked"), "{}", e);
        prop_assert_eq!(
            o.status.code(),
            Some(2),
            "damaged byte {} resumed: {}",
            k,
            e
        );
        prop_assert!(e.contains("checkpoint.bin"), "{}", e);
    }
    Ok(())
}

/// Features of the scenes, counted by exit status to show what the campaign reaches.
const FEATURES: [&str; 11] = [
    "integrator = \"implicit\"",
    "\"pockets\"",
    "[[air.pocket]]",
    "[[cloth.paint]]",
    "\"mesh\"",
    "], rotation = [",
    "implicit_budget = \"interactive\"",
    "pressure_force = \"area\"",
    "[[grab]]",
    "\"inside-out.obj\"",
    "\"flat.obj\"",
];

/// Runs by exit status (0, 1, 2): all, then with each feature.
type ByExit = [[u64; 12]; 3];
/// The first words of exit-1 errors (digits dropped) and how often each came.
type Errors = Vec<(String, u64)>;
static TALLY: std::sync::Mutex<(ByExit, Errors)> =
    std::sync::Mutex::new(([[0; 12]; 3], Vec::new()));

fn tally(scene: &str, code: usize, err: &str) {
    let mut t = TALLY.lock().unwrap_or_else(|e| e.into_inner());
    if code > 2 {
        return;
    }
    // Every thousand runs, the counts so far (a long campaign cut short still reports).
    let done: u64 = t.0.iter().map(|row| row[0]).sum::<u64>() + 1;
    if done.is_multiple_of(1000) {
        let so_far: Vec<u64> = t.0.iter().map(|row| row[0]).collect();
        eprintln!("fuzz: {done} runs so far, by exit status 0, 1, 2: {so_far:?} (before this one)");
    }
    t.0[code][0] += 1;
    for (k, feature) in FEATURES.iter().enumerate() {
        if scene.contains(feature) {
            t.0[code][k + 1] += 1;
        }
    }
    if code == 1 {
        let what: String = err
            .lines()
            .find(|l| l.starts_with("error"))
            .unwrap_or("")
            .chars()
            .filter(|c| !c.is_ascii_digit())
            .take(60)
            .collect();
        match t.1.iter_mut().find(|(w, _)| *w == what) {
            Some((_, n)) => *n += 1,
            None => t.1.push((what, 1)),
        }
    }
}

fn report() {
    let t = TALLY.lock().unwrap_or_else(|e| e.into_inner());
    for (code, row) in t.0.iter().enumerate() {
        let with: Vec<String> = FEATURES
            .iter()
            .zip(&row[1..])
            .map(|(f, n)| format!("{f} {n}"))
            .collect();
        eprintln!("fuzz: exit {code}: {} runs ({})", row[0], with.join(", "));
    }
    for (what, n) in &t.1 {
        eprintln!("fuzz: exit 1 x{n}: {what}");
    }
}

fn campaign(n: u32) {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-run");
    fs::create_dir_all(&dir).unwrap();
    for (name, text) in MESHES {
        if name == "missing.obj" {
            let _ = fs::remove_file(dir.join(name));
        } else {
            fs::write(dir.join(name), text).unwrap();
        }
    }
    runner(n)
        .run(
            &(scene(), before(), any::<usize>()),
            |(scene, b, damage)| run_case(&dir, &scene, &b, damage),
        )
        .unwrap();
    report();
}

#[test]
fn short_runs_of_generated_scenes_exit_cleanly_and_write_only_finite_numbers() {
    campaign(cases(40));
}

/// The long campaign: 10 000 short runs, unless `WETCLOTH_FUZZ_CASES` says otherwise.
#[test]
#[ignore = "long fuzz campaign: run with --ignored"]
fn long_campaign_ten_thousand_runs() {
    campaign(cases(10_000));
}
