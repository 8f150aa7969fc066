//! Mesh colliders and moving colliders against the analytic shapes and closed forms. Each test
//! states the law, the set-up and why its tolerance is what it is.

#[path = "common/icosphere.rs"]
mod icosphere;

use icosphere::icosphere;
use wetcloth::collide::{Key, Mesh};
use wetcloth::{AirParams, ClothParams, Collider, Real, SimConfig, Simulation, Vec3};

/// A small dry cloth (no air, no damping, no self-collision) at `position`.
fn dry(n: usize, size: Real, position: Vec3, colliders: Vec<Collider>) -> SimConfig {
    SimConfig {
        cloth: ClothParams {
            resolution: [n, n],
            size: [size, size],
            mass: 0.01,
            position,
            damping: 0.0,
            self_collision: false,
            ..Default::default()
        },
        air: AirParams {
            enabled: false,
            ..Default::default()
        },
        colliders,
        ..Default::default()
    }
}

fn steps(sim: &mut Simulation, n: usize) {
    for _ in 0..n {
        sim.step().expect("stable step");
    }
}

/// Two triangles spanning the square [-h, h]^2 of the plane y = 0, wound to face +y.
fn two_triangles(h: Real) -> Mesh {
    let v = vec![
        Vec3::new(-h, 0.0, -h),
        Vec3::new(h, 0.0, -h),
        Vec3::new(h, 0.0, h),
        Vec3::new(-h, 0.0, h),
    ];
    Mesh::new(
        "two.obj",
        v,
        vec![[0, 2, 1], [0, 3, 2]],
        Vec3::ZERO,
        Vec3::ZERO,
        1.0,
    )
    .unwrap()
}

/// The plane a two-triangle mesh spans: a dry cloth dropped onto either, sliding under a tilted
/// gravity, ends in the same place. Both answer the same projection and friction (eq. 3.4-3.5)
/// from the same distance, computed once by a dot product and once through the mesh's closest
/// point, which differ by round-off (1e-16 relative); 1e-9 leaves room for its growth over the
/// run.
#[test]
fn two_triangle_mesh_behaves_like_its_plane() {
    let run = |c: Collider| {
        let mut cfg = dry(9, 0.1, Vec3::new(0.0, 0.02, 0.0), vec![c]);
        // Tilted gravity: the cloth lands, then slides, so friction acts (mu = 0.3 < tan).
        cfg.simulation.gravity = Vec3::new(3.0, -9.81, 1.0);
        let mut sim = Simulation::new(cfg).unwrap();
        steps(&mut sim, 2400);
        (sim.positions().clone(), sim.state().contact.clone())
    };
    let (plane, plane_contact) = run(Collider::plane(Vec3::ZERO, Vec3::Y, 0.3));
    let (mesh, mesh_contact) = run(Collider::mesh(two_triangles(5.0), 0.3));
    assert!(
        plane_contact.iter().all(|&c| c),
        "the cloth lies on the plane"
    );
    assert_eq!(plane_contact, mesh_contact);
    let scale = plane
        .x
        .iter()
        .chain(&plane.z)
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.05, "the cloth slid: {scale}");
    for k in 0..plane.len() {
        let d = (plane.get(k) - mesh.get(k)).length();
        assert!(d <= 1e-9 * scale, "particle {k}: {d} m apart");
    }
}

/// The same with the implicit integrator at a large step (1/60 s): a cloth at rest 2 mm above
/// the sheet falls 4.5 mm in its first step, so a particle is driven through the surface inside
/// the solve (not seen coming at the step's start, where it is at rest) and the open mesh must
/// stop it on the side it came from, as the plane does, rather than measure it from the far
/// side and let it through. Both runs take the same contact decisions from distances equal to
/// round-off, so they agree to far less than the 1 um allowed (the solver's tolerance in
/// velocity, 1e-6 m/s relative, over a handful of steps' displacements).
#[test]
fn implicit_open_mesh_stops_a_falling_cloth_as_its_plane_does() {
    let run = |c: Collider| {
        let mut cfg = dry(9, 0.1, Vec3::new(0.0, 0.002, 0.0), vec![c]);
        cfg.simulation.integrator = wetcloth::Integrator::Implicit;
        cfg.simulation.time_step = 1.0 / 60.0;
        cfg.simulation.gravity = Vec3::new(3.0, -9.81, 1.0);
        let mut sim = Simulation::new(cfg).unwrap();
        steps(&mut sim, 60);
        sim.positions().clone()
    };
    let plane = run(Collider::plane(Vec3::ZERO, Vec3::Y, 0.3));
    let mesh = run(Collider::mesh(two_triangles(5.0), 0.3));
    for k in 0..plane.len() {
        assert!(
            mesh.y[k] > 0.0,
            "particle {k} went through the sheet: {}",
            mesh.get(k)
        );
        let d = (plane.get(k) - mesh.get(k)).length();
        assert!(d <= 1e-6, "particle {k}: {d} m apart");
    }
}

