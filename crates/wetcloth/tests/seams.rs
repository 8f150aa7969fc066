//! Seams (`[[cloth.seam]]`): two flat panels sewn edge to edge close, with both integrators
//! and both cloth models, conserving the panels' momentum.

use std::sync::Arc;
use wetcloth::forces::seam::SeamSpec;
use wetcloth::{
    AirParams, ClothMeshSource, ClothModel, ClothParams, Integrator, Real, SimConfig, Simulation,
    Vec3,
};

/// Panel side, m, and vertices along it.
const SIDE: Real = 0.2;
const N: usize = 11;
/// The gap between the panels' facing edges at the start, m.
const GAP: Real = 0.04;

/// Two square panels in the plane y = 0.5, side by side along x with `GAP` between them, and
/// the seam pairing the first panel's right edge with the second's left edge.
fn panels() -> (ClothMeshSource, SeamSpec) {
    let h = SIDE / (N - 1) as Real;
    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for panel in 0..2 {
        let x0 = if panel == 0 {
            -SIDE - GAP / 2.0
        } else {
            GAP / 2.0
        };
        let base = vertices.len() as u32;
        for j in 0..N {
            for i in 0..N {
                vertices.push(Vec3::new(
                    x0 + i as Real * h,
                    0.0,
                    j as Real * h - SIDE / 2.0,
                ));
            }
        }
        let v = |i: usize, j: usize| base + (j * N + i) as u32;
        for j in 0..N - 1 {
            for i in 0..N - 1 {
                // Wound so the normals point up (+y).
                faces.push(vec![v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
                faces.push(vec![v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
            }
        }
    }
    let seam = SeamSpec {
        a: (0..N).map(|j| (j * N + N - 1) as u32).collect(),
        b: (0..N).map(|j| (N * N + j * N) as u32).collect(),
        stiffness: SeamSpec::DEFAULT_STIFFNESS,
        max_force: SeamSpec::DEFAULT_MAX_FORCE,
    };
    let mesh = ClothMeshSource {
        file: "panels.obj".into(),
        vertices: Arc::new(vertices),
        faces: Arc::new(faces),
        uvs: Arc::new(Vec::new()),
        face_uvs: Arc::new(Vec::new()),
        rotation: Vec3::ZERO,
        scale: 1.0,
        flip_normals: false,
    };
    (mesh, seam)
}

/// The panels in zero gravity at 1 kg/m^2, no colliders, no air.
fn config(integrator: Integrator, model: ClothModel, self_collision: bool) -> SimConfig {
    let (mesh, seam) = panels();
    let mut cfg = SimConfig::default();
    cfg.simulation.integrator = integrator;
    cfg.simulation.time_step = match integrator {
        Integrator::Verlet => 1.0 / 6000.0,
        Integrator::Implicit => 1.0 / 600.0,
    };
    cfg.simulation.gravity = Vec3::ZERO;
    cfg.colliders.clear();
    cfg.air = AirParams {
        enabled: false,
        ..AirParams::default()
    };
    cfg.cloth = ClothParams {
        mesh: Some(mesh),
        position: Vec3::new(0.0, 0.5, 0.0),
        model,
        density: Some(1.0),
        self_collision,
        seams: vec![seam],
        ..ClothParams::default()
    };
    cfg
}

fn centre_of_mass(sim: &Simulation) -> Vec3 {
    let x = sim.positions();
    let model = sim.model();
    let (mut m, mut c) = (0.0, Vec3::ZERO);
    for k in 0..x.len() {
        c += x.get(k) * model.mass(k);
        m += model.mass(k);
    }
    c / m
}

/// The time (s) from which the seam's widest gap stays under 1 mm, watched for 1.5 s; fails if
/// it is open at the end or the panels' centre of mass moves.
fn time_to_close(cfg: SimConfig) -> Real {
    // Verlet's pair forces are equal and opposite to the last bit; the implicit step's
    // momentum is as exact as its conjugate gradient: a relative residual of 1e-5 (the
    // converged budget's) leaves forces of about a newton unbalanced by up to 1e-5 N, which over
    // 1.5 s could move the 80 g of panels 1e-5 N / 0.08 kg * (1.5 s)^2 / 2 = 1.4e-4 m if it
    // never cancelled; from step to step it largely does (1.5e-7 m measured), and 1e-6 m is
    // the bound.
    let tolerance = match cfg.simulation.integrator {
        Integrator::Verlet => 1e-12,
        Integrator::Implicit => 1e-6,
    };
    let mut sim = Simulation::new(cfg).expect("a valid configuration");
    let c0 = centre_of_mass(&sim);
    let seams = sim.model().seams.clone().expect("the seam");
    assert!((seams.widest_gap(sim.positions()) - GAP).abs() < 1e-12);
    let mut open_until: Real = 0.0;
    while sim.time() < 1.5 {
        sim.step().expect("a stable step");
        if seams.widest_gap(sim.positions()) >= 1e-3 {
            open_until = sim.time();
        }
    }
    // No outside force: the panels' centre of mass stays where it was.
    let drift = (centre_of_mass(&sim) - c0).length();
    assert!(drift < tolerance, "centre of mass moved {drift} m");
    let gap = seams.widest_gap(sim.positions());
    assert!(gap < 1e-3, "the seam is still {gap} m open after 1.5 s");
    open_until
}

#[test]
fn a_seam_closes_under_a_millimetre_within_a_second() {
    for integrator in [Integrator::Verlet, Integrator::Implicit] {
        for model in [ClothModel::Springs, ClothModel::Membrane] {
            let t = time_to_close(config(integrator, model, true));
            eprintln!("{integrator:?} {model:?}: under 1 mm from {t:.3} s");
            assert!(t < 1.0);
        }
    }
}

#[test]
fn the_force_cap_slows_a_seam_down() {
    // Panels 4 cm apart at 50 N/m would pull at 2 N per pair; capped at a tenth of the default
    // cap they close more slowly (about sqrt(10) times, pulled at constant force).
    let mut fast = config(Integrator::Implicit, ClothModel::Springs, true);
    let t_fast = time_to_close(fast.clone());
    fast.cloth.seams[0].max_force = 0.1 * SeamSpec::DEFAULT_MAX_FORCE;
    let t_slow = time_to_close(fast);
    assert!(t_slow > 2.0 * t_fast, "{t_slow} against {t_fast}");
}

#[test]
fn seam_energy_is_counted_and_spent() {
    // The seam's stored energy at the start (every pair 4 cm open, beyond the cap: F_max d -
    // F_max^2 / (2 k)) is part of the cloth's elastic energy, so the energy audit allows the
    // panels the motion it gives them; closed, the seam holds none.
    let cfg = config(Integrator::Verlet, ClothModel::Springs, true);
    let mut sim = Simulation::new(cfg).unwrap();
    let (k, cap) = (SeamSpec::DEFAULT_STIFFNESS, SeamSpec::DEFAULT_MAX_FORCE);
    let per_pair = cap * GAP - cap * cap / (2.0 * k);
    let e0 = sim.model().elastic_energy(sim.positions());
    assert!((e0 - N as Real * per_pair).abs() < 1e-9, "{e0}");
    while sim.time() < 1.0 {
        sim.step().unwrap();
    }
    sim.audit().expect("the energy audit");
    let e1 = sim.model().elastic_energy(sim.positions());
    assert!(e1 < 0.01 * e0, "{e1} of {e0} left");
}

#[test]
fn seams_are_refused_on_the_spring_grid_and_out_of_range() {
    let mut cfg = SimConfig::default();
    cfg.air.enabled = false;
    cfg.cloth.seams = vec![SeamSpec {
        a: vec![0],
        b: vec![1],
        stiffness: 1.0,
        max_force: 1.0,
    }];
    let e = cfg.validate().unwrap_err().to_string();
    assert!(e.contains("cloth.seam") && e.contains("mesh"), "{e}");
    cfg.cloth.model = ClothModel::Membrane;
    cfg.validate().expect("the membrane grid is a mesh");
    cfg.cloth.seams[0].b = vec![2500];
    let e = cfg.validate().unwrap_err().to_string();
    assert!(e.contains("cloth.seam[0].b") && e.contains("2500"), "{e}");
}

/// `[cloth] shrink = s` scales the cloth's rest shape by `1 - s`: a free square cloth (no
/// gravity, damped) relaxes to a square `1 - s` times its side, its elastic energy to nothing,
/// with the grid's springs, a mesh's springs and membrane elements. Tolerance: the damping
/// (5/s over 3 s) leaves 3e-7 of the first strain; 1e-4 of the side allows the solver's.
#[test]
fn shrink_scales_the_rest_shape() {
    let s = 0.1;
    for (what, model, membrane) in [
        ("grid springs", None, false),
        ("mesh springs", Some(ClothModel::Springs), false),
        ("mesh membrane", Some(ClothModel::Membrane), true),
    ] {
        let mut cfg = config(Integrator::Implicit, ClothModel::Springs, false);
        cfg.cloth.seams.clear();
        cfg.cloth.shrink = s;
        cfg.cloth.damping = 5.0;
        match model {
            None => {
                cfg.cloth.mesh = None;
                cfg.cloth.density = None;
                cfg.cloth.resolution = [11, 11];
                cfg.cloth.size = [SIDE, SIDE];
            }
            Some(m) => {
                // One panel: the first's vertices only.
                let (mut mesh, _) = panels();
                let faces: Vec<Vec<u32>> = mesh.faces[..2 * (N - 1) * (N - 1)].to_vec();
                mesh.vertices = Arc::new(mesh.vertices[..N * N].to_vec());
                mesh.faces = Arc::new(faces);
                cfg.cloth.mesh = Some(mesh);
                cfg.cloth.model = m;
                if membrane {
                    cfg.cloth.membrane.poisson = 0.3;
                }
            }
        }
        let mut sim = Simulation::new(cfg).unwrap();
        assert!(sim.model().elastic_energy(sim.positions()) > 0.0, "{what}");
        while sim.time() < 3.0 {
            sim.step().unwrap();
        }
        let x = sim.positions();
        // Corners 0 and N - 1 (an edge), and 0 and N (N - 1) (the other).
        let side_x = (x.get(N - 1) - x.get(0)).length();
        let side_z = (x.get(N * (N - 1)) - x.get(0)).length();
        for side in [side_x, side_z] {
            assert!(
                (side / SIDE - (1.0 - s)).abs() < 1e-4,
                "{what}: side {side} m, want {} m",
                SIDE * (1.0 - s)
            );
        }
        let e = sim.model().elastic_energy(x);
        assert!(e < 1e-9, "{what}: {e} J left");
    }
}
