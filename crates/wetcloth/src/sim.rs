//! The simulation and its step (thesis 3.2, fig. 3.4).

use crate::air::AirModel;
use crate::checkpoint::{Checkpoint, RestoreError};
use crate::checks::{self, EnergyAudit};
use crate::collide::contact;
use crate::collide::mesh_self::MeshSelf;
use crate::collide::self_collision::{ExemptPairs, SelfCollision};
use crate::constraints::strain_limit;
use crate::control::{Attachment, Control, Grab, GrabMotion, GrabPick, attach};
use crate::error::{ConfigError, StepError};
use crate::exec;
use crate::integrate::{Air, Fused, IntegratorState};
use crate::math::{Real, Soa, Vec3};
use crate::measure::Measures;
use crate::metrics::FrameMetrics;
use crate::model::{Grid, Model};
use crate::params::SimConfig;
use crate::state::State;

pub use crate::checks::BLOWUP_STRETCH;
pub use crate::exec::{PARALLEL_MIN_PARTICLES, PARALLEL_MIN_PARTICLES_IN_POOL};

/// Most times the implicit integrator halves one step ([`Simulation::step`]): down to a
/// sixteenth of the time step.
pub const MAX_HALVINGS: u32 = 4;

/// How far beyond the strain limit, as a share of the limit, a step of the implicit integrator
/// may end before it is taken again as two of half the time step: 0.25 (a 10 % limit holds
/// to 12.5 %).
pub const HALVING_STRETCH: Real = 0.25;

/// A wet cloth on its colliders, with trapped air and grabs.
///
/// Holds the configuration, the static [`Model`] built from it, the [`State`] that changes
/// every step, the user's [`Control`], the air model, and the scratch of the integrator and the
/// corrections. [`Simulation::step`] advances by one time step.
#[derive(Clone, Debug)]
pub struct Simulation {
    config: SimConfig,
    model: Model,
    state: State,
    control: Control,
    air: AirModel,
    integrator: IntegratorState,
    self_collision: Option<SelfCollision>,
    /// A mesh cloth's vertex-triangle and edge-edge self-contact (with `self_collision`); not
    /// part of a checkpoint: it keeps nothing from one step to the next but its candidate
    /// lists, which it rebuilds when it finds them missing.
    mesh_self: Option<MeshSelf>,
    /// The particle pairs self-collision leaves alone ([`Simulation::set_exempt`]).
    exempt: ExemptPairs,
    /// The cell measures (volume, stretch, finiteness) of the current state.
    measures: Measures,
    /// Scratch of the strain limiter.
    strain: strain_limit::Scratch,
    /// The energy budget of the blow-up checks.
    audit: EnergyAudit,
    /// Steps the implicit integrator took again as two of half the time step, since t = 0.
    halvings: u64,
    /// Scratch: the particles the water film pulls during the step being taken, with the
    /// pull (N) and their positions at its start (m), to count the film's work.
    film: Vec<(u32, Vec3, Vec3)>,
    /// The scene grab (`[[grab]]` index) each of the control's grabs belongs to: a grab
    /// holding several particles (`within`) is one control grab per particle.
    grab_of: Vec<u32>,
}

