//! The font the plots and the pockets' overlay write with: DejaVu Sans, bundled, registered
//! with the chart library once per process.

use plotters::style::FontStyle;
use std::sync::Once;

static FONT: Once = Once::new();

/// Registers the bundled font as `sans-serif` (once; later calls do nothing).
pub(crate) fn register_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
        // The bundled font is known to parse; a failure would show as missing text only.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, bytes);
    });
}
