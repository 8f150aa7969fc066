//! Rendering a run directory (written by `wetcloth run`) into PNG frames and an MP4.
//!
//! Reads `RUN_DIR/frames/frame_NNNN.obj` and `RUN_DIR/run.json` (with `--pockets` also
//! `pockets.csv`, `scene.toml` and `frames/frame_NNNN.pockets`, see `pockets`), writes
//! `OUT/frame_NNNN.png` (default `OUT` = `RUN_DIR/render/`) and, when `ffmpeg` is on the PATH,
//! `OUT/<name>.mp4` (H.264, yuv420p, at the run's frame rate divided by the frame step).
//!
//! By concern: `input` reads the run folder (`run.json`, OBJ frames), `frames` selects frames,
//! `framing` chooses the camera, `video` drives ffmpeg, `options` holds what the command asks
//! for; this module is the render loop.

mod frames;
mod framing;
mod input;
mod options;
mod pockets;
mod video;

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub use frames::{FrameSelection, list_frames};
pub use framing::CameraSpec;
pub use input::{MeshInfo, ObjMesh, RunInfo, read_obj, read_run_info};
pub use options::{ImageSize, RenderOptions, parse_pressure_range, parse_wetness};
pub use pockets::{PocketPressures, draw_legend, pressure_colour};
pub use video::ffmpeg_available;

use crate::camera::Camera;
use crate::error::RenderError;
use crate::mesh::GroundPlane;
use crate::mesh::{collider_scene, smooth_normals};
use crate::offscreen::Offscreen;
use crate::renderer::{MeshView, SceneView};
use input::FrameCheck;
use video::Encoder;

/// What happened to the MP4.
#[derive(Clone, Debug, PartialEq)]
pub enum VideoOutcome {
    /// Written to this file.
    Written(PathBuf),
    /// Not made: `ffmpeg` is not on the PATH.
    FfmpegMissing,
    /// Not asked for.
    Disabled,
}

/// The result of [`render_run`].
#[derive(Clone, Debug)]
pub struct RenderSummary {
    /// Where the PNGs went.
    pub out_dir: PathBuf,
    /// The PNG files written, in frame order.
    pub images: Vec<PathBuf>,
    /// The MP4, or why there is none.
    pub video: VideoOutcome,
    /// The graphics adapter used.
    pub adapter: String,
    /// The camera used for every frame.
    pub camera: Camera,
    /// Wall-clock time, s.
    pub seconds: f64,
}

impl fmt::Display for RenderSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.images.len();
        writeln!(
            f,
            "rendered {n} frame{} to {} in {:.1} s ({:.0} ms/frame) on {}",
            if n == 1 { "" } else { "s" },
            self.out_dir.display(),
            self.seconds,
            1e3 * self.seconds / n.max(1) as f64,
            self.adapter
        )?;
        match &self.video {
            VideoOutcome::Written(p) => write!(f, "video: {}", p.display()),
            VideoOutcome::FfmpegMissing => write!(
                f,
                "video: not made, ffmpeg is not on the PATH (Debian/Ubuntu: apt-get install ffmpeg)"
            ),
            VideoOutcome::Disabled => write!(f, "video: not asked for"),
        }
    }
}

/// What [`check_run`] found in a run folder.
#[derive(Clone, Debug)]
pub struct RunCheck {
    /// `run.json`, when there is one.
    pub info: Option<RunInfo>,
    /// Frame files read.
    pub frames: usize,
    /// Vertices of every frame.
    pub vertices: usize,
    /// Triangles of every frame (its faces split into fans).
    pub triangles: usize,
    /// Faces (`f` lines) of every frame: the triangles of the grid, the polygons of a mesh.
    pub faces: usize,
}

/// Reads and checks everything [`render_run`] reads, without a graphics device: `run.json`,
/// the frame list (every frame `run.json` counts must be there), and every frame (each a sound
/// mesh of the run's cloth, see `read_obj` and docs/rendering.md). The error is the one
/// `render_run` would give.
pub fn check_run(run_dir: &Path) -> Result<RunCheck, RenderError> {
    let info = read_run_info(run_dir)?;
    let all = list_frames(run_dir)?;
    if all.is_empty() {
        return Err(RenderError::NoFrames(run_dir.to_path_buf()));
    }
    if let Some(written) = info.as_ref().and_then(|i| i.frames) {
        frames::check_complete(run_dir, &all, written)?;
    }
    let mut check = FrameCheck::new(info.as_ref());
    let mut size = (0, 0, 0);
    for (_, path) in &all {
        let mesh = check.read(path)?;
        size = (mesh.positions.len(), mesh.indices.len() / 3, mesh.faces);
    }
    Ok(RunCheck {
        info,
        frames: all.len(),
        vertices: size.0,
        triangles: size.1,
        faces: size.2,
    })
}

