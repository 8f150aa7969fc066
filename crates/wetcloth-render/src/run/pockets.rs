//! `wetcloth render --pockets`: the cloth over each sealed air pocket tinted by the pocket's
//! pressure, on a diverging colour map around atmospheric pressure (blue below, red above,
//! near white at atmospheric; the cloth keeps its own colour where there is no pocket), with a
//! colour bar naming the pressure range.
//!
//! Reads `RUN_DIR/pockets.csv` (the pressure of each pocket per frame), `RUN_DIR/scene.toml`
//! (`[air] atmospheric_pressure` and `model`; defaults when absent) and, with the pockets air
//! model, `frames/frame_NNNN.pockets` (each particle's pocket, see `wetcloth_export`'s labels
//! format). With the thesis model (no label files) the whole cloth takes the colour of its
//! single bubble, pocket 0.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::RenderError;
use wetcloth_export::{NO_POCKET, parse_pocket_labels, pocket_labels_file_name};

/// The largest `pockets.csv` read, bytes.
const MAX_POCKETS_CSV_BYTES: u64 = 1 << 30;
/// The largest label file or `scene.toml` read, bytes.
const MAX_SMALL_FILE_BYTES: u64 = 256 << 20;

/// Share of the pockets' pressure differences (over the rendered frames) the colour map spans
/// by default: the rest saturate. A pocket seeded flat starts at an enormous pressure for one
/// frame, which would wash out every other frame's colours if the range were the largest.
const RANGE_QUANTILE: f64 = 0.9;

/// Smallest pressure range of the colour map, Pa.
const MIN_RANGE: f64 = 1.0;

/// The pockets' pressures of a run, and where its label files are.
#[derive(Clone, Debug)]
pub struct PocketPressures {
    /// Atmospheric pressure of the run, Pa.
    pub atmosphere: f64,
    /// Whether the run used the pockets air model (label files per frame).
    pub labelled: bool,
    /// Per frame, each pocket's (id, pressure in Pa).
    pub frames: BTreeMap<u64, Vec<(u32, f64)>>,
    frames_dir: PathBuf,
}

impl PocketPressures {
    /// Reads `pockets.csv` and `scene.toml` of `run_dir`; refuses a folder without
    /// `pockets.csv` ([`RenderError::NoPockets`]).
    pub fn read(run_dir: &Path) -> Result<Self, RenderError> {
        let csv = run_dir.join("pockets.csv");
        if !csv.is_file() {
            return Err(RenderError::NoPockets(run_dir.to_path_buf()));
        }
        let text = crate::read_limited(&csv, MAX_POCKETS_CSV_BYTES)?;
        let frames = parse_pockets_csv(&text, &csv)?;
        let (atmosphere, labelled) = read_air(&run_dir.join("scene.toml"))?;
        Ok(Self {
            atmosphere,
            labelled,
            frames,
            frames_dir: run_dir.join("frames"),
        })
    }

    /// The colour map's half range, Pa: `fixed`, or the `RANGE_QUANTILE` (0.9) quantile of the
    /// pockets' `|P - P_a|` over `frames`, at least `MIN_RANGE` (1 Pa).
    pub fn range(&self, frames: &[u64], fixed: Option<f64>) -> f64 {
        if let Some(r) = fixed {
            return r;
        }
        let mut d: Vec<f64> = frames
            .iter()
            .filter_map(|f| self.frames.get(f))
            .flatten()
            .map(|(_, p)| (p - self.atmosphere).abs())
            .filter(|d| d.is_finite())
            .collect();
        if d.is_empty() {
            return MIN_RANGE;
        }
        d.sort_by(f64::total_cmp);
        let i = ((d.len() - 1) as f64 * RANGE_QUANTILE).round() as usize;
        d[i].max(MIN_RANGE)
    }

