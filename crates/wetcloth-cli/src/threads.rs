//! The worker threads: the global thread pool is built once, before any simulation work, so a
//! pool that cannot start is an error with a message, not a panic inside the thread library
//! (which builds its pool lazily on first use and panics, or aborts, when that fails).

use crate::error::CliError;

/// The most worker threads `--threads` and `RAYON_NUM_THREADS` may ask for.
pub const MAX_THREADS: usize = 4096;

/// The thread count `RAYON_NUM_THREADS` asks for: `None` when unset, empty or 0 (all cores);
/// an error when it is not a number of threads in 0..=[`MAX_THREADS`].
pub fn from_env() -> Result<Option<usize>, CliError> {
    let bad = |value: &str| {
        CliError::Usage(format!(
            "RAYON_NUM_THREADS = {value:?} is not a thread count: allowed 1 to {MAX_THREADS}, \
             or 0 or unset for one thread per core"
        ))
    };
    match std::env::var("RAYON_NUM_THREADS") {
        Err(std::env::VarError::NotPresent) => Ok(None),
        Err(std::env::VarError::NotUnicode(v)) => Err(bad(&v.to_string_lossy())),
        Ok(s) if s.trim().is_empty() => Ok(None),
        Ok(s) => match s.trim().parse::<usize>() {
            Ok(0) => Ok(None),
            Ok(n) if n <= MAX_THREADS => Ok(Some(n)),
            _ => Err(bad(&s)),
        },
    }
}

/// Builds the global pool with `threads` workers (default: `RAYON_NUM_THREADS`, else one per
/// core) and returns how many it has. A pool that cannot start (too many threads for the
/// memory or process limits) is a [`CliError::Setup`] naming the count.
pub fn start_pool(threads: Option<usize>) -> Result<usize, CliError> {
    let env = from_env()?;
    let n = threads.or(env).unwrap_or(0);
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .thread_name(|i| format!("wetcloth-{i}"))
        .build_global()
        .map_err(|e| {
            let what = if n == 0 {
                "one worker thread per core".to_string()
            } else {
                format!("{n} worker threads")
            };
            CliError::Setup(format!(
                "cannot start {what}: {e}; ask for fewer with --threads N (or \
                 RAYON_NUM_THREADS)"
            ))
        })?;
    Ok(rayon::current_num_threads())
}
