//! # wetcloth-viewer: the interactive demo
//!
//! The thesis' demo program (Yamada 2012, section 4.1, fig. 4.1) as a window: a wet cloth on a
//! table that you pull up with the mouse and watch cling. [`run`] opens it; the `wetcloth view`
//! command is a thin wrapper.
//!
//! - The 3D view draws the cloth (smooth-shaded, darker and glossier when wet) and the table
//!   with the same renderer as the offline `wetcloth render` command
//!   ([`wetcloth_render::ClothRenderer`]), inside the window's render pass.
//! - The thesis' three buttons: (1) air-pressure force on/off, (2) pick mode, (3) reset. In pick
//!   mode the particles are shown; dragging one pulls it in the plane through it facing the
//!   camera (Shift or the wheel moves it vertically), and a right click while dragging pins it
//!   there. Picking and dragging are pure functions in [`pick`], tested without a window.
//! - Orbit / pan / zoom camera, pause and single step, a shortcut for every button, live
//!   readouts (simulated time, real-time factor, steps/s, frame rate, bubble volume and
//!   pressure, grab force) and a plot of pressure and volume.
//! - The air pockets: each sealed pocket tinted by its pressure (a toggle, key T) and listed
//!   with its volume, air, pressure, area and particles ([`pockets`]).
//! - Parameters (air amount, stiffnesses, friction, damping, time step, resolution), opening
//!   another scene file, and recording the session as a run folder (`frames/frame_NNNN.obj` +
//!   `metrics.csv`) that `wetcloth render` and Blender read.
//! - The simulation runs on a thread of its own ([`runner`]): it keeps to real time when it
//!   can and publishes snapshots the window reads without waiting, so the window never stalls.
//! - A script of input events ([`script`]) can drive the window, replayed through the same
//!   input handling as the mouse and keyboard, and save screenshots: this is how the viewer is
//!   tested end to end under Xvfb.
//!
//! ## Why egui + wgpu
//!
//! eframe/egui 0.37 with its wgpu backend gives the panels, sliders and plots of a real tool in
//! little code, and its paint callbacks hand the window's wgpu device and render pass to our
//! own renderer, so the viewer and the offline `render` command share one renderer and one set
//! of WGSL shaders. It runs under Xvfb with Mesa's software Vulkan (lavapipe), which is what
//! makes the end-to-end test possible on a machine without a GPU, and it needs no -dev
//! packages to build. The alternatives: eframe's glow backend draws faster on software OpenGL
//! but cannot share WGSL shaders with the offline renderer; bevy's current release needs a
//! newer rustc than this workspace's, and pulls hundreds of crates for a few widgets and one
//! mesh; a browser UI would mean a second language.
//!
//! ## Requirements at run time
//!
//! A display (X11 or Wayland) and a Vulkan, Metal, DX12 or OpenGL driver; without a GPU, Mesa's
//! software drivers work (`mesa-vulkan-drivers` on Debian). Without a display [`run`] returns
//! [`ViewerError::NoDisplay`]; use `wetcloth run` for batch runs, or `xvfb-run` to script the
//! viewer on a headless machine.

pub mod camera;
pub mod pick;
pub mod pockets;
pub mod record;
pub mod runner;
pub mod script;

mod app;
mod view3d;

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use wetcloth::SimConfig;

/// What to show and how.
pub struct ViewerOptions {
    /// The scene to simulate.
    pub scene: SimConfig,
    /// Its name, shown in the toolbar.
    pub scene_name: String,
    /// The scene's file, if it came from one (prefills the "Scene file" field).
    pub scene_path: Option<PathBuf>,
    /// A script of input events to replay (see [`script`]).
    pub script: Option<PathBuf>,
    /// A PNG to save once the script has run (or after start-up without a script).
    pub screenshot: Option<PathBuf>,
    /// Close the window when the script (and the screenshot) is done.
    pub exit_after_script: bool,
    /// Default run folder for recording.
    pub record_dir: Option<PathBuf>,
    /// Initial window size, logical pixels.
    pub window_size: [f32; 2],
}

impl ViewerOptions {
    /// Options for `scene`, named `name`, with no script.
    pub fn new(scene: SimConfig, name: impl Into<String>) -> Self {
        Self {
            scene,
            scene_name: name.into(),
            scene_path: None,
            script: None,
            screenshot: None,
            exit_after_script: false,
            record_dir: None,
            window_size: [1180.0, 760.0],
        }
    }

    /// The thesis' demo (ch. 4) with its keyframed lift removed: the hand is yours. It runs on
    /// the implicit integrator at 1/60 s with the interactive solve budget, which keeps real
    /// time while the cloth is pulled (docs/integrators.md); the parameters panel switches to
    /// the thesis' explicit step or the converged solve.
    pub fn thesis_demo() -> Self {
        let mut scene = SimConfig::thesis_demo();
        scene.grabs.clear();
        scene.simulation.integrator = wetcloth::Integrator::Implicit;
        scene.simulation.time_step = 1.0 / 60.0;
        scene.simulation.implicit_budget = wetcloth::SolveBudget::Interactive;
        Self::new(scene, wetcloth_scene::THESIS_DEMO_NAME)
    }
}

