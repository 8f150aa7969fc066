//! The air's share of the implicit integrator's solve (`integrate/implicit/`): everything the
//! solve needs to know of the air beyond its gas springs (`region.rs`). For the thesis' bubble,
//! the pressure shift that closes the gap between the volume the solve's velocities give
//! (eq. 3.10 at the step's end) and its linear prediction, by a relaxed fixed point
//! ([`Relaxation`]), and the pressure the step applied; for the pockets, each sealed rim
//! particle's share of its pockets' end-of-step pressures, following the solves.
//!
//! The solve owns the velocities `v`, the pressure force per pascal `g` (`S N_k`) and the
//! right-hand side; this share reads the first two and adds its pressure forces (times `dt`)
//! to the third.

use super::region::Regions;
use super::{AirModel, Timing};
use crate::math::{Real, Soa};
use crate::model::Model;

/// Pressure change (Pa) of the bubble's volume correction, or of a rim particle's share, that
/// calls for another solve.
pub(crate) const PRESSURE_TOLERANCE: Real = 1e-2;

/// Most solves after the contact set is settled that only correct the bubble's pressure.
pub(crate) const PRESSURE_PASSES: usize = 4;

/// The air's share of one implicit step (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct SolveShare {
    /// Whether the solve finds the end-of-step pressure (the gas springs act in it).
    pub(crate) end_of_step: bool,
    /// Whether the air is the thesis' bubble.
    thesis: bool,
    /// The thesis bubble's gas spring (Pa/m^3), when the solve predicts its pressure; 0 else.
    stiffness: Real,
    /// The bubble's volume at the step's start (m^3).
    start_volume: Real,
    /// The bubble's pressure shift applied so far this step, as a volume miss (m^3).
    miss: Real,
    shift: Relaxation,
    /// End-of-step positions of the current velocities (for the bubble's volume).
    end: Soa,
    /// Per particle: the pressure difference (Pa) of the pockets of air around it that the
    /// right-hand side holds so far this step, as a sealed particle on their rims; with
    /// `rim_target` the one the last solve asks for.
    rim_applied: Vec<Real>,
    rim_target: Vec<Real>,
    /// Per region, the difference to the atmosphere (Pa) of the end-of-step pressure the last
    /// solve found.
    end_pressure: Vec<Real>,
}

impl SolveShare {
    /// For `n` particles.
    pub(crate) fn new(n: usize) -> Self {
        Self {
            end: Soa::zeros(n),
            rim_applied: vec![0.0; n],
            rim_target: vec![0.0; n],
            ..Default::default()
        }
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.end.heap_bytes()
            + (self.rim_applied.capacity() + self.rim_target.capacity()) * 8
            + self.end_pressure.capacity() * 8
    }

    /// The step's start: the air `air` as `regions` at positions `x` with timing `timing`.
    pub(crate) fn begin(
        &mut self,
        air: &AirModel,
        regions: &Regions,
        timing: Timing,
        model: &Model,
        x: &Soa,
    ) {
        self.end_of_step = timing == Timing::EndOfStep;
        self.thesis = matches!(air, AirModel::Thesis(_));
        self.stiffness = match (air, regions.list.first()) {
            (AirModel::Thesis(_), Some(r)) if self.end_of_step => r.stiffness,
            _ => 0.0,
        };
        self.miss = 0.0;
        self.shift = Relaxation::default();
        // Nothing applied to any rim yet (`applied` reads every particle's).
        self.rim_applied.fill(0.0);
        // The bubble's volume now (m^3): measured once, the miss is measured after each solve.
        self.start_volume = match model.sticking {
            Some(plane) if self.stiffness > 0.0 => {
                super::volume(model.grid(), x, plane, model.radius)
            }
            _ => 0.0,
        };
    }

