//! Fuzzing the scene reader: generated scene files (every key, values of every TOML type,
//! extreme and non-finite numbers, misspelt keys, tables written as arrays) and byte-level
//! mutations of them. Properties: no panic, no hang; a scene that is accepted validates, starts
//! clear of its colliders, and its resolved `scene.toml` reads back to the same configuration;
//! a refusal names the file and, where it has a line, the line really is that line of the text.
//!
//! A short campaign runs with the test suite. The long one (a million scene files) is
//! `cargo test --release -p wetcloth-scene --test fuzz -- --ignored`; `WETCLOTH_FUZZ_CASES`
//! sets the number of cases of any campaign and `WETCLOTH_FUZZ_SEED` its seed (the default
//! seed is fixed, so the short campaign is the same on every run). See docs/reliability.md.
//! A failure prints the smallest input found: keep it as a regression test named after what
//! it found (as `tests/misleading_messages.rs` and `tests/cloth_inside_collider.rs` do).

use std::sync::Mutex;
use std::time::{Duration, Instant};

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};
use wetcloth_scene::{Scene, SceneError, parse};

/// A case that takes longer than this is a hang: the watchdog prints it and aborts.
const HANG: Duration = Duration::from_secs(20);

/// The case being run and when it started, for the watchdog.
static CURRENT: Mutex<Option<(Instant, String)>> = Mutex::new(None);

fn watchdog() {
    static STARTED: std::sync::Once = std::sync::Once::new();
    STARTED.call_once(|| {
        std::thread::spawn(|| {
            loop {
                std::thread::sleep(Duration::from_millis(200));
                let guard = CURRENT.lock().unwrap_or_else(|e| e.into_inner());
                if let Some((t, input)) = guard.as_ref()
                    && t.elapsed() > HANG
                {
                    eprintln!("fuzz: a case hung for {HANG:?}; its input:\n{input:?}");
                    std::process::abort();
                }
            }
        });
    });
}

/// Runs `f` on `input` under the watchdog.
fn guarded<T>(input: &str, f: impl FnOnce() -> T) -> T {
    *CURRENT.lock().unwrap_or_else(|e| e.into_inner()) = Some((Instant::now(), input.into()));
    let out = f();
    *CURRENT.lock().unwrap_or_else(|e| e.into_inner()) = None;
    out
}

/// Cases: `WETCLOTH_FUZZ_CASES`, else `default`.
fn cases(default: u32) -> u32 {
    std::env::var("WETCLOTH_FUZZ_CASES")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(default)
}

/// A runner with `cases` cases, seeded from `WETCLOTH_FUZZ_SEED` (default fixed).
fn runner(cases: u32) -> TestRunner {
    watchdog();
    let seed: u64 = std::env::var("WETCLOTH_FUZZ_SEED")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(0x7765_7463_6c6f_7468);
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let config = Config {
        cases,
        max_shrink_iters: 4096,
        failure_persistence: None,
        ..Config::default()
    };
    eprintln!("fuzz: {cases} cases, seed {seed}");
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &bytes))
}

/// A float as TOML writes it (`nan`, `inf`, `-inf`, or the shortest exact text).
fn toml_float(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        format!("{v:?}")
    }
}

fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => (-2.0f64..2.0).prop_map(toml_float),
        3 => (-1e4f64..1e4).prop_map(toml_float),
        3 => any::<f64>().prop_map(toml_float),
        2 => (0u64..5000).prop_map(|v| v.to_string()),
        1 => any::<i64>().prop_map(|v| v.to_string()),
        1 => prop::sample::select(vec![
            "inf", "-inf", "nan", "-nan", "+inf", "-0.0", "0", "1e308", "-1e308", "1.7976931348623157e308",
            "5e-324", "1e-320", "1e-7", "1e-2", "1e4", "1e7", "4096", "4097", "1", "2", "1_000", "0x10",
            "0o7", "0b1", "1e", ".5", "1.", "+1", "9223372036854775807", "18446744073709551616",
        ])
        .prop_map(String::from),
    ]
}

