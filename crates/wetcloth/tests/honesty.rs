//! What the core must never let through, found from outside: a correct run stopped for the
//! water film's work, and a leak that carries a bubble past the atmosphere. Each test is named
//! after what was found.

use wetcloth::{AirModelKind, Real, SimConfig, Simulation};

/// The thesis demo with the pockets model on a 10 x 10 cloth at `time_step` (s).
fn pockets_demo(time_step: Real) -> SimConfig {
    let mut cfg = SimConfig::thesis_demo();
    cfg.air.model = AirModelKind::Pockets;
    cfg.cloth.resolution = [10, 10];
    cfg.grabs[0].particle = [5, 5];
    cfg.simulation.time_step = time_step;
    cfg
}

/// The water film pulls sealed particles onto the table: work done on the cloth from outside
/// its mechanical energy, like the hands'. It was not in the energy budget, so the thesis demo
/// with pockets at 1e-5 s stopped at 12.8 ms as "the cloth gained 4.6 mJ", and a smaller step
/// made it worse. Now the film's work is counted (and the run passes its audits), while the
/// same run without the film's pull is audited against a budget without it.
#[test]
fn film_pull_is_in_the_energy_budget() {
    let cfg = pockets_demo(1e-5);
    let mut sim = Simulation::new(cfg.clone()).unwrap();
    // Every particle's path, m.
    let mut path = 0.0;
    for step in 0..4000 {
        let before = sim.positions().clone();
        sim.step().unwrap();
        let after = sim.positions();
        path += (0..after.len())
            .map(|k| (after.get(k) - before.get(k)).length())
            .sum::<Real>();
        if step % 100 == 99 {
            sim.audit().unwrap();
        }
    }
    let film = sim.control().film_work();
    assert!(film > 1e-3, "the film did {film} J");
    // Its work is at most its pull, 300 Pa * S on a soaked particle, over the paths.
    let bound = 300.0 * sim.area_per_particle() * path;
    assert!(film <= bound, "{film} J, more than {bound} J");

    // Without the film's pull the film does no work.
    let mut dry = cfg;
    dry.cloth.wet_adhesion = 0.0;
    let mut sim = Simulation::new(dry).unwrap();
    sim.advance(400).unwrap();
    sim.audit().unwrap();
    assert_eq!(sim.control().film_work(), 0.0);
}

/// A vacuum under an `n` x `n`, 20 g cloth whose border lies 4.4 mm off the table (the thesis
/// demo's height), with a leak of `leak_conductance` m^2/s, `steps` steps of position Verlet
/// at 1e-4 s: the most air the bubble held and the largest volume it had (m^3), then over the
/// second half of the run the highest pressure (Pa) and the largest particle speed (m/s), and
/// the pressure at the end (Pa).
fn leaking_vacuum(n: usize, leak_conductance: Real, steps: u32) -> [Real; 5] {
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.resolution = [n, n];
    cfg.cloth.mass = 0.02;
    cfg.grabs.clear();
    cfg.air.trapped_air = 0.0;
    cfg.air.leak_conductance = leak_conductance;
    cfg.simulation.time_step = 1e-4;
    let mut sim = Simulation::new(cfg).unwrap();
    let [mut air, mut pressure, mut speed] = [0.0; 3];
    // The volume at the start counts: the first step may fill it.
    let mut volume = sim.air().bubble().unwrap().volume;
    for step in 0..steps {
        sim.step().unwrap();
        let b = sim.air().bubble().unwrap();
        air = Real::max(air, b.trapped_air);
        volume = Real::max(volume, b.volume);
        if step >= steps / 2 {
            pressure = Real::max(pressure, sim.air_pressure());
            let v = sim.velocities();
            for k in 0..v.len() {
                speed = Real::max(speed, v.get(k).length());
            }
        }
    }
    [air, volume, pressure, speed, sim.air_pressure()]
}

