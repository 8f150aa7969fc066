//! `metrics.csv`: one row of [`FrameMetrics`] per written frame.

use std::io::{self, Write};
use wetcloth::FrameMetrics;
use wetcloth::metrics::COLUMNS;

/// The header of `metrics.csv`, without the line end: `frame` followed by
/// [`wetcloth::metrics::COLUMNS`]. Units: frame number, s, m^3, Pa, J, ratio, ratio 0..1, m, N,
/// m^3, count, J, N.
pub const CSV_HEADER: &str = "frame,time,air_volume,air_pressure,kinetic_energy,max_stretch,contact_fraction,max_height,grab_force,trapped_air,pocket_count,elastic_energy,attach_force";

/// The header built from [`wetcloth::metrics::COLUMNS`] (equal to [`CSV_HEADER`]; a test keeps
/// them in step).
pub fn csv_header() -> String {
    std::iter::once("frame")
        .chain(COLUMNS)
        .collect::<Vec<_>>()
        .join(",")
}

/// Writes `metrics.csv`: the header on creation, then one row per frame, each flushed at once so
/// that a run that stops early leaves only complete rows.
#[derive(Debug)]
pub struct MetricsCsv<W: Write> {
    w: W,
    rows: u64,
}

impl<W: Write> MetricsCsv<W> {
    /// Writes the header line to `w` and flushes it.
    pub fn new(mut w: W) -> io::Result<Self> {
        writeln!(w, "{}", csv_header())?;
        w.flush()?;
        Ok(Self { w, rows: 0 })
    }

    /// Writes the row of frame `frame` (values in full precision) and flushes it.
    pub fn write_row(&mut self, frame: u64, m: &FrameMetrics) -> io::Result<()> {
        let mut line = frame.to_string();
        for (name, v) in COLUMNS.iter().zip(m.values()) {
            line.push(',');
            if *name == "pocket_count" {
                // A count: written as an integer.
                line.push_str(&(v as u64).to_string());
            } else {
                line.push_str(&crate::number(v));
            }
        }
        line.push('\n');
        self.w.write_all(line.as_bytes())?;
        self.w.flush()?;
        self.rows += 1;
        Ok(())
    }

    /// Rows written so far (without the header).
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.w
    }
}

/// The header of `pockets.csv`, without the line end. Units: frame number, s, id, m^3, m^3 at
/// atmospheric pressure, Pa, m^2, count.
pub const POCKETS_CSV_HEADER: &str = "frame,time,pocket,volume,amount,pressure,area,particles";

/// Writes `pockets.csv`: the header on creation, then one row per sealed air pocket per frame
/// (with the thesis' single bubble, one row per frame, pocket 0), each frame flushed at once.
#[derive(Debug)]
pub struct PocketsCsv<W: Write> {
    w: W,
}

impl<W: Write> PocketsCsv<W> {
    /// Writes the header line to `w` and flushes it.
    pub fn new(mut w: W) -> io::Result<Self> {
        writeln!(w, "{POCKETS_CSV_HEADER}")?;
        w.flush()?;
        Ok(Self { w })
    }

    /// Writes the rows of frame `frame` at `time` (s), one per pocket, and flushes them.
    pub fn write_frame(
        &mut self,
        frame: u64,
        time: f64,
        pockets: &[wetcloth::air::PocketReport],
    ) -> io::Result<()> {
        let mut text = String::new();
        for p in pockets {
            let n = crate::number;
            text.push_str(&format!(
                "{frame},{},{},{},{},{},{},{}\n",
                n(time),
                p.id,
                n(p.volume),
                n(p.amount),
                n(p.pressure),
                n(p.area),
                p.particles
            ));
        }
        self.w.write_all(text.as_bytes())?;
        self.w.flush()
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.w
    }
}

/// The header of `grabs.csv`, without the line end. Units: frame number, s, index, count, N,
/// N, N.
pub const GRABS_CSV_HEADER: &str = "frame,time,grab,particles,force_x,force_y,force_z";

/// The header of `attachments.csv` (`[[attach]]`), without the line end: one row per
/// attachment per frame, as `grabs.csv`'s.
pub const ATTACHMENTS_CSV_HEADER: &str = "frame,time,attach,particles,force_x,force_y,force_z";

