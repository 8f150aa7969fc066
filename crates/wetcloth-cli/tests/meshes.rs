//! `wetcloth run` and `wetcloth export` with a mesh collider and a moving collider: the run
//! folder carries the mesh (a copy of the model beside `run.json`, which names it with its
//! digest; the renderer and the exporter read it) and the motion keys, and the resolved scene
//! reads back.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli-meshes")
        .join(test);
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(dir.join("models")).unwrap();
    dir
}

/// An 8 x 8 cloth dropped onto a closed tetrahedron, with a sphere sinking beside it.
const SCENE: &str = r#"
name = "on-mesh"
[simulation]
duration = 0.1
frame_rate = 40
[cloth]
resolution = [8, 8]
position = [0.0, 0.12, 0.0]
[air]
enabled = false
[[collider]]
shape = "mesh"
file = "models/tetra.obj"
position = [0.0, 0.0, 0.0]
scale = 0.1
friction = 0.5
[[collider]]
shape = "sphere"
center = [0.5, 0.0, 0.0]
radius = 0.05
sticky = false
keys = [ { time = 0.0 }, { time = 0.1, offset = [0.0, -0.1, 0.0], rotation = [0.0, 0.0, 90.0] } ]
"#;

const TETRA: &str = "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nv 0 1 0\nf 1 2 3\nf 1 4 2\nf 2 4 3\nf 3 4 1\n";

#[test]
fn a_run_on_a_mesh_carries_the_mesh_and_the_motion() {
    let dir = scratch("carries");
    fs::write(dir.join("models/tetra.obj"), TETRA).unwrap();
    fs::write(dir.join("scene.toml"), SCENE).unwrap();
    let out = dir.join("out");
    let o = Command::new(BIN)
        .args(["run", "-q", "-o"])
        .arg(&out)
        .arg(dir.join("scene.toml"))
        .args(["--export", "usda"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let run: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    let mesh = &run["colliders"][0];
    assert_eq!(mesh["shape"], "mesh");
    assert_eq!(mesh["scale"], 0.1);
    assert_eq!(mesh["triangle_count"], 4);
    assert!(mesh.get("triangles").is_none(), "{mesh}");
    let copy = fs::read_to_string(out.join(mesh["copy"].as_str().unwrap())).unwrap();
    assert_eq!(copy.lines().filter(|l| l.starts_with("v ")).count(), 4);
    assert_eq!(copy.lines().filter(|l| l.starts_with("f ")).count(), 4);
    assert!(
        mesh["copy"]
            .as_str()
            .unwrap()
            .contains(mesh["digest"].as_str().unwrap())
    );
    let sphere = &run["colliders"][1];
    assert_eq!(sphere["sticky"], false);
    assert_eq!(sphere["keys"][1]["offset"][1], -0.1);
    assert_eq!(sphere["keys"][1]["rotation"][2], 90.0);
    // The resolved scene reads back, from its own folder, to the same colliders.
    let back = wetcloth_scene_load(&out.join("scene.toml"));
    assert!(
        back.contains("shape = \"mesh\"") && back.contains("tetra.obj"),
        "{back}"
    );
    let o = Command::new(BIN)
        .args(["run", "-q", "-o"])
        .arg(dir.join("again"))
        .arg(out.join("scene.toml"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        fs::read(out.join("metrics.csv")).unwrap(),
        fs::read(dir.join("again/metrics.csv")).unwrap()
    );
    // The USD stage has the mesh's triangles and the sphere's time samples.
    let usda = fs::read_to_string(out.join("on-mesh.usda")).unwrap();
    assert!(usda.contains("def Mesh \"mesh_0\""), "no mesh prim");
    assert!(
        usda.contains("int[] faceVertexCounts = [3, 3, 3, 3]"),
        "no triangles"
    );
    assert!(usda.contains("xformOp:translate.timeSamples"), "no motion");
}

fn wetcloth_scene_load(path: &Path) -> String {
    fs::read_to_string(path).unwrap()
}
