//! Golden digest: a small scene's final state, bit for bit.
//!
//! The speed work on the step (vectorised kernels, springs evaluated once, parallel rows) must
//! not change the physics. The physics tests bound the error against closed forms; this test
//! pins the exact bits of one run that exercises everything (springs, gravity, damping, plane
//! contact and friction, the pressure force with trapped air, a grab, self-collision, strain
//! limiting). It fails on any change of the numbers, intended or not.
//!
//! When a change of the numbers is intended (a new term in the model, another summation order),
//! check the physics tests still pass, then replace `GOLDEN` with the pair this test prints on
//! failure. The pair's first number, the count of values hashed, is kept beside the digest so a
//! changed particle count is told apart from changed values.
//!
//! Last intended change: the implicit bubble pressure is solved from the step's coasting
//! positions (springs and contacts included) and counts the hands' particles as held.

use wetcloth::{GrabSpec, SimConfig, Simulation};

/// (number of state values hashed, FNV-1a 64 digest of their bits).
// (6543, 5373332358238574821) before metrics gained `pocket_count` (the same state: the old
// digest is that of these words without the last one).
// (6544, 3527288578448526840) before metrics gained `elastic_energy` (the same state, one
// word more).
// (6545, 15209493011294440913) before metrics gained `attach_force` (the same state, one word
// more).
const GOLDEN: (usize, u64) = (6546, 10117265387316113905);

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

fn final_state(threads: usize) -> (usize, u64) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut cfg = SimConfig::thesis_demo();
        cfg.cloth.resolution = [33, 33];
        cfg.cloth.strain_limit = 0.5;
        cfg.air.trapped_air = 200e-6;
        cfg.cloth.position.y = cfg.cloth.particle_radius() + 200e-6 / 0.09;
        cfg.grabs = vec![GrabSpec::lift([16, 16], 0.0, 0.04, 0.01)];
        let mut sim = Simulation::new(cfg).unwrap();
        sim.advance(600).unwrap();
        let p = sim.positions();
        let q = sim.previous_positions();
        let words: Vec<u64> = [&p.x, &p.y, &p.z, &q.x, &q.y, &q.z]
            .into_iter()
            .flat_map(|v| v.iter().map(|x| x.to_bits()))
            .chain(sim.metrics().values().map(f64::to_bits))
            .collect();
        (words.len(), fnv1a(words.into_iter()))
    })
}

#[test]
fn a_small_scene_ends_in_exactly_the_pinned_state() {
    let one = final_state(1);
    assert_eq!(one, final_state(2), "the thread count changed the result");
    assert_eq!(
        one, GOLDEN,
        "golden digest of tests/golden.rs changed: if intended, set GOLDEN = {one:?}"
    );
}
