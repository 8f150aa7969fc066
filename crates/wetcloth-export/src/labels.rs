//! Pocket labels: which sealed air pocket each particle is in, one file per written frame
//! (`frames/frame_NNNN.pockets`, written with the pockets air model), so that a renderer can
//! tint each pocket by its pressure from `pockets.csv`.
//!
//! # Format
//!
//! Plain text, run-length encoded over the particles in their order (particle `k` is vertex `k`
//! of the frame's OBJ, row-major over the grid):
//!
//! ```text
//! wetcloth pocket labels 1
//! particles 2500
//! - 1210
//! 3 12
//! - 38
//! 3 14
//! ...
//! ```
//!
//! The first line names the format and its version; the second the particle count. Every
//! following line is a run: `ID COUNT`, `COUNT` (at least 1) consecutive particles in the pocket
//! whose id is `ID` (the `pocket` column of `pockets.csv` in the same frame), or `- COUNT`,
//! particles in no pocket (sealed on the surface, or under air open to the room). The runs
//! cover exactly `particles` particles; a run never repeats the label of the run before it.
//! Blank lines and lines starting with `#` are ignored.

use std::fmt;
use std::io::{self, Write};

use wetcloth::Simulation;

/// The label of a particle in no pocket.
pub const NO_POCKET: u32 = u32::MAX;

/// The first line of a pocket-labels file.
pub const POCKET_LABELS_MAGIC: &str = "wetcloth pocket labels 1";

/// Name of the pocket-labels file of frame `frame`: `frame_NNNN.pockets`, numbered as
/// [`crate::frame_file_name`] numbers the OBJ frames.
pub fn pocket_labels_file_name(frame: u64) -> String {
    format!("frame_{frame:04}.pockets")
}

/// Whether `name` is a pocket-labels file name as [`pocket_labels_file_name`] writes it.
pub fn is_pocket_labels_file_name(name: &str) -> bool {
    name.strip_prefix("frame_")
        .and_then(|s| s.strip_suffix(".pockets"))
        .is_some_and(|n| n.len() >= 4 && n.bytes().all(|b| b.is_ascii_digit()))
}

/// Each particle's pocket id in `sim` (the id of `pockets.csv`), or [`NO_POCKET`]; `None` with
/// the thesis air model (its single bubble, pocket 0, lies under the whole cloth).
pub fn particle_pocket_ids(sim: &Simulation) -> Option<Vec<u32>> {
    let p = sim.air().pockets()?;
    Some(
        p.particle_pocket
            .iter()
            .map(|&q| match p.pockets.get(q as usize) {
                Some(pocket) => pocket.id,
                None => NO_POCKET,
            })
            .collect(),
    )
}

/// Writes `labels` (one per particle: a pocket id or [`NO_POCKET`]) in the format above.
pub fn write_pocket_labels(mut w: impl Write, labels: &[u32]) -> io::Result<()> {
    writeln!(w, "{POCKET_LABELS_MAGIC}")?;
    writeln!(w, "particles {}", labels.len())?;
    let mut rest = labels;
    while let Some(&first) = rest.first() {
        let run = rest.iter().take_while(|&&l| l == first).count();
        if first == NO_POCKET {
            writeln!(w, "- {run}")?;
        } else {
            writeln!(w, "{first} {run}")?;
        }
        rest = &rest[run..];
    }
    w.flush()
}

/// Why a pocket-labels file could not be read: the line (1-based, when one is to blame) and
/// what is wrong there.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LabelsError {
    /// The line at fault, 1-based; `None` for the file as a whole (it ends too early).
    pub line: Option<usize>,
    /// What is wrong, naming the value and what is allowed.
    pub message: String,
}

impl fmt::Display for LabelsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "line {l}: {}", self.message),
            None => write!(f, "{}", self.message),
        }
    }
}

impl std::error::Error for LabelsError {}

