//! Parameters of a simulation: the cloth, the air, the colliders, the grabs and the stepping.
//!
//! Field names are the scene-file keys (`[cloth] structural_stiffness = ...`), and each field's
//! documentation gives its unit, default and valid range. [`SimConfig::validate`] checks every
//! range and names the offending key.

//!
//! | file | scene table |
//! |---|---|
//! | `simulation.rs` | `[simulation]`: [`SimulationParams`], [`Integrator`] |
//! | `cloth.rs` | `[cloth]`: [`ClothParams`] |
//! | `air.rs` | `[air]`: [`AirParams`], [`PressureSolve`], [`PressureForce`] |
//! | `stability.rs` | [`SimConfig::stable_time_step`], the explicit limit |
//!
//! Colliders (`[[collider]]`) are described in [`crate::collide`], grabs (`[[grab]]`) in
//! [`crate::control`].

mod air;
mod cloth;
pub mod materials;
mod simulation;
mod stability;

pub use air::{AirModelKind, AirParams, PocketSeed, PressureForce, PressureSolve};
pub use cloth::{
    BendingParams, BendingRest, ClothMeshSource, ClothModel, ClothParams, MembraneParams,
    PaintShape, WetPaint,
};
pub use simulation::{Integrator, SimulationParams, SolveBudget};

use crate::collide::Collider;
use crate::collide::StickingPlane;
use crate::control::GrabSpec;
use crate::error::ConfigError;
use crate::math::{Real, Vec3};
use crate::math::{num, num3};

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
    /// Particles bound to colliders (scene `[[attach]]`).
    pub attachments: Vec<crate::control::AttachSpec>,
}

fn check_range(key: &str, value: Real, lo: Real, hi: Real) -> Result<(), ConfigError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.to_string(),
            value: num(value),
            range: format!("[{}, {}]", num(lo), num(hi)),
        })
    }
}

fn check_open_low(key: &str, value: Real, lo: Real, hi: Real) -> Result<(), ConfigError> {
    if value.is_finite() && value > lo && value <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.to_string(),
            value: num(value),
            range: format!("({}, {}]", num(lo), num(hi)),
        })
    }
}

