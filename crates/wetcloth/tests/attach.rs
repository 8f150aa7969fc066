//! Attachments (`[[attach]]`): particles bound to a collider follow it exactly, and at rest they
//! carry the cloth's weight. Each test states the law and why its tolerance is what it is.

use std::sync::Arc;
use wetcloth::collide::motion::rotation_matrix;
use wetcloth::collide::{Key, Mesh, PointMotion, PointSource};
use wetcloth::control::AttachSpec;
use wetcloth::{
    AirParams, ClothParams, Collider, GrabPick, Integrator, Real, SimConfig, Simulation, Vec3,
};

fn dry(n: usize, size: Real, position: Vec3, colliders: Vec<Collider>) -> SimConfig {
    SimConfig {
        cloth: ClothParams {
            resolution: [n, n],
            size: [size, size],
            mass: 0.01,
            position,
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

/// A closed box of half sizes `h` about the origin, wound outwards.
fn box_mesh(h: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let v = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -h.x } else { h.x },
                if i & 2 == 0 { -h.y } else { h.y },
                if i & 4 == 0 { -h.z } else { h.z },
            )
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let t = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    (v, t)
}

/// The box's rigid motion: 60 degrees about y and 4 cm up over 0.5 s.
fn pose(s: Real) -> (Vec3, Real) {
    (Vec3::new(0.0, 0.04 * s, 0.0), 60.0 * s)
}

/// Hard attachments follow their point: a cloth lying on a box, its middle attached, while the
/// box turns and rises, once moved by keys and once by its points (a sequence of the same
/// rigid motion at 600 frames per second, its frames at every 20th explicit step and every
/// implicit step). The attached particles are where the box's motion takes their starting
/// points, computed here from the motion itself: to round-off (1e-9 m allows its growth over the
/// run), at every step for the keys and at every frame for the sequence (between frames a
/// sequence's points move along chords, not arcs).
#[test]
fn attached_particles_follow_their_point_on_a_moving_surface() {
    let half = Vec3::new(0.1, 0.05, 0.1);
    let (v, t) = box_mesh(half);
    let fps = 600.0;
    let frames = (0..=300)
        .map(|k| {
            let (o, a) = pose(k as Real / 300.0);
            let r = rotation_matrix(Vec3::new(0.0, a, 0.0));
            v.iter().map(|p| r * *p + o).collect()
        })
        .collect();
    let still = Mesh::new("box.obj", v.clone(), t, Vec3::ZERO, Vec3::ZERO, 1.0).unwrap();
    let deforming = still
        .clone()
        .with_motion(PointMotion {
            source: PointSource::Sequence("box_####.obj".into()),
            frame_rate: fps,
            start: 0.0,
            frames: Arc::new(frames),
        })
        .unwrap();
    let mut keyed = Collider::mesh(still, 0.6);
    keyed.keys = [0.0, 0.5]
        .iter()
        .map(|&time| {
            let (offset, a) = pose(time / 0.5);
            Key {
                time,
                offset,
                rotation: Vec3::new(0.0, a, 0.0),
            }
        })
        .collect();
    for integrator in Integrator::ALL {
        for (what, collider) in [
            ("keys", keyed.clone()),
            ("points", Collider::mesh(deforming.clone(), 0.6)),
        ] {
            let r = dry(9, 0.1, Vec3::ZERO, vec![]).cloth.particle_radius();
            let mut cfg = dry(9, 0.1, Vec3::new(0.01, half.y + r, 0.0), vec![collider]);
            cfg.simulation.integrator = integrator;
            cfg.simulation.time_step = match integrator {
                Integrator::Verlet => 1.0 / 12000.0,
                Integrator::Implicit => 1.0 / 600.0,
            };
            cfg.attachments = vec![AttachSpec {
                collider: 0,
                pick: GrabPick::Ball {
                    center: Vec3::new(0.01, half.y + r, 0.0),
                    radius: 0.03,
                },
                stiffness: None,
            }];
            let mut sim = Simulation::new(cfg).unwrap();
            let start = sim.positions().clone();
            let held: Vec<usize> = sim.grabs().iter().map(|g| g.particle).collect();
            assert!(held.len() >= 9, "{} particles attached", held.len());
            let name = format!("{} on a box moved by {what}", integrator.name());
            let mut checked = 0;
            while sim.time() < 0.6 {
                sim.step().unwrap();
                let time = sim.time();
                let on_frame = ((time * fps).round() - time * fps).abs() < 1e-6;
                if what == "points" && !on_frame {
                    continue;
                }
                let (o, a) = pose((time / 0.5).min(1.0));
                let r = rotation_matrix(Vec3::new(0.0, a, 0.0));
                for &k in &held {
                    let want = r * start.get(k) + o;
                    let got = sim.positions().get(k);
                    assert!(
                        (got - want).length() < 1e-9,
                        "{name}: particle {k} at {got}, its point at {want} (t = {time})"
                    );
                }
                checked += 1;
            }
            assert!(checked >= 300, "{name}: {checked} steps checked");
        }
    }
}

/// At rest the attachments carry the cloth's weight: a cloth hanging from one edge attached to
/// a box (and touching nothing else), damped until still (damping 5/s over 4 s leaves 2e-9 of
/// its first swing), is held by attachment forces summing to `M g` upwards, to 1e-3 (and no
/// sideways force beyond that), under both integrators; `grab_force` stays zero.
#[test]
fn attachments_carry_the_weight_of_a_hanging_cloth() {
    let g = 9.8;
    for integrator in Integrator::ALL {
        let bx = Collider::cuboid(Vec3::new(-0.11, 0.1, 0.0), Vec3::new(0.05, 0.02, 0.06), 0.6);
        let mut cfg = dry(9, 0.1, Vec3::new(0.0, 0.1, 0.0), vec![bx]);
        cfg.cloth.damping = 5.0;
        cfg.simulation.integrator = integrator;
        cfg.simulation.time_step = match integrator {
            Integrator::Verlet => 1.0 / 12000.0,
            Integrator::Implicit => 1.0 / 600.0,
        };
        cfg.attachments = vec![AttachSpec {
            collider: 0,
            pick: GrabPick::Box {
                center: Vec3::new(-0.05, 0.1, 0.0),
                half_size: Vec3::new(1e-3, 1e-3, 0.06),
            },
            stiffness: None,
        }];
        let mass = cfg.cloth.mass;
        let mut sim = Simulation::new(cfg).unwrap();
        while sim.time() < 4.0 {
            sim.step().unwrap();
        }
        let name = integrator.name();
        let forces = sim.attach_forces();
        assert_eq!(forces.len(), 1);
        assert_eq!(forces[0].0, 9, "{name}: the edge's 9 particles");
        let f = forces[0].1;
        let weight = mass * g;
        assert!(
            (f - Vec3::new(0.0, weight, 0.0)).length() < 1e-3 * weight,
            "{name}: attachments pull {f}, the cloth weighs {weight} N"
        );
        assert_eq!(sim.attach_force(), f);
        assert_eq!(sim.grab_force(), Vec3::ZERO);
        // It hangs: the far edge is below the attached one.
        let low = sim
            .positions()
            .y
            .iter()
            .fold(Real::INFINITY, |a, &b| a.min(b));
        assert!(low < 0.02, "{name}: the lowest particle at {low}");
    }
}

/// A soft attachment (`stiffness`, N/m per particle) hangs the same cloth on springs: at rest
/// their pulls sum to the weight `M g` (to 1e-3, as the hard one's), and the attached edge sags
/// below its points by Hooke's law, `M g / (n k)` on average over its `n` particles (the pulls
/// are the springs' stretches times `k`, to round-off); the cloth is the grid's triangles with
/// membrane elements (soft attachments pull a mesh cloth's particles).
#[test]
fn soft_attachments_carry_the_weight_on_their_springs() {
    let (g, k) = (9.8, 200.0);
    for integrator in Integrator::ALL {
        let bx = Collider::cuboid(Vec3::new(-0.11, 0.1, 0.0), Vec3::new(0.05, 0.02, 0.06), 0.6);
        let mut cfg = dry(9, 0.1, Vec3::new(0.0, 0.1, 0.0), vec![bx]);
        cfg.cloth.model = wetcloth::ClothModel::Membrane;
        cfg.cloth.damping = 5.0;
        cfg.simulation.integrator = integrator;
        cfg.simulation.time_step = match integrator {
            Integrator::Verlet => 1.0 / 12000.0,
            Integrator::Implicit => 1.0 / 600.0,
        };
        let edge = Vec3::new(-0.05, 0.1, 0.0);
        cfg.attachments = vec![AttachSpec {
            collider: 0,
            pick: GrabPick::Box {
                center: edge,
                half_size: Vec3::new(1e-3, 1e-3, 0.06),
            },
            stiffness: Some(k),
        }];
        let mass = cfg.cloth.mass;
        let mut sim = Simulation::new(cfg).unwrap();
        let start = sim.positions().clone();
        while sim.time() < 4.0 {
            sim.step().unwrap();
        }
        let name = integrator.name();
        let forces = sim.attach_forces();
        assert_eq!(forces[0].0, 9, "{name}: the edge's 9 particles");
        let f = forces[0].1;
        let weight = mass * g;
        assert!(
            (f - Vec3::new(0.0, weight, 0.0)).length() < 1e-3 * weight,
            "{name}: soft attachments pull {f}, the cloth weighs {weight} N"
        );
        assert!(
            sim.grabs().is_empty(),
            "{name}: soft attachments hold nothing hard"
        );
        // The edge's mean sag below its points (the box does not move).
        let x = sim.positions();
        let edge_particles: Vec<usize> = (0..x.len())
            .filter(|&i| (start.get(i).x - edge.x).abs() < 1e-3)
            .collect();
        assert_eq!(edge_particles.len(), 9);
        let sag: Real = edge_particles
            .iter()
            .map(|&i| start.get(i).y - x.get(i).y)
            .sum::<Real>()
            / 9.0;
        let want = weight / (9.0 * k);
        assert!(
            (sag - want).abs() < 1e-3 * want,
            "{name}: the edge sags {sag} m, Hooke's law says {want} m"
        );
    }
}

/// Soft attachments are refused on the spring grid and out of range, naming the key.
#[test]
fn soft_attachments_are_refused_where_they_cannot_pull() {
    let bx = Collider::cuboid(Vec3::new(-0.11, 0.1, 0.0), Vec3::new(0.05, 0.02, 0.06), 0.6);
    let mut cfg = dry(9, 0.1, Vec3::new(0.0, 0.1, 0.0), vec![bx]);
    cfg.attachments = vec![AttachSpec {
        collider: 0,
        pick: GrabPick::Vertex(0),
        stiffness: Some(100.0),
    }];
    let e = cfg.validate().unwrap_err().to_string();
    assert!(
        e.contains("attach[0].stiffness") && e.contains("mesh"),
        "{e}"
    );
    cfg.cloth.model = wetcloth::ClothModel::Membrane;
    cfg.validate().unwrap();
    cfg.attachments[0].stiffness = Some(-1.0);
    let e = cfg.validate().unwrap_err().to_string();
    assert!(e.contains("attach[0].stiffness") && e.contains("-1"), "{e}");
}

/// Softly attached particles do not collide with the collider they are attached to: a cloth
/// lying 1 mm over the ground, every particle softly attached to the ground (k = 0.05 N/m), sinks
/// through it until the springs carry its weight, the mean sag `M g / (n k)` (2.4 cm, far below
/// the ground; the membrane's forces are internal and cancel in the sum), to 1e-3. A box
/// beside it, which they are not attached to, still stops them.
#[test]
fn softly_attached_particles_pass_through_their_own_collider() {
    let (g, k) = (9.8, 0.05);
    let ground = Collider::plane(Vec3::ZERO, Vec3::Y, 0.6);
    let r = dry(9, 0.1, Vec3::ZERO, vec![]).cloth.particle_radius();
    let mut cfg = dry(9, 0.1, Vec3::new(0.0, r + 1e-3, 0.0), vec![ground]);
    cfg.cloth.model = wetcloth::ClothModel::Membrane;
    cfg.cloth.damping = 5.0;
    cfg.simulation.integrator = Integrator::Implicit;
    cfg.simulation.time_step = 1.0 / 600.0;
    cfg.attachments = vec![AttachSpec {
        collider: 0,
        pick: GrabPick::Box {
            center: Vec3::ZERO,
            half_size: Vec3::splat(1.0),
        },
        stiffness: Some(k),
    }];
    let mass = cfg.cloth.mass;
    let mut sim = Simulation::new(cfg.clone()).unwrap();
    let start = sim.positions().clone();
    while sim.time() < 4.0 {
        sim.step().unwrap();
    }
    let x = sim.positions();
    let n = x.len();
    let sag: Real = (0..n).map(|i| start.get(i).y - x.get(i).y).sum::<Real>() / n as Real;
    let want = mass * g / (n as Real * k);
    assert!(
        (sag - want).abs() < 1e-3 * want,
        "the cloth sags {sag} m, its springs say {want} m"
    );
    assert!(
        x.y.iter().all(|&y| y < 0.0),
        "every particle through the ground"
    );
    // Attached to a box below the ground instead, the ground stops them.
    cfg.colliders.push(Collider::cuboid(
        Vec3::new(0.0, -0.5, 0.0),
        Vec3::splat(0.1),
        0.6,
    ));
    cfg.attachments[0].collider = 1;
    let mut sim = Simulation::new(cfg).unwrap();
    while sim.time() < 1.0 {
        sim.step().unwrap();
    }
    let low = sim
        .positions()
        .y
        .iter()
        .fold(Real::INFINITY, |a, &b| a.min(b));
    assert!(low > r - 1e-6, "the ground holds them: lowest at {low} m");
}
