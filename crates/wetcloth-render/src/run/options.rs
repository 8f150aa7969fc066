//! What `wetcloth render` is asked to do: [`RenderOptions`] and the image size.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use super::{CameraSpec, FrameSelection};

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

/// What [`render_run`](crate::render_run) does. Every field has a command-line form (with the `clap` feature the
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
        arg(long, value_name = "0..1", default_value_t = 1.0, value_parser = parse_wetness)
    )]
    pub wetness: f32,
    /// Also encode an MP4 when ffmpeg is on the PATH (default true; `--no-video` turns it off).
    #[cfg_attr(
        feature = "clap",
        arg(
            long = "no-video",
            action = clap::ArgAction::SetFalse,
            help = "Do not encode an MP4 (by default one is made when ffmpeg is on the PATH)"
        )
    )]
    pub video: bool,
    /// Mark the grabbed particles with red pins (default true; `--no-grabs` turns it off).
    #[cfg_attr(
        feature = "clap",
        arg(
            long = "no-grabs",
            action = clap::ArgAction::SetFalse,
            help = "Do not mark the grabbed particles (by default they get red pins)"
        )
    )]
    pub show_grabs: bool,
    /// Tint the cloth over each sealed air pocket by the pocket's pressure (blue below
    /// atmospheric, red above; needs the run's pockets.csv), with a colour bar.
    #[cfg_attr(feature = "clap", arg(long))]
    pub pockets: bool,
    /// With --pockets: the pressure difference from atmospheric at which the colours saturate,
    /// Pa (default: 90 % of the pockets' differences over the rendered frames lie within it).
    #[cfg_attr(
        feature = "clap",
        arg(long, value_name = "PA", value_parser = parse_pressure_range, requires = "pockets")
    )]
    pub pressure_range: Option<f64>,
}

/// Parses `--pressure-range`: a positive, finite pressure difference in Pa.
pub fn parse_pressure_range(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1e9 => Ok(v),
        _ => Err(format!(
            "{s:?} is not allowed: expected a pressure difference in Pa, above 0 and at most 1e9"
        )),
    }
}

/// Parses `--wetness`: a number from 0 (dry) to 1 (wet); NaN and values outside are refused.
pub fn parse_wetness(s: &str) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number: expected 0 (dry) to 1 (wet)"))?;
    if v.is_finite() && (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{s} is out of range: allowed 0 (dry) to 1 (wet)"))
    }
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
            pockets: false,
            pressure_range: None,
        }
    }

    /// The output directory: `out_dir`, or `RUN_DIR/render`.
    pub fn output_dir(&self) -> PathBuf {
        self.out_dir
            .clone()
            .unwrap_or_else(|| self.run_dir.join("render"))
    }
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

    /// Found from outside: `--wetness nan` was accepted (and drew NaN colours).
    #[cfg(feature = "clap")]
    #[test]
    fn wetness_nan_and_out_of_range_are_refused() {
        use clap::Parser;
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            opts: RenderOptions,
        }
        for bad in ["nan", "NaN", "inf", "-0.1", "1.5", "wet"] {
            let err = Cli::try_parse_from(["render", "runs/a", &format!("--wetness={bad}")])
                .err()
                .unwrap_or_else(|| panic!("--wetness {bad} accepted"));
            assert!(err.to_string().contains("0 (dry) to 1 (wet)"), "{err}");
        }
        assert_eq!(parse_wetness("0").unwrap(), 0.0);
        assert_eq!(parse_wetness("1").unwrap(), 1.0);
    }

    /// Found from outside: the help of `--no-video` and `--no-grabs` described the opposite
    /// of what they do ("Also encode an MP4", "Mark the grabbed particles").
    #[cfg(feature = "clap")]
    #[test]
    fn the_help_of_the_no_flags_says_what_they_turn_off() {
        use clap::{CommandFactory, Parser};
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            opts: RenderOptions,
        }
        let cmd = Cli::command();
        let help = |id: &str| {
            cmd.get_arguments()
                .find(|a| a.get_id() == id)
                .and_then(|a| a.get_help())
                .map(|h| h.to_string())
                .unwrap()
        };
        let video = help("video");
        assert!(video.starts_with("Do not encode an MP4"), "{video}");
        let grabs = help("show_grabs");
        assert!(
            grabs.starts_with("Do not mark the grabbed particles"),
            "{grabs}"
        );
    }
}
