//! The pocket labels of a run (`frames/frame_NNNN.pockets`, see `wetcloth_export::labels`):
//! with the pockets air model, each written frame also says which sealed pocket each particle
//! is in, so that `wetcloth render --pockets` can tint the pockets by their pressure.

use crate::error::CliError;
use std::fs;
use std::path::Path;
use wetcloth::Simulation;
use wetcloth_export::{
    is_pocket_labels_file_name, particle_pocket_ids, pocket_labels_file_name, write_atomically,
    write_pocket_labels,
};

/// Writes frame `frame`'s pocket labels into `frames_dir` (nothing with the thesis air model).
/// Frame 0 first removes the label files an earlier run left there (with the thesis model too),
/// so that a label file always belongs to the run beside it.
pub fn write_frame(frames_dir: &Path, sim: &Simulation, frame: u64) -> Result<(), CliError> {
    if frame == 0 {
        remove_stale(frames_dir)?;
    }
    let Some(labels) = particle_pocket_ids(sim) else {
        return Ok(());
    };
    let path = frames_dir.join(pocket_labels_file_name(frame));
    write_atomically(&path, |w| write_pocket_labels(w, &labels)).map_err(CliError::output(&path))
}

/// Removes label files (and their `.part` leftovers) from `frames_dir`; other files stay.
fn remove_stale(frames_dir: &Path) -> Result<(), CliError> {
    let entries = fs::read_dir(frames_dir).map_err(CliError::output(frames_dir))?;
    for entry in entries {
        let entry = entry.map_err(CliError::output(frames_dir))?;
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let stale = is_pocket_labels_file_name(&name)
            || name
                .strip_suffix(".part")
                .is_some_and(is_pocket_labels_file_name);
        if stale && entry.file_type().is_ok_and(|t| !t.is_dir()) {
            fs::remove_file(entry.path()).map_err(CliError::output(entry.path()))?;
        }
    }
    Ok(())
}