fn check_vec(key: &str, v: Vec3, lo: Real, hi: Real) -> Result<(), ConfigError> {
    for c in v.to_array() {
        if !(c.is_finite() && c >= lo && c <= hi) {
            return Err(ConfigError::OutOfRange {
                key: key.to_string(),
                value: num3(v),
                range: format!("each component in [{}, {}]", num(lo), num(hi)),
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

    /// Checks every parameter against its documented range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let s = &self.simulation;
        check_open_low("simulation.duration", s.duration, 0.0, 1e4)?;
        check_range(
            "simulation.time_step",
            s.time_step,
            1e-7,
            s.integrator.max_time_step(),
        )?;
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
        if !(1..=10_000).contains(&c.strain_limit_iterations) {
            return Err(ConfigError::OutOfRange {
                key: "cloth.strain_limit_iterations".into(),
                value: c.strain_limit_iterations.to_string(),
                range: "[1, 10000]".into(),
            });
        }

        check_range("cloth.wetness", c.wetness, 0.0, 1.0)?;
        check_range("cloth.water_mass", c.water_mass, 0.0, 100.0)?;
        check_range(
            "cloth.dry_friction_factor",
            c.dry_friction_factor,
            0.0,
            10.0,
        )?;
        check_range("cloth.wet_adhesion", c.wet_adhesion, 0.0, 1e6)?;
        check_range("cloth.shrink", c.shrink, 0.0, 0.5)?;
        for (i, p) in c.paint.iter().enumerate() {
            let key = |k: &str| format!("cloth.paint[{i}].{k}");
            check_range(&key("center"), p.center[0], -1e3, 1e3)?;
            check_range(&key("center"), p.center[1], -1e3, 1e3)?;
            check_range(&key("wetness"), p.wetness, 0.0, 1.0)?;
            // The grid paints in its rest coordinates (`center`), a mesh in the scene (`point`):
            // a region given in the other's terms would paint about the wrong point.
            check_center(&key("center"), p.point, p.center, c.mesh.is_some())?;
            match p.shape {
                PaintShape::Disc(r) => check_open_low(&key("radius"), r, 0.0, 1e3)?,
                PaintShape::Box(h) => {
                    check_open_low(&key("half_size"), h[0], 0.0, 1e3)?;
                    check_open_low(&key("half_size"), h[1], 0.0, 1e3)?;
                }
                PaintShape::Cuboid(h) => {
                    for v in h {
                        check_open_low(&key("half_size"), v, 0.0, 1e3)?;
                    }
                }
            }
        }
        let mb = &c.membrane;
        check_open_low("cloth.membrane.warp", mb.warp, 0.0, 1e7)?;
        check_open_low("cloth.membrane.weft", mb.weft, 0.0, 1e7)?;
        check_open_low("cloth.membrane.shear", mb.shear, 0.0, 1e7)?;
        if !(mb.poisson >= 0.0 && mb.poisson < 0.5) {
            return Err(ConfigError::OutOfRange {
                key: "cloth.membrane.poisson".into(),
                value: crate::math::num(mb.poisson),
                range: "[0, 0.5)".into(),
            });
        }
        if mb.poisson * mb.poisson * mb.weft / mb.warp >= 1.0 {
            return Err(ConfigError::Invalid {
                key: "cloth.membrane.poisson".into(),
                message: format!(
                    "poisson^2 weft / warp = {} must be below 1 for the membrane to be stable \
                     (poisson {}, weft {} N/m, warp {} N/m)",
                    crate::math::num(mb.poisson * mb.poisson * mb.weft / mb.warp),
                    crate::math::num(mb.poisson),
                    crate::math::num(mb.weft),
                    crate::math::num(mb.warp)
                ),
            });
        }
        let bd = &c.bending;
        check_range("cloth.bending.stiffness", bd.stiffness, 0.0, 1.0)?;
        check_range("cloth.bending.warp", bd.warp, 0.0, 1e3)?;
        check_range("cloth.bending.weft", bd.weft, 0.0, 1e3)?;
        if let Some(d) = c.density {
            check_range("cloth.density", d, 1e-6, 1e3)?;
        }
        if let Some(m) = &c.mesh {
            check_vec("cloth.rotation", m.rotation, -1e6, 1e6)?;
            check_open_low("cloth.scale", m.scale, 0.0, 1e4)?;
            let (triangles, from) = m.triangles();
            crate::model::ClothMesh::new(m.placed(c.position), triangles).map_err(|e| {
                let face = e
                    .triangle()
                    .and_then(|t| from.get(t))
                    .map_or(String::new(), |f| {
                        format!(" (face {} counting from 1)", f + 1)
                    });
                ConfigError::Invalid {
                    key: "cloth.mesh".into(),
                    message: format!("{}{face}: {e}", m.file),
                }
            })?;
        }

        let a = &self.air;
        check_range("air.atmospheric_pressure", a.atmospheric_pressure, 0.0, 1e7)?;
        check_range("air.trapped_air", a.trapped_air, 0.0, 1e3)?;
        check_range("air.leak_conductance", a.leak_conductance, 0.0, 10.0)?;
        check_range("air.seal_distance", a.seal_distance, 0.0, 0.1)?;
        check_range("air.seal_hysteresis", a.seal_hysteresis, 0.0, 1.0)?;
        check_open_low("air.seal_wetness", a.seal_wetness, 0.0, 1.0)?;
        check_range("air.permeability", a.permeability, 0.0, 1.0)?;
        check_range("air.dry_permeability", a.dry_permeability, 0.0, 1.0)?;
        for (i, p) in a.pockets.iter().enumerate() {
            let key = |k: &str| format!("air.pocket[{i}].{k}");
            check_center(&key("center"), p.point, p.center, c.mesh.is_some())?;
            if p.point.is_none() {
                check_range(&key("center"), p.center[0], -1e3, 1e3)?;
                check_range(&key("center"), p.center[1], -1e3, 1e3)?;
            }
            check_open_low(&key("radius"), p.radius, 0.0, 1e3)?;
            check_range(&key("amount"), p.amount, 0.0, 1e3)?;
        }
        if let Some(m) = c.mesh.as_ref().filter(|_| !a.pockets.is_empty()) {
            // On a mesh a seed is a ball about a point of the scene: one that misses the cloth
            // (a centre at the wrong height, say) is refused rather than left out.
            let placed = m.placed(c.position);
            for (i, p) in a.pockets.iter().enumerate() {
                let point = p.point.unwrap_or_default();
                let nearest = placed
                    .iter()
                    .map(|&v| (v - point).length_squared())
                    .fold(Real::INFINITY, Real::min);
                if nearest > p.radius * p.radius {
                    return Err(ConfigError::Invalid {
                        key: format!("air.pocket[{i}].center"),
                        message: format!(
                            "no particle of the cloth lies within `radius` = {} m of {} at \
                             t = 0 (the nearest is {} m away); on a mesh cloth `center` is a \
                             point of the scene at t = 0",
                            num(p.radius),
                            num3(point),
                            num(nearest.sqrt())
                        ),
                    });
                }
            }
        }
        if !a.pockets.is_empty() && a.model != AirModelKind::Pockets {
            return Err(ConfigError::Invalid {
                key: "air.pocket".into(),
                message: "seeded pockets need the pockets model: set [air] model = \"pockets\" \
                          (the thesis model's air is [air] trapped_air)"
                    .into(),
            });
        }
        if a.enabled && a.model == AirModelKind::Thesis && self.sticking_plane().is_none() {
            return Err(ConfigError::Invalid {
                key: "air.enabled".into(),
                message: "the thesis' air model needs a plane collider as its sticking surface; \
                          add a [[collider]] with shape = \"plane\", set [air] model = \
                          \"pockets\" (air against any collider) or set [air] enabled = false"
                    .into(),
            });
        }

        for (i, col) in self.colliders.iter().enumerate() {
            col.validate(i)?;
        }
        for (i, g) in self.grabs.iter().enumerate() {
            g.validate(i, c.resolution)?;
        }
        for (i, a) in self.attachments.iter().enumerate() {
            a.validate(i, self.colliders.len())?;
        }
        if !c.seams.is_empty() && c.mesh.is_none() && c.model == ClothModel::Springs {
            return Err(ConfigError::Invalid {
                key: "cloth.seam".into(),
                message: "seams sew the panels of a mesh cloth: give [cloth] a `mesh`, or \
                          set `model = \"membrane\"` for the grid"
                    .into(),
            });
        }
        if c.mesh.is_none()
            && c.model == ClothModel::Springs
            && let Some(i) = self.attachments.iter().position(|a| a.stiffness.is_some())
        {
            return Err(ConfigError::Invalid {
                key: format!("attach[{i}].stiffness"),
                message: "a soft attachment pulls the particles of a mesh cloth: give \
                          [cloth] a `mesh`, set `model = \"membrane\"` for the grid, or \
                          leave `stiffness` out for a hard attachment"
                    .into(),
            });
        }
        for (i, s) in c.seams.iter().enumerate() {
            s.validate(i, c.particle_count())?;
        }
        Ok(())
    }

    /// The sticking surface of the air model: the first plane collider.
    pub fn sticking_plane(&self) -> Option<StickingPlane> {
        self.colliders.iter().find_map(|c| {
            c.as_plane().map(|p| StickingPlane {
                point: p.point,
                up: p.normal,
            })
        })
    }
}

/// A region's `center` in its cloth's terms: 3 components (`point`, scene coordinates at t =
/// 0) on a mesh cloth, 2 (`center`, from the grid's centre at rest) on the grid.
fn check_center(
    key: &str,
    point: Option<Vec3>,
    center: [Real; 2],
    mesh: bool,
) -> Result<(), ConfigError> {
    match (point, mesh) {
        (Some(point), true) => check_vec(key, point, -1e4, 1e4),
        (None, false) => Ok(()),
        (None, true) => Err(ConfigError::Invalid {
            key: key.into(),
            message: format!(
                "on a mesh cloth `center` has 3 components [x, y, z] (m, scene coordinates at \
                 t = 0), not the grid's [{}, {}]",
                num(center[0]),
                num(center[1])
            ),
        }),
        (Some(point), false) => Err(ConfigError::Invalid {
            key: key.into(),
            message: format!(
                "on the grid `center` has 2 components [x, z] (m from the cloth's centre at \
                 rest), not a mesh's {}",
                num3(point)
            ),
        }),
    }
}
