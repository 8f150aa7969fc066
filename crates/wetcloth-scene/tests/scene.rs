//! Scene files: defaults, every kind of error with its location, and the resolved round trip.

use std::path::Path;
use wetcloth::collide::{Cuboid, Plane};
use wetcloth::{
    AirModelKind, AirParams, ClothParams, Collider, GrabKey, GrabSpec, PaintShape, PocketSeed,
    Shape, SimConfig, Vec3, WetPaint,
};
use wetcloth_scene::{SceneError, parse, to_toml};

fn err(text: &str) -> (SceneError, String) {
    let e = parse(text, Path::new("scene.toml")).expect_err("the scene should be refused");
    let msg = e.to_string();
    (e, msg)
}

fn assert_contains(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "message lacks {p:?}:\n{msg}");
    }
}

const PLANE: &str = "[[collider]]\nshape = \"plane\"\n";

#[test]
fn an_empty_file_is_the_core_defaults_on_the_ground_named_after_the_file() {
    let s = parse("", Path::new("dir/my-scene.toml")).unwrap();
    assert_eq!(s.name, "my-scene");
    let expected = SimConfig {
        colliders: vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.6)],
        ..Default::default()
    };
    assert_eq!(s.config, expected);
    // A stem that is no valid name is made one.
    let s = parse("", Path::new("my scene.toml")).unwrap();
    assert_eq!(s.name, "my-scene");
}

#[test]
fn an_empty_collider_list_means_no_colliders() {
    let s = parse(
        "collider = []\n[air]\nenabled = false\n",
        Path::new("free.toml"),
    )
    .unwrap();
    assert!(s.config.colliders.is_empty());
}

#[test]
fn missing_keys_take_the_core_defaults() {
    let s = parse(
        &format!("name = \"n\"\n[cloth]\nmass = 0.5\n{PLANE}"),
        Path::new("x.toml"),
    )
    .unwrap();
    assert_eq!(s.name, "n");
    let cloth = ClothParams {
        mass: 0.5,
        ..ClothParams::default()
    };
    assert_eq!(s.config.cloth, cloth);
    assert_eq!(s.config.simulation, Default::default());
    assert_eq!(s.config.air, AirParams::default());
    assert_eq!(
        s.config.colliders,
        vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.6)]
    );
    assert!(s.config.grabs.is_empty());
}

#[test]
fn the_documented_example_parses_as_written() {
    let text = r#"
name = "pinch-center"
[simulation]
duration = 3.0
time_step = 8.333e-5
integrator = "verlet"
frame_rate = 60
gravity = [0.0, -9.8, 0.0]
[cloth]
size = [0.30, 0.30]
resolution = [50, 50]
position = [0.0, 0.002, 0.0]
mass = 0.02
structural_stiffness = 1000.0
shear_stiffness = 250.0
damping = 0.0
thickness = 0.001
self_collision = true
strain_limit = 0.0
[air]
enabled = true
atmospheric_pressure = 101325.0
trapped_air = 400e-6
[[collider]]
shape = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
friction = 0.6
[[grab]]
particle = [25, 25]
keys = [ { time = 0.5, offset = [0.0, 0.0, 0.0] },
         { time = 1.5, offset = [0.0, 0.05, 0.0] } ]
"#;
    let s = parse(text, Path::new("p.toml")).unwrap();
    assert_eq!(s.name, "pinch-center");
    assert_eq!(s.config.simulation.frame_rate, 60.0);
    assert_eq!(s.config.simulation.time_step, 8.333e-5);
    assert_eq!(s.config.air.trapped_air, 400e-6);
    assert_eq!(s.config.grabs.len(), 1);
    assert_eq!(s.config.grabs[0].particle, [25, 25]);
    assert_eq!(s.config.grabs[0].keys[1].offset, Vec3::new(0.0, 0.05, 0.0));
}

