//! The physics of the thesis model against closed forms. Each test states the law, the set-up
//! and why its tolerance is what it is.

use wetcloth::air::{self, StickingPlane, volume};
use wetcloth::forces::{pressure_force, spring_force};
use wetcloth::{AirParams, ClothParams, Collider, Grid, Real, SimConfig, Simulation, Soa, Vec3};

/// A small cloth with no air, no grabs, no colliders, no damping.
fn bare(n: usize) -> SimConfig {
    SimConfig {
        cloth: ClothParams {
            resolution: [n, n],
            size: [0.1, 0.1],
            mass: 0.01,
            position: Vec3::new(0.0, 1.0, 0.0),
            self_collision: false,
            ..Default::default()
        },
        air: AirParams {
            enabled: false,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// `bare(n)` lying on a level plane of friction `mu`, its particle spheres touching it, under
/// gravity (9.8 m/s^2) tilted by `theta` (rad) towards +x: a slope of angle `theta`.
fn on_a_slope(n: usize, theta: Real, mu: Real) -> SimConfig {
    let mut cfg = bare(n);
    cfg.simulation.gravity = Vec3::new(9.8 * theta.sin(), -9.8 * theta.cos(), 0.0);
    cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, mu)];
    cfg.cloth.position.y = cfg.cloth.particle_radius();
    cfg
}

/// The bits of every position and of every `metrics.csv` column of `sim`.
fn state_bits(sim: &Simulation) -> (Vec<u64>, [u64; 12]) {
    let p = sim.positions();
    let bits =
        p.x.iter()
            .chain(&p.y)
            .chain(&p.z)
            .map(|v| v.to_bits())
            .collect();
    (bits, sim.metrics().values().map(Real::to_bits))
}

fn run(sim: &mut Simulation, seconds: Real) {
    let steps = (seconds / sim.time_step()).round() as u64;
    for _ in 0..steps {
        sim.step().expect("stable step");
    }
}

fn mean(v: &[Real]) -> Real {
    v.iter().sum::<Real>() / v.len() as Real
}

// ---- Bubble volume, eq. 3.10 ----------------------------------------------------------------

fn grid_of(n: [usize; 2], size: [Real; 2]) -> Grid {
    Grid::new(&ClothParams {
        resolution: n,
        size,
        ..Default::default()
    })
}

/// A flat cloth at height h encloses exactly area * h (each prism is exact).
#[test]
fn volume_of_a_flat_cloth_is_area_times_height() {
    let g = grid_of([11, 7], [0.3, 0.2]);
    let p = g.rest_positions(Vec3::new(0.5, 0.04, -0.2));
    let v = volume(&g, &p, StickingPlane::new(Vec3::ZERO, Vec3::Y), 0.0);
    assert!((v - 0.3 * 0.2 * 0.04).abs() < 1e-15, "{v}");
    // Measured from the particle spheres' bottom: a cloth resting on the plane holds no air.
    let v = volume(&g, &p, StickingPlane::new(Vec3::ZERO, Vec3::Y), 0.04);
    assert!(v.abs() < 1e-15);
}

/// Heights linear over every triangle make every prism exact: a tilted cloth and a tent whose
/// ridge lies on a grid line give their exact volumes up to round-off.
#[test]
fn volume_of_tilted_and_tent_shaped_cloths_is_exact() {
    let g = grid_of([21, 21], [0.3, 0.3]);
    let mut p = g.rest_positions(Vec3::ZERO);
    // Tilted: h = 0.05 + 0.2 x (x in [-0.15, 0.15]): mean height 0.05.
    for k in 0..g.len() {
        p.y[k] = 0.05 + 0.2 * p.x[k];
    }
    let v = volume(&g, &p, StickingPlane::new(Vec3::ZERO, Vec3::Y), 0.0);
    // The tilted sheet's projected area is still 0.3 x 0.3 (x and z unchanged).
    assert!((v - 0.09 * 0.05).abs() < 1e-15, "tilted {v}");
    // Tent: ridge along z at x = 0 (column 10), height H, down to 0 at x = +-0.15: V = A H / 2.
    for k in 0..g.len() {
        p.y[k] = 0.04 * (1.0 - p.x[k].abs() / 0.15);
    }
    let v = volume(&g, &p, StickingPlane::new(Vec3::ZERO, Vec3::Y), 0.0);
    assert!((v - 0.09 * 0.02).abs() < 1e-15, "tent {v}");
    // The same tent over a tilted sticking plane, rotated with it: same volume.
    let rot = glam::DQuat::from_rotation_z(0.3);
    let q = Soa::from_vec3(&p.to_vec3().iter().map(|v| rot * *v).collect::<Vec<_>>());
    let v2 = volume(&g, &q, StickingPlane::new(Vec3::ZERO, rot * Vec3::Y), 0.0);
    assert!((v2 - v).abs() < 1e-15, "rotated {v2}");
}

/// A cloth folded over itself: where layers overlap, the upper layer faces down and its prism
/// is subtracted (figs. 3.11-3.12). A Z-fold of three layers at heights h1 < h2 < h3 over the
/// same footprint encloses A (h1 - h2 + h3): the air under the bottom layer plus the pocket
/// between the top two, not three layers' worth. Laid flat (all at h) it is one layer's A h.
#[test]
fn folded_cloth_cancels_overlapping_layers() {
    let n = 6; // columns per layer
    let (len, width) = (0.1, 0.05);
    let g = grid_of([3 * n, 2], [1.0, width]);
    let fold = |h: [Real; 3]| {
        let mut p = Soa::zeros(g.len());
        for j in 0..2 {
            for c in 0..3 * n {
                let (layer, s) = (c / n, (c % n) as Real / (n - 1) as Real);
                let x = if layer == 1 { len * (1.0 - s) } else { len * s };
                p.set(g.index(c, j), Vec3::new(x, h[layer], j as Real * width));
            }
        }
        p
    };
    let (h1, h2, h3) = (0.01, 0.013, 0.017);
    let p = fold([h1, h2, h3]);
    let v = volume(&g, &p, StickingPlane::new(Vec3::ZERO, Vec3::Y), 0.0);
    let exact = len * width * (h1 - h2 + h3);
    assert!((v - exact).abs() < 1e-16, "{v} vs {exact}");
    let flat = volume(
        &g,
        &fold([h1; 3]),
        StickingPlane::new(Vec3::ZERO, Vec3::Y),
        0.0,
    );
    assert!((flat - len * width * h1).abs() < 1e-16, "{flat}");
}

// ---- Boyle, eq. 3.8-3.9 ---------------------------------------------------------------------

/// Along a whole run in which the bubble grows and shrinks, the reported pressure and volume
/// keep P_b v = P_a v0 (to round-off: P_b is computed from v).
#[test]
fn boyle_pressure_times_volume_is_constant_during_a_run() {
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.resolution = [15, 15];
    cfg.cloth.self_collision = false;
    cfg.air.trapped_air = 200e-6;
    cfg.cloth.position.y = cfg.cloth.particle_radius() + 200e-6 / 0.09;
    // The whole cloth is carried up by 1 cm and back down to 5 mm: the bubble must grow and
    // shrink, and its pressure follow.
    cfg.grabs = (0..15 * 15)
        .map(|k| wetcloth::GrabSpec {
            particle: [k % 15, k / 15],
            pick: None,
            keys: vec![
                wetcloth::GrabKey {
                    time: 0.0,
                    offset: Vec3::ZERO,
                },
                wetcloth::GrabKey {
                    time: 0.1,
                    offset: Vec3::new(0.0, 0.01, 0.0),
                },
                wetcloth::GrabKey {
                    time: 0.15,
                    offset: Vec3::new(0.0, 0.005, 0.0),
                },
            ],
        })
        .collect();
    let k = cfg.air.atmospheric_pressure * cfg.air.trapped_air;
    let mut sim = Simulation::new(cfg).unwrap();
    let (mut vmin, mut vmax) = (Real::INFINITY, 0.0 as Real);
    for _ in 0..20 {
        run(&mut sim, 0.01);
        let m = sim.metrics();
        vmin = vmin.min(m.air_volume);
        vmax = vmax.max(m.air_volume);
        assert!(
            (m.air_pressure * m.air_volume - k).abs() < 1e-12 * k,
            "{m:?}"
        );
    }
    // Carried 5 mm above where it started: v = v0 + A * 5 mm exactly.
    let v = sim.air_volume();
    assert!((v - (200e-6 + 0.09 * 0.005)).abs() < 1e-12, "{v}");
    assert!(
        vmax > 1.2 * vmin,
        "the volume must actually change: {vmin} .. {vmax}"
    );
}

// ---- Gravity and Verlet, eq. 3.1, 3.3 -----------------------------------------------------

/// Free fall: with the Taylor start, position Verlet is exact for constant acceleration, so
/// every particle follows y0 - g t^2 / 2 up to round-off. Round-off of ~1e-16 m per step in the
/// implied velocity accumulates to ~n^2 1e-16 after n steps (4e-9 m at n = 6000), far below the
/// error of a naive start, g t dt / 2 = 2e-4 m at t = 0.5 s.
#[test]
fn free_fall_follows_the_parabola() {
    let mut sim = Simulation::new(bare(6)).unwrap();
    for _ in 0..10 {
        run(&mut sim, 0.05);
        let t = sim.time();
        let exact = 1.0 - 0.5 * 9.8 * t * t;
        let n = sim.step_count() as Real;
        for &y in &sim.positions().y {
            assert!((y - exact).abs() < 2e-16 * n * n, "t = {t}: {y} vs {exact}");
        }
    }
}

// ---- Springs, eq. 3.6 ---------------------------------------------------------------------

/// Hooke: a 2 x 2 cloth stretched uniformly along x by e, no gravity: after one step each
/// particle has moved by F dt^2 / (2m) (Taylor start) with F = k e dx from its structural spring
/// plus the shear springs' x share; linear in e, as Hooke says.
#[test]
fn springs_obey_hookes_law() {
    for (e, k, ks) in [(0.01, 500.0, 0.0), (0.02, 500.0, 0.0), (0.01, 800.0, 200.0)] {
        let mut cfg = bare(2);
        cfg.simulation.gravity = Vec3::ZERO;
        cfg.cloth.structural_stiffness = k;
        cfg.cloth.shear_stiffness = ks;
        let mut sim = Simulation::new(cfg).unwrap();
        let g = sim.grid().clone();
        let mut p = sim.positions().clone();
        for x in &mut p.x {
            *x *= 1.0 + e;
        }
        sim.set_state(p.clone(), p.clone()).unwrap();
        sim.step().unwrap();
        // Structural: k (d - l) = k e dx; shear: diagonal of (dx(1+e), dz) vs rest diagonal.
        let (dx, dz) = (g.dx, g.dz);
        let diag = ((dx * (1.0 + e)).powi(2) + dz * dz).sqrt();
        let rest = (dx * dx + dz * dz).sqrt();
        let f = k * e * dx + ks * (diag - rest) * (dx * (1.0 + e) / diag);
        let expect = f * sim.time_step().powi(2) / (2.0 * sim.particle_mass());
        // Particle 0 sits at -x: it is pulled towards +x.
        let moved = sim.positions().x[0] - p.x[0];
        assert!(
            (moved - expect).abs() < 1e-9 * expect.abs(),
            "{moved} vs {expect}"
        );
        let pure = spring_force(Vec3::ZERO, Vec3::X * (dx * (1.0 + e)), k, dx).x;
        assert!((pure - k * e * dx).abs() < 1e-12 * pure);
    }
}

// ---- Contact and friction, eq. 3.4-3.5 ------------------------------------------------------

/// A cloth on a plane with gravity tilted by 20 degrees: with mu = 0.5 > tan 20 it stays put;
/// with mu = 0.2 it slides with a = g (sin 20 - mu cos 20). The contact response removes exactly
/// mu times the normal push each step, so the slide is exact up to round-off.
#[test]
fn friction_on_a_slope_holds_or_slides_at_the_kinetic_rate() {
    let theta: Real = 20f64.to_radians();
    let g = 9.8;
    for mu in [0.5, 0.2] {
        let mut cfg = bare(5);
        cfg.simulation.gravity = Vec3::new(g * theta.sin(), -g * theta.cos(), 0.0);
        cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, mu)];
        cfg.cloth.position.y = cfg.cloth.particle_radius();
        let mut sim = Simulation::new(cfg).unwrap();
        let x0 = mean(&sim.positions().x);
        run(&mut sim, 0.5);
        let t = sim.time();
        let dx = mean(&sim.positions().x) - x0;
        let a = (g * (theta.sin() - mu * theta.cos())).max(0.0);
        let expect = 0.5 * a * t * t;
        assert!(
            (dx - expect).abs() < 1e-9,
            "mu = {mu}: moved {dx}, expected {expect}"
        );
        if mu == 0.5 {
            assert_eq!(dx, 0.0, "static friction holds");
        }
        let y = sim
            .positions()
            .y
            .iter()
            .fold(0.0 as Real, |a, b| a.max((b - sim.particle_radius()).abs()));
        assert!(y < 1e-12, "stays on the plane");
    }
}

