//! The air pockets in the viewer: each sealed pocket's cloth tinted by its pressure (the
//! diverging colour map of `wetcloth render --pockets`, [`wetcloth_render::pressure_colour`]:
//! blue below atmospheric, red above), and the list of pockets the side panel shows. Pure
//! functions of a [`Snapshot`], tested without a window.

use wetcloth::air::PocketReport;
use wetcloth_export::NO_POCKET;
use wetcloth_render::pressure_colour;

use crate::runner::Snapshot;

/// Smallest half range of the live colour map, Pa (a pocket at atmospheric pressure stays
/// near white instead of showing round-off).
pub const MIN_RANGE: f64 = 1.0;

/// The live colour map's half range, Pa: the largest `|P - P_a|` of the current pockets, at
/// least [`MIN_RANGE`].
pub fn colour_range(snap: &Snapshot) -> f64 {
    let pa = snap.config.air.atmospheric_pressure;
    snap.pockets
        .iter()
        .map(|p| (p.pressure - pa).abs())
        .filter(|d| d.is_finite())
        .fold(MIN_RANGE, f64::max)
}

/// A tint per cloth vertex (linear RGB, weight) for the renderer: each pocket's particles in
/// its pressure's colour on a half range of `range` Pa, the others keep the cloth's colour;
/// with the thesis model the whole cloth takes its bubble's (pocket 0's) colour.
pub fn pocket_tints(snap: &Snapshot, range: f64) -> Vec<[f32; 4]> {
    let pa = snap.config.air.atmospheric_pressure;
    let colour = |p: &PocketReport| {
        let [r, g, b] = pressure_colour((p.pressure - pa) / range);
        [r, g, b, 1.0]
    };
    let n = snap.positions.len();
    match &snap.pocket_of {
        None => {
            let tint = snap
                .pockets
                .iter()
                .find(|p| p.id == 0)
                .map_or([0.0; 4], colour);
            vec![tint; n]
        }
        Some(labels) => labels
            .iter()
            .map(|&l| match snap.pockets.iter().find(|p| p.id == l) {
                Some(p) if l != NO_POCKET => colour(p),
                _ => [0.0; 4],
            })
            .chain(std::iter::repeat([0.0; 4]))
            .take(n)
            .collect(),
    }
}

/// One row of the side panel's pocket list, in the panel's units.
#[derive(Clone, Debug, PartialEq)]
pub struct PocketRow {
    /// The pocket's id (as in `pockets.csv`).
    pub id: u32,
    /// Volume, cm^3.
    pub volume_cm3: f64,
    /// Air, cm^3 at atmospheric pressure.
    pub amount_cm3: f64,
    /// Pressure, Pa.
    pub pressure: f64,
    /// Pressure minus atmospheric, Pa.
    pub delta_p: f64,
    /// Cloth area over it, cm^2.
    pub area_cm2: f64,
    /// Particles in it.
    pub particles: u32,
}

/// The pockets of `snap` as the side panel lists them, by id.
pub fn pocket_rows(snap: &Snapshot) -> Vec<PocketRow> {
    let pa = snap.config.air.atmospheric_pressure;
    let mut rows: Vec<PocketRow> = snap
        .pockets
        .iter()
        .map(|p| PocketRow {
            id: p.id,
            volume_cm3: p.volume * 1e6,
            amount_cm3: p.amount * 1e6,
            pressure: p.pressure,
            delta_p: p.pressure - pa,
            area_cm2: p.area * 1e4,
            particles: p.particles,
        })
        .collect();
    rows.sort_by_key(|r| r.id);
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::runner::Runner;
    use std::time::{Duration, Instant};
    use wetcloth::{PocketSeed, SimConfig, params::AirModelKind};

    /// Two seeded pockets under a wet 21 x 21 cloth, left and right of its centre.
    fn two_pockets() -> SimConfig {
        let mut c = SimConfig::thesis_demo();
        c.air.model = AirModelKind::Pockets;
        c.air.trapped_air = 0.0;
        c.cloth.resolution = [21, 21];
        c.cloth.position.y = c.cloth.particle_radius();
        c.cloth.self_collision = false;
        c.grabs.clear();
        c.air.pockets = [-0.07, 0.07]
            .map(|x| PocketSeed {
                center: [x, 0.0],
                radius: 0.04,
                amount: 15e-6,
                point: None,
            })
            .to_vec();
        c
    }

    fn wait_for(r: &Runner, ok: impl Fn(&Snapshot) -> bool) -> std::sync::Arc<Snapshot> {
        let start = Instant::now();
        loop {
            let s = r.latest();
            if ok(&s) {
                return s;
            }
            assert!(start.elapsed() < Duration::from_secs(60), "timed out");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    #[test]
    fn the_pocket_list_and_tint_follow_the_simulation() {
        let r = Runner::start(two_pockets(), || {}).unwrap();
        let s = wait_for(&r, |s| s.metrics.time > 0.1);
        let rows = pocket_rows(&s);
        assert_eq!(rows.len(), 2, "{rows:?}");
        assert_eq!(rows.len() as f64, s.metrics.pocket_count);
        let labels = s.pocket_of.as_ref().expect("pockets model: labels");
        let tints = pocket_tints(&s, colour_range(&s));
        assert_eq!(tints.len(), 21 * 21);
        for row in &rows {
            // Each seed holds its 15 cm^3, inflated to a little above atmospheric (Boyle).
            assert!((row.amount_cm3 - 15.0).abs() < 1e-6, "{row:?}");
            assert!(row.delta_p > 0.0, "{row:?}");
            assert!(
                ((row.pressure * row.volume_cm3) / (101325.0 * row.amount_cm3) - 1.0).abs() < 1e-9,
                "P V = P_a N: {row:?}"
            );
            // The listed particle count is the particles tinted for it, all red.
            let mine: Vec<usize> = (0..labels.len()).filter(|&k| labels[k] == row.id).collect();
            assert_eq!(mine.len(), row.particles as usize);
            for &k in &mine {
                let [red, green, blue, weight] = tints[k];
                assert!(
                    weight == 1.0 && red > green && red > blue,
                    "{k}: {:?}",
                    tints[k]
                );
            }
        }
        // The largest pocket pressure saturates the map: deep red.
        let worst = rows.iter().map(|r| r.delta_p).fold(0.0, f64::max);
        assert_eq!(colour_range(&s), worst.max(MIN_RANGE));
        // Outside the pockets the cloth keeps its colour.
        let outside = (0..labels.len()).filter(|&k| labels[k] == NO_POCKET);
        assert!(outside.clone().count() > 0);
        for k in outside {
            assert_eq!(tints[k][3], 0.0);
        }
    }

    #[test]
    fn a_thesis_bubble_tints_the_whole_cloth() {
        let mut c = SimConfig::thesis_demo();
        c.cloth.resolution = [12, 12];
        c.grabs.clear();
        let r = Runner::start(c, || {}).unwrap();
        let s = wait_for(&r, |s| s.metrics.time > 0.02);
        assert!(s.pocket_of.is_none());
        let rows = pocket_rows(&s);
        assert_eq!(rows.len(), 1);
        assert_eq!(rows[0].id, 0);
        let tints = pocket_tints(&s, colour_range(&s));
        assert_eq!(tints.len(), 144);
        assert!(tints.iter().all(|t| t[3] == 1.0 && *t == tints[0]));
    }
}
