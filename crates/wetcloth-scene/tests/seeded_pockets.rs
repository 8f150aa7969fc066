//! `[[air.pocket]]` in scene files on every cloth: `center = [x, y, z]` (scene coordinates at
//! t = 0) on a mesh cloth, `[x, z]` (rest coordinates from the cloth's centre) on the grid under
//! either model; the wrong count refused at its line with the key and the value, a mesh's seed
//! that holds no particle refused naming the distance to the nearest, and a resolved scene that
//! reads back to the same seeds.

use std::path::{Path, PathBuf};
use wetcloth::{ClothModel, Simulation, Vec3};

/// A fresh folder for one test's files.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wetcloth-seeds-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// An OBJ of `n x n` vertices over `size` m in the xz plane about the origin, faces wound with
/// their normal up (counter-clockwise seen from above).
fn flat_obj(n: usize, size: f64) -> String {
    let h = size / (n - 1) as f64;
    let mut s = String::new();
    for j in 0..n {
        for i in 0..n {
            s += &format!(
                "v {} 0 {}\n",
                i as f64 * h - 0.5 * size,
                j as f64 * h - 0.5 * size
            );
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            // OBJ counts from 1.
            let a = j * n + i + 1;
            let (b, c, d) = (a + 1, a + 1 + n, a + n);
            s += &format!("f {a} {c} {b}\nf {a} {d} {c}\n");
        }
    }
    s
}

/// A wet cloth (the mesh of `dir/flat.obj` with `mesh`, else the grid of `model`) lying on the
/// default ground, pockets model, with one seed of `center`.
fn scene(
    dir: &Path,
    mesh: bool,
    model: &str,
    center: &str,
) -> Result<wetcloth_scene::Scene, String> {
    let cloth = if mesh {
        std::fs::write(dir.join("flat.obj"), flat_obj(11, 0.2)).unwrap();
        "mesh = \"flat.obj\"\nposition = [0.0, 0.00075, 0.0]\n".to_string()
    } else {
        "size = [0.2, 0.2]\nresolution = [11, 11]\nposition = [0.0, 0.00075, 0.0]\n".to_string()
    };
    let text = format!(
        "[cloth]\n{cloth}model = \"{model}\"\n\n[air]\nmodel = \"pockets\"\n\n\
         [[air.pocket]]\ncenter = {center}\nradius = 0.03\namount = 5e-6\n"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    wetcloth_scene::load(&path).map_err(|e| e.to_string())
}

#[test]
fn a_mesh_cloth_takes_a_point_and_the_grid_its_rest_coordinates() {
    let dir = folder("point");
    for model in ["springs", "membrane"] {
        let s = scene(&dir, true, model, "[0.01, 0.00075, -0.02]").unwrap();
        let seed = &s.config.air.pockets[0];
        assert_eq!(seed.point, Some(Vec3::new(0.01, 0.00075, -0.02)), "{model}");
        assert_eq!((seed.radius, seed.amount), (0.03, 5e-6));
        // It runs: one sealed pocket holding the seed's air at frame 0.
        let sim = Simulation::new(s.config.clone()).unwrap();
        let r = sim.pocket_reports();
        assert_eq!(r.len(), 1, "{model}: {r:?}");
        assert!((r[0].amount - 5e-6).abs() <= 1e-18, "{model}: {r:?}");
        // The resolved scene names the point and reads back the same.
        let text = wetcloth_scene::to_toml(&s.name, &s.config);
        assert!(
            text.contains("center = [0.01, 0.00075, -0.02]  # m, scene at t = 0"),
            "{text}"
        );
        let again = dir.join("again.toml");
        std::fs::write(&again, text).unwrap();
        assert_eq!(wetcloth_scene::load(&again).unwrap().config, s.config);

        let g = scene(&dir, false, model, "[0.01, -0.02]").unwrap();
        let seed = &g.config.air.pockets[0];
        assert_eq!((seed.center, seed.point), ([0.01, -0.02], None), "{model}");
        assert_eq!(
            g.config.cloth.model == ClothModel::Membrane,
            model == "membrane"
        );
        let sim = Simulation::new(g.config.clone()).unwrap();
        assert_eq!(sim.pocket_reports().len(), 1, "{model}");
        let text = wetcloth_scene::to_toml(&g.name, &g.config);
        let again = dir.join("again.toml");
        std::fs::write(&again, text).unwrap();
        assert_eq!(wetcloth_scene::load(&again).unwrap().config, g.config);
    }
}

#[test]
fn a_centre_of_the_wrong_size_or_off_the_cloth_is_refused_at_its_line() {
    let dir = folder("refused");
    // Line 10 of the scene holds the seed's centre (the mesh's [cloth] has two lines, the
    // grid's three).
    let cases = [
        (true, "[0.01, -0.02]", "scene.toml:10:", "3 components"),
        (
            false,
            "[0.01, 0.0, -0.02]",
            "scene.toml:11:",
            "2 components",
        ),
        (
            true,
            "[0.0, 0.05, 0.0]",
            "scene.toml:10:",
            "no particle of the cloth",
        ),
    ];
    for (mesh, center, at, why) in cases {
        for model in ["springs", "membrane"] {
            let e = scene(&dir, mesh, model, center).unwrap_err();
            eprintln!("{e}");
            assert!(e.contains(at), "{model} {center}: {e}");
            assert!(e.contains("air.pocket[0].center"), "{model} {center}: {e}");
            assert!(e.contains(why), "{model} {center}: {e}");
            assert!(
                e.contains(center) || e.contains("[0, 0.05, 0]"),
                "{model} {center}: {e}"
            );
        }
    }
    // The ball 5 cm above the cloth: the message gives the nearest particle's distance.
    let e = scene(&dir, true, "springs", "[0.0, 0.05, 0.0]").unwrap_err();
    assert!(
        e.contains("`radius` = 0.03 m") && e.contains("0.0492"),
        "{e}"
    );
}
