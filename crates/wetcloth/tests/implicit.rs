//! The implicit integrator (backward Euler, conjugate gradient) against closed forms at large
//! steps. Each test states the law, the set-up and why its tolerance is what it is.

use wetcloth::{
    AirParams, ClothParams, Collider, Integrator, Real, SimConfig, Simulation, SolveBudget, Vec3,
};

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

/// The thesis demo on a `side` x `side` cloth, its middle particle lifted by `(t0, t1,
/// height)` (s, s, m), with `integrator` at `dt` s.
fn lifted_demo(
    side: usize,
    (t0, t1, height): (Real, Real, Real),
    integrator: Integrator,
    dt: Real,
) -> SimConfig {
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.resolution = [side, side];
    cfg.grabs = vec![wetcloth::GrabSpec::lift(
        [side / 2, side / 2],
        t0,
        t1,
        height,
    )];
    cfg.simulation.integrator = integrator;
    cfg.simulation.time_step = dt;
    cfg
}

fn mean(v: &[Real]) -> Real {
    v.iter().sum::<Real>() / v.len() as Real
}

/// Free fall under backward Euler: v_n = -g n dt exactly, y_n = y0 - g dt^2 n (n + 1) / 2, which
/// is the parabola less g t dt / 2: first order. At 1/600 s and 1/1200 s the error is that, to
/// round-off, and halves with the step; with either solve budget.
#[test]
fn implicit_free_fall_is_first_order() {
    let mut errors = Vec::new();
    for dt in [1.0 / 600.0, 1.0 / 1200.0] {
        let mut sim = Simulation::new(bare(6, dt)).unwrap();
        // The interactive budget (first guess: the last step's acceleration) falls the same.
        let mut cfg = bare(6, dt);
        cfg.simulation.implicit_budget = SolveBudget::Interactive;
        let mut interactive = Simulation::new(cfg).unwrap();
        run(&mut interactive, 0.5);
        run(&mut sim, 0.5);
        let t = sim.time();
        let exact = 1.0 - 0.5 * 9.8 * t * t;
        let method = exact - 0.5 * 9.8 * t * dt;
        for &y in sim.positions().y.iter().chain(&interactive.positions().y) {
            assert!((y - method).abs() < 1e-9, "dt = {dt}: {y} vs {method}");
        }
        errors.push(mean(&sim.positions().y) - exact);
    }
    let ratio = errors[0] / errors[1];
    assert!((ratio - 2.0).abs() < 1e-6, "first order: {errors:?}");
}

/// The solve budgets and steps the closed forms below are checked at: the converged budget at
/// 1/600 s, and the interactive one (three coarse solves a step) at 1/600 s and at the viewer's
/// 1/60 s.
fn closed_form_cases() -> [(SolveBudget, Real); 3] {
    [
        (SolveBudget::Converged, 1.0 / 600.0),
        (SolveBudget::Interactive, 1.0 / 600.0),
        (SolveBudget::Interactive, 1.0 / 60.0),
    ]
}

/// Friction on a 20-degree slope: with mu = 0.5 > tan 20 the cloth does not move; with mu =
/// 0.2 its velocity grows at g (sin 20 - mu cos 20), to 5 % (the velocity is exact up to the
/// solver's tolerance; the position lags by a t dt / 2, first order). For each of
/// [`closed_form_cases`]. The interactive budget's solves stop at a hundredth of the smaller of
/// the right-hand side and the step's first residual: relative to the right-hand side alone
/// (mostly momentum `M v` at small steps) the slide at 1/600 s stopped while friction was barely
/// resolved and accelerated at 2.57 m/s^2 instead of 1.51 (+70 %).
#[test]
fn implicit_friction_on_a_slope_holds_or_slides() {
    let theta: Real = 20f64.to_radians();
    let g = 9.8;
    for ((budget, dt), mu) in closed_form_cases()
        .into_iter()
        .flat_map(|c| [(c, 0.5), (c, 0.2)])
    {
        let mut cfg = bare(5, dt);
        cfg.simulation.implicit_budget = budget;
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
            assert!(
                dx.abs() < 1e-12,
                "{budget:?} at {dt}: static friction holds: moved {dx}"
            );
        } else {
            assert!(
                (v / t - a).abs() < 0.05 * a,
                "{budget:?} at {dt}: slides at {} vs {a}",
                v / t
            );
            let expect = 0.5 * a * t * (t + sim.time_step());
            assert!(
                (dx - expect).abs() < 0.05 * expect,
                "{budget:?} at {dt}: {dx} vs {expect}"
            );
        }
        let y = sim
            .positions()
            .y
            .iter()
            .fold(0.0 as Real, |m, b| m.max((b - sim.particle_radius()).abs()));
        assert!(y < 1e-9, "stays on the plane: {y}");
    }
}

/// A cloth hanging from two corners, settled: the hands carry its weight, to 1e-3, for each of
/// [`closed_form_cases`] (measured: within 2e-8 of the weight with the interactive budget).
#[test]
fn implicit_hanging_cloth_hands_carry_its_weight() {
    for (budget, dt) in closed_form_cases() {
        let mut cfg = bare(11, dt);
        cfg.simulation.implicit_budget = budget;
        cfg.cloth.damping = 4.0;
        cfg.grabs = vec![
            wetcloth::GrabSpec::lift([0, 0], 0.0, 10.0, 0.0),
            wetcloth::GrabSpec::lift([10, 0], 0.0, 10.0, 0.0),
        ];
        let mut sim = Simulation::new(cfg).unwrap();
        run(&mut sim, 5.0);
        let weight = 0.01 * 9.8;
        let f = sim.grab_force();
        assert!(
            (f.y - weight).abs() < 1e-3 * weight,
            "{budget:?} at {dt}: {f} vs {weight}"
        );
        assert!(
            f.x.abs() < 1e-3 * weight && f.z.abs() < 1e-3 * weight,
            "{budget:?} at {dt}: {f}"
        );
        let ke = sim.metrics().kinetic_energy;
        assert!(ke < 1e-6, "{budget:?} at {dt}: settled: {ke} J");
    }
}

