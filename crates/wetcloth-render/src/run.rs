//! Rendering a run directory (written by `wetcloth run`) into PNG frames and an MP4.
//!
//! Reads `RUN_DIR/frames/frame_NNNN.obj` and `RUN_DIR/run.json`, writes
//! `OUT/frame_NNNN.png` (default `OUT` = `RUN_DIR/render/`) and, when `ffmpeg` is on the PATH,
//! `OUT/<name>.mp4` (H.264, yuv420p, at the run's frame rate divided by the frame step).

use std::fmt;
use std::io::{BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::str::FromStr;
use std::time::Instant;

use serde::Deserialize;

use crate::camera::{Camera, DEFAULT_FOV_Y, FRAMING_PITCH, FRAMING_YAW};
use crate::error::RenderError;
use crate::mesh::{Solid, bounds_of, smooth_normals};
use crate::offscreen::Offscreen;
use crate::renderer::{GroundPlane, MeshView, SceneView};

/// An image size in pixels, written `WIDTHxHEIGHT` (e.g. `1280x720`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageSize {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
}

impl Default for ImageSize {
    /// 1280x720.
    fn default() -> Self {
        Self {
            width: 1280,
            height: 720,
        }
    }
}

impl fmt::Display for ImageSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

impl FromStr for ImageSize {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || format!("invalid size {s:?}: expected WIDTHxHEIGHT in pixels, e.g. 1280x720");
        let (w, h) = s.trim().split_once(['x', 'X']).ok_or_else(bad)?;
        let width: u32 = w.trim().parse().map_err(|_| bad())?;
        let height: u32 = h.trim().parse().map_err(|_| bad())?;
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            return Err(format!(
                "invalid size {s:?}: each side must be 1..=16384 pixels"
            ));
        }
        Ok(Self { width, height })
    }
}

/// A camera chosen on the command line; what is left out comes from the automatic framing.
///
/// Written either as `YAW,PITCH[,DISTANCE]` (degrees, degrees, metres), or as `key=value`
/// pairs separated by `;` or spaces, with keys `yaw`, `pitch` (degrees), `distance` (m),
/// `fov` (vertical, degrees), `target=x,y,z` and `eye=x,y,z` (m). Examples: `30,25`,
/// `-60,40,0.8`, `eye=0.4,0.3,0.5;target=0,0,0`, `yaw=90 pitch=15 fov=25`.
/// With `eye`, yaw, pitch and distance are ignored.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CameraSpec {
    /// Turn about the vertical, degrees (0 looks from +Z towards -Z, positive towards +X).
    pub yaw: Option<f32>,
    /// Elevation above the horizon, degrees.
    pub pitch: Option<f32>,
    /// Distance from the target, m.
    pub distance: Option<f32>,
    /// Point looked at, m.
    pub target: Option<[f32; 3]>,
    /// Eye position, m (overrides yaw, pitch and distance).
    pub eye: Option<[f32; 3]>,
    /// Vertical field of view, degrees.
    pub fov: Option<f32>,
}

impl CameraSpec {
    /// The camera for a scene with bounds `bounds_min..bounds_max` in a frame of width /
    /// height `aspect`.
    pub fn resolve(&self, bounds_min: [f32; 3], bounds_max: [f32; 3], aspect: f32) -> Camera {
        let yaw = self.yaw.map_or(FRAMING_YAW, f32::to_radians);
        let pitch = self.pitch.map_or(FRAMING_PITCH, f32::to_radians);
        let framed = Camera::framing_aspect(bounds_min, bounds_max, yaw, pitch, aspect);
        let target = self.target.unwrap_or(framed.target);
        let mut cam = if let Some(eye) = self.eye {
            let d = glam::Vec3::from(eye)
                .distance(glam::Vec3::from(target))
                .max(1e-4);
            Camera {
                eye,
                target,
                near: d * 0.01,
                far: d * 100.0,
                ..framed
            }
        } else {
            let d = glam::Vec3::from(framed.eye).distance(glam::Vec3::from(framed.target));
            Camera::orbit(target, yaw, pitch, self.distance.unwrap_or(d))
        };
        cam.fov_y = self.fov.map_or(DEFAULT_FOV_Y, f32::to_radians);
        cam
    }
}