#[test]
fn collider_shapes_and_their_defaults() {
    // The cloth starts above the sphere at the origin (a cloth may not start inside one).
    let text = format!(
        "[cloth]\nposition = [0, 0.5, 0]\n[air]\nenabled = false\n\
         {PLANE}normal = [0, 2, 0]\n\
         [[collider]]\nshape = \"sphere\"\nradius = 0.1\nfriction = 0.2\n\
         [[collider]]\nshape = \"box\"\ncenter = [1, 2, 3]\nhalf_extents = [0.1, 0.2, 0.3]\n"
    );
    let s = parse(&text, Path::new("c.toml")).unwrap();
    assert_eq!(
        s.config.colliders[0].as_plane(),
        Some(&Plane {
            point: Vec3::ZERO,
            normal: Vec3::Y
        })
    );
    assert_eq!(
        s.config.colliders[1],
        Collider::sphere(Vec3::ZERO, 0.1, 0.2)
    );
    assert_eq!(
        s.config.colliders[2].shape,
        Shape::Box(Cuboid {
            center: Vec3::new(1.0, 2.0, 3.0),
            half_extents: Vec3::new(0.1, 0.2, 0.3)
        })
    );
    assert_eq!(s.config.colliders[2].friction, 0.6);
}

#[test]
fn syntax_errors_give_line_and_column() {
    let (e, msg) = err("[cloth]\nmass = = 3\n");
    assert!(matches!(e, SceneError::Syntax { .. }));
    assert_contains(
        &msg,
        &["scene.toml:2:8:", "TOML syntax error", "mass = = 3"],
    );
}

#[test]
fn unknown_keys_are_refused_with_the_closest_key_suggested() {
    let (e, msg) = err("[cloth]\nresolution = [8, 8]\nstructural_stifness = 3\n");
    assert!(matches!(e, SceneError::UnknownKey { .. }));
    assert_contains(
        &msg,
        &[
            "scene.toml:3:1:",
            "unknown key `cloth.structural_stifness`",
            "did you mean `structural_stiffness`?",
        ],
    );
    let (_, msg) = err("[clth]\nmass = 3\n");
    assert_contains(
        &msg,
        &["scene.toml:1:2:", "`clth`", "did you mean `cloth`?"],
    );
    // A key at the wrong level points to where it belongs.
    let (_, msg) = err("mass = 3\n");
    assert_contains(&msg, &["scene.toml:1:1:", "did you mean `cloth.mass`?"]);
    let (_, msg) = err("[cloth]\nstiffness = 3\n");
    assert_contains(&msg, &["did you mean `structural_stiffness`?"]);
    // In arrays of tables and inline tables too, and the first in the file is reported.
    let (_, msg) = err(&format!("{PLANE}frction = 1\n[air]\nenabld = true\n"));
    assert_contains(
        &msg,
        &["scene.toml:3:1:", "collider[0].frction", "`friction`"],
    );
    let (_, msg) = err("[[grab]]\nparticle = [1, 1]\nkeys = [{ time = 1, offst = [0, 0, 0] }]\n");
    assert_contains(
        &msg,
        &["scene.toml:3:21:", "grab[0].keys[0].offst", "`offset`"],
    );
}