/// A fine icosphere against the sphere it is inscribed in. The polyhedron lies inside the
/// sphere and contains the ball of radius `R - h`, `h` the largest gap between a face and the
/// sphere (its sagitta, at the face centres): so for any point outside, the mesh's distance
/// exceeds the sphere's by between 0 and `h`. A cloth dropped on the mesh rests with every
/// touching particle pushed out to its radius `r` from the mesh (friction then moves it along
/// the tangent plane, which on a convex surface only takes it farther, by at most its slide:
/// micrometres), so between `r - h` and `r` (plus that slide) from the sphere.
#[test]
fn fine_icosphere_behaves_like_the_sphere_within_its_sagitta() {
    let radius = 0.05;
    let (v, f) = icosphere(radius, 4);
    // The sagitta: the largest gap between a face's plane and the sphere.
    let h = f
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| v[i as usize]);
            let n = (b - a).cross(c - a).normalize();
            radius - n.dot(a).abs()
        })
        .fold(0.0, Real::max);
    assert!(h > 0.0 && h < 1e-4, "sagitta {h}");
    let mesh = Mesh::new("ico.obj", v, f, Vec3::ZERO, Vec3::ZERO, 1.0).unwrap();
    assert!(mesh.is_closed());
    let sphere = Collider::sphere(Vec3::ZERO, radius, 0.6);
    let mesh = Collider::mesh(mesh, 0.6);
    // Distances: a spiral of points from inside to outside.
    for i in 0..2000 {
        let s = i as Real / 2000.0;
        let dir = Vec3::new((s * 97.0).cos(), 2.0 * s - 1.0, (s * 97.0).sin()).normalize();
        let p = dir * radius * (0.5 + s);
        let (ds, _) = sphere.distance(p);
        let (dm, nm) = mesh.distance(p);
        assert!(
            dm - ds >= -1e-12 && dm - ds <= h + 1e-12,
            "{p}: {dm} vs {ds}"
        );
        assert!((nm.length() - 1.0).abs() < 1e-12);
    }
    // A cloth dropped on each.
    let drop = |c: Collider| {
        let cfg = dry(13, 0.12, Vec3::new(0.0, radius + 0.01, 0.0), vec![c]);
        let mut sim = Simulation::new(cfg).unwrap();
        steps(&mut sim, 1800);
        sim
    };
    let on_mesh = drop(mesh);
    let r = on_mesh.model().radius;
    let mut touching = 0;
    for k in 0..on_mesh.positions().len() {
        if on_mesh.state().contact[k] {
            touching += 1;
            let (d, _) = sphere.distance(on_mesh.positions().get(k));
            assert!(d >= r - h - 1e-12 && d <= r + 1e-6, "particle {k} at {d}");
        }
    }
    assert!(touching > 10, "{touching} particles touch");
    // And the centre particle sits on top of each within the sagitta.
    let on_sphere = drop(sphere.clone());
    let centre = 6 * 13 + 6;
    let dy = on_mesh.positions().get(centre).y - on_sphere.positions().get(centre).y;
    assert!(dy.abs() <= h + 1e-9, "centre heights differ by {dy}");
}

/// Plate keys at `times` following `offset(t)`.
fn keys(times: impl Iterator<Item = Real>, offset: impl Fn(Real) -> Vec3) -> Vec<Key> {
    times
        .map(|t| Key {
            time: t,
            offset: offset(t),
            rotation: Vec3::ZERO,
        })
        .collect()
}