/// A 12 cm cloth of the thesis' spacing and areal mass (21 x 21), lying stuck on the table with
/// no air under it, air force on, no self-collision, pinched at its centre and lifted 5 mm from
/// t = 0.02 s to 0.12 s, then held.
fn small_pinch(integrator: Integrator, dt: Real) -> SimConfig {
    let mut cfg = SimConfig::thesis_demo();
    cfg.air.trapped_air = 0.0;
    cfg.cloth.position.y = cfg.cloth.particle_radius();
    cfg.cloth.resolution = [21, 21];
    cfg.cloth.size = [0.12, 0.12];
    cfg.cloth.mass = 0.02 * 0.16;
    cfg.cloth.self_collision = false;
    cfg.grabs = vec![wetcloth::GrabSpec::lift([10, 10], 0.02, 0.12, 0.005)];
    cfg.simulation.integrator = integrator;
    cfg.simulation.time_step = dt;
    cfg
}

/// What the thesis measures on a pinch: the hand's force (N), the lifted area (m^2: the cloth
/// area not in contact), and the tent's height (m), at the end of the lift.
fn pinch_measures(integrator: Integrator, dt: Real) -> [Real; 3] {
    let mut sim = Simulation::new(small_pinch(integrator, dt)).unwrap();
    run(&mut sim, 0.15);
    let m = sim.metrics();
    [
        m.grab_force,
        (1.0 - m.contact_fraction) * 0.12 * 0.12,
        m.max_height,
    ]
}

/// The pinch of a cloth stuck by the atmosphere, as the explicit integrator at its fine step
/// (1/12000 s) measures it: the hand's force (5.69 N: the atmosphere on the pinched particle's
/// area plus the springs, with the neighbours slipping 0.37 mm towards the pinch), and the tent's
/// height. Static friction is a constraint in the solve, released into kinetic friction when
/// the force leaves the cone: Coulomb's `mu F_n` against the slide, linearised at its velocity
/// from solve to solve (a Newton step), and carried from step to step while the contact
/// slides. Measured: +0.006, +0.006, +0.008 and -0.042 % at 1/120, 1/300, 1/600 and 1/2400 s,
/// within the explicit integrator's own spread (5.6897 to 5.6921 N at 1/12000, 1/24000 and
/// 1/50000 s: 0.04 %). While kinetic friction was a drag lagged from solve to solve (`mu F_n`
/// over the speed of the solve before), the slide came out short at coarse steps: 3.7 %, 1.9 %,
/// 0.4 % and 0.4 % too high; with its first drag from the force beyond the cone
/// (`Implicit::slip_speed`) still 0.7 %, 0.8 %, 0.34 % and 0.08 % low. Required: within 0.1 %
/// at every step (the target is 10 %) and the tent's height to 1 %. (The convergence
/// in the step that the earlier errors showed is below the reference's own resolution now; the
/// free fall's test measures the order.)
#[test]
fn implicit_pinch_agrees_with_the_explicit_integrator_and_converges() {
    let reference = pinch_measures(Integrator::Verlet, 1.0 / 12000.0);
    let steps = [
        (1.0 / 120.0, 1e-3),
        (1.0 / 300.0, 1e-3),
        (1.0 / 600.0, 1e-3),
        (1.0 / 2400.0, 1e-3),
    ];
    let measured: Vec<[Real; 3]> = steps
        .iter()
        .map(|&(dt, _)| pinch_measures(Integrator::Implicit, dt))
        .collect();
    let errors: Vec<Real> = measured
        .iter()
        .map(|m| (m[0] - reference[0]) / reference[0])
        .collect();
    for ((&(dt, tolerance), m), force) in steps.iter().zip(&measured).zip(&errors) {
        assert!(
            force.abs() < tolerance,
            "dt = {dt}: {m:?} vs {reference:?} (force errors {errors:?})"
        );
        assert!((m[2] - reference[2]).abs() < 0.01 * reference[2], "{m:?}");
    }
}

/// A vacuum pinch held for 2 s at 1/600 s: after the lift the cloth neither creeps (no particle
/// moves by more than 1 micrometre over the last 1.5 s) nor jitters (kinetic energy below
/// 1e-9 J, the hand's force steady to 1e-4).
#[test]
fn implicit_vacuum_pinch_held_neither_creeps_nor_jitters() {
    let mut sim = Simulation::new(small_pinch(Integrator::Implicit, 1.0 / 600.0)).unwrap();
    run(&mut sim, 0.5);
    let before = sim.positions().clone();
    let f0 = sim.metrics().grab_force;
    let mut forces = Vec::new();
    for _ in 0..15 {
        run(&mut sim, 0.1);
        let m = sim.metrics();
        assert!(m.kinetic_energy < 1e-9, "jitters: {m:?}");
        forces.push(m.grab_force);
    }
    let creep = (0..before.len())
        .map(|k| (sim.positions().get(k) - before.get(k)).length())
        .fold(0.0, Real::max);
    assert!(creep < 1e-6, "creeps {creep} m");
    for f in forces {
        assert!((f - f0).abs() < 1e-4 * f0, "{f} vs {f0}");
    }
    assert!(f0 > 1.0, "the atmosphere holds the cloth: {f0} N");
}