fn scalar() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => number(),
        1 => prop::bool::ANY.prop_map(|b| b.to_string()),
        1 => "[a-z0-9 _.-]{0,12}".prop_map(|s| format!("{s:?}")),
        1 => prop::sample::select(vec![
            "1979-05-27", "07:32:00", "1979-05-27T07:32:00Z", "1979-05-27 07:32:00.999999",
            "\"plane\"", "\"sphere\"", "\"box\"", "\"verlet\"", "\"implicit\"", "\"explicit\"",
            "'plane'", "\"\"", "\"\\u00e9\"", "\"\\n\"",
        ])
        .prop_map(String::from),
    ]
}

fn value() -> impl Strategy<Value = String> {
    let leaf = scalar();
    leaf.prop_recursive(3, 24, 5, |inner| {
        prop_oneof![
            3 => prop::collection::vec(inner.clone(), 0..5)
                .prop_map(|v| format!("[{}]", v.join(", "))),
            3 => prop::collection::vec(number(), 2..=3)
                .prop_map(|v| format!("[{}]", v.join(", "))),
            1 => prop::collection::vec(("[a-z]{1,6}", inner), 0..3).prop_map(|v| {
                let kv: Vec<String> = v.iter().map(|(k, x)| format!("{k} = {x}")).collect();
                format!("{{ {} }}", kv.join(", "))
            }),
        ]
    })
}

const SIMULATION: &[&str] = &[
    "duration",
    "time_step",
    "integrator",
    "implicit_budget",
    "frame_rate",
    "gravity",
];
const CLOTH: &[&str] = &[
    "size",
    "resolution",
    "position",
    "mass",
    "structural_stiffness",
    "shear_stiffness",
    "damping",
    "thickness",
    "collision_margin",
    "self_collision",
    "strain_limit",
    "strain_limit_iterations",
    "wetness",
    "water_mass",
    "dry_friction_factor",
    "wet_adhesion",
    "mesh",
    "rotation",
    "scale",
    "flip_normals",
];
/// The keys of a mesh cloth's `[cloth]` (besides `mesh`): no `size` or `resolution`.
const MESH_CLOTH: &[&str] = &[
    "position",
    "mass",
    "structural_stiffness",
    "shear_stiffness",
    "damping",
    "thickness",
    "collision_margin",
    "self_collision",
    "strain_limit",
    "wetness",
    "rotation",
    "scale",
    "flip_normals",
];
const AIR: &[&str] = &[
    "enabled",
    "atmospheric_pressure",
    "trapped_air",
    "leak_conductance",
    "pressure_solve",
    "pressure_force",
    "model",
    "seal_distance",
    "seal_hysteresis",
    "seal_wetness",
    "permeability",
    "dry_permeability",
];
const COLLIDER: &[&str] = &[
    "shape",
    "point",
    "normal",
    "center",
    "radius",
    "half_extents",
    "friction",
    "file",
    "position",
    "rotation",
    "scale",
    "sticky",
];
const PLANE: &[&str] = &["point", "normal", "friction", "sticky"];
const SPHERE: &[&str] = &["center", "radius", "friction", "sticky"];
const BOX: &[&str] = &["center", "half_extents", "friction", "sticky"];
const MESH: &[&str] = &[
    "file", "position", "rotation", "scale", "friction", "sticky",
];
const PAINT: &[&str] = &["center", "radius", "half_size", "wetness"];
const POCKET: &[&str] = &["center", "radius", "amount"];

/// Key names: mostly valid ones, sometimes misspelt or foreign.
fn key(valid: &'static [&'static str]) -> impl Strategy<Value = String> {
    prop_oneof![
        24 => prop::sample::select(valid).prop_map(String::from),
        1 => (prop::sample::select(valid), "[a-z_]{1,2}").prop_map(|(k, s)| format!("{k}{s}")),
        1 => "[a-z_]{1,10}".prop_map(|s| s),
    ]
}

fn num(r: std::ops::Range<f64>) -> BoxedStrategy<String> {
    r.prop_map(toml_float).boxed()
}

fn vec_of(parts: Vec<BoxedStrategy<String>>) -> BoxedStrategy<String> {
    parts.prop_map(|v| format!("[{}]", v.join(", "))).boxed()
}

