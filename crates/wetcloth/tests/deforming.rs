//! Deforming mesh colliders (a mesh whose points move frame by frame) against rigid keys and
//! closed forms. Each test states the law, the set-up and why its tolerance is what it is.

#[path = "common/icosphere.rs"]
mod icosphere;

use std::sync::Arc;
use wetcloth::collide::motion::rotation_matrix;
use wetcloth::collide::{Key, Mesh, PointMotion, PointSource};
use wetcloth::{
    AirParams, ClothMeshSource, ClothParams, Collider, Integrator, Real, SimConfig, Simulation,
    Vec3,
};

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

/// A small dry cloth (no air, no self-collision) at `position`: the grid, or the same grid as
/// a mesh cloth.
fn dry(n: usize, size: Real, position: Vec3, colliders: Vec<Collider>, mesh: bool) -> SimConfig {
    let mut cloth = ClothParams {
        resolution: [n, n],
        size: [size, size],
        mass: 0.01,
        position,
        self_collision: false,
        ..Default::default()
    };
    if mesh {
        let h = size / (n - 1) as Real;
        let mut v = Vec::new();
        for j in 0..n {
            for i in 0..n {
                v.push(Vec3::new(
                    i as Real * h - 0.5 * size,
                    0.0,
                    j as Real * h - 0.5 * size,
                ));
            }
        }
        let mut faces = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = (j * n + i) as u32;
                let (b, c, d) = (a + 1, a + 1 + n as u32, a + n as u32);
                faces.push(vec![a, c, b]);
                faces.push(vec![a, d, c]);
            }
        }
        cloth.mesh = Some(ClothMeshSource {
            file: "grid.obj".into(),
            vertices: Arc::new(v),
            faces: Arc::new(faces),
            uvs: Arc::new(Vec::new()),
            face_uvs: Arc::new(Vec::new()),
            rotation: Vec3::ZERO,
            scale: 1.0,
            flip_normals: false,
        });
    }
    SimConfig {
        cloth,
        air: AirParams {
            enabled: false,
            ..Default::default()
        },
        colliders,
        ..Default::default()
    }
}

fn motion(frames: Vec<Vec<Vec3>>, frame_rate: Real) -> PointMotion {
    PointMotion {
        source: PointSource::Sequence("frame_####.obj".into()),
        frame_rate,
        start: 0.0,
        frames: Arc::new(frames),
    }
}