fn parse_vec3(key: &str, v: &str) -> Result<[f32; 3], String> {
    let parts: Vec<&str> = v.split(',').map(str::trim).collect();
    let nums: Result<Vec<f32>, _> = parts.iter().map(|p| p.parse::<f32>()).collect();
    match nums {
        Ok(n) if n.len() == 3 && n.iter().all(|x| x.is_finite()) => Ok([n[0], n[1], n[2]]),
        _ => Err(format!(
            "{key}={v:?}: expected three numbers x,y,z in metres"
        )),
    }
}

fn parse_num(key: &str, v: &str) -> Result<f32, String> {
    v.trim()
        .parse::<f32>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("{key}={v:?}: expected a number"))
}

impl FromStr for CameraSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        let mut spec = CameraSpec::default();
        if !s.contains('=') {
            let parts: Vec<&str> = s.split(',').collect();
            if !(2..=3).contains(&parts.len()) {
                return Err(format!(
                    "invalid camera {s:?}: expected YAW,PITCH[,DISTANCE] (degrees, degrees, m) \
                     or key=value pairs such as eye=x,y,z;target=x,y,z"
                ));
            }
            spec.yaw = Some(parse_num("yaw", parts[0])?);
            spec.pitch = Some(parse_num("pitch", parts[1])?);
            if let Some(d) = parts.get(2) {
                spec.distance = Some(parse_num("distance", d)?);
            }
        } else {
            for pair in s.split([';', ' ']).filter(|p| !p.trim().is_empty()) {
                let (k, v) = pair.split_once('=').ok_or_else(|| {
                    format!("invalid camera setting {pair:?}: expected key=value")
                })?;
                match k.trim() {
                    "yaw" => spec.yaw = Some(parse_num(k, v)?),
                    "pitch" => spec.pitch = Some(parse_num(k, v)?),
                    "distance" => spec.distance = Some(parse_num(k, v)?),
                    "fov" => spec.fov = Some(parse_num(k, v)?),
                    "target" => spec.target = Some(parse_vec3(k, v)?),
                    "eye" => spec.eye = Some(parse_vec3(k, v)?),
                    other => {
                        return Err(format!(
                            "unknown camera setting {other:?}: use yaw, pitch, distance, fov, \
                             target or eye"
                        ));
                    }
                }
            }
        }
        if spec.distance.is_some_and(|d| d <= 0.0) {
            return Err("camera distance must be > 0 m".into());
        }
        if spec.fov.is_some_and(|f| !(1.0..=170.0).contains(&f)) {
            return Err("camera fov must be 1..=170 degrees".into());
        }
        Ok(spec)
    }
}

impl fmt::Display for CameraSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        let v = |p: [f32; 3]| format!("{},{},{}", p[0], p[1], p[2]);
        if let Some(x) = self.yaw {
            parts.push(format!("yaw={x}"));
        }
        if let Some(x) = self.pitch {
            parts.push(format!("pitch={x}"));
        }
        if let Some(x) = self.distance {
            parts.push(format!("distance={x}"));
        }
        if let Some(x) = self.fov {
            parts.push(format!("fov={x}"));
        }
        if let Some(x) = self.target {
            parts.push(format!("target={}", v(x)));
        }
        if let Some(x) = self.eye {
            parts.push(format!("eye={}", v(x)));
        }
        write!(f, "{}", parts.join(";"))
    }
}