// ---- Pressure force, eq. 3.7 ----------------------------------------------------------------

/// The pressure force on a particle is (P_b - P_a) S N, N pointing out of the bubble: for a
/// cloth lifted off the plane with too little air (P_b < P_a) it points down. Checked through
/// the step: weightless, springless cloth hovering above the plane, one step moves every particle
/// by F dt^2 / (2 m) with F = (P_b - P_a) S (0, 1, 0).
#[test]
fn pressure_force_presses_a_lifted_cloth_down() {
    let mut cfg = bare(6);
    cfg.simulation.gravity = Vec3::ZERO;
    cfg.cloth.structural_stiffness = 0.0;
    cfg.cloth.shear_stiffness = 0.0;
    cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.5)];
    cfg.air = AirParams {
        enabled: true,
        atmospheric_pressure: 101_325.0,
        trapped_air: 0.1 * 0.1 * 0.005,
        ..Default::default()
    };
    cfg.cloth.position.y = cfg.cloth.particle_radius() + 0.01; // twice the air's own volume
    let mut sim = Simulation::new(cfg).unwrap();
    let pb = sim.air_pressure();
    assert!(
        (pb - 101_325.0 / 2.0).abs() < 1e-6,
        "Boyle: half the pressure at twice the volume"
    );
    let s = sim.area_per_particle();
    let f = pressure_force(pb, 101_325.0, s, Vec3::Y);
    assert!(f.y < 0.0 && f.x == 0.0 && f.z == 0.0, "points down: {f}");
    assert!((f.y - (pb - 101_325.0) * s).abs() < 1e-12);
    let y0 = sim.positions().y.clone();
    sim.step().unwrap();
    // The step's force uses the pressure at the end of the step (the implicit air solve):
    // every particle moves by the same amount here, so the solve's prediction of the new volume
    // is exact and the applied pressure obeys Boyle at the end of the step to round-off. The
    // cloth starts falling into the bubble, so that pressure is a little above the start's.
    let applied = sim.applied_pressure();
    let k = 101_325.0 * 0.1 * 0.1 * 0.005;
    assert!(
        (applied * sim.air_volume() - k).abs() < 1e-12 * k,
        "{applied}"
    );
    assert!(applied > pb && applied < 1.05 * pb, "{applied} vs {pb}");
    let f = pressure_force(applied, 101_325.0, s, Vec3::Y);
    let expect = f.y * sim.time_step().powi(2) / (2.0 * sim.particle_mass());
    for (y, y0) in sim.positions().y.iter().zip(&y0) {
        assert!(
            ((y - y0) - expect).abs() < 1e-12 * expect.abs(),
            "{} vs {expect}",
            y - y0
        );
    }
    // More air than the space holds pushes it up instead.
    assert!(pressure_force(2.0e5, 101_325.0, s, Vec3::Y).y > 0.0);
    assert!((air::boyle_pressure(101_325.0, 1.0, 2.0, 1.0) - 50_662.5).abs() < 1e-9);
}