/// A cloth resting on a box that turns on a turntable (40 degrees about y in 1 s) while it
/// slides (5 cm along x), once moved by keys and once by its points (an OBJ sequence of the
/// same motion at 600 frames per second), under both integrators and on the grid and a mesh
/// cloth. The contact's frame is the nearest triangle's, which for a rigid motion is the body's
/// own, so where a step starts and ends on frames (the implicit step of 1/600 s) the two agree
/// to round-off (measured: 2e-14 m). Between frames the sequence's points move linearly where
/// the keys turn: the chord of a frame's 0.067 degrees lies within `r theta^2 / 8` = 2.4e-8 m of
/// the arc at the box's corners (r = 0.14 m), which the explicit steps inside a frame see; so
/// the cloth rides the same to within 1e-6 m. (The implicit step turns a pose's chord error
/// into a velocity error of the surface, `e / dt`: at 240 frames per second, its steps falling
/// between frames, the rides differed by 1e-5 m.)
#[test]
fn a_rigid_point_motion_carries_the_cloth_as_keys_do() {
    let half = Vec3::new(0.1, 0.05, 0.1);
    let (v, t) = box_mesh(half);
    let (turn, slide, duration, fps) = (40.0, 0.05, 1.0, 600.0);
    let keys = vec![
        Key {
            time: 0.0,
            offset: Vec3::ZERO,
            rotation: Vec3::ZERO,
        },
        Key {
            time: duration,
            offset: Vec3::new(slide, 0.0, 0.0),
            rotation: Vec3::new(0.0, turn, 0.0),
        },
    ];
    let frames: Vec<Vec<Vec3>> = (0..=(duration * fps) as usize)
        .map(|k| {
            let s = k as Real / fps / duration;
            let r = rotation_matrix(Vec3::new(0.0, turn * s, 0.0));
            v.iter()
                .map(|p| r * *p + Vec3::new(slide * s, 0.0, 0.0))
                .collect()
        })
        .collect();
    let still = Mesh::new("box.obj", v.clone(), t.clone(), Vec3::ZERO, Vec3::ZERO, 1.0).unwrap();
    let deforming = still.clone().with_motion(motion(frames, fps)).unwrap();
    for integrator in Integrator::ALL {
        for mesh_cloth in [false, true] {
            let dt = match integrator {
                Integrator::Verlet => 1.0 / 12000.0,
                Integrator::Implicit => 1.0 / 600.0,
            };
            let run = |c: Collider| {
                let r = dry(6, 0.1, Vec3::ZERO, vec![], false)
                    .cloth
                    .particle_radius();
                let mut cfg = dry(
                    6,
                    0.1,
                    Vec3::new(0.02, half.y + r + 1e-4, 0.01),
                    vec![c],
                    mesh_cloth,
                );
                cfg.simulation.integrator = integrator;
                cfg.simulation.time_step = dt;
                let mut sim = Simulation::new(cfg).unwrap();
                for _ in 0..(1.2 / dt).round() as usize {
                    sim.step().unwrap();
                }
                (sim.positions().clone(), sim.control().collider_work())
            };
            let mut keyed = Collider::mesh(still.clone(), 1.0);
            keyed.keys = keys.clone();
            let (a, work_a) = run(keyed);
            let (b, work_b) = run(Collider::mesh(deforming.clone(), 1.0));
            let name = format!(
                "{} on a {}",
                integrator.name(),
                if mesh_cloth { "mesh" } else { "grid" }
            );
            let worst = (0..a.len())
                .map(|k| (a.get(k) - b.get(k)).length())
                .fold(0.0, Real::max);
            assert!(worst < 1e-6, "{name}: the two rides differ by {worst} m");
            // The cloth rode: its centre turned with the box (the particle over the axis'
            // offset moved by the slide and the turn).
            let centre = (0..a.len()).map(|k| a.get(k)).sum::<Vec3>() / a.len() as Real;
            let expect = Vec3::new(slide, 0.0, 0.0)
                + rotation_matrix(Vec3::new(0.0, turn, 0.0)) * Vec3::new(0.02, 0.0, 0.01);
            assert!(
                (centre.x - expect.x).abs() < 1e-3 && (centre.z - expect.z).abs() < 1e-3,
                "{name}: the cloth's centre at {centre}, the box carried it to {expect}"
            );
            assert!(
                (work_a - work_b).abs() <= 1e-3 * work_a.abs().max(1e-12),
                "{name}: work {work_a} against {work_b}"
            );
        }
    }
}

