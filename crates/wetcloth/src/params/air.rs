//! `[air]`: the trapped air and how its pressure is solved.

use crate::math::{Real, Vec3};

/// The trapped air (`[air]` in a scene file), thesis 3.4.
#[derive(Clone, Debug, PartialEq)]
pub struct AirParams {
    /// Whether the pressure force acts (the demo's button 1); with the pockets model, the water
    /// film's pull (`[cloth] wet_adhesion`) too. Default true.
    pub enabled: bool,
    /// Atmospheric pressure P_a, Pa. Default 101325; range [0, 1e7].
    pub atmospheric_pressure: Real,
    /// Trapped air v0: the air under the cloth, as its volume at atmospheric pressure, m^3.
    /// Default 0 (thesis: 0 and 400 cm^3); range [0, 1e3].
    pub trapped_air: Real,
    /// Leak conductance of the cloth's border, m^2/s: where the border is lifted off the
    /// surface, air flows into an under-pressured bubble (or out of an over-pressured one) at
    /// `leak_conductance * L_open * (P_a - P_b) / P_a` cubic metres per second (measured at
    /// atmospheric pressure), `L_open` the length of border lifted more than `seal_distance`
    /// beyond its radius off every surface. The
    /// thesis' future work ("the amount of air should change while the cloth deforms").
    /// Default 0 (sealed, as in the thesis); range [0, 10].
    pub leak_conductance: Real,
    /// How the step evaluates the bubble pressure of the pressure force. Default
    /// [`PressureSolve::Implicit`].
    pub pressure_solve: PressureSolve,
    /// How the pressure force is spread over the particles. Default [`PressureForce::Thesis`].
    pub pressure_force: PressureForce,
    /// The air model. Default [`AirModelKind::Thesis`].
    pub model: AirModelKind,
    /// How far beyond its collision radius a particle still seals against a surface, m: with
    /// the pockets model, where a pocket's rim runs; with the thesis' bubble and a
    /// `leak_conductance`, a border particle lifted further lets air through. Default 0.0005;
    /// range [0, 0.1].
    pub seal_distance: Real,
    /// With the pockets model: wetting hysteresis of the seal, a fraction of `seal_distance`. A
    /// sealed particle stays sealed out to `seal_distance` beyond its radius; an open one seals
    /// only within `seal_distance * (1 - seal_hysteresis)`: the water film's contact line
    /// recedes further than it advances. Without it (0) a particle whose gap hovers at the seal
    /// distance can seal and open on alternate steps, its load jumping between the water
    /// film's pull and a neighbouring vacuum's (101 kPa) each time (`scenes/pockets-middle.toml`
    /// sets 0.5). At 1 an open particle seals only where it touches. Default 0 (a cloth leaving a
    /// ball keeps its brief suction, `scenes/ball-pull.toml`); range [0, 1].
    pub seal_hysteresis: Real,
    /// With the pockets model: the least wetness at which a particle seals, 0..1. Default 0.5;
    /// range (0, 1] (dry cloth never seals).
    pub seal_wetness: Real,
    /// With the pockets model: Darcy permeability of the soaked fabric, m/(s Pa): a pocket of
    /// cloth area `A` at pressure `P` loses `permeability * A * (P - P_a)` m^3 of air (at
    /// atmospheric pressure) per second through the weave. Default 0 (water seals the weave);
    /// range [0, 1].
    pub permeability: Real,
    /// With the pockets model: Darcy permeability of dry fabric, m/(s Pa). A particle of
    /// wetness `w` has `permeability + (dry_permeability - permeability) (1 - w)^3` (the water
    /// closes the pores fast as the cloth wets). Default 1e-4 (a satin weave: about 10 litres per
    /// m^2 and second at 100 Pa, so a pocket under dry cloth empties in well under a second);
    /// range [0, 1].
    pub dry_permeability: Real,
    /// With the pockets model: air placed under the cloth at t = 0 (thesis fig. 1.3). Default
    /// none.
    pub pockets: Vec<PocketSeed>,
}

/// Which air model a simulation uses (`[air] model`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum AirModelKind {
    /// The thesis' single bubble (3.4): all the air under the cloth as one amount, its pressure
    /// on every particle.
    #[default]
    Thesis,
    /// Sealed pockets: where wet cloth touches a surface it seals; the air under the rest forms
    /// pockets, each with its own amount and pressure, and a pocket that reaches the cloth's
    /// border is open to the room.
    Pockets,
}

impl AirModelKind {
    /// Both choices.
    pub const ALL: [AirModelKind; 2] = [AirModelKind::Thesis, AirModelKind::Pockets];

    /// The scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            AirModelKind::Thesis => "thesis",
            AirModelKind::Pockets => "pockets",
        }
    }

    /// Parses a scene-file name.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == s)
    }
}

