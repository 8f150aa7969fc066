//! Mesh colliders against the plane: `cargo bench -p wetcloth --bench mesh`.
//!
//! One step of a dry 50 x 50 cloth (30 cm, no air, no self-collision, one thread) resting on
//! (a) the plane, (b) the top of a 20 480-triangle icosphere of radius 1 m, where every
//! particle is within reach of the surface and queries the mesh every step (the worst case),
//! and (c) the analytic sphere it approximates. Particle-steps per second are the items per
//! second divan reports; `docs/performance.md` quotes them.

#[path = "../tests/common/icosphere.rs"]
mod icosphere;

use icosphere::icosphere;
use wetcloth::collide::Mesh;
use wetcloth::{AirParams, ClothParams, Collider, Real, SimConfig, Simulation, Vec3};

fn main() {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .expect("first pool");
    divan::main();
}

/// The dry 50 x 50 cloth resting at height `y` on `collider`, settled.
fn resting(collider: Collider, y: Real) -> Simulation {
    let cfg = SimConfig {
        cloth: ClothParams {
            resolution: [50, 50],
            size: [0.3, 0.3],
            mass: 0.02,
            position: Vec3::new(0.0, y, 0.0),
            self_collision: false,
            ..Default::default()
        },
        air: AirParams {
            enabled: false,
            ..Default::default()
        },
        colliders: vec![collider],
        ..Default::default()
    };
    let mut sim = Simulation::new(cfg).expect("valid workload");
    sim.advance(400).expect("stable");
    sim
}

fn step(bencher: divan::Bencher, mut sim: Simulation) {
    bencher
        .counter(divan::counter::ItemsCount::new(sim.grid().len()))
        .bench_local(|| sim.step().expect("stable"));
}

const R: Real = 0.00075;

#[divan::bench]
fn on_plane(bencher: divan::Bencher) {
    step(
        bencher,
        resting(Collider::plane(Vec3::ZERO, Vec3::Y, 0.6), R),
    );
}

#[divan::bench]
fn on_mesh_20480_triangles(bencher: divan::Bencher) {
    let (v, f) = icosphere(1.0, 5);
    assert_eq!(f.len(), 20480);
    let mesh = Mesh::new("icosphere", v, f, Vec3::ZERO, Vec3::ZERO, 1.0).expect("valid mesh");
    step(bencher, resting(Collider::mesh(mesh, 0.6), 1.0 + R));
}

#[divan::bench]
fn on_sphere(bencher: divan::Bencher) {
    step(
        bencher,
        resting(Collider::sphere(Vec3::ZERO, 1.0, 0.6), 1.0 + R),
    );
}