    /// The tint of each of the `vertices` cloth vertices in frame `frame` for a colour map of
    /// half range `range` Pa: a pocket's colour at full weight, or weight 0 (the cloth's
    /// colour) outside the pockets.
    pub fn tints(
        &self,
        frame: u64,
        vertices: usize,
        range: f64,
    ) -> Result<Vec<[f32; 4]>, RenderError> {
        let rows = self.frames.get(&frame).map_or(&[][..], Vec::as_slice);
        let colour = |p: f64| {
            let [r, g, b] = pressure_colour((p - self.atmosphere) / range);
            [r, g, b, 1.0]
        };
        if !self.labelled {
            let tint = rows
                .iter()
                .find(|(id, _)| *id == 0)
                .map_or([0.0; 4], |&(_, p)| colour(p));
            return Ok(vec![tint; vertices]);
        }
        let path = self.frames_dir.join(pocket_labels_file_name(frame));
        let parse_err = |line: Option<usize>, message: String| RenderError::Parse {
            path: path.clone(),
            line,
            message,
        };
        if !path.is_file() {
            return Err(parse_err(
                None,
                "missing: a pockets-model run writes one label file per frame".into(),
            ));
        }
        let text = crate::read_limited(&path, MAX_SMALL_FILE_BYTES)?;
        let labels = parse_pocket_labels(&text).map_err(|e| parse_err(e.line, e.message))?;
        if labels.len() != vertices {
            return Err(parse_err(
                None,
                format!(
                    "labels {} particles, but the frame's mesh has {vertices} vertices",
                    labels.len()
                ),
            ));
        }
        let colours: BTreeMap<u32, [f32; 4]> =
            rows.iter().map(|&(id, p)| (id, colour(p))).collect();
        labels
            .iter()
            .map(|&l| match (l, colours.get(&l)) {
                (NO_POCKET, _) => Ok([0.0; 4]),
                (_, Some(c)) => Ok(*c),
                (_, None) => Err(parse_err(
                    None,
                    format!("pocket {l} is not in pockets.csv at frame {frame}"),
                )),
            })
            .collect()
    }
}

/// The diverging colour map, linear RGB: `t` = (P - P_a) / range, clamped to [-1, 1]; -1 deep
/// blue, 0 near white, 1 deep red (NaN: near white).
pub fn pressure_colour(t: f64) -> [f32; 3] {
    const BLUE: [f32; 3] = [0.045, 0.11, 0.52];
    const WHITE: [f32; 3] = [0.80, 0.80, 0.80];
    const RED: [f32; 3] = [0.55, 0.012, 0.02];
    let t = if t.is_nan() { 0.0 } else { t.clamp(-1.0, 1.0) } as f32;
    let (end, s) = if t < 0.0 { (BLUE, -t) } else { (RED, t) };
    std::array::from_fn(|i| WHITE[i] + (end[i] - WHITE[i]) * s)
}

/// Parses `pockets.csv`: per frame, each pocket's (id, pressure). The header must name the
/// columns `frame`, `pocket` and `pressure`.
fn parse_pockets_csv(
    text: &str,
    path: &Path,
) -> Result<BTreeMap<u64, Vec<(u32, f64)>>, RenderError> {
    let err = |line: usize, message: String| RenderError::Parse {
        path: path.to_path_buf(),
        line: Some(line),
        message,
    };
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
    let (_, header) = lines
        .next()
        .ok_or_else(|| err(1, "empty: expected the header of pockets.csv".into()))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column = |name: &str| {
        names
            .iter()
            .position(|n| *n == name)
            .ok_or_else(|| err(1, format!("the header has no column {name:?}: {header:?}")))
    };
    let (cf, cp, cq) = (column("frame")?, column("pocket")?, column("pressure")?);
    let mut frames: BTreeMap<u64, Vec<(u32, f64)>> = BTreeMap::new();
    for (n, line) in lines.filter(|(_, l)| !l.is_empty()) {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != names.len() {
            return Err(err(
                n,
                format!(
                    "{} fields, but the header names {} columns",
                    fields.len(),
                    names.len()
                ),
            ));
        }
        let frame: u64 = fields[cf]
            .parse()
            .map_err(|_| err(n, format!("frame {:?} is not a whole number", fields[cf])))?;
        let pocket: u32 = fields[cp]
            .parse()
            .ok()
            .filter(|&p| p != NO_POCKET)
            .ok_or_else(|| {
                err(
                    n,
                    format!(
                        "pocket {:?} is not an id (0 to {})",
                        fields[cp],
                        NO_POCKET - 1
                    ),
                )
            })?;
        let pressure: f64 = fields[cq]
            .parse()
            .ok()
            .filter(|p: &f64| p.is_finite())
            .ok_or_else(|| {
                err(
                    n,
                    format!("pressure {:?} is not a finite number (Pa)", fields[cq]),
                )
            })?;
        frames.entry(frame).or_default().push((pocket, pressure));
    }
    Ok(frames)
}

