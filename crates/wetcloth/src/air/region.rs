//! The trapped air as an implicit integrator sees it: a list of sealed regions, each with its
//! amount of air `K = P_a v0` (J) and its current volume `V` (m^3), and the region of each
//! particle.
//!
//! Both air models are regions: the thesis' single bubble (3.4) is one region holding every
//! particle; the pockets model has one region per sealed pocket, and particles in no pocket feel
//! no pressure. Each region is a gas spring: its pressure `P = K / V` (Boyle, eq. 3.9) changes
//! with the volume at the rate `dP/dV = -K / V^2 = -P / V`, so its force `(P - P_a) g_i` on
//! particle `i` (`g_i = dV/dx_i`, which eq. 3.7 approximates by `S N_i`) has the rank-one
//! Hessian `-(P / V) g g^T`. An implicit solve keeps that term inside its linear system, so the
//! gas spring, however stiff, does not limit the step.

use super::{AirModel, MIN_GAP, boyle_pressure, pockets};
use crate::math::Real;
use crate::model::Model;
use crate::params::AirParams;

/// Label of a particle in no region.
pub const NO_REGION: u32 = u32::MAX;

/// One sealed region of air.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Region {
    /// Its pressure now, Pa: Boyle's law on its amount and volume (volume floored at
    /// [`MIN_GAP`] times its area), or the applied pressure when the air is a vacuum.
    pub pressure: Real,
    /// Its gas spring's stiffness `-dP/dV = P / V`, Pa/m^3 (0 for a vacuum: the pressure does
    /// not change with the volume).
    pub stiffness: Real,
}

/// The regions of the air and each particle's region.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Regions {
    /// Atmospheric pressure `P_a`, Pa.
    pub atmosphere: Real,
    /// The regions.
    pub list: Vec<Region>,
    /// Each particle's region (index into `list`) or [`NO_REGION`]; empty when every particle
    /// is in region 0 (the thesis' bubble).
    pub label: Vec<u32>,
    /// A pressure difference of its own on each particle in no region, Pa (the pockets
    /// model's water film pulling a sealed particle onto the surface, negative); empty when
    /// there is none.
    pub extra: Vec<Real>,
    /// The sealed particles on the rims of pockets of air, each with its share of one such
    /// region's pressure difference: `(particle, region, weight)`, the weight one over the
    /// number of cells around the particle for each of its cells in that region (the mean
    /// over its cells that the explicit step spreads). Their pressure is the region's at the
    /// step's end, which only the solve finds: the implicit step applies it from its solves.
    pub rim: Vec<(u32, u32, Real)>,
}

impl Regions {
    /// The region of particle `k`, if any.
    #[inline]
    pub fn of(&self, k: usize) -> Option<usize> {
        if self.list.is_empty() {
            return None;
        }
        if self.label.is_empty() {
            return Some(0);
        }
        let r = self.label[k];
        (r != NO_REGION).then_some(r as usize)
    }
}

/// A gas spring of `trapped` m^3 of air at atmospheric pressure `pa` (Pa) in `volume` m^3 under
/// a cloth area `area` m^2.
fn gas_spring(pa: Real, trapped: Real, volume: Real, area: Real) -> Region {
    let pressure = boyle_pressure(pa, trapped, volume, area);
    Region {
        pressure,
        stiffness: pressure / volume.max(MIN_GAP * area),
    }
}

impl AirModel {
    /// The air as regions (see the module docs) with the air force `enabled`; no region with
    /// the force off or without a sticking surface.
    pub(crate) fn regions(&self, air: &AirParams, model: &Model, enabled: bool, out: &mut Regions) {
        out.atmosphere = air.atmospheric_pressure;
        out.list.clear();
        out.label.clear();
        out.extra.clear();
        out.rim.clear();
        let needs_plane = matches!(self, AirModel::Thesis(_));
        if !enabled || (needs_plane && model.sticking.is_none()) {
            return;
        }
        let pa = air.atmospheric_pressure;
        match self {
            AirModel::Thesis(b) => {
                out.list
                    .push(gas_spring(pa, b.trapped_air, b.volume, model.cloth_area));
            }
            AirModel::Pockets(p) => {
                // A sealed particle in no pocket: the water film's pull, and its share of the
                // vacuums around it (the mean over its cells, as the explicit step spreads the
                // pockets' pressures), so that a particle joining a vacuum takes on its load a
                // cell at a time. (A pocket of air is a gas spring, whose pressure at the
                // step's end the solve finds: its share goes to `rim`.)
                if p.sealed.iter().any(|&s| s) {
                    let (nx, nz) = (model.grid().nx, model.grid().nz);
                    let vacuum = |q: usize| {
                        let pocket = &p.pockets[q];
                        if pocket.amount > 0.0 { 0.0 } else { -pa }
                    };
                    out.extra.resize(nx * nz, 0.0);
                    for k in 0..nx * nz {
                        if !p.sealed[k] || p.particle_pocket[k] != pockets::NONE {
                            continue;
                        }
                        let (i, j) = (k % nx, k / nx);
                        out.extra[k] = pockets::sealed_share(&p.cell_pocket, nx, nz, i, j, vacuum)
                            - model.wet_adhesion * model.wetness[k];
                        pockets::sealed_weights(&p.cell_pocket, nx, nz, i, j, |q, w| {
                            if p.pockets[q].amount > 0.0 {
                                out.rim.push((k as u32, q as u32, w));
                            }
                        });
                    }
                }
                out.list.extend(
                    p.pockets
                        .iter()
                        .map(|q| gas_spring(pa, q.amount, q.volume, q.area)),
                );
                out.label.extend(
                    p.particle_pocket.iter().map(
                        |&r| {
                            if r == pockets::NONE { NO_REGION } else { r }
                        },
                    ),
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The gas spring's stiffness is minus Boyle's dP/dV, checked by a finite difference.
    #[test]
    fn gas_spring_stiffness_is_minus_boyles_slope() {
        let (pa, v0, area) = (101_325.0, 2e-4, 0.09);
        for v in [1e-4, 5e-4, 2e-3] {
            let r = gas_spring(pa, v0, v, area);
            let dv = 1e-9 * v;
            let slope = (boyle_pressure(pa, v0, v + dv, area)
                - boyle_pressure(pa, v0, v - dv, area))
                / (2.0 * dv);
            assert!((r.stiffness + slope).abs() < 1e-6 * r.stiffness, "{v}");
            assert!((r.pressure * v - pa * v0).abs() < 1e-9);
        }
        // A vacuum is no spring.
        assert_eq!(gas_spring(pa, 0.0, 1e-3, area).stiffness, 0.0);
    }
}