/// The thesis demo at 1/120 s (a 30 cm cloth over 400 cm^3 of air, pinched and lifted 5 cm;
/// here 20 x 20 particles and the first 0.6 s): no blow-up, and Boyle's law on every row.
#[test]
fn implicit_thesis_demo_is_stable_at_1_120_s_and_keeps_boyle() {
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.resolution = [20, 20];
    cfg.cloth.self_collision = false;
    cfg.grabs = vec![wetcloth::GrabSpec::lift([10, 10], 0.05, 0.5, 0.05)];
    cfg.simulation.integrator = Integrator::Implicit;
    cfg.simulation.time_step = 1.0 / 120.0;
    let k = cfg.air.atmospheric_pressure * cfg.air.trapped_air;
    let mut sim = Simulation::new(cfg).unwrap();
    for _ in 0..12 {
        run(&mut sim, 0.05);
        let m = sim.metrics();
        assert!(
            (m.air_pressure * m.air_volume - k).abs() < 1e-9 * k,
            "{m:?}"
        );
    }
    let m = sim.metrics();
    assert!(m.max_height > 0.04, "lifted: {m:?}");
}

/// A cloth dropped 2 mm onto the table with the air force on, settled for 1 s at 1/600 s: its
/// kinetic energy is below 1e-6 J (backward Euler damps what the contact leaves).
#[test]
fn implicit_settled_cloth_is_at_rest() {
    let mut cfg = wetcloth::bench::thesis_workload(20);
    cfg.simulation.integrator = Integrator::Implicit;
    cfg.simulation.time_step = 1.0 / 600.0;
    let mut sim = Simulation::new(cfg).unwrap();
    run(&mut sim, 1.0);
    let ke = sim.metrics().kinetic_energy;
    assert!(ke < 1e-6, "{ke} J");
}

/// `scenes/pinch-dry.toml` at 1/120 s: a dry 30 cm cloth (5000 / 1250 N/m, no air) lying on
/// the table, pinched at its centre and lifted 1.2 cm. Gravity alone presses it, so friction
/// is tiny beside the springs and the whole cloth slides towards the pinch. Kinetic friction
/// used to enter the solve as a fixed impulse along the direction the static grip had pushed;
/// where the slide went another way it did positive work, and the cloth gained 5.5 mJ by
/// t = 1.07 s (the energy audit stopped the run). As a drag against the slide's own velocity it
/// can only take energy: the run passes the audit, and the cloth's mechanical energy stays
/// within the audit's 1 mJ floor of the hand's work (measured: it ends 0.65 mJ below it; two
/// single-step spikes of the springs' energy, where the lifted cloth buckles, reach 0.38 mJ and
/// 0.72 mJ above it, against 5.2 mJ before).
#[test]
fn implicit_dry_cloth_dragged_over_the_table_gains_no_energy() {
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.size = [0.30, 0.30];
    cfg.cloth.resolution = [50, 50];
    cfg.cloth.mass = 0.02;
    cfg.cloth.structural_stiffness = 5000.0;
    cfg.cloth.shear_stiffness = 1250.0;
    cfg.cloth.damping = 2.0;
    cfg.cloth.thickness = 0.001;
    cfg.cloth.collision_margin = 0.0005;
    cfg.cloth.self_collision = false;
    cfg.cloth.strain_limit = 0.0;
    cfg.cloth.position = Vec3::new(0.0, 0.00075, 0.0);
    cfg.air.enabled = false;
    cfg.air.trapped_air = 0.0;
    cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.6)];
    cfg.grabs = vec![wetcloth::GrabSpec::lift([25, 25], 0.25, 1.25, 0.012)];
    cfg.simulation.integrator = Integrator::Implicit;
    cfg.simulation.time_step = 1.0 / 120.0;
    let mut sim = Simulation::new(cfg).unwrap();
    let dt = sim.time_step();
    let energy =
        |sim: &Simulation| wetcloth::checks::mechanical_energy(sim.model(), sim.state(), dt);
    let e0 = energy(&sim);
    let mut worst = Real::NEG_INFINITY;
    for _ in 0..160 {
        sim.step().expect("no blow-up, no energy from nowhere");
        worst = worst.max(energy(&sim) - e0 - sim.control().hand_work());
    }
    assert!(
        worst < 1e-3,
        "the cloth gained {worst} J beyond the hand's work"
    );
    assert!(sim.metrics().max_height > 0.01, "lifted");
}

