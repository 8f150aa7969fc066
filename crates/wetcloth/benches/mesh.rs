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

/// The same icosphere breathing (its radius 1 m to 1.01 m and back over 30 frames at 30 per
/// second, from before the cloth settles): every step refits its hierarchy to a new pose and
/// carries each particle's start by its nearest triangle.
#[divan::bench]
fn on_deforming_mesh_20480_triangles(bencher: divan::Bencher) {
    use std::sync::Arc;
    use wetcloth::collide::{PointMotion, PointSource};
    let (v, f) = icosphere(1.0, 5);
    let frames = (0..=30)
        .map(|k| {
            let s = 1.0 + 0.01 * (std::f64::consts::PI * k as Real / 30.0).sin();
            v.iter().map(|p| *p * s).collect()
        })
        .collect();
    let mesh = Mesh::new("icosphere", v, f, Vec3::ZERO, Vec3::ZERO, 1.0)
        .expect("valid mesh")
        .with_motion(PointMotion {
            source: PointSource::Sequence("breathing_##.obj".into()),
            frame_rate: 30.0,
            start: 0.0,
            frames: Arc::new(frames),
        })
        .expect("valid motion");
    step(bencher, resting(Collider::mesh(mesh, 0.6), 1.0 + R));
}

/// A pose of the 20 480-triangle icosphere at a new time: its 10 242 points interpolated and
/// its hierarchy refitted (what a deforming mesh costs per step, whatever the cloth).
#[divan::bench]
fn deforming_mesh_pose_refit(bencher: divan::Bencher) {
    use std::sync::Arc;
    use wetcloth::collide::{PointMotion, PointSource};
    let (v, f) = icosphere(1.0, 5);
    let frames = vec![v.clone(), v.iter().map(|p| *p * 1.01).collect()];
    let mesh = Mesh::new("icosphere", v, f, Vec3::ZERO, Vec3::ZERO, 1.0)
        .expect("valid mesh")
        .with_motion(PointMotion {
            source: PointSource::Sequence("two_##.obj".into()),
            frame_rate: 1.0,
            start: 0.0,
            frames: Arc::new(frames),
        })
        .expect("valid motion");
    let d = mesh.deform().expect("deforms");
    let mut t = 0.0;
    bencher.bench_local(|| {
        // A new time each call, so the pose cache never answers.
        t += 1e-7;
        d.pose(t)
    });
}
