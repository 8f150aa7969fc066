//! Cloths of any shape (`[cloth] mesh`) against the closed forms the grid passes, against the
//! built-in grid itself, and a regular mesh against an irregular one of the same cloth.

#[path = "common/grid_mesh.rs"]
mod grid_mesh;

use grid_mesh::{grid_mesh, source};
use wetcloth::{
    AirParams, ClothMeshSource, ClothParams, Collider, GrabKey, GrabPick, GrabSpec, Real,
    SimConfig, Simulation, Vec3,
};

/// A deterministic irregular triangulation of the same square: the grid's interior points
/// moved by up to `jitter` spacings (a fixed pseudo-random sequence), each cell split along
/// the diagonal the Delaunay criterion picks (the one whose opposite angles sum to less).
fn irregular_mesh(n: usize, size: Real, jitter: Real) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (mut v, _) = grid_mesh(n, size);
    let h = size / (n - 1) as Real;
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as Real / (1u64 << 53) as Real * 2.0 - 1.0
    };
    for j in 1..n - 1 {
        for i in 1..n - 1 {
            let k = j * n + i;
            v[k].x += jitter * h * rnd();
            v[k].z += jitter * h * rnd();
        }
    }
    let angle = |a: Vec3, b: Vec3, c: Vec3| (b - a).angle_between(c - a);
    let mut t = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (j * n + i) as u32;
            let (b, c, d) = (a + 1, a + 1 + n as u32, a + n as u32);
            let p = |k: u32| v[k as usize];
            // Diagonal a-c: opposite angles at b and d; diagonal b-d: at a and c.
            let ac = angle(p(b), p(a), p(c)) + angle(p(d), p(a), p(c));
            let bd = angle(p(a), p(b), p(d)) + angle(p(c), p(b), p(d));
            if ac <= bd {
                t.push([a, c, b]);
                t.push([a, d, c]);
            } else {
                t.push([a, d, b]);
                t.push([b, d, c]);
            }
        }
    }
    (v, t)
}

/// The smallest angle of any triangle, degrees.
fn smallest_angle(v: &[Vec3], t: &[[u32; 3]]) -> Real {
    let mut least = Real::INFINITY;
    for tri in t {
        for e in 0..3 {
            let [a, b, c] = [tri[e], tri[(e + 1) % 3], tri[(e + 2) % 3]].map(|k| v[k as usize]);
            least = least.min((b - a).angle_between(c - a).to_degrees());
        }
    }
    least
}

/// A cloth of `mesh` with no air, no colliders, no grabs.
fn bare(mesh: ClothMeshSource, position: Vec3) -> SimConfig {
    SimConfig {
        cloth: ClothParams {
            mesh: Some(mesh),
            mass: 0.01,
            position,
            self_collision: false,
            ..Default::default()
        },
        air: AirParams {
            enabled: false,
            ..Default::default()
        },
        colliders: Vec::new(),
        ..Default::default()
    }
}

fn run(sim: &mut Simulation, seconds: Real) {
    let steps = (seconds / sim.time_step()).round() as u64;
    for _ in 0..steps {
        sim.step().expect("stable step");
    }
}

/// Free fall: every particle of a mesh cloth follows `y0 - g t^2 / 2` (Verlet with the Taylor
/// start is exact for a constant force), to round-off as on the grid.
#[test]
fn a_mesh_cloth_falls_freely() {
    let (v, t) = irregular_mesh(6, 0.1, 0.2);
    let mut sim = Simulation::new(bare(source(v, t), Vec3::new(0.0, 1.0, 0.0))).unwrap();
    run(&mut sim, 0.5);
    let t = sim.time();
    let exact = 1.0 - 0.5 * 9.8 * t * t;
    let n = sim.step_count() as Real;
    for &y in &sim.positions().y {
        assert!((y - exact).abs() < 2e-16 * n * n, "{y} vs {exact}");
    }
}

