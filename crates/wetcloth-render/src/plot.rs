//! `wetcloth plot`: a run's `metrics.csv` drawn as stacked panels over time, written to
//! `RUN_DIR/metrics.png`.
//!
//! Text is set in DejaVu Sans, bundled (`assets/fonts/`, Bitstream Vera licence), so no
//! fontconfig or system font is needed.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use crate::error::RenderError;

/// The columns of `metrics.csv` the plot reads: `frame` and the core's own list
/// ([`wetcloth::metrics::COLUMNS`]; units: frame number, s, m^3, Pa, J, ratio, ratio, m, N,
/// m^3, count). Extra columns are ignored; `pocket_count` may be missing.
pub const COLUMNS: [&str; 1 + wetcloth::metrics::COLUMNS.len()] = {
    let core = wetcloth::metrics::COLUMNS;
    let mut out = ["frame"; 1 + wetcloth::metrics::COLUMNS.len()];
    let mut i = 0;
    while i < core.len() {
        out[i + 1] = core[i];
        i += 1;
    }
    out
};

/// The metrics of a run, one vector per column, one entry per frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Metrics {
    /// Frame number.
    pub frame: Vec<f64>,
    /// Simulated time, s.
    pub time: Vec<f64>,
    /// Air bubble volume, m^3.
    pub air_volume: Vec<f64>,
    /// Air bubble pressure (absolute), Pa.
    pub air_pressure: Vec<f64>,
    /// Kinetic energy of the cloth, J.
    pub kinetic_energy: Vec<f64>,
    /// Largest spring strain (length / rest length - 1).
    pub max_stretch: Vec<f64>,
    /// Fraction of particles touching a collider, 0..1.
    pub contact_fraction: Vec<f64>,
    /// Height of the highest particle, m.
    pub max_height: Vec<f64>,
    /// Magnitude of the grabs' reaction force, N.
    pub grab_force: Vec<f64>,
    /// Air trapped under the cloth, m^3 at atmospheric pressure.
    pub trapped_air: Vec<f64>,
    /// Sealed pockets (empty when the file predates the column).
    pub pocket_count: Vec<f64>,
}

impl Metrics {
    fn column_mut(&mut self, name: &str) -> Option<&mut Vec<f64>> {
        Some(match name {
            "frame" => &mut self.frame,
            "time" => &mut self.time,
            "air_volume" => &mut self.air_volume,
            "air_pressure" => &mut self.air_pressure,
            "kinetic_energy" => &mut self.kinetic_energy,
            "max_stretch" => &mut self.max_stretch,
            "contact_fraction" => &mut self.contact_fraction,
            "max_height" => &mut self.max_height,
            "grab_force" => &mut self.grab_force,
            "trapped_air" => &mut self.trapped_air,
            "pocket_count" => &mut self.pocket_count,
            _ => return None,
        })
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }
}