/// A value that is usually right for `key` (in range, of its type), so that many scenes are
/// accepted and reach the round trip.
fn good(key: &str) -> BoxedStrategy<String> {
    let int = |r: std::ops::Range<u64>| r.prop_map(|v| v.to_string()).boxed();
    match key {
        "duration" => num(1e-3..10.0),
        "time_step" => num(1e-5..1e-3),
        "integrator" => prop::sample::select(vec!["\"verlet\"", "\"implicit\""])
            .prop_map(String::from)
            .boxed(),
        "implicit_budget" => prop::sample::select(vec!["\"converged\"", "\"interactive\""])
            .prop_map(String::from)
            .boxed(),
        "frame_rate" => num(1.0..1000.0),
        "gravity" | "normal" => vec_of(vec![num(-20.0..20.0), num(-20.0..20.0), num(-20.0..20.0)]),
        "size" => vec_of(vec![num(0.01..2.0), num(0.01..2.0)]),
        "resolution" => vec_of(vec![int(2..64), int(2..64)]),
        "position" => vec_of(vec![num(-1.0..1.0), num(0.01..1.0), num(-1.0..1.0)]),
        "mass" => num(1e-4..1.0),
        "structural_stiffness" | "shear_stiffness" => num(0.0..1e4),
        "damping" => num(0.0..10.0),
        "thickness" | "collision_margin" => num(0.0..0.01),
        "wetness" | "seal_wetness" => num(0.0..1.0),
        "water_mass" => num(0.0..10.0),
        "dry_friction_factor" => num(0.0..10.0),
        "wet_adhesion" => num(0.0..1e4),
        "pressure_force" => prop::sample::select(vec!["\"thesis\"", "\"area\""])
            .prop_map(String::from)
            .boxed(),
        "model" => prop::sample::select(vec!["\"thesis\"", "\"pockets\""])
            .prop_map(String::from)
            .boxed(),
        "seal_distance" => num(0.0..0.01),
        "seal_hysteresis" => num(0.0..0.99),
        "permeability" | "dry_permeability" => num(0.0..1e-3),
        "amount" => num(0.0..1e-3),
        "rest_center" => vec_of(vec![num(-0.5..0.5), num(-0.5..0.5)]),
        "half_size" => vec_of(vec![num(0.0..1.0), num(0.0..1.0)]),
        "rotation" => vec_of(vec![
            num(-360.0..360.0),
            num(-360.0..360.0),
            num(-360.0..360.0),
        ]),
        "scale" => num(0.0..10.0),
        "file" => prop::sample::select(vec![
            "\"mesh.obj\"",
            "\"tiny.obj\"",
            "\"missing.obj\"",
            "\"damaged.obj\"",
            "\"huge.obj\"",
            "\"inside-out.obj\"",
            "\"flat.obj\"",
            "\"fifo.obj\"",
            "\"\"",
            "\".\"",
        ])
        .prop_map(String::from)
        .boxed(),
        "mesh" => prop::sample::select(vec![
            "\"cloth.obj\"",
            "\"cloth-quads.obj\"",
            "\"inconsistent.obj\"",
            "\"nonmanifold.obj\"",
            "\"degenerate.obj\"",
            "\"unused.obj\"",
            "\"mesh.obj\"",
            "\"tiny.obj\"",
            "\"damaged.obj\"",
            "\"huge.obj\"",
            "\"missing.obj\"",
            "\"fifo.obj\"",
        ])
        .prop_map(String::from)
        .boxed(),
        "self_collision" | "enabled" | "sticky" | "flip_normals" => {
            prop::bool::ANY.prop_map(|b| b.to_string()).boxed()
        }
        "strain_limit" => num(0.0..1.0),
        "strain_limit_iterations" => int(1..10),
        "atmospheric_pressure" => num(0.0..2e5),
        "trapped_air" => num(0.0..1e-3),
        "leak_conductance" => num(0.0..1.0),
        "pressure_solve" => prop::sample::select(vec!["\"implicit\"", "\"explicit\""])
            .prop_map(String::from)
            .boxed(),
        "point" | "center" => vec_of(vec![num(-1.0..1.0), num(-1.0..0.0), num(-1.0..1.0)]),
        "radius" => num(0.01..0.3),
        "half_extents" => vec_of(vec![num(0.01..0.3), num(0.01..0.3), num(0.01..0.3)]),
        "friction" => num(0.0..2.0),
        "name" => "[a-z][a-z0-9_.-]{0,10}"
            .prop_map(|s| format!("{s:?}"))
            .boxed(),
        _ => value().boxed(),
    }
}

