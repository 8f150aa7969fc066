//! The air's share of the solve: the thesis bubble's pressure shift from its volume miss
//! (a relaxed fixed point, [`Relaxation`]) and the pockets' rims following the end-of-step
//! pressures of their pockets.

use super::*;

/// Pressure change (Pa) of the bubble's volume correction that calls for another solve.
pub(super) const PRESSURE_TOLERANCE: Real = 1e-2;

/// Most solves after the contact set is settled that only correct the bubble's pressure.
pub(super) const PRESSURE_PASSES: usize = 4;

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
pub(super) struct Relaxation {
    /// The last shift (Pa) and its residual `F` (Pa), if any.
    pub(super) last: Option<(Real, Real)>,
}

impl Relaxation {
    /// Smallest and largest scale of the fixed-point step: a slope that would ask for less or
    /// more is taken as measured through the noise of a changing contact set.
    const MIN_SCALE: Real = 0.1;
    const MAX_SCALE: Real = 1.5;

    /// The change of shift (Pa) after a solve with shift `s` (Pa) whose miss asks for
    /// `target` (Pa, the gas spring times the miss).
    pub(super) fn next(&mut self, s: Real, target: Real) -> Real {
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

impl Implicit {
    /// How much the bubble's volume (eq. 3.10) at the end of the step, with the current
    /// velocities, differs from its linear prediction `now + sum of g_k . v_k dt` (m^3;
    /// `now` its volume at the step's start, the same eq. 3.10 at `x`). The
    /// thesis' pressure force `g_k = S N_k` is not the volume's gradient (a border particle's
    /// share of the volume is half an inner one's, its force the same), so a lift that raises
    /// the middle while the rim comes down changes the volume otherwise than `g` predicts.
    pub(super) fn volume_miss(&mut self, model: &Model, x: &Soa, now: Real, dt: Real) -> Real {
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
            let v = self.v.get(k);
            end.set(k, x.get(k) + v * dt);
            linear += self.per_pascal.get(k).dot(v) * dt;
        }
        let then = crate::air::volume(&model.grid, end, plane, model.radius);
        then - now - linear
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
    pub(super) fn rim_pressures(
        &mut self,
        model: &Model,
        regions: &Regions,
        dt: Real,
        start: bool,
    ) -> bool {
        let n = self.v.len();
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
                    self.end_pressure[r] += self.per_pascal.get(k).dot(self.v.get(k));
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
                let f = self.rhs.get(k) + self.per_pascal.get(k) * (dp * dt);
                self.rhs.set(k, f);
                self.rim_applied[k] = self.rim_target[k];
                changed = true;
            }
        }
        changed
    }

    /// Adds to the right-hand side the pressure force of a drop `dp` (Pa) of the bubble's
    /// pressure: `-dp g_k dt` on every particle.
    pub(super) fn shift_pressure(&mut self, dp: Real, dt: Real) {
        for k in 0..self.rhs.len() {
            let f = self.rhs.get(k) - self.per_pascal.get(k) * (dp * dt);
            self.rhs.set(k, f);
        }
    }
}