#[test]
fn out_of_range_values_name_key_value_and_range_at_their_place() {
    let (e, msg) = err(&format!(
        "[simulation]\nduration = 1\n\n[cloth]\nmass = -1\n{PLANE}"
    ));
    assert!(matches!(e, SceneError::OutOfRange { .. }));
    assert_contains(
        &msg,
        &[
            "scene.toml:5:8: cloth.mass = -1 is out of range: allowed [",
            "10000]",
            "mass = -1\n",
        ],
    );
    let (_, msg) = err("[[collider]]\nshape = \"plane\"\nfriction = 20\n");
    assert_contains(
        &msg,
        &["scene.toml:3:12:", "collider[0].friction = 20", "[0, 10]"],
    );
    let (_, msg) = err(&format!(
        "{PLANE}[[grab]]\nparticle = [1, 1]\nkeys = [\n  {{ time = 1, offset = [0, 0, 0] }},\n  {{ time = 0.5, offset = [0, 0, 0] }},\n]\n"
    ));
    assert_contains(
        &msg,
        &["scene.toml:7:12:", "grab[0].keys[1].time = 0.5", "> 1"],
    );
    let (_, msg) = err(&format!(
        "{PLANE}[[grab]]\nparticle = [60, 1]\nkeys = [{{ time = 0, offset = [0, 0, 0] }}]\n"
    ));
    assert_contains(
        &msg,
        &[
            "scene.toml:4:12:",
            "grab[0].particle = [60, 1]",
            "column in [0, 49]",
        ],
    );
    let (_, msg) = err("[cloth]\nresolution = [1, 4]\n");
    assert_contains(
        &msg,
        &["scene.toml:2:14:", "cloth.resolution = [1, 4]", "[2, 4096]"],
    );
    let (_, msg) = err("[simulation]\ntime_step = 0.5\n");
    assert_contains(
        &msg,
        &["scene.toml:2:13:", "simulation.time_step = 0.5", "0.01]"],
    );
}

#[test]
fn inconsistent_defaults_point_at_the_table() {
    let (e, msg) = err("collider = []\n[air]\ntrapped_air = 0\n");
    assert!(matches!(e, SceneError::Invalid { .. }));
    assert_contains(&msg, &["scene.toml:2:1:", "air.enabled", "plane collider"]);
}

#[test]
fn wrong_types_name_the_key_and_the_expected_type() {
    let (e, msg) = err("[cloth]\nmass = \"heavy\"\n");
    assert!(matches!(e, SceneError::WrongType { .. }));
    assert_contains(
        &msg,
        &[
            "scene.toml:2:8:",
            "cloth.mass = \"heavy\"",
            "expected a number",
            "found string",
        ],
    );
    let (_, msg) = err("[cloth]\nresolution = [50.5, 4]\n");
    assert_contains(
        &msg,
        &[
            "scene.toml:2:15:",
            "cloth.resolution",
            "non-negative integer",
        ],
    );
    let (_, msg) = err("[cloth]\nsize = [1, 2, 3]\n");
    assert_contains(
        &msg,
        &["scene.toml:2:8:", "cloth.size", "array of 2 elements"],
    );
    let (_, msg) = err("[cloth]\nself_collision = 1\n");
    assert_contains(&msg, &["cloth.self_collision", "true or false"]);
    let (_, msg) = err("cloth = 3\n");
    assert_contains(&msg, &["scene.toml:1:9:", "cloth = 3", "expected a table"]);
    let (_, msg) =
        err("[[grab]]\nparticle = [1, 1]\nkeys = [{ time = \"x\", offset = [0, 0, 0] }]\n");
    assert_contains(&msg, &["scene.toml:3:18:", "grab[0].keys[0].time = \"x\""]);
}

#[test]
fn bad_names_shapes_and_integrators_are_refused() {
    let (e, msg) = err("[[collider]]\nshape = \"cone\"\n");
    assert!(matches!(e, SceneError::Invalid { .. }));
    assert_contains(
        &msg,
        &[
            "scene.toml:2:9:",
            "collider[0].shape = \"cone\"",
            "\"plane\", \"sphere\", \"box\"",
        ],
    );
    let (_, msg) = err("[[collider]]\nshape = \"plain\"\n");
    assert_contains(&msg, &["(did you mean \"plane\"?)"]);
    let (_, msg) = err("[[collider]]\nshape = \"sphere\"\nnormal = [0, 1, 0]\nradius = 1\n");
    assert_contains(
        &msg,
        &["scene.toml:3:", "collider[0].normal", "center, radius"],
    );
    let (e, msg) = err("[[collider]]\nshape = \"sphere\"\n");
    assert!(matches!(e, SceneError::Missing { .. }));
    assert_contains(
        &msg,
        &["scene.toml:1:1:", "collider[0].radius", "is missing"],
    );
    let (_, msg) = err("[[collider]]\nfriction = 1\n");
    assert_contains(
        &msg,
        &["scene.toml:1:1:", "collider[0].shape", "is missing"],
    );
    let (_, msg) = err("[simulation]\nintegrator = \"rk4\"\n");
    assert_contains(
        &msg,
        &[
            "scene.toml:2:14:",
            "simulation.integrator = \"rk4\"",
            "allowed \"verlet\"",
        ],
    );
    let (_, msg) = err("name = \"../x\"\n");
    assert_contains(
        &msg,
        &["scene.toml:1:8:", "name = \"../x\"", "letters, digits"],
    );
}