    /// The pressure difference (Pa) this share has added so far this step to particle `k`'s
    /// right-hand side (as `dp g_k dt`): the bubble's shift, and a rim's share of its pockets.
    pub(crate) fn applied(&self, regions: &Regions, k: usize) -> Real {
        let shift = if self.corrects_bubble() && regions.of(k).is_some() {
            -self.stiffness * self.miss
        } else {
            0.0
        };
        shift + self.rim_applied.get(k).copied().unwrap_or(0.0)
    }

    /// Whether the solve predicts the thesis bubble's pressure (and so corrects it).
    pub(crate) fn corrects_bubble(&self) -> bool {
        self.stiffness > 0.0
    }

    /// Before the step's first solve: the bubble's pressure shifted by its miss at the first
    /// guess `v`, and the rims from their pockets' pressures now (a pocket at rest keeps them:
    /// no second solve).
    #[allow(clippy::too_many_arguments)] // the solve's vectors
    pub(crate) fn start(
        &mut self,
        model: &Model,
        regions: &Regions,
        x: &Soa,
        v: &Soa,
        g: &Soa,
        rhs: &mut Soa,
        dt: Real,
    ) {
        if self.corrects_bubble() {
            self.miss = self.volume_miss(model, x, v, g, dt);
            shift_pressure(rhs, g, self.stiffness * self.miss, dt);
        }
        if self.end_of_step && !regions.rim.is_empty() {
            self.rim_pressures(model, regions, v, g, rhs, dt, true);
        }
    }

    /// After a solve: the bubble's pressure shifted by its miss at the solve's velocities `v`,
    /// if that moves it by more than [`PRESSURE_TOLERANCE`]. Returns whether it did.
    pub(crate) fn correct_bubble(
        &mut self,
        model: &Model,
        x: &Soa,
        v: &Soa,
        g: &Soa,
        rhs: &mut Soa,
        dt: Real,
    ) -> bool {
        if !self.corrects_bubble() {
            return false;
        }
        let k = self.stiffness;
        let now = self.volume_miss(model, x, v, g, dt);
        let dp = self.shift.next(k * self.miss, k * now);
        if dp.abs() <= PRESSURE_TOLERANCE {
            return false;
        }
        shift_pressure(rhs, g, dp, dt);
        self.miss += dp / k;
        true
    }

    /// After a solve: the pockets' rims follow the pockets' end-of-step pressures at the solve's
    /// velocities `v`. Returns whether any particle's share changed.
    #[allow(clippy::too_many_arguments)] // the solve's vectors
    pub(crate) fn correct_rims(
        &mut self,
        model: &Model,
        regions: &Regions,
        v: &Soa,
        g: &Soa,
        rhs: &mut Soa,
        dt: Real,
    ) -> bool {
        self.end_of_step
            && !regions.rim.is_empty()
            && self.rim_pressures(model, regions, v, g, rhs, dt, false)
    }

    /// The end of the step: the pressure the thesis bubble's step applied (its gas spring's,
    /// linearised at the end of the step, from its pressure at the start `regions`' and the
    /// volume change `volume_change` (m^3) the pressure force's `g . dx` gives), written to
    /// the bubble.
    pub(crate) fn finish(
        &self,
        air: &mut AirModel,
        air_enabled: bool,
        regions: &Regions,
        volume_change: Real,
    ) {
        if let AirModel::Thesis(b) = air
            && air_enabled
            && let Some(r) = regions.list.first()
        {
            b.applied_pressure = if self.end_of_step {
                (r.pressure - r.stiffness * (volume_change + self.miss)).max(0.0)
            } else {
                r.pressure
            };
        }
    }

    /// Whether the thesis' bubble's volume change is measured for [`SolveShare::finish`].
    pub(crate) fn measures_bubble(&self) -> bool {
        self.thesis
    }