/// Which frames to render, by the number in their file name, written `[RANGE][:STEP]`:
/// `120` (one frame), `0..240` (end excluded), `0..=240`, `100..`, `..50`, `:5` (every fifth
/// frame), `0..=240:2`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameSelection {
    /// First frame number, inclusive.
    pub start: Option<u64>,
    /// Last frame number, inclusive.
    pub end: Option<u64>,
    /// Keep every `step`-th of the frames in range (>= 1).
    pub step: u64,
}

impl Default for FrameSelection {
    /// Every frame.
    fn default() -> Self {
        Self {
            start: None,
            end: None,
            step: 1,
        }
    }
}

impl FrameSelection {
    /// Whether frame `n` is in range (the step is applied to the frames found, in order).
    pub fn contains(&self, n: u64) -> bool {
        self.start.is_none_or(|s| n >= s) && self.end.is_none_or(|e| n <= e)
    }
}

impl fmt::Display for FrameSelection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.start, self.end) {
            (Some(a), Some(b)) if a == b => write!(f, "{a}")?,
            (a, b) => {
                if let Some(a) = a {
                    write!(f, "{a}")?;
                }
                if a.is_some() || b.is_some() {
                    write!(f, "..")?;
                }
                if let Some(b) = b {
                    write!(f, "={b}")?;
                }
            }
        }
        if self.step != 1 {
            write!(f, ":{}", self.step)?;
        }
        Ok(())
    }
}

impl FromStr for FrameSelection {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || {
            format!(
                "invalid frame selection {s:?}: expected N, A..B, A..=B, A.., ..B, with an \
                 optional :STEP (e.g. 0..=240:2, or :5 for every fifth frame)"
            )
        };
        let num = |t: &str| t.trim().parse::<u64>().map_err(|_| bad());
        let (range, step) = match s.trim().split_once(':') {
            Some((r, st)) => (r.trim(), num(st)?),
            None => (s.trim(), 1),
        };
        if step == 0 {
            return Err(format!(
                "invalid frame selection {s:?}: the step must be >= 1"
            ));
        }
        let (start, end) = if range.is_empty() {
            (None, None)
        } else if let Some((a, b)) = range.split_once("..") {
            let start = if a.trim().is_empty() {
                None
            } else {
                Some(num(a)?)
            };
            let end = if let Some(b) = b.strip_prefix('=') {
                Some(num(b)?)
            } else if b.trim().is_empty() {
                None
            } else {
                let b = num(b)?;
                if b == 0 {
                    return Err(format!("invalid frame selection {s:?}: the range is empty"));
                }
                Some(b - 1)
            };
            (start, end)
        } else {
            let n = num(range)?;
            (Some(n), Some(n))
        };
        if let (Some(a), Some(b)) = (start, end)
            && a > b
        {
            return Err(format!("invalid frame selection {s:?}: the range is empty"));
        }
        Ok(Self { start, end, step })
    }
}

