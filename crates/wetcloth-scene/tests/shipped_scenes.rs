//! The shipped scenes, run as a user runs them.

use std::path::Path;
use wetcloth::{Real, Simulation};

fn scene(name: &str) -> wetcloth_scene::Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    wetcloth_scene::parse(&text, &path).unwrap()
}

/// Symptom: `scenes/peel-leak.toml` ran at its own step (8.33e-5 s) and at 7.5e-5 s, but at
/// 6.25e-5, 5e-5 and 4.2e-5 s the whole cloth jumped off the table and the run blew up: a
/// smaller explicit step was less stable. Causes: (1) the implicit bubble pressure predicted
/// the end-of-step volume from the volume's own last change, ignoring the springs and letting
/// only particles off the table respond; around the tiny leaking bubble its prediction came out
/// 10 % off and, now and then, far too small, and the resulting over-pressure acted on the
/// whole cloth; (2) the thesis' pressure force, with the same area S for border particles and a
/// unit normal, is not the gradient of the volume, and on the peeled corner (a crease at the
/// border) it feeds energy into the crease's flapping. Fixes: the pressure is solved from the
/// step's coasting positions (springs and contacts included, see `air::bubble::EndOfStep`),
/// and the scene spreads the pressure by area (`pressure_force = "area"`). Here: the scene runs
/// at its own step and four smaller ones, and the outcome (air let in, bubble pressure, the
/// hand's force) agrees between them.
fn peel_leak_at(dt: Real) {
    let base = scene("peel-leak.toml").config;
    let mut cfg = base.clone();
    cfg.simulation.time_step = dt;
    let mut sim = Simulation::new(cfg).unwrap();
    let frames = 30;
    let per_frame = (base.simulation.duration / frames as Real / dt).round() as u64;
    let mut peak_energy: Real = 0.0;
    for _ in 0..frames {
        sim.advance(per_frame)
            .unwrap_or_else(|e| panic!("at dt = {dt} s: {e}"));
        peak_energy = peak_energy.max(sim.metrics().kinetic_energy);
    }
    let m = sim.metrics();
    // At its own step the scene ends with 2.8 cm^3 let in, the bubble at 93 kPa and the hand
    // pulling 4.8 N; smaller steps must agree within 30 %.
    assert!(peak_energy < 0.02, "dt = {dt} s: {peak_energy} J");
    assert!(
        m.air_pressure > 80e3 && m.air_pressure < 101_325.0,
        "dt = {dt} s: {} Pa",
        m.air_pressure
    );
    assert!(
        (m.trapped_air / 2.76e-6 - 1.0).abs() < 0.3,
        "dt = {dt} s: {} m^3 let in",
        m.trapped_air
    );
    assert!(
        (m.grab_force / 4.8 - 1.0).abs() < 0.3,
        "dt = {dt} s: {} N",
        m.grab_force
    );
}

/// Symptom: the air let in under `peel-leak`'s corner depended on the explicit step where it
/// first got in: at 1/10000 s none had entered by 0.33 s, at 1/20000 s the bubble had filled to
/// 83 kPa by 0.30 s. The leak's open border came from the step's contact flags, and a particle
/// counts as touching only if its step ends inside the surface: at 1/20000 s the flags of 92 %
/// of the cloth, lying on the table, dropped for 13 ms and the leak saw the whole border open.
/// Fix: the border is open where its gap to the surface exceeds the radius plus `[air]
/// seal_distance` (`air::leak::open_border_length`). Here: at 0.3 s (the corner lifted for
/// 50 ms) both steps have let in the same air, within 10 % (measured: 2.6e-8 m^3 at both, 0.2 %
/// apart, the bubble at 29 kPa).
#[test]
fn peel_leak_lets_in_the_same_air_at_two_explicit_steps() {
    let air_at = |dt: Real| {
        let mut cfg = scene("peel-leak.toml").config;
        cfg.simulation.time_step = dt;
        let mut sim = Simulation::new(cfg).unwrap();
        sim.advance((0.3 / dt).round() as u64).unwrap();
        let m = sim.metrics();
        (m.trapped_air, m.air_pressure)
    };
    let (coarse, p_coarse) = air_at(1e-4);
    let (fine, p_fine) = air_at(5e-5);
    assert!(coarse > 1e-8, "air gets in: {coarse} m^3");
    assert!(
        (fine / coarse - 1.0).abs() < 0.1,
        "{coarse} m^3 ({p_coarse} Pa) at 1e-4 s, {fine} m^3 ({p_fine} Pa) at 5e-5 s"
    );
}

