//! Ctrl-C and termination signals (SIGINT, SIGTERM, SIGHUP): a run stops after the frame it
//! is on, says so in `run.json` and leaves only whole files. The handler only raises a flag;
//! the run loop looks at it between chunks of steps.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A flag raised by Ctrl-C or a termination signal.
#[derive(Clone, Debug, Default)]
pub struct Interrupt(Arc<AtomicBool>);

impl Interrupt {
    /// A flag raised by the signals, once a handler is installed; a flag nothing raises
    /// (with a warning) when the handler cannot be installed.
    pub fn install() -> Self {
        let flag = Self::default();
        let raised = Arc::clone(&flag.0);
        if let Err(e) = ctrlc::set_handler(move || raised.store(true, Ordering::SeqCst)) {
            eprintln!(
                "wetcloth: warning: cannot catch Ctrl-C ({e}); an interrupted run will not \
                 update run.json"
            );
        }
        flag
    }

    /// Whether a signal has come.
    pub fn raised(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }
}