/// `scenes/settle.toml` at 1/600 s: a cloth 3 cm above a table tilted 10 degrees, with no air
/// under it (the thesis bubble at `trapped_air = 0`, a vacuum: the atmosphere slams it down in
/// the first step). Found: a particle that would land was held at its height (the contact
/// constraint's normal velocity was clamped to "never towards the surface"), so the cloth hung
/// 3 cm up, counted as touching, while the atmosphere's push along the plane accelerated it to
/// 575 m/s and the springs tore. Now it lands in the first step and stays: every particle on
/// the plane to 1 um, at rest, within 1 cm of where it fell. The energy audit starts with the
/// air as it is at the start (the vacuum spends its 3.8 J in that one step), so it holds too.
/// The table's friction here is 0.3; at the scene's 0.15 (below tan 10 deg = 0.18) see
/// `implicit_cloth_slammed_onto_a_tilted_table_at_large_steps_does_not_slide`.
#[test]
fn implicit_cloth_slammed_onto_a_tilted_table_by_a_vacuum_lands_and_stays() {
    let normal = Vec3::new(10f64.to_radians().sin(), 10f64.to_radians().cos(), 0.0);
    let mut cfg = SimConfig::thesis_demo();
    cfg.cloth.resolution = [20, 20];
    cfg.cloth.structural_stiffness = 500.0;
    cfg.cloth.shear_stiffness = 125.0;
    cfg.cloth.damping = 2.0;
    cfg.cloth.self_collision = false;
    cfg.cloth.position = Vec3::new(0.0, 0.03, 0.0);
    cfg.air.trapped_air = 0.0;
    cfg.colliders = vec![Collider::plane(Vec3::ZERO, normal, 0.3)];
    cfg.grabs.clear();
    cfg.simulation.integrator = Integrator::Implicit;
    cfg.simulation.time_step = 1.0 / 600.0;
    let radius = cfg.cloth.particle_radius();
    let mut sim = Simulation::new(cfg).unwrap();
    let x0 = mean(&sim.positions().x);
    run(&mut sim, 0.3);
    let p = sim.positions();
    for k in 0..p.len() {
        let height = p.get(k).dot(normal) - radius;
        assert!(
            height.abs() < 1e-6,
            "particle {k} is {height} m off the plane"
        );
    }
    assert!(sim.metrics().kinetic_energy < 1e-6, "{:?}", sim.metrics());
    assert!((mean(&p.x) - x0).abs() < 0.01, "slid {} m", mean(&p.x) - x0);
}

/// `scenes/settle.toml` at the large steps the implicit integrator is for: a cloth 3 cm above
/// a table tilted 10 degrees, friction 0.15 (below tan 10 deg = 0.18), no air under it (the
/// thesis bubble as a vacuum). The atmosphere slams the cloth onto the table within the first
/// step, then presses it onto the table along the table's normal: friction holds it against
/// the slope with the vacuum's normal force, and it must not slide. Found: the landing step
/// applied the pressure along the normal the cloth had at the step's start (level, so
/// vertical), whose share along the table friction could not hold; at 1/60 s the cloth slid
/// about 3 m down the table within that step (364.6 J of kinetic energy at its end), at 1/600 s
/// 3 cm (8.8 J). Now the pressure on a particle that lands with its whole stencil acts along
/// the contact normal (`integrate/implicit/lying.rs`). Measured here: after the landing step
/// the cloth moves along the table at the speed of round-off, its kinetic energy is that of the
/// landing's normal motion alone (the gap closed over the step), the landing moved it down the
/// table by no more than a fall straight down would (the explicit integrator's cloth, which
/// falls so, lands 5.2 mm down the table on `settle.toml`; this one lands along the table's
/// normal, by round-off), and in the 0.5 s after it slides less than 0.1 mm and comes to rest;
/// for both budgets at 1/60 s and the converged one at 1/600 s.
#[test]
fn implicit_cloth_slammed_onto_a_tilted_table_at_large_steps_does_not_slide() {
    let normal = Vec3::new(10f64.to_radians().sin(), 10f64.to_radians().cos(), 0.0);
    // Down the slope, in the table's plane.
    let downhill = Vec3::new(normal.y, -normal.x, 0.0);
    for (budget, dt) in [
        (SolveBudget::Converged, 1.0 / 60.0),
        (SolveBudget::Interactive, 1.0 / 60.0),
        (SolveBudget::Converged, 1.0 / 600.0),
    ] {
        let mut cfg = SimConfig::thesis_demo();
        cfg.cloth.resolution = [20, 20];
        cfg.cloth.structural_stiffness = 500.0;
        cfg.cloth.shear_stiffness = 125.0;
        cfg.cloth.damping = 2.0;
        cfg.cloth.self_collision = false;
        cfg.cloth.position = Vec3::new(0.0, 0.03, 0.0);
        cfg.air.trapped_air = 0.0;
        cfg.colliders = vec![Collider::plane(Vec3::ZERO, normal, 0.15)];
        cfg.grabs.clear();
        cfg.simulation.integrator = Integrator::Implicit;
        cfg.simulation.implicit_budget = budget;
        cfg.simulation.time_step = dt;
        let radius = cfg.cloth.particle_radius();
        let mass = cfg.cloth.mass / 400.0;
        let mut sim = Simulation::new(cfg).unwrap();
        let along = |sim: &Simulation| {
            let p = sim.positions();
            (0..p.len()).map(|k| p.get(k).dot(downhill)).sum::<Real>() / p.len() as Real
        };
        let start = along(&sim);
        // The landing's normal motion: each particle's gap closed over the step; and the share
        // along the table of a fall straight down (the level cloth's normal) onto it.
        let p = sim.positions();
        let gaps: Vec<Real> = (0..p.len())
            .map(|k| p.get(k).dot(normal) - radius)
            .collect();
        let landing: Real = gaps.iter().map(|g| 0.5 * mass * (g / dt).powi(2)).sum();
        let fall = mean(&gaps) / normal.y * normal.x;
        sim.step().expect("stable step");
        let v = sim.velocities();
        let slide = (0..v.len()).map(|k| v.get(k).dot(downhill)).sum::<Real>() / v.len() as Real;
        let energy = sim.metrics().kinetic_energy;
        assert!(
            slide.abs() < 1e-3,
            "{budget:?} at {dt}: slides at {slide} m/s after landing"
        );
        assert!(
            energy <= 1.01 * landing,
            "{budget:?} at {dt}: {energy} J after landing, the landing's normal motion {landing} J"
        );
        let landed = along(&sim) - start;
        assert!(
            (-1e-3..fall + 1e-3).contains(&landed),
            "{budget:?} at {dt}: landed {landed} m down the table (a fall straight down: {fall} m)"
        );
        let after = along(&sim);
        run(&mut sim, 0.5);
        let slid = along(&sim) - after;
        assert!(slid.abs() < 1e-4, "{budget:?} at {dt}: slid {slid} m");
        assert!(
            sim.metrics().kinetic_energy < 1e-6,
            "{budget:?} at {dt}: {:?}",
            sim.metrics()
        );
        let p = sim.positions();
        for k in 0..p.len() {
            let height = p.get(k).dot(normal) - radius;
            assert!(
                height.abs() < 1e-6,
                "{budget:?} at {dt}: particle {k} {height} m off"
            );
        }
    }
}