/// `peel-leak`'s explicit reference reads a hand force 10 to 15 % below the implicit
/// integrator's from the moment air first gets in (0.28 s). The scene's explicit runs predict
/// the bubble's pressure from the coasting positions (`pressure_solve = "implicit"`), and while
/// air rushes in that prediction lets the corner's bubble grow twice as fast as the cloth's
/// motion does: at 0.30 s the hand holds 0.014 N against the implicit integrator's 0.914 N with
/// the bubble at 29 kPa. With the thesis' own pressure (Boyle's at the step's start, explicit)
/// the explicit integrator at 1/40000 s agrees with the implicit one at 1/600 s to 2.5 % on
/// every frame up to 0.75 s (measured: 0.2 % at 0.3 and 0.4 s, 2.2 % at 0.5 s, 2.4 % at 0.6 s,
/// 0.1 % at 0.75 s), and then goes unstable around the tiny bubble (147 kPa at 0.9 s), which is
/// why the scene predicts instead. Here: the frames to 0.75 s agree within 5 %.
#[test]
fn peel_leak_implicit_agrees_with_the_thesis_pressure_where_that_runs() {
    let forces = |cfg: wetcloth::SimConfig| {
        let dt = cfg.simulation.time_step;
        let mut sim = Simulation::new(cfg).unwrap();
        [0.3, 0.4, 0.5, 0.6, 0.75].map(|t: Real| {
            let steps = (t / dt).round() as u64 - sim.step_count();
            sim.advance(steps).unwrap();
            sim.metrics().grab_force
        })
    };
    let mut thesis = scene("peel-leak.toml").config;
    thesis.simulation.time_step = 1.0 / 40000.0;
    thesis.air.pressure_solve = wetcloth::PressureSolve::Explicit;
    let mut implicit = scene("peel-leak.toml").config;
    implicit.simulation.integrator = wetcloth::Integrator::Implicit;
    implicit.simulation.time_step = 1.0 / 600.0;
    let (a, b) = (forces(thesis), forces(implicit));
    for (fa, fb) in a.iter().zip(&b) {
        assert!(
            (fb / fa - 1.0).abs() < 0.05,
            "explicit {a:?} N, implicit {b:?} N"
        );
    }
}

#[test]
fn peel_leak_runs_at_its_own_step() {
    peel_leak_at(8.333e-5);
}

#[test]
fn peel_leak_runs_at_smaller_steps_7_5e_5() {
    peel_leak_at(7.5e-5);
}

#[test]
fn peel_leak_runs_at_smaller_steps_6_25e_5() {
    peel_leak_at(6.25e-5);
}

#[test]
fn peel_leak_runs_at_smaller_steps_5e_5() {
    peel_leak_at(5e-5);
}

#[test]
fn peel_leak_runs_at_smaller_steps_4_2e_5() {
    peel_leak_at(4.2e-5);
}

