//! Runs the thesis demo and prints metrics every 0.05 s (a quick look at a scene's behaviour).
use wetcloth::{SimConfig, Simulation};

fn main() {
    let mut cfg = SimConfig::thesis_demo();
    let args: Vec<String> = std::env::args().collect();
    if let Some(v) = args.get(1) {
        cfg.air.trapped_air = v.parse().unwrap();
        let h = cfg.cloth.particle_radius() + cfg.air.trapped_air / 0.09;
        cfg.cloth.position.y = h;
    }
    if let Some(v) = args.get(2) {
        cfg.air.enabled = v == "on";
    }
    if let Some(v) = args.get(3) {
        cfg.cloth.strain_limit = v.parse().unwrap();
    }
    cfg.simulation.duration = 2.0;
    let mut sim = Simulation::new(cfg.clone()).unwrap();
    let per = (0.05 / cfg.simulation.time_step).round() as usize;
    let t0 = std::time::Instant::now();
    let mut k = 0;
    loop {
        let m = sim.metrics();
        println!(
            "t={:.2} V={:.3}cm3 P={:.0} KE={:.3e} str={:.3} contact={:.2} h={:.4} F={:.3}",
            m.time,
            m.air_volume * 1e6,
            m.air_pressure,
            m.kinetic_energy,
            m.max_stretch,
            m.contact_fraction,
            m.max_height,
            m.grab_force
        );
        if m.time >= cfg.simulation.duration {
            break;
        }
        for _ in 0..per {
            if let Err(e) = sim.step() {
                println!("{e}");
                return;
            }
            k += 1;
        }
    }
    eprintln!(
        "{} steps in {:?}: {:.0} steps/s",
        k,
        t0.elapsed(),
        k as f64 / t0.elapsed().as_secs_f64()
    );
}