/// A dry cloth resting on a plate that accelerates downward at `a > g` leaves it at once and
/// falls freely, so after `T` the gap between them is `(a - g) T^2 / 2`. The plate's keys lie
/// on `-a t^2 / 2` at every step, so it is exactly there at the step times; Verlet is exact
/// for the cloth's constant acceleration, and a flat cloth in free fall keeps its springs at
/// rest: the gap is the closed form to round-off.
#[test]
fn dry_cloth_separates_from_a_plate_falling_faster_than_gravity() {
    let g = -SimConfig::default().simulation.gravity.y;
    let a = 2.0 * g;
    let dt = 1.0 / 12000.0;
    let mut plate = Collider::plane(Vec3::ZERO, Vec3::Y, 0.6);
    plate.keys = keys((0..=1200).map(|i| i as Real * dt), |t| {
        Vec3::new(0.0, -a * t * t / 2.0, 0.0)
    });
    let probe = dry(8, 0.1, Vec3::ZERO, vec![]);
    let r = probe.cloth.particle_radius();
    let cfg = dry(8, 0.1, Vec3::new(0.0, r, 0.0), vec![plate]);
    let mut sim = Simulation::new(cfg).unwrap();
    let n = 1200;
    steps(&mut sim, n);
    let t = n as Real * dt;
    let plate_y = -a * t * t / 2.0;
    let expected = (a - g) * t * t / 2.0;
    for k in 0..sim.positions().len() {
        let gap = sim.positions().get(k).y - r - plate_y;
        assert!(
            (gap - expected).abs() < 1e-9,
            "particle {k}: gap {gap} vs {expected}"
        );
    }
}

/// A cloth on a plate that starts sliding sideways at `v` rides along: friction in the plate's
/// frame (mu = 1) stops the slip within `v / (mu g)` (5 ms here), after which the cloth moves
/// with the plate. Over 0.3 s it has moved `v T` less the slip, at most `v^2 / (2 mu g)` = 0.13
/// mm.
#[test]
fn cloth_on_a_moving_plate_rides_along() {
    let v = 0.05;
    let mut plate = Collider::plane(Vec3::ZERO, Vec3::Y, 1.0);
    plate.keys = keys([0.0, 10.0].into_iter(), |t| Vec3::new(v * t, 0.0, 0.0));
    let probe = dry(8, 0.1, Vec3::ZERO, vec![]);
    let r = probe.cloth.particle_radius();
    let cfg = dry(8, 0.1, Vec3::new(0.0, r, 0.0), vec![plate]);
    let mut sim = Simulation::new(cfg).unwrap();
    let start = sim.positions().clone();
    let n = 3600;
    steps(&mut sim, n);
    let t = n as Real * sim.time_step();
    let g = -SimConfig::default().simulation.gravity.y;
    let slip = v * v / (2.0 * 1.0 * g);
    let vel = sim.velocities();
    for k in 0..start.len() {
        let moved = sim.positions().get(k) - start.get(k);
        // The first step is Verlet's half step (the Taylor start): the plate's grip on it is
        // half, which lets the cloth lag by up to one more step's move, v dt.
        let lag = slip + v * sim.time_step();
        assert!(
            moved.x <= v * t + 1e-9 && moved.x >= v * t - lag,
            "{k}: {moved}"
        );
        assert!(moved.y.abs() < 1e-6 && moved.z.abs() < 1e-9, "{k}: {moved}");
        assert!((vel.get(k).x - v).abs() < 1e-6 * v, "{k}: {}", vel.get(k));
        assert!(sim.state().contact[k]);
    }
    assert!(sim.control().collider_work() > 0.0);
}