/// Most particles a labels file may declare (a 16384 x 16384 cloth), so that a corrupt count
/// cannot ask for an absurd allocation.
const MAX_PARTICLES: usize = 1 << 28;

/// Parses the text of a pocket-labels file: one label per particle (a pocket id or
/// [`NO_POCKET`]).
pub fn parse_pocket_labels(text: &str) -> Result<Vec<u32>, LabelsError> {
    let err = |line: usize, message: String| LabelsError {
        line: Some(line),
        message,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    match lines.next() {
        Some((_, l)) if l == POCKET_LABELS_MAGIC => {}
        Some((n, l)) => {
            return Err(err(
                n,
                format!("expected {POCKET_LABELS_MAGIC:?} (a pocket-labels file), found {l:?}"),
            ));
        }
        None => {
            return Err(LabelsError {
                line: None,
                message: "empty: expected a pocket-labels file".into(),
            });
        }
    }
    let (n, l) = lines.next().ok_or_else(|| LabelsError {
        line: None,
        message: "ends after its first line: expected \"particles N\"".into(),
    })?;
    let count = l
        .strip_prefix("particles")
        .map(str::trim)
        .and_then(|c| c.parse::<usize>().ok())
        .filter(|&c| c <= MAX_PARTICLES)
        .ok_or_else(|| {
            err(
                n,
                format!("expected \"particles N\" with N from 0 to {MAX_PARTICLES}, found {l:?}"),
            )
        })?;
    let mut labels = Vec::with_capacity(count);
    let mut previous: Option<u32> = None;
    for (n, l) in lines {
        let mut fields = l.split_whitespace();
        let (Some(id), Some(run), None) = (fields.next(), fields.next(), fields.next()) else {
            return Err(err(
                n,
                format!("expected a run \"ID COUNT\" or \"- COUNT\", found {l:?}"),
            ));
        };
        let label = if id == "-" {
            NO_POCKET
        } else {
            match id.parse::<u32>() {
                Ok(v) if v != NO_POCKET => v,
                _ => {
                    return Err(err(
                        n,
                        format!(
                            "pocket id {id:?} is not allowed: expected 0 to {} or \"-\" (no pocket)",
                            NO_POCKET - 1
                        ),
                    ));
                }
            }
        };
        let run = match run.parse::<usize>() {
            Ok(r) if r >= 1 => r,
            _ => {
                return Err(err(
                    n,
                    format!("run length {run:?} is not allowed: expected a whole number >= 1"),
                ));
            }
        };
        if previous == Some(label) {
            return Err(err(
                n,
                format!("run repeats the label {id} of the line before (runs must alternate)"),
            ));
        }
        if run > count - labels.len() {
            return Err(err(
                n,
                format!(
                    "run of {run} goes past the {count} particles declared ({} labelled before it)",
                    labels.len()
                ),
            ));
        }
        labels.resize(labels.len() + run, label);
        previous = Some(label);
    }
    if labels.len() != count {
        return Err(LabelsError {
            line: None,
            message: format!(
                "labels {} particles, but declares {count} (file cut short?)",
                labels.len()
            ),
        });
    }
    Ok(labels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_round_trip_run_length_encoded() {
        let mut labels = vec![NO_POCKET; 100];
        labels[10..20].fill(3);
        labels[20..25].fill(7);
        labels[40..60].fill(3);
        labels[99] = 0;
        let mut out = Vec::new();
        write_pocket_labels(&mut out, &labels).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert_eq!(
            text,
            "wetcloth pocket labels 1\nparticles 100\n- 10\n3 10\n7 5\n- 15\n3 20\n- 39\n0 1\n"
        );
        assert_eq!(parse_pocket_labels(&text).unwrap(), labels);
        // No particles, all in no pocket, all in one pocket.
        for labels in [vec![], vec![NO_POCKET; 7], vec![12; 7]] {
            let mut out = Vec::new();
            write_pocket_labels(&mut out, &labels).unwrap();
            let text = String::from_utf8(out).unwrap();
            assert_eq!(parse_pocket_labels(&text).unwrap(), labels, "{text}");
        }
    }

    #[test]
    fn bad_labels_files_are_refused_naming_the_line() {
        let head = "wetcloth pocket labels 1\nparticles 5\n";
        let cases = [
            ("", None, "empty"),
            ("wetcloth pocket labels 2\n", Some(1), "pocket-labels file"),
            ("wetcloth pocket labels 1\n", None, "particles N"),
            (
                "wetcloth pocket labels 1\nparticles x\n",
                Some(2),
                "particles N",
            ),
            (&format!("{head}- 2\n3\n"), Some(4), "ID COUNT"),
            (&format!("{head}- 2\n3 1 1\n"), Some(4), "ID COUNT"),
            (&format!("{head}x 5\n"), Some(3), "pocket id \"x\""),
            (&format!("{head}4294967295 5\n"), Some(3), "pocket id"),
            (&format!("{head}- 0\n"), Some(3), ">= 1"),
            (&format!("{head}- -1\n"), Some(3), ">= 1"),
            (&format!("{head}- 2\n- 3\n"), Some(4), "repeats"),
            (&format!("{head}- 2\n3 4\n"), Some(4), "goes past the 5"),
            (&format!("{head}- 2\n3 2\n"), None, "labels 4 particles"),
        ];
        for (text, line, needle) in cases {
            let e = parse_pocket_labels(text).unwrap_err();
            assert_eq!(e.line, line, "{text:?}: {e}");
            assert!(e.to_string().contains(needle), "{text:?}: {e}");
        }
        // Comments and blank lines are fine.
        let text = format!("# made by hand\n{head}\n- 2\n# a pocket\n3 3\n");
        assert_eq!(
            parse_pocket_labels(&text).unwrap(),
            [NO_POCKET, NO_POCKET, 3, 3, 3]
        );
    }

    #[test]
    fn label_file_names_follow_the_frame_numbers() {
        assert_eq!(pocket_labels_file_name(7), "frame_0007.pockets");
        assert_eq!(pocket_labels_file_name(12345), "frame_12345.pockets");
        assert!(is_pocket_labels_file_name("frame_0007.pockets"));
        assert!(!is_pocket_labels_file_name("frame_0007.obj"));
        assert!(!is_pocket_labels_file_name("frame_7.pockets"));
    }

    #[test]
    fn particle_ids_come_from_the_simulation_pockets() {
        use wetcloth::{SimConfig, air::pockets::NONE};
        let sim = Simulation::new(SimConfig::thesis_demo()).unwrap();
        assert_eq!(particle_pocket_ids(&sim), None, "thesis model: no labels");
        let mut c = SimConfig::thesis_demo();
        c.air.model = wetcloth::params::AirModelKind::Pockets;
        c.air.trapped_air = 0.0;
        c.cloth.resolution = [15, 15];
        c.cloth.position.y = c.cloth.particle_radius();
        c.grabs.clear();
        c.air.pockets.push(wetcloth::PocketSeed {
            center: [0.0, 0.0],
            radius: 0.06,
            amount: 1e-6,
            point: None,
        });
        let sim = Simulation::new(c).unwrap();
        let ids = particle_pocket_ids(&sim).unwrap();
        let pockets = sim.air().pockets().unwrap();
        assert_eq!(ids.len(), sim.grid().len());
        assert!(!pockets.pockets.is_empty(), "the seeded pocket is sealed");
        for (k, &id) in ids.iter().enumerate() {
            let q = pockets.particle_pocket[k];
            if q == NONE {
                assert_eq!(id, NO_POCKET);
            } else {
                assert_eq!(id, pockets.pockets[q as usize].id);
            }
        }
        let inside = ids.iter().filter(|&&i| i != NO_POCKET).count();
        assert!(inside > 0, "the seed's particles are in its pocket");
    }
}
