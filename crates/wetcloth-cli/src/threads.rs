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
    let what = if n == 0 {
        "one worker thread per core".to_string()
    } else {
        format!("{n} worker threads")
    };
    let refuse = |why: String| {
        CliError::Setup(format!(
            "cannot start {what}: {why}; ask for fewer with --threads N (or RAYON_NUM_THREADS)"
        ))
    };
    // A thread whose stack the address space cannot hold is not refused by the thread
    // library: the thread starts and the process aborts inside it. So check first.
    if let Some(limit) = address_space_limit() {
        let count = if n == 0 { num_cpus() } else { n } as u64;
        let need = count * THREAD_RESERVE;
        if need > limit / 2 {
            return Err(refuse(format!(
                "their stacks need about {} MB of address space, and the process may use {} MB \
                 (ulimit -v)",
                need >> 20,
                limit >> 20
            )));
        }
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .stack_size(STACK_BYTES)
        .thread_name(|i| format!("wetcloth-{i}"))
        .build_global()
        .map_err(|e| refuse(e.to_string()))?;
    Ok(rayon::current_num_threads())
}

/// Stack of a worker thread, bytes (the simulation's recursion is shallow).
const STACK_BYTES: usize = 2 << 20;

/// Address space a worker thread takes, bytes: its stack, the guard page and the signal stack,
/// rounded up.
const THREAD_RESERVE: u64 = (STACK_BYTES as u64) + (256 << 10);

/// The process's address-space limit (`ulimit -v`), bytes, when there is one.
#[cfg(unix)]
fn address_space_limit() -> Option<u64> {
    rustix::process::getrlimit(rustix::process::Resource::As).current
}

#[cfg(not(unix))]
fn address_space_limit() -> Option<u64> {
    None
}

/// Cores the thread library would use by default.
fn num_cpus() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}
