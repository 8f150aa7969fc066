//! The implicit integrator (backward Euler, conjugate gradient) against closed forms at large
//! steps. Each test states the law, the set-up and why its tolerance is what it is.

use wetcloth::{AirParams, ClothParams, Collider, Integrator, Real, SimConfig, Simulation, Vec3};

/// A small cloth with no air, no grabs, no colliders, no damping, integrated implicitly at `dt`.
fn bare(n: usize, dt: Real) -> SimConfig {
    let mut cfg = SimConfig {
        cloth: ClothParams {
            resolution: [n, n],
            size: [0.1, 0.1],
            mass: 0.01,
            position: Vec3::new(0.0, 1.0, 0.0),
            self_collision: false,
            damping: 0.0,
            ..Default::default()
        },
        air: AirParams {
            enabled: false,
            ..Default::default()
        },
        ..Default::default()
    };
    cfg.simulation.time_step = dt;
    cfg.simulation.integrator = Integrator::Implicit;
    cfg
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

/// Free fall under backward Euler: v_n = -g n dt exactly, y_n = y0 - g dt^2 n (n + 1) / 2, which
/// is the parabola less g t dt / 2: first order. At 1/600 s and 1/1200 s the error is that, to
/// round-off, and halves with the step.
#[test]
fn implicit_free_fall_is_first_order() {
    let mut errors = Vec::new();
    for dt in [1.0 / 600.0, 1.0 / 1200.0] {
        let mut sim = Simulation::new(bare(6, dt)).unwrap();
        run(&mut sim, 0.5);
        let t = sim.time();
        let exact = 1.0 - 0.5 * 9.8 * t * t;
        let method = exact - 0.5 * 9.8 * t * dt;
        for &y in &sim.positions().y {
            assert!((y - method).abs() < 1e-9, "dt = {dt}: {y} vs {method}");
        }
        errors.push(mean(&sim.positions().y) - exact);
    }
    let ratio = errors[0] / errors[1];
    assert!((ratio - 2.0).abs() < 1e-6, "first order: {errors:?}");
}

/// Friction on a 20-degree slope at 1/600 s: with mu = 0.5 > tan 20 the cloth does not move;
/// with mu = 0.2 its velocity grows at g (sin 20 - mu cos 20), to 5 % (the velocity is exact up
/// to the solver's tolerance; the position lags by a t dt / 2, first order).
#[test]
fn implicit_friction_on_a_slope_holds_or_slides() {
    let theta: Real = 20f64.to_radians();
    let g = 9.8;
    for mu in [0.5, 0.2] {
        let mut cfg = bare(5, 1.0 / 600.0);
        cfg.simulation.gravity = Vec3::new(g * theta.sin(), -g * theta.cos(), 0.0);
        cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, mu)];
        cfg.cloth.position.y = cfg.cloth.particle_radius();
        let mut sim = Simulation::new(cfg).unwrap();
        let x0 = mean(&sim.positions().x);
        run(&mut sim, 0.5);
        let t = sim.time();
        let dx = mean(&sim.positions().x) - x0;
        let v = mean(&sim.velocities().x);
        let a = (g * (theta.sin() - mu * theta.cos())).max(0.0);
        if mu == 0.5 {
            assert!(dx.abs() < 1e-12, "static friction holds: moved {dx}");
        } else {
            assert!((v / t - a).abs() < 0.05 * a, "slides at {} vs {a}", v / t);
            let expect = 0.5 * a * t * (t + sim.time_step());
            assert!((dx - expect).abs() < 0.05 * expect, "{dx} vs {expect}");
        }
        let y = sim
            .positions()
            .y
            .iter()
            .fold(0.0 as Real, |m, b| m.max((b - sim.particle_radius()).abs()));
        assert!(y < 1e-9, "stays on the plane: {y}");
    }
}

/// A cloth hanging from two corners, settled: the hands carry its weight, to 1e-3.
#[test]
fn implicit_hanging_cloth_hands_carry_its_weight() {
    let mut cfg = bare(11, 1.0 / 600.0);
    cfg.cloth.damping = 4.0;
    cfg.grabs = vec![
        wetcloth::GrabSpec::lift([0, 0], 0.0, 10.0, 0.0),
        wetcloth::GrabSpec::lift([10, 0], 0.0, 10.0, 0.0),
    ];
    let mut sim = Simulation::new(cfg).unwrap();
    run(&mut sim, 5.0);
    let weight = 0.01 * 9.8;
    let f = sim.grab_force();
    assert!((f.y - weight).abs() < 1e-3 * weight, "{f} vs {weight}");
    assert!(
        f.x.abs() < 1e-3 * weight && f.z.abs() < 1e-3 * weight,
        "{f}"
    );
    let ke = sim.metrics().kinetic_energy;
    assert!(ke < 1e-6, "settled: {ke} J");
}