/// The leak was an explicit step on the amount of air, `N + c L (P_a - P) / P_a dt`: once
/// `c L dt / V` exceeds 1 it admits more air than the bubble holds, so a vacuum behind a
/// lifted border ended at 39 atmospheres with 3.1 l of air in an 8 ml bubble at the largest
/// conductance (3.9e5 and 3.9e6 Pa at 0.1 and 1), and a small cloth jumped millimetres every
/// step. Integrated exactly, the air relaxes towards the amount that fills the bubble at
/// atmospheric pressure and never past it: the bubble never holds more air than its largest
/// volume, and once the cloth has settled its pressure is the atmosphere's and it is still.
#[test]
fn a_strong_leak_brings_the_bubble_towards_the_atmosphere() {
    let pa = 101_325.0;
    for n in [4, 10] {
        for c in [0.01, 0.1, 1.0, 10.0] {
            let [air, volume, pressure, speed, end] = leaking_vacuum(n, c, 4000);
            assert!(
                air <= volume.max(1e-6 * 0.09) * (1.0 + 1e-12),
                "{n} x {n}, conductance {c}: {air} m^3 of air in {volume} m^3"
            );
            assert!(
                pressure < 1.01 * pa && (end - pa).abs() < 0.01 * pa,
                "{n} x {n}, conductance {c}: {pressure} Pa, {end} Pa at the end"
            );
            assert!(speed < 0.05, "{n} x {n}, conductance {c}: {speed} m/s");
        }
    }
}

/// A cube of half side `h` centred at `c`, as 12 triangles (indices from `base`), wound
/// outwards, or inwards with `inwards`.
fn cube(
    c: wetcloth::Vec3,
    h: Real,
    base: u32,
    inwards: bool,
) -> (Vec<wetcloth::Vec3>, Vec<[u32; 3]>) {
    let v: Vec<wetcloth::Vec3> = (0..8)
        .map(|k| {
            let s = |b: u32| if k & b != 0 { h } else { -h };
            c + wetcloth::Vec3::new(s(1), s(2), s(4))
        })
        .collect();
    // Outward faces of the unit cube with corner k = x + 2 y + 4 z.
    let quads = [
        [0, 2, 3, 1], // z-
        [4, 5, 7, 6], // z+
        [0, 1, 5, 4], // y-
        [2, 6, 7, 3], // y+
        [0, 4, 6, 2], // x-
        [1, 3, 7, 5], // x+
    ];
    let mut t = Vec::new();
    for q in quads {
        for tri in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            let mut tri = tri.map(|i| i + base);
            if inwards {
                tri.swap(1, 2);
            }
            t.push(tri);
        }
    }
    (v, t)
}

/// A closed mesh of two boxes wound opposite ways was taken to contain all of space (the
/// inside-out part's outside counted as inside): a cloth far from both was "inside this mesh".
/// Each part is now turned outwards by its own volume.
#[test]
fn closed_meshes_with_parts_wound_oppositely_are_two_solids() {
    use wetcloth::Vec3;
    let (mut v, mut t) = cube(Vec3::new(-2.0, 0.0, 0.0), 0.5, 0, false);
    let (v2, t2) = cube(Vec3::new(2.0, 0.0, 0.0), 0.5, 8, true);
    v.extend(v2);
    t.extend(t2);
    let mesh = wetcloth::collide::Mesh::new("two.obj", v, t, Vec3::ZERO, Vec3::ZERO, 1.0).unwrap();
    assert!(mesh.is_closed());
    // Outside both: positive, at the distance to the nearer box.
    let (d, _) = mesh.distance(Vec3::new(0.0, 0.0, 0.0));
    assert!((d - 1.5).abs() < 1e-12, "{d}");
    let (d, _) = mesh.distance(Vec3::new(0.0, 5.0, 0.0));
    assert!(d > 4.0, "{d}");
    // Inside each: negative.
    for x in [-2.0, 2.0] {
        let (d, n) = mesh.distance(Vec3::new(x, 0.1, 0.0));
        assert!((d + 0.4).abs() < 1e-12, "{x}: {d}");
        assert!((n - Vec3::Y).length() < 1e-12, "{n}");
    }
}