/// Lumped masses: a mesh cloth's particles weigh their share of the cloth by area, and the
/// whole weighs `mass`.
#[test]
fn masses_are_lumped_by_area() {
    let (v, t) = irregular_mesh(8, 0.2, 0.25);
    let sim = Simulation::new(bare(source(v, t), Vec3::ZERO)).unwrap();
    let m = sim.model();
    assert!((m.total_mass() - 0.01).abs() < 1e-15);
    let areas = m.areas.as_ref().unwrap();
    for k in 0..m.len() {
        let share = 0.01 * areas[k] / 0.04;
        assert!((m.mass(k) - share).abs() < 1e-15 * share.max(1e-9));
    }
}

/// Friction on a slope: a mesh cloth on a plane under gravity tilted by 20 degrees holds at
/// mu = 0.5 and slides at g (sin 20 - mu cos 20) at mu = 0.2 (the contact removes mu times the
/// normal push each step, exactly, as on the grid).
#[test]
fn a_mesh_cloth_holds_or_slides_on_a_slope() {
    let theta: Real = 20f64.to_radians();
    for mu in [0.5, 0.2] {
        let (v, t) = irregular_mesh(6, 0.1, 0.2);
        let mut cfg = bare(source(v, t), Vec3::ZERO);
        cfg.simulation.gravity = Vec3::new(9.8 * theta.sin(), -9.8 * theta.cos(), 0.0);
        cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, mu)];
        cfg.cloth.position.y = cfg.cloth.particle_radius();
        let mut sim = Simulation::new(cfg).unwrap();
        let x0: Real = sim.positions().x.iter().sum::<Real>() / sim.particle_count() as Real;
        run(&mut sim, 0.5);
        let t = sim.time();
        let x1: Real = sim.positions().x.iter().sum::<Real>() / sim.particle_count() as Real;
        let a = (9.8 * (theta.sin() - mu * theta.cos())).max(0.0);
        let expect = 0.5 * a * t * t;
        assert!(
            (x1 - x0 - expect).abs() < 1e-9,
            "mu = {mu}: {} vs {expect}",
            x1 - x0
        );
    }
}

/// A vertical sheet `size` wide and tall in the xy plane, pinned along its top edge (a `within`
/// box grab with a still key), hanging under gravity until it rests; returns how far its bottom
/// edge's mean height fell from rest, m.
fn hanging_elongation(v: Vec<Vec3>, t: Vec<[u32; 3]>, size: Real) -> Real {
    // The xz square stood up: z becomes -y, so the top edge (z = -size / 2) is at y = size / 2.
    let v: Vec<Vec3> = v.into_iter().map(|p| Vec3::new(p.x, -p.z, 0.0)).collect();
    let bottom: Vec<usize> = (0..v.len())
        .filter(|&k| (v[k].y + 0.5 * size).abs() < 1e-12)
        .collect();
    let mut cfg = bare(source(v, t), Vec3::ZERO);
    cfg.cloth.structural_stiffness = 20.0;
    cfg.cloth.shear_stiffness = 10.0;
    cfg.cloth.damping = 30.0;
    cfg.simulation.time_step = 2e-4;
    cfg.grabs = vec![GrabSpec {
        particle: [0, 0],
        pick: Some(GrabPick::Box {
            center: Vec3::new(0.0, 0.5 * size, 0.0),
            half_size: Vec3::new(size, 1e-9, 1.0),
        }),
        keys: vec![GrabKey {
            time: 0.0,
            offset: Vec3::ZERO,
        }],
    }];
    let mut sim = Simulation::new(cfg).unwrap();
    let before: Real = bottom.iter().map(|&k| sim.positions().y[k]).sum::<Real>();
    run(&mut sim, 1.5);
    let after: Real = bottom.iter().map(|&k| sim.positions().y[k]).sum::<Real>();
    (before - after) / bottom.len() as Real
}

