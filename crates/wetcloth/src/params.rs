//! Parameters of a simulation: the cloth, the air, the colliders, the grabs and the stepping.
//!
//! Field names are the scene-file keys (`[cloth] structural_stiffness = ...`), and each field's
//! documentation gives its unit, default and valid range. [`SimConfig::validate`] checks every
//! range and names the offending key.

use crate::collider::Collider;
use crate::error::ConfigError;
use crate::grab::GrabSpec;
use crate::math::{Real, Vec3};

/// Time stepping and global fields (`[simulation]` in a scene file).
#[derive(Clone, Debug, PartialEq)]
pub struct SimulationParams {
    /// Simulated time to run, s. Default 3.0; range (0, 1e4]. Used by drivers, not by `step`.
    pub duration: Real,
    /// Integration step, s. Default 1/12000 (the thesis' value, 8.333e-5); range [1e-7, 1e-2].
    pub time_step: Real,
    /// Time integrator. Default [`Integrator::Verlet`] (thesis eq. 3.1).
    pub integrator: Integrator,
    /// Frames (and metrics rows) written per simulated second, 1/s. Default 60; range [1, 10000].
    /// Used by drivers.
    pub frame_rate: Real,
    /// Gravitational acceleration, m/s^2. Default (0, -9.8, 0) (thesis eq. 3.3); each component
    /// in [-1000, 1000].
    pub gravity: Vec3,
}

impl Default for SimulationParams {
    fn default() -> Self {
        Self {
            duration: 3.0,
            time_step: 1.0 / 12000.0,
            integrator: Integrator::Verlet,
            frame_rate: 60.0,
            gravity: Vec3::new(0.0, -9.8, 0.0),
        }
    }
}

/// The time integrator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Position Verlet, thesis eq. 3.1: `x(t+dt) = 2 x(t) - x(t-dt) + F/m dt^2`.
    #[default]
    Verlet,
}

impl Integrator {
    /// All integrators, for tests that run one scenario table over each.
    pub const ALL: [Integrator; 1] = [Integrator::Verlet];

    /// The scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Verlet => "verlet",
        }
    }

    /// Parses a scene-file name.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.name() == s)
    }
}

/// The cloth (`[cloth]` in a scene file): a square grid of particles, flat in the xz plane.
#[derive(Clone, Debug, PartialEq)]
pub struct ClothParams {
    /// Extent along x and z, m. Default (0.30, 0.30) (thesis ch. 4); each in [1e-3, 1e3].
    pub size: [Real; 2],
    /// Particles along x and z. Default (50, 50) (thesis: 2500 particles); each in [2, 4096].
    pub resolution: [usize; 2],
    /// Centre of the cloth at t = 0, m. Default (0, 0.002, 0).
    pub position: Vec3,
    /// Mass of the whole cloth, kg, shared equally by the particles. Default 0.02; range
    /// [1e-6, 1e4].
    pub mass: Real,
    /// Stiffness of the structural springs (4 grid neighbours), N/m. Default 500; range
    /// [0, 1e7]. With the shear stiffness and the particle mass it sets the explicit stability
    /// limit of the time step, see [`SimConfig::stable_time_step`].
    pub structural_stiffness: Real,
    /// Stiffness of the shear springs (4 diagonal neighbours), N/m. Default 125 (shear is
    /// softer than the weave); range [0, 1e7].
    pub shear_stiffness: Real,
    /// Velocity damping rate, 1/s: every particle feels `-damping * m * v`, so free motion decays
    /// as `exp(-damping * t)`. Default 0 (none); range [0, 1e4].
    pub damping: Real,
    /// Cloth thickness, m. Default 0.001; range [0, 0.1].
    pub thickness: Real,
    /// Collision margin added to the thickness, m: particles are spheres of diameter
    /// `thickness + collision_margin` (thesis 3.1). Default 0.0005; range [0, 0.1].
    pub collision_margin: Real,
    /// Whether particles collide with each other (thesis 3.1). Default true.
    pub self_collision: bool,
    /// Provot strain limit: the largest relative stretch allowed for a structural or shear
    /// spring (0.1 = 10 %); 0 turns it off. Default 0 (off, as in the thesis); range [0, 10].
    pub strain_limit: Real,
    /// Jacobi iterations of the strain limiter per step. Default 4; range [1, 100].
    pub strain_limit_iterations: usize,
}

impl Default for ClothParams {
    fn default() -> Self {
        Self {
            size: [0.30, 0.30],
            resolution: [50, 50],
            position: Vec3::new(0.0, 0.002, 0.0),
            mass: 0.02,
            structural_stiffness: 500.0,
            shear_stiffness: 125.0,
            damping: 0.0,
            thickness: 0.001,
            collision_margin: 0.0005,
            self_collision: true,
            strain_limit: 0.0,
            strain_limit_iterations: 4,
        }
    }
}

impl ClothParams {
    /// Radius of a particle's collision sphere, m: `(thickness + collision_margin) / 2`.
    pub fn particle_radius(&self) -> Real {
        0.5 * (self.thickness + self.collision_margin)
    }

    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        self.resolution[0] * self.resolution[1]
    }
}