#[test]
fn a_missing_file_is_named() {
    let e = wetcloth_scene::load("no/such/scene.toml").unwrap_err();
    assert!(matches!(e, SceneError::Read { .. }));
    assert_contains(&e.to_string(), &["no/such/scene.toml", "cannot read"]);
}

fn full_config() -> SimConfig {
    let mut c = SimConfig::thesis_demo();
    c.simulation.time_step = 1.0 / 12000.0;
    c.simulation.duration = 0.1 + 0.2;
    c.simulation.gravity = Vec3::new(1e-300, -9.81, 1.0 / 3.0);
    c.cloth.resolution = [17, 9];
    c.cloth.strain_limit = 0.1;
    c.cloth.self_collision = false;
    c.air.trapped_air = 400e-6;
    c.cloth.wetness = 0.75;
    c.cloth.water_mass = 0.2;
    c.cloth.dry_friction_factor = 1.5;
    c.cloth.wet_adhesion = 800.0;
    c.cloth.paint = vec![
        WetPaint {
            center: [0.05, -0.025],
            shape: PaintShape::Disc(0.04),
            point: None,
            wetness: 0.0,
        },
        WetPaint {
            center: [0.0, 0.0],
            shape: PaintShape::Box([0.1, 0.02]),
            point: None,
            wetness: 1.0,
        },
    ];
    c.air.model = AirModelKind::Pockets;
    c.air.seal_distance = 0.001;
    c.air.seal_hysteresis = 0.25;
    c.air.seal_wetness = 0.25;
    c.air.permeability = 1e-7;
    c.air.dry_permeability = 2e-4;
    c.air.pockets = vec![PocketSeed {
        center: [0.0, 0.03],
        radius: 0.04,
        amount: 50e-6,
        point: None,
    }];
    c.colliders.push(Collider::plane(
        Vec3::new(0.5, -1.0, 2.0),
        Vec3::new(1.0, 1.0, 0.0),
        0.25,
    ));
    c.colliders
        .push(Collider::sphere(Vec3::new(0.0, 1.0, 0.0), 0.125, 0.0));
    c.colliders.push(Collider::cuboid(
        Vec3::new(0.0, -0.5, 0.0),
        Vec3::new(1.0, 0.5, 1.0),
        1.5,
    ));
    c.grabs = vec![
        GrabSpec::lift([3, 4], 0.25, 1.25, 0.05),
        GrabSpec {
            particle: [16, 8],
            pick: None,
            keys: vec![GrabKey {
                time: 0.0,
                offset: Vec3::new(0.1, 0.2, -0.3),
            }],
        },
    ];
    c
}

#[test]
fn the_resolved_scene_parses_back_to_the_same_configuration() {
    let config = full_config();
    config.validate().unwrap();
    let text = to_toml("round-trip", &config);
    let back = parse(&text, Path::new("elsewhere.toml")).unwrap();
    assert_eq!(back.name, "round-trip");
    assert_eq!(back.config, config, "resolved scene:\n{text}");
    // Writing it again gives the same text.
    assert_eq!(to_toml(&back.name, &back.config), text);
    // The built-in default, and a scene without colliders.
    let demo = SimConfig::thesis_demo();
    let back = parse(&to_toml("thesis-demo", &demo), Path::new("x.toml")).unwrap();
    assert_eq!(back.config, demo);
    let mut free = demo.clone();
    free.colliders.clear();
    free.air.enabled = false;
    let back = parse(&to_toml("free", &free), Path::new("x.toml")).unwrap();
    assert_eq!(back.config, free);
}