/// Fig. 4.3 on the fine, stiff cloth (`scenes/pinch-fine.toml`, 100 x 100, 200 000 / 10 000
/// N/m, the implicit integrator at 1/600 s): at the end of the lift the tent is cross-shaped,
/// ridges running out from the fingertip along the weave. Six cells out along a thread the
/// cloth stands higher than 4 sqrt 2 = 5.7 cells out along a diagonal, nearer the pinch, by
/// more than half a millimetre (a round cone would have it the other way round; measured: 4.67
/// against 3.78 mm, with the explicit integrator at 1/400 000 s too). The tent is some 250
/// particles, the rest of the cloth stays pressed flat, and away from the fingertip the threads
/// stretch less than 10 % (measured 5.9 %; the coarse `pinch-center` stretches 39 %).
#[test]
fn fine_pinch_lifts_a_cross_shaped_tent() {
    let cfg = scene("pinch-fine.toml").config;
    let mut sim = Simulation::new(cfg).unwrap();
    sim.advance((1.25 / sim.time_step()).round() as u64)
        .unwrap();
    let (nx, nz, dx, dz) = {
        let g = sim.grid();
        (g.nx, g.nz, g.dx, g.dz)
    };
    assert_eq!((nx, nz), (100, 100));
    let radius = sim.model().radius;
    let x = sim.positions();
    let h = |i: usize, j: usize| x.get(j * nx + i).y - radius;
    let c = 50;
    let threads = [h(c + 6, c), h(c - 6, c), h(c, c + 6), h(c, c - 6)];
    let diagonals = [
        h(c + 4, c + 4),
        h(c - 4, c - 4),
        h(c + 4, c - 4),
        h(c - 4, c + 4),
    ];
    let low = threads.iter().copied().fold(Real::INFINITY, Real::min);
    let high = diagonals.iter().copied().fold(0.0, Real::max);
    assert!(
        low > high + 0.5e-3,
        "threads {threads:?} m, diagonals {diagonals:?} m"
    );
    let lifted = (0..nx * nz).filter(|&k| x.get(k).y - radius > 1e-3).count();
    assert!((100..1000).contains(&lifted), "{lifted} particles lifted");
    assert!(sim.metrics().contact_fraction > 0.9);
    // The threads' stretch, both ends more than two cells from the fingertip's centre.
    let far = |i: usize, j: usize| i.abs_diff(c).max(j.abs_diff(c)) > 2;
    let mut stretch: Real = 0.0;
    for j in 0..nz {
        for i in 0..nx {
            let p = x.get(j * nx + i);
            if i + 1 < nx && far(i, j) && far(i + 1, j) {
                stretch = stretch.max((x.get(j * nx + i + 1) - p).length() / dx - 1.0);
            }
            if j + 1 < nz && far(i, j) && far(i, j + 1) {
                stretch = stretch.max((x.get((j + 1) * nx + i) - p).length() / dz - 1.0);
            }
        }
    }
    assert!(stretch < 0.10, "threads stretch {stretch}");
}

/// Symptom: `scenes/pockets-middle.toml` with the implicit integrator at 1/600 s blew up at
/// 0.59 s, once its 10 % strain limit bound against the vacuum pocket under the hand. Causes:
/// a sealed particle on the pocket's rim felt none of the vacuum, so a particle joining the
/// pocket took its whole load (3.6 N) at once, the first solve drove it through the table, and
/// the strain limit, judging springs by that solve, stiffened every spring around it. Fixes:
/// the rim's share of a vacuum as the explicit step spreads it, and the limit judges a particle
/// driven through a surface by its landing. Here: the whole scene at 1/600 s, the threads near
/// the limit at the end, the hand's force that of a held lift (tens of newtons).
#[test]
fn pockets_middle_runs_implicitly_at_1_600_s() {
    limit_holds_with_the_hand_in("pockets-middle.toml", 10.0..200.0);
}

/// Symptom: `scenes/pockets-middle.toml` with the implicit integrator ran at 1/600 s but blew
/// up at 1/550, 1/610, 1/620 and 1/700 s (at 0.64 to 1.9 s, threads at 20 to 120 times their
/// length) and read 15 to 250 N at the steps where it ran. Cause: the particles at the vacuum
/// pocket's edge hovered at the seal distance and sealed and opened on alternate steps, each
/// one's load jumping between the water film's pull (300 Pa) and the vacuum's share (51 to
/// 101 kPa): a period-two rocking of the rim that the strain limit's stiff springs, judged by
/// one such step's solve, turned into a blow-up. Fix: the scene sets the seal's wetting
/// hysteresis (`[air] seal_hysteresis = 0.5`: an open particle seals within half the seal
/// distance, a sealed one opens beyond all of it). Here the lift (to 1.3 s) at three of those
/// steps: no blow-up, the threads near the limit, the hand's force that of the held vacuum
/// (measured with the whole scene: 84.5 to 96.7 N at nine steps from 1/550 to 1/1200 s).
#[test]
fn pockets_middle_runs_implicitly_at_nearby_steps() {
    for rate in [550.0, 620.0, 700.0] {
        let sim = implicit_run("pockets-middle.toml", rate, Some(1.3));
        let m = sim.metrics();
        assert!(
            m.max_stretch < 0.12,
            "1/{rate} s: threads at {}",
            m.max_stretch
        );
        let force = sim.grab_force().length();
        assert!((40.0..150.0).contains(&force), "1/{rate} s: hand {force} N");
    }
}