/// What [`render_run`] does. Every field has a command-line form (with the `clap` feature the
/// struct derives `clap::Args`, so a CLI can `#[command(flatten)]` it).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct RenderOptions {
    /// Run directory written by `wetcloth run` (frames/frame_NNNN.obj, run.json).
    #[cfg_attr(feature = "clap", arg(value_name = "RUN_DIR"))]
    pub run_dir: PathBuf,
    /// Output directory for the PNG frames and the MP4 (default: RUN_DIR/render).
    #[cfg_attr(feature = "clap", arg(long = "out", value_name = "DIR"))]
    pub out_dir: Option<PathBuf>,
    /// Image size in pixels.
    #[cfg_attr(feature = "clap", arg(long, value_name = "WxH", default_value_t = ImageSize::default()))]
    pub size: ImageSize,
    /// Camera: YAW,PITCH or YAW,PITCH,DISTANCE in degrees and metres, or key=value pairs
    /// (yaw, pitch, distance, fov, target=x,y,z, eye=x,y,z) separated by ';' (default: a 3/4
    /// view framing the whole run).
    #[cfg_attr(
        feature = "clap",
        arg(long, value_name = "SPEC", allow_hyphen_values = true)
    )]
    pub camera: Option<CameraSpec>,
    /// Draw the particles as dots.
    #[cfg_attr(feature = "clap", arg(long))]
    pub particles: bool,
    /// Frames to render: N, A..B, A..=B, A.., ..B, each with an optional :STEP (default: all).
    #[cfg_attr(feature = "clap", arg(long, value_name = "SEL"))]
    pub frames: Option<FrameSelection>,
    /// How wet the cloth looks, 0 (dry) to 1 (wet: darker, glossier).
    #[cfg_attr(
        feature = "clap",
        arg(long, value_name = "0..1", default_value_t = 1.0)
    )]
    pub wetness: f32,
    /// Also encode an MP4 when ffmpeg is on the PATH.
    #[cfg_attr(feature = "clap", arg(long = "no-video", action = clap::ArgAction::SetFalse))]
    pub video: bool,
    /// Mark the grabbed particles (red pins).
    #[cfg_attr(feature = "clap", arg(long = "no-grabs", action = clap::ArgAction::SetFalse))]
    pub show_grabs: bool,
}

impl RenderOptions {
    /// Defaults for `run_dir`: 1280x720, automatic camera, all frames, wet, MP4 if possible.
    pub fn new(run_dir: impl Into<PathBuf>) -> Self {
        Self {
            run_dir: run_dir.into(),
            out_dir: None,
            size: ImageSize::default(),
            camera: None,
            particles: false,
            frames: None,
            wetness: 1.0,
            video: true,
            show_grabs: true,
        }
    }

    /// The output directory: `out_dir`, or `RUN_DIR/render`.
    pub fn output_dir(&self) -> PathBuf {
        self.out_dir
            .clone()
            .unwrap_or_else(|| self.run_dir.join("render"))
    }
}

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

/// The parts of `run.json` the renderer uses; other keys are ignored.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(default)]
pub struct RunInfo {
    /// Scene name (names the MP4).
    pub name: String,
    /// Particles along x and z.
    pub resolution: [usize; 2],
    /// Particle collision radius, m.
    pub particle_radius: f64,
    /// Frames per simulated second.
    pub frame_rate: f64,
    /// Colliders.
    pub colliders: Vec<ColliderInfo>,
    /// Grabbed particles as `[column, row]`.
    pub grabs: Vec<[usize; 2]>,
}

/// A collider of `run.json`.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "shape", rename_all = "lowercase")]
pub enum ColliderInfo {
    /// An infinite plane.
    Plane {
        /// A point of the plane, m.
        point: [f64; 3],
        /// Its normal.
        normal: [f64; 3],
    },
    /// A sphere.
    Sphere {
        /// Centre, m.
        center: [f64; 3],
        /// Radius, m.
        radius: f64,
    },
    /// An axis-aligned box.
    Box {
        /// Centre, m.
        center: [f64; 3],
        /// Half edge lengths, m.
        half_extents: [f64; 3],
    },
}

fn f32s(v: [f64; 3]) -> [f32; 3] {
    v.map(|x| x as f32)
}

/// Reads `RUN_DIR/run.json`; `Ok(None)` when there is none.
pub fn read_run_info(run_dir: &Path) -> Result<Option<RunInfo>, RenderError> {
    let path = run_dir.join("run.json");
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(RenderError::io(path, e)),
    };
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| RenderError::Parse {
            line: Some(e.line()),
            message: e.to_string(),
            path,
        })
}

/// The frame files of a run, `(number, path)` in number order.
pub fn list_frames(run_dir: &Path) -> Result<Vec<(u64, PathBuf)>, RenderError> {
    let dir = run_dir.join("frames");
    let entries = std::fs::read_dir(&dir).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            RenderError::NoFrames(run_dir.to_path_buf())
        } else {
            RenderError::io(&dir, e)
        }
    })?;
    let mut frames = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| RenderError::io(&dir, e))?;
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        if let Some(n) = name
            .strip_prefix("frame_")
            .and_then(|r| r.strip_suffix(".obj"))
            .and_then(|n| n.parse::<u64>().ok())
        {
            frames.push((n, entry.path()));
        }
    }
    frames.sort();
    Ok(frames)
}

