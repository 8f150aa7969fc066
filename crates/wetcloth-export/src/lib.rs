//! # wetcloth-export: what a run writes
//!
//! Writers for the files of a run directory, each to any [`std::io::Write`], with no physics:
//!
//! - [`write_obj`]: one frame of the cloth as a Wavefront OBJ mesh (Y-up, metres, with UVs and
//!   normals; vertex `k` is particle `k` in every frame, so Blender can import a sequence; a
//!   mesh cloth keeps its file's faces and texture seams, see [`wetcloth::ClothSurface`]);
//! - [`MetricsCsv`]: `metrics.csv`, one row per written frame, columns [`CSV_HEADER`];
//! - [`GrabsCsv`]: `grabs.csv`, each scene grab's force on the cloth, one row per grab per
//!   frame, columns [`GRABS_CSV_HEADER`];
//! - [`write_pocket_labels`] and [`parse_pocket_labels`]: `frames/frame_NNNN.pockets`, each
//!   particle's sealed air pocket in one frame (pockets air model; see the `labels` format);
//! - [`RunInfo`] and [`write_run_json`]: `run.json`, what a renderer needs to know about the
//!   run (the cloth's layout, the colliders, the grabbed particles, the frame count);
//! - caches of a whole run for animation packages ([`cache`]): PC2 and MDD point caches
//!   ([`Pc2Writer`], [`MddWriter`]), USD stages ([`UsdaWriter`], [`UsdcWriter`]) and Alembic
//!   archives ([`AbcWriter`]), each a [`CacheWriter`] fed one frame at a time, and
//!   [`export_run`], which reads a run folder's frames back ([`read_obj_frame`]) and writes
//!   the caches and `rest.obj`.
//!
//! Files that must never be seen half written go through [`write_atomically`] (a temporary
//! `NAME.part`, never followed if a stale link sits there, and a rename).
//!
//! Every number is written by [`number`]: the shortest text that parses back to the same `f64`
//! (nothing is rounded), in scientific notation when very small or very large so that
//! `1e-20` does not become twenty zeros.

pub mod abc;
mod atomic;
pub mod cache;
mod csv;
mod export;
mod labels;
mod mesh_copy;
mod obj;
mod params;
pub mod pointcache;
mod read;
mod run_json;
mod timing;
pub mod usd;

pub use abc::AbcWriter;
pub use atomic::{create_fresh, part_path, remove_if_present, write_atomically};
pub use cache::{CacheFormat, CacheSpec, CacheWriter, Frame};
pub use csv::{
    ATTACHMENTS_CSV_HEADER, CSV_HEADER, GRABS_CSV_HEADER, GrabsCsv, MetricsCsv, POCKETS_CSV_HEADER,
    PocketsCsv, csv_header,
};
pub use export::{
    ExportError, ExportJob, REST_OBJ, RunFolder, export_run, read_run_folder, write_rest_obj,
};
pub use labels::{
    LabelsError, NO_POCKET, POCKET_LABELS_MAGIC, is_pocket_labels_file_name, parse_pocket_labels,
    particle_pocket_ids, pocket_labels_file_name, write_pocket_labels,
};
pub use mesh_copy::{
    cloth_copy, read_cloth_copy, read_colliders, read_run_json, write_cloth_copy, write_mesh_copies,
};
pub use obj::write_obj;
pub use params::{ParamValue, SceneParam, scene_params};
pub use pointcache::{MddWriter, PC2_SIGNATURE, Pc2Writer};
pub use read::{FrameBuffers, FrameError, read_obj_frame};
pub use run_json::{
    ClothMeshInfo, RunInfo, RunStatus, incomplete, write_run_json, write_run_json_file,
};
pub use timing::{frame_step, last_frame, step_at};
pub use usd::{PLANE_HALF_SIDE, PLANE_MIN_HALF_SIDE, UsdaWriter, UsdcWriter};

/// `v` as the shortest decimal text that parses back to the same value (Rust's `{:?}`
/// formatting of `f64`: `0.1`, `101325.0`, `1.5e-20`).
pub fn number(v: f64) -> String {
    format!("{v:?}")
}

/// Name of the OBJ file of frame `frame`: `frame_NNNN.obj`, zero-padded to 4 digits (more when
/// the frame number needs them).
pub fn frame_file_name(frame: u64) -> String {
    format!("frame_{frame:04}.obj")
}

/// Whether `name` is a frame file name as [`frame_file_name`] writes it.
pub fn is_frame_file_name(name: &str) -> bool {
    name.strip_prefix("frame_")
        .and_then(|s| s.strip_suffix(".obj"))
        .is_some_and(|n| n.len() >= 4 && n.bytes().all(|b| b.is_ascii_digit()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_names_are_zero_padded_and_recognised() {
        assert_eq!(frame_file_name(0), "frame_0000.obj");
        assert_eq!(frame_file_name(42), "frame_0042.obj");
        assert_eq!(frame_file_name(12345), "frame_12345.obj");
        assert!(is_frame_file_name("frame_0042.obj"));
        assert!(is_frame_file_name("frame_12345.obj"));
        assert!(!is_frame_file_name("frame_42.obj"));
        assert!(!is_frame_file_name("frame_0042.obj.bak"));
        assert!(!is_frame_file_name("render_0042.obj"));
    }
}