/// A value for `key`: mostly a good one, sometimes any value at all.
fn value_for(key: String) -> impl Strategy<Value = (String, String)> {
    let v = prop_oneof![
        24 => good(&key),
        1 => number().boxed(),
        1 => value().boxed(),
    ];
    v.prop_map(move |v| (key.clone(), v))
}

/// Keys and values of a table, mostly each key once (a repeated key is a TOML error, tried
/// now and then).
fn entries(valid: &'static [&'static str]) -> impl Strategy<Value = Vec<(String, String)>> {
    (
        prop::collection::vec(key(valid).prop_flat_map(value_for), 0..7),
        prop::bool::weighted(0.01),
    )
        .prop_map(|(mut v, repeat)| {
            if !repeat {
                let mut seen = std::collections::HashSet::new();
                v.retain(|(k, _)| seen.insert(k.clone()));
            }
            v
        })
}

/// A grab with plausible keys (or not).
fn grab() -> impl Strategy<Value = String> {
    let coordinate = || prop_oneof![6 => num(-0.1..0.1), 1 => number().boxed()];
    // Times in order, now and then not (or not numbers at all).
    let keyframe = (
        prop_oneof![12 => Just(None), 1 => number().prop_map(Some)],
        0.0f64..0.5,
        coordinate(),
        coordinate(),
        coordinate(),
    );
    let keyframes = prop::collection::vec(keyframe, 0..4).prop_map(|ks| {
        let mut t = 0.0;
        ks.into_iter()
            .map(|(odd, dt, x, y, z)| {
                t += dt;
                let time = odd.unwrap_or_else(|| toml_float(t));
                format!("{{ time = {time}, offset = [{x}, {y}, {z}] }}")
            })
            .collect::<Vec<_>>()
    });
    // Which particles: a grid index, a vertex, the nearest to a point, or a ball or a box
    // (now and then two of them, which is refused).
    let pick = prop_oneof![
        6 => (0u64..6, 0u64..6).prop_map(|(i, j)| format!("particle = [{i}, {j}]")),
        2 => (0u64..40).prop_map(|k| format!("vertex = {k}")),
        2 => (coordinate(), coordinate(), coordinate())
            .prop_map(|(x, y, z)| format!("near = [{x}, {y}, {z}]")),
        2 => (coordinate(), coordinate(), coordinate(), num(0.0..0.2))
            .prop_map(|(x, y, z, r)| format!("within = {{ center = [{x}, {y}, {z}], radius = {r} }}")),
        1 => (coordinate(), coordinate(), coordinate(), num(0.0..0.2))
            .prop_map(|(x, y, z, h)| format!(
                "within = {{ center = [{x}, {y}, {z}], half_size = [{h}, {h}, {h}] }}"
            )),
        1 => (0u64..40).prop_map(|k| format!("particle = [0, 0]\nvertex = {k}")),
    ];
    (
        pick,
        keyframes,
        prop::collection::vec(key(&["x_extra"]).prop_flat_map(value_for), 0..1),
    )
        .prop_map(|(pick, keys, extra)| {
            let mut s = format!("[[grab]]\n{pick}\nkeys = [{}]\n", keys.join(", "));
            for (k, v) in extra {
                s += &format!("{k} = {v}\n");
            }
            s
        })
}

/// A collider's motion: keys with times mostly in order, offsets and rotations mostly small.
fn collider_keys() -> impl Strategy<Value = String> {
    let key = (
        prop_oneof![12 => Just(None), 1 => number().prop_map(Some)],
        0.0f64..0.5,
        good("point"),
        prop::option::of(good("rotation")),
        prop::collection::vec(key(&["x_extra"]).prop_flat_map(value_for), 0..1),
    );
    prop::collection::vec(key, 0..4).prop_map(|ks| {
        let mut t = 0.0;
        let keys: Vec<String> = ks
            .into_iter()
            .map(|(odd, dt, offset, rotation, extra)| {
                t += dt;
                let time = odd.unwrap_or_else(|| toml_float(t));
                let mut k = format!("{{ time = {time}, offset = {offset}");
                if let Some(r) = rotation {
                    k += &format!(", rotation = {r}");
                }
                for (name, v) in extra {
                    k += &format!(", {name} = {v}");
                }
                k + " }"
            })
            .collect();
        format!("keys = [{}]\n", keys.join(", "))
    })
}