/// A small bubble is a stiff air spring: 20 cm^3 under the 20 g thesis cloth has
/// omega = A sqrt(P_a / (v0 M)) = 2.0e4 rad/s, past the explicit limit 2 / dt = 2.4e4 rad/s
/// once the springs add theirs, so Boyle's law evaluated at the start of each step (the thesis)
/// blows up, while the implicit pressure (Boyle at the end of the step) settles the cloth on its
/// cushion: at rest the bubble carries the cloth's weight, P_b = P_a + M g / A.
#[test]
fn implicit_pressure_keeps_a_small_bubble_stable() {
    let run_with = |solve: wetcloth::PressureSolve| {
        let mut cfg = SimConfig::thesis_demo();
        cfg.cloth.resolution = [20, 20];
        cfg.cloth.self_collision = false;
        cfg.grabs.clear();
        cfg.air.trapped_air = 20e-6;
        cfg.air.pressure_solve = solve;
        cfg.cloth.position.y = cfg.cloth.particle_radius() + 20e-6 / 0.09;
        assert!(
            cfg.stable_time_step() < cfg.simulation.time_step
                || solve == wetcloth::PressureSolve::Implicit
        );
        let mut sim = Simulation::new(cfg).unwrap();
        let steps = (0.3 / sim.time_step()) as u64;
        sim.advance(steps).map(|()| sim.metrics())
    };
    assert!(
        run_with(wetcloth::PressureSolve::Explicit).is_err(),
        "explicit must blow up"
    );
    let m = run_with(wetcloth::PressureSolve::Implicit).expect("implicit is stable");
    let weight = 0.02 * 9.8 / 0.09;
    assert!(
        (m.air_pressure - (101_325.0 + weight)).abs() < 0.5 * weight,
        "{m:?}"
    );
    assert!(m.kinetic_energy < 1e-9, "settled: {m:?}");
}