/// A hanging sheet: a regular and an irregular mesh of the same cloth (smallest angle at least
/// 25 degrees) stretch alike, within 5 %, and near the membrane's closed form: a strip of
/// weight per area `rho g` hanging from its top edge stretches by `rho g L^2 / (2 E)`,
/// `E = C11 - C12^2 / C11` = 8/3 `k_h` for the isotropic `k_s = 2 k_h` (within 15 %: the
/// pinned top edge cannot narrow, which stiffens the sheet near it).
#[test]
fn regular_and_irregular_meshes_hang_alike() {
    let (size, n) = (0.1, 15);
    let (v, t) = grid_mesh(n, size);
    let regular = hanging_elongation(v, t, size);
    let (v, t) = irregular_mesh(n, size, 0.2);
    let angle = smallest_angle(&v, &t);
    assert!(angle >= 25.0, "smallest angle {angle} degrees");
    let irregular = hanging_elongation(v, t, size);
    let (rho, e) = (0.01 / (size * size), 8.0 / 3.0 * 10.0);
    let closed = rho * 9.8 * size * size / (2.0 * e);
    eprintln!(
        "hanging: regular {regular:.6e} m, irregular {irregular:.6e} m, closed form {closed:.6e} m"
    );
    assert!(
        (irregular / regular - 1.0).abs() < 0.05,
        "regular {regular}, irregular {irregular}"
    );
    assert!(
        (regular / closed - 1.0).abs() < 0.15,
        "regular {regular}, closed form {closed}"
    );
}

/// The built-in grid and a mesh of the same particles and triangles drape alike: a cloth
/// dropped onto a sphere comes to rest with the same mean height, lowest point and mean reach
/// from the axis, each within half a grid spacing. The two are not the same discretisation
/// (the mesh has one diagonal per cell, lumped masses by area, and springs across its edges
/// that also resist folding), so particle by particle their folds differ; the drape's shape
/// agrees to the grid's resolution.
#[test]
fn a_mesh_of_the_grid_drapes_like_the_grid() {
    let (n, size) = (16, 0.3);
    let sphere = Collider::sphere(Vec3::new(0.0, -0.1, 0.0), 0.1, 0.3);
    let mut grid_cfg = SimConfig {
        cloth: ClothParams {
            resolution: [n, n],
            size: [size, size],
            mass: 0.02,
            position: Vec3::new(0.0, 0.01, 0.0),
            self_collision: false,
            damping: 5.0,
            ..Default::default()
        },
        air: AirParams {
            enabled: false,
            ..Default::default()
        },
        colliders: vec![sphere],
        ..Default::default()
    };
    grid_cfg.simulation.time_step = 1e-4;
    let mut mesh_cfg = grid_cfg.clone();
    let (v, t) = grid_mesh(n, size);
    mesh_cfg.cloth.mesh = Some(source(v, t));
    let mut a = Simulation::new(grid_cfg).unwrap();
    let mut b = Simulation::new(mesh_cfg).unwrap();
    run(&mut a, 1.0);
    run(&mut b, 1.0);
    let h = size / (n - 1) as Real;
    let stats = |s: &Simulation| {
        let p = s.positions();
        let n = p.len() as Real;
        let mean_y = p.y.iter().sum::<Real>() / n;
        let low = p.y.iter().copied().fold(Real::INFINITY, Real::min);
        let reach = (0..p.len()).map(|k| p.x[k].hypot(p.z[k])).sum::<Real>() / n;
        [mean_y, low, reach]
    };
    let (sa, sb) = (stats(&a), stats(&b));
    eprintln!("drape (mean height, lowest, mean reach), m: grid {sa:?}, mesh {sb:?}");
    for (what, x, y) in [
        ("mean height", sa[0], sb[0]),
        ("lowest point", sa[1], sb[1]),
        ("mean reach", sa[2], sb[2]),
    ] {
        assert!(
            (x - y).abs() < 0.5 * h,
            "{what}: grid {x}, mesh {y}, spacing {h}"
        );
    }
}

/// The thesis' bubble over a mesh: a flat mesh cloth at height `h` above the table encloses
/// exactly its area times `h` (eq. 3.10 per triangle is exact for a flat cloth).
#[test]
fn a_flat_mesh_encloses_area_times_height() {
    let (v, t) = irregular_mesh(9, 0.2, 0.25);
    let h = 0.01;
    let mut cfg = bare(source(v, t), Vec3::new(0.0, 0.0, 0.0));
    cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.5)];
    cfg.cloth.position.y = h + cfg.cloth.particle_radius();
    let sim = Simulation::new(cfg).unwrap();
    let v = sim.air_volume();
    assert!((v - 0.04 * h).abs() < 1e-15, "{v}");
}