/// A collider: a shape and some keys, sometimes moving.
fn collider() -> impl Strategy<Value = String> {
    // Mostly the keys of the shape, sometimes those of any shape.
    let shape_and_keys = prop_oneof![
        8 => Just(("\"plane\"", PLANE)),
        3 => Just(("\"sphere\"", SPHERE)),
        3 => Just(("\"box\"", BOX)),
        3 => Just(("\"mesh\"", MESH)),
        1 => prop::sample::select(vec!["\"cone\"", "3", "\"Plane\""]).prop_map(|s| (s, COLLIDER)),
        2 => prop::sample::select(vec!["\"plane\"", "\"sphere\"", "\"box\"", "\"mesh\""])
            .prop_map(|s| (s, COLLIDER)),
    ];
    (
        shape_and_keys.prop_flat_map(|(shape, keys)| (Just(shape), entries(keys))),
        prop::option::weighted(0.2, collider_keys()),
        required(&["file"]),
    )
        .prop_map(|((shape, e), keys, file)| {
            let mut s = format!("[[collider]]\nshape = {shape}\n");
            // A mesh mostly names its file.
            let file = file.into_iter().filter(|_| shape.contains("mesh"));
            let mut seen = std::collections::HashSet::new();
            for (k, v) in file.chain(e).filter(|(k, _)| k != "shape") {
                if seen.insert(k.clone()) {
                    s += &format!("{k} = {v}\n");
                }
            }
            s + &keys.unwrap_or_default()
        })
}

/// The keys of `required`, each mostly present with a good value.
fn required(keys: &'static [&'static str]) -> impl Strategy<Value = Vec<(String, String)>> {
    // A paint region's or a seed's centre is `[x, z]` in the cloth's rest coordinates.
    let each: Vec<_> = keys
        .iter()
        .map(|&k| {
            let generated = if k == "center" { "rest_center" } else { k };
            prop::option::weighted(0.95, value_for(generated.to_string()))
                .prop_map(move |v| v.map(|(_, v)| (k.to_string(), v)))
        })
        .collect();
    each.prop_map(|v| v.into_iter().flatten().collect())
}

/// A `[[cloth.paint]]` region or an `[[air.pocket]]` seed: mostly its required keys, then any.
fn sub_table(
    header: &'static str,
    valid: &'static [&'static str],
    needs: &'static [&'static str],
) -> impl Strategy<Value = String> {
    (required(needs), entries(valid)).prop_map(move |(need, e)| {
        let mut s = format!("{header}\n");
        let mut seen = std::collections::HashSet::new();
        for (k, v) in need.into_iter().chain(e) {
            if seen.insert(k.clone()) {
                s += &format!("{k} = {v}\n");
            }
        }
        s
    })
}