/// The multigrid preconditioner at work: the thesis' cloth (50 x 50 particles, 5000 N/m, 8 mg
/// a particle: `dt^2 k / m` = 4e4 at 1/120 s) floating on its air before the lift. The stiff,
/// smooth stretching modes take a diagonal preconditioner hundreds of conjugate-gradient
/// iterations a step; the V-cycle (with the bubble's gas spring by Woodbury) takes about ten.
/// A count of iterations, not a timing: the same on every machine.
#[test]
fn implicit_floating_cloth_solves_in_few_iterations() {
    let mut cfg = SimConfig::thesis_demo();
    cfg.simulation.integrator = Integrator::Implicit;
    cfg.simulation.time_step = 1.0 / 120.0;
    let mut sim = Simulation::new(cfg).unwrap();
    run(&mut sim, 0.2);
    let per_step = sim.solver_iterations() as Real / 24.0;
    assert!(per_step < 20.0, "{per_step} iterations a step");
}

/// Strain limiting inside the implicit solve. The small vacuum pinch at 500 N/m stretches the
/// pinched particle's springs by 25 %; with `strain_limit = 0.1` the implicit integrator at
/// 1/600 s stiffens a spring 1000-fold beyond 10 % (and solves a step again where its solution
/// takes a spring past the limit), so that the contacts' friction answers the limit's pull.
/// Found before: Provot's projection after the implicit step slid particles that static
/// friction held, the next step's friction kept the strain it left, and a 100 x 100 pinch
/// gained 0.77 J until the energy audit stopped it. Here every step passes the audit, the
/// threads never stretch past 13 % (measured 11.45 %, for one step as the lift starts; 12.25 %
/// while kinetic friction was a drag alone and every contact started a step held; 10.0 % once
/// the lift has settled), the cloth gains nothing beyond the hand's work (measured: nothing),
/// and the cloth, now nearly inextensible, is drawn in over the table towards the pinch, so
/// the hand pulls harder (measured 11.8 N against 5.7 N). (While every contact started a step
/// held, static friction gripped the cloth anew each step and the pinch lifted five more
/// particles off the table instead, with 23.2 N; the explicit integrator, whose strain limit
/// is Provot's projection, slides it in with no more lifted, 4.4 N at 1/50000 s.)
#[test]
fn implicit_strain_limit_holds_the_pinch_without_gaining_energy() {
    let at = |limit: Real| {
        let mut cfg = small_pinch(Integrator::Implicit, 1.0 / 600.0);
        cfg.cloth.strain_limit = limit;
        Simulation::new(cfg).unwrap()
    };
    // How far the pinch's neighbour lies from it across the table, and its thread's length, m.
    let reach = |sim: &Simulation| {
        let (p, q) = (sim.positions().get(220), sim.positions().get(221));
        (
            ((p.x - q.x).powi(2) + (p.z - q.z).powi(2)).sqrt(),
            (p - q).length(),
        )
    };
    let mut free = at(0.0);
    run(&mut free, 0.15);
    let free_reach = reach(&free);
    let free = free.metrics();
    let mut sim = at(0.1);
    let dt = sim.time_step();
    let energy =
        |sim: &Simulation| wetcloth::checks::mechanical_energy(sim.model(), sim.state(), dt);
    let e0 = energy(&sim);
    let mut worst: Real = 0.0;
    let mut gain = Real::NEG_INFINITY;
    let mut at_lift = None;
    for step in 1..=(0.3 / dt).round() as usize {
        sim.step().expect("the energy audit holds");
        worst = worst.max(sim.metrics().max_stretch);
        gain = gain.max(energy(&sim) - e0 - sim.control().hand_work());
        if step == (0.15 / dt).round() as usize {
            at_lift = Some((sim.metrics(), reach(&sim)));
        }
    }
    let (limited, limited_reach) = at_lift.unwrap();
    assert!(
        free.max_stretch > 0.2,
        "without the limit: {}",
        free.max_stretch
    );
    assert!(worst < 0.13, "threads stretched {worst}");
    assert!(
        gain < 1e-3,
        "the cloth gained {gain} J beyond the hand's work"
    );
    // Without the limit the neighbour slips 0.36 mm towards the pinch (the explicit
    // integrator's 0.37 mm) and its thread stretches to 7.5 mm; with it the thread stays at
    // 1.1 times its 6 mm and the neighbour, still on the table, slides in until it is
    // sqrt(6.6^2 - 5^2) = 4.31 mm from the pinch (measured 4.3095 mm).
    let rest = 0.12 / 20.0;
    assert!(
        limited_reach.1 < 1.1 * rest * 1.002,
        "thread {} m",
        limited_reach.1
    );
    assert!(
        limited_reach.0 < free_reach.0 - 1e-3,
        "slides in: {} m against {} m",
        limited_reach.0,
        free_reach.0
    );
    assert!(
        limited.grab_force > 2.0 * free.grab_force,
        "{} N against {} N",
        limited.grab_force,
        free.grab_force
    );
}