/// `scenes/tilted-lift.toml` (a wet cloth sealed on a tilted plate mesh, an open two-sided
/// sheet, strain limit 10 %) with the implicit integrator at 1/600 s. It blew up at 1.71 s
/// while the step judged a landing on the sheet by the plain (unsigned) distance: a particle
/// the vacuum drove through the plate was measured from the far side, so it was never
/// "landed" and the strain limit stiffened every spring around it. Measured once: the hand
/// holds the vacuum tent with 52.3 N at the end (52.4 N at 1/1200 s, 52.6 N at 1/2400 s); the
/// explicit integrator's projection, which also slides cloth friction holds, reads 20.4 N
/// (without the limit the two agree: 17.2465 against 17.2418 N).
#[test]
fn tilted_lift_runs_implicitly_at_1_600_s() {
    limit_holds_with_the_hand_in("tilted-lift.toml", 30.0..80.0);
}

/// `scenes/pockets-merge.toml`: two pockets of air under a wet cloth, whose seam a hand lifts
/// until they merge. The hand's peak force (over every step, a spike at the merge) with the
/// implicit integrator agrees with the explicit one at the scene's own step, and converges to it
/// as the step shrinks: backward Euler's error on the spike is first order in the step.
/// Measured since the seeded pockets start at rest (lifted to hold their air at atmospheric
/// pressure, a sharper merge): explicit 27.18 N; implicit 30.80 N at 1/300 s, 30.00 N at 1/600 s
/// (+10.4 %), 29.06 N at 1/1200 s, 28.28 N at 1/2400 s. (Before, from a flat start: 26.91
/// against 28.61 N, -5.9 %.) A sealed particle on a pocket's rim feels its share of the
/// pocket's pressure in both; while the implicit step left that share out, its hand pulled
/// 30.58 N from the flat start (+6.9 %).
#[test]
fn pockets_merge_hand_agrees_between_the_integrators() {
    let peak = |mut sim: Simulation, steps: u64| {
        let mut peak: Real = 0.0;
        for _ in 0..steps {
            sim.step().unwrap();
            peak = peak.max(sim.grab_force().length());
        }
        peak
    };
    let cfg = scene("pockets-merge.toml").config;
    let own = (cfg.simulation.duration / cfg.simulation.time_step).round() as u64;
    let explicit = peak(Simulation::new(cfg.clone()).unwrap(), own);
    let implicit_at = |rate: Real| {
        let mut imp = cfg.clone();
        imp.simulation.integrator = wetcloth::Integrator::Implicit;
        imp.simulation.time_step = 1.0 / rate;
        let steps = (cfg.simulation.duration * rate).round() as u64;
        peak(Simulation::new(imp).unwrap(), steps)
    };
    let (coarse, fine) = (implicit_at(600.0), implicit_at(1200.0));
    assert!(
        explicit > 20.0,
        "the hand holds the merged pocket: {explicit} N"
    );
    let off = coarse / explicit - 1.0;
    assert!(
        off.abs() < 0.12,
        "{coarse} N against {explicit} N ({off:+.3})"
    );
    let closer = fine / explicit - 1.0;
    assert!(
        closer.abs() < 0.75 * off.abs(),
        "halving the step brings the implicit spike closer: {off:+.3} at 1/600 s, \
         {closer:+.3} at 1/1200 s"
    );
}

/// The shipped scene `name` (a 10 % strain limit binding under a held lift) at 1/600 s with
/// the implicit integrator: the threads end within 12 % and the hand's force in `range` (N).
fn limit_holds_with_the_hand_in(name: &str, range: std::ops::Range<Real>) {
    let sim = implicit_at_1_600_s(name);
    let m = sim.metrics();
    assert!(m.max_stretch < 0.12, "{name}: threads at {}", m.max_stretch);
    let force = sim.grab_force().length();
    assert!(range.contains(&force), "{name}: hand {force} N");
}

/// The shipped scene `name` run to its end with the implicit integrator at 1/600 s.
fn implicit_at_1_600_s(name: &str) -> Simulation {
    implicit_run(name, 600.0, None)
}