fn table(name: &'static str, valid: &'static [&'static str]) -> impl Strategy<Value = String> {
    (
        prop_oneof![12 => Just("[{}]"), 1 => Just("[[{}]]")],
        entries(valid),
    )
        .prop_map(move |(header, e)| {
            let mut s = format!("{}\n", header.replace("{}", name));
            for (k, v) in e {
                s += &format!("{k} = {v}\n");
            }
            s
        })
}

/// A whole scene file, its parts in a random order.
fn scene_text() -> impl Strategy<Value = String> {
    (
        prop::option::of(prop_oneof![12 => good("name"), 1 => scalar().boxed()]),
        prop::option::of(table("simulation", SIMULATION)),
        prop::option::of(prop_oneof![
            3 => table("cloth", CLOTH).boxed(),
            1 => (good("mesh"), entries(MESH_CLOTH))
                .prop_map(|(mesh, e)| {
                    let mut s = format!("[cloth]\nmesh = {mesh}\n");
                    for (k, v) in e {
                        s += &format!("{k} = {v}\n");
                    }
                    s
                })
                .boxed(),
        ]),
        prop::option::of(table("air", AIR)),
        prop::collection::vec(collider(), 0..3),
        prop::collection::vec(grab(), 0..2),
        prop::collection::vec(
            sub_table("[[cloth.paint]]", PAINT, &["center", "wetness"]),
            0..2,
        ),
        prop::collection::vec(sub_table("[[air.pocket]]", POCKET, POCKET), 0..2),
        any::<bool>(),
    )
        .prop_map(
            |(name, sim, cloth, air, colliders, grabs, paint, pockets, reverse)| {
                let mut parts: Vec<String> = Vec::new();
                parts.extend(sim);
                // A table's sub-tables follow it (TOML refuses `[cloth]` after `[[cloth.paint]]`).
                parts.push(cloth.unwrap_or_default() + &paint.join("\n"));
                parts.push(air.unwrap_or_default() + &pockets.join("\n"));
                parts.extend(colliders);
                parts.extend(grabs);
                if reverse {
                    parts.reverse();
                }
                let mut s = name.map(|n| format!("name = {n}\n")).unwrap_or_default();
                s += &parts.join("\n");
                s
            },
        )
}

/// A byte-level change to a text.
#[derive(Clone, Debug)]
enum Mutation {
    Delete(prop::sample::Index, usize),
    Insert(prop::sample::Index, Vec<u8>),
    Duplicate(prop::sample::Index, usize),
    Truncate(prop::sample::Index),
    SwapLines(prop::sample::Index, prop::sample::Index),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<prop::sample::Index>(), 1usize..20).prop_map(|(i, n)| Mutation::Delete(i, n)),
        (
            any::<prop::sample::Index>(),
            prop::collection::vec(
                prop_oneof![
                    prop::sample::select(b"[]{}=\",.#\n'\\0123456789eE+-_ x".to_vec()),
                    any::<u8>()
                ],
                1..8
            )
        )
            .prop_map(|(i, b)| Mutation::Insert(i, b)),
        (any::<prop::sample::Index>(), 1usize..40).prop_map(|(i, n)| Mutation::Duplicate(i, n)),
        any::<prop::sample::Index>().prop_map(Mutation::Truncate),
        (any::<prop::sample::Index>(), any::<prop::sample::Index>())
            .prop_map(|(a, b)| Mutation::SwapLines(a, b)),
    ]
}

fn mutate(text: &str, mutations: &[Mutation]) -> Vec<u8> {
    let mut b = text.as_bytes().to_vec();
    for m in mutations {
        let n = b.len().max(1);
        match m {
            Mutation::Delete(i, len) => {
                let at = i.index(n).min(b.len());
                let end = (at + len).min(b.len());
                b.drain(at..end);
            }
            Mutation::Insert(i, bytes) => {
                let at = i.index(n + 1).min(b.len());
                b.splice(at..at, bytes.iter().copied());
            }
            Mutation::Duplicate(i, len) => {
                let at = i.index(n).min(b.len());
                let end = (at + len).min(b.len());
                let copy = b[at..end].to_vec();
                b.splice(end..end, copy);
            }
            Mutation::Truncate(i) => b.truncate(i.index(n)),
            Mutation::SwapLines(x, y) => {
                let mut lines: Vec<Vec<u8>> =
                    b.split(|&c| c == b'\n').map(<[u8]>::to_vec).collect();
                let (p, q) = (x.index(lines.len()), y.index(lines.len()));
                lines.swap(p, q);
                b = lines.join(&b'\n');
            }
        }
    }
    b
}

/// The properties every scene text must have.
static ACCEPTED: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
static REFUSED: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
/// Features whose accepted scenes are counted, to show the campaign reaches them.
const FEATURES: [&str; 8] = [
    "mesh = \"cloth",
    "within = ",
    "\"mesh\"",
    "\"pockets\"",
    "[[cloth.paint]]",
    "[[air.pocket]]",
    "keys = [{",
    "\"implicit\"",
];
static ACCEPTED_WITH: [std::sync::atomic::AtomicU64; 8] =
    [const { std::sync::atomic::AtomicU64::new(0) }; 8];