// ---- Leaks (beyond the thesis) --------------------------------------------------------------

/// Air leaking in through a lifted border: a cloth held 1 cm above the plane (every particle
/// grabbed, so the volume v stays A h) starts as a vacuum; air enters at
/// C L (P_a - P_b) / P_a = C L (1 - v0 / v), so v0 relaxes to v with rate k = C L / v:
/// v0(t) = v (1 - exp(-k t)). Each step integrates that exponential exactly (`air::leak::relax`),
/// so the bubble holds the closed form to round-off at any step.
#[test]
fn leaking_air_refills_the_bubble_exponentially() {
    let mut cfg = bare(10);
    cfg.simulation.gravity = Vec3::ZERO;
    cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.5)];
    cfg.cloth.position.y = cfg.cloth.particle_radius() + 0.01;
    let (area, perimeter) = (0.1 * 0.1, 0.4);
    let v = area * 0.01;
    let k = 10.0; // 1/s
    cfg.air = AirParams {
        enabled: true,
        leak_conductance: k * v / perimeter,
        ..Default::default()
    };
    cfg.grabs = (0..100)
        .map(|p| wetcloth::GrabSpec::lift([p % 10, p / 10], 0.0, 1.0, 0.0))
        .collect();
    let mut sim = Simulation::new(cfg).unwrap();
    assert!((sim.air_volume() - v).abs() < 1e-15);
    for _ in 0..4 {
        run(&mut sim, 0.05);
        assert!((sim.open_border_length() - perimeter).abs() < 1e-12);
        let t = sim.time();
        let exact = v * (1.0 - (-k * t).exp());
        let got = sim.trapped_air();
        assert!((got - exact).abs() < 1e-12 * v, "{got} vs {exact}");
        let m = sim.metrics();
        assert!(
            (m.air_pressure - 101_325.0 * got / v).abs() < 1e-6,
            "Boyle with the new air"
        );
    }
    // Sealed (the default): nothing changes.
    assert_eq!(AirParams::default().leak_conductance, 0.0);
}