/// Writes `grabs.csv`: the header on creation, then one row per scene grab (`[[grab]]`, by its
/// 0-based index in the scene) per frame: how many particles it holds and its force on the
/// cloth summed over them (N, the sum over grabs is `metrics.csv`'s `grab_force` as a
/// vector). A scene without grabs has the header alone. Each frame is flushed at once.
#[derive(Debug)]
pub struct GrabsCsv<W: Write> {
    w: W,
}

impl<W: Write> GrabsCsv<W> {
    /// Writes the header line to `w` and flushes it.
    pub fn new(w: W) -> io::Result<Self> {
        Self::with_header(w, GRABS_CSV_HEADER)
    }

    /// The same form under another header (`attachments.csv`: [`ATTACHMENTS_CSV_HEADER`]).
    pub fn with_header(mut w: W, header: &str) -> io::Result<Self> {
        writeln!(w, "{header}")?;
        w.flush()?;
        Ok(Self { w })
    }

    /// Writes the rows of frame `frame` at `time` (s), one per grab of `grabs` (each the
    /// particles it holds and its summed force, N, as `Simulation::grab_forces` gives them),
    /// and flushes them.
    pub fn write_frame(
        &mut self,
        frame: u64,
        time: f64,
        grabs: &[(usize, wetcloth::Vec3)],
    ) -> io::Result<()> {
        let mut text = String::new();
        let n = crate::number;
        for (g, (particles, f)) in grabs.iter().enumerate() {
            text.push_str(&format!(
                "{frame},{},{g},{particles},{},{},{}\n",
                n(time),
                n(f.x),
                n(f.y),
                n(f.z)
            ));
        }
        self.w.write_all(text.as_bytes())?;
        self.w.flush()
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grabs_rows_are_one_per_grab_in_full_precision() {
        let mut g = GrabsCsv::new(Vec::new()).unwrap();
        g.write_frame(
            3,
            0.1,
            &[
                (2, wetcloth::Vec3::new(0.0, 0.5, -1e-20)),
                (0, wetcloth::Vec3::ZERO),
            ],
        )
        .unwrap();
        let text = String::from_utf8(g.into_inner()).unwrap();
        assert_eq!(
            text,
            "frame,time,grab,particles,force_x,force_y,force_z\n\
             3,0.1,0,2,0.0,0.5,-1e-20\n3,0.1,1,0,0.0,0.0,0.0\n"
        );
    }

    #[test]
    fn pockets_rows_one_per_pocket_in_full_precision() {
        let mut csv = PocketsCsv::new(Vec::new()).unwrap();
        let p = |id, amount: f64| wetcloth::air::PocketReport {
            id,
            volume: 0.1 + 0.2,
            amount,
            pressure: 101325.5,
            area: 1e-3,
            particles: 7,
        };
        csv.write_frame(3, 0.05, &[p(1, 2e-5), p(4, 0.0)]).unwrap();
        csv.write_frame(4, 0.06, &[]).unwrap();
        let text = String::from_utf8(csv.into_inner()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], POCKETS_CSV_HEADER);
        assert_eq!(lines.len(), 3);
        let f: Vec<&str> = lines[1].split(',').collect();
        assert_eq!(f[..3], ["3", "0.05", "1"]);
        assert_eq!(f[3].parse::<f64>().unwrap(), 0.1 + 0.2);
        assert_eq!(f[7], "7");
        assert!(lines[2].starts_with("3,0.05,4,"));
    }

    #[test]
    fn header_and_rows_in_full_precision() {
        assert_eq!(csv_header(), CSV_HEADER);
        let mut csv = MetricsCsv::new(Vec::new()).unwrap();
        let m = FrameMetrics {
            time: 0.1 + 0.2,
            air_volume: 1e-20,
            air_pressure: 101325.0,
            kinetic_energy: 0.0,
            max_stretch: -0.5,
            contact_fraction: 1.0,
            max_height: 1.0 / 3.0,
            grab_force: 2.5,
            trapped_air: 4e-4,
            pocket_count: 1.0,
            elastic_energy: 0.125,
            attach_force: 0.5,
        };
        csv.write_row(7, &m).unwrap();
        assert_eq!(csv.rows(), 1);
        let text = String::from_utf8(csv.into_inner()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], CSV_HEADER);
        assert_eq!(
            lines[1],
            "7,0.30000000000000004,1e-20,101325.0,0.0,-0.5,1.0,0.3333333333333333,2.5,0.0004,1,0.125,0.5"
        );
        let parsed: Vec<f64> = lines[1].split(',').map(|v| v.parse().unwrap()).collect();
        assert_eq!(parsed[1..], m.values());
    }
}