/// A cloth frame read from OBJ: positions and triangle indices.
#[derive(Clone, Debug, Default)]
pub struct ObjMesh {
    /// Vertex positions, m.
    pub positions: Vec<[f32; 3]>,
    /// Triangle indices.
    pub indices: Vec<u32>,
}

/// Reads an OBJ file's first object (triangulated; positions keep their file order, so vertex
/// k is particle k).
pub fn read_obj(path: &Path) -> Result<ObjMesh, RenderError> {
    let file = std::fs::File::open(path).map_err(|e| RenderError::io(path, e))?;
    // tobj adds fields behind its optional features: keep the struct update.
    #[allow(clippy::needless_update)]
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj_buf(&mut BufReader::new(file), &opts, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| RenderError::Parse {
        path: path.to_path_buf(),
        line: None,
        message: format!("not a readable OBJ mesh: {e}"),
    })?;
    let model = models
        .into_iter()
        .next()
        .ok_or_else(|| RenderError::Parse {
            path: path.to_path_buf(),
            line: None,
            message: "no mesh in the file".into(),
        })?;
    let positions = model
        .mesh
        .positions
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    Ok(ObjMesh {
        positions,
        indices: model.mesh.indices,
    })
}

/// Renders a run's frames to PNGs (and an MP4 when ffmpeg is on the PATH). See
/// [`render_run_with_progress`].
pub fn render_run(opts: RenderOptions) -> Result<RenderSummary, RenderError> {
    render_run_with_progress(opts, &mut |_, _| {})
}