/// The thesis' cloth floating on its 400 cm^3 of air, its centre lifted 7 mm in 0.5 s (here
/// 20 x 20 particles, the rim clear of the table throughout). The air carries the cloth's
/// weight, 2.18 Pa over the atmosphere, and a slow lift hardly changes that: the explicit
/// integrator's bubble stays within 0.1 Pa of it. Found before: the implicit solve predicted
/// the bubble's volume change with the thesis' pressure force `S N_k` as its gradient, but a
/// border particle's share of the volume (eq. 3.10) is half an inner one's while its force is
/// the same; a lift that raises the middle as the rim comes down looked like a shrinking
/// bubble to the solve, so every step it expected a pressure rise that never came, and the
/// bubble fell 33 Pa below the atmosphere here at 1/600 s (18 Pa on the 50 x 50 `air-400`).
/// Now the miss between the volume at the step's end and its linear prediction corrects the
/// pressure inside the step (solved again while it moves the pressure by more than 0.01 Pa):
/// measured within 0.017 Pa of the explicit integrator's pressure at 1/600 s and 0.019 Pa at
/// 1/120 s (0.44 Pa at 1/120 s when the shift was a fixed-point iteration that ended with the
/// step's fourth solve; 1.9 Pa with eight solves whose first ones stopped at a hundredth, the
/// miss measured on them). Required: 0.05 Pa and 0.1 Pa.
#[test]
fn implicit_floating_cloth_lifted_keeps_the_bubbles_pressure() {
    let lifted = |integrator: Integrator, dt: Real| {
        let mut cfg = lifted_demo(20, (0.05, 0.55, 0.007), integrator, dt);
        cfg.cloth.self_collision = false;
        let pa = cfg.air.atmospheric_pressure;
        let mut sim = Simulation::new(cfg).unwrap();
        let mut over = Vec::new();
        for _ in 0..11 {
            run(&mut sim, 0.05);
            let m = sim.metrics();
            assert!(m.contact_fraction == 0.0, "the rim touched: {m:?}");
            over.push(m.air_pressure - pa);
        }
        over
    };
    let weight = 0.02 * 9.8 / 0.09;
    let explicit = lifted(Integrator::Verlet, 1.0 / 12000.0);
    for p in &explicit {
        assert!((p - weight).abs() < 0.1, "explicit: {explicit:?}");
    }
    for (dt, within) in [(1.0 / 600.0, 0.05), (1.0 / 120.0, 0.1)] {
        let implicit = lifted(Integrator::Implicit, dt);
        for (p, e) in implicit.iter().zip(&explicit) {
            assert!(
                (p - e).abs() < within,
                "dt = {dt}: {implicit:?} against {explicit:?}"
            );
        }
    }
}

/// The thesis demo's lift without air (25 x 25 particles, 500 N/m, friction 0.6): the hand
/// raises the centre 5 cm over 1.5 s and the cloth around the tent slides in over the table.
/// Found: every particle that landed during a step was held for the rest of it, whatever pulled
/// it, and one landing in the step's last solve stayed held through the step; as the cloth
/// sank onto the table around the rising tent it was pinned there ring by ring, so at 1/600 s
/// the hand pulled 28 % harder than the explicit integrator's (per-step peaks 0.0997 against
/// 0.0778 N; at 1/120 s +164 %; with the 400 cm^3 bubble, whose vacuum then pressed the pinned
/// rim harder, +320 % at 1/600 s). A landing particle now gets the impact's Coulomb friction:
/// the peak hand force is within 10 % of the explicit one at its fine step (measured 0.0780 N,
/// +0.2 %; -3.7 % while kinetic friction was a lagged drag and every contact started a step
/// held).
#[test]
fn implicit_lifted_cloth_slides_in_over_the_table_as_the_explicit_one_does() {
    let peak = |integrator: Integrator, dt: Real| {
        let mut cfg = lifted_demo(25, (0.25, 1.75, 0.05), integrator, dt);
        cfg.air.enabled = false;
        let mut sim = Simulation::new(cfg).unwrap();
        let mut peak: Real = 0.0;
        for _ in 0..(2.0 / dt).round() as usize {
            sim.step().expect("stable step");
            peak = peak.max(sim.grab_force().length());
        }
        peak
    };
    let explicit = peak(Integrator::Verlet, 1.0 / 12000.0);
    let implicit = peak(Integrator::Implicit, 1.0 / 600.0);
    assert!(
        (implicit / explicit - 1.0).abs() < 0.1,
        "implicit {implicit} N against explicit {explicit} N"
    );
}

