//! Nothing passes through: a thin blade (a closed mesh 3 mm thick) swung by its keys through a
//! hanging cloth at 1, 2 and 4 m/s, under both integrators. Whether a particle ends a step
//! inside the blade is decided here, independently of the simulator's contact queries: the
//! blade's triangles are placed by this file's own rotation and each particle's winding number
//! about them is summed from the triangles' solid angles (Van Oosterom and Strackee 1983): 1
//! inside a closed surface wound outwards, 0 outside.

use std::sync::Arc;
use wetcloth::collide::{Key, Mesh};
use wetcloth::control::{GrabKey, GrabPick, GrabSpec};
use wetcloth::{
    AirParams, ClothMeshSource, ClothParams, Collider, Integrator, Real, SimConfig, Simulation,
    Vec3,
};

/// The blade in its file's frame (the pivot at the origin): a plate 16 cm wide along x, from
/// 35 to 65 cm below the pivot, 3 mm thick along z; triangles wound outwards.
fn blade() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (c, h) = (Vec3::new(0.0, -0.5, 0.0), Vec3::new(0.08, 0.15, 0.0015));
    let v = (0..8)
        .map(|i| {
            c + Vec3::new(
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

/// The winding number of the closed triangle surface `tris` over `points` about `p`: the sum of
/// the triangles' signed solid angles over 4 pi.
fn winding(points: &[Vec3], tris: &[[u32; 3]], p: Vec3) -> Real {
    let mut omega = 0.0;
    for t in tris {
        let [a, b, c] = t.map(|i| points[i as usize] - p);
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
        omega += 2.0 * num.atan2(den);
    }
    omega / (4.0 * std::f64::consts::PI)
}

/// A hanging cloth 30 x 30 cm in the plane z = 0, 21 x 21 particles, its top edge (y = 0) held.
fn hanging(blade: Collider, integrator: Integrator) -> SimConfig {
    let (n, size) = (21usize, 0.3);
    let h = size / (n - 1) as Real;
    let mut v = Vec::new();
    for j in 0..n {
        for i in 0..n {
            v.push(Vec3::new(i as Real * h - 0.5 * size, -(j as Real) * h, 0.0));
        }
    }
    let mut faces = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (j * n + i) as u32;
            let (b, c, d) = (a + 1, a + 1 + n as u32, a + n as u32);
            faces.push(vec![a, b, c]);
            faces.push(vec![a, c, d]);
        }
    }
    let mut cfg = SimConfig {
        cloth: ClothParams {
            mass: 0.02,
            damping: 1.0,
            self_collision: false,
            position: Vec3::ZERO,
            mesh: Some(ClothMeshSource {
                file: "hanging.obj".into(),
                vertices: Arc::new(v),
                faces: Arc::new(faces),
                uvs: Arc::new(Vec::new()),
                face_uvs: Arc::new(Vec::new()),
                rotation: Vec3::ZERO,
                scale: 1.0,
                flip_normals: false,
            }),
            ..Default::default()
        },
        air: AirParams {
            enabled: false,
            ..Default::default()
        },
        colliders: vec![blade],
        grabs: vec![GrabSpec {
            particle: [0, 0],
            pick: Some(GrabPick::Box {
                center: Vec3::ZERO,
                half_size: Vec3::new(0.2, 1e-3, 1e-3),
            }),
            keys: vec![GrabKey {
                time: 0.0,
                offset: Vec3::ZERO,
            }],
        }],
        ..Default::default()
    };
    cfg.simulation.integrator = integrator;
    cfg.simulation.time_step = match integrator {
        Integrator::Verlet => 1.0 / 12000.0,
        Integrator::Implicit => 1.0 / 600.0,
    };
    cfg
}

/// The blade hangs from a pivot 30 cm above the cloth's top edge (an axis along x) and swings
/// from 40 degrees behind the cloth to 40 degrees in front of it, its middle (50 cm from the
/// axis) at `speed` m/s; it passes 5 cm below the held edge, so it must push the cloth ahead of
/// it. At every step of the swing and 0.2 s after it, no particle's centre is inside the blade
/// (its winding number below a half), and the blade did sweep the cloth: some particles were
/// pushed at least 5 cm forward.
#[test]
fn no_particle_ends_a_step_inside_a_swinging_blade() {
    let (v, t) = blade();
    let pivot = Vec3::new(0.0, 0.3, 0.0);
    let mesh = Mesh::new("blade.obj", v.clone(), t.clone(), pivot, Vec3::ZERO, 1.0).unwrap();
    assert!(mesh.is_closed());
    for integrator in Integrator::ALL {
        for speed in [1.0, 2.0, 4.0] {
            let omega = speed / 0.5;
            let swing = 80.0_f64.to_radians() / omega;
            let mut c = Collider::mesh(mesh.clone(), 0.3);
            c.keys = vec![
                Key {
                    time: 0.0,
                    offset: Vec3::ZERO,
                    rotation: Vec3::new(40.0, 0.0, 0.0),
                },
                Key {
                    time: swing,
                    offset: Vec3::ZERO,
                    rotation: Vec3::new(-40.0, 0.0, 0.0),
                },
            ];
            let mut sim = Simulation::new(hanging(c, integrator)).unwrap();
            let dt = sim.time_step();
            let name = format!("{} at {speed} m/s", integrator.name());
            let mut pushed: Real = 0.0;
            for _ in 0..((swing + 0.2) / dt).round() as usize {
                sim.step().unwrap();
                let time = sim.time();
                let angle = (40.0 - 80.0 * (time / swing).min(1.0)).to_radians();
                let (s, co) = angle.sin_cos();
                let placed: Vec<Vec3> = v
                    .iter()
                    .map(|p| pivot + Vec3::new(p.x, co * p.y - s * p.z, s * p.y + co * p.z))
                    .collect();
                let x = sim.positions();
                for k in 0..x.len() {
                    let p = x.get(k);
                    let w = winding(&placed, &t, p);
                    assert!(
                        w.abs() < 0.5,
                        "{name}: particle {k} at {p} is inside the blade (winding {w}) at \
                         t = {time} s"
                    );
                    pushed = pushed.max(p.z);
                }
            }
            assert!(
                pushed > 0.05,
                "{name}: the blade pushed the cloth only {pushed} m"
            );
        }
    }
}