/// Boyle's law on a mesh: a cloth with trapped air, carried up 1 cm and back to 5 mm by a hand
/// holding every particle (`within` a box), keeps `P V` constant, and ends with `V = V0 + A dy`
/// exactly (each prism of eq. 3.10 grows by its area times the lift).
#[test]
fn a_mesh_cloth_obeys_boyle_as_a_piston() {
    let (v, t) = irregular_mesh(9, 0.3, 0.25);
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.mesh = Some(source(v, t));
    cfg.cloth.self_collision = false;
    cfg.simulation.integrator = wetcloth::Integrator::Verlet;
    cfg.air.trapped_air = 200e-6;
    cfg.cloth.position = Vec3::new(0.0, cfg.cloth.particle_radius() + 200e-6 / 0.09, 0.0);
    cfg.grabs = vec![GrabSpec {
        particle: [0, 0],
        pick: Some(GrabPick::Box {
            center: Vec3::ZERO,
            half_size: Vec3::splat(1.0),
        }),
        keys: vec![
            GrabKey {
                time: 0.0,
                offset: Vec3::ZERO,
            },
            GrabKey {
                time: 0.1,
                offset: Vec3::new(0.0, 0.01, 0.0),
            },
            GrabKey {
                time: 0.15,
                offset: Vec3::new(0.0, 0.005, 0.0),
            },
        ],
    }];
    let k = cfg.air.atmospheric_pressure * cfg.air.trapped_air;
    let mut sim = Simulation::new(cfg).unwrap();
    assert_eq!(sim.grab_forces(), vec![(81, sim.grab_forces()[0].1)]);
    for _ in 0..20 {
        run(&mut sim, 0.01);
        let m = sim.metrics();
        assert!(
            (m.air_pressure * m.air_volume - k).abs() < 1e-12 * k,
            "{m:?}"
        );
    }
    let v = sim.air_volume();
    assert!((v - (200e-6 + 0.09 * 0.005)).abs() < 1e-12, "{v}");
}

/// The pressure force on a mesh is `(P_b - P_a) S_k N_k` with each particle's lumped area
/// `S_k`: on a flat, weightless, springless mesh cloth with too little air under it, one step
/// moves every particle down by `(P_b - P_a) S_k dt^2 / (2 m_k)`; masses lumped by area make
/// `S_k / m_k` the cloth's area over its mass, the same for every particle.
#[test]
fn the_pressure_force_on_a_mesh_uses_the_lumped_area() {
    let (v, t) = irregular_mesh(7, 0.3, 0.25);
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.mesh = Some(source(v, t));
    cfg.cloth.self_collision = false;
    cfg.cloth.structural_stiffness = 0.0;
    cfg.cloth.shear_stiffness = 0.0;
    cfg.cloth.damping = 0.0;
    cfg.simulation.integrator = wetcloth::Integrator::Verlet;
    cfg.simulation.gravity = Vec3::ZERO;
    cfg.air.pressure_solve = wetcloth::PressureSolve::Explicit;
    cfg.air.trapped_air = 1e-4;
    cfg.grabs.clear();
    let lift = 0.01;
    cfg.cloth.position = Vec3::new(0.0, cfg.cloth.particle_radius() + lift, 0.0);
    let mut sim = Simulation::new(cfg.clone()).unwrap();
    let dp = sim.air_pressure() - cfg.air.atmospheric_pressure;
    assert!(dp < -1000.0, "a vacuum: {dp} Pa");
    let y0 = sim.positions().y.clone();
    sim.step().unwrap();
    let dt = sim.time_step();
    let expect = dp * 0.09 / cfg.cloth.mass * dt * dt / 2.0;
    for (k, (&a, &b)) in y0.iter().zip(&sim.positions().y).enumerate() {
        assert!(
            ((b - a) - expect).abs() < 1e-9 * expect.abs(),
            "particle {k}: {} vs {expect}",
            b - a
        );
    }
}