/// `pinch-dry` made small: a dry, stiff cloth (5000 / 1250 N/m, 25 x 25 particles, 15 cm, 6 mm
/// apart like the scene's 50 x 50) lifted 1.2 cm at its centre over 1 s: the hand carries the
/// lifted part's weight while the cloth around it slides in over the table. Found on the full
/// scene: the hand's force spiked to twice the explicit integrator's peak at 1/600 s (0.092
/// against 0.047 N; 46 % off on average over the lift) because the step ran out of its four
/// solves while the rim changed from held to sliding, ending steps with held particles
/// outside the friction cone. With eight solves it agrees (0.0466 N). Here, the hand's force
/// every 1/60 s over the lift against the explicit integrator at the scene's 1/36000 s, the
/// mean difference over the mean force: measured 4.0 % (5.8 % with kinetic friction a lagged
/// drag, 12.2 % with four solves); required within 10 %, the bound.
#[test]
fn implicit_dry_cloth_lifted_at_its_centre_agrees_with_the_explicit_one() {
    let forces = |integrator: Integrator, dt: Real| {
        let mut cfg = lifted_demo(25, (0.25, 1.25, 0.012), integrator, dt);
        cfg.air.enabled = false;
        cfg.air.trapped_air = 0.0;
        cfg.cloth.size = [0.15, 0.15];
        cfg.cloth.mass = 0.005;
        cfg.cloth.structural_stiffness = 5000.0;
        cfg.cloth.shear_stiffness = 1250.0;
        cfg.cloth.position.y = cfg.cloth.particle_radius();
        let mut sim = Simulation::new(cfg).unwrap();
        let per_frame = (1.0 / (60.0 * dt)).round() as usize;
        let mut out = Vec::new();
        // Frames of 1/60 s to the lift's end (1.25 s), measured from 0.4 s on.
        for frame in 1..=75 {
            for _ in 0..per_frame {
                sim.step().expect("stable step");
            }
            if frame >= 24 {
                out.push(sim.grab_force().length());
            }
        }
        out
    };
    let explicit = forces(Integrator::Verlet, 1.0 / 36000.0);
    let implicit = forces(Integrator::Implicit, 1.0 / 600.0);
    // The average difference over the average force (a frame's own relative difference
    // would weigh the lift's first instants, where the force is a few millinewtons, most).
    let off = mean(
        &implicit
            .iter()
            .zip(&explicit)
            .map(|(i, e)| (i - e).abs())
            .collect::<Vec<_>>(),
    ) / mean(&explicit);
    assert!(
        off < 0.1,
        "{:.1} % off on average: implicit {implicit:?} against explicit {explicit:?}",
        100.0 * off
    );
}

/// A dry cloth (no air, 25 x 25 particles, 15 cm, 500 N/m, friction 0.6) lifted 3 cm by a
/// corner over 1.5 s: the hand drags the whole cloth a few millimetres towards it over the
/// table while the corner peels off. How far it slides and how much of it peels off depend on
/// friction holding a slide that should stop: the implicit integrator's kinetic friction is a
/// drag that falls below Coulomb's under `SLIDE_EPSILON` (`integrate/implicit.rs`), where a
/// slide creeps on. While all of kinetic friction was such a drag, with a floor of 1 mm/s, it
/// did: measured at 1/600 s, 2 s in, the far corner slid 6.80 mm against the explicit
/// integrator's 6.56 mm (+3.7 %) and more of the cloth stayed on the table (contact fraction
/// 0.758 against 0.739, +2.6 %); at 0.01 mm/s 6.63 mm (+1.1 %), 0.742 (+0.4 %). With Coulomb's
/// friction linearised by a Newton step (the drag only across the slide): 6.58 mm (+0.4 %),
/// 0.7392 (the explicit integrator's). Required: the slide within 2.5 % and the contact
/// fraction within 1.5 % of the explicit integrator's at 1/20000 s.
#[test]
fn implicit_dry_cloth_lifted_by_a_corner_slides_as_the_explicit_one_does() {
    let measure = |integrator: Integrator, dt: Real| {
        let mut cfg = lifted_demo(25, (0.25, 1.75, 0.03), integrator, dt);
        cfg.grabs = vec![wetcloth::GrabSpec::lift([0, 0], 0.25, 1.75, 0.03)];
        cfg.air.enabled = false;
        cfg.air.trapped_air = 0.0;
        cfg.cloth.size = [0.15, 0.15];
        cfg.cloth.position.y = cfg.cloth.particle_radius();
        let mut sim = Simulation::new(cfg).unwrap();
        let far = 25 * 25 - 1;
        let start = Vec3::new(sim.positions().x[far], 0.0, sim.positions().z[far]);
        run(&mut sim, 2.0);
        let end = Vec3::new(sim.positions().x[far], 0.0, sim.positions().z[far]);
        ((end - start).length(), sim.metrics().contact_fraction)
    };
    let (slide_e, contact_e) = measure(Integrator::Verlet, 1.0 / 20000.0);
    let (slide_i, contact_i) = measure(Integrator::Implicit, 1.0 / 600.0);
    assert!(
        (slide_i / slide_e - 1.0).abs() < 0.025,
        "the far corner slid {slide_i} m against the explicit {slide_e} m"
    );
    assert!(
        (contact_i / contact_e - 1.0).abs() < 0.015,
        "contact fraction {contact_i} against the explicit {contact_e}"
    );
}