/// Renders a run's frames to PNGs (and an MP4 when ffmpeg is on the PATH). See
/// [`render_run_with_progress`].
pub fn render_run(opts: RenderOptions) -> Result<RenderSummary, RenderError> {
    render_run_with_progress(opts, &mut |_, _| {})
}

/// Renders a run's frames to PNGs (and an MP4 when ffmpeg is on the PATH and `opts.video`),
/// calling `progress(done, total)` after each frame. One camera serves every frame: `opts.camera`
/// completed by a 3/4 view that frames the cloth over the whole run (and the solids).
pub fn render_run_with_progress(
    opts: RenderOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<RenderSummary, RenderError> {
    let started = Instant::now();
    let run_dir = opts.run_dir.as_path();
    let info = read_run_info(run_dir)?;
    let all = list_frames(run_dir)?;
    if all.is_empty() {
        return Err(RenderError::NoFrames(run_dir.to_path_buf()));
    }
    if let Some(written) = info.as_ref().and_then(|i| i.frames) {
        frames::check_complete(run_dir, &all, written)?;
    }
    let sel = opts.frames.unwrap_or_default();
    let frames: Vec<(u64, PathBuf)> = all
        .iter()
        .filter(|(n, _)| sel.contains(*n))
        .step_by(sel.step.max(1) as usize)
        .cloned()
        .collect();
    if frames.is_empty() {
        return Err(RenderError::NoFramesSelected {
            dir: run_dir.to_path_buf(),
            selection: sel.to_string(),
            first: all[0].0,
            last: all[all.len() - 1].0,
            count: all.len(),
        });
    }
    if !opts.wetness.is_finite() || !(0.0..=1.0).contains(&opts.wetness) {
        return Err(RenderError::Option(format!(
            "wetness = {} is out of range: allowed 0 (dry) to 1 (wet)",
            opts.wetness
        )));
    }
    if let Some(r) = opts.pressure_range
        && !(r.is_finite() && r > 0.0)
    {
        return Err(RenderError::Option(format!(
            "pressure range = {r} Pa is not allowed: expected a positive number"
        )));
    }
    // With --pockets: the pockets' pressures, one colour range for every frame.
    let pockets = if opts.pockets {
        let p = PocketPressures::read(run_dir)?;
        let numbers: Vec<u64> = frames.iter().map(|(n, _)| *n).collect();
        let range = p.range(&numbers, opts.pressure_range);
        Some((p, range))
    } else {
        None
    };
    let mut check = FrameCheck::new(info.as_ref());

    // The scene around the cloth: without run.json, the thesis' table.
    let (ground, solids) = match &info {
        None => (Some(GroundPlane::default()), Vec::new()),
        Some(i) => collider_scene(&i.colliders),
    };
    // Moving colliders are drawn where their keys put them at each frame's time.
    let moving = info
        .as_ref()
        .is_some_and(|i| i.colliders.iter().any(|c| c.is_moving()));
    // A mesh run's grabs name no grid particle (run.json lists none).
    let grabbed: Vec<usize> = match &info {
        Some(i) if opts.show_grabs && i.mesh.is_none() => {
            let nx = i.resolution[0];
            i.grabs.iter().map(|[c, r]| r * nx + c).collect()
        }
        _ => Vec::new(),
    };

    let aspect = opts.size.width as f32 / opts.size.height as f32;
    let camera = framing::frame_run(
        opts.camera.clone().unwrap_or_default(),
        &frames,
        &solids,
        aspect,
        &mut check,
    )?;

    let out_dir = opts.output_dir();
    std::fs::create_dir_all(&out_dir).map_err(|e| RenderError::io(&out_dir, e))?;
    let mut offscreen = Offscreen::new(opts.size.width, opts.size.height)?;

    let frame_rate = info.as_ref().map_or(30.0, |i| i.frame_rate);
    let name = info
        .as_ref()
        .map(|i| i.name.clone())
        .filter(|n| !n.is_empty())
        .unwrap_or_else(|| "run".into());
    let video_path = out_dir.join(format!("{}.mp4", sanitize(&name)));
    let mut encoder = match (opts.video, ffmpeg_available()) {
        (false, _) => None,
        (true, false) => None,
        (true, true) => Some(Encoder::start(
            video_path,
            opts.size,
            frame_rate / sel.step.max(1) as f64,
        )?),
    };

    // PNG encoding runs on a second thread while the next frame renders.
    let (tx, rx) = std::sync::mpsc::sync_channel::<(PathBuf, image::RgbaImage)>(2);
    let writer = std::thread::spawn(move || -> Result<(), RenderError> {
        for (path, img) in rx {
            img.save(&path).map_err(|e| RenderError::Image {
                path: path.clone(),
                message: e.to_string(),
            })?;
        }
        Ok(())
    });

    let total = frames.len();
    let mut images = Vec::with_capacity(total);
    let particle_radius = info.as_ref().map_or(0.0, |i| i.particle_radius as f32);
    let mut result = Ok(());
    for (done, (n, path)) in frames.iter().enumerate() {
        let step = (|| -> Result<(), RenderError> {
            let mesh = check.read(path)?;
            let normals = smooth_normals(&mesh.positions, &mesh.indices);
            let pinned: Vec<usize> = grabbed
                .iter()
                .copied()
                .filter(|&k| k < mesh.positions.len())
                .collect();
            let moved = match &info {
                Some(i) if moving => {
                    let t = *n as f64 / i.frame_rate;
                    let at: Vec<_> = i.colliders.iter().map(|c| c.at(t)).collect();
                    Some(collider_scene(&at))
                }
                _ => None,
            };
            let (ground, solids) = match &moved {
                Some((g, s)) => (*g, s.as_slice()),
                None => (ground, solids.as_slice()),
            };
            let tint = match &pockets {
                Some((p, range)) => Some(p.tints(*n, mesh.positions.len(), *range)?),
                None => None,
            };
            let scene = SceneView {
                cloth: MeshView {
                    positions: &mesh.positions,
                    normals: &normals,
                    indices: &mesh.indices,
                },
                ground,
                particles: opts.particles.then_some(mesh.positions.as_slice()),
                particle_radius: dot_radius(particle_radius, &mesh),
                highlight: None,
                pinned: &pinned,
                solids,
                camera,
                wetness: opts.wetness,
                tint: tint.as_deref(),
            };
            let mut img = offscreen.render(&scene)?;
            if let Some((p, range)) = &pockets {
                pockets::draw_legend(&mut img, *range, p.atmosphere)?;
            }
            if let Some(enc) = encoder.as_mut() {
                enc.push(img.as_raw())?;
            }
            let png = out_dir.join(format!("frame_{n:04}.png"));
            images.push(png.clone());
            tx.send((png, img))
                .map_err(|_| RenderError::Readback("the PNG writer stopped".into()))
        })();
        if let Err(e) = step {
            result = Err(e);
            break;
        }
        progress(done + 1, total);
    }
    drop(tx);
    let written = writer
        .join()
        .unwrap_or_else(|_| Err(RenderError::Readback("the PNG writer panicked".into())));
    // The first error wins: a failed PNG write usually explains a closed channel.
    written?;
    result?;
    let video = match encoder {
        Some(enc) => VideoOutcome::Written(enc.finish()?),
        None if !opts.video => VideoOutcome::Disabled,
        None => VideoOutcome::FfmpegMissing,
    };
    Ok(RenderSummary {
        out_dir,
        images,
        video,
        adapter: offscreen.adapter_info(),
        camera,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// The dot radius: the run's particle radius, but never more than 0.4 of the mean particle
/// spacing (dots that touch hide the cloth).
fn dot_radius(particle_radius: f32, mesh: &ObjMesh) -> f32 {
    let spacing = mesh
        .indices
        .chunks_exact(3)
        .take(200)
        .filter_map(|t| {
            let a = mesh.positions.get(t[0] as usize)?;
            let b = mesh.positions.get(t[2] as usize)?;
            Some(glam::Vec3::from(*a).distance(glam::Vec3::from(*b)))
        })
        .fold((0.0, 0), |(s, n), d| (s + d, n + 1));
    let spacing = if spacing.1 > 0 {
        spacing.0 / spacing.1 as f32
    } else {
        0.0
    };
    match (particle_radius > 0.0, spacing > 0.0) {
        (true, true) => particle_radius.min(0.4 * spacing),
        (true, false) => particle_radius,
        (false, _) => 0.3 * spacing,
    }
}

/// A file-name-safe version of a scene name (at most 100 characters).
fn sanitize(name: &str) -> String {
    name.chars()
        .take(100)
        .map(|c| {
            if c.is_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}