/// Atmospheric pressure (Pa) and whether the air model is `"pockets"`, from a run's
/// `scene.toml` (the defaults when there is none or it does not say).
fn read_air(path: &Path) -> Result<(f64, bool), RenderError> {
    let default = wetcloth::params::AirParams::default().atmospheric_pressure;
    if !path.is_file() {
        return Ok((default, false));
    }
    let text = crate::read_limited(path, MAX_SMALL_FILE_BYTES)?;
    let err = |line: Option<usize>, message: String| RenderError::Parse {
        path: path.to_path_buf(),
        line,
        message,
    };
    let value: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let line = e.span().map(|s| text[..s.start].lines().count().max(1));
        err(line, e.message().to_string())
    })?;
    let air = value.get("air").and_then(|a| a.as_table());
    let atmosphere = match air.and_then(|a| a.get("atmospheric_pressure")) {
        None => default,
        Some(v) => v
            .as_float()
            .or_else(|| v.as_integer().map(|i| i as f64))
            .filter(|p| p.is_finite() && *p > 0.0)
            .ok_or_else(|| {
                err(
                    None,
                    format!("[air] atmospheric_pressure = {v} is not a positive number (Pa)"),
                )
            })?,
    };
    let labelled = air
        .and_then(|a| a.get("model"))
        .and_then(|m| m.as_str())
        .is_some_and(|m| m == "pockets");
    Ok((atmosphere, labelled))
}

/// Draws the colour bar into `img` (bottom left): the map from `-range` to `+range` Pa around
/// `atmosphere`, labelled.
pub fn draw_legend(
    img: &mut image::RgbaImage,
    range: f64,
    atmosphere: f64,
) -> Result<(), RenderError> {
    use plotters::prelude::*;
    let (w, h) = img.dimensions();
    let scale = (h as f64 / 720.0).clamp(0.7, 4.0);
    let px = |v: f64| (v * scale).round().max(1.0) as i32;
    let (bar_w, bar_h) = (px(300.0).min(w as i32 - 2 * px(24.0)).max(8), px(18.0));
    let x0 = px(24.0);
    let y0 = h as i32 - px(58.0);
    if bar_w < 8 || y0 < px(30.0) {
        return Ok(()); // too small an image for a legend
    }
    let mut rgb = image::DynamicImage::ImageRgba8(std::mem::take(img)).into_rgb8();
    {
        crate::font::register_font();
        let root = BitMapBackend::with_buffer(rgb.as_mut(), (w, h)).into_drawing_area();
        let plot_err = |e: &dyn std::fmt::Display| RenderError::Plot(e.to_string());
        // A pale panel behind the bar keeps the labels readable on any background.
        root.draw(&Rectangle::new(
            [
                (x0 - px(10.0), y0 - px(30.0)),
                (x0 + bar_w + px(10.0), y0 + bar_h + px(30.0)),
            ],
            RGBAColor(255, 255, 255, 0.75).filled(),
        ))
        .map_err(|e| plot_err(&e))?;
        for i in 0..bar_w {
            let t = 2.0 * (i as f64 + 0.5) / bar_w as f64 - 1.0;
            let [r, g, b] = pressure_colour(t).map(linear_to_srgb);
            root.draw(&Rectangle::new(
                [(x0 + i, y0), (x0 + i + 1, y0 + bar_h)],
                RGBColor(r, g, b).filled(),
            ))
            .map_err(|e| plot_err(&e))?;
        }
        let size = px(15.0).max(8);
        let font = ("sans-serif", size).into_font().color(&BLACK);
        root.draw(&Text::new(
            format!("pocket pressure - P_a (P_a = {} Pa)", short(atmosphere)),
            (x0, y0 - px(26.0)),
            font.clone(),
        ))
        .map_err(|e| plot_err(&e))?;
        let below = y0 + bar_h + px(5.0);
        for (text, x, anchor) in [
            (
                format!("-{} Pa", short(range)),
                x0,
                plotters::style::text_anchor::HPos::Left,
            ),
            (
                "0".into(),
                x0 + bar_w / 2,
                plotters::style::text_anchor::HPos::Center,
            ),
            (
                format!("+{} Pa", short(range)),
                x0 + bar_w,
                plotters::style::text_anchor::HPos::Right,
            ),
        ] {
            let style = font.pos(plotters::style::text_anchor::Pos::new(
                anchor,
                plotters::style::text_anchor::VPos::Top,
            ));
            root.draw(&Text::new(text, (x, below), style))
                .map_err(|e| plot_err(&e))?;
        }
        root.present().map_err(|e| plot_err(&e))?;
    }
    *img = image::DynamicImage::ImageRgb8(rgb).into_rgba8();
    Ok(())
}