/// Every integrator carries a cloth on a moving collider: a plate sliding sideways at `v`
/// (friction 1) carries the cloth at its speed once the slip has stopped (within `v / (mu g)`,
/// 5 ms), so after 0.3 s every particle has moved `v T` less at most the slip `v^2 / (2 mu g)`
/// (0.13 mm) and one step's move (each integrator's first step grips it late); and a box lifted
/// 10 cm in 0.5 s (0.2 m/s) carries the cloth resting on it up to its top. The two integrators
/// agree to their own difference (the slip, 0.13 mm; the lift to within a tenth of a
/// millimetre), and the plate's work counts in the energy audit of both.
#[test]
fn moving_colliders_carry_the_cloth_under_every_integrator() {
    let g = -SimConfig::default().simulation.gravity.y;
    let probe = dry(8, 0.1, Vec3::ZERO, vec![]);
    let r = probe.cloth.particle_radius();
    let mut rides = Vec::new();
    let mut lifts = Vec::new();
    for integrator in wetcloth::Integrator::ALL {
        let dt: Real = match integrator {
            wetcloth::Integrator::Verlet => 1.0 / 12000.0,
            wetcloth::Integrator::Implicit => 1.0 / 600.0,
        };
        let name = integrator.name();
        // The sliding plate.
        let v = 0.05;
        let mut plate = Collider::plane(Vec3::ZERO, Vec3::Y, 1.0);
        plate.keys = keys([0.0, 10.0].into_iter(), |t| Vec3::new(v * t, 0.0, 0.0));
        let mut cfg = dry(8, 0.1, Vec3::new(0.0, r, 0.0), vec![plate]);
        cfg.simulation.integrator = integrator;
        cfg.simulation.time_step = dt;
        let mut sim = Simulation::new(cfg).unwrap();
        let start = sim.positions().clone();
        let n = (0.3 / dt).round() as usize;
        steps(&mut sim, n);
        let t = sim.time();
        let lag = v * v / (2.0 * g) + v * dt;
        let vel = sim.velocities();
        let mut mean = 0.0;
        for k in 0..start.len() {
            let moved = sim.positions().get(k) - start.get(k);
            assert!(
                moved.x <= v * t + 1e-9 && moved.x >= v * t - lag,
                "{name}, particle {k}: moved {moved}, plate {}",
                v * t
            );
            assert!(
                moved.y.abs() < 1e-6 && moved.z.abs() < 1e-9,
                "{name}, {k}: {moved}"
            );
            assert!(
                (vel.get(k).x - v).abs() < 1e-6 * v,
                "{name}, {k}: {}",
                vel.get(k)
            );
            assert!(sim.state().contact[k], "{name}, {k} touches");
            mean += moved.x / start.len() as Real;
        }
        assert!(
            sim.control().collider_work() > 0.0,
            "{name}: the plate worked"
        );
        rides.push(mean);
        // The lifted box: 10 cm in 0.5 s, then held; the cloth (8 cm) rests on its 20 cm top.
        let mut table =
            Collider::cuboid(Vec3::new(0.0, -0.05, 0.0), Vec3::new(0.1, 0.05, 0.1), 0.6);
        table.keys = keys([0.0, 0.5].into_iter(), |t| Vec3::new(0.0, 0.2 * t, 0.0));
        let mut cfg = dry(8, 0.08, Vec3::new(0.0, r, 0.0), vec![table]);
        cfg.simulation.integrator = integrator;
        cfg.simulation.time_step = dt;
        let mut sim = Simulation::new(cfg).unwrap();
        steps(&mut sim, (0.7 / dt).round() as usize);
        let top = 0.1 + r;
        for (k, y) in sim.positions().y.iter().enumerate() {
            assert!(
                (y - top).abs() < 1e-4,
                "{name}, particle {k} at {y}, the top at {top}"
            );
        }
        lifts.push(sim.positions().y.iter().sum::<Real>() / sim.positions().len() as Real);
    }
    assert!((rides[0] - rides[1]).abs() < v_slip(g), "{rides:?}");
    assert!((lifts[0] - lifts[1]).abs() < 1e-4, "{lifts:?}");
}

/// The slip of a cloth a plate starts sliding at 0.05 m/s under friction 1 (m).
fn v_slip(g: Real) -> Real {
    0.05 * 0.05 / (2.0 * g)
}

/// A plate carrying a cloth up at 1 m/s for 0.5 s gives it potential and kinetic energy the
/// hands never gave: the energy audit counts the plate's work, so the run is not stopped as a
/// blow-up (before, any energy gain past a millijoule stopped it).
#[test]
fn moving_collider_work_is_not_taken_for_a_blow_up() {
    let mut plate = Collider::plane(Vec3::ZERO, Vec3::Y, 0.6);
    plate.keys = keys([0.0, 0.5].into_iter(), |t| Vec3::new(0.0, t, 0.0));
    let probe = dry(8, 0.1, Vec3::ZERO, vec![]);
    let r = probe.cloth.particle_radius();
    let mut cfg = dry(8, 0.3, Vec3::new(0.0, r, 0.0), vec![plate]);
    cfg.cloth.mass = 1.0;
    let mut sim = Simulation::new(cfg).unwrap();
    steps(&mut sim, 6000);
    // Lifted 0.5 m: 1 kg gained 4.9 J of height, which the plate's work covers. The plate's
    // sudden start at 1 m/s is an inelastic impact: it does m v^2 = 1 J of work, twice the
    // kinetic energy it gives, and twice that again in Verlet's half first step, whose force
    // acts over half the time.
    let y = sim.positions().get(0).y;
    assert!((y - (0.5 + r)).abs() < 1e-3, "{y}");
    let g = -SimConfig::default().simulation.gravity.y;
    let work = sim.control().collider_work();
    assert!(
        work > 0.5 * g + 0.5 && work < 0.5 * g + 2.0 + 1e-3,
        "{work}"
    );
}