/// The border the leak counts as open is measured against the surface: a flat cloth whose
/// particles lie within `[air] seal_distance` (0.5 mm) beyond their radius is sealed all round,
/// one higher is open all round, whatever the step's contact flags say (a cloth just placed has
/// touched nothing yet).
#[test]
fn the_leak_opens_where_the_border_is_lifted_beyond_the_seal_distance() {
    let at = |gap: Real| {
        let mut cfg = bare(10);
        cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.5)];
        cfg.cloth.position.y = cfg.cloth.particle_radius() + gap;
        cfg.air = AirParams {
            enabled: true,
            leak_conductance: 1e-4,
            ..Default::default()
        };
        Simulation::new(cfg).unwrap().open_border_length()
    };
    let perimeter = 0.4;
    assert_eq!(at(0.0), 0.0);
    assert_eq!(at(0.0004), 0.0);
    assert!((at(0.0006) - perimeter).abs() < 1e-12, "{}", at(0.0006));
    // One corner raised: its two border edges count half each.
    let mut cfg = bare(10);
    cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.5)];
    cfg.cloth.position.y = cfg.cloth.particle_radius();
    cfg.grabs = vec![wetcloth::GrabSpec::lift([0, 0], 0.0, 0.01, 0.01)];
    let mut sim = Simulation::new(cfg).unwrap();
    run(&mut sim, 0.01);
    let spacing = 0.1 / 9.0;
    let open = sim.open_border_length();
    assert!(open >= spacing - 1e-12, "{open}");
    assert!(open < perimeter / 2.0, "{open}");
}