/// Symptom: `scenes/ball-pull.toml` (a wet cloth over a ball pulled down out of it) with the
/// implicit integrator at 1/600 s took 179 conjugate-gradient iterations a step, and solves of
/// 4000 (the cap), where it had taken 29. Cause: a slide that a solve had stopped (its speed
/// 1e-16 to 1e-29 m/s, round-off) took the round-off's direction for the next solve's
/// friction, off the tangent plane on the ball's curve, a force the filtered solve cannot
/// balance. Fix: a slide at a round-off speed is stopped, and a slide's direction is taken in
/// the tangent plane. Here: the whole scene, at most 60 iterations a step on average
/// (measured 25.9; iteration counts, not wall time).
#[test]
fn ball_pull_solves_implicitly_in_few_iterations() {
    let sim = implicit_run("ball-pull.toml", 600.0, None);
    let per_step = sim.solver_iterations() as Real / sim.step_count() as Real;
    assert!(per_step < 60.0, "{per_step} iterations a step");
}

/// The shipped scene `name` run with the implicit integrator at `1 / rate` s for `seconds`
/// (its whole duration with `None`).
fn implicit_run(name: &str, rate: Real, seconds: Option<Real>) -> Simulation {
    let mut cfg = scene(name).config;
    cfg.simulation.integrator = wetcloth::Integrator::Implicit;
    cfg.simulation.time_step = 1.0 / rate;
    let steps = (seconds.unwrap_or(cfg.simulation.duration) * rate).round() as u64;
    let mut sim = Simulation::new(cfg).unwrap();
    sim.advance(steps)
        .unwrap_or_else(|e| panic!("{name} at 1/{rate} s: {e}"));
    sim
}

/// Whether `p` is inside the closed triangle mesh (`positions`, `triangles`): the parity of the
/// crossings of a ray from `p` along a fixed, slightly skewed direction (no face of a body is
/// parallel to it), counted triangle by triangle (Moller-Trumbore). Independent of the
/// simulator's own contact queries.
fn inside(p: [f64; 3], positions: &[wetcloth::Vec3], triangles: &[[u32; 3]]) -> bool {
    let d = wetcloth::Vec3::new(0.9123, 0.2987, 0.2797).normalize();
    let p = wetcloth::Vec3::from(p);
    let mut crossings = 0;
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let (e1, e2) = (b - a, c - a);
        let h = d.cross(e2);
        let det = e1.dot(h);
        if det.abs() < 1e-18 {
            continue;
        }
        let s = p - a;
        let u = s.dot(h) / det;
        if !(0.0..=1.0).contains(&u) {
            continue;
        }
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        if v < 0.0 || u + v > 1.0 {
            continue;
        }
        if e2.dot(q) / det > 0.0 {
            crossings += 1;
        }
    }
    crossings % 2 == 1
}

/// `scenes/shirt-arms-wet.toml` through the arms' fastest rise (to 0.9 s: the hands rise at
/// 1.2 to 1.7 m/s from 0.4 s on, through the sleeves): at every frame no particle of the shirt
/// is inside the posed mannequin, by a ray-parity test of each particle against the body's
/// triangles where the motion puts them then.
#[test]
fn the_wet_shirt_stays_outside_the_moving_body() {
    use wetcloth::Surface;
    let cfg = scene("shirt-arms-wet.toml").config;
    let body = cfg
        .colliders
        .iter()
        .find(|c| c.is_deforming())
        .expect("the mannequin")
        .clone();
    let per_frame = (1.0 / 30.0 / cfg.simulation.time_step).round() as u64; // steps in 1/30 s
    let mut sim = Simulation::new(cfg).unwrap();
    let mut checked = 0;
    for _ in 0..27 {
        sim.advance(per_frame).unwrap();
        let Surface::Mesh(posed) = body.surface_at(sim.time()) else {
            unreachable!()
        };
        let (lo, hi) = posed.positions.iter().fold(
            (
                wetcloth::Vec3::splat(f64::INFINITY),
                wetcloth::Vec3::splat(f64::NEG_INFINITY),
            ),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let x = sim.positions();
        for k in 0..x.len() {
            let p = x.get(k);
            if p.cmplt(lo).any() || p.cmpgt(hi).any() {
                continue;
            }
            checked += 1;
            assert!(
                !inside(p.to_array(), &posed.positions, &posed.triangles),
                "particle {k} at {p} is inside the body at t = {} s",
                sim.time()
            );
        }
    }
    assert!(
        checked > 10_000,
        "{checked} particle-frames near the body checked"
    );
}