/// The folder the fuzzed scene files "live" in, holding the meshes they name: `mesh.obj` (an
/// octahedron), `tiny.obj` (one triangle), `damaged.obj` (cut, with a NaN and a face naming
/// a missing vertex), `huge.obj` (a triangle 1e200 m away), `inside-out.obj` (two
/// octahedra wound opposite ways), `flat.obj` (a square's two faces: closed, no volume) and
/// `fifo.obj` (a FIFO, on Unix); `missing.obj` is not there.
fn scene_path() -> &'static std::path::Path {
    static PATH: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    PATH.get_or_init(|| {
        let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-scene");
        std::fs::create_dir_all(&dir).unwrap();
        let octahedron = "v 0.1 0 0\nv -0.1 0 0\nv 0 0.1 0\nv 0 -0.1 0\nv 0 0 0.1\nv 0 0 -0.1\n\
                          f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";
        std::fs::write(dir.join("mesh.obj"), octahedron).unwrap();
        std::fs::write(
            dir.join("tiny.obj"),
            "v 0 -1 0\nv 1 -1 0\nv 0 -1 1\nf 1 2 3\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("damaged.obj"),
            "v 0 0 0\nv nan 1 0\nv 0 0\nf 1 2 9\nf 1",
        )
        .unwrap();
        std::fs::write(
            dir.join("huge.obj"),
            "v 0 -1e200 0\nv 1e200 -1e200 0\nv 0 -1e200 1e200\nf 1 2 3\n",
        )
        .unwrap();
        let flipped = "v 0.5 0 0\nv 0.3 0 0\nv 0.4 0.1 0\nv 0.4 -0.1 0\nv 0.4 0 0.1\nv 0.4 0 -0.1\n\
                       f 7 11 9\nf 9 11 8\nf 8 11 10\nf 10 11 7\nf 9 12 7\nf 8 12 9\nf 10 12 8\nf 7 12 10\n";
        std::fs::write(dir.join("inside-out.obj"), format!("{octahedron}{flipped}")).unwrap();
        std::fs::write(
            dir.join("flat.obj"),
            "v -1 -1 -1\nv 1 -1 -1\nv 1 -1 1\nv -1 -1 1\nf 1 2 3\nf 1 3 4\nf 2 1 4\nf 2 4 3\n",
        )
        .unwrap();
        // Cloths: a 4 x 4 grid of triangles (lying at y = 0.05), the same of quads with
        // texture coordinates, and damaged ones: one face wound against the rest, an edge of
        // three faces, a face of zero area, a vertex no face uses.
        let mut grid = String::new();
        for j in 0..4 {
            for i in 0..4 {
                grid += &format!("v {} 0.05 {}\n", i as f64 * 0.05, j as f64 * 0.05);
            }
        }
        let mut tris = String::new();
        let mut quads = String::new();
        for j in 0..3 {
            for i in 0..3 {
                let a = j * 4 + i + 1;
                let (b, c, d) = (a + 1, a + 5, a + 4);
                tris += &format!("f {a} {c} {b}\nf {a} {d} {c}\n");
                quads += &format!("f {a}/{a} {d}/{d} {c}/{c} {b}/{b}\n");
            }
        }
        let uvs: String = (0..16).map(|k| format!("vt {} {}\n", k % 4, k / 4)).collect();
        std::fs::write(dir.join("cloth.obj"), format!("{grid}{tris}")).unwrap();
        std::fs::write(dir.join("cloth-quads.obj"), format!("{grid}{uvs}{quads}")).unwrap();
        std::fs::write(
            dir.join("inconsistent.obj"),
            format!("{grid}{tris}").replacen("f 1 6 2", "f 1 2 6", 1),
        )
        .unwrap();
        std::fs::write(
            dir.join("nonmanifold.obj"),
            format!("{grid}v 0 0.2 0\n{tris}f 1 2 17\n"),
        )
        .unwrap();
        std::fs::write(dir.join("degenerate.obj"), format!("{grid}{tris}f 1 2 3\n")).unwrap();
        std::fs::write(dir.join("unused.obj"), format!("{grid}v 1 1 1\n{tris}")).unwrap();
        #[cfg(unix)]
        if !dir.join("fifo.obj").exists() {
            let _ = std::process::Command::new("mkfifo")
                .arg(dir.join("fifo.obj"))
                .status();
        }
        let _ = std::fs::remove_file(dir.join("missing.obj"));
        dir.join("s.toml")
    })
}