/// A closed mesh of zero volume (a flat square whose two faces are its two sides: every edge
/// shared by two triangles running it opposite ways) was taken as a solid of no inside whose
/// outside was everything. It is open and two-sided.
#[test]
fn a_closed_mesh_of_no_volume_is_an_open_two_sided_sheet() {
    use wetcloth::Vec3;
    let v = vec![
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(-1.0, 0.0, 1.0),
    ];
    // The top split along 0-2, the bottom (wound the other way) along 1-3: every edge once
    // each way.
    let t = vec![[0, 1, 2], [0, 2, 3], [1, 0, 3], [1, 3, 2]];
    let mesh = wetcloth::collide::Mesh::new("flat.obj", v, t, Vec3::ZERO, Vec3::ZERO, 1.0).unwrap();
    assert!(!mesh.is_closed());
    for y in [0.2, -0.2] {
        let (d, n) = mesh.distance(Vec3::new(0.3, y, 0.1));
        assert!((d - 0.2).abs() < 1e-12, "{y}: {d}");
        assert!((n.y - y.signum()).abs() < 1e-12, "{y}: {n}");
        // Beside it, off an edge and a corner: outside too.
        let (d, _) = mesh.distance(Vec3::new(1.5, y, 0.0));
        assert!((d - 0.5f64.hypot(0.2)).abs() < 1e-12, "{y}: {d}");
        let (d, _) = mesh.distance(Vec3::new(2.0, y, 2.0));
        assert!(d > 1.0, "{y}: {d}");
    }
}

/// A mesh whose coordinates reach 1e155 and beyond overflowed the contact queries' squared
/// distances and judged a cloth inside a triangle 1e200 m away. Such a model is refused,
/// naming the vertex and the value.
#[test]
fn huge_mesh_coordinates_are_refused() {
    use wetcloth::Vec3;
    let v = vec![
        Vec3::new(0.0, -1e200, 0.0),
        Vec3::new(1e200, -1e200, 0.0),
        Vec3::new(0.0, -1e200, 1e200),
    ];
    let err =
        wetcloth::collide::Mesh::new("far.obj", v, vec![[0, 1, 2]], Vec3::ZERO, Vec3::ZERO, 1.0)
            .unwrap_err();
    assert_eq!(
        err.to_string(),
        "vertex 1 (counting from 1) has the coordinate -1e200, out of range: allowed each in [-1e9, 1e9] (the model's units)"
    );
}

/// A 16 x 16 wet cloth landing on the table while a sphere rises through the table into it,
/// pockets model with the air force `enabled` or not: the least amount of air (m^3) and the
/// least pressure (Pa) any pocket had at the end of any step, and how many pocket-steps.
fn rising_sphere(
    enabled: bool,
    centre: [Real; 3],
    radius: Real,
    mirrored: bool,
) -> (Real, Real, usize) {
    use wetcloth::collide::Key;
    use wetcloth::{Collider, Vec3};
    let mut cfg = SimConfig::thesis_demo();
    cfg.air.model = AirModelKind::Pockets;
    cfg.air.enabled = enabled;
    cfg.air.trapped_air = 0.0;
    cfg.cloth.resolution = [16, 16];
    cfg.cloth.position = Vec3::new(0.0, 0.03, 0.0);
    cfg.cloth.self_collision = false;
    cfg.cloth.strain_limit = 0.1;
    cfg.grabs.clear();
    cfg.simulation.time_step = 2e-4;
    let mut sphere = Collider::sphere(Vec3::from(centre), radius, 0.6);
    sphere.keys = vec![
        Key {
            time: 0.0,
            offset: Vec3::ZERO,
            rotation: Vec3::ZERO,
        },
        Key {
            time: 0.3,
            offset: Vec3::new(0.0, 2.0 * radius, 0.0),
            rotation: Vec3::ZERO,
        },
    ];
    cfg.colliders.push(sphere);
    let mut sim = Simulation::new(cfg).unwrap();
    if mirrored {
        // The same cloth mirrored in z: every cell wound the other way, so every signed gap
        // volume under it is negative (a cloth lying upside down, or cells folded over).
        let mut x = sim.positions().clone();
        for z in &mut x.z {
            *z = -*z;
        }
        sim.set_state(x.clone(), x).unwrap();
    }
    let (mut amount, mut pressure, mut seen): (Real, Real, usize) =
        (Real::INFINITY, Real::INFINITY, 0);
    for _ in 0..1500 {
        if sim.step().is_err() {
            break;
        }
        for r in sim.pocket_reports() {
            amount = amount.min(r.amount);
            pressure = pressure.min(r.pressure);
            seen += 1;
        }
    }
    (amount, pressure, seen)
}