    /// How much the bubble's volume (eq. 3.10) at the end of the step, with the velocities `v`,
    /// differs from its linear prediction `now + sum of g_k . v_k dt` (m^3; `now` its volume at
    /// the step's start, the same eq. 3.10 at `x`). The thesis' pressure force `g_k = S N_k` is
    /// not the volume's gradient (a border particle's share of the volume is half an inner
    /// one's, its force the same), so a lift that raises the middle while the rim comes down
    /// changes the volume otherwise than `g` predicts.
    fn volume_miss(&mut self, model: &Model, x: &Soa, v: &Soa, g: &Soa, dt: Real) -> Real {
        let Some(plane) = model.sticking else {
            return 0.0;
        };
        let n = x.len();
        let end = &mut self.end;
        end.x.resize(n, 0.0);
        end.y.resize(n, 0.0);
        end.z.resize(n, 0.0);
        let mut linear = 0.0;
        for k in 0..n {
            let v = v.get(k);
            end.set(k, x.get(k) + v * dt);
            linear += g.get(k).dot(v) * dt;
        }
        let then = super::volume(model.grid(), end, plane, model.radius);
        then - self.start_volume - linear
    }

    /// The rims of the pockets of air: a sealed particle beside a pocket feels its share of the
    /// pocket's pressure difference (the mean over the cells around it, as the explicit step
    /// spreads it, `pockets::sealed_share`). A pocket's pressure at the step's end is what the
    /// solve finds (its gas spring: `P - (P / V) g . v dt`), so the share is applied from the
    /// last solve and the step solved again while it moves by more than
    /// [`PRESSURE_TOLERANCE`]: the rim lags the pocket by a solve, not by a step. (The rim's own
    /// motion does not enter the pocket's volume: a sealed particle lies on the surface.) With
    /// `start`, before the first solve of a step, the rims start from nothing applied and take
    /// the pockets' pressures now. Returns whether any particle's share changed.
    #[allow(clippy::too_many_arguments)] // the solve's vectors
    fn rim_pressures(
        &mut self,
        model: &Model,
        regions: &Regions,
        v: &Soa,
        g: &Soa,
        rhs: &mut Soa,
        dt: Real,
        start: bool,
    ) -> bool {
        let n = v.len();
        let count = regions.list.len();
        self.end_pressure.clear();
        self.end_pressure.resize(count, 0.0);
        if start {
            for &(k, _, _) in &regions.rim {
                self.rim_applied[k as usize] = 0.0;
            }
        } else {
            for k in 0..n {
                if let Some(r) = regions.of(k) {
                    self.end_pressure[r] += g.get(k).dot(v.get(k));
                }
            }
        }
        for (r, p) in self.end_pressure.iter_mut().enumerate() {
            let region = regions.list[r];
            *p = region.pressure - regions.atmosphere - region.stiffness * dt * *p;
        }
        for &(k, _, _) in &regions.rim {
            self.rim_target[k as usize] = 0.0;
        }
        for &(k, r, w) in &regions.rim {
            self.rim_target[k as usize] += w * self.end_pressure[r as usize];
        }
        let mut changed = false;
        for &(k, _, _) in &regions.rim {
            let k = k as usize;
            // At most the particle's water film's pull: a sealed particle is one the film holds,
            // so the air never pushes it off within a step (a pocket's pressure at its first
            // steps, its air placed under a flat cloth, is 1e8 Pa); the pressure beyond lifts the
            // cloth inside, and the sealing at the step's end decides where the rim now runs.
            let pull = model.wet_adhesion * model.wetness[k];
            self.rim_target[k] = self.rim_target[k].min(pull);
            let dp = self.rim_target[k] - self.rim_applied[k];
            if dp.abs() > PRESSURE_TOLERANCE {
                let f = rhs.get(k) + g.get(k) * (dp * dt);
                rhs.set(k, f);
                self.rim_applied[k] = self.rim_target[k];
                changed = true;
            }
        }
        changed
    }
}