/// A 12 cm cloth of the thesis' spacing and areal mass (21 x 21), lying stuck on the table with
/// no air under it, air force on, no self-collision.
fn stuck_small_cloth() -> SimConfig {
    let mut cfg = SimConfig::thesis_demo();
    cfg.air.trapped_air = 0.0;
    cfg.cloth.position.y = cfg.cloth.particle_radius();
    cfg.cloth.resolution = [21, 21];
    cfg.cloth.size = [0.12, 0.12];
    cfg.cloth.mass = 0.02 * 0.16;
    cfg.cloth.self_collision = false;
    cfg
}

// ---- Suction felt by the hand ---------------------------------------------------------------

/// Lifting the centre of a cloth stuck with no trapped air: the hand feels the atmosphere on the
/// lifted area, many times the force needed with the air force off (just the weight of the
/// lifted part).
#[test]
fn suction_makes_lifting_many_times_harder() {
    let force = |air: bool| {
        let mut cfg = stuck_small_cloth();
        cfg.air.enabled = air;
        cfg.grabs = vec![wetcloth::GrabSpec::lift([10, 10], 0.02, 0.12, 0.005)];
        let mut sim = Simulation::new(cfg).unwrap();
        run(&mut sim, 0.15);
        sim.metrics().grab_force
    };
    let (wet, dry) = (force(true), force(false));
    assert!(wet > 20.0 * dry, "wet {wet} N vs dry {dry} N");
    assert!(dry > 0.0);
}

// ---- Self-collision -----------------------------------------------------------------------

/// A cloth folded in half, the upper half 5 mm above the lower one, falls onto itself: no two
/// particles that are not grid neighbours end up closer than the particle diameter (less the
/// slack of one step's motion); without self-collision the layers pass through each other.
#[test]
fn self_collision_keeps_layers_apart() {
    let gap = |self_collision: bool| {
        let mut cfg = bare(16);
        cfg.cloth.self_collision = self_collision;
        cfg.cloth.damping = 5.0;
        cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.5)];
        let mut sim = Simulation::new(cfg).unwrap();
        let g = sim.grid().clone();
        let r = sim.particle_radius();
        let mut p = sim.positions().clone();
        for j in 0..g.nz {
            for i in 0..g.nx {
                let k = g.index(i, j);
                let (x, y) = if i < g.nx / 2 {
                    (i as Real * g.dx, r)
                } else {
                    // Folded back: column nx/2 lies above column nx/2 - 1, offset by half a cell.
                    ((g.nx - 1 - i) as Real * g.dx + 0.5 * g.dx, r + 0.005)
                };
                p.x[k] = x;
                p.y[k] = y;
            }
        }
        sim.set_state(p.clone(), p).unwrap();
        run(&mut sim, 0.3);
        let q = sim.positions();
        let mut closest = Real::INFINITY;
        for a in 0..g.len() {
            for b in a + 1..g.len() {
                let (ia, ja, ib, jb) = (a % g.nx, a / g.nx, b % g.nx, b / g.nx);
                if ia.abs_diff(ib) <= 1 && ja.abs_diff(jb) <= 1 {
                    continue;
                }
                closest = closest.min((q.get(a) - q.get(b)).length());
            }
        }
        closest / (2.0 * r)
    };
    let with = gap(true);
    let without = gap(false);
    assert!(
        with > 0.95,
        "closest pair {with} diameters apart with self-collision"
    );
    assert!(
        without < 0.5,
        "closest pair {without} diameters apart without it"
    );
}

// ---- Strain limiting ----------------------------------------------------------------------