/// No particle is ever inside a closed mesh, thinner than a step's move included: a cloth
/// thrown at 15 m/s onto a 2 mm slab (a closed box mesh) moves 1.25 mm per step, more than
/// half the slab, and a pressing gravity of 20 g keeps it pushing. The inside test is the box's
/// own, independent of the mesh.
#[test]
fn no_particle_ends_inside_a_thin_closed_mesh() {
    let (hx, hy, hz) = (0.2, 0.001, 0.2);
    let mut v = Vec::new();
    for i in 0..8 {
        v.push(Vec3::new(
            if i & 1 == 0 { -hx } else { hx },
            if i & 2 == 0 { -hy } else { hy },
            if i & 4 == 0 { -hz } else { hz },
        ));
    }
    // Wound inwards on purpose: a closed mesh is turned outwards whatever its file's winding.
    let f = vec![
        [0, 1, 3],
        [0, 3, 2],
        [4, 6, 7],
        [4, 7, 5],
        [0, 4, 5],
        [0, 5, 1],
        [2, 3, 7],
        [2, 7, 6],
        [0, 2, 6],
        [0, 6, 4],
        [1, 5, 7],
        [1, 7, 3],
    ];
    let slab = Mesh::new("slab.obj", v, f, Vec3::ZERO, Vec3::ZERO, 1.0).unwrap();
    assert!(slab.is_closed());
    let mut cfg = dry(
        10,
        0.1,
        Vec3::new(0.0, 0.01, 0.0),
        vec![Collider::mesh(slab, 0.3)],
    );
    cfg.simulation.gravity = Vec3::new(0.0, -200.0, 0.0);
    let mut sim = Simulation::new(cfg).unwrap();
    let n = sim.positions().len();
    let start = sim.positions().clone();
    let fall = wetcloth::Soa::from_vec3(&vec![Vec3::new(0.0, -15.0, 0.0); n]);
    sim.set_positions_and_velocities(start, &fall).unwrap();
    let r = sim.model().radius;
    for _ in 0..600 {
        sim.step().unwrap();
        for k in 0..n {
            let p = sim.positions().get(k);
            let inside = p.x.abs() < hx && p.y.abs() < hy + r - 1e-9 && p.z.abs() < hz;
            assert!(!inside, "particle {k} inside the slab at {p}");
        }
    }
    // And they rest on top.
    assert!((sim.positions().get(0).y - (hy + r)).abs() < 1e-6);
}

/// Bad meshes are refused with what is wrong.
#[test]
fn bad_meshes_are_refused() {
    use wetcloth::collide::MeshError;
    let at = |v: Vec<Vec3>, f: Vec<[u32; 3]>| {
        Mesh::new("m.obj", v, f, Vec3::ZERO, Vec3::ZERO, 1.0).unwrap_err()
    };
    let tri = vec![Vec3::ZERO, Vec3::X, Vec3::Z];
    assert_eq!(at(tri.clone(), vec![]), MeshError::NoFaces);
    let mut nan = tri.clone();
    nan[1].y = Real::NAN;
    assert!(matches!(
        at(nan, vec![[0, 1, 2]]),
        MeshError::NonFiniteVertex { index: 2, .. }
    ));
    assert_eq!(
        at(tri.clone(), vec![[0, 1, 3]]),
        MeshError::IndexOutOfRange {
            triangle: 1,
            index: 4,
            count: 3
        }
    );
    // A scale of 0 is refused by name.
    let m = Mesh::new("m.obj", tri, vec![[0, 1, 2]], Vec3::ZERO, Vec3::ZERO, 0.0).unwrap();
    let e = Collider::mesh(m, 0.5).validate(3).unwrap_err();
    assert!(e.to_string().contains("collider[3].scale"), "{e}");
}