/// Coulomb's law on a slide: a dry cloth (11 x 11 particles, 10 g, 2000 / 500 N/m) dragged
/// over a table by one border particle at 5 cm/s, friction 0.3. Once the whole cloth slides at
/// the hand's speed, the hand pulls the kinetic friction of the particles on the table, `mu (M -
/// m) g` horizontally, and carries its own particle's weight `m g` vertically. Kinetic
/// friction is `mu F_n` against each slide, its normal impulse taken from the solve before
/// (solved to a relative residual of 1e-3 while the contact set is decided), so the error is
/// that solve's: measured -0.15 %, +0.02 % and +0.33 % at 1/60, 1/120 and 1/600 s (within
/// 1e-5 while friction was a drag `mu F_n / |v_t|`, exact at a steady slide). Required: the
/// mean force over the last 0.8 s within 0.5 % horizontally and 1e-6 N vertically. (The explicit integrator's hand force has the same mean,
/// but its magnitude swings between 0.001 and 0.14 N from step to step as the stiff cloth
/// rings.)
#[test]
fn implicit_cloth_dragged_over_the_table_pulls_coulombs_kinetic_friction() {
    let mu = 0.3;
    for dt in [1.0 / 60.0, 1.0 / 120.0, 1.0 / 600.0] {
        let mut cfg = bare(11, dt);
        cfg.cloth.structural_stiffness = 2000.0;
        cfg.cloth.shear_stiffness = 500.0;
        cfg.cloth.position.y = cfg.cloth.particle_radius();
        cfg.colliders = vec![Collider::plane(Vec3::ZERO, Vec3::Y, mu)];
        let mut grab = wetcloth::GrabSpec::lift([10, 5], 0.2, 2.0, 0.0);
        grab.keys[1].offset = Vec3::new(0.09, 0.0, 0.0);
        cfg.grabs = vec![grab];
        let mut sim = Simulation::new(cfg).unwrap();
        run(&mut sim, 1.2);
        let steps = (0.8 / dt).round() as usize;
        let mut mean = Vec3::ZERO;
        for _ in 0..steps {
            sim.step().expect("stable step");
            mean += sim.grab_force() / steps as Real;
        }
        let m = 0.01 / 121.0;
        let friction = mu * (0.01 - m) * 9.8;
        assert!(
            (mean.x / friction - 1.0).abs() < 0.005,
            "dt = {dt}: the hand pulls {} N against Coulomb's {friction} N",
            mean.x
        );
        assert!(
            (mean.y - m * 9.8).abs() < 1e-6,
            "dt = {dt}: the hand carries {} N against its particle's weight {} N",
            mean.y,
            m * 9.8
        );
    }
}

/// A step of the implicit integrator that ends with a thread beyond the strain limit by more
/// than a quarter of the limit is taken again as two steps of half the time step (down to a
/// sixteenth): the small strain-limited pinch lifted in 0.1 s at 1/60 s (six steps for the
/// lift) halves some of its steps and keeps every thread within 12.5 % at every step, while
/// the same lift without the limit, and a cloth lying still, halve none.
#[test]
fn implicit_steps_that_break_the_strain_limit_are_halved() {
    let run_for = |limit: Real| {
        let mut cfg = small_pinch(Integrator::Implicit, 1.0 / 60.0);
        cfg.cloth.strain_limit = limit;
        let mut sim = Simulation::new(cfg).unwrap();
        let mut worst: Real = 0.0;
        for _ in 0..18 {
            sim.step().expect("no blow-up");
            worst = worst.max(sim.metrics().max_stretch);
        }
        (sim.halvings(), worst)
    };
    let (halved, worst) = run_for(0.1);
    assert!(halved > 0, "no step halved (worst stretch {worst})");
    assert!(worst <= 0.125 + 1e-9, "threads stretched {worst}");
    let (free, stretched) = run_for(0.0);
    assert_eq!(free, 0, "without the limit ({stretched})");
    let mut still = SimConfig::thesis_demo();
    still.cloth.resolution = [12, 12];
    still.cloth.strain_limit = 0.1;
    still.cloth.position.y = still.cloth.particle_radius();
    still.air.trapped_air = 0.0;
    still.grabs.clear();
    still.simulation.integrator = Integrator::Implicit;
    still.simulation.time_step = 1.0 / 60.0;
    let mut sim = Simulation::new(still).unwrap();
    run(&mut sim, 0.5);
    assert_eq!(sim.halvings(), 0);
}

/// What the viewer runs: the thesis demo (50 x 50, 400 cm^3 of trapped air) lifted 5 cm by its
/// centre over 1.5 s at 1/60 s with the interactive budget, then held for 1 s. The hand's peak
/// force lies within the explicit integrator's spread at nearby steps widened by 10 % (0.096 to
/// 0.168 N at 1/10000 to 1/30000 s, docs/reproduction.md; measured 0.095 N), the final contact
/// fraction within 10 % of the explicit 0.458 to 0.472 (measured 0.451), Boyle's law holds at
/// every step, and the held cloth comes to rest (kinetic energy below 1e-6 J; measured 9e-8
/// J). The budget is what makes it fast: 22 conjugate-gradient iterations a step here against
/// the converged budget's 237 (2.05 against 0.29 times real time on one thread,
/// docs/performance.md); required below 50.
#[test]
fn interactive_budget_pulls_the_thesis_demo_within_the_explicit_spread() {
    let mut cfg = lifted_demo(50, (0.25, 1.75, 0.05), Integrator::Implicit, 1.0 / 60.0);
    cfg.simulation.implicit_budget = wetcloth::SolveBudget::Interactive;
    // The hand stays at 5 cm after the lift.
    cfg.grabs[0].keys.push(wetcloth::GrabKey {
        time: 2.75,
        offset: Vec3::new(0.0, 0.05, 0.0),
    });
    let k = cfg.air.atmospheric_pressure * cfg.air.trapped_air;
    let mut sim = Simulation::new(cfg).unwrap();
    let mut peak: Real = 0.0;
    let steps = (2.75 * 60.0) as usize;
    for _ in 0..steps {
        sim.step().expect("stable step");
        peak = peak.max(sim.grab_force().length());
        let m = sim.metrics();
        assert!(
            (m.air_pressure * m.air_volume - k).abs() < 1e-9 * k,
            "Boyle at t = {}: {m:?}",
            sim.time()
        );
    }
    let m = sim.metrics();
    assert!(
        (0.096 * 0.9..=0.168 * 1.1).contains(&peak),
        "peak hand force {peak} N"
    );
    assert!(
        (0.458 * 0.9..=0.472 * 1.1).contains(&m.contact_fraction),
        "{m:?}"
    );
    assert!(m.kinetic_energy < 1e-6, "held cloth not at rest: {m:?}");
    let per_step = sim.solver_iterations() as Real / steps as Real;
    assert!(per_step < 50.0, "{per_step} iterations a step");
}