/// A cell of negative signed gap volume (its cloth below the surface, or wound the other way:
/// folded over, or lying upside down) counted its volume as enclosed air, or as a share of a
/// pocket's: pockets of -1.3 to -8.9 cm^3 of air (a sphere rising into a landing cloth), and
/// negative absolute pressures, in runs that exited 0. Air and absolute pressure are never
/// negative now, beyond round-off.
#[test]
fn pockets_never_hold_negative_air() {
    let mut seen = 0;
    for enabled in [false, true] {
        for (centre, radius) in [
            ([0.02, -0.06, 0.01], 0.05),
            ([0.0, -0.1, 0.0], 0.1),
            ([0.1, -0.03, -0.05], 0.03),
        ] {
            for mirrored in [false, true] {
                let (amount, pressure, n) = rising_sphere(enabled, centre, radius, mirrored);
                seen += n;
                let case = format!("air {enabled}, {centre:?}, mirrored {mirrored}");
                assert!(amount >= -1e-15, "{case}: {amount} m^3");
                assert!(pressure >= -1e-3, "{case}: {pressure} Pa");
            }
        }
    }
    assert!(seen > 0, "no pocket formed");
}

/// Seeding asked every particle for its seed once per seed: seeds^2 x particles, so 20 000
/// seeds took 30 s before the first step (100 000, minutes). Each particle's seed is found
/// once now: 20 000 seeds on a 50 x 50 cloth start in well under a second (the bound leaves
/// room for a slow, shared machine).
#[test]
fn many_seeded_pockets_start_at_once() {
    let mut cfg = SimConfig::thesis_demo();
    cfg.air.model = AirModelKind::Pockets;
    cfg.air.trapped_air = 0.0;
    cfg.cloth.position.y = cfg.cloth.particle_radius();
    cfg.grabs.clear();
    // Small discs on every other particle but the border ones (24 x 24 of them, each sealed
    // round by its neighbours), over and over: 20 000 seeds.
    let d = 0.3 / 49.0;
    cfg.air.pockets = (0..20_000)
        .map(|k| {
            let (i, j) = (1 + 2 * (k % 24), 1 + 2 * ((k / 24) % 24));
            wetcloth::PocketSeed {
                center: [-0.15 + i as Real * d, -0.15 + j as Real * d],
                radius: 0.001,
                amount: 1e-9,
                point: None,
            }
        })
        .collect();
    let start = std::time::Instant::now();
    let sim = Simulation::new(cfg).unwrap();
    let took = start.elapsed().as_secs_f64();
    assert!(took < 5.0, "{took} s to seed");
    // One pocket per seeded particle, holding its first seed's air.
    let pockets = &sim.air().pockets().unwrap().pockets;
    assert_eq!(pockets.len(), 24 * 24);
    assert!(pockets.iter().all(|p| (p.amount - 1e-9).abs() < 1e-21));
}