/// An open mesh is two-sided: a particle rests on whichever side it comes from.
#[test]
fn open_mesh_stops_particles_on_both_sides() {
    let sheet = Collider::mesh(two_triangles(1.0), 0.0);
    let r = 0.001;
    for side in [1.0, -1.0] {
        let from = Vec3::new(0.1, side * 0.01, 0.2);
        // A move straight through the sheet, past it by far more than the radius.
        let to = Vec3::new(0.1, -side * 0.05, 0.2);
        let (x, hit) =
            wetcloth::collide::contact::resolve(std::slice::from_ref(&sheet), from, to, r);
        assert!(hit);
        assert!((x.y - side * r).abs() < 1e-15, "{side}: {x}");
    }
}

/// The world contact query of an open mesh where keys have placed it (raised 1 m, turned 90
/// degrees about x: the sheet is the plane z = 0, its faces towards +-z): a move through the
/// sheet ends at minus its depth beyond it, with the normal towards the side it came from,
/// from either side, where the plain distance (an open mesh has no inside) is the positive
/// depth. A move that stays on one side answers the plain distance.
#[test]
fn placed_open_mesh_contact_is_measured_from_the_side_the_move_came_from() {
    let mut sheet = Collider::mesh(two_triangles(1.0), 0.0);
    sheet.keys = vec![
        Key {
            time: 0.0,
            offset: Vec3::new(0.0, 1.0, 0.0),
            rotation: Vec3::new(90.0, 0.0, 0.0),
        },
        Key {
            time: 1.0,
            offset: Vec3::new(0.0, 1.0, 0.0),
            rotation: Vec3::new(90.0, 0.0, 0.0),
        },
    ];
    let placed = sheet.at(0.5);
    for side in [1.0, -1.0] {
        let from = Vec3::new(0.1, 1.2, side * 0.01);
        let to = Vec3::new(0.1, 1.2, -side * 0.003);
        let (d, n) = placed.contact(from, to, 0.001).expect("within reach");
        assert!((d + 0.003).abs() < 1e-12, "{side}: {d}");
        assert!((n - Vec3::Z * side).length() < 1e-12, "{side}: {n}");
        let (plain, _) = placed.distance(to);
        assert!((plain - 0.003).abs() < 1e-12, "{side}: {plain}");
        // Staying on its side: the plain distance.
        let near = Vec3::new(0.1, 1.2, side * 0.0005);
        let (d, n) = placed.contact(from, near, 0.001).expect("within reach");
        assert!((d - 0.0005).abs() < 1e-12 && (n - Vec3::Z * side).length() < 1e-12);
    }
}

/// Keys move and turn any shape about its own centre, linearly between keys: a box turned 45
/// degrees about y presents an edge along x at `h sqrt 2` from its centre, and halfway (22.5
/// degrees, half the offset) a face whose normal is turned by 22.5 degrees.
#[test]
fn keys_move_and_turn_a_box_about_its_centre() {
    let mut b = Collider::cuboid(Vec3::new(1.0, 0.0, 0.0), Vec3::splat(0.5), 0.5);
    b.keys = vec![
        Key {
            time: 0.0,
            offset: Vec3::ZERO,
            rotation: Vec3::ZERO,
        },
        Key {
            time: 1.0,
            offset: Vec3::new(0.0, 1.0, 0.0),
            rotation: Vec3::new(0.0, 45.0, 0.0),
        },
    ];
    let end = b.at(1.0);
    let (d, n) = end.distance(Vec3::new(2.0, 1.0, 0.0));
    assert!((d - (1.0 - 0.5 * 2f64.sqrt())).abs() < 1e-12, "{d}");
    assert!((n - Vec3::X).length() < 1e-12, "{n}");
    // Held after the last key.
    assert_eq!(b.at(5.0).distance(Vec3::new(2.0, 1.0, 0.0)), (d, n));
    let half = b.at(0.5);
    let turn = 22.5f64.to_radians();
    let face = Vec3::new(turn.cos(), 0.0, -turn.sin());
    let (d, n) = half.distance(Vec3::new(1.0, 0.5, 0.0) + face * 0.7);
    assert!(
        (d - 0.2).abs() < 1e-12 && (n - face).length() < 1e-12,
        "{d} {n}"
    );
    // What a renderer draws moves with it: every vertex of the drawn box lies on the surface.
    let wetcloth::Surface::Mesh(m) = half.surface() else {
        panic!("a box draws as a mesh")
    };
    for p in &m.positions {
        assert!(half.distance(*p).0.abs() < 1e-12);
    }
}