/// A tent: a wet cloth lying on the table with the thesis' vacuum under it, its middle (every
/// particle within 4 cm of the centre) lifted 2 cm by a hand, holds the same air volume on a
/// regular and an irregular mesh of the same cloth, within 2 %.
#[test]
fn regular_and_irregular_meshes_hold_the_same_tent() {
    let tent = |(v, t): (Vec<Vec3>, Vec<[u32; 3]>)| {
        let mut cfg = SimConfig::thesis_demo();
        cfg.cloth.mesh = Some(source(v, t));
        cfg.cloth.self_collision = false;
        cfg.simulation.integrator = wetcloth::Integrator::Verlet;
        cfg.simulation.time_step = 1.0 / 20000.0;
        cfg.cloth.position = Vec3::new(0.0, cfg.cloth.particle_radius(), 0.0);
        cfg.air.trapped_air = 0.0;
        cfg.grabs = vec![GrabSpec {
            particle: [0, 0],
            pick: Some(GrabPick::Ball {
                center: Vec3::ZERO,
                radius: 0.04,
            }),
            keys: vec![
                GrabKey {
                    time: 0.0,
                    offset: Vec3::ZERO,
                },
                GrabKey {
                    time: 0.3,
                    offset: Vec3::new(0.0, 0.02, 0.0),
                },
            ],
        }];
        let mut sim = Simulation::new(cfg).unwrap();
        run(&mut sim, 0.4);
        sim.air_volume()
    };
    let regular = tent(grid_mesh(21, 0.3));
    let irregular = tent(irregular_mesh(21, 0.3, 0.2));
    eprintln!("tent volume: regular {regular:.6e} m^3, irregular {irregular:.6e} m^3");
    assert!(regular > 1e-6, "a tent holds air: {regular}");
    assert!(
        (irregular / regular - 1.0).abs() < 0.02,
        "regular {regular}, irregular {irregular}"
    );
}

// ---- The implicit integrator on a mesh -----------------------------------------------------

fn implicit(mut cfg: SimConfig, dt: Real) -> SimConfig {
    cfg.simulation.integrator = wetcloth::Integrator::Implicit;
    cfg.simulation.time_step = dt;
    cfg
}

/// Backward Euler's free fall is exact in closed form: `v_n = -g n dt`, `x_n = x_0 - g dt^2
/// n (n + 1) / 2`; a mesh cloth follows it at 1/60 s to round-off (the springs stay at rest).
#[test]
fn a_mesh_cloth_falls_as_backward_euler_says() {
    let (v, t) = irregular_mesh(6, 0.1, 0.2);
    let dt = 1.0 / 60.0;
    let mut sim =
        Simulation::new(implicit(bare(source(v, t), Vec3::new(0.0, 1.0, 0.0)), dt)).unwrap();
    for _ in 0..30 {
        sim.step().unwrap();
    }
    let n = sim.step_count() as Real;
    let exact = 1.0 - 9.8 * dt * dt * n * (n + 1.0) / 2.0;
    for &y in &sim.positions().y {
        assert!((y - exact).abs() < 1e-9, "{y} vs {exact}");
    }
}

