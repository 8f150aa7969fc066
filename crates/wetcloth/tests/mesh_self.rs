//! A mesh cloth's self-contact (`collide/mesh_self.rs`): its triangles do not pass through each
//! other, judged from the positions alone by an exact triangle-triangle intersection test
//! written here, however fast they meet; the result does not depend on the thread count; and
//! exempt pairs (a seam's) are left alone.

use std::sync::Arc;
use wetcloth::{
    AirParams, ClothMeshSource, ClothParams, Collider, GrabKey, GrabPick, GrabSpec, Integrator,
    Real, SimConfig, Simulation, Soa, Vec3,
};

/// Mesh edge length, m: ten particle diameters.
const EDGE: Real = 0.02;

/// A mesh source of `vertices` and triangular `faces`.
fn source(vertices: Vec<Vec3>, faces: Vec<[u32; 3]>) -> ClothMeshSource {
    ClothMeshSource {
        file: "test.obj".into(),
        vertices: Arc::new(vertices),
        faces: Arc::new(faces.into_iter().map(|f| f.to_vec()).collect()),
        uvs: Arc::new(Vec::new()),
        face_uvs: Arc::new(Vec::new()),
        rotation: Vec3::ZERO,
        scale: 1.0,
        flip_normals: false,
    }
}

/// A fixed pseudo-random sequence in [-1, 1].
fn sequence(mut seed: u64) -> impl FnMut() -> Real {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as Real / (1u64 << 53) as Real * 2.0 - 1.0
    }
}

/// The triangles of a `columns x rows` grid of particles (`j * columns + i`), numbered from
/// `first`, the diagonals alternating, all wound with the normal up (+y when laid in the xz
/// plane with i along x and j along z).
fn grid_triangles(columns: usize, rows: usize, first: u32) -> Vec<[u32; 3]> {
    let mut t = Vec::new();
    for j in 0..rows - 1 {
        for i in 0..columns - 1 {
            let a = first + (j * columns + i) as u32;
            let (b, c, d) = (a + 1, a + 1 + columns as u32, a + columns as u32);
            if (i + j) % 2 == 0 {
                t.push([a, c, b]);
                t.push([a, d, c]);
            } else {
                t.push([a, d, b]);
                t.push([b, d, c]);
            }
        }
    }
    t
}

/// A strip `EDGE` between particles, folded over itself: `bottom` edges flat along x at y = 0,
/// a hinge edge `gap` (m) up, and `flap` edges back over the bottom at y = `gap`; `rows` edges
/// wide along z. Every particle is moved by up to a quarter edge along x and z (a fixed
/// sequence), so the two layers' particles do not line up.
fn folded_strip(bottom: usize, flap: usize, rows: usize, gap: Real) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let columns = bottom + flap + 2;
    let mut rnd = sequence(0x9E37_79B9_7F4A_7C15);
    let mut v = Vec::new();
    for j in 0..=rows {
        for i in 0..columns {
            let (x, y) = if i <= bottom {
                (i as Real * EDGE, 0.0)
            } else {
                ((2 * bottom + 1 - i) as Real * EDGE, gap)
            };
            let z = (j as Real - 0.5 * rows as Real) * EDGE;
            v.push(Vec3::new(
                x + 0.25 * EDGE * rnd(),
                y,
                z + 0.25 * EDGE * rnd(),
            ));
        }
    }
    (v, grid_triangles(columns, rows + 1, 0))
}