/// A wet cloth (the pockets air model) lying on the plate of
/// `dry_cloth_separates_from_a_plate_falling_faster_than_gravity`: as the plate drops away, the
/// gap under the sealed cloth is a vacuum, and the atmosphere (about 1e5 N per m^2 against the
/// cloth's 1 N per m^2 of weight) presses the cloth after the plate: it stays on it, where the
/// dry cloth separates by `(a - g) T^2 / 2` (3.9 mm here).
#[test]
fn wet_cloth_stays_on_a_plate_falling_faster_than_gravity() {
    let g = -SimConfig::default().simulation.gravity.y;
    let a = 2.0 * g;
    let dt = 1.0 / 12000.0;
    let plate_at = |t: Real| -a * t * t / 2.0;
    let mut plate = Collider::plane(Vec3::ZERO, Vec3::Y, 0.6);
    plate.keys = keys((0..=1200).map(|i| i as Real * dt), |t| {
        Vec3::new(0.0, plate_at(t), 0.0)
    });
    let probe = dry(8, 0.1, Vec3::ZERO, vec![]);
    let r = probe.cloth.particle_radius();
    let mut cfg = dry(8, 0.1, Vec3::new(0.0, r, 0.0), vec![plate]);
    cfg.air.enabled = true;
    cfg.air.model = wetcloth::AirModelKind::Pockets;
    let mut sim = Simulation::new(cfg).unwrap();
    steps(&mut sim, 1200);
    let t = 1200.0 * dt;
    let separation = (a - g) * t * t / 2.0;
    let grid = sim.grid().clone();
    for k in 0..sim.positions().len() {
        let (i, j) = (k % grid.nx, k / grid.nx);
        if i == 0 || j == 0 || i + 1 == grid.nx || j + 1 == grid.nx {
            continue; // the border is open to the room
        }
        let gap = sim.positions().get(k).y - r - plate_at(t);
        assert!(
            gap.abs() < 0.05 * separation,
            "particle {k}: {gap} m off the plate, a dry cloth {separation} m"
        );
    }
}

/// A two-triangle mesh behaves like the plane it spans on a suction scene too: a wet cloth
/// (pockets model) lying on it with a seeded pocket, lifted at its middle. Against the plane
/// the pockets use eq. 3.10 in the fused pass; against the mesh, the frustum under each cloth
/// triangle, which on a plane is the same prism: the outputs agree to round-off.
#[test]
fn two_triangle_mesh_behaves_like_its_plane_under_suction() {
    let run = |c: Collider| {
        let mut cfg = dry(15, 0.14, Vec3::ZERO, vec![c]);
        cfg.cloth.position.y = cfg.cloth.particle_radius();
        cfg.cloth.damping = 2.0;
        cfg.air.enabled = true;
        cfg.air.model = wetcloth::AirModelKind::Pockets;
        cfg.air.pockets = vec![wetcloth::PocketSeed {
            center: [0.03, 0.0],
            radius: 0.02,
            amount: 2e-6,
            point: None,
        }];
        cfg.grabs = vec![wetcloth::GrabSpec::lift([7, 7], 0.01, 0.1, 0.004)];
        let mut sim = Simulation::new(cfg).unwrap();
        steps(&mut sim, 1200);
        (
            sim.positions().clone(),
            sim.pocket_reports(),
            sim.grab_force(),
        )
    };
    let (plane, plane_pockets, plane_force) = run(Collider::plane(Vec3::ZERO, Vec3::Y, 0.6));
    let (mesh, mesh_pockets, mesh_force) = run(Collider::mesh(two_triangles(5.0), 0.6));
    assert!(
        plane_pockets.len() >= 2,
        "the seed and the vacuum: {plane_pockets:?}"
    );
    assert!(
        plane_force.y > 1.0,
        "suction holds the cloth: {plane_force} N"
    );
    assert_eq!(plane_pockets.len(), mesh_pockets.len());
    for (p, q) in plane_pockets.iter().zip(&mesh_pockets) {
        assert_eq!(p.id, q.id);
        assert!(
            (p.volume - q.volume).abs() <= 1e-9 * p.volume,
            "{p:?} {q:?}"
        );
        assert!(
            (p.pressure - q.pressure).abs() <= 1e-9 * p.pressure,
            "{p:?} {q:?}"
        );
    }
    assert!((plane_force - mesh_force).length() <= 1e-9 * plane_force.length());
    for k in 0..plane.len() {
        let d = (plane.get(k) - mesh.get(k)).length();
        assert!(d <= 1e-9, "particle {k}: {d} m apart");
    }
}