/// The bubble's pressure shift inside a step, by a relaxed fixed-point iteration whose
/// relaxation is set from the slope it measures. The shift `s` (Pa) the solve applied should
/// equal the gas spring times the volume miss it leads to, `k miss(s)`: a root of
/// `F(s) = k miss(s) - s`. Taking `s = k miss` (the plain fixed-point step `s += F`) converges
/// only while the miss answers a shift by less than the shift itself; at large steps it does
/// not (the thesis' force `S N_k` and the volume's gradient differ on a tent's slopes, and the
/// gas spring is stiff), and the pressure swung by tens of pascals from step to step at 1/60 s.
/// Here the step is `F / (1 - F')`, `F'` measured from the last two solves and the scale kept
/// within [`Relaxation::MIN_SCALE`] and [`Relaxation::MAX_SCALE`]. For a miss linear in the
/// shift, `k miss = a + G' s`, that shrinks the error by `1 / (2 - G')` a solve for every slope
/// `G' < 1` down to `-8`, the oscillating ones (`G' < -1`) where the plain step diverges
/// included; below `-8` the scale's floor binds and the error is multiplied by
/// `1 - 0.1 (1 - G')` a solve, which still shrinks it down to `G' = -19` and no further (the
/// unit test measures both regimes). (It is not the secant step `-F / F'`, which would land on
/// a linear miss's root at once; the measurements in docs/integrators.md are of this one.)
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Relaxation {
    /// The last shift (Pa) and its residual `F` (Pa), if any.
    pub(crate) last: Option<(Real, Real)>,
}

impl Relaxation {
    /// Smallest and largest scale of the fixed-point step: a slope that would ask for less or
    /// more is taken as measured through the noise of a changing contact set.
    const MIN_SCALE: Real = 0.1;
    const MAX_SCALE: Real = 1.5;

    /// The change of shift (Pa) after a solve with shift `s` (Pa) whose miss asks for
    /// `target` (Pa, the gas spring times the miss).
    pub(crate) fn next(&mut self, s: Real, target: Real) -> Real {
        let f = target - s;
        let scale = match self.last {
            Some((s0, f0)) if s != s0 => {
                let slope = (f - f0) / (s - s0);
                (1.0 / (1.0 - slope)).clamp(Self::MIN_SCALE, Self::MAX_SCALE)
            }
            _ => 1.0,
        };
        self.last = Some((s, f));
        scale * f
    }
}

/// Adds to the right-hand side `rhs` the pressure force of a drop `dp` (Pa) of the bubble's
/// pressure: `-dp g_k dt` on every particle.
fn shift_pressure(rhs: &mut Soa, g: &Soa, dp: Real, dt: Real) {
    for k in 0..rhs.len() {
        let f = rhs.get(k) - g.get(k) * (dp * dt);
        rhs.set(k, f);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A miss that answers a shift linearly, `k miss(s) = a - b s` (`G' = -b`), root `a / (1 +
    /// b)`. With `b = 2` the plain fixed-point step multiplies the error by `-b` and diverges;
    /// the relaxed one, after its first (plain) step, shrinks it by `1 / (2 - G') = 1 / 4` a
    /// solve. With `b = 20` the scale `1 / 22` is below [`Relaxation::MIN_SCALE`] and clamped:
    /// the error is multiplied by `1 - 0.1 (1 + b) = -1.1` a solve.
    #[test]
    fn relaxation_converges_where_the_fixed_point_diverges() {
        let errors = |b: Real, plain: bool| {
            let (a, root) = (10.0, 10.0 / (1.0 + b));
            let mut shift = Relaxation::default();
            let mut s: Real = 0.0;
            let mut out = Vec::new();
            for _ in 0..6 {
                let target = a - b * s;
                s += if plain {
                    target - s
                } else {
                    shift.next(s, target)
                };
                out.push(s - root);
            }
            out
        };
        let plain = errors(2.0, true);
        let relaxed = errors(2.0, false);
        for w in plain.windows(2) {
            assert!((w[1] / w[0] + 2.0).abs() < 1e-9, "plain: {plain:?}");
        }
        for w in relaxed[1..].windows(2) {
            assert!((w[1] / w[0] - 0.25).abs() < 1e-9, "relaxed: {relaxed:?}");
        }
        let clamped = errors(20.0, false);
        for w in clamped[1..].windows(2) {
            assert!((w[1] / w[0] + 1.1).abs() < 1e-9, "clamped: {clamped:?}");
        }
    }
}
