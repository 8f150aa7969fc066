//! Kernel benchmarks of the step: `cargo bench -p wetcloth`.
//!
//! Each benchmark is one step of the thesis workload (`bench::thesis_workload`, 50 x 50) with a
//! single part of the model switched on or off, so the differences show what each part costs:
//! springs and integration alone, plus plane contact, plus the air (pressure force and eq. 3.10
//! volume), plus self-collision (everything: the workload of `wetcloth bench`). The volume and
//! the self-collision solve are also timed on their own. Single-threaded (the kernels, not the
//! scheduling); `wetcloth bench` measures threads.

use wetcloth::collide::self_collision::SelfCollision;
use wetcloth::{SimConfig, Simulation, air, bench::thesis_workload};

fn main() {
    // One worker: these benchmarks time the kernels, not the scheduling.
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .expect("first pool");
    divan::main();
}

const SIDES: [usize; 2] = [50, 200];

fn settled(cfg: SimConfig) -> Simulation {
    let mut sim = Simulation::new(cfg).expect("valid workload");
    sim.advance(400).expect("stable");
    sim
}

fn step_with(bencher: divan::Bencher, cfg: SimConfig) {
    let mut sim = settled(cfg);
    bencher
        .counter(divan::counter::ItemsCount::new(sim.grid().len()))
        .bench_local(|| sim.step().expect("stable"));
}

/// Springs, gravity, damping and Verlet only.
#[divan::bench(args = SIDES)]
fn springs_only(bencher: divan::Bencher, side: usize) {
    let mut cfg = thesis_workload(side);
    cfg.colliders.clear();
    cfg.air.enabled = false;
    cfg.cloth.self_collision = false;
    cfg.simulation.gravity = wetcloth::Vec3::ZERO;
    step_with(bencher, cfg);
}

/// Plus the plane's normal force and friction.
#[divan::bench(args = SIDES)]
fn with_contact(bencher: divan::Bencher, side: usize) {
    let mut cfg = thesis_workload(side);
    cfg.air.enabled = false;
    cfg.cloth.self_collision = false;
    step_with(bencher, cfg);
}

/// Plus the pressure force and the bubble volume.
#[divan::bench(args = SIDES)]
fn with_air(bencher: divan::Bencher, side: usize) {
    let mut cfg = thesis_workload(side);
    cfg.cloth.self_collision = false;
    step_with(bencher, cfg);
}

/// Everything, as `wetcloth bench` measures it.
#[divan::bench(args = SIDES)]
fn full_step(bencher: divan::Bencher, side: usize) {
    step_with(bencher, thesis_workload(side));
}

/// Eq. 3.10 alone (the reference implementation in `air`).
#[divan::bench(args = SIDES)]
fn volume(bencher: divan::Bencher, side: usize) {
    let sim = settled(thesis_workload(side));
    let plane = air::StickingPlane::new(wetcloth::Vec3::ZERO, wetcloth::Vec3::Y);
    bencher
        .counter(divan::counter::ItemsCount::new(sim.grid().len()))
        .bench_local(|| air::volume(sim.grid(), sim.positions(), plane, 0.0));
}

/// The self-collision narrow phase on a cloth folded onto itself (many contacts).
#[divan::bench(args = SIDES)]
fn self_collision_folded(bencher: divan::Bencher, side: usize) {
    let sim = settled(thesis_workload(side));
    let grid = sim.grid().clone();
    // Fold: the second half of the columns mirrored onto the first, one diameter above.
    let mut p = sim.positions().clone();
    let d = 2.0 * sim.particle_radius();
    for j in 0..grid.nz {
        for i in grid.nx / 2..grid.nx {
            let k = grid.index(i, j);
            let m = grid.index(grid.nx - 1 - i, j);
            p.x[k] = p.x[m] + 0.25 * grid.dx;
            p.y[k] = p.y[m] + 0.9 * d;
        }
    }
    let fixed = vec![false; grid.len()];
    let mut sc = SelfCollision::new(grid.len(), d);
    bencher
        .counter(divan::counter::ItemsCount::new(grid.len()))
        .bench_local(|| {
            let mut q = p.clone();
            sc.solve(&grid, &mut q, &fixed)
        });
}