/// Finds ffmpeg: `true` when `ffmpeg -version` runs.
pub fn ffmpeg_available() -> bool {
    Command::new("ffmpeg")
        .arg("-version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// An ffmpeg process reading raw RGBA frames on its standard input.
struct Encoder {
    child: Child,
    path: PathBuf,
    stderr: std::thread::JoinHandle<String>,
}

impl Encoder {
    fn start(path: PathBuf, size: ImageSize, fps: f64) -> Result<Self, RenderError> {
        let mut child = Command::new("ffmpeg")
            .args(["-hide_banner", "-loglevel", "error", "-y"])
            .args(["-f", "rawvideo", "-pix_fmt", "rgba"])
            .args(["-s", &size.to_string(), "-framerate", &format!("{fps}")])
            .args(["-i", "-"])
            // H.264 in yuv420p needs even sides: pad odd ones by a pixel.
            .args(["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"])
            .args(["-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "18"])
            .args(["-movflags", "+faststart"])
            .arg(&path)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| RenderError::Ffmpeg(format!("could not start ffmpeg: {e}")))?;
        let mut err = child.stderr.take().expect("stderr is piped");
        let stderr = std::thread::spawn(move || {
            let mut s = String::new();
            let _ = std::io::Read::read_to_string(&mut err, &mut s);
            s
        });
        Ok(Self {
            child,
            path,
            stderr,
        })
    }

    fn push(&mut self, rgba: &[u8]) -> Result<(), RenderError> {
        let stdin = self.child.stdin.as_mut().expect("stdin is piped");
        stdin
            .write_all(rgba)
            .map_err(|e| RenderError::Ffmpeg(format!("writing a frame: {e}")))
    }

    fn finish(mut self) -> Result<PathBuf, RenderError> {
        drop(self.child.stdin.take());
        let status = self
            .child
            .wait()
            .map_err(|e| RenderError::Ffmpeg(e.to_string()))?;
        let log = self.stderr.join().unwrap_or_default();
        if status.success() {
            Ok(self.path)
        } else {
            Err(RenderError::Ffmpeg(format!("{status}: {}", log.trim())))
        }
    }
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
    let sel = opts.frames.unwrap_or_default();
    let frames: Vec<(u64, PathBuf)> = all
        .into_iter()
        .filter(|(n, _)| sel.contains(*n))
        .step_by(sel.step.max(1) as usize)
        .collect();
    if frames.is_empty() {
        return Err(RenderError::NoFrames(run_dir.to_path_buf()));
    }

    // The scene around the cloth.
    let ground = match &info {
        None => Some(GroundPlane::default()),
        Some(i) => i.colliders.iter().find_map(|c| match c {
            ColliderInfo::Plane { point, normal } => Some(GroundPlane {
                point: f32s(*point),
                normal: f32s(*normal),
            }),
            _ => None,
        }),
    };
    let solids: Vec<Solid> = info
        .iter()
        .flat_map(|i| &i.colliders)
        .filter_map(|c| match c {
            ColliderInfo::Sphere { center, radius } => Some(Solid::Sphere {
                center: f32s(*center),
                radius: *radius as f32,
            }),
            ColliderInfo::Box {
                center,
                half_extents,
            } => Some(Solid::Box {
                center: f32s(*center),
                half_extents: f32s(*half_extents),
            }),
            ColliderInfo::Plane { .. } => None,
        })
        .collect();
    let grabbed: Vec<usize> = match &info {
        Some(i) if opts.show_grabs => {
            let nx = i.resolution[0];
            i.grabs.iter().map(|[c, r]| r * nx + c).collect()
        }
        _ => Vec::new(),
    };

    // One camera for the whole run: frame the cloth's extent over (up to 64 of) its frames.
    let stride = frames.len().div_ceil(64).max(1);
    let mut corners: Vec<[f32; 3]> = Vec::new();
    for (k, (_, path)) in frames.iter().enumerate() {
        if k % stride == 0 || k + 1 == frames.len() {
            let mesh = read_obj(path)?;
            if let Some((lo, hi)) = bounds_of(&mesh.positions) {
                corners.extend([lo, hi]);
            }
        }
    }
    for s in &solids {
        let (lo, hi) = s.bounds();
        corners.extend([lo, hi]);
    }
    let (lo, hi) = bounds_of(&corners).unwrap_or(([-0.15, 0.0, -0.15], [0.15, 0.02, 0.15]));
    let aspect = opts.size.width as f32 / opts.size.height as f32;
    let camera = opts
        .camera
        .clone()
        .unwrap_or_default()
        .resolve(lo, hi, aspect);

    let out_dir = opts.output_dir();
    std::fs::create_dir_all(&out_dir).map_err(|e| RenderError::io(&out_dir, e))?;
    let mut offscreen = Offscreen::new(opts.size.width, opts.size.height)?;

    let frame_rate = info
        .as_ref()
        .map(|i| i.frame_rate)
        .filter(|r| *r > 0.0 && r.is_finite())
        .unwrap_or(30.0);
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
            let mesh = read_obj(path)?;
            let normals = smooth_normals(&mesh.positions, &mesh.indices);
            let pinned: Vec<usize> = grabbed
                .iter()
                .copied()
                .filter(|&k| k < mesh.positions.len())
                .collect();
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
                solids: &solids,
                camera,
                wetness: opts.wetness,
            };
            let img = offscreen.render(&scene)?;
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

/// A file-name-safe version of a scene name.
fn sanitize(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_print() {
        assert_eq!(
            "640x480".parse::<ImageSize>().unwrap(),
            ImageSize {
                width: 640,
                height: 480
            }
        );
        assert_eq!(ImageSize::default().to_string(), "1280x720");
        assert!("640".parse::<ImageSize>().is_err());
        assert!("0x10".parse::<ImageSize>().is_err());
    }

    #[test]
    fn frame_selections_parse() {
        let p = |s: &str| s.parse::<FrameSelection>().unwrap();
        assert_eq!(
            p("7"),
            FrameSelection {
                start: Some(7),
                end: Some(7),
                step: 1
            }
        );
        assert_eq!(
            p("0..10"),
            FrameSelection {
                start: Some(0),
                end: Some(9),
                step: 1
            }
        );
        assert_eq!(
            p("0..=10:2"),
            FrameSelection {
                start: Some(0),
                end: Some(10),
                step: 2
            }
        );
        assert_eq!(
            p(":5"),
            FrameSelection {
                start: None,
                end: None,
                step: 5
            }
        );
        assert_eq!(
            p("100.."),
            FrameSelection {
                start: Some(100),
                end: None,
                step: 1
            }
        );
        for bad in ["x", "5..2", "0..0", ":0", "1..2:x"] {
            assert!(bad.parse::<FrameSelection>().is_err(), "{bad}");
        }
        for s in ["7", "3..=9:2", ":5", "4.."] {
            assert_eq!(p(&p(s).to_string()), p(s), "{s}");
        }
    }

    #[test]
    fn camera_specs_parse_and_resolve() {
        let c: CameraSpec = "30,20,0.8".parse().unwrap();
        assert_eq!(
            (c.yaw, c.pitch, c.distance),
            (Some(30.0), Some(20.0), Some(0.8))
        );
        let cam = c.resolve([-0.1, 0.0, -0.1], [0.1, 0.0, 0.1], 1.5);
        let d = glam::Vec3::from(cam.eye) - glam::Vec3::from(cam.target);
        assert!((d.length() - 0.8).abs() < 1e-5);
        assert!((d.y / d.length() - 20f32.to_radians().sin()).abs() < 1e-5);

        let c: CameraSpec = "eye=0.4,0.3,0.5;target=0,0.01,0 fov=25".parse().unwrap();
        assert_eq!(c.eye, Some([0.4, 0.3, 0.5]));
        let cam = c.resolve([0.0; 3], [0.0; 3], 1.5);
        assert_eq!((cam.eye, cam.target), ([0.4, 0.3, 0.5], [0.0, 0.01, 0.0]));
        assert!((cam.fov_y - 25f32.to_radians()).abs() < 1e-6);
        assert_eq!(c.to_string().parse::<CameraSpec>().unwrap(), c);

        for bad in ["1", "1,2,3,4", "yaw=a", "zoom=2", "eye=1,2", "30,20,-1"] {
            assert!(bad.parse::<CameraSpec>().is_err(), "{bad}");
        }
    }

    #[cfg(feature = "clap")]
    #[test]
    fn clap_fills_render_options() {
        use clap::Parser;
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            opts: RenderOptions,
        }
        let cli = Cli::try_parse_from(["render", "runs/a"]).unwrap();
        assert_eq!(cli.opts, RenderOptions::new("runs/a"));
        let cli = Cli::try_parse_from([
            "render",
            "runs/a",
            "--out",
            "pics",
            "--size",
            "640x360",
            "--camera",
            "-60,40",
            "--frames",
            ":2",
            "--particles",
            "--wetness",
            "0.3",
            "--no-video",
            "--no-grabs",
        ])
        .unwrap();
        let o = cli.opts;
        assert_eq!(o.out_dir, Some(PathBuf::from("pics")));
        assert_eq!(
            o.size,
            ImageSize {
                width: 640,
                height: 360
            }
        );
        assert_eq!(o.camera.unwrap().yaw, Some(-60.0));
        assert_eq!(o.frames.unwrap().step, 2);
        assert!(o.particles && !o.video && !o.show_grabs);
        assert_eq!(o.wetness, 0.3);
        let err = Cli::try_parse_from(["render", "runs/a", "--size", "big"])
            .err()
            .unwrap();
        assert!(err.to_string().contains("WIDTHxHEIGHT"), "{err}");
    }
}
