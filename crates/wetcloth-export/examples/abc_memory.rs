//! Writes a synthetic Alembic cache of a large cloth, to measure the writer's memory:
//!
//! ```sh
//! cargo build --release -p wetcloth-export --example abc_memory
//! /usr/bin/time -v target/release/examples/abc_memory OUT.abc [NX NZ FRAMES]
//! ```
//!
//! Every frame is distinct (a travelling wave), so every frame's points are hashed and
//! written; defaults 1000 x 1000 particles and 300 frames (3.6 GB of points).

use std::fs::File;
use std::io::BufWriter;
use wetcloth::{ClothSurface, SimConfig};
use wetcloth_export::{AbcWriter, CacheSpec, CacheWriter, Frame, RunInfo};

fn main() -> std::io::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let out = args.get(1).map_or("synthetic.abc", String::as_str);
    let num = |i: usize, d: usize| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(d);
    let (nx, nz, frames) = (num(2, 1000), num(3, 1000), num(4, 300) as u64);
    let mut config = SimConfig::default();
    config.cloth.resolution = [nx, nz];
    let run = RunInfo::new("synthetic", &config, frames, true);
    let surface = ClothSurface::new(&config.cloth);
    let spec = CacheSpec {
        run: &run,
        frames,
        surface: &surface,
        params: &[],
    };
    let file = BufWriter::with_capacity(1 << 20, File::create(out)?);
    let mut w: Box<dyn CacheWriter> = Box::new(AbcWriter::new(file, &spec)?);
    let mut positions = vec![[0f32; 3]; nx * nz];
    let normals = vec![[0f32, 1.0, 0.0]; nx * nz];
    for k in 0..frames {
        for j in 0..nz {
            for i in 0..nx {
                let (x, z) = (i as f32 / nx as f32, j as f32 / nz as f32);
                let y = 0.05 * (10.0 * x + 0.1 * k as f32).sin() * z;
                positions[j * nx + i] = [x - 0.5, y, z - 0.5];
            }
        }
        let frame = Frame {
            index: k,
            positions: &positions,
            normals: &normals,
        };
        w.write_frame(&frame)?;
    }
    w.finish()
}