impl Simulation {
    /// Builds a simulation at t = 0 from a validated configuration.
    pub fn new(config: SimConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let mut model = Model::new(&config);
        let n = model.len();
        let rest = model.rest_positions(config.cloth.position);
        let mut control = Control::new(n, config.air.enabled);
        let mut grab_of = Vec::with_capacity(config.grabs.len());
        for (i, g) in config.grabs.iter().enumerate() {
            let held = match (&g.pick, &model.grid) {
                (Some(pick), _) => pick.particles(&rest),
                (None, Some(grid)) => vec![grid.index(g.particle[0], g.particle[1])],
                // The built-in grid run as a mesh (`model = "membrane"`) keeps its numbering.
                (None, None) if config.cloth.mesh.is_none() => {
                    let [nx, nz] = config.cloth.resolution;
                    let [i, j] = g.particle;
                    if i < nx && j < nz {
                        vec![j * nx + i]
                    } else {
                        Vec::new()
                    }
                }
                (None, None) => Vec::new(),
            };
            if held.is_empty() {
                return Err(ConfigError::Invalid {
                    key: format!("grab[{i}]"),
                    message: match &g.pick {
                        Some(GrabPick::Vertex(k)) => {
                            format!("vertex {k} is out of range: the cloth has {n} particles")
                        }
                        Some(_) => "no particle of the cloth is inside at t = 0".into(),
                        None => "`particle = [i, j]` names a grid particle: on a mesh cloth \
                                 use `vertex`, `near` or `within`"
                            .into(),
                    },
                });
            }
            for k in held {
                control
                    .grabs
                    .push(Grab::new(k, GrabMotion::Path(g.clone())));
                grab_of.push(i as u32);
            }
        }
        // Attachments after the scene's grabs (so `grab_of` still names those first).
        for (i, a) in config.attachments.iter().enumerate() {
            let held = a.pick.particles(&rest);
            if held.is_empty() {
                return Err(ConfigError::Invalid {
                    key: format!("attach[{i}]"),
                    message: match &a.pick {
                        GrabPick::Vertex(k) => {
                            format!("vertex {k} is out of range: the cloth has {n} particles")
                        }
                        _ => "no particle of the cloth is inside at t = 0".into(),
                    },
                });
            }
            let collider = &model.colliders[a.collider];
            for k in held {
                let attachment = Attachment {
                    attach: i as u32,
                    collider: a.collider as u32,
                    binding: attach::bind(collider, rest.get(k)),
                };
                match a.stiffness {
                    None => control
                        .grabs
                        .push(Grab::new(k, GrabMotion::Attached(attachment))),
                    Some(stiffness) => control.tethers.push(crate::control::Tether {
                        particle: k,
                        attachment,
                        stiffness,
                        points: [rest.get(k); 2],
                        force: Vec3::ZERO,
                    }),
                }
            }
        }
        if !control.tethers.is_empty() {
            model.contact_exempt = vec![u32::MAX; model.len()];
            for t in &control.tethers {
                model.contact_exempt[t.particle] = t.attachment.collider;
            }
        }
        // The seeded pockets' particles; at rest, the cloth over them lifted to hold their air.
        let seeds = crate::air::seeds::SeedLayout::new(&config, &model);
        let mut sim = Self {
            grab_of,
            state: State::at_rest(crate::air::pockets::lift_seeds(
                &config.air,
                &model,
                &seeds,
                rest,
            )),
            control,
            air: AirModel::Thesis(crate::air::Bubble::new(config.air.trapped_air)),
            integrator: IntegratorState::new(
                config.simulation.integrator,
                config.simulation.implicit_budget,
                &model,
            ),
            self_collision: config
                .cloth
                .self_collision
                .then(|| SelfCollision::new(n, 2.0 * model.radius)),
            mesh_self: match (&model.mesh, config.cloth.self_collision) {
                (Some(mesh), true) => Some(MeshSelf::new(mesh, 2.0 * model.radius)),
                _ => None,
            },
            // The seams' pairs close: their particles do not push each other apart.
            exempt: model.seams.as_ref().map_or_else(ExemptPairs::default, |s| {
                ExemptPairs::new(n, s.exempt_pairs()).expect("validated seams")
            }),
            measures: Measures::for_layout(model.layout(), AirModel::keeps_cells(&config.air)),
            strain: strain_limit::Scratch::default(),
            audit: EnergyAudit::default(),
            halvings: 0,
            film: Vec::new(),
            model,
            config,
        };
        sim.remeasure_and_check()
            .map_err(|e| ConfigError::Invalid {
                key: "cloth.position".into(),
                message: e.to_string(),
            })?;
        // The air of the start: measured, then the model built on it.
        sim.air = AirModel::new(
            &sim.config.air,
            &sim.model,
            &sim.state,
            &sim.measures,
            &seeds.seed_of,
        );
        if sim.air.bubble().is_some() {
            let volume = sim.measures.totals().volume;
            sim.air.finish_step(
                &sim.config.air,
                &sim.model,
                &sim.state,
                &sim.measures,
                volume,
                0.0,
            );
        }
        sim.settle_air_history();
        sim.restart_audit();
        Ok(sim)
    }

    /// The configuration the simulation was built from.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// The static model: grid, masses, colliders.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The state: positions, motion, contacts, step count.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The user's input: grabs and the air switch.
    pub fn control(&self) -> &Control {
        &self.control
    }

    /// The air model and its state.
    pub fn air(&self) -> &AirModel {
        &self.air
    }