/// Provot strain limiting caps the stretch that suction causes around a pulled point.
#[test]
fn strain_limit_caps_the_stretch() {
    let stretch = |limit: Real| {
        let mut cfg = stuck_small_cloth();
        cfg.cloth.strain_limit = limit;
        cfg.cloth.strain_limit_iterations = 20;
        cfg.grabs = vec![wetcloth::GrabSpec::lift([10, 10], 0.02, 0.12, 0.006)];
        let mut sim = Simulation::new(cfg).unwrap();
        run(&mut sim, 0.15);
        sim.metrics().max_stretch
    };
    let free = stretch(0.0);
    let limited = stretch(0.1);
    assert!(free > 0.3, "suction over-stretches: {free}");
    assert!(limited < 0.1 + 0.02, "limited to 10 %: {limited}");
}

// ---- Determinism --------------------------------------------------------------------------

/// The same configuration gives bit-identical states with 1, 2 and 3 threads (1320 particles:
/// inside the pool, the row passes are split between threads).
#[test]
fn results_do_not_depend_on_the_thread_count() {
    let state = |threads: usize, strain_limit: Real| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut cfg = SimConfig::thesis_demo();
            cfg.cloth.resolution = [40, 33];
            cfg.cloth.strain_limit = strain_limit;
            cfg.grabs = vec![wetcloth::GrabSpec::lift([20, 16], 0.0, 0.05, 0.01)];
            let mut sim = Simulation::new(cfg).unwrap();
            run(&mut sim, 0.06);
            state_bits(&sim)
        })
    };
    // With and without strain limiting: the step measures the volume in its main pass unless a
    // correction moved particles afterwards, and both ways must agree across thread counts.
    for limit in [0.0, 0.05] {
        let one = state(1, limit);
        assert_eq!(one, state(2, limit));
        assert_eq!(one, state(3, limit));
    }
}

// ---- Every integrator --------------------------------------------------------------------

/// The closed forms every integrator must meet, each at its own step and with its own derived
/// tolerance: free fall (position Verlet with the Taylor start is exact to round-off; backward
/// Euler lags by g t dt / 2, first order) and a 20-degree slope (static friction holds at
/// mu = 0.5; at mu = 0.2 the cloth slides at g (sin 20 - mu cos 20): exact in velocity for both,
/// the tolerance is the 5 % of the target).
#[test]
fn closed_forms_hold_for_every_integrator() {
    for integrator in wetcloth::Integrator::ALL {
        let (dt, lag): (Real, Real) = match integrator {
            wetcloth::Integrator::Verlet => (1.0 / 12000.0, 0.0),
            wetcloth::Integrator::Implicit => (1.0 / 600.0, 1.0),
        };
        let name = integrator.name();
        // Free fall for 0.3 s.
        let mut cfg = bare(5);
        cfg.simulation.integrator = integrator;
        cfg.simulation.time_step = dt;
        let mut sim = Simulation::new(cfg).unwrap();
        run(&mut sim, 0.3);
        let t = sim.time();
        let expect = 1.0 - 0.5 * 9.8 * t * t - lag * 0.5 * 9.8 * t * dt;
        for &y in &sim.positions().y {
            assert!((y - expect).abs() < 1e-9, "{name}: {y} vs {expect}");
        }
        // The slope, 0.3 s.
        let theta: Real = 20f64.to_radians();
        for mu in [0.5, 0.2] {
            let mut cfg = on_a_slope(5, theta, mu);
            cfg.simulation.integrator = integrator;
            cfg.simulation.time_step = dt;
            let mut sim = Simulation::new(cfg).unwrap();
            let x0 = mean(&sim.positions().x);
            run(&mut sim, 0.3);
            let a = (9.8 * (theta.sin() - mu * theta.cos())).max(0.0);
            let v = mean(&sim.velocities().x);
            let dx = mean(&sim.positions().x) - x0;
            if a == 0.0 {
                assert!(
                    dx.abs() < 1e-12,
                    "{name}: static friction holds, moved {dx}"
                );
            } else {
                let got = v / sim.time();
                assert!((got - a).abs() < 0.05 * a, "{name}: slides at {got} vs {a}");
            }
        }
    }
}