/// The trapped air (`[air]` in a scene file), thesis 3.4.
#[derive(Clone, Debug, PartialEq)]
pub struct AirParams {
    /// Whether the pressure force acts (the demo's button 1). Default true.
    pub enabled: bool,
    /// Atmospheric pressure P_a, Pa. Default 101325; range [0, 1e7].
    pub atmospheric_pressure: Real,
    /// Trapped air v0: the air under the cloth, as its volume at atmospheric pressure, m^3.
    /// Default 0 (thesis: 0 and 400 cm^3); range [0, 1e3].
    pub trapped_air: Real,
    /// Leak conductance of the cloth's border, m^2/s: where the border is lifted off the
    /// surface, air flows into an under-pressured bubble (or out of an over-pressured one) at
    /// `leak_conductance * L_open * (P_a - P_b) / P_a` cubic metres per second (measured at
    /// atmospheric pressure), `L_open` the length of border lifted off the surface. The
    /// thesis' future work ("the amount of air should change while the cloth deforms").
    /// Default 0 (sealed, as in the thesis); range [0, 10].
    pub leak_conductance: Real,
    /// How the step evaluates the bubble pressure of the pressure force. Default
    /// [`PressureSolve::Implicit`].
    pub pressure_solve: PressureSolve,
}

/// How a step evaluates the bubble pressure `P_b` that its pressure force uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PressureSolve {
    /// Boyle's law on the volume at the start of the step (the thesis). The trapped air is then
    /// a spring the explicit step must resolve: see [`SimConfig::stable_time_step`]; a small
    /// bubble (under about 70 cm^3 for the thesis cloth) blows up.
    Explicit,
    /// The pressure at the *end* of the step: `P_b` solves `P_b v(t + dt) = P_a v0`, with
    /// `v(t + dt)` predicted from the step's own dynamics (inertia, damping, gravity, and the
    /// pressure force itself on the particles not held by a contact), a quadratic with one
    /// positive root. The air spring is then integrated implicitly and is stable for any
    /// amount of air; the other forces stay explicit.
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
        }
    }
}

/// Everything a [`crate::Simulation`] needs.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct SimConfig {
    /// Stepping and gravity.
    pub simulation: SimulationParams,
    /// The cloth.
    pub cloth: ClothParams,
    /// The trapped air.
    pub air: AirParams,
    /// Colliders; the first plane is the sticking surface of the air model.
    pub colliders: Vec<Collider>,
    /// Keyframed grabs.
    pub grabs: Vec<GrabSpec>,
}

fn check_range(key: &str, value: Real, lo: Real, hi: Real) -> Result<(), ConfigError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.to_string(),
            value: format!("{value}"),
            range: format!("[{lo}, {hi}]"),
        })
    }
}

fn check_open_low(key: &str, value: Real, lo: Real, hi: Real) -> Result<(), ConfigError> {
    if value.is_finite() && value > lo && value <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.to_string(),
            value: format!("{value}"),
            range: format!("({lo}, {hi}]"),
        })
    }
}

fn check_vec(key: &str, v: Vec3, lo: Real, hi: Real) -> Result<(), ConfigError> {
    for c in v.to_array() {
        if !(c.is_finite() && c >= lo && c <= hi) {
            return Err(ConfigError::OutOfRange {
                key: key.to_string(),
                value: format!("[{}, {}, {}]", v.x, v.y, v.z),
                range: format!("each component in [{lo}, {hi}]"),
            });
        }
    }
    Ok(())
}

impl SimConfig {
    /// The thesis' demo (ch. 4): a 30 cm satin cloth, 50 x 50 particles, on a table with
    /// 400 cm^3 of air trapped under it (the thesis' fig. 4.6), pinched at its centre and lifted
    /// 5 cm over 1.5 s, air force on, at the thesis' step of 1/12000 s. The cloth starts at the
    /// height that holds that air at atmospheric pressure; lifting draws the air into a tent
    /// while the rest of the cloth is pressed onto the table.
    pub fn thesis_demo() -> Self {
        let mut cfg = SimConfig {
            colliders: vec![Collider::plane(Vec3::ZERO, Vec3::Y, 0.6)],
            ..Default::default()
        };
        cfg.cloth.damping = 2.0;
        cfg.air.trapped_air = 400e-6;
        let area = cfg.cloth.size[0] * cfg.cloth.size[1];
        cfg.cloth.position = Vec3::new(
            0.0,
            cfg.cloth.particle_radius() + cfg.air.trapped_air / area,
            0.0,
        );
        cfg.grabs = vec![GrabSpec::lift([25, 25], 0.25, 1.75, 0.05)];
        cfg
    }

