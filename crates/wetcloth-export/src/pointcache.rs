//! Point caches: every vertex position of every frame, after a short header. They carry no
//! topology; they are applied to a mesh with the same vertices in the same order (a run's
//! `rest.obj`).
//!
//! **PC2** (Blender, 3ds Max), little-endian:
//!
//! | bytes | contents |
//! |---|---|
//! | 12 | signature `POINTCACHE2` and a zero byte |
//! | 4 | i32 file version, 1 |
//! | 4 | i32 vertex count |
//! | 4 | f32 start frame (0: the cache starts at the run's frame 0) |
//! | 4 | f32 sampling, frames between samples (1: every frame) |
//! | 4 | i32 frame count |
//! | 12 per vertex per frame | f32 x, y, z |
//!
//! **MDD** (LightWave, Houdini, Blender, three.js), big-endian:
//!
//! | bytes | contents |
//! |---|---|
//! | 4 | i32 frame count |
//! | 4 | i32 vertex count |
//! | 4 per frame | f32 time of the frame in seconds (`k / frame_rate`) |
//! | 12 per vertex per frame | f32 x, y, z |
//!
//! Coordinates are the run's: metres, Y up (as in the OBJ frames); see `docs/export.md` for the
//! axis settings of each reader.

use crate::cache::{CacheSpec, CacheWriter, Frame, check_complete, check_frame, invalid};
use std::io::{self, Write};

/// The 12-byte PC2 signature: `POINTCACHE2` and a zero byte.
pub const PC2_SIGNATURE: &[u8; 12] = b"POINTCACHE2\0";

/// Converts a count to the i32 the point-cache headers hold.
fn header_count(n: u64, what: &str) -> io::Result<i32> {
    i32::try_from(n).map_err(|_| invalid(format!("{n} {what} do not fit a point cache header")))
}

/// Writes a PC2 point cache to `W`, frame by frame (see the [module docs](self) for the layout).
#[derive(Debug)]
pub struct Pc2Writer<W: Write> {
    w: W,
    vertices: usize,
    frames: u64,
    fed: u64,
    buf: Vec<u8>,
}

impl<W: Write> Pc2Writer<W> {
    /// Writes the header for `spec.frames` frames of `spec.vertices()` vertices, starting at
    /// frame 0, one sample per frame.
    ///
    /// # Errors
    ///
    /// I/O errors, or counts beyond an i32.
    pub fn new(mut w: W, spec: &CacheSpec<'_>) -> io::Result<Self> {
        let vertices = spec.vertices();
        let mut h = Vec::with_capacity(32);
        h.extend_from_slice(PC2_SIGNATURE);
        h.extend_from_slice(&1i32.to_le_bytes());
        h.extend_from_slice(&header_count(vertices as u64, "vertices")?.to_le_bytes());
        h.extend_from_slice(&0f32.to_le_bytes());
        h.extend_from_slice(&1f32.to_le_bytes());
        h.extend_from_slice(&header_count(spec.frames, "frames")?.to_le_bytes());
        w.write_all(&h)?;
        Ok(Self {
            w,
            vertices,
            frames: spec.frames,
            fed: 0,
            buf: Vec::new(),
        })
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.w
    }
}

