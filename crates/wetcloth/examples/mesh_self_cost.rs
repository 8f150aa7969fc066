//! Times a mesh cloth's self-contact:
//! `mesh_self_cost [verlet|implicit] [STEPS] [COLUMNS] [WARMUP]`.
//!
//! A strip of 2 cm edges folded over itself (a flap 5 mm over the other half) falls onto a
//! sphere of radius 1 m and settles there, its layers in contact: `COLUMNS x COLUMNS / 2`
//! particles (default 100: 5 000). Prints particle-steps per second with self-collision on
//! (particle spheres, and the triangles and edges) and off, the median of three runs of `STEPS`
//! steps each (default 200) after `WARMUP` steps (default 50), and the self-contact's candidate
//! pairs, contacts at the last step, list rebuilds and repairs (a few particles' boxes
//! widened).

use std::sync::Arc;
use std::time::Instant;
use wetcloth::{
    AirParams, ClothMeshSource, ClothParams, Collider, Integrator, Real, SimConfig, Simulation,
    Vec3,
};

const EDGE: Real = 0.02;

fn folded(columns: usize, integrator: Integrator, self_collision: bool) -> SimConfig {
    let (bottom, flap, rows) = (columns / 2, columns / 2 - 2, columns / 2 - 1);
    let cols = bottom + flap + 2;
    let mut v = Vec::new();
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as Real / (1u64 << 53) as Real * 2.0 - 1.0
    };
    for j in 0..=rows {
        for i in 0..cols {
            let (x, y) = if i <= bottom {
                (i as Real * EDGE, 0.0)
            } else {
                ((2 * bottom + 1 - i) as Real * EDGE, 0.005)
            };
            let z = (j as Real - 0.5 * rows as Real) * EDGE;
            v.push(Vec3::new(
                x + 0.25 * EDGE * rnd(),
                y,
                z + 0.25 * EDGE * rnd(),
            ));
        }
    }
    let mut faces = Vec::new();
    for j in 0..rows {
        for i in 0..cols - 1 {
            let a = (j * cols + i) as u32;
            let (b, c, d) = (a + 1, a + 1 + cols as u32, a + cols as u32);
            if (i + j) % 2 == 0 {
                faces.push(vec![a, c, b]);
                faces.push(vec![a, d, c]);
            } else {
                faces.push(vec![a, d, b]);
                faces.push(vec![b, d, c]);
            }
        }
    }
    let mut cfg = SimConfig {
        cloth: ClothParams {
            mesh: Some(ClothMeshSource {
                file: "folded.obj".into(),
                vertices: Arc::new(v),
                faces: Arc::new(faces),
                uvs: Arc::new(Vec::new()),
                face_uvs: Arc::new(Vec::new()),
                rotation: Vec3::ZERO,
                scale: 1.0,
                flip_normals: false,
            }),
            mass: 0.1 * (bottom * rows) as Real * EDGE * EDGE,
            damping: 1.0,
            thickness: 0.001,
            position: Vec3::ZERO,
            self_collision,
            ..Default::default()
        },
        air: AirParams {
            enabled: false,
            ..Default::default()
        },
        ..Default::default()
    };
    let r = cfg.cloth.particle_radius();
    let centre = (bottom as Real - 0.5 * flap as Real) * EDGE;
    cfg.colliders = vec![Collider::sphere(
        Vec3::new(centre, -1.0 - r - 1e-4, 0.0),
        1.0,
        0.6,
    )];
    cfg.simulation.integrator = integrator;
    cfg.simulation.time_step = match integrator {
        Integrator::Verlet => 1.0 / 12000.0,
        Integrator::Implicit => 1.0 / 500.0,
    };
    cfg
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let integrator = match a.get(1).map(String::as_str) {
        Some("implicit") => Integrator::Implicit,
        _ => Integrator::Verlet,
    };
    let steps: u64 = a.get(2).map_or(200, |s| s.parse().unwrap());
    let columns: usize = a.get(3).map_or(100, |s| s.parse().unwrap());
    let warmup: u64 = a.get(4).map_or(50, |s| s.parse().unwrap());
    for on in [true, false] {
        let mut sim = Simulation::new(folded(columns, integrator, on)).unwrap();
        sim.advance(warmup).unwrap();
        let n = sim.particle_count();
        let mut rates = Vec::new();
        for _ in 0..3 {
            let t0 = Instant::now();
            sim.advance(steps).unwrap();
            rates.push((steps * n as u64) as f64 / t0.elapsed().as_secs_f64());
        }
        rates.sort_by(f64::total_cmp);
        let (pairs, contacts, rebuilds, repairs) = sim.mesh_self().map_or(((0, 0), 0, 0, 0), |m| {
            (m.candidate_count(), m.contacts, m.rebuilds, m.repairs)
        });
        println!(
            "{integrator:?} {n} particles, self-collision {on}: {:.3e} particle-steps/s \
             (runs {:.3e} {:.3e} {:.3e}); candidates {pairs:?}, contacts {contacts}, \
             rebuilds {rebuilds} (and {repairs} repairs) in {} steps",
            rates[1],
            rates[0],
            rates[1],
            rates[2],
            sim.step_count()
        );
    }
}