    /// Largest stable time step of the explicit integrator for this cloth, s.
    ///
    /// The fastest mode of the spring grid is the in-plane zig-zag where neighbours move in
    /// opposite directions: each particle then feels `4 (k_structural + k_shear) u` for a
    /// displacement `u`, so `omega^2 = 4 (k_s + k_sh) / m`, and position Verlet is stable for
    /// `omega dt < 2`. The thesis-like 50 x 50 cloth of 20 g with 1000 and 250 N/m has
    /// `dt_max = 8.0e-5 s`, just *below* the thesis' 1/12000 s: a free-hanging cloth with those
    /// values grows a zig-zag from round-off within milliseconds (resting on a plane, friction
    /// hides it). Hence the defaults of 500 and 125 N/m (`dt_max = 1.13e-4 s`).
    ///
    /// Trapped air adds a second limit. Moving the whole cloth by `u` along its normal changes
    /// the bubble by `A u` and its pressure by `-(P/v) A u` (Boyle), which pushes every particle
    /// back with `(P/v) A S u`: an air spring with `omega^2 = P_a A^2 / (v0 M)` (`A` the cloth's
    /// area, `M` its mass). A small bubble is a stiff spring: for the 20 g, 30 cm cloth at
    /// 1/12000 s, less than about 70 cm^3 of trapped air is unstable (none at all is fine: then
    /// the bubble is a vacuum and has no stiffness). This limit applies to
    /// [`PressureSolve::Explicit`] only; the default implicit pressure removes it.
    pub fn stable_time_step(&self) -> Real {
        let c = &self.cloth;
        let m = c.mass / c.particle_count() as Real;
        let k = 4.0 * (c.structural_stiffness + c.shear_stiffness);
        let springs = if k > 0.0 {
            2.0 * (m / k).sqrt()
        } else {
            Real::INFINITY
        };
        let a = &self.air;
        let area = c.size[0] * c.size[1];
        let air = if a.enabled
            && a.pressure_solve == PressureSolve::Explicit
            && a.trapped_air > 0.0
            && a.atmospheric_pressure > 0.0
        {
            2.0 * (c.mass * a.trapped_air / a.atmospheric_pressure).sqrt() / area
        } else {
            Real::INFINITY
        };
        springs.min(air)
    }

    /// Checks every parameter against its documented range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let s = &self.simulation;
        check_open_low("simulation.duration", s.duration, 0.0, 1e4)?;
        check_range("simulation.time_step", s.time_step, 1e-7, 1e-2)?;
        check_range("simulation.frame_rate", s.frame_rate, 1.0, 1e4)?;
        check_vec("simulation.gravity", s.gravity, -1000.0, 1000.0)?;

        let c = &self.cloth;
        check_range("cloth.size", c.size[0], 1e-3, 1e3)?;
        check_range("cloth.size", c.size[1], 1e-3, 1e3)?;
        for r in c.resolution {
            if !(2..=4096).contains(&r) {
                return Err(ConfigError::OutOfRange {
                    key: "cloth.resolution".into(),
                    value: format!("[{}, {}]", c.resolution[0], c.resolution[1]),
                    range: "each in [2, 4096]".into(),
                });
            }
        }
        check_vec("cloth.position", c.position, -1e4, 1e4)?;
        check_range("cloth.mass", c.mass, 1e-6, 1e4)?;
        check_range(
            "cloth.structural_stiffness",
            c.structural_stiffness,
            0.0,
            1e7,
        )?;
        check_range("cloth.shear_stiffness", c.shear_stiffness, 0.0, 1e7)?;
        check_range("cloth.damping", c.damping, 0.0, 1e4)?;
        check_range("cloth.thickness", c.thickness, 0.0, 0.1)?;
        check_range("cloth.collision_margin", c.collision_margin, 0.0, 0.1)?;
        check_range("cloth.strain_limit", c.strain_limit, 0.0, 10.0)?;
        if !(1..=100).contains(&c.strain_limit_iterations) {
            return Err(ConfigError::OutOfRange {
                key: "cloth.strain_limit_iterations".into(),
                value: c.strain_limit_iterations.to_string(),
                range: "[1, 100]".into(),
            });
        }

        let a = &self.air;
        check_range("air.atmospheric_pressure", a.atmospheric_pressure, 0.0, 1e7)?;
        check_range("air.trapped_air", a.trapped_air, 0.0, 1e3)?;
        check_range("air.leak_conductance", a.leak_conductance, 0.0, 10.0)?;
        if a.enabled && self.sticking_plane().is_none() {
            return Err(ConfigError::Invalid {
                key: "air.enabled".into(),
                message: "the air force needs a plane collider as its sticking surface; add a \
                          [[collider]] with shape = \"plane\" or set [air] enabled = false"
                    .into(),
            });
        }

        for (i, col) in self.colliders.iter().enumerate() {
            col.validate(i)?;
        }
        for (i, g) in self.grabs.iter().enumerate() {
            g.validate(i, c.resolution)?;
        }
        Ok(())
    }

    /// The sticking surface of the air model: the first plane collider, as (point, unit normal).
    pub fn sticking_plane(&self) -> Option<(Vec3, Vec3)> {
        self.colliders.iter().find_map(|c| c.as_plane())
    }
}
