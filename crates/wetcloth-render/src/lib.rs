//! Rendering and plotting for wetcloth runs.
//!
//! One renderer ([`ClothRenderer`], wgpu with WGSL shaders) draws the scene for both the
//! offline `wetcloth render` command (through [`Offscreen`]) and the interactive viewer (through
//! egui-wgpu's paint callback, which hands over its device and render pass). The look imitates
//! the thesis' set-up: a satin cloth on a plain table, lit softly, darker and glossier when wet.
//!
//! - [`Camera`]: orbit and auto-framing look-at camera.
//! - [`SceneView`]: what one frame shows (cloth mesh, table plane, particles, pins, solids).
//! - [`ClothRenderer`]: `new` once, then `prepare` + `paint` per frame.
//! - [`Offscreen`]: a headless device rendering [`SceneView`]s into images.
//! - [`render_run`]: a run directory's frames to PNGs (and an MP4 when ffmpeg is installed);
//!   with `pockets`, the air pockets tinted by their pressure ([`pressure_colour`]).
//! - [`plot::plot_run`]: a run's `metrics.csv` to a chart.
//!
//! The `wgpu` version is the one egui-wgpu 0.37 uses (wgpu 30), re-exported as [`wgpu`].

pub mod camera;
mod error;
mod font;
pub mod mesh;
mod offscreen;
pub mod plot;
mod renderer;
mod run;

pub use camera::Camera;
pub use error::RenderError;
pub use mesh::{GroundPlane, Solid, collider_scene, smooth_normals, tented_grid};
pub use offscreen::{OFFSCREEN_DEPTH, OFFSCREEN_FORMAT, OFFSCREEN_SAMPLES, Offscreen};
pub use plot::plot_run;
pub use renderer::{ClothRenderer, KEY_LIGHT_DIR, Material, MeshView, SceneView, srgb_to_linear};
pub use run::{
    CameraSpec, FrameSelection, ImageSize, MeshInfo, ObjMesh, PocketPressures, RenderOptions,
    RenderSummary, RunCheck, RunInfo, VideoOutcome, check_run, draw_legend, ffmpeg_available,
    list_frames, parse_pressure_range, parse_wetness, pressure_colour, read_obj, read_run_info,
    render_run, render_run_with_progress,
};
pub use wgpu;

/// Reads the text file at `path`, refusing anything but a regular file (a device such as
/// `/dev/zero` never ends) and files over `limit` bytes, with the file named in the error.
pub(crate) fn read_limited(path: &std::path::Path, limit: u64) -> Result<String, RenderError> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|e| RenderError::io(path, e))?;
    let meta = file.metadata().map_err(|e| RenderError::io(path, e))?;
    let refuse = |message: String| RenderError::Parse {
        path: path.to_path_buf(),
        line: None,
        message,
    };
    if !meta.is_file() {
        return Err(refuse("not a regular file".into()));
    }
    if meta.len() > limit {
        return Err(refuse(format!(
            "{} bytes is more than the {limit} bytes read from such a file",
            meta.len()
        )));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| RenderError::io(path, e))?;
    if bytes.len() as u64 > limit {
        return Err(refuse(format!(
            "more than the {limit} bytes read from such a file"
        )));
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        RenderError::Parse {
            path: path.to_path_buf(),
            line: Some(line),
            message: "not UTF-8 text".into(),
        }
    })
}
