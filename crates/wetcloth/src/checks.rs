//! Blow-up checks: a state no cloth can be in stops the run with a [`StepError`] (rapier's
//! quarantine, at one chokepoint: the end of every step).
//!
//! - **Non-finite** positions, and a structural spring past [`BLOWUP_STRETCH`] rest lengths
//!   (measured every step in the integrator's pass, the crate's private `measure` module).
//! - **A negative bubble**: with the air force on, a gap volume below `-2 r A` (`r` the particle
//!   radius, `A` the cloth's area) is more negative than any cloth lying folded flat can give;
//!   the cloth has passed through the sticking surface or through itself, and Boyle's law
//!   means nothing any more.
//! - **Energy from nowhere** ([`EnergyAudit`]): the cloth's mechanical energy (kinetic,
//!   elastic, gravitational) may grow only by the work the hands, the moving colliders and the
//!   water film's pull do (`Simulation` passes their sum as the hands' work,
//!   [`Control::external_work`]) and the energy the air can give; a run that gains far more is
//!   pumping energy out of round-off or out of a force law pushed past its validity, and
//!   stops. It runs every [`AUDIT_INTERVAL`] steps inside the simulation, and
//!   [`crate::Simulation::audit`] runs it at once (`wetcloth run` before every frame).
//! - **Out of reach** ([`EnergyAudit::reach`]): at the same audits, a particle farther from the
//!   centre the cloth had at the start than free fall, the hands' paths, the cloth's own
//!   (over-)stretched size and the speed the energy budget allows over the time since can
//!   explain: the cloth has been flung away by a blow-up the other checks did not see.

use crate::control::{Control, GrabMotion};
use crate::error::StepError;
use crate::math::{Real, Vec3};
use crate::measure::Totals;
use crate::model::Model;
use crate::state::State;

/// A structural spring longer than this many rest lengths means the run has blown up: cloth
/// tears long before, while strong suction legitimately stretches springs by tens of percent.
pub const BLOWUP_STRETCH: Real = 10.0;

/// Metres added to every reach ([`EnergyAudit::reach`]), so round-off and small pushes never
/// trip it.
pub const REACH_MARGIN: Real = 10.0;

/// Steps between two energy audits: often enough to stop a run long before it writes garbage,
/// rarely enough to cost nothing measurable (one pass over the springs every 128 steps).
pub const AUDIT_INTERVAL: u64 = 128;

/// `Err` if the measured state at time `time` (s) has a non-finite position or a structural
/// spring past [`BLOWUP_STRETCH`].
pub(crate) fn check(totals: &Totals, time: Real) -> Result<(), StepError> {
    if !totals.finite {
        return Err(StepError::NonFinite { time });
    }
    if totals.stretch2 > BLOWUP_STRETCH * BLOWUP_STRETCH {
        return Err(StepError::OverStretch {
            time,
            ratio: totals.stretch2.sqrt(),
            limit: BLOWUP_STRETCH,
        });
    }
    Ok(())
}

/// `Err` if the bubble volume `volume` (m^3) is more negative than a folded cloth can make it
/// (see the module docs), while the air force acts.
pub(crate) fn check_volume(model: &Model, volume: Real, time: Real) -> Result<(), StepError> {
    let floor = -2.0 * model.radius * model.cloth_area;
    if volume < floor {
        return Err(StepError::NegativeVolume {
            time,
            volume,
            floor,
        });
    }
    Ok(())
}

/// The cloth's energy budget (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct EnergyAudit {
    /// Mechanical energy when the audit started, J.
    start: Real,
    /// [`crate::Control::hand_work`] when the audit started, J.
    hand_work_start: Real,
    /// Largest bubble volume seen, m^3, and largest pressure difference across the cloth, Pa:
    /// the air can give at most their product.
    air_volume: Real,
    air_pressure: Real,
    /// Centre of the cloth's bounding sphere at the start, m, and its radius, m.
    centre: Vec3,
    radius: Real,
    /// Fastest particle at the start, m/s, and the time of the start, s.
    speed: Real,
    start_time: Real,
}

