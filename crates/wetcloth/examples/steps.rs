//! Times the benchmark workload: `steps SIDE SECONDS` (timed), or `steps SIDE -N` (exactly N
//! steps, for instruction counts with `perf stat`).
use wetcloth::{Simulation, bench::thesis_workload};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let side: usize = a.get(1).map_or(50, |s| s.parse().unwrap());
    let secs: f64 = a.get(2).map_or(3.0, |s| s.parse().unwrap());
    let mut sim = Simulation::new(thesis_workload(side)).unwrap();
    for _ in 0..200 {
        sim.step().unwrap();
    }
    let t0 = std::time::Instant::now();
    let mut n = 0u64;
    if secs < 0.0 {
        sim.advance((-secs) as u64).unwrap();
        n = (-secs) as u64;
    } else {
        while t0.elapsed().as_secs_f64() < secs {
            sim.advance(500).unwrap();
            n += 500;
        }
    }
    let s = n as f64 / t0.elapsed().as_secs_f64();
    println!(
        "{side}x{side}: {s:.0} steps/s, {:.3e} particle-steps/s, rebuilds {}",
        s * (side * side) as f64,
        sim.self_collision_rebuilds()
    );
}
