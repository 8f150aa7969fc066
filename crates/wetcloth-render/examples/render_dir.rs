//! Renders a run directory like `wetcloth render` will:
//! `cargo run --release --example render_dir -- RUN_DIR [WxH] [FRAMES] [CAMERA] [WETNESS]`, then
//! plots it. Empty arguments keep the defaults.

use wetcloth_render::{RenderOptions, plot_run, render_run_with_progress};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = args
        .next()
        .ok_or("usage: render_dir RUN_DIR [WxH] [FRAMES] [CAMERA]")?;
    let mut opts = RenderOptions::new(&dir);
    if let Some(s) = args.next() {
        opts.size = s.parse()?;
    }
    if let Some(s) = args.next().filter(|s| !s.is_empty()) {
        opts.frames = Some(s.parse()?);
    }
    if let Some(s) = args.next().filter(|s| !s.is_empty()) {
        opts.camera = Some(s.parse()?);
    }
    if let Some(s) = args.next() {
        opts.wetness = s.parse()?;
    }
    let summary = render_run_with_progress(opts, &mut |done, total| {
        eprint!("\r{done}/{total}");
    })?;
    eprintln!();
    println!("{summary}");
    println!("plot: {}", plot_run(&dir)?.display());
    Ok(())
}