/// A sphere whose radius grows from 10 to 14 cm over 1 s (an icosphere's points scaled frame
/// by frame, 30 frames per second) under a cloth draped over it: the cloth is pushed out with
/// the surface. At the end every particle is outside the grown sphere (no farther inside than
/// the icosphere's flat faces lie within the sphere, its sagitta, 1.3 mm at level 3 and 14 cm),
/// and the particle over the pole rests on the pole, `R + r` above the centre, to the same
/// sagitta (the pole is a vertex, but the cloth's particles around it lie on faces).
#[test]
fn a_growing_sphere_pushes_a_draped_cloth_out() {
    let (v, t) = icosphere::icosphere(1.0, 3);
    let (r0, r1, fps) = (0.10, 0.14, 30.0);
    let frames = (0..=30)
        .map(|k| {
            let radius = r0 + (r1 - r0) * k as Real / 30.0;
            v.iter().map(|p| *p * radius).collect()
        })
        .collect();
    let centre = Vec3::ZERO;
    let sphere = Mesh::new("ball.obj", v.clone(), t, centre, Vec3::ZERO, 1.0)
        .unwrap()
        .with_motion(motion(frames, fps))
        .unwrap();
    let sagitta = r1 * (1.0 - (1.0 - 0.5 * 0.08 * 0.08 as Real).sqrt()) + 1.3e-3;
    for integrator in Integrator::ALL {
        let dt = match integrator {
            Integrator::Verlet => 1.0 / 12000.0,
            Integrator::Implicit => 1.0 / 600.0,
        };
        let probe = dry(15, 0.3, Vec3::ZERO, vec![], false);
        let r = probe.cloth.particle_radius();
        let mut cfg = dry(
            15,
            0.3,
            Vec3::new(0.0, r0 + r + 2e-3, 0.0),
            vec![Collider::mesh(sphere.clone(), 0.5)],
            false,
        );
        cfg.cloth.damping = 2.0;
        cfg.simulation.integrator = integrator;
        cfg.simulation.time_step = dt;
        let mut sim = Simulation::new(cfg).unwrap();
        for _ in 0..(1.3 / dt).round() as usize {
            sim.step().unwrap();
        }
        let x = sim.positions();
        let name = integrator.name();
        let mut deepest: Real = Real::INFINITY;
        for k in 0..x.len() {
            deepest = deepest.min((x.get(k) - centre).length() - r1);
        }
        assert!(
            deepest > -sagitta,
            "{name}: a particle is {deepest} m from the grown sphere's surface"
        );
        // The middle particle (7, 7) lies over the pole.
        let top = x.get(7 * 15 + 7);
        assert!(
            (top.y - (r1 + r)).abs() < sagitta,
            "{name}: the top at {}, the grown pole at {}",
            top.y,
            r1 + r
        );
    }
}

/// A body moved by points whose lowest corner sinks 6 mm into the floor in one frame (a planted
/// foot of a bobbing walk) is reported with how deep and when; standing on the floor, or with
/// the floor lowered 1 cm, it is not (cloth caught between the two would have no room).
#[test]
fn a_mesh_moved_into_a_still_plane_is_reported() {
    let half = Vec3::new(0.1, 0.05, 0.1);
    let (v, t) = box_mesh(half);
    // Frames at 10 per second: the box's bottom at the floor, 6 mm under it, at it again.
    let sink = [0.0, 0.003, 0.006, 0.002, 0.0];
    let frames: Vec<Vec<Vec3>> = sink
        .iter()
        .map(|&d| {
            v.iter()
                .map(|p| *p + Vec3::new(0.0, half.y - d, 0.0))
                .collect()
        })
        .collect();
    let body = Mesh::new(
        "body.obj",
        v.clone(),
        t.clone(),
        Vec3::ZERO,
        Vec3::ZERO,
        1.0,
    )
    .unwrap()
    .with_motion(motion(frames, 10.0))
    .unwrap();
    let floor = |y: Real| Collider::plane(Vec3::new(0.0, y, 0.0), Vec3::Y, 0.6);
    let overlaps = |colliders: &[Collider]| wetcloth::collide::plane_overlaps(colliders, 0.0008);
    let found = overlaps(&[floor(0.0), Collider::mesh(body.clone(), 0.6)]);
    assert_eq!(found.len(), 1, "{found:?}");
    let o = found[0];
    assert_eq!((o.mesh, o.plane), (1, 0));
    assert!((o.depth - 0.006).abs() < 1e-12, "depth {}", o.depth);
    assert!((o.time - 0.2).abs() < 1e-12, "time {}", o.time);
    assert!(overlaps(&[floor(-0.01), Collider::mesh(body.clone(), 0.6)]).is_empty());
    // Standing on the floor in every frame: touching is not going into it.
    let standing = Mesh::new("body.obj", v.clone(), t, Vec3::ZERO, Vec3::ZERO, 1.0)
        .unwrap()
        .with_motion(motion(
            vec![v.iter().map(|p| *p + Vec3::Y * half.y).collect(); 3],
            10.0,
        ))
        .unwrap();
    assert!(overlaps(&[floor(0.0), Collider::mesh(standing, 0.6)]).is_empty());
}
