//! `wetcloth view [SCENE]`: the interactive demo window (thesis fig. 4.1), from the
//! `wetcloth-viewer` crate.

use crate::error::CliError;
use clap::Args;
use std::path::PathBuf;
use wetcloth_viewer::ViewerOptions;

/// Arguments of `wetcloth view`.
#[derive(Args, Debug)]
pub struct ViewArgs {
    /// Scene file (TOML). Without one, the thesis demo opens with its keyframed lift removed:
    /// the cloth lies on the table and the mouse is the hand.
    pub scene: Option<PathBuf>,

    /// Drop the scene's keyframed grabs, leaving the cloth to the mouse.
    #[arg(long)]
    pub no_grabs: bool,

    /// Replay input events from a script file (see docs/viewer.md).
    #[arg(long, value_name = "FILE")]
    pub script: Option<PathBuf>,

    /// Save a PNG screenshot when the script has run (or right after start-up).
    #[arg(long, value_name = "PNG")]
    pub screenshot: Option<PathBuf>,

    /// Close the window when the script (and the screenshot) is done.
    #[arg(long)]
    pub exit: bool,

    /// Run folder for recording (default runs/view).
    #[arg(long, value_name = "DIR")]
    pub record_dir: Option<PathBuf>,
}

/// Runs `wetcloth view`.
pub fn view(args: &ViewArgs) -> Result<(), CliError> {
    let mut opts = match &args.scene {
        Some(path) => {
            let scene = wetcloth_scene::load(path)?;
            let mut o = ViewerOptions::new(scene.config, scene.name);
            o.scene_path = Some(path.clone());
            o
        }
        None => ViewerOptions::thesis_demo(),
    };
    if args.no_grabs {
        opts.scene.grabs.clear();
    }
    opts.script.clone_from(&args.script);
    opts.screenshot.clone_from(&args.screenshot);
    opts.exit_after_script = args.exit;
    opts.record_dir.clone_from(&args.record_dir);
    // No display, a bad script or a failed window: the viewer's message says what to do.
    wetcloth_viewer::run(opts).map_err(|e| CliError::Setup(e.to_string()))
}
