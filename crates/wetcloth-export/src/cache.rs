//! Animation caches: the whole run in one file that animation packages open.
//!
//! Every cache is written by a [`CacheWriter`], fed one frame at a time in frame order and then
//! finished, so memory stays bounded by one frame however long the run. The writers are:
//!
//! | [`CacheFormat`] | writer | read by |
//! |---|---|---|
//! | `pc2` | [`Pc2Writer`](crate::Pc2Writer) | Blender's Mesh Cache modifier, 3ds Max |
//! | `mdd` | [`MddWriter`](crate::MddWriter) | Blender, Houdini, LightWave, three.js |
//! | `usda` | [`UsdaWriter`](crate::UsdaWriter) | anything with USD (text) |
//! | `usdc` | [`UsdcWriter`](crate::UsdcWriter) | anything with USD (binary "crate" file) |
//! | `abc` | [`AbcWriter`](crate::AbcWriter) | Maya, Houdini, Blender, Cinema 4D, Unreal (Alembic) |
//!
//! A new format is one more writer implementing [`CacheWriter`] and one more
//! [`CacheFormat`] variant.

use crate::RunInfo;
use crate::params::SceneParam;
use std::fmt;
use std::io;
use std::str::FromStr;
use wetcloth::ClothSurface;

/// The cache formats `wetcloth export --format` and `wetcloth run --export` know.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CacheFormat {
    /// PC2 point cache (little-endian), for Blender's Mesh Cache modifier and 3ds Max.
    Pc2,
    /// MDD point cache (big-endian), for Blender, Houdini, LightWave and three.js.
    Mdd,
    /// USD stage as text.
    Usda,
    /// USD stage in the binary crate format.
    Usdc,
    /// Alembic archive (Ogawa).
    Abc,
}

impl CacheFormat {
    /// Every format, in the order `--format` lists them.
    pub const ALL: [CacheFormat; 5] = [
        CacheFormat::Pc2,
        CacheFormat::Mdd,
        CacheFormat::Usda,
        CacheFormat::Usdc,
        CacheFormat::Abc,
    ];

    /// The format's name on the command line, which is also its file extension.
    pub fn name(self) -> &'static str {
        match self {
            CacheFormat::Pc2 => "pc2",
            CacheFormat::Mdd => "mdd",
            CacheFormat::Usda => "usda",
            CacheFormat::Usdc => "usdc",
            CacheFormat::Abc => "abc",
        }
    }

    /// The file extension (without the dot): the same as [`CacheFormat::name`].
    pub fn extension(self) -> &'static str {
        self.name()
    }

    /// Parses a comma-separated list such as `usdc,pc2` (spaces around names allowed). A format
    /// named twice is kept once, in its first place.
    ///
    /// # Errors
    ///
    /// A message naming the unknown or empty entry and the known formats.
    pub fn parse_list(list: &str) -> Result<Vec<CacheFormat>, String> {
        let mut out = Vec::new();
        for item in list.split(',') {
            let f: CacheFormat = item.trim().parse()?;
            if !out.contains(&f) {
                out.push(f);
            }
        }
        Ok(out)
    }
}

impl fmt::Display for CacheFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for CacheFormat {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        CacheFormat::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| {
                let known: Vec<&str> = CacheFormat::ALL.iter().map(|f| f.name()).collect();
                format!(
                    "unknown cache format `{s}`; the formats are {}",
                    known.join(", ")
                )
            })
    }
}

/// One frame of the cloth as the caches store it: single-precision positions and normals, one
/// per particle (vertex `k` is particle `k`), in metres, Y up.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a> {
    /// Frame number, from 0.
    pub index: u64,
    /// Particle positions, m.
    pub positions: &'a [[f32; 3]],
    /// Unit vertex normals.
    pub normals: &'a [[f32; 3]],
}

impl Frame<'_> {
    /// The axis-aligned bounds of the positions, `[min, max]` (USD's `extent`).
    pub fn extent(&self) -> [[f32; 3]; 2] {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in self.positions {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        [lo, hi]
    }
}