/// The hanging sheet of [`regular_and_irregular_meshes_hang_alike`] comes to the same rest
/// under the implicit integrator at 1/100 s as under Verlet (a static equilibrium does not
/// depend on the integrator), within 1 %.
#[test]
fn the_implicit_mesh_step_hangs_like_verlet() {
    let size = 0.1;
    let (v, t) = irregular_mesh(11, size, 0.2);
    let verlet = hanging_elongation(v.clone(), t.clone(), size);
    let hang = |dt: Real| {
        let vv: Vec<Vec3> = v.iter().map(|p| Vec3::new(p.x, -p.z, 0.0)).collect();
        let bottom: Vec<usize> = (0..vv.len())
            .filter(|&k| (vv[k].y + 0.5 * size).abs() < 1e-12)
            .collect();
        let mut cfg = bare(source(vv, t.clone()), Vec3::ZERO);
        cfg.cloth.structural_stiffness = 20.0;
        cfg.cloth.shear_stiffness = 10.0;
        cfg.cloth.damping = 30.0;
        cfg.grabs = vec![GrabSpec {
            particle: [0, 0],
            pick: Some(GrabPick::Box {
                center: Vec3::new(0.0, 0.5 * size, 0.0),
                half_size: Vec3::new(size, 1e-9, 1.0),
            }),
            keys: vec![GrabKey {
                time: 0.0,
                offset: Vec3::ZERO,
            }],
        }];
        let mut sim = Simulation::new(implicit(cfg, dt)).unwrap();
        let before: Real = bottom.iter().map(|&k| sim.positions().y[k]).sum::<Real>();
        run(&mut sim, 1.5);
        let after: Real = bottom.iter().map(|&k| sim.positions().y[k]).sum::<Real>();
        (
            (before - after) / bottom.len() as Real,
            sim.solver_iterations(),
        )
    };
    let (imp, iterations) = hang(0.01);
    eprintln!(
        "hanging: verlet {verlet:.6e} m, implicit at 1/100 s {imp:.6e} m ({iterations} CG iterations)"
    );
    assert!(
        (imp / verlet - 1.0).abs() < 0.01,
        "verlet {verlet}, implicit {imp}"
    );
}

/// Boyle's law with the implicit step on a mesh: the piston of
/// [`a_mesh_cloth_obeys_boyle_as_a_piston`] at 1/600 s keeps `P V` to the end-of-step solve's
/// accuracy (the pressure is solved on the volume the step predicts; every particle is held,
/// so the prediction is exact).
#[test]
fn the_implicit_mesh_step_obeys_boyle() {
    let (v, t) = irregular_mesh(9, 0.3, 0.25);
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.mesh = Some(source(v, t));
    cfg.cloth.self_collision = false;
    cfg.air.trapped_air = 200e-6;
    cfg.cloth.position = Vec3::new(0.0, cfg.cloth.particle_radius() + 200e-6 / 0.09, 0.0);
    cfg.grabs = vec![GrabSpec {
        particle: [0, 0],
        pick: Some(GrabPick::Box {
            center: Vec3::ZERO,
            half_size: Vec3::splat(1.0),
        }),
        keys: vec![
            GrabKey {
                time: 0.0,
                offset: Vec3::ZERO,
            },
            GrabKey {
                time: 0.1,
                offset: Vec3::new(0.0, 0.01, 0.0),
            },
        ],
    }];
    let k = cfg.air.atmospheric_pressure * cfg.air.trapped_air;
    let mut sim = Simulation::new(implicit(cfg, 1.0 / 600.0)).unwrap();
    for _ in 0..10 {
        run(&mut sim, 0.01);
        let m = sim.metrics();
        assert!(
            (m.air_pressure * m.air_volume - k).abs() < 1e-9 * k,
            "{m:?}"
        );
    }
}

/// A wet mesh cloth lying on the table with a small bubble of trapped air under it, at the
/// implicit integrator's large step (1/60 s): the air is a stiff spring the step solves with
/// the cloth, so it stays at rest, its pressure near atmospheric, its kinetic energy tiny.
#[test]
fn the_implicit_mesh_step_holds_a_bubble_at_large_steps() {
    let (v, t) = irregular_mesh(15, 0.3, 0.2);
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.mesh = Some(source(v, t));
    cfg.cloth.self_collision = false;
    cfg.grabs.clear();
    cfg.air.trapped_air = 20e-6;
    cfg.cloth.position = Vec3::new(0.0, cfg.cloth.particle_radius() + 20e-6 / 0.09, 0.0);
    let mut sim = Simulation::new(implicit(cfg.clone(), 1.0 / 60.0)).unwrap();
    run(&mut sim, 1.0);
    let m = sim.metrics();
    eprintln!("bubble at 1/60 s: {m:?}");
    assert!(m.kinetic_energy < 1e-6, "{m:?}");
    assert!(
        (m.air_pressure - cfg.air.atmospheric_pressure).abs() < 0.01 * cfg.air.atmospheric_pressure,
        "{m:?}"
    );
}