/// A pressure for a label: up to 4 significant digits, without trailing zeros.
fn short(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-2..1e7).contains(&a) {
        return format!("{v:.3e}");
    }
    let decimals = (3 - a.log10().floor().max(0.0) as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Linear RGB to 8-bit sRGB.
fn linear_to_srgb(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_colour_map_diverges_around_atmospheric() {
        let [r, g, b] = pressure_colour(-1.0);
        assert!(b > r && b > g, "below atmospheric is blue");
        let [r, g, b] = pressure_colour(1.0);
        assert!(r > g && r > b, "above atmospheric is red");
        let [r, g, b] = pressure_colour(0.0);
        assert!(r == g && g == b, "atmospheric is neutral");
        assert_eq!(pressure_colour(5.0), pressure_colour(1.0), "saturates");
        assert_eq!(pressure_colour(f64::NAN), pressure_colour(0.0));
        // Monotone towards each end.
        assert!(pressure_colour(0.5)[0] > pressure_colour(1.0)[0]);
        assert!(pressure_colour(0.5)[2] > pressure_colour(1.0)[2]);
    }

    #[test]
    fn pockets_csv_is_read_by_frame_and_checked() {
        let path = Path::new("run/pockets.csv");
        let text = "frame,time,pocket,volume,amount,pressure,area,particles\n\
                    0,0.0,1,1e-6,1e-6,101325.0,0.01,20\n\
                    0,0.0,4,1e-6,1e-6,101000.5,0.01,20\n\
                    2,0.1,4,1e-6,1e-6,101500.0,0.01,20\n";
        let f = parse_pockets_csv(text, path).unwrap();
        assert_eq!(f[&0], vec![(1, 101325.0), (4, 101000.5)]);
        assert_eq!(f[&2], vec![(4, 101500.0)]);
        assert!(!f.contains_key(&1));
        for (bad, line, needle) in [
            ("frame,time,volume\n", 1, "no column \"pocket\""),
            (
                "frame,time,pocket,pressure\n0,0,1\n",
                2,
                "3 fields, but the header names 4",
            ),
            ("frame,time,pocket,pressure\nx,0,1,1\n", 2, "frame \"x\""),
            ("frame,time,pocket,pressure\n0,0,-1,1\n", 2, "pocket \"-1\""),
            (
                "frame,time,pocket,pressure\n0,0,1,nan\n",
                2,
                "pressure \"nan\"",
            ),
        ] {
            let e = parse_pockets_csv(bad, path).unwrap_err().to_string();
            assert!(e.contains(&format!("pockets.csv:{line}")), "{e}");
            assert!(e.contains(needle), "{e}");
        }
    }

    #[test]
    fn the_default_range_ignores_a_rare_outlier() {
        let mut frames = BTreeMap::new();
        frames.insert(0, vec![(1, 1e8)]); // a flat seeded pocket's first frame
        for f in 1..=20 {
            frames.insert(f, vec![(1, 101325.0 + f as f64)]);
        }
        let p = PocketPressures {
            atmosphere: 101325.0,
            labelled: true,
            frames,
            frames_dir: PathBuf::new(),
        };
        let all: Vec<u64> = (0..=20).collect();
        let r = p.range(&all, None);
        assert!((17.0..=20.0).contains(&r), "{r}");
        assert_eq!(p.range(&[0], None), 1e8 - 101325.0);
        assert_eq!(p.range(&all, Some(50.0)), 50.0);
        assert_eq!(p.range(&[99], None), MIN_RANGE);
    }

    #[test]
    fn labels_short_numbers() {
        assert_eq!(short(101325.0), "101325");
        assert_eq!(short(37.25), "37.25");
        assert_eq!(short(0.5), "0.5");
        assert_eq!(short(2.5e8), "2.500e8");
    }
}