/// Why the viewer could not run.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// No display to open a window on.
    #[error(
        "no display to open the viewer window on ({0}).\n\
         For a batch run without a window use `wetcloth run SCENE`; to drive the viewer on a \
         headless machine, run it under a virtual display: `xvfb-run -a wetcloth view ...` \
         (Debian packages: xvfb mesa-vulkan-drivers)"
    )]
    NoDisplay(String),
    /// The scene is invalid.
    #[error("invalid scene: {0}")]
    Scene(#[from] wetcloth::ConfigError),
    /// The script could not be read.
    #[error(transparent)]
    Script(#[from] script::ScriptError),
    /// The window or its renderer failed.
    #[error("the viewer window failed: {0}")]
    Window(String),
    /// A scripted step failed (a screenshot could not be written, a particle was off screen).
    #[error("the script failed: {0}")]
    ScriptFailed(String),
}

/// Whether a display server is configured for this process (X11 or Wayland); on other
/// platforms there always is one.
pub fn display_available() -> Result<(), String> {
    if cfg!(all(unix, not(target_os = "macos"), not(target_os = "ios"))) {
        let set = |v: &str| std::env::var_os(v).is_some_and(|s| !s.is_empty());
        if !set("DISPLAY") && !set("WAYLAND_DISPLAY") {
            return Err("neither DISPLAY nor WAYLAND_DISPLAY is set".into());
        }
    }
    Ok(())
}

/// Whether a window error means there is no display to connect to (winit's wording when the X
/// or Wayland connection cannot be made, e.g. "Failed to open connection to X server").
fn is_display_error(text: &str) -> bool {
    let lower = text.to_lowercase();
    ["x server", "display", "wayland", "x11"]
        .iter()
        .any(|w| lower.contains(w))
}

/// Opens the viewer window and runs until it is closed.
pub fn run(opts: ViewerOptions) -> Result<(), ViewerError> {
    display_available().map_err(ViewerError::NoDisplay)?;
    opts.scene.validate()?;
    let commands = match &opts.script {
        Some(p) => script::load(p)?,
        None => Vec::new(),
    };

    let native = eframe::NativeOptions {
        viewport: eframe::egui::ViewportBuilder::default()
            .with_title("wetcloth")
            .with_app_id("wetcloth")
            .with_inner_size(opts.window_size)
            .with_min_inner_size([640.0, 420.0]),
        renderer: eframe::Renderer::Wgpu,
        depth_buffer: view3d::DEPTH_BITS,
        multisampling: view3d::SAMPLES,
        ..Default::default()
    };
    let outcome = Arc::new(Mutex::new(app::Outcome::default()));
    let out = Arc::clone(&outcome);
    let result = eframe::run_native(
        "wetcloth",
        native,
        Box::new(move |cc| {
            let app = app::ViewerApp::new(cc, opts, commands, out)?;
            Ok(Box::new(app))
        }),
    );
    if let Err(e) = result {
        let text = e.to_string();
        if is_display_error(&text) {
            return Err(ViewerError::NoDisplay(text));
        }
        return Err(ViewerError::Window(text));
    }
    let outcome = outcome.lock().unwrap_or_else(|e| e.into_inner());
    match &outcome.error {
        Some(e) => Err(ViewerError::ScriptFailed(e.clone())),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_no_display_error_points_to_run_and_xvfb() {
        let e = ViewerError::NoDisplay("neither DISPLAY nor WAYLAND_DISPLAY is set".into());
        let s = e.to_string();
        assert!(s.contains("no display"), "{s}");
        assert!(s.contains("wetcloth run"), "{s}");
        assert!(s.contains("xvfb-run"), "{s}");
    }

    #[test]
    fn winit_connection_failures_read_as_no_display() {
        assert!(is_display_error(
            "winit EventLoopError: os error at ...: Failed to open connection to X server"
        ));
        assert!(is_display_error("Failed to connect to the Wayland display"));
        assert!(!is_display_error("wgpu error: no suitable adapter"));
    }

    #[test]
    fn the_default_scene_leaves_the_hand_to_the_user() {
        let o = ViewerOptions::thesis_demo();
        assert!(o.scene.grabs.is_empty());
        assert_eq!(
            o.scene.simulation.integrator,
            wetcloth::Integrator::Implicit
        );
        assert_eq!(
            o.scene.simulation.implicit_budget,
            wetcloth::SolveBudget::Interactive
        );
        assert!((o.scene.simulation.time_step - 1.0 / 60.0).abs() < 1e-15);
        assert!(o.scene.validate().is_ok());
    }
}