impl EnergyAudit {
    /// Starts the budget from `state`, with the hands' work so far `hand_work` (J).
    pub fn new(model: &Model, state: &State, dt: Real, hand_work: Real) -> Self {
        let n = state.len().max(1) as Real;
        let centre = (0..state.len()).map(|k| state.x.get(k)).sum::<Vec3>() / n;
        let radius = (0..state.len())
            .map(|k| (state.x.get(k) - centre).length())
            .fold(0.0, Real::max);
        let speed = (0..state.len())
            .map(|k| state.velocity(k, dt).length())
            .fold(0.0, Real::max);
        Self {
            start: mechanical_energy(model, state, dt),
            hand_work_start: hand_work,
            centre,
            radius,
            speed,
            start_time: state.steps as Real * dt,
            ..Default::default()
        }
    }

    /// How far from the cloth's centre at the start any particle can be at time `time` (s), m:
    ///
    /// `R0 + BLOWUP_STRETCH D + G + v0 t + |g| t^2 / 2 + sqrt(2 E / m) t + REACH_MARGIN`
    ///
    /// with `t` the time since the start, `R0` the cloth's radius at the start, `D` its rest
    /// diagonal (a cloth stretched further has blown up), `G` the sum of the grabs' reaches
    /// (`grab_reach`, m: how far their paths or targets take a particle), `v0` the fastest
    /// particle at the start, `g` gravity, and `sqrt(2 E / m)` the speed one particle of mass
    /// `m` would have with all the energy the hands and the air can have given
    /// ([`EnergyAudit::allowance`]). No collider moves, so nothing else carries the cloth.
    pub fn reach(&self, model: &Model, hand_work: Real, grab_reach: Real, time: Real) -> Real {
        let t = (time - self.start_time).max(0.0);
        let size = match model.layout() {
            crate::model::Layout::Grid(g) => {
                (g.dx * (g.nx - 1) as Real).hypot(g.dz * (g.nz - 1) as Real)
            }
            crate::model::Layout::Mesh(m, _) => {
                let (lo, hi) = m.rest.iter().fold(
                    (Vec3::splat(Real::INFINITY), Vec3::splat(Real::NEG_INFINITY)),
                    |(lo, hi), &p| (lo.min(p), hi.max(p)),
                );
                (hi - lo).length()
            }
        };
        let lightest = model.masses.as_ref().map_or(model.particle_mass, |m| {
            m.iter().copied().fold(Real::INFINITY, Real::min)
        });
        let budget = (2.0 * self.allowance(hand_work).max(0.0) / lightest).sqrt();
        self.radius
            + BLOWUP_STRETCH * size
            + grab_reach
            + (self.speed + budget) * t
            + 0.5 * model.gravity.length() * t * t
            + REACH_MARGIN
    }

    /// Records the air after a step: bubble volume (m^3) and pressure difference (Pa).
    pub(crate) fn record_air(&mut self, volume: Real, pressure_difference: Real) {
        self.air_volume = self.air_volume.max(volume);
        self.air_pressure = self.air_pressure.max(pressure_difference.abs());
    }

    /// The most the mechanical energy may have grown, J, with the hands' work so far
    /// `hand_work` (J): twice what the hands and the air can have given, plus a millijoule.
    pub fn allowance(&self, hand_work: Real) -> Real {
        2.0 * ((hand_work - self.hand_work_start) + self.air_volume * self.air_pressure) + 1e-3
    }

    /// `Err` if the mechanical energy of `state` exceeds the start by more than
    /// [`EnergyAudit::allowance`].
    ///
    /// Also `Err` if a particle is beyond [`EnergyAudit::reach`] (with the grabs of
    /// `control`).
    pub(crate) fn check(
        &self,
        model: &Model,
        state: &State,
        control: &Control,
        dt: Real,
        time: Real,
    ) -> Result<(), StepError> {
        // The work done from outside: the hands', the moving colliders' and the water film's.
        let hand_work = control.external_work();
        // The largest distance, NaN if any is (Real::max would skip it).
        let distance = (0..state.len())
            .map(|k| (state.x.get(k) - self.centre).length_squared())
            .fold(0.0, |a: Real, d| if d > a || d.is_nan() { d } else { a })
            .sqrt();
        let reach = self.reach(model, hand_work, grab_reach(control, self.centre), time);
        // A NaN distance or reach is out of reach too.
        if distance > reach || distance.is_nan() || reach.is_nan() {
            return Err(StepError::OutOfReach {
                time,
                distance,
                reach,
            });
        }
        let gain = mechanical_energy(model, state, dt) - self.start;
        let allowance = self.allowance(hand_work);
        if gain > allowance {
            return Err(StepError::EnergyGain {
                time,
                gain,
                allowance,
            });
        }
        Ok(())
    }
}