/// Friction on a slope with the implicit step on a mesh, at 1/600 s and 1/120 s: it holds at
/// mu = 0.5 and slides at mu = 0.2 with `a = g (sin 20 - mu cos 20)`; backward Euler's
/// displacement after `n` steps of a constant acceleration is `a dt^2 n (n + 1) / 2`, which the
/// contact's friction (mu times the normal push of each step's move) keeps to round-off.
#[test]
fn the_implicit_mesh_step_holds_or_slides_on_a_slope() {
    let theta: Real = 20f64.to_radians();
    for dt in [1.0 / 600.0, 1.0 / 120.0] {
        for mu in [0.5, 0.2] {
            let (v, t) = irregular_mesh(6, 0.1, 0.2);
            let mut cfg = bare(source(v, t), Vec3::ZERO);
            cfg.simulation.gravity = Vec3::new(9.8 * theta.sin(), -9.8 * theta.cos(), 0.0);
            cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, mu)];
            cfg.cloth.position.y = cfg.cloth.particle_radius();
            let mut sim = Simulation::new(implicit(cfg, dt)).unwrap();
            let mean =
                |s: &Simulation| s.positions().x.iter().sum::<Real>() / s.particle_count() as Real;
            let x0 = mean(&sim);
            run(&mut sim, 0.5);
            let n = sim.step_count() as Real;
            let a = (9.8 * (theta.sin() - mu * theta.cos())).max(0.0);
            let expect = a * dt * dt * n * (n + 1.0) / 2.0;
            let moved = mean(&sim) - x0;
            assert!(
                (moved - expect).abs() < 1e-3 * expect.max(1e-6),
                "dt = {dt}, mu = {mu}: {moved} vs {expect}"
            );
        }
    }
}

// ---- The pockets model on a mesh ----------------------------------------------------------

/// A wet cloth dropped from 2 mm onto the table under the pockets model (its border seals
/// first and traps the air under it), its middle (every particle within 2 cm of the centre)
/// then lifted 1 cm: one sealed pocket, its air stretched over a larger volume (a partial
/// vacuum), which obeys Boyle's law `P V = P_a N`. A mesh of the grid's particles and the built-in grid
/// hold the same pocket: its volume within 10 %, its pressure within that and the difference of
/// the air they trapped (the grid's cells are quads, the mesh's triangles, and the air each
/// traps as its border seals differs with the fall: 8 % at 1/6000 s), under both integrators.
#[test]
fn a_mesh_cloth_holds_a_pocket_like_the_grid() {
    for integrator in [wetcloth::Integrator::Verlet, wetcloth::Integrator::Implicit] {
        let (n, size) = (21, 0.3);
        let mut cfg = SimConfig::thesis_demo();
        cfg.air.model = wetcloth::AirModelKind::Pockets;
        cfg.air.trapped_air = 0.0;
        cfg.cloth.resolution = [n, n];
        cfg.cloth.self_collision = false;
        cfg.cloth.position = Vec3::new(0.0, cfg.cloth.particle_radius() + 0.002, 0.0);
        cfg.simulation.integrator = integrator;
        if integrator == wetcloth::Integrator::Implicit {
            cfg.simulation.time_step = 1.0 / 600.0;
        } else {
            cfg.simulation.time_step = 1.0 / 6000.0;
        }
        cfg.grabs = vec![GrabSpec {
            particle: [0, 0],
            pick: Some(GrabPick::Ball {
                center: Vec3::new(0.0, cfg.cloth.position.y, 0.0),
                radius: 0.02,
            }),
            keys: vec![
                GrabKey {
                    time: 0.0,
                    offset: Vec3::ZERO,
                },
                GrabKey {
                    time: 0.2,
                    offset: Vec3::new(0.0, 0.01, 0.0),
                },
            ],
        }];
        let mut mesh_cfg = cfg.clone();
        let (v, t) = grid_mesh(n, size);
        mesh_cfg.cloth.mesh = Some(source(v, t));
        let mut results = Vec::new();
        for c in [cfg, mesh_cfg] {
            let mut sim = Simulation::new(c.clone()).unwrap();
            run(&mut sim, 0.3);
            let m = sim.metrics();
            let p = sim.air().pockets().unwrap();
            assert_eq!(p.pockets.len(), 1, "{integrator:?}: {m:?}");
            let q = &p.pockets[0];
            let k = c.air.atmospheric_pressure * q.amount;
            assert!(
                k > 0.0 && (q.pressure * q.effective_volume() - k).abs() < 1e-9 * k,
                "Boyle: {q:?}"
            );
            assert!(q.pressure < c.air.atmospheric_pressure, "a vacuum: {q:?}");
            results.push((q.pressure, q.volume, q.amount));
        }
        let [(pg, vg, ng), (pm, vm, nm)] = [results[0], results[1]];
        eprintln!(
            "{integrator:?}: grid {pg:.1} Pa {vg:.3e} m^3 ({ng:.3e} m^3 of air), \
             mesh {pm:.1} Pa {vm:.3e} m^3 ({nm:.3e})"
        );
        // `P = P_a N / V`: the pressures differ by the volumes' 10 % and by as much as the air
        // the two seals trapped does (the triangles seal other particles than the quads: at
        // 1/600 s the mesh traps 18 % less).
        let trapped = ((nm - ng) / ng).abs();
        assert!(
            ((pm - pg) / pg).abs() < 0.1 + trapped,
            "pressure: grid {pg}, mesh {pm}; air {ng}, {nm}"
        );
        assert!(((vm - vg) / vg).abs() < 0.1, "volume: grid {vg}, mesh {vm}");
    }
}