    /// The particle grid. Panics on a mesh cloth (see [`Simulation::model`]'s `layout`).
    pub fn grid(&self) -> &Grid {
        self.model.grid()
    }

    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        self.model.len()
    }

    /// Each `[[grab]]`'s force on the cloth during the last step, N, summed over the particles
    /// it holds, with how many it holds: one entry per scene grab, in scene order.
    pub fn grab_forces(&self) -> Vec<(usize, Vec3)> {
        let mut out = vec![(0usize, Vec3::ZERO); self.config.grabs.len()];
        for (g, &i) in self.control.grabs.iter().zip(&self.grab_of) {
            let o = &mut out[i as usize];
            o.0 += 1;
            o.1 += g.force();
        }
        out
    }

    /// Particle positions at the current time, m (structure of arrays).
    pub fn positions(&self) -> &Soa {
        &self.state.x
    }

    /// Particle positions one step earlier, m.
    pub fn previous_positions(&self) -> Soa {
        self.state.previous_positions(self.time_step())
    }

    /// Particle velocities, m/s.
    pub fn velocities(&self) -> Soa {
        self.state.velocities(self.time_step())
    }

    /// Mass of one particle, kg.
    pub fn particle_mass(&self) -> Real {
        self.model.particle_mass
    }

    /// Radius of a particle's collision sphere, m.
    pub fn particle_radius(&self) -> Real {
        self.model.radius
    }

    /// Cloth area per particle S, m^2.
    pub fn area_per_particle(&self) -> Real {
        self.model.area_per_particle
    }

    /// Simulated time, s.
    pub fn time(&self) -> Real {
        self.state.steps as Real * self.config.simulation.time_step
    }

    /// Steps taken since t = 0.
    pub fn step_count(&self) -> u64 {
        self.state.steps
    }

    /// Steps the implicit integrator took again as two of half the time step since this
    /// simulation was built (counting each halving, nested ones too): where, with a strain
    /// limit, a step of the configured size would break it by more than [`HALVING_STRETCH`]
    /// times the limit, or blow up. Zero for the explicit integrator and without a strain
    /// limit.
    pub fn halvings(&self) -> u64 {
        self.halvings
    }

    /// The time step, s.
    pub fn time_step(&self) -> Real {
        self.config.simulation.time_step
    }

    /// Volume of the trapped air, m^3: the bubble's (eq. 3.10; 0 without a sticking plane), or
    /// with the pockets model the sealed pockets' together.
    pub fn air_volume(&self) -> Real {
        self.air.volume()
    }

    /// Pressure of the trapped air, Pa: the bubble's by Boyle's law, or with the pockets model
    /// the sealed pockets' volume-weighted mean (atmospheric without any). With the air force
    /// off the cloth is treated as permeable, and the pressure under it is atmospheric.
    pub fn air_pressure(&self) -> Real {
        self.air
            .pressure(&self.config.air, &self.model, self.control.air_enabled)
    }

    /// Trapped air now, m^3 at atmospheric pressure: the scene's `trapped_air` plus what has
    /// leaked in since (see `AirParams::leak_conductance`), or the sealed pockets' together.
    pub fn trapped_air(&self) -> Real {
        self.air.trapped_air()
    }

    /// Number of sealed pockets of air (the thesis' single bubble counts as one).
    pub fn pocket_count(&self) -> usize {
        self.air.pocket_count()
    }

    /// The sealed pockets as the outputs report them (`pockets.csv`; the thesis' bubble is
    /// pocket 0).
    pub fn pocket_reports(&self) -> Vec<crate::air::PocketReport> {
        self.air
            .reports(&self.config.air, &self.model, self.control.air_enabled)
    }

    /// The bubble pressure the last step's pressure force used, Pa: Boyle's law at the start of
    /// the step ([`crate::PressureSolve::Explicit`]) or the predicted end-of-step pressure
    /// ([`crate::PressureSolve::Implicit`]); [`Simulation::air_pressure`] is Boyle's law on the
    /// current state. With the pockets model, the pockets' mean pressure.
    pub fn applied_pressure(&self) -> Real {
        match self.air.bubble() {
            Some(b) => b.applied_pressure,
            None => self.air_pressure(),
        }
    }

    /// Length of the cloth's border lifted off every collider now, m (see
    /// [`crate::air::leak::open_border_length`]).
    pub fn open_border_length(&self) -> Real {
        crate::air::leak::open_border_length(
            &self.model,
            &self.state.x,
            self.model.radius + self.config.air.seal_distance,
        )
    }

    /// Whether the pressure force acts.
    pub fn air_enabled(&self) -> bool {
        self.control.air_enabled
    }

    /// Turns the pressure force on or off (the demo's button 1). Turning it on needs a sticking
    /// plane; without one the call is ignored and returns false.
    pub fn set_air_enabled(&mut self, on: bool) -> bool {
        self.control.air_enabled = on && self.model.sticking.is_some();
        self.control.air_enabled == on
    }

    /// Whether particle `k` touched a collider during the last step.
    pub fn in_contact(&self, k: usize) -> bool {
        self.state.contact[k]
    }

    /// The grabs.
    pub fn grabs(&self) -> &[Grab] {
        &self.control.grabs
    }

    /// Adds a grab; returns its index.
    pub fn add_grab(&mut self, grab: Grab) -> usize {
        self.control.grabs.push(grab);
        self.control.grabs.len() - 1
    }

    /// Removes grab `index` (the particle is released with its current velocity).
    pub fn remove_grab(&mut self, index: usize) -> Grab {
        self.control.remove(index)
    }

    /// Mutable access to grab `index` (to move an interactive target).
    pub fn grab_mut(&mut self, index: usize) -> &mut Grab {
        &mut self.control.grabs[index]
    }

    /// Each `[[attach]]`'s force on the cloth during the last step, N, summed over the
    /// particles it holds, with how many it holds: one entry per attachment, in scene order.
    pub fn attach_forces(&self) -> Vec<(usize, Vec3)> {
        let mut out = vec![(0usize, Vec3::ZERO); self.config.attachments.len()];
        for g in &self.control.grabs {
            if let GrabMotion::Attached(a) = &g.motion {
                let o = &mut out[a.attach as usize];
                o.0 += 1;
                o.1 += g.force();
            }
        }
        for t in &self.control.tethers {
            let o = &mut out[t.attachment.attach as usize];
            o.0 += 1;
            o.1 += t.force;
        }
        out
    }

    /// Summed force of every attachment on the cloth during the last step, N.
    pub fn attach_force(&self) -> Vec3 {
        self.control
            .grabs
            .iter()
            .filter(|g| matches!(g.motion, GrabMotion::Attached(_)))
            .map(|g| g.force)
            .chain(self.control.tethers.iter().map(|t| t.force))
            .sum()
    }

    /// Summed force of all grabs on the cloth during the last step, N.
    pub fn grab_force(&self) -> Vec3 {
        self.control
            .grabs
            .iter()
            .filter(|g| !matches!(g.motion, GrabMotion::Attached(_)))
            .map(|g| g.force)
            .sum()
    }

    /// Conjugate-gradient iterations the implicit integrator took over every step this
    /// simulation made (all their solves; a measure of its cost; 0 with position Verlet). Not
    /// part of a checkpoint: a restored simulation counts from 0.
    pub fn solver_iterations(&self) -> u64 {
        self.integrator.solver_iterations()
    }

    /// Heap memory the simulation holds, bytes: model, state, control, integrator scratch,
    /// measures, corrections and the self-collision lists (the thread pool's own per-thread
    /// spring rows, a few rows each, are not counted).
    pub fn memory_bytes(&self) -> usize {
        self.model.heap_bytes()
            + self.state.heap_bytes()
            + self.control.heap_bytes()
            + self.integrator.heap_bytes()
            + self.measures.heap_bytes()
            + self.strain.heap_bytes()
            + self
                .self_collision
                .as_ref()
                .map_or(0, SelfCollision::heap_bytes)
            + self.mesh_self.as_ref().map_or(0, MeshSelf::heap_bytes)
            + self.exempt.heap_bytes()
    }

    /// Number of self-collision neighbour-list rebuilds so far.
    pub fn self_collision_rebuilds(&self) -> u64 {
        self.self_collision.as_ref().map_or(0, |s| s.rebuilds)
    }

    /// A mesh cloth's vertex-triangle and edge-edge self-contact (see
    /// [`crate::collide::mesh_self`]): `None` on the grid or without `self_collision`.
    pub fn mesh_self(&self) -> Option<&MeshSelf> {
        self.mesh_self.as_ref()
    }

    /// Exempts particle pairs from self-collision, replacing any exempted before: the particle
    /// spheres of a pair are not pushed apart, and on a mesh cloth neither particle is pushed
    /// from the triangles and edges holding the other. For seams, two panels sewn particle
    /// pair by particle pair, which must close. Either order names a pair; an empty list
    /// exempts none. Refused (nothing changed) for a particle out of range or paired with
    /// itself. The pairs are not part of a checkpoint: set them again on a restored
    /// simulation; [`Simulation::reset`] keeps them. The seams' pairs (`[[cloth.seam]]`) are
    /// always exempt, whatever this is given.
    pub fn set_exempt(&mut self, pairs: &[[u32; 2]]) -> Result<(), ConfigError> {
        let seams = self
            .model
            .seams
            .as_ref()
            .map_or(&[][..], |s| s.exempt_pairs());
        let all: Vec<[u32; 2]> = seams.iter().chain(pairs).copied().collect();
        self.exempt =
            ExemptPairs::new(self.model.len(), &all).map_err(|message| ConfigError::Invalid {
                key: "exempt".into(),
                message,
            })?;
        if let Some(m) = &mut self.mesh_self {
            m.invalidate();
        }
        Ok(())
    }

    /// The particle pairs self-collision leaves alone ([`Simulation::set_exempt`]).
    pub fn exempt(&self) -> &ExemptPairs {
        &self.exempt
    }

    /// Replaces the particle positions (m) at the current and the previous step, e.g. to start
    /// from a draped or folded shape; the velocity is `(positions - previous) / dt`. Both must
    /// have one entry per particle.
    pub fn set_state(&mut self, positions: Soa, previous: Soa) -> Result<(), StepError> {
        assert_eq!(
            positions.len(),
            self.model.len(),
            "one position per particle"
        );
        assert_eq!(
            previous.len(),
            self.model.len(),
            "one previous position per particle"
        );
        let dt = self.time_step();
        let velocities = Soa::from_vec3(
            &(0..positions.len())
                .map(|k| (positions.get(k) - previous.get(k)) / dt)
                .collect::<Vec<_>>(),
        );
        self.state.x = positions;
        match &mut self.state.motion {
            crate::state::Motion::Previous(p) => *p = previous,
            crate::state::Motion::Velocity(_) => self.state.set_velocities(&velocities, dt),
        }
        self.restart_lists_and_measures()
    }

    /// Replaces the particle positions (m) and velocities (m/s).
    pub fn set_positions_and_velocities(
        &mut self,
        positions: Soa,
        velocities: &Soa,
    ) -> Result<(), StepError> {
        assert_eq!(
            positions.len(),
            self.model.len(),
            "one position per particle"
        );
        assert_eq!(
            velocities.len(),
            self.model.len(),
            "one velocity per particle"
        );
        self.state.x = positions;
        self.state.set_velocities(velocities, self.time_step());
        self.restart_lists_and_measures()
    }

    fn restart_lists_and_measures(&mut self) -> Result<(), StepError> {
        if let Some(sc) = &mut self.self_collision {
            *sc = SelfCollision::new(self.model.len(), 2.0 * self.model.radius);
        }
        if let Some(m) = &mut self.mesh_self {
            m.invalidate();
        }
        self.remeasure_and_check()?;
        self.settle_air_history();
        self.restart_audit();
        Ok(())
    }

    /// Starts the energy budget from the current state, with the air as it is now: a large
    /// step may spend a bubble's whole work in the first step (a cloth slammed onto the
    /// table by a vacuum), after which no later volume shows it.
    fn restart_audit(&mut self) {
        self.audit = EnergyAudit::new(
            &self.model,
            &self.state,
            self.time_step(),
            self.external_work(),
        );
        if self.control.air_enabled {
            let difference =
                self.air
                    .largest_pressure_difference(&self.config.air, &self.model, true);
            self.audit.record_air(self.air.volume(), difference);
        }
    }

    /// The work done on the cloth from outside so far, J: the hands' and the moving colliders'
    /// (summed magnitudes), which the energy audit allows for.
    fn external_work(&self) -> Real {
        self.control.external_work()
    }

    /// Before a step: the particles the water film pulls onto the surface during it (the
    /// pockets model's sealed particles outside every pocket, `wet_adhesion * wetness * S`
    /// along the cloth normal), with their pulls (N) and positions, into `self.film`.
    fn start_film_work(&mut self) {
        self.film.clear();
        let Some(p) = self.air.pockets() else {
            return;
        };
        let model = &self.model;
        if !self.control.air_enabled || model.wet_adhesion <= 0.0 {
            return;
        }
        let x = &self.state.x;
        for (k, (&sealed, &q)) in p.sealed.iter().zip(&p.particle_pocket).enumerate() {
            if sealed && q == crate::air::pockets::NONE && model.wetness[k] > 0.0 {
                let pull = model.wet_adhesion * model.wetness[k] * model.area(k);
                self.film
                    .push((k as u32, model.normal(x, k) * -pull, x.get(k)));
            }
        }
    }

    /// After a step: adds the magnitude of the work the film's pulls of
    /// [`Simulation::start_film_work`] did over the particles' moves to the control's
    /// `film_work`, J.
    fn finish_film_work(&mut self) {
        let x = &self.state.x;
        let work: Real = self
            .film
            .iter()
            .map(|&(k, pull, from)| checks::work(pull, from, x.get(k as usize)).abs())
            .sum();
        self.control.film_work += work;
    }

    /// Forgets the air's history: the previous volume becomes the current one.
    fn settle_air_history(&mut self) {
        if let AirModel::Thesis(b) = &mut self.air {
            b.prev_volume = b.volume;
            b.applied_pressure =
                b.pressure(&self.config.air, &self.model, self.control.air_enabled);
        }
    }

    /// Resets to the state at t = 0 (the demo's button 3), keeping the air switch.
    pub fn reset(&mut self) -> Result<(), ConfigError> {
        let air = self.control.air_enabled;
        let exempt = std::mem::take(&mut self.exempt);
        *self = Self::new(self.config.clone())?;
        self.set_air_enabled(air);
        self.exempt = exempt;
        Ok(())
    }

    /// Per-frame metrics of the current state (the `metrics.csv` columns).
    pub fn metrics(&self) -> FrameMetrics {
        let (max_height, mut max_stretch, contact_fraction) =
            FrameMetrics::cloth(self.model.layout(), self.positions(), &self.state.contact);
        if let Some(f) = &self.model.fabric {
            max_stretch = f.membrane.max_stretch(self.positions());
        }
        FrameMetrics {
            time: self.time(),
            air_volume: self.air_volume(),
            air_pressure: self.air_pressure(),
            kinetic_energy: self.state.kinetic_energy_with(
                self.model.masses.as_deref(),
                self.particle_mass(),
                self.time_step(),
            ),
            max_stretch,
            contact_fraction,
            max_height,
            grab_force: self.grab_force().length(),
            trapped_air: self.trapped_air(),
            pocket_count: self.pocket_count() as Real,
            elastic_energy: self.model.elastic_energy(self.positions()),
            attach_force: self.attach_force().length(),
        }
    }

    /// Advances by one time step: thesis fig. 3.4, as these phases.
    ///
    /// 1. **Input** (3.2 step 1): each grab's target at `t + dt` ([`crate::control`]).
    /// 2. **Air load** (3.4-3.5): the bubble pressure `P_b` the pressure force uses during the
    ///    step, by Boyle's law (eq. 3.9) on the current volume or predicted at the end of the
    ///    step ([`crate::air`]).
    /// 3. **Integrate** (3.1-3.3): forces (gravity eq. 3.3, springs eq. 3.6, damping, pressure
    ///    `(P_b - P_a) S N` eq. 3.7 with the physical sign), the integrator's move (position
    ///    Verlet, eq. 3.1), contacts with the colliders (normal force and Coulomb friction,
    ///    eq. 3.4-3.5) and the hand placing grabbed particles (3.2 step 3), in one fused pass
    ///    that also measures the new state ([`crate::integrate`]).
    /// 4. **Leak**: air through the lifted border during the step ([`crate::air::leak`]).
    /// 5. **Corrections**: self-collision (3.1) with anything it moved pushed back out of the
    ///    colliders, then Provot strain limiting, last so that the limit holds at the end of the
    ///    step ([`crate::collide`], [`crate::constraints`]).
    /// 6. **Measure and check** (3.5): the new bubble volume (eq. 3.10) and the blow-up checks
    ///    ([`crate::checks`]); measured in phase 3 unless phase 5 moved particles.
    ///
    /// With the implicit integrator and a strain limit, a step whose end breaks the limit by
    /// more than a quarter of it, or fails a blow-up check, is taken again as two steps of half
    /// the time step (and so on, at most [`MAX_HALVINGS`] times): see
    /// [`Simulation::halvings`]. (Without a strain limit no step is halved: the snapshot each
    /// step keeps for it costs a sixth of a settled cloth's implicit step.)
    pub fn step(&mut self) -> Result<(), StepError> {
        let dt = self.config.simulation.time_step;
        let t_next = (self.state.steps + 1) as Real * dt;
        if self.config.simulation.integrator == crate::params::Integrator::Implicit
            && self.config.cloth.strain_limit > 0.0
        {
            self.adaptive_span(t_next, dt, 0)?;
        } else {
            self.span(t_next, dt)?;
        }
        self.state.steps += 1;
        self.audit_energy()
    }

    /// The time from `t_next - dt` to `t_next` as one step of `dt`, or, where that step breaks the
    /// strain limit by more than [`HALVING_STRETCH`] times the limit or fails a blow-up
    /// check, as two of half of it (each again so, `depth` halvings deep so far). The state
    /// carries Verlet's previous positions for `dt` before and after.
    fn adaptive_span(&mut self, t_next: Real, dt: Real, depth: u32) -> Result<(), StepError> {
        if depth >= MAX_HALVINGS {
            return self.span(t_next, dt);
        }
        let saved = self.checkpoint();
        let result = self.span(t_next, dt);
        let limit = self.config.cloth.strain_limit;
        let broken = self.measures.totals().stretch2.sqrt() > 1.0 + (1.0 + HALVING_STRETCH) * limit;
        if result.is_ok() && !broken {
            return result;
        }
        self.put_back(saved);
        self.halvings += 1;
        let half = 0.5 * dt;
        self.state.use_velocities(dt);
        self.state.use_previous_positions(half);
        self.adaptive_span(t_next - half, half, depth + 1)?;
        self.adaptive_span(t_next, half, depth + 1)?;
        self.state.use_velocities(half);
        self.state.use_previous_positions(dt);
        Ok(())
    }

    /// Phases 1 to 6 (without the energy audit) of a step of `dt` ending at `t_next`; the step
    /// count is left to the caller.
    fn span(&mut self, t_next: Real, dt: Real) -> Result<(), StepError> {
        // 1. Input.
        let colliders = &self.model.colliders;
        self.control
            .begin_step(&self.state.x, t_next, dt, &|a: &Attachment, t| {
                attach::place(&colliders[a.collider as usize], &a.binding, t)
            });

        // 2. Air load.
        let timing = self.air.begin_step(
            &self.config.air,
            &self.model,
            &self.state,
            &self.control,
            dt,
        );

        // 3. Integrate (and count the water film's work over the step). A mesh cloth's
        // self-contact keeps the positions at the start: the side each pair belongs on.
        if let Some(m) = &mut self.mesh_self {
            m.begin_step(&self.state.x);
        }
        self.start_film_work();
        let reference = self
            .self_collision
            .as_ref()
            .and_then(SelfCollision::reference);
        let moved2 = self.integrator.step(
            &self.model,
            &mut self.state,
            &mut self.control,
            Air {
                params: &self.config.air,
                model: &mut self.air,
                timing,
            },
            dt,
            Fused {
                reference,
                measures: &mut self.measures,
                rows_per_task: self
                    .model
                    .grid
                    .as_ref()
                    .and_then(|g| exec::row_split(g.nx, g.nz)),
                start: t_next - dt,
            },
        );

        // 4. Leak.
        self.air.leak(
            &self.config.air,
            &self.model,
            &self.state.x,
            self.control.air_enabled,
            dt,
        );

        // 5. Corrections.
        let corrected = self.correct(moved2, t_next, dt);

        self.finish_film_work();

        // 6. Measure and check.
        if corrected {
            self.remeasure_all();
        }
        self.finish_measures_at(t_next, dt)
    }

    /// The energy and reach audit of [`crate::checks`] (`EnergyAudit::check`) on the current
    /// state, now: `Err` if the cloth has more mechanical energy than the hands, the moving
    /// colliders, the air and the water film can have given it since the audit started, or a
    /// particle is farther than anything can have carried it.
    ///
    /// [`Simulation::step`] runs it only every [`checks::AUDIT_INTERVAL`] steps (one pass over
    /// the springs); a program that writes the state out (a frame, a checkpoint) runs it
    /// before each write and at the end, so that nothing written has escaped it whatever the
    /// number of steps between writes.
    pub fn audit(&self) -> Result<(), StepError> {
        self.audit.check(
            &self.model,
            &self.state,
            &self.control,
            self.time_step(),
            self.time(),
        )
    }

    /// The checks of [`crate::checks`] beyond the measures: the sign of the bubble, and every
    /// [`checks::AUDIT_INTERVAL`] steps the energy budget.
    fn audit_energy(&mut self) -> Result<(), StepError> {
        let time = self.time();
        if self.control.air_enabled {
            let volume = self.air.volume();
            checks::check_volume(&self.model, volume, time)?;
            let difference =
                self.air
                    .largest_pressure_difference(&self.config.air, &self.model, true);
            self.audit.record_air(volume, difference);
        }
        if self.state.steps.is_multiple_of(checks::AUDIT_INTERVAL) {
            let dt = self.time_step();
            self.audit
                .check(&self.model, &self.state, &self.control, dt, time)?;
        }
        Ok(())
    }

    /// Phase 5: self-collision and the collider re-projection, then strain limiting; `moved2` is how
    /// far (squared, m^2) the integrator moved particles from the self-collision lists'
    /// reference. Returns whether anything moved.
    fn correct(&mut self, moved2: Real, end: Real, dt: Real) -> bool {
        let (model, state, control) = (&self.model, &mut self.state, &self.control);
        // The colliders where they are at the end of the step (a copy only if any moves).
        let colliders: std::borrow::Cow<'_, [crate::collide::Collider]> = if model.moving.is_empty()
        {
            std::borrow::Cow::Borrowed(&model.colliders)
        } else {
            model.colliders.iter().map(|c| c.at(end)).collect()
        };
        // The grabbed particles' moves count too.
        let mut moved2 = moved2;
        if let Some(r) = self
            .self_collision
            .as_ref()
            .and_then(SelfCollision::reference)
        {
            for g in &control.grabs {
                moved2 = moved2.max((state.x.get(g.particle) - r.get(g.particle)).length_squared());
            }
        }
        let mut corrected = false;
        if let Some(sc) = &mut self.self_collision {
            // The rest distance's path chosen once, not per pair.
            let hits = match model.layout() {
                crate::model::Layout::Grid(g) => sc.solve_moved(
                    &|a, b| g.rest_distance(a, b),
                    &mut state.x,
                    &control.held,
                    &self.exempt,
                    Some(moved2),
                ),
                crate::model::Layout::Mesh(m, _) => sc.solve_moved(
                    &|a, b| (m.rest[b] - m.rest[a]).length(),
                    &mut state.x,
                    &control.held,
                    &self.exempt,
                    Some(moved2),
                ),
            };
            corrected |= hits > 0;
        }
        // A mesh cloth's triangles and edges: what the spheres let through (their edges are
        // longer than the spheres are wide).
        if let (Some(ms), crate::model::Layout::Mesh(m, _)) = (&mut self.mesh_self, model.layout())
        {
            let hits = ms.solve(
                m,
                &mut state.x,
                &model.inv_mass,
                &control.held,
                &self.exempt,
            );
            corrected |= hits > 0;
        }
        if corrected && !model.colliders.is_empty() {
            let (colliders, r, held) = (&*colliders, model.radius, &control.held);
            exec::map_in_place(&mut state.x, |k, p| {
                if held[k] {
                    p
                } else if let Some(c) = model.exempt_collider(k) {
                    // Not out of the collider a soft attachment binds it to.
                    let p = contact::project(&colliders[..c], p, r);
                    contact::project(&colliders[c + 1..], p, r)
                } else {
                    contact::project(colliders, p, r)
                }
            });
        }
        // Strain limiting last, so the limit holds at the end of the step. The implicit
        // integrator limits the strain inside its solve (springs that stiffen beyond the
        // limit), where the contacts' friction answers the pull: a projection after it would
        // slide particles the friction holds.
        let cloth = &self.config.cloth;
        // A mesh cloth's implicit step has no limit inside its solve: it is limited here too.
        if cloth.strain_limit > 0.0
            && (self.config.simulation.integrator == crate::params::Integrator::Verlet
                || model.mesh.is_some())
        {
            corrected |= match &model.fabric {
                Some(f) => strain_limit::limit_triangle_strain(
                    &f.membrane,
                    state,
                    &model.inv_mass,
                    &control.held,
                    cloth.strain_limit,
                    cloth.strain_limit_iterations,
                    &colliders,
                    model.radius,
                    &mut self.strain,
                ),
                None => strain_limit::limit_strain(
                    model.layout(),
                    state,
                    &model.inv_mass,
                    &control.held,
                    cloth.strain_limit,
                    cloth.strain_limit_iterations,
                    &colliders,
                    model.radius,
                    &mut self.strain,
                ),
            }
            .corrected;
            // A hand holds its particle against the limit's pull too (the springs' share is
            // in its force already).
            // Its work over the hand's move this step is the hands' too: the energy audit
            // counts it (the limit carries the hand's pull to the cloth beyond the springs).
            let mut work = 0.0;
            for &(k, pull) in self.strain.pulls() {
                let k = k as usize;
                let moved = match &self.state.motion {
                    crate::state::Motion::Previous(prev) => self.state.x.get(k) - prev.get(k),
                    _ => Vec3::ZERO,
                };
                for g in &mut self.control.grabs {
                    if g.particle == k {
                        g.force += pull / (dt * dt);
                        work += checks::work(pull / (dt * dt), Vec3::ZERO, moved).abs();
                    }
                }
            }
            self.control.hand_work += work;
        }
        corrected
    }

    /// Measures the current state from scratch and checks it.
    fn remeasure_and_check(&mut self) -> Result<(), StepError> {
        self.remeasure_all();
        self.finish_measures()
    }

    /// Re-measures every row of cells from the current positions.
    fn remeasure_all(&mut self) {
        let model = &self.model;
        self.measures.remeasure_layout(
            model.layout(),
            &self.state.x,
            model.sticking,
            model.radius,
            model
                .grid
                .as_ref()
                .and_then(|g| exec::row_split(g.nx, g.nz)),
        );
    }

    /// Checks the measures of the current state and hands the new volume to the air model.
    fn finish_measures(&mut self) -> Result<(), StepError> {
        self.finish_measures_at(self.time(), self.config.simulation.time_step)
    }

    /// [`Simulation::finish_measures`] at the end of a step of `dt` (s) ending at `time` (s).
    fn finish_measures_at(&mut self, time: Real, dt: Real) -> Result<(), StepError> {
        let totals = self.measures.totals();
        checks::check(&totals, time)?;
        self.air.finish_step(
            &self.config.air,
            &self.model,
            &self.state,
            &self.measures,
            totals.volume,
            dt,
        );
        Ok(())
    }

    /// Everything a step carries to the next, to continue later with
    /// [`Simulation::restore`] (see [`crate::checkpoint`]).
    pub fn checkpoint(&self) -> Checkpoint {
        Checkpoint {
            version: crate::checkpoint::CHECKPOINT_VERSION,
            state: self.state.clone(),
            control: self.control.clone(),
            air: self.air.clone(),
            self_collision: self.self_collision.clone(),
            measures: self.measures.clone(),
            audit: self.audit.clone(),
        }
    }

    /// The simulation of `config` continued from `checkpoint`: stepping it gives bit for bit
    /// what the simulation the checkpoint was taken from would have given. Refused when the
    /// checkpoint does not fit the configuration (another cloth, air model, integrator or
    /// format version).
    pub fn restore(config: SimConfig, checkpoint: Checkpoint) -> Result<Self, RestoreError> {
        let mut sim = Self::new(config)?;
        checkpoint.check_fits(&sim.config, sim.model.layout(), &sim.state, &sim.air)?;
        sim.put_back(checkpoint);
        Ok(sim)
    }

    /// Puts the parts of `checkpoint` (one that fits) in place of the simulation's own.
    fn put_back(&mut self, checkpoint: Checkpoint) {
        let Checkpoint {
            version: _,
            state,
            control,
            air,
            self_collision,
            measures,
            audit,
        } = checkpoint;
        (self.state, self.control, self.air) = (state, control, air);
        (self.self_collision, self.measures, self.audit) = (self_collision, measures, audit);
    }

    /// Takes `steps` steps (see [`Simulation::step`]), on the thread pool when the cloth is big
    /// enough to share out: the whole loop runs inside the pool, so each step's parallel passes
    /// cost tens of nanoseconds to start instead of microseconds. Stops at the first error.
    pub fn advance(&mut self, steps: u64) -> Result<(), StepError> {
        let pooled = rayon::current_num_threads() > 1
            && rayon::current_thread_index().is_none()
            && self.model.len() >= PARALLEL_MIN_PARTICLES_IN_POOL;
        let run = |sim: &mut Self| (0..steps).try_for_each(|_| sim.step());
        if pooled {
            rayon::scope(|_| run(self))
        } else {
            run(self)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Memory grows linearly with the particle count, at under 256 bytes a particle (so a
    /// million-particle cloth fits in a quarter of a gigabyte).
    #[test]
    fn memory_per_particle_is_small_and_constant() {
        let per_particle = |side: usize| {
            let mut sim = Simulation::new(crate::bench::thesis_workload(side)).unwrap();
            sim.advance(3).unwrap();
            sim.memory_bytes() as f64 / (side * side) as f64
        };
        let (small, large) = (per_particle(40), per_particle(160));
        assert!(large < 256.0, "{large} bytes per particle");
        assert!((small - large).abs() < 0.25 * large, "{small} vs {large}");
    }
}
