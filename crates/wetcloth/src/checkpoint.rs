//! Checkpoints: everything a step carries to the next, so that a simulation can be stopped,
//! stored and continued bit for bit.
//!
//! A [`Checkpoint`] holds the parts of a [`Simulation`](crate::Simulation) that are not rebuilt from its
//! configuration: the [`State`] (positions, motion, contacts and their slides' friction, the
//! implicit integrator's last accelerations, step count), the [`Control`] (grabs with their
//! anchors and last targets, which particles are held, the hands' work so far, the air
//! switch), the [`AirModel`] (the thesis' bubble or the sealed pockets with their ids, amounts
//! and sealing state), the self-collision neighbour lists with their reference positions, the
//! cell measures of the current state and the energy audit. The model (grid, masses, colliders) is rebuilt from the configuration, and
//! the integrator's buffers are scratch that every step overwrites before reading, so neither
//! is stored.
//! [`Simulation::restore`](crate::Simulation::restore) builds a simulation from the configuration and a checkpoint;
//! stepping it gives exactly the numbers the original would have given (see the test
//! `checkpoint_restore_continues_bit_for_bit` in `tests/checkpoint.rs`).
//!
//! The self-collision lists are stored with their reference positions rather than rebuilt on
//! restore. The lists hold every pair within a diameter plus a skin, in a fixed order, and are
//! rebuilt before any particle moves half a skin, so a rebuild at another step should give the
//! same numbers (the test above finds the same digests either way, on a fold where
//! self-collision acts); storing them makes the continuation exact without leaning on that.
//!
//! With the `serde` feature every part derives `Serialize` and `Deserialize`; the core chooses
//! no file format (`wetcloth run` stores checkpoints as postcard with a version and a checksum,
//! see `docs/reliability.md`). State added to the core later is one derive away: a type a step
//! carries forward gets `#[cfg_attr(feature = "serde", derive(serde::Serialize,
//! serde::Deserialize))]` and, if it is a new field of [`Simulation`](crate::Simulation), a field here, with
//! [`CHECKPOINT_VERSION`] raised so that older checkpoints are refused rather than misread.
//! Pure scratch may be left out with `#[cfg_attr(feature = "serde", serde(skip))]`.

use crate::air::AirModel;
use crate::checks::EnergyAudit;
use crate::collide::self_collision::SelfCollision;
use crate::control::Control;
use crate::measure::Measures;
use crate::model::Layout;
use crate::params::SimConfig;
use crate::state::{Motion, State};

/// Version of a checkpoint's contents; raised whenever a stored type changes.
pub const CHECKPOINT_VERSION: u32 = 5;

/// Everything a step carries to the next (see the module docs).
#[derive(Clone, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Checkpoint {
    pub(crate) version: u32,
    pub(crate) state: State,
    pub(crate) control: Control,
    pub(crate) air: AirModel,
    pub(crate) self_collision: Option<SelfCollision>,
    pub(crate) measures: Measures,
    pub(crate) audit: EnergyAudit,
}

/// Why a checkpoint cannot continue a simulation.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RestoreError {
    /// The configuration itself is invalid.
    #[error(transparent)]
    Config(#[from] crate::error::ConfigError),
    /// The checkpoint was written by another version of the format.
    #[error("checkpoint format version {found}, this build reads version {expected}")]
    Version {
        /// The checkpoint's version.
        found: u32,
        /// [`CHECKPOINT_VERSION`].
        expected: u32,
    },
    /// The checkpoint does not fit the configuration (another cloth, air model or integrator).
    #[error("checkpoint does not fit the scene: {0}")]
    Mismatch(String),
}

impl Checkpoint {
    /// The version of the format it was written in.
    pub fn version(&self) -> u32 {
        self.version
    }

    /// Steps taken when it was made.
    pub fn steps(&self) -> u64 {
        self.state.steps
    }

    /// The state it holds.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// Checks that it fits a simulation just built from the configuration `config` it is to
    /// continue (its cloth's `layout`, its fresh `state` and `air`): the same number of particles,
    /// air model, integrator and self-collision, every index in range.
    pub(crate) fn check_fits(
        &self,
        config: &SimConfig,
        layout: Layout<'_>,
        state: &State,
        air: &AirModel,
    ) -> Result<(), RestoreError> {
        if self.version != CHECKPOINT_VERSION {
            return Err(RestoreError::Version {
                found: self.version,
                expected: CHECKPOINT_VERSION,
            });
        }
        let n = state.x.len();
        let bad = |what: String| Err(RestoreError::Mismatch(what));
        let soa_fits = |s: &crate::math::Soa, len: usize| {
            s.x.len() == len && s.y.len() == len && s.z.len() == len
        };
        let s = &self.state;
        if !soa_fits(&s.x, n) {
            return bad(format!(
                "{} positions for a cloth of {n} particles",
                s.x.len()
            ));
        }
        match (&s.motion, &state.motion) {
            (Motion::Previous(p), Motion::Previous(_))
            | (Motion::Velocity(p), Motion::Velocity(_))
                if soa_fits(p, n) => {}
            _ => return bad("the motion does not fit the integrator or the cloth".into()),
        }
        if s.contact.len() != n {
            return bad(format!(
                "{} contact flags for {n} particles",
                s.contact.len()
            ));
        }
        if s.slides.len() != n {
            return bad(format!("{} slides for {n} particles", s.slides.len()));
        }
        if !soa_fits(&s.acceleration, n) {
            return bad(format!(
                "{} accelerations for {n} particles",
                s.acceleration.x.len()
            ));
        }
        let c = &self.control;
        if c.held.len() != n || c.targets.len() > c.grabs.len() {
            return bad("the grabs' held particles or targets do not fit the cloth".into());
        }
        if let Some(g) = c.grabs.iter().find(|g| g.particle >= n) {
            return bad(format!(
                "a grab holds particle {} of {n} particles",
                g.particle
            ));
        }
        if std::mem::discriminant(&self.air) != std::mem::discriminant(air) {
            return bad("another air model".into());
        }
        if let AirModel::Pockets(p) = &self.air {
            let cells = match layout {
                Layout::Grid(grid) => (grid.nx - 1) * (grid.nz - 1),
                Layout::Mesh(mesh, _) => mesh.triangles.len(),
            };
            let count = p.pockets.len() as u32;
            let in_range = |v: &[u32]| {
                v.iter()
                    .all(|&i| i == crate::air::pockets::NONE || i < count)
            };
            if p.sealed.len() != n
                || p.particle_pocket.len() != n
                || p.cell_pocket.len() != cells
                || !in_range(&p.particle_pocket)
                || !in_range(&p.cell_pocket)
            {
                return bad("the pockets do not fit the cloth".into());
            }
        }
        match (&self.self_collision, config.cloth.self_collision) {
            (None, false) => {}
            (Some(sc), true) => {
                if !sc.fits(n) {
                    return bad("the self-collision lists do not fit the cloth".into());
                }
            }
            _ => return bad("self-collision is on in one and off in the other".into()),
        }
        let (m, want) = (
            &self.measures,
            Measures::for_layout(layout, AirModel::keeps_cells(&config.air)),
        );
        if m.rows.len() != want.rows.len()
            || m.cells.len() != want.cells.len()
            || m.keep_cells != want.keep_cells
        {
            return bad("the cell measures do not fit the cloth".into());
        }
        Ok(())
    }
}
