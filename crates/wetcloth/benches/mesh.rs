//! Mesh colliders against the plane: `cargo bench -p wetcloth --bench mesh`.
//!
//! One step of a dry 50 x 50 cloth (30 cm, no air, no self-collision, one thread) resting on
//! (a) the plane, (b) the top of a 20 480-triangle icosphere of radius 1 m, where every
//! particle is within reach of the surface and queries the mesh every step (the worst case),
//! and (c) the analytic sphere it approximates. Particle-steps per second are the items per
//! second divan reports; `docs/performance.md` quotes them.

use wetcloth::collide::Mesh;
use wetcloth::{AirParams, ClothParams, Collider, Real, SimConfig, Simulation, Vec3};

fn main() {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .expect("first pool");
    divan::main();
}

/// An icosphere of radius `r`: the icosahedron split `level` times (20 * 4^level triangles).
fn icosphere(r: Real, level: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3::from(*p).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for [a, b, c] in f {
            let mut middle = |a: u32, b: u32| {
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    v.push(((v[a as usize] + v[b as usize]) / 2.0).normalize());
                    (v.len() - 1) as u32
                })
            };
            let (ab, bc, ca) = (middle(a, b), middle(b, c), middle(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (v.into_iter().map(|p| p * r).collect(), f)
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
