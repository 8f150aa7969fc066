//! Per-frame measurements: the columns of `metrics.csv`.

use crate::math::{Real, Soa};
use crate::model::Layout;

/// Column names of [`FrameMetrics::values`], in order, as in `metrics.csv` (after `frame`).
pub const COLUMNS: [&str; 12] = [
    "time",
    "air_volume",
    "air_pressure",
    "kinetic_energy",
    "max_stretch",
    "contact_fraction",
    "max_height",
    "grab_force",
    "trapped_air",
    "pocket_count",
    "elastic_energy",
    "attach_force",
];

/// Measurements of one state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameMetrics {
    /// Simulated time, s.
    pub time: Real,
    /// Bubble volume (eq. 3.10), m^3.
    pub air_volume: Real,
    /// Bubble pressure (Boyle, eq. 3.9), Pa; atmospheric with the air force off.
    pub air_pressure: Real,
    /// Kinetic energy, J ([`crate::State::kinetic_energy`]: Verlet's velocities are
    /// `(x(t) - x(t - dt)) / dt`).
    pub kinetic_energy: Real,
    /// Largest relative elongation of a structural spring (0.1 = 10 % longer than at rest;
    /// negative when every spring is compressed); under `model = "membrane"` the largest
    /// principal stretch minus one of any triangle.
    pub max_stretch: Real,
    /// Fraction of particles that touched a collider during the last step, 0..1.
    pub contact_fraction: Real,
    /// Largest particle height (y), m.
    pub max_height: Real,
    /// Magnitude of the summed force of all grabs on the cloth, N.
    pub grab_force: Real,
    /// Air trapped under the cloth, m^3 at atmospheric pressure (changes only with a leak).
    pub trapped_air: Real,
    /// Sealed pockets (the pockets model); 1 with the thesis' single bubble.
    pub pocket_count: Real,
    /// Elastic energy stored in the cloth, J: its springs', or its membrane and bending
    /// elements' (`model = "membrane"`).
    pub elastic_energy: Real,
    /// Magnitude of the summed force of all attachments (`[[attach]]`) on the cloth, N (0
    /// without attachments; `grab_force` does not count them).
    pub attach_force: Real,
}

impl FrameMetrics {
    /// The cloth's own columns of positions `x` on `layout` (a mesh: every spring) with contact flags `contact`: the
    /// largest height (m), the largest relative stretch of a structural spring, and the
    /// fraction of particles touching a collider, as `(max_height, max_stretch,
    /// contact_fraction)`. [`crate::Simulation::metrics`] adds the rest.
    pub fn cloth(layout: Layout<'_>, x: &Soa, contact: &[bool]) -> (Real, Real, Real) {
        let grid = match layout {
            Layout::Grid(grid) => grid,
            Layout::Mesh(_, springs) => {
                let n = x.len();
                let mut max_height = Real::NEG_INFINITY;
                let mut contacts = 0usize;
                for k in 0..n {
                    max_height = max_height.max(x.y[k]);
                    contacts += usize::from(contact[k]);
                }
                let mut max_stretch = Real::NEG_INFINITY;
                for (s, &[a, b]) in springs.ends.iter().enumerate() {
                    let l = (x.get(b as usize) - x.get(a as usize)).length();
                    max_stretch = max_stretch.max(l / springs.rest[s] - 1.0);
                }
                return (max_height, max_stretch, contacts as Real / n as Real);
            }
        };
        let n = grid.len();
        let mut max_height = Real::NEG_INFINITY;
        let mut max_stretch = Real::NEG_INFINITY;
        let mut contacts = 0usize;
        for k in 0..n {
            let p = x.get(k);
            max_height = max_height.max(p.y);
            contacts += usize::from(contact[k]);
            let (i, j) = (k % grid.nx, k / grid.nx);
            if i + 1 < grid.nx {
                max_stretch = max_stretch.max((x.get(k + 1) - p).length() / grid.dx - 1.0);
            }
            if j + 1 < grid.nz {
                max_stretch = max_stretch.max((x.get(k + grid.nx) - p).length() / grid.dz - 1.0);
            }
        }
        (max_height, max_stretch, contacts as Real / n as Real)
    }

    /// The values in [`COLUMNS`] order.
    pub fn values(&self) -> [Real; 12] {
        [
            self.time,
            self.air_volume,
            self.air_pressure,
            self.kinetic_energy,
            self.max_stretch,
            self.contact_fraction,
            self.max_height,
            self.grab_force,
            self.trapped_air,
            self.pocket_count,
            self.elastic_energy,
            self.attach_force,
        ]
    }
}