/// Air under the cloth at t = 0 (`[[air.pocket]]`): the particles within `radius` of `center`
/// start unsealed and hold `amount`, at rest at atmospheric pressure: the cloth over them starts
/// lifted into a shallow cap (at most a tenth as high as wide, its footprint widened beyond
/// `radius` where the amount needs more) whose measured gap volume is `amount`
/// (`air::pockets::lift_seeds`). On the grid (either `[cloth] model`) the region is a disc in
/// the cloth's rest coordinates; on a mesh cloth, a ball about `point`.
#[derive(Clone, Debug, PartialEq)]
pub struct PocketSeed {
    /// Centre, m, as (x, z) from the cloth's centre at rest (the grid). Default (0, 0); each in
    /// [-1e3, 1e3]. On a mesh cloth, `point`'s x and z (not used).
    pub center: [Real; 2],
    /// Radius, m: of the disc (grid) or the ball (mesh). Required; range (0, 1e3].
    pub radius: Real,
    /// Air, m^3 at atmospheric pressure. Required; range [0, 1e3].
    pub amount: Real,
    /// On a mesh cloth: the seed's centre in scene coordinates at t = 0, m (a 3-component
    /// `center`); the particles within `radius` of it at t = 0 are the seed's, and at least
    /// one must be. Each component in [-1e4, 1e4]. `None` on the grid.
    pub point: Option<Vec3>,
}

/// How the pressure difference becomes a force on each particle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PressureForce {
    /// The thesis' eq. 3.7: `(P_b - P_a) S N` with `S` the rest area per particle (the same for
    /// every particle, border ones included) and `N` the unit normal.
    #[default]
    Thesis,
    /// `(P_b - P_a) A_i`, with `A_i` the particle's share of the cloth's area vector: a third of
    /// the area vector `(b - a) x (c - a) / 2` of each triangle around it. On a flat cloth at rest
    /// it is the thesis' force for interior particles (area `dx dz`), and border particles get
    /// the area they actually bound (half at an edge, a sixth or a third at a corner). It is the
    /// gradient of the volume the cloth encloses, so the pressure does no net work around a
    /// closed cycle of shapes; the thesis' force, with a constant `S` and a unit normal, is not
    /// a gradient, and where the cloth creases at a border (a corner peeled under suction) it
    /// can feed energy into the crease's oscillation until the run blows up, whatever the step.
    Area,
}

impl PressureForce {
    /// Both choices.
    pub const ALL: [PressureForce; 2] = [PressureForce::Thesis, PressureForce::Area];

    /// The scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            PressureForce::Thesis => "thesis",
            PressureForce::Area => "area",
        }
    }

    /// Parses a scene-file name.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == s)
    }
}

/// How a step evaluates the bubble pressure `P_b` that its pressure force uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PressureSolve {
    /// Boyle's law on the volume at the start of the step (the thesis). The trapped air is then
    /// a spring the explicit step must resolve: see [`crate::SimConfig::stable_time_step`]; a small
    /// bubble (under about 70 cm^3 for the thesis cloth) blows up.
    Explicit,
    /// The pressure at the *end* of the step: `P_b` solves `P_b v(t + dt) = P_a v0`, with
    /// `v(t + dt)` predicted from the step's own dynamics: the integrator first moves the
    /// particles by every other force (inertia, springs, gravity, damping) and then solves
    /// Boyle's law with the pressure's own move, capped where it presses a particle onto the
    /// surface (see `air::bubble::EndOfStep`). The bubble's stiffness acts on the whole cloth
    /// as one mode, and that mode is integrated implicitly; the other forces stay explicit.
    #[default]
    Implicit,
}

impl PressureSolve {
    /// Both choices.
    pub const ALL: [PressureSolve; 2] = [PressureSolve::Implicit, PressureSolve::Explicit];

    /// The scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            PressureSolve::Explicit => "explicit",
            PressureSolve::Implicit => "implicit",
        }
    }

    /// Parses a scene-file name.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == s)
    }
}

impl Default for AirParams {
    fn default() -> Self {
        Self {
            enabled: true,
            atmospheric_pressure: 101_325.0,
            trapped_air: 0.0,
            leak_conductance: 0.0,
            pressure_solve: PressureSolve::Implicit,
            pressure_force: PressureForce::Thesis,
            model: AirModelKind::Thesis,
            seal_distance: 0.0005,
            seal_hysteresis: 0.0,
            seal_wetness: 0.5,
            permeability: 0.0,
            dry_permeability: 1e-4,
            pockets: Vec::new(),
        }
    }
}

impl AirParams {
    /// Darcy permeability of fabric of wetness `w` (0..1), m/(s Pa) (see
    /// [`AirParams::dry_permeability`]).
    pub fn permeability_at(&self, w: Real) -> Real {
        let dry = 1.0 - w.clamp(0.0, 1.0);
        self.permeability + (self.dry_permeability - self.permeability) * dry * dry * dry
    }
}