/// Parses `metrics.csv` text; `path` only names the file in errors. The header must name every
/// column of [`COLUMNS`] (in any order; other columns are ignored); every row must have as many
/// fields as the header, each a number, and every `time` must be finite (a run never writes
/// an infinite or NaN time; other columns may hold anything, non-finite values are not drawn).
pub fn parse_metrics(text: &str, path: &Path) -> Result<Metrics, RenderError> {
    let err = |line: usize, message: String| RenderError::Parse {
        path: path.to_path_buf(),
        line: Some(line),
        message,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((hl, header)) = lines.next() else {
        return Err(err(1, "empty file: expected a header line and rows".into()));
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    // `pocket_count` and `elastic_energy` came later: a file without them still plots.
    for c in COLUMNS
        .into_iter()
        .filter(|c| !matches!(*c, "pocket_count" | "elastic_energy" | "attach_force"))
    {
        if !names.contains(&c) {
            return Err(err(
                hl + 1,
                format!("missing column {c:?} (expected {})", COLUMNS.join(",")),
            ));
        }
    }
    let mut m = Metrics::default();
    for (i, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != names.len() {
            return Err(err(
                i + 1,
                format!("{} fields, the header has {}", fields.len(), names.len()),
            ));
        }
        for (name, field) in names.iter().zip(&fields) {
            if let Some(col) = m.column_mut(name) {
                let v: f64 = field
                    .parse()
                    .map_err(|_| err(i + 1, format!("column {name}: {field:?} is not a number")))?;
                if *name == "time" && !v.is_finite() {
                    return Err(err(
                        i + 1,
                        format!(
                            "column time: {field:?} is not a finite time (simulated seconds); \
                             the file is damaged"
                        ),
                    ));
                }
                col.push(v);
            }
        }
    }
    if m.is_empty() {
        return Err(err(hl + 1, "no rows after the header".into()));
    }
    Ok(m)
}

/// The largest `metrics.csv` [`read_metrics`] reads, bytes (1 GiB: about five million rows).
pub const MAX_METRICS_BYTES: u64 = 1 << 30;

/// Reads and parses a `metrics.csv` file (at most [`MAX_METRICS_BYTES`]).
pub fn read_metrics(path: &Path) -> Result<Metrics, RenderError> {
    let text = crate::read_limited(path, MAX_METRICS_BYTES)?;
    parse_metrics(&text, path)
}

/// Width of the chart, px.
pub const PLOT_WIDTH: u32 = 1200;
/// Height of one panel, px.
const PANEL_HEIGHT: u32 = 172;
/// Height of the title band, px.
const TITLE_HEIGHT: u32 = 48;

/// One stacked panel: its label (with unit), the series colour and how to get its values.
struct Panel {
    label: &'static str,
    colour: RGBColor,
    values: fn(&Metrics) -> Vec<f64>,
}

fn scaled(v: &[f64], k: f64) -> Vec<f64> {
    v.iter().map(|x| x * k).collect()
}

const PANELS: [Panel; 8] = [
    Panel {
        label: "air pressure (kPa)",
        colour: RGBColor(200, 60, 50),
        values: |m| scaled(&m.air_pressure, 1e-3),
    },
    Panel {
        label: "air volume (cm³)",
        colour: RGBColor(40, 110, 190),
        values: |m| scaled(&m.air_volume, 1e6),
    },
    Panel {
        label: "trapped air (cm³ at P_a)",
        colour: RGBColor(90, 140, 210),
        values: |m| scaled(&m.trapped_air, 1e6),
    },
    Panel {
        label: "grab force (N)",
        colour: RGBColor(190, 120, 0),
        values: |m| m.grab_force.clone(),
    },
    Panel {
        label: "contact fraction",
        colour: RGBColor(30, 140, 90),
        values: |m| m.contact_fraction.clone(),
    },
    Panel {
        label: "kinetic energy (J)",
        colour: RGBColor(120, 70, 170),
        values: |m| m.kinetic_energy.clone(),
    },
    Panel {
        label: "max height (cm)",
        colour: RGBColor(20, 130, 150),
        values: |m| scaled(&m.max_height, 1e2),
    },
    Panel {
        label: "max strain (%)",
        colour: RGBColor(150, 90, 60),
        values: |m| scaled(&m.max_stretch, 1e2),
    },
];

/// Size `(width, height)` of the chart, px.
pub fn plot_size() -> (u32, u32) {
    (
        PLOT_WIDTH,
        TITLE_HEIGHT + PANEL_HEIGHT * PANELS.len() as u32,
    )
}

/// Largest magnitude an axis reaches: values beyond it are drawn at its edge. Far beyond
/// anything a run writes, and small enough that an axis' span and its tick steps stay finite.
const AXIS_LIMIT: f64 = 1e300;

/// An axis range covering the finite values of `v` with a margin of `margin` of their span on
/// each side; a flat or empty series gets a range around its value.
///
/// Every range it returns is safe for the chart library's tick search, which loops forever on
/// an infinite span or on a span of a few ulps of its end points: the end points are finite
/// and within [`AXIS_LIMIT`] (plus the margin), and the span is at least a millionth of the
/// largest magnitude.
fn axis_range(v: &[f64], margin: f64) -> (f64, f64) {
    let (lo, hi) = v
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| x.clamp(-AXIS_LIMIT, AXIS_LIMIT))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    if lo > hi {
        return (0.0, 1.0);
    }
    let span = hi - lo;
    let magnitude = lo.abs().max(hi.abs());
    if span <= 1e-6 * magnitude || span == 0.0 {
        let pad = (magnitude * 0.05).max(1e-3);
        return (lo - pad, hi + pad);
    }
    (lo - margin * span, hi + margin * span)
}

/// A y range covering `v` with a margin (see [`axis_range`]).
fn y_range(v: &[f64]) -> (f64, f64) {
    axis_range(v, 0.08)
}

/// The time axis: the run's first to last time, or one second from a lone row (see
/// [`axis_range`]).
fn time_range(t: &[f64]) -> (f64, f64) {
    match axis_range(t, 0.0) {
        (a, b) if t.iter().filter(|x| x.is_finite()).count() == 1 => {
            let a = 0.5 * (a + b);
            (a, a + 1.0_f64.max(a.abs() * 1e-3))
        }
        r => r,
    }
}

/// Draws `metrics` as stacked panels into an RGB image with `title` on top.
pub fn draw_metrics(metrics: &Metrics, title: &str) -> Result<image::RgbImage, RenderError> {
    crate::font::register_font();
    let (w, h) = plot_size();
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let plot_err = |e: &dyn std::fmt::Display| RenderError::Plot(e.to_string());
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(&e))?;
        let (top, body) = root.split_vertically(TITLE_HEIGHT);
        top.titled(title, ("sans-serif", 26).into_font().color(&BLACK))
            .map_err(|e| plot_err(&e))?;
        let panels = body.split_evenly((PANELS.len(), 1));
        let t = &metrics.time;
        let (t0, t1) = time_range(t);
        for (k, (area, panel)) in panels.iter().zip(&PANELS).enumerate() {
            let v = (panel.values)(metrics);
            let (y0, y1) = y_range(&v);
            let last = k + 1 == PANELS.len();
            let mut chart = ChartBuilder::on(area)
                .margin_left(12)
                .margin_right(24)
                .margin_top(8)
                .margin_bottom(if last { 4 } else { 6 })
                .x_label_area_size(if last { 42 } else { 22 })
                .y_label_area_size(92)
                .build_cartesian_2d(t0..t1, y0..y1)
                .map_err(|e| plot_err(&e))?;
            chart
                .configure_mesh()
                .light_line_style(RGBColor(247, 247, 247))
                .bold_line_style(RGBColor(215, 215, 215))
                .axis_style(RGBColor(120, 120, 120))
                .x_labels(10)
                .y_labels(4)
                .y_desc(panel.label)
                .x_desc(if last { "time (s)" } else { "" })
                .label_style(("sans-serif", 14).into_font().color(&RGBColor(60, 60, 60)))
                .axis_desc_style(("sans-serif", 15).into_font().color(&BLACK))
                .y_label_formatter(&|y| format_tick(*y, y0, y1))
                .x_label_formatter(&|x| format_tick(*x, t0, t1))
                .draw()
                .map_err(|e| plot_err(&e))?;
            // Points are kept inside the axes: a point far outside would be rasterised from
            // a pixel coordinate near i32::MAX.
            let points = t
                .iter()
                .zip(&v)
                .filter(|(a, b)| a.is_finite() && b.is_finite())
                .map(|(a, b)| (a.clamp(t0, t1), b.clamp(y0, y1)));
            chart
                .draw_series(LineSeries::new(points, panel.colour.stroke_width(2)))
                .map_err(|e| plot_err(&e))?;
        }
        root.present().map_err(|e| plot_err(&e))?;
    }
    image::RgbImage::from_raw(w, h, buf).ok_or_else(|| RenderError::Plot("buffer size".into()))
}