/// A dry mesh cloth of `mesh` (no air), `mass` (kg).
fn cloth(mesh: ClothMeshSource, mass: Real, self_collision: bool) -> SimConfig {
    SimConfig {
        cloth: ClothParams {
            mesh: Some(mesh),
            mass,
            damping: 1.0,
            thickness: 0.001,
            position: Vec3::ZERO,
            self_collision,
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

/// The folded strip of `folded_strip(bottom, flap, rows, gap)` lying on a sphere of radius 0.3 m
/// under the middle of its flap.
fn folded_on_sphere(
    bottom: usize,
    flap: usize,
    rows: usize,
    gap: Real,
    self_collision: bool,
) -> SimConfig {
    let (v, t) = folded_strip(bottom, flap, rows, gap);
    let mut cfg = cloth(
        source(v, t),
        0.01 * (bottom * rows) as Real / 100.0,
        self_collision,
    );
    let r = cfg.cloth.particle_radius();
    let centre = (bottom as Real - 0.5 * flap as Real) * EDGE;
    cfg.colliders = vec![Collider::sphere(
        Vec3::new(centre, -0.3 - r - 1e-4, 0.0),
        0.3,
        0.6,
    )];
    cfg
}

/// The height of `p` over the surface of `triangles` at positions `x`, straight down (along
/// -y): `None` where no triangle is under or over it.
fn height_over(x: &Soa, triangles: &[[u32; 3]], p: Vec3) -> Option<Real> {
    let flat = |v: Vec3| [v.x, v.z];
    let q = flat(p);
    triangles.iter().find_map(|t| {
        let [a, b, c] = t.map(|k| x.get(k as usize));
        let (s, u, w) = (
            orient2(flat(a), flat(b), q),
            orient2(flat(b), flat(c), q),
            orient2(flat(c), flat(a), q),
        );
        let inside = (s >= 0.0 && u >= 0.0 && w >= 0.0) || (s <= 0.0 && u <= 0.0 && w <= 0.0);
        let area = s + u + w;
        (inside && area != 0.0).then(|| p.y - (a.y * u + b.y * w + c.y * s) / area)
    })
}

// --- An exact triangle-triangle intersection test, from the positions alone ---

/// Six times the signed volume of tetrahedron `(a, b, c, d)`.
fn orient(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> Real {
    (b - a).cross(c - a).dot(d - a)
}

/// Twice the signed area of 2D triangle `(a, b, c)`.
fn orient2(a: [Real; 2], b: [Real; 2], c: [Real; 2]) -> Real {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether 2D segments `pq` and `ab` meet (touching counts).
fn segments_meet2(p: [Real; 2], q: [Real; 2], a: [Real; 2], b: [Real; 2]) -> bool {
    let (d1, d2) = (orient2(p, q, a), orient2(p, q, b));
    let (d3, d4) = (orient2(a, b, p), orient2(a, b, q));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    let on = |a: [Real; 2], b: [Real; 2], p: [Real; 2], d: Real| {
        d == 0.0
            && p[0] >= a[0].min(b[0])
            && p[0] <= a[0].max(b[0])
            && p[1] >= a[1].min(b[1])
            && p[1] <= a[1].max(b[1])
    };
    on(p, q, a, d1) || on(p, q, b, d2) || on(a, b, p, d3) || on(a, b, q, d4)
}

/// Whether segment `pq`, in the plane of triangle `(a, b, c)`, meets it.
fn coplanar_segment_meets(p: Vec3, q: Vec3, a: Vec3, b: Vec3, c: Vec3) -> bool {
    let n = (b - a).cross(c - a).abs();
    // Drop the normal's largest component.
    let flat = |v: Vec3| {
        if n.x >= n.y && n.x >= n.z {
            [v.y, v.z]
        } else if n.y >= n.z {
            [v.z, v.x]
        } else {
            [v.x, v.y]
        }
    };
    let [p, q, a, b, c] = [p, q, a, b, c].map(flat);
    let inside = |p: [Real; 2]| {
        let (s, t, u) = (orient2(a, b, p), orient2(b, c, p), orient2(c, a, p));
        (s >= 0.0 && t >= 0.0 && u >= 0.0) || (s <= 0.0 && t <= 0.0 && u <= 0.0)
    };
    inside(p)
        || inside(q)
        || segments_meet2(p, q, a, b)
        || segments_meet2(p, q, b, c)
        || segments_meet2(p, q, c, a)
}

/// Whether segment `pq` meets triangle `(a, b, c)` (touching counts).
fn segment_meets_triangle(p: Vec3, q: Vec3, a: Vec3, b: Vec3, c: Vec3) -> bool {
    let (dp, dq) = (orient(a, b, c, p), orient(a, b, c, q));
    if dp == 0.0 && dq == 0.0 {
        return coplanar_segment_meets(p, q, a, b, c);
    }
    if (dp > 0.0 && dq > 0.0) || (dp < 0.0 && dq < 0.0) {
        return false;
    }
    // The segment reaches the plane: inside the triangle iff the line through it passes every
    // side the same way.
    let (s, t, u) = (orient(p, q, a, b), orient(p, q, b, c), orient(p, q, c, a));
    (s >= 0.0 && t >= 0.0 && u >= 0.0) || (s <= 0.0 && t <= 0.0 && u <= 0.0)
}

/// Whether two triangles meet: where they do, a side of one meets the other.
fn triangles_meet(t: [Vec3; 3], u: [Vec3; 3]) -> bool {
    let lo = |t: [Vec3; 3]| t[0].min(t[1]).min(t[2]);
    let hi = |t: [Vec3; 3]| t[0].max(t[1]).max(t[2]);
    if lo(t).cmpgt(hi(u)).any() || lo(u).cmpgt(hi(t)).any() {
        return false;
    }
    (0..3).any(|i| segment_meets_triangle(t[i], t[(i + 1) % 3], u[0], u[1], u[2]))
        || (0..3).any(|i| segment_meets_triangle(u[i], u[(i + 1) % 3], t[0], t[1], t[2]))
}

/// The pairs of triangles sharing no particle that meet at positions `x`.
fn intersections(x: &Soa, triangles: &[[u32; 3]]) -> usize {
    let corners: Vec<[Vec3; 3]> = triangles
        .iter()
        .map(|t| t.map(|k| x.get(k as usize)))
        .collect();
    let mut count = 0;
    for i in 0..triangles.len() {
        for j in i + 1..triangles.len() {
            if triangles[i].iter().any(|k| triangles[j].contains(k)) {
                continue;
            }
            if triangles_meet(corners[i], corners[j]) {
                count += 1;
            }
        }
    }
    count
}

#[test]
fn the_intersection_test_sees_crossings_and_not_neighbours() {
    let t = [Vec3::ZERO, Vec3::X, Vec3::Z];
    // Crosswise through it, beside it, parallel above it, lying in it.
    let through = [
        Vec3::new(0.2, -1.0, 0.2),
        Vec3::new(0.2, 1.0, 0.2),
        Vec3::new(0.3, 1.0, 0.2),
    ];
    let beside = through.map(|v| v + Vec3::new(2.0, 0.0, 0.0));
    let above = t.map(|v| v + Vec3::new(0.1, 1e-9, 0.1));
    let within = t.map(|v| v * 0.2 + Vec3::new(0.1, 0.0, 0.1));
    assert!(triangles_meet(t, through));
    assert!(!triangles_meet(t, beside));
    assert!(!triangles_meet(t, above));
    assert!(triangles_meet(t, within));
}

/// (a) A strip folded over itself, its edges ten particle diameters long, falls onto a sphere
/// and comes to rest: at every frame (each 1/100 s) no two triangles sharing no particle meet,
/// and at the end the flap lies on the layer under it. Without self-collision the flap falls
/// through it.
#[test]
fn a_folded_strip_does_not_pass_through_itself() {
    let run = |self_collision: bool| {
        let cfg = folded_on_sphere(16, 6, 5, 0.01, self_collision);
        let mut sim = Simulation::new(cfg).unwrap();
        let triangles = sim.model().triangles();
        let mut worst = 0;
        let frame = (0.01 / sim.time_step()).round() as u64;
        for _ in 0..120 {
            sim.advance(frame).unwrap();
            worst = worst.max(intersections(sim.positions(), &triangles));
        }
        (worst, sim)
    };
    let (worst, sim) = run(true);
    assert_eq!(worst, 0, "{worst} pairs of triangles meet");
    // At rest, with the flap on the layer under it: every flap particle over the layer is
    // above it, most of them within two thicknesses.
    let v = sim.velocities();
    let fastest = (0..v.len()).map(|k| v.get(k).length()).fold(0.0, Real::max);
    assert!(fastest < 0.05, "still moving at {fastest} m/s");
    let x = sim.positions();
    let h = 2.0 * sim.particle_radius();
    let columns = 16 + 6 + 2;
    let layer: Vec<[u32; 3]> = sim
        .model()
        .triangles()
        .into_iter()
        .filter(|t| t.iter().all(|&k| k as usize % columns <= 16))
        .collect();
    let heights: Vec<Real> = (0..x.len())
        .filter(|k| k % columns > 17)
        .filter_map(|k| height_over(x, &layer, x.get(k)))
        .collect();
    assert!(heights.len() >= 20, "{heights:?}");
    assert!(heights.iter().all(|&y| y > 0.0), "{heights:?}");
    let resting = heights.iter().filter(|&&y| y < 2.0 * h).count();
    assert!(2 * resting > heights.len(), "{heights:?}");
    let (worst, _) = run(false);
    assert!(
        worst > 0,
        "without self-collision the flap stayed on the strip"
    );
}

/// A flat `columns x rows` sheet `EDGE` between particles in the xz plane centred on `centre`,
/// turned by `angle` (radians) about y, its particles numbered from `first`.
fn sheet(
    columns: usize,
    rows: usize,
    centre: Vec3,
    angle: Real,
    first: u32,
) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (sin, cos) = angle.sin_cos();
    let mut v = Vec::new();
    for j in 0..rows {
        for i in 0..columns {
            let x = (i as Real - 0.5 * (columns - 1) as Real) * EDGE;
            let z = (j as Real - 0.5 * (rows - 1) as Real) * EDGE;
            v.push(centre + Vec3::new(cos * x + sin * z, 0.0, -sin * x + cos * z));
        }
    }
    (v, grid_triangles(columns, rows, first))
}

/// A 20 cm sheet held by its border, and a 4 cm patch (one mesh of two pieces) 2 cm above its
/// middle, turned 30 degrees; the patch is then thrown down at `speed` (m/s).
fn thrown_patch(
    integrator: Integrator,
    time_step: Real,
    self_collision: bool,
) -> (SimConfig, usize) {
    let (mut v, mut t) = sheet(11, 11, Vec3::ZERO, 0.0, 0);
    let first = v.len();
    let (pv, pt) = sheet(3, 3, Vec3::new(0.013, 0.02, -0.007), 0.5, first as u32);
    v.extend(pv);
    t.extend(pt);
    let mut cfg = cloth(source(v, t), 0.01, self_collision);
    let held = |center: Vec3, half_size: Vec3| GrabSpec {
        particle: [0, 0],
        pick: Some(GrabPick::Box { center, half_size }),
        keys: vec![GrabKey {
            time: 0.0,
            offset: Vec3::ZERO,
        }],
    };
    let (edge, long) = (0.1, Vec3::new(0.11, 1e-3, 1e-3));
    cfg.grabs = vec![
        held(Vec3::new(0.0, 0.0, edge), long),
        held(Vec3::new(0.0, 0.0, -edge), long),
        held(Vec3::new(edge, 0.0, 0.0), Vec3::new(1e-3, 1e-3, 0.11)),
        held(Vec3::new(-edge, 0.0, 0.0), Vec3::new(1e-3, 1e-3, 0.11)),
    ];
    cfg.simulation.integrator = integrator;
    cfg.simulation.time_step = time_step;
    (cfg, first)
}

/// (b) A patch thrown at a held sheet, crossing several thicknesses each step (5 m/s in steps
/// of 1/500 s with the implicit integrator, 10 mm a step; 30 m/s in steps of 1/12000 s with
/// position Verlet, 2.5 mm a step; the thickness is 1.5 mm), never ends a step under it, and
/// is stopped (the pushes are in its velocity, with both integrators). Without self-collision
/// it goes through.
#[test]
fn a_patch_thrown_at_a_sheet_stays_on_its_side() {
    for (integrator, time_step, speed) in [
        (Integrator::Implicit, 1.0 / 500.0, 5.0),
        (Integrator::Verlet, 1.0 / 12000.0, 30.0),
    ] {
        let lowest = |self_collision: bool| {
            let (cfg, first) = thrown_patch(integrator, time_step, self_collision);
            let mut sim = Simulation::new(cfg).unwrap();
            let n = sim.particle_count();
            let x = sim.positions().clone();
            let v = Soa::from_vec3(
                &(0..n)
                    .map(|k| {
                        if k >= first {
                            Vec3::new(0.0, -speed, 0.0)
                        } else {
                            Vec3::ZERO
                        }
                    })
                    .collect::<Vec<_>>(),
            );
            sim.set_positions_and_velocities(x, &v).unwrap();
            let sheet: Vec<[u32; 3]> = sim
                .model()
                .triangles()
                .into_iter()
                .filter(|t| (t[0] as usize) < first)
                .collect();
            // The lowest height of a patch particle over the sheet, over every step.
            let mut lowest = Real::INFINITY;
            let steps = (0.1 / time_step).round() as usize;
            for _ in 0..steps {
                sim.step().unwrap();
                let x = sim.positions();
                for k in first..n {
                    if let Some(y) = height_over(x, &sheet, x.get(k)) {
                        lowest = lowest.min(y);
                    }
                }
            }
            // The pushes are in the velocities too: the patch was stopped, not merely put back
            // each step while still falling at `speed`.
            let v = sim.velocities();
            let fastest = (first..n).map(|k| v.get(k).length()).fold(0.0, Real::max);
            (lowest, fastest)
        };
        let (with, fastest) = lowest(true);
        assert!(
            fastest < 0.5 * speed,
            "{integrator:?}: the patch still moves at {fastest} m/s"
        );
        assert!(
            with > 0.0,
            "{integrator:?}: a patch particle went {with} m under the sheet"
        );
        let (without, _) = lowest(false);
        assert!(
            without < 0.0,
            "{integrator:?}: without self-collision it stayed on top"
        );
    }
}

/// (c) The same run on one thread and on two gives the same bits: a folded strip of 1092
/// particles (enough to share out) settling on a sphere with the implicit integrator, its
/// layers in contact.
#[test]
fn self_contact_does_not_depend_on_the_thread_count() {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut cfg = folded_on_sphere(20, 20, 25, 0.005, true);
            cfg.simulation.integrator = Integrator::Implicit;
            cfg.simulation.time_step = 1.0 / 500.0;
            let mut sim = Simulation::new(cfg).unwrap();
            assert!(sim.particle_count() >= 1024);
            let mut contacts = 0;
            for _ in 0..10 {
                sim.advance(10).unwrap();
                contacts = contacts.max(sim.mesh_self().unwrap().contacts);
            }
            let (p, q) = (sim.positions(), sim.previous_positions());
            let bits: Vec<u64> = [&p.x, &p.y, &p.z, &q.x, &q.y, &q.z]
                .into_iter()
                .flat_map(|v| v.iter().map(|x| x.to_bits()))
                .collect();
            (bits, contacts)
        })
    };
    let (one, contacts) = run(1);
    assert!(
        contacts > 1024,
        "only {contacts} contacts: the layers never met"
    );
    let (two, _) = run(2);
    assert!(one == two, "the thread count changed the result");
}

/// (d) Exempt pairs (a seam's) are not pushed apart: two patches 5 cm apart at rest, brought
/// to 0.5 mm apart (a third of the thickness), particle over particle, stay so when every
/// particle is paired with the one under it; without the pairs they are pushed to the
/// thickness. Bad pairs are refused and `reset` keeps the pairs.
#[test]
fn exempt_pairs_may_close() {
    let gap = 0.0005;
    let build = || {
        let (mut v, mut t) = sheet(3, 3, Vec3::ZERO, 0.0, 0);
        let (pv, pt) = sheet(3, 3, Vec3::new(0.0, 0.05, 0.0), 0.0, 9);
        v.extend(pv);
        t.extend(pt);
        let mut cfg = cloth(source(v, t), 0.001, true);
        cfg.simulation.gravity = Vec3::ZERO;
        Simulation::new(cfg).unwrap()
    };
    let close = |sim: &mut Simulation| {
        let mut x = sim.positions().clone();
        for k in 9..18 {
            x.set(k, x.get(k) - Vec3::new(0.0, 0.05 - gap, 0.0));
        }
        sim.set_state(x.clone(), x).unwrap();
    };
    let pairs: Vec<[u32; 2]> = (0..9).map(|k| [k, k + 9]).collect();
    let apart = |sim: &Simulation| {
        let x = sim.positions();
        (0..9)
            .map(|k| (x.get(k + 9) - x.get(k)).length())
            .fold(Real::INFINITY, Real::min)
    };
    let mut sewn = build();
    sewn.set_exempt(&pairs).unwrap();
    assert_eq!(sewn.exempt().len(), 9);
    close(&mut sewn);
    sewn.advance(50).unwrap();
    assert!((apart(&sewn) - gap).abs() < 1e-9, "{}", apart(&sewn));
    sewn.reset().unwrap();
    assert_eq!(sewn.exempt().len(), 9);

    let mut loose = build();
    close(&mut loose);
    loose.advance(50).unwrap();
    let h = 2.0 * loose.particle_radius();
    assert!(apart(&loose) > 0.99 * h, "{}", apart(&loose));

    // Out of range, or a particle paired with itself: refused, the pairs as they were.
    assert!(sewn.set_exempt(&[[0, 18]]).is_err());
    assert!(sewn.set_exempt(&[[3, 3]]).is_err());
    assert_eq!(sewn.exempt().len(), 9);
    sewn.set_exempt(&[]).unwrap();
    assert!(sewn.exempt().is_empty());
}

/// A run resumed from a checkpoint taken while the layers touch continues bit for bit, though
/// the self-contact's lists are not in the checkpoint (they are rebuilt at the resume).
#[test]
fn a_resumed_run_continues_bit_for_bit() {
    let mut cfg = folded_on_sphere(16, 6, 5, 0.005, true);
    cfg.simulation.integrator = Integrator::Implicit;
    cfg.simulation.time_step = 1.0 / 500.0;
    let bits = |sim: &Simulation| {
        let (p, q) = (sim.positions(), sim.previous_positions());
        [&p.x, &p.y, &p.z, &q.x, &q.y, &q.z]
            .into_iter()
            .flat_map(|v| v.iter().map(|x| x.to_bits()))
            .collect::<Vec<u64>>()
    };
    let mut straight = Simulation::new(cfg.clone()).unwrap();
    straight.advance(200).unwrap();
    let saved = straight.checkpoint();
    assert!(
        straight.mesh_self().unwrap().contacts > 0,
        "no contact at the split"
    );
    straight.advance(100).unwrap();
    let mut resumed = Simulation::restore(cfg, saved).unwrap();
    assert_eq!(resumed.mesh_self().unwrap().rebuilds, 0);
    resumed.advance(100).unwrap();
    assert!(bits(&straight) == bits(&resumed), "the resumed run differs");
}