fn check(text: &str) -> Result<(), TestCaseError> {
    let result = guarded(text, || parse(text, scene_path()));
    let counter = if result.is_ok() { &ACCEPTED } else { &REFUSED };
    counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    if result.is_ok() {
        for (k, feature) in FEATURES.iter().enumerate() {
            if text.contains(feature) {
                ACCEPTED_WITH[k].fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }
        }
    }
    match result {
        Ok(scene) => accepted(&scene),
        Err(e) => refused(text, &e),
    }
}

fn accepted(scene: &Scene) -> Result<(), TestCaseError> {
    prop_assert!(
        scene.config.validate().is_ok(),
        "accepted but invalid: {:?}",
        scene.config
    );
    prop_assert!(scene.check_start().is_ok());
    let resolved = scene.to_toml();
    let back = guarded(&resolved, || {
        parse(&resolved, &scene_path().with_file_name("resolved.toml"))
    });
    match back {
        Ok(back) => {
            prop_assert_eq!(&back.config, &scene.config, "resolved:\n{}", resolved);
            prop_assert_eq!(&back.name, &scene.name);
        }
        Err(e) => prop_assert!(false, "the resolved scene is refused: {e}\n{resolved}"),
    }
    Ok(())
}

fn refused(text: &str, e: &SceneError) -> Result<(), TestCaseError> {
    let msg = e.to_string();
    prop_assert!(
        msg.starts_with(&scene_path().display().to_string()),
        "{}",
        msg
    );
    prop_assert!(!msg.contains("panicked"), "{}", msg);
    if let Some(at) = e.location()
        && at.line > 0
    {
        let lines: Vec<&str> = text.split('\n').collect();
        prop_assert!(
            at.line <= lines.len(),
            "line {} of {}: {}",
            at.line,
            lines.len(),
            msg
        );
        prop_assert_eq!(
            at.source_line.as_str(),
            lines[at.line - 1].trim_end_matches('\r'),
            "{}",
            msg
        );
        prop_assert!(at.column >= 1);
    }
    Ok(())
}

fn generated_campaign(n: u32) {
    runner(n).run(&scene_text(), |text| check(&text)).unwrap();
    let with: Vec<String> = FEATURES
        .iter()
        .zip(&ACCEPTED_WITH)
        .map(|(f, n)| format!("{f} {}", n.load(std::sync::atomic::Ordering::Relaxed)))
        .collect();
    eprintln!(
        "fuzz: {} accepted ({}), {} refused so far",
        ACCEPTED.load(std::sync::atomic::Ordering::Relaxed),
        with.join(", "),
        REFUSED.load(std::sync::atomic::Ordering::Relaxed)
    );
}

fn mutated_campaign(n: u32) {
    runner(n)
        .run(
            &(scene_text(), prop::collection::vec(mutation(), 1..4)),
            |(text, m)| {
                let bytes = mutate(&text, &m);
                check(&String::from_utf8_lossy(&bytes))
            },
        )
        .unwrap();
}

/// The shipped scenes, mutated: realistic files one typo away from valid.
fn shipped_campaign(n: u32) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut scenes: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| {
            let p = e.ok()?.path();
            (p.extension()? == "toml").then(|| std::fs::read_to_string(p).ok())?
        })
        .collect();
    scenes.sort();
    runner(n)
        .run(
            &(
                prop::sample::select(scenes),
                prop::collection::vec(mutation(), 1..4),
            ),
            |(text, m)| check(&String::from_utf8_lossy(&mutate(&text, &m))),
        )
        .unwrap();
}

#[test]
fn generated_scenes_never_panic_and_round_trip() {
    generated_campaign(cases(1500));
}

#[test]
fn mutated_scenes_never_panic() {
    mutated_campaign(cases(1500));
}

#[test]
fn mutated_shipped_scenes_never_panic() {
    shipped_campaign(cases(1000));
}

/// The long campaign: a million scene files (0.4 million generated, 0.4 million mutated, 0.2
/// million mutated shipped scenes), unless `WETCLOTH_FUZZ_CASES` says otherwise (per part).
#[test]
#[ignore = "long fuzz campaign: run with --ignored"]
fn long_campaign_a_million_scene_files() {
    let per = |share: u32| {
        std::env::var("WETCLOTH_FUZZ_CASES")
            .ok()
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or(share)
    };
    generated_campaign(per(400_000));
    mutated_campaign(per(400_000));
    shipped_campaign(per(200_000));
}
