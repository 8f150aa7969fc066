//! A snug cotton sleeve on a horizontal arm (a closed cylinder given as a mesh collider), the
//! garment set-up of `scenes/shirt-back-lift-*.toml` at a size a test can run: a mesh cloth cut
//! a little small (`shrink`), the pockets model, the implicit integrator at 1/600 s, the
//! membrane and bending of the `cotton` material. A hand pinches a 3 cm patch on top of the
//! sleeve and draws it 1 cm off the arm. Wet, the sleeve lies sealed around the patch and the
//! hand opens a vacuum under it: the atmosphere pushes back on the patch's area (each
//! square centimetre carries up to 10 N at a full vacuum). Dry, nothing seals and the hand
//! only stretches the tight cloth. The wet sleeve needs at least ten times the dry one's force,
//! and every pocket it shows obeys Boyle's law.

use std::path::{Path, PathBuf};
use wetcloth::{Real, Simulation};

/// A fresh folder for one test's files.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wetcloth-sleeve-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Arm radius, m.
const ARM: f64 = 0.05;
/// The sleeve's radius as made, m: 2 mm off the arm.
const SLEEVE: f64 = 0.052;

/// A closed cylinder along x of radius `r` and length `len` about the origin, `seg` sides,
/// wound with its normals outwards.
fn arm_obj(r: f64, len: f64, seg: usize) -> String {
    let mut s = String::new();
    for end in [-0.5 * len, 0.5 * len] {
        for i in 0..seg {
            let a = std::f64::consts::TAU * i as f64 / seg as f64;
            s += &format!("v {end} {} {}\n", r * a.cos(), r * a.sin());
        }
    }
    s += &format!("v {} 0 0\nv {} 0 0\n", -0.5 * len, 0.5 * len);
    let (c0, c1) = (2 * seg + 1, 2 * seg + 2);
    for i in 0..seg {
        let (a, b) = (i + 1, (i + 1) % seg + 1);
        let (a2, b2) = (a + seg, b + seg);
        // The side (counter-clockwise seen from outside), then the caps at -x and +x.
        s += &format!("f {a} {b} {b2}\nf {a} {b2} {a2}\n");
        s += &format!("f {c0} {b} {a}\nf {c1} {a2} {b2}\n");
    }
    s
}

/// An open tube along x of radius `r` and length `len`: `seg` points round, `rings` along,
/// its normals outwards (away from the arm, the side the air is kept off).
fn sleeve_obj(r: f64, len: f64, seg: usize, rings: usize) -> String {
    let mut s = String::new();
    for j in 0..rings {
        let x = -0.5 * len + len * j as f64 / (rings - 1) as f64;
        for i in 0..seg {
            let a = std::f64::consts::TAU * i as f64 / seg as f64;
            s += &format!("v {x} {} {}\n", r * a.cos(), r * a.sin());
        }
    }
    for j in 0..rings - 1 {
        for i in 0..seg {
            let a = j * seg + i + 1;
            let b = j * seg + (i + 1) % seg + 1;
            let (a2, b2) = (a + seg, b + seg);
            s += &format!("f {a} {b} {b2}\nf {a} {b2} {a2}\n");
        }
    }
    s
}

/// The scene: the sleeve at `wetness` on the arm, the hand drawing the patch on top 1 cm up
/// from 0.3 s to 0.5 s.
fn scene(dir: &Path, wetness: Real) -> wetcloth_scene::Scene {
    std::fs::write(dir.join("arm.obj"), arm_obj(ARM, 0.3, 48)).unwrap();
    std::fs::write(dir.join("sleeve.obj"), sleeve_obj(SLEEVE, 0.2, 24, 15)).unwrap();
    let text = format!(
        "[simulation]\nduration = 0.55\ntime_step = 0.0016666666666666668\n\
         integrator = \"implicit\"\n\n\
         [cloth]\nmesh = \"sleeve.obj\"\nmaterial = \"cotton\"\nwetness = {wetness}\n\
         shrink = 0.04\nself_collision = false\n\n\
         [air]\nmodel = \"pockets\"\n\n\
         [[collider]]\nshape = \"mesh\"\nfile = \"arm.obj\"\nfriction = 0.6\n\n\
         [[grab]]\nwithin = {{ center = [0.0, {SLEEVE}, 0.0], radius = 0.015 }}\n\
         keys = [ {{ time = 0.3, offset = [0.0, 0.0, 0.0] }},\n\
         {{ time = 0.5, offset = [0.0, 0.01, 0.0] }} ]\n"
    );
    let path = dir.join("sleeve.toml");
    std::fs::write(&path, text).unwrap();
    wetcloth_scene::load(&path).unwrap()
}

/// The hand's largest force over the run, N, and the lowest pocket pressure seen, Pa.
fn lift(wetness: Real) -> (Real, Real) {
    let dir = folder(&format!("w{wetness}"));
    let cfg = scene(&dir, wetness).config;
    let pa = cfg.air.atmospheric_pressure;
    let mut sim = Simulation::new(cfg).unwrap();
    let steps = (0.55 / sim.time_step()).round() as u64;
    let (mut peak, mut lowest): (Real, Real) = (0.0, pa);
    for _ in 0..steps {
        sim.step().unwrap();
        peak = peak.max(sim.grab_force().length());
        for p in sim.pocket_reports() {
            // Boyle: each pocket's air at its pressure fills its volume.
            assert!(
                (p.pressure * p.volume - pa * p.amount).abs() <= 1e-6 * pa * p.volume.max(1e-9),
                "{p:?}"
            );
            lowest = lowest.min(p.pressure);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    (peak, lowest)
}

#[test]
fn a_snug_wet_sleeve_holds_ten_times_the_dry_ones_pull() {
    let (wet, wet_low) = lift(1.0);
    let (dry, dry_low) = lift(0.0);
    eprintln!(
        "sleeve: wet {wet} N (lowest pocket {wet_low} Pa), dry {dry} N (lowest {dry_low} Pa)"
    );
    assert!(dry > 0.0, "the dry hand pulls the tight cloth: {dry} N");
    assert!(wet >= 10.0 * dry, "wet {wet} N, dry {dry} N");
    // The wet one's force is the air's: a pocket under the hand well below the atmosphere.
    assert!(wet_low < 0.5 * 101_325.0, "lowest pocket {wet_low} Pa");
    assert_eq!(dry_low, 101_325.0, "the dry sleeve seals nothing");
}