/// Self-collision on a mesh of two separate pieces (several pieces in one file are allowed):
/// two squares, one laid 12 mm above the other and offset by half a spacing, dropped onto the
/// table. With self-collision the upper one comes to rest on the lower's surface, one
/// thickness (a particle diameter `d`) above its triangles: not nested between its particles,
/// `sqrt(d^2 - o^2)` above them (`o` the pieces' horizontal offset), as the spheres alone
/// would let it sink; the closest pair of particles of different pieces at least `d` apart.
/// Without, it falls through it onto the table (the pieces' mean heights within a fifth of a
/// diameter).
#[test]
fn self_collision_keeps_two_mesh_pieces_apart() {
    let stack = |self_collision: bool| {
        let (n, size) = (12, 0.1);
        let h = size / (n - 1) as Real;
        let (v, t) = grid_mesh(n, size);
        let m = v.len() as u32;
        let mut vertices = v.clone();
        vertices.extend(v.iter().map(|p| *p + Vec3::new(0.5 * h, 0.012, 0.5 * h)));
        let mut faces = t.clone();
        faces.extend(t.iter().map(|f| f.map(|k| k + m)));
        let mut cfg = bare(source(vertices, faces), Vec3::ZERO);
        cfg.cloth.self_collision = self_collision;
        cfg.cloth.damping = 5.0;
        // Particles 8.5 mm across, wider than the pieces' 6.4 mm horizontal offset: a piece
        // cannot slip between the other's particles.
        cfg.cloth.thickness = 0.008;
        cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.5)];
        cfg.cloth.position.y = cfg.cloth.particle_radius();
        let mut sim = Simulation::new(cfg).unwrap();
        let r = sim.particle_radius();
        run(&mut sim, 0.3);
        let q = sim.positions();
        let m = m as usize;
        let mut closest = Real::INFINITY;
        for a in 0..m {
            for b in m..2 * m {
                closest = closest.min((q.get(a) - q.get(b)).length());
            }
        }
        let lower: Real = q.y[..m].iter().sum::<Real>() / m as Real;
        let upper: Real = q.y[m..].iter().sum::<Real>() / m as Real;
        (closest / (2.0 * r), (upper - lower) / (2.0 * r))
    };
    let (with, with_lift) = stack(true);
    let (_, without_lift) = stack(false);
    eprintln!("with: closest {with} diameters, lift {with_lift}; without: lift {without_lift}");
    assert!(
        with > 0.99,
        "closest pair {with} diameters apart with self-collision"
    );
    assert!(
        (with_lift - 1.0).abs() < 0.02,
        "the upper piece rests a thickness over the lower: {with_lift} diameters"
    );
    assert!(
        without_lift.abs() < 0.2,
        "without, it falls through: {without_lift}"
    );
}