/// How far the grabs of `control` can take a particle, m: for each path grab the largest
/// offset of its keys, for each target grab its target's distance from `centre` (m), summed.
pub fn grab_reach(control: &Control, centre: Vec3) -> Real {
    control
        .grabs
        .iter()
        .map(|g| match &g.motion {
            GrabMotion::Path(spec) => spec
                .keys
                .iter()
                .map(|k| k.offset.length())
                .fold(0.0, Real::max),
            GrabMotion::Target { target, .. } => (*target - centre).length(),
            // An attachment is carried by its collider, whose work is counted.
            GrabMotion::Attached(_) => 0.0,
        })
        .sum()
}

/// Kinetic plus elastic plus gravitational energy of the cloth, J (gravity's zero at the
/// origin).
pub fn mechanical_energy(model: &Model, state: &State, dt: Real) -> Real {
    let gravity: Real = (0..state.len())
        .map(|k| -model.mass(k) * model.gravity.dot(state.x.get(k)))
        .sum();
    state.kinetic_energy_with(model.masses.as_deref(), model.particle_mass, dt)
        + model.elastic_energy(&state.x)
        + gravity
}

/// Work of a hand force `force` (N) over the move `from` -> `to` (m), J.
#[inline]
pub(crate) fn work(force: Vec3, from: Vec3, to: Vec3) -> Real {
    force.dot(to - from)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::SimConfig;

    fn start() -> (Model, State, Control, Real) {
        let mut cfg = SimConfig::thesis_demo();
        cfg.cloth.resolution = [8, 8];
        cfg.grabs.clear();
        let model = Model::new(&cfg);
        let state = State::at_rest(model.grid().rest_positions(cfg.cloth.position));
        let control = Control::new(model.grid().len(), false);
        (model, state, control, cfg.simulation.time_step)
    }

    #[test]
    fn reach_covers_free_fall_the_cloth_and_the_grabs() {
        let (model, state, mut control, dt) = start();
        let audit = EnergyAudit::new(&model, &state, dt, 0.0);
        let g = model.gravity.length();
        for t in [0.0, 1.0, 60.0, 3600.0] {
            let reach = audit.reach(&model, 0.0, 0.0, t);
            // Free fall from rest, the cloth's own size and the margin, at least.
            assert!(reach >= 0.5 * g * t * t + 0.3 * BLOWUP_STRETCH + REACH_MARGIN);
        }
        // Not absurdly more: a second after the start, a cloth nobody touches is within tens of
        // metres of where it was.
        assert!(audit.reach(&model, 0.0, 0.0, 1.0) < 50.0);
        control.grabs.push(crate::control::Grab::new(
            0,
            GrabMotion::Path(crate::control::GrabSpec::lift([0, 0], 0.0, 1.0, 500.0)),
        ));
        assert_eq!(grab_reach(&control, Vec3::ZERO), 500.0);
    }

    /// A cloth flung a kilometre away in one step (a blow-up no other check saw) stops as out
    /// of reach; one within reach passes.
    #[test]
    fn a_particle_far_outside_every_reach_stops_the_run() {
        let (model, mut state, control, dt) = start();
        let audit = EnergyAudit::new(&model, &state, dt, 0.0);
        state.steps = 10;
        let time = 10.0 * dt;
        assert!(audit.check(&model, &state, &control, dt, time).is_ok());
        let mut far = state.clone();
        let p = far.x.get(5);
        far.x.set(5, p + Vec3::new(1000.0, 0.0, 0.0));
        match audit.check(&model, &far, &control, dt, time) {
            Err(StepError::OutOfReach {
                distance, reach, ..
            }) => {
                assert!(distance > 999.0 && reach < 100.0, "{distance} {reach}");
            }
            other => panic!("{other:?}"),
        }
        let mut nan = state.clone();
        nan.x.set(3, Vec3::new(Real::NAN, 0.0, 0.0));
        assert!(matches!(
            audit.check(&model, &nan, &control, dt, time),
            Err(StepError::OutOfReach { .. })
        ));
    }
}