#[test]
fn every_scene_key_is_written_by_the_resolved_scene() {
    let text = to_toml("keys", &full_config());
    for key in [
        "duration",
        "time_step",
        "integrator",
        "frame_rate",
        "gravity",
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
        "half_size",
        "model",
        "seal_distance",
        "seal_hysteresis",
        "seal_wetness",
        "permeability",
        "dry_permeability",
        "amount",
        "enabled",
        "atmospheric_pressure",
        "trapped_air",
        "shape",
        "point",
        "normal",
        "center",
        "radius",
        "half_extents",
        "friction",
        "particle",
        "keys",
        "time",
        "offset",
    ] {
        assert!(
            text.contains(&format!("\n{key} = ")) || text.contains(&format!(" {key} = ")),
            "`{key}` not written:\n{text}"
        );
    }
}

#[test]
fn the_shipped_scenes_parse_and_round_trip() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return;
    };
    for entry in entries {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let scene = wetcloth_scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            let back = parse(&scene.to_toml(), Path::new("resolved.toml")).unwrap();
            assert_eq!(back.config, scene.config, "{}", path.display());
            assert_eq!(back.name, scene.name);
        }
    }
}

#[test]
fn pockets_and_wetness_keys_parse_and_are_checked_at_their_place() {
    let s = parse(
        "[cloth]\nwetness = 0.5\n\n[[cloth.paint]]\ncenter = [0.1, 0.0]\nradius = 0.05\nwetness = 0.0\n\n[air]\nmodel = \"pockets\"\npermeability = 1e-6\n\n[[air.pocket]]\ncenter = [0.0, 0.0]\nradius = 0.04\namount = 50e-6\n",
        Path::new("wet.toml"),
    )
    .unwrap();
    let c = &s.config;
    assert_eq!(c.air.model, AirModelKind::Pockets);
    assert_eq!(c.air.permeability, 1e-6);
    assert_eq!(c.cloth.wetness, 0.5);
    assert_eq!(c.cloth.paint[0].shape, PaintShape::Disc(0.05));
    assert_eq!(
        c.air.pockets,
        vec![PocketSeed {
            center: [0.0, 0.0],
            radius: 0.04,
            amount: 50e-6,
            point: None,
        }]
    );
    let (_, msg) = err("[air]\nmodel = \"bubbles\"\n");
    assert_contains(
        &msg,
        &["scene.toml:2:9:", "air.model", "\"thesis\", \"pockets\""],
    );
    let (_, msg) = err(
        "[air]\nmodel = \"pockets\"\n\n[[air.pocket]]\ncenter = [0.0, 0.0]\nradius = -0.04\namount = 1e-6\n",
    );
    assert_contains(
        &msg,
        &["scene.toml:6:10:", "air.pocket[0].radius = -0.04", "1000]"],
    );
    let (_, msg) = err("[[air.pocket]]\ncenter = [0.0, 0.0]\nradius = 0.04\namount = 1e-6\n");
    assert_contains(&msg, &["air.pocket", "model = \"pockets\""]);
    let (_, msg) = err("[cloth]\nwetness = 2\n");
    assert_contains(&msg, &["scene.toml:2:11:", "cloth.wetness = 2", "[0, 1]"]);
    let (_, msg) = err("[[cloth.paint]]\nradius = 0.1\nhalf_size = [0.1, 0.1]\nwetness = 1\n");
    assert_contains(&msg, &["scene.toml:1:", "cloth.paint[0]", "not both"]);
    let (_, msg) = err("[[air.pocket]]\ncentre = [0.0, 0.0]\n");
    assert_contains(&msg, &["air.pocket[0].centre", "center"]);
}