/// What every cache writer knows before the first frame: the run, the cloth's topology and the
/// scene's parameters.
#[derive(Clone, Copy, Debug)]
pub struct CacheSpec<'a> {
    /// The run (`run.json`): name, frame rate, colliders.
    pub run: &'a RunInfo,
    /// Frames the cache will hold: frame 0 up to `frames - 1`, each fed once, in order.
    pub frames: u64,
    /// The cloth's faces and texture coordinates as the frames have them: the grid's
    /// triangles with a texture coordinate per particle, or a mesh cloth's polygons in the
    /// file's order and winding with its face-varying texture coordinates (counter-clockwise
    /// seen from the side their normal points to).
    pub surface: &'a ClothSurface,
    /// The scene's parameters (see [`crate::scene_params`]), written into USD stages as custom
    /// attributes.
    pub params: &'a [SceneParam],
}

impl CacheSpec<'_> {
    /// Vertices per frame: the cloth's particles.
    pub fn vertices(&self) -> usize {
        self.surface.vertices
    }

    /// The texture coordinates in single precision.
    pub fn uvs_f32(&self) -> Vec<[f32; 2]> {
        self.surface
            .uvs
            .iter()
            .map(|&[u, v]| [u as f32, v as f32])
            .collect()
    }

    /// Time of frame `k` in seconds: `k / frame_rate`.
    pub fn frame_time(&self, k: u64) -> f64 {
        k as f64 / self.run.frame_rate
    }
}

/// A cache being written: fed every frame once, in order, then finished.
pub trait CacheWriter {
    /// Appends frame `frame.index`.
    ///
    /// # Errors
    ///
    /// The output's I/O errors, or [`io::ErrorKind::InvalidInput`] for a frame out of order or
    /// of the wrong vertex count.
    fn write_frame(&mut self, frame: &Frame<'_>) -> io::Result<()>;

    /// Writes what follows the last frame and flushes the output.
    ///
    /// # Errors
    ///
    /// The output's I/O errors, or [`io::ErrorKind::InvalidInput`] when fewer frames were fed
    /// than the [`CacheSpec`] announced.
    fn finish(self: Box<Self>) -> io::Result<()>;
}

/// Checks that `frame` is the `expected`-th frame and has `vertices` positions and normals.
pub(crate) fn check_frame(frame: &Frame<'_>, expected: u64, vertices: usize) -> io::Result<()> {
    if frame.index != expected {
        return Err(invalid(format!(
            "frame {} fed where frame {expected} was expected",
            frame.index
        )));
    }
    if frame.positions.len() != vertices || frame.normals.len() != vertices {
        return Err(invalid(format!(
            "frame {} has {} positions and {} normals, the cache {vertices} vertices",
            frame.index,
            frame.positions.len(),
            frame.normals.len()
        )));
    }
    Ok(())
}

/// Checks at `finish` that all `announced` frames were fed.
pub(crate) fn check_complete(fed: u64, announced: u64) -> io::Result<()> {
    if fed == announced {
        Ok(())
    } else {
        Err(invalid(format!(
            "{fed} frame(s) fed to a cache announced with {announced}"
        )))
    }
}

/// An [`io::ErrorKind::InvalidInput`] error.
pub(crate) fn invalid(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, msg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_parse_by_name_and_lists_keep_first_places() {
        for f in CacheFormat::ALL {
            assert_eq!(f.name().parse::<CacheFormat>(), Ok(f));
            assert_eq!(f.extension(), f.to_string());
        }
        assert_eq!(
            CacheFormat::parse_list("usdc, pc2,usdc"),
            Ok(vec![CacheFormat::Usdc, CacheFormat::Pc2])
        );
        let e = CacheFormat::parse_list("pc2,obj").unwrap_err();
        assert!(
            e.contains("`obj`") && e.contains("pc2, mdd, usda, usdc, abc"),
            "{e}"
        );
        assert!(CacheFormat::parse_list("pc2,").is_err());
    }

    #[test]
    fn extent_bounds_every_position() {
        let p = [[0.0, 1.0, -2.0], [3.0, -1.0, 0.5]];
        let f = Frame {
            index: 0,
            positions: &p,
            normals: &p,
        };
        assert_eq!(f.extent(), [[0.0, -1.0, -2.0], [3.0, 1.0, 0.5]]);
    }
}