/// Kinetic and static friction at large steps, for every integrator: a 10 x 10 cloth (10 cm,
/// 10 g, 500/125 N/m, no damping) lying on a level plane under gravity tilted 20 degrees slides
/// at `g (sin 20 - mu cos 20)` = 1.510 m/s^2 with mu = 0.2 and holds still with mu = 0.5, at
/// the implicit integrator's 1/600 s and 1/120 s (both budgets) as at Verlet's 1/12000 s.
/// Backward Euler's velocity is exact for a constant acceleration; the tolerance, 1 % of the
/// closed form, leaves room only for the first step's grip (a slide starts held).
#[test]
fn friction_holds_and_slides_at_large_steps() {
    let theta: Real = 20f64.to_radians();
    let g = 9.8;
    let runs = [
        (
            wetcloth::Integrator::Verlet,
            12000.0,
            wetcloth::SolveBudget::Converged,
        ),
        (
            wetcloth::Integrator::Implicit,
            600.0,
            wetcloth::SolveBudget::Converged,
        ),
        (
            wetcloth::Integrator::Implicit,
            120.0,
            wetcloth::SolveBudget::Converged,
        ),
        (
            wetcloth::Integrator::Implicit,
            600.0,
            wetcloth::SolveBudget::Interactive,
        ),
        (
            wetcloth::Integrator::Implicit,
            120.0,
            wetcloth::SolveBudget::Interactive,
        ),
    ];
    for (integrator, rate, budget) in runs {
        for mu in [0.2, 0.5] {
            let mut cfg = on_a_slope(10, theta, mu);
            cfg.simulation.integrator = integrator;
            cfg.simulation.implicit_budget = budget;
            cfg.simulation.time_step = 1.0 / rate;
            let mut sim = Simulation::new(cfg).unwrap();
            let x0 = mean(&sim.positions().x);
            run(&mut sim, 0.5);
            let a = (g * (theta.sin() - mu * theta.cos())).max(0.0);
            let got = mean(&sim.velocities().x) / sim.time();
            let dx = mean(&sim.positions().x) - x0;
            let what = format!("{} at 1/{rate} s ({budget:?}), mu {mu}", integrator.name());
            if a == 0.0 {
                assert!(dx.abs() < 1e-9, "{what}: static friction holds, moved {dx}");
            } else {
                assert!((got - a).abs() < 0.01 * a, "{what}: slides at {got} vs {a}");
            }
        }
    }
}

/// The implicit integrator gives bit-identical states with 1 and 2 threads.
#[test]
fn implicit_results_do_not_depend_on_the_thread_count() {
    let state = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut cfg = SimConfig::thesis_demo();
            cfg.cloth.resolution = [40, 33];
            cfg.simulation.integrator = wetcloth::Integrator::Implicit;
            cfg.simulation.time_step = 1.0 / 600.0;
            cfg.grabs = vec![wetcloth::GrabSpec::lift([20, 16], 0.0, 0.05, 0.01)];
            let mut sim = Simulation::new(cfg).unwrap();
            run(&mut sim, 0.05);
            state_bits(&sim)
        })
    };
    assert_eq!(state(1), state(2));
}

/// The implicit integrator inside `advance` (where the cell measures after it split over the
/// pool on a cloth of at least 1024 particles) gives the same bits on 1, 2 and 4 threads,
/// moving colliders included. A 40 x 40 wet cloth under the thesis' pinch, on a table that
/// slides sideways under it (keys), with trapped air, at 1/600 s for 0.1 s.
#[test]
fn implicit_results_inside_advance_do_not_depend_on_the_thread_count() {
    let state = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut cfg = SimConfig::thesis_demo();
            cfg.cloth.resolution = [40, 40];
            cfg.simulation.integrator = wetcloth::Integrator::Implicit;
            cfg.simulation.time_step = 1.0 / 600.0;
            cfg.grabs = vec![wetcloth::GrabSpec::lift([20, 20], 0.0, 0.05, 0.01)];
            let mut table = Collider::plane(Vec3::ZERO, Vec3::Y, 0.6);
            table.keys = vec![
                wetcloth::collide::Key {
                    time: 0.0,
                    offset: Vec3::ZERO,
                    rotation: Vec3::ZERO,
                },
                wetcloth::collide::Key {
                    time: 1.0,
                    offset: Vec3::new(0.05, 0.0, 0.0),
                    rotation: Vec3::ZERO,
                },
            ];
            cfg.colliders = vec![table];
            let mut sim = Simulation::new(cfg).unwrap();
            sim.advance(60).unwrap();
            state_bits(&sim)
        })
    };
    let one = state(1);
    assert_eq!(one, state(2));
    assert_eq!(one, state(4));
}