impl<W: Write> CacheWriter for Pc2Writer<W> {
    fn write_frame(&mut self, frame: &Frame<'_>) -> io::Result<()> {
        check_frame(frame, self.fed, self.vertices)?;
        self.buf.clear();
        for p in frame.positions {
            for c in p {
                self.buf.extend_from_slice(&c.to_le_bytes());
            }
        }
        self.w.write_all(&self.buf)?;
        self.fed += 1;
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> io::Result<()> {
        check_complete(self.fed, self.frames)?;
        self.w.flush()
    }
}

/// Writes an MDD point cache to `W`, frame by frame (see the [module docs](self) for the
/// layout).
#[derive(Debug)]
pub struct MddWriter<W: Write> {
    w: W,
    vertices: usize,
    frames: u64,
    fed: u64,
    buf: Vec<u8>,
}

impl<W: Write> MddWriter<W> {
    /// Writes the header: the counts and the time of every frame, `k / frame_rate` seconds.
    ///
    /// # Errors
    ///
    /// I/O errors, or counts beyond an i32.
    pub fn new(mut w: W, spec: &CacheSpec<'_>) -> io::Result<Self> {
        let vertices = spec.vertices();
        w.write_all(&header_count(spec.frames, "frames")?.to_be_bytes())?;
        w.write_all(&header_count(vertices as u64, "vertices")?.to_be_bytes())?;
        for k in 0..spec.frames {
            w.write_all(&(spec.frame_time(k) as f32).to_be_bytes())?;
        }
        Ok(Self {
            w,
            vertices,
            frames: spec.frames,
            fed: 0,
            buf: Vec::new(),
        })
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.w
    }
}

impl<W: Write> CacheWriter for MddWriter<W> {
    fn write_frame(&mut self, frame: &Frame<'_>) -> io::Result<()> {
        check_frame(frame, self.fed, self.vertices)?;
        self.buf.clear();
        for p in frame.positions {
            for c in p {
                self.buf.extend_from_slice(&c.to_be_bytes());
            }
        }
        self.w.write_all(&self.buf)?;
        self.fed += 1;
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> io::Result<()> {
        check_complete(self.fed, self.frames)?;
        self.w.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RunInfo;
    use wetcloth::SimConfig;

    /// A run of a 2 x 2 cloth (4 vertices), 3 frames at 4 frames per second.
    fn run() -> RunInfo {
        let mut cfg = SimConfig::default();
        cfg.cloth.resolution = [2, 2];
        cfg.simulation.frame_rate = 4.0;
        RunInfo::new("t", &cfg, 3, true)
    }

    fn spec<'a>(run: &'a RunInfo, surface: &'a wetcloth::ClothSurface) -> CacheSpec<'a> {
        CacheSpec {
            run,
            frames: 3,
            surface,
            params: &[],
        }
    }

    fn surface() -> wetcloth::ClothSurface {
        wetcloth::ClothSurface::new(&wetcloth::ClothParams {
            resolution: [2, 2],
            ..Default::default()
        })
    }

    /// Frame `k`: vertex `v` at (k + v/4, -v, 0.5 k), exactly representable in f32.
    fn positions(k: u64) -> Vec<[f32; 3]> {
        (0..4)
            .map(|v| [k as f32 + v as f32 / 4.0, -(v as f32), 0.5 * k as f32])
            .collect()
    }

    fn feed(w: &mut dyn CacheWriter, frames: u64) {
        for k in 0..frames {
            let p = positions(k);
            w.write_frame(&Frame {
                index: k,
                positions: &p,
                normals: &p,
            })
            .unwrap();
        }
    }

    #[test]
    fn pc2_header_bytes_are_little_endian_as_computed_by_hand() {
        let run = run();
        let mut w = Pc2Writer::new(Vec::new(), &spec(&run, &surface())).unwrap();
        feed(&mut w, 3);
        let bytes = w.into_inner();
        #[rustfmt::skip]
        let header: [u8; 32] = [
            b'P', b'O', b'I', b'N', b'T', b'C', b'A', b'C', b'H', b'E', b'2', 0,
            1, 0, 0, 0,             // version 1
            4, 0, 0, 0,             // 4 vertices
            0, 0, 0, 0,             // start frame 0.0
            0x00, 0x00, 0x80, 0x3f, // sampling 1.0 (0x3f800000)
            3, 0, 0, 0,             // 3 frames
        ];
        assert_eq!(bytes[..32], header);
        assert_eq!(bytes.len(), 32 + 3 * 4 * 12);
        // Frame 1, vertex 2: (1.5, -2, 0.5) = 0x3fc00000, 0xc0000000, 0x3f000000.
        let at = 32 + (4 + 2) * 12;
        assert_eq!(
            bytes[at..at + 12],
            [0, 0, 0xc0, 0x3f, 0, 0, 0, 0xc0, 0, 0, 0, 0x3f]
        );
    }

    #[test]
    fn mdd_header_bytes_are_big_endian_with_frame_times() {
        let run = run();
        let mut w = MddWriter::new(Vec::new(), &spec(&run, &surface())).unwrap();
        feed(&mut w, 3);
        let bytes = w.into_inner();
        #[rustfmt::skip]
        let header: [u8; 20] = [
            0, 0, 0, 3,             // 3 frames
            0, 0, 0, 4,             // 4 vertices
            0, 0, 0, 0,             // t0 = 0 s
            0x3e, 0x80, 0, 0,       // t1 = 0.25 s
            0x3f, 0, 0, 0,          // t2 = 0.5 s
        ];
        assert_eq!(bytes[..20], header);
        assert_eq!(bytes.len(), 20 + 3 * 4 * 12);
        let at = 20 + (4 + 2) * 12;
        assert_eq!(
            bytes[at..at + 12],
            [0x3f, 0xc0, 0, 0, 0xc0, 0, 0, 0, 0x3f, 0, 0, 0]
        );
    }

    /// Reads every position back from either cache and compares bit for bit.
    #[test]
    fn positions_round_trip_through_both_caches() {
        let run = run();
        let mut pc2 = Pc2Writer::new(Vec::new(), &spec(&run, &surface())).unwrap();
        let mut mdd = MddWriter::new(Vec::new(), &spec(&run, &surface())).unwrap();
        feed(&mut pc2, 3);
        feed(&mut mdd, 3);
        let (pc2, mdd) = (pc2.into_inner(), mdd.into_inner());
        let le = |b: &[u8]| f32::from_le_bytes(b.try_into().unwrap());
        let be = |b: &[u8]| f32::from_be_bytes(b.try_into().unwrap());
        for k in 0..3 {
            for (v, p) in positions(k).iter().enumerate() {
                for (a, &want) in p.iter().enumerate() {
                    let i = ((k as usize * 4 + v) * 3 + a) * 4;
                    assert_eq!(le(&pc2[32 + i..36 + i]).to_bits(), want.to_bits());
                    assert_eq!(be(&mdd[20 + i..24 + i]).to_bits(), want.to_bits());
                }
            }
        }
    }

    #[test]
    fn frames_out_of_order_short_or_missing_are_refused() {
        let run = run();
        let mut w = Pc2Writer::new(Vec::new(), &spec(&run, &surface())).unwrap();
        let p = positions(0);
        let skip = Frame {
            index: 1,
            positions: &p,
            normals: &p,
        };
        assert_eq!(
            w.write_frame(&skip).unwrap_err().kind(),
            io::ErrorKind::InvalidInput
        );
        let short = Frame {
            index: 0,
            positions: &p[..3],
            normals: &p[..3],
        };
        assert!(w.write_frame(&short).is_err());
        feed(&mut w, 2);
        let e = Box::new(w).finish().unwrap_err();
        assert!(e.to_string().contains("2 frame(s) fed"), "{e}");
    }
}