/// A short tick label for an axis spanning `lo..hi`: up to 4 significant digits, scientific
/// notation when the axis' values are very large or very small, and round-off near zero shown
/// as 0.
fn format_tick(v: f64, lo: f64, hi: f64) -> String {
    let scale = lo.abs().max(hi.abs());
    if v.abs() <= 1e-9 * scale.max(f64::MIN_POSITIVE) {
        return "0".into();
    }
    if scale != 0.0 && !(1e-2..1e5).contains(&scale) {
        format!("{v:.2e}")
    } else {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" { "0".into() } else { s.into() }
    }
}

/// Reads `RUN_DIR/metrics.csv` (and the scene name from `run.json`, if any) and writes the
/// chart to `RUN_DIR/metrics.png`, returning its path.
pub fn plot_run(run_dir: impl AsRef<Path>) -> Result<PathBuf, RenderError> {
    let run_dir = run_dir.as_ref();
    let metrics = read_metrics(&run_dir.join("metrics.csv"))?;
    let name = crate::run::read_run_info(run_dir)
        .ok()
        .flatten()
        .map(|i| i.name)
        .filter(|n| !n.is_empty())
        .or_else(|| {
            run_dir
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
        })
        .unwrap_or_else(|| "run".into());
    let title = format!("{name}: {} frames", metrics.len());
    let img = draw_metrics(&metrics, &title)?;
    let out = run_dir.join("metrics.png");
    img.save(&out).map_err(|e| RenderError::Image {
        path: out.clone(),
        message: e.to_string(),
    })?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn csv(rows: usize) -> String {
        let mut s = format!("{}\n", COLUMNS.join(","));
        for f in 0..rows {
            let t = f as f64 / 30.0;
            let v = 2e-4 * (1.0 - (-t).exp());
            let p = 101_325.0 * 4e-4 / (4e-4 + v);
            s += &format!(
                "{f},{t},{v},{p},{},{},{},{},{},{},1,0.001,0\n",
                1e-4 * (3.0 * t).sin().abs(),
                0.02 * t,
                1.0 - 0.3 * t.min(1.0),
                0.01 + 0.05 * t,
                0.5 * t,
                4e-4
            );
        }
        s
    }

    fn temp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("wetcloth-plot-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn every_panel_draws_its_series() {
        let dir = temp_dir("ok");
        std::fs::write(dir.join("metrics.csv"), csv(90)).unwrap();
        let out = plot_run(&dir).unwrap();
        assert_eq!(out, dir.join("metrics.png"));
        let img = image::open(&out).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), plot_size());
        for (k, panel) in PANELS.iter().enumerate() {
            let y0 = TITLE_HEIGHT + k as u32 * PANEL_HEIGHT;
            let RGBColor(r, g, b) = panel.colour;
            let want = [r, g, b];
            let hits = (y0..y0 + PANEL_HEIGHT)
                .flat_map(|y| (0..PLOT_WIDTH).map(move |x| (x, y)))
                .filter(|&(x, y)| {
                    let c = img.get_pixel(x, y).0;
                    (0..3).all(|i| (c[i] as i32 - want[i] as i32).abs() < 40)
                })
                .count();
            assert!(
                hits > 300,
                "panel {:?}: {hits} pixels of its colour",
                panel.label
            );
        }
        // Text is drawn (axis labels are dark grey/black), i.e. the bundled font works.
        let dark = img.pixels().filter(|p| p.0.iter().all(|&c| c < 90)).count();
        assert!(dark > 2000, "{dark} dark pixels");
        // The chart stays in the temporary directory for a look.
    }

    #[test]
    fn malformed_csv_names_file_and_line() {
        let path = Path::new("run/metrics.csv");
        let mut text = csv(3);
        text = text.replacen("\n1,", "\n1,x", 1);
        let e = parse_metrics(&text, path).unwrap_err().to_string();
        assert!(e.starts_with("run/metrics.csv:3: column time"), "{e}");

        let e = parse_metrics("frame,time\n0,0\n", path)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("metrics.csv:1: missing column \"air_volume\""),
            "{e}"
        );

        let e = parse_metrics(&format!("{}\n0,1\n", COLUMNS.join(",")), path).unwrap_err();
        assert!(
            e.to_string()
                .contains(&format!(":2: 2 fields, the header has {}", COLUMNS.len())),
            "{e}"
        );

        let e = parse_metrics("", path).unwrap_err().to_string();
        assert!(e.contains("empty file"), "{e}");

        let dir = temp_dir("missing");
        let e = plot_run(&dir).unwrap_err().to_string();
        assert!(
            e.contains("metrics.csv") && e.contains("No such file"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Runs `f` on its own thread and fails the test if it takes longer than `seconds` (a
    /// hang) or panics.
    fn within<T: Send + 'static>(seconds: u64, f: impl FnOnce() -> T + Send + 'static) -> T {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let _ = tx.send(f());
        });
        rx.recv_timeout(std::time::Duration::from_secs(seconds))
            .expect("finished in time, without a panic")
    }

    /// A metrics.csv whose `time` column is `times` and whose other columns are `value`.
    fn csv_with(times: &[&str], value: &str) -> String {
        let mut s = format!("{}\n", COLUMNS.join(","));
        for (f, t) in times.iter().enumerate() {
            s += &format!("{f},{t},{}\n", [value; COLUMNS.len() - 2].join(","));
        }
        s
    }

    /// Found from outside: `plot` spun at 100 % CPU forever on a time column holding `inf`
    /// (the chart library's tick search never ends on an infinite axis). A run never writes
    /// a non-finite time, so such a file is damaged: refused, naming the line.
    #[test]
    fn plot_refuses_an_infinite_time_instead_of_spinning() {
        for bad in ["inf", "-inf", "infinity"] {
            let text = csv_with(&["0", "0.5", bad], "1.0");
            let e = within(30, move || {
                parse_metrics(&text, Path::new("run/metrics.csv"))
            })
            .unwrap_err()
            .to_string();
            assert!(
                e.starts_with("run/metrics.csv:4: column time") && e.contains("not a finite time"),
                "{e}"
            );
        }
    }

    /// Found from outside: `plot` panicked (exit 101, an assertion inside the chart library)
    /// when the time column was all NaN. Refused, naming the first bad line.
    #[test]
    fn plot_refuses_an_all_nan_time_column_instead_of_panicking() {
        let dir = temp_dir("nan-time");
        std::fs::write(dir.join("metrics.csv"), csv_with(&["NaN", "nan"], "1.0")).unwrap();
        let e = within(30, move || plot_run(&dir)).unwrap_err().to_string();
        assert!(
            e.contains("metrics.csv:2: column time") && e.contains("\"NaN\""),
            "{e}"
        );
    }

    /// Found from outside: `plot` spun forever on a time column spanning -1e308 .. 1e308 (the
    /// span overflows to infinity). Such a file is drawn, in bounded time, as are values at
    /// the ends of the f64 range and subnormal ones.
    #[test]
    fn plot_draws_times_and_values_spanning_the_whole_f64_range_in_bounded_time() {
        let cases: [(&[&str], &str); 6] = [
            (&["-1e308", "1e308"], "1.0"),
            (
                &["-1.7976931348623157e308", "0", "1.7976931348623157e308"],
                "-1e308",
            ),
            (&["0", "1e-320", "2e-320"], "1e308"),
            (&["1e10", "1.0000000000000002e10"], "5e-324"),
            (&["0", "0"], "nan"),
            (&["7"], "inf"),
        ];
        for (k, (times, value)) in cases.into_iter().enumerate() {
            let dir = temp_dir(&format!("extreme-{k}"));
            std::fs::write(dir.join("metrics.csv"), csv_with(times, value)).unwrap();
            let out = within(60, move || plot_run(&dir)).unwrap();
            assert!(out.exists(), "case {k}");
        }
        // Mixed magnitudes in one value column, and a row whose value is far off the rest.
        let mut text = csv_with(&["0", "1", "2", "3"], "0.5");
        text = text.replacen("\n2,2,0.5", "\n2,2,1e300", 1);
        let m = parse_metrics(&text, Path::new("m.csv")).unwrap();
        let img = within(60, move || draw_metrics(&m, "extreme")).unwrap();
        assert_eq!(img.dimensions(), plot_size());
    }

    #[test]
    fn axis_ranges_are_finite_with_a_span_of_many_ulps() {
        let samples: [&[f64]; 8] = [
            &[f64::MAX, f64::MIN],
            &[f64::MAX],
            &[1e10, 1e10 + 2e-6],
            &[5e-324, 1e-323],
            &[f64::NAN, f64::INFINITY],
            &[],
            &[0.0, 0.0],
            &[-3.0, 4.0],
        ];
        for v in samples {
            for (lo, hi) in [axis_range(v, 0.08), time_range(v)] {
                assert!(
                    lo.is_finite() && hi.is_finite() && hi > lo,
                    "{v:?}: {lo}..{hi}"
                );
                assert!((hi - lo).is_finite(), "{v:?}");
                assert!(
                    hi - lo >= 1e-6 * lo.abs().max(hi.abs()),
                    "{v:?}: {lo}..{hi}"
                );
            }
        }
        assert_eq!(axis_range(&[-3.0, 4.0], 0.0), (-3.0, 4.0));
    }

    #[test]
    fn ticks_are_short() {
        assert_eq!(format_tick(101.3250, 90.0, 110.0), "101.325");
        assert_eq!(format_tick(0.5, 0.0, 1.0), "0.5");
        assert_eq!(format_tick(0.0, 0.0, 1.0), "0");
        assert_eq!(format_tick(2.5e-5, 0.0, 1e-4), "2.50e-5");
        assert_eq!(format_tick(-6.78e-21, 0.0, 1e-4), "0");
    }
}
