//! Checkpoints: N steps, checkpoint, restore, M steps is N + M steps, bit for bit, whatever the
//! thread count on either side, with grabs, trapped air, a leak, self-collision and strain
//! limiting on, for the thesis' bubble and for the pockets model. (Needs the `serde` feature,
//! which the workspace's other crates turn on: `cargo test --workspace` runs it.)
#![cfg(feature = "serde")]

use wetcloth::params::{AirModelKind, PocketSeed};
use wetcloth::{Checkpoint, GrabKey, GrabSpec, RestoreError, SimConfig, Simulation, Vec3};

fn fnv1a(words: impl Iterator<Item = u64>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for w in words {
        for b in w.to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    h
}

/// Digest of everything observable: positions, previous positions, the metrics, the air, the
/// hands' work and force, and the step count.
fn digest(sim: &Simulation) -> u64 {
    let p = sim.positions();
    let q = sim.previous_positions();
    let words = [&p.x, &p.y, &p.z, &q.x, &q.y, &q.z]
        .into_iter()
        .flat_map(|v| v.iter().map(|x| x.to_bits()))
        .chain(sim.metrics().values().map(f64::to_bits))
        .chain(
            [
                sim.trapped_air(),
                sim.air_volume(),
                sim.air_pressure(),
                sim.control().hand_work(),
                sim.grab_force().length(),
            ]
            .map(f64::to_bits),
        )
        .chain([sim.step_count(), sim.pocket_count() as u64]);
    fnv1a(words)
}

/// The golden scene with a leak and a corner lifted early, so that air leaks in through the
/// lifted border, the self-collision lists are rebuilt, and the grab's anchor is set.
fn thesis_scene() -> SimConfig {
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.resolution = [17, 17];
    cfg.cloth.strain_limit = 0.5;
    cfg.cloth.self_collision = true;
    // Thick, so that the fold below brings the layers within a particle diameter (1 cm).
    cfg.cloth.thickness = 0.008;
    cfg.cloth.collision_margin = 0.002;
    cfg.air.trapped_air = 200e-6;
    cfg.air.leak_conductance = 0.05;
    cfg.cloth.position.y = cfg.cloth.particle_radius() + 200e-6 / 0.09;
    // A corner lifted, carried over the cloth and laid on it (a fold: self-collision acts),
    // and the centre pinched and lifted.
    let key = |time, x, y, z| GrabKey {
        time,
        offset: Vec3::new(x, y, z),
    };
    cfg.grabs = vec![
        GrabSpec {
            particle: [0, 0],
            pick: None,
            keys: vec![
                key(0.0, 0.0, 0.0, 0.0),
                key(0.02, 0.0, 0.03, 0.0),
                key(0.08, 0.12, 0.03, 0.12),
                key(0.12, 0.12, 0.008, 0.12),
            ],
        },
        GrabSpec::lift([8, 8], 0.005, 0.03, 0.01),
    ];
    cfg
}

/// Wet cloth on the plane with a seeded pocket of air, the pockets model.
fn pockets_scene() -> SimConfig {
    let mut cfg = thesis_scene();
    cfg.air.model = AirModelKind::Pockets;
    cfg.air.pockets = vec![PocketSeed {
        center: [0.0, 0.0],
        radius: 0.06,
        amount: 100e-6,
        point: None,
    }];
    cfg
}

/// Steps of every run: 0.15 s at the thesis' time step, past the fold.
const STEPS: u64 = 1800;

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// Through the bytes a file would hold.
fn round_trip(c: &Checkpoint) -> Checkpoint {
    let bytes = postcard::to_allocvec(c).unwrap();
    postcard::from_bytes(&bytes).unwrap()
}

fn straight(cfg: &SimConfig, steps: u64) -> (u64, Simulation) {
    in_pool(1, || {
        let mut sim = Simulation::new(cfg.clone()).unwrap();
        sim.advance(steps).unwrap();
        (digest(&sim), sim)
    })
}

fn resumed(cfg: &SimConfig, split: u64, steps: u64, threads: (usize, usize)) -> u64 {
    let saved = in_pool(threads.0, || {
        let mut sim = Simulation::new(cfg.clone()).unwrap();
        sim.advance(split).unwrap();
        round_trip(&sim.checkpoint())
    });
    assert_eq!(saved.steps(), split);
    in_pool(threads.1, || {
        let mut sim = Simulation::restore(cfg.clone(), saved).unwrap();
        assert_eq!(sim.step_count(), split);
        sim.advance(steps - split).unwrap();
        digest(&sim)
    })
}

fn continues_bit_for_bit(cfg: SimConfig) -> Simulation {
    let steps = STEPS;
    let (want, sim) = straight(&cfg, steps);
    for (split, threads) in [
        (0, (1, 2)),
        (1, (2, 1)),
        (77, (1, 2)),
        (700, (2, 2)),
        (1234, (1, 1)),
        (STEPS - 1, (2, 1)),
    ] {
        assert_eq!(
            resumed(&cfg, split, steps, threads),
            want,
            "checkpoint at step {split}, threads {threads:?}"
        );
    }
    sim
}

#[test]
fn checkpoint_restore_continues_bit_for_bit() {
    let cfg = thesis_scene();
    let sim = continues_bit_for_bit(cfg.clone());
    // The scene does exercise what the checkpoint must carry.
    assert_ne!(sim.trapped_air(), cfg.air.trapped_air, "no air leaked");
    assert!(sim.self_collision_rebuilds() > 1, "lists never rebuilt");
    assert!(sim.control().hand_work() > 0.0);
    assert!(sim.air_volume() > 0.0);
    let mut apart = cfg;
    apart.cloth.self_collision = false;
    assert_ne!(
        straight(&apart, STEPS).0,
        digest(&sim),
        "self-collision never acted"
    );
}

#[test]
fn checkpoint_restore_continues_bit_for_bit_with_pockets() {
    let cfg = pockets_scene();
    continues_bit_for_bit(cfg.clone());
    let (_, sim) = straight(&cfg, 700);
    assert!(sim.pocket_count() >= 1, "no pocket at the checkpoint");
}

#[test]
fn a_checkpoint_of_another_scene_is_refused() {
    let mut sim = Simulation::new(thesis_scene()).unwrap();
    sim.advance(5).unwrap();
    let saved = sim.checkpoint();

    let mut bigger = thesis_scene();
    bigger.cloth.resolution = [18, 17];
    let err = Simulation::restore(bigger, saved.clone()).unwrap_err();
    assert!(matches!(err, RestoreError::Mismatch(_)), "{err}");

    let err = Simulation::restore(pockets_scene(), saved.clone()).unwrap_err();
    assert!(err.to_string().contains("air model"), "{err}");

    let mut alone = thesis_scene();
    alone.cloth.self_collision = false;
    let err = Simulation::restore(alone, saved).unwrap_err();
    assert!(err.to_string().contains("self-collision"), "{err}");
}

/// The implicit integrator carries each contact's slide from step to step (`State::slides`):
/// a dry cloth whose corner drags it over the table at 1/600 s continues bit for bit from
/// checkpoints taken while its contacts slide.
#[test]
fn checkpoint_restore_continues_bit_for_bit_with_the_implicit_integrator() {
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.resolution = [17, 17];
    cfg.cloth.self_collision = false;
    cfg.air.enabled = false;
    cfg.air.trapped_air = 0.0;
    cfg.cloth.position.y = cfg.cloth.particle_radius();
    cfg.simulation.integrator = wetcloth::Integrator::Implicit;
    cfg.simulation.time_step = 1.0 / 600.0;
    cfg.grabs = vec![GrabSpec {
        particle: [0, 0],
        pick: None,
        keys: vec![
            GrabKey {
                time: 0.0,
                offset: Vec3::ZERO,
            },
            GrabKey {
                time: 0.3,
                offset: Vec3::new(-0.06, 0.01, 0.0),
            },
        ],
    }];
    let steps = 180;
    let (want, _) = straight(&cfg, steps);
    for (split, threads) in [(0, (1, 2)), (1, (2, 1)), (60, (1, 2)), (150, (2, 2))] {
        assert_eq!(
            resumed(&cfg, split, steps, threads),
            want,
            "checkpoint at step {split}, threads {threads:?}"
        );
    }
    let (_, sim) = straight(&cfg, 150);
    let sliding = sim
        .state()
        .slides
        .iter()
        .filter(|s| matches!(s, wetcloth::state::Slide::Kinetic(_)))
        .count();
    assert!(sliding > 10, "{sliding} contacts sliding at the checkpoint");
}

/// The interactive solve budget starts each step from the velocity plus the last step's
/// acceleration (`State::acceleration`), so that acceleration is carried: the thesis demo's
/// bubble under a cloth lifted at its centre at 1/60 s continues bit for bit from checkpoints
/// taken during the lift.
#[test]
fn checkpoint_restore_continues_bit_for_bit_with_the_interactive_budget() {
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.resolution = [17, 17];
    cfg.cloth.self_collision = false;
    cfg.simulation.integrator = wetcloth::Integrator::Implicit;
    cfg.simulation.implicit_budget = wetcloth::SolveBudget::Interactive;
    cfg.simulation.time_step = 1.0 / 60.0;
    cfg.grabs = vec![GrabSpec::lift([8, 8], 0.1, 0.6, 0.03)];
    let steps = 50;
    let (want, _) = straight(&cfg, steps);
    for (split, threads) in [(1, (1, 2)), (20, (2, 1)), (30, (1, 1))] {
        assert_eq!(
            resumed(&cfg, split, steps, threads),
            want,
            "checkpoint at step {split}, threads {threads:?}"
        );
    }
    let (_, sim) = straight(&cfg, 20);
    let moving = sim
        .state()
        .acceleration
        .y
        .iter()
        .filter(|a| a.abs() > 1e-3)
        .count();
    assert!(
        moving > 10,
        "{moving} particles accelerating at the checkpoint"
    );
}
