//! What a run will need, estimated before it starts: memory, disk and time.
//!
//! A scene inside the documented ranges can still be far too big for the machine: a
//! 4096 x 4096 cloth holds 1.7 GB of particle state before its first step, and thick
//! particles on a fine grid give every particle thousands of self-collision candidates (a
//! 200 x 200 cloth 1 mm across, with the default 0.75 mm particle radius, has 40 000 per
//! particle: 6 GB of lists). `wetcloth run` estimates before it allocates anything, prints the
//! estimate for large runs and refuses a run that cannot fit (`--force` runs it anyway).
//!
//! - **Memory**: the simulation's own layout, measured on tiny cloths of the same kind
//!   ([`Simulation::memory_bytes`] is linear in the particle count and the row lengths), plus
//!   the self-collision lists, sized from the number of particle pairs within reach in the
//!   flat starting grid, plus what a list rebuild and the frame writer hold for a moment.
//! - **Disk**: the OBJ frames (a line per vertex, texture coordinate and normal in full
//!   precision, a line per triangle), `metrics.csv`, `scene.toml` and `run.json`.
//! - **Time**: steps x (particles x a per-particle cost + candidate pairs x a per-pair cost),
//!   shared over the threads; rough (a factor of two either way), for orders of magnitude.

use wetcloth::{Grid, SimConfig, Simulation};

/// Bytes written per number in an OBJ frame, separator included: full-precision `f64` text
/// (`-0.12345678901234567`) is 19 to 21 characters. This makes the frame size an upper bound:
/// a crumpled cloth's positions and normals are all full precision, a cloth lying flat has
/// normals `0.0 1.0 0.0` and writes about a quarter less.
const OBJ_NUMBER_BYTES: u64 = 21;

/// Bytes of one `metrics.csv` row: the frame number and 9 full-precision values.
const CSV_ROW_BYTES: u64 = 10 * 21;

/// Seconds per particle per step on one thread (measured: 2 to 3e7 particle-steps/s on one
/// core of the development machine; this is the slow end).
const SECONDS_PER_PARTICLE_STEP: f64 = 5e-8;

/// Seconds per self-collision candidate pair per step on one thread.
const SECONDS_PER_CANDIDATE_STEP: f64 = 3e-9;

/// What a run needs.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// Particles.
    pub particles: u64,
    /// Frames the run writes.
    pub frames: u64,
    /// Steps the run takes.
    pub steps: u64,
    /// Self-collision candidate pairs (ordered, as the core lists them) in the flat starting
    /// cloth: every pair of particles closer than twice their diameter. 0 without
    /// self-collision.
    pub candidates: u64,
    /// Heap memory of the simulation once its self-collision lists are built, bytes: an upper
    /// bound of what [`Simulation::memory_bytes`] then reports (lists may hold up to twice
    /// their length while they grow).
    pub simulation_bytes: u64,
    /// Peak memory of the run, bytes: [`Estimate::simulation_bytes`] plus the transient of a
    /// list rebuild and the frame writer's buffers.
    pub memory_bytes: u64,
    /// Bytes of one OBJ frame.
    pub frame_bytes: u64,
    /// Bytes the run writes: frames, `metrics.csv`, `scene.toml` and `run.json`.
    pub disk_bytes: u64,
    /// Wall-clock time on `threads` threads, s (rough).
    pub seconds: f64,
}

/// Ordered pairs of distinct grid points `(i, j)`, `(i', j')` of an `nx` x `nz` grid with
/// spacings `dx`, `dz` that lie closer than `reach`.
pub fn pairs_within(nx: usize, nz: usize, dx: f64, dz: f64, reach: f64) -> u64 {
    let positive = |v: f64| v > 0.0 && v.is_finite();
    if !(positive(reach) && positive(dx) && positive(dz)) {
        return 0;
    }
    let (nx, nz) = (nx as u64, nz as u64);
    let r2 = reach * reach;
    let mut total = 0u64;
    let max_di = ((reach / dx).ceil() as u64).min(nx - 1);
    for di in 0..=max_di {
        let u = di as f64 * dx;
        let rem = r2 - u * u;
        if rem <= 0.0 {
            break;
        }
        // The largest dj with (dj dz)^2 < rem.
        let mut m = ((rem.sqrt() / dz).floor() as u64).min(nz - 1);
        while m > 0 && (m as f64 * dz).powi(2) >= rem {
            m -= 1;
        }
        while m < nz - 1 && ((m + 1) as f64 * dz).powi(2) < rem {
            m += 1;
        }
        // Sum over dj in -m..=m of (nz - |dj|).
        let column = nz + 2 * (m * nz - m * (m + 1) / 2);
        let rows = if di == 0 { nx } else { 2 * (nx - di) };
        total += rows * column;
    }
    // Each point paired with itself is not a pair.
    total - nx * nz
}

/// The simulation's memory without self-collision lists, bytes, as `a n + b nx + c nz + d`,
/// measured on four tiny cloths of the same kind.
fn base_memory(config: &SimConfig) -> u64 {
    // The layout depends on the grid and on whether self-collision is on, not on where the
    // cloth is or what it touches: a free cloth with the air off serves.
    let measure = |nx: usize, nz: usize| -> f64 {
        let mut c = SimConfig::default();
        c.cloth.resolution = [nx, nz];
        c.cloth.self_collision = config.cloth.self_collision;
        c.air.enabled = false;
        Simulation::new(c).map_or(0.0, |s| s.memory_bytes() as f64)
    };
    let (m44, m84, m48, m88) = (measure(4, 4), measure(8, 4), measure(4, 8), measure(8, 8));
    let a = ((m88 - m84) - (m48 - m44)) / 16.0;
    let b = (m84 - m44 - 16.0 * a) / 4.0;
    let c = (m48 - m44 - 16.0 * a) / 4.0;
    let d = m44 - 16.0 * a - 4.0 * b - 4.0 * c;
    let [nx, nz] = config.cloth.resolution;
    let n = (nx * nz) as f64;
    (a * n + b * nx as f64 + c * nz as f64 + d).max(0.0).ceil() as u64
}

/// Estimates what running `config` needs on `threads` threads.
pub fn estimate(config: &SimConfig, threads: usize) -> Estimate {
    let cloth = &config.cloth;
    let [nx, nz] = cloth.resolution;
    let n = (nx * nz) as u64;
    let grid = Grid::new(cloth);
    let frames = wetcloth_export::last_frame(config) + 1;
    let steps = wetcloth_export::frame_step(
        frames - 1,
        config.simulation.frame_rate,
        config.simulation.time_step,
    );

    // Self-collision: particles are spheres of diameter 2r; the lists hold every particle
    // within diameter + skin (= 2 diameters) of each particle.
    let diameter = 2.0 * cloth.particle_radius();
    let candidates = if cloth.self_collision {
        pairs_within(nx, nz, grid.dx, grid.dz, 2.0 * diameter)
    } else {
        0
    };
    let buckets = (2 * n).next_power_of_two() + 1;
    // Reference positions and cell coordinates (24 bytes each a particle), list starts (up to
    // twice n + 1 entries while growing), hash buckets and items, and the list itself (up to
    // twice its length while growing), 4 bytes an entry.
    let lists = if cloth.self_collision {
        48 * n + 8 * (n + 1) + 4 * buckets + 4 * n + 8 * candidates
    } else {
        0
    };
    let simulation_bytes = base_memory(config) + lists;
    // A rebuild collects every particle's list before joining them (a vector header each and
    // up to twice the entries), and copies the bucket starts.
    let rebuild = if cloth.self_collision {
        24 * n + 16 * n + 8 * candidates + 4 * buckets
    } else {
        0
    };
    // The frame writer: texture coordinates (kept), normals and triangles (per frame).
    let triangles = 2 * (nx as u64 - 1) * (nz as u64 - 1);
    let writer = 16 * n + 24 * n + 12 * triangles + (1 << 16);
    let memory_bytes = simulation_bytes + rebuild + writer;

    let frame_bytes = match &cloth.mesh {
        None => obj_bytes(nx, nz),
        Some(m) => mesh_obj_bytes(m),
    };
    let disk_bytes = frames * frame_bytes + (frames + 1) * CSV_ROW_BYTES + (16 << 10);

    let speedup = (threads as f64)
        .min((n as f64 / 1024.0).max(1.0))
        .max(1.0)
        .powf(0.85);
    let seconds = steps as f64
        * (n as f64 * SECONDS_PER_PARTICLE_STEP + candidates as f64 * SECONDS_PER_CANDIDATE_STEP)
        / speedup;

    Estimate {
        particles: n,
        frames,
        steps,
        candidates,
        simulation_bytes,
        memory_bytes,
        frame_bytes,
        disk_bytes,
        seconds,
    }
}

/// Bytes of one OBJ frame of an `nx` x `nz` cloth, as `write_obj` writes it.
fn obj_bytes(nx: usize, nz: usize) -> u64 {
    let n = (nx * nz) as u64;
    let triangles = 2 * (nx as u64 - 1) * (nz as u64 - 1);
    let header = format!("# wetcloth cloth mesh: {nx} x {nz} particles\no cloth\n").len() as u64;
    // "v x y z\n", "vt u v\n", "vn x y z\n".
    let vertex =
        (2 + 3 * OBJ_NUMBER_BYTES) + (3 + 2 * OBJ_NUMBER_BYTES) + (3 + 3 * OBJ_NUMBER_BYTES);
    // "f a/a/a b/b/b c/c/c\n": 3 corners of 3 d-digit indices and 2 slashes, each after a
    // space, with the mean digit count of the 1-based indices.
    let mut digits = 0u64;
    let mut p = 1u64;
    let mut d = 1u64;
    while p <= n {
        let upto = (p * 10 - 1).min(n);
        digits += (upto - p + 1) * d;
        p *= 10;
        d += 1;
    }
    let mean_digits = digits as f64 / n as f64;
    let face = 2.0 + 3.0 * (1.0 + 3.0 * mean_digits + 2.0);
    header + n * vertex + (triangles as f64 * face).ceil() as u64
}

/// Bytes of one OBJ frame of a mesh cloth, as `write_obj` writes it: a `v` and a `vn` line a
/// vertex, the file's `vt` lines, and its faces' corners (`v/vt/vn`).
fn mesh_obj_bytes(m: &wetcloth::ClothMeshSource) -> u64 {
    let n = m.vertices.len() as u64;
    let corners: u64 = m.faces.iter().map(|f| f.len() as u64).sum();
    let digits = |count: u64| (count.max(1) as f64).log10().floor() as u64 + 1;
    let (dv, dt) = (digits(n), digits(m.uvs.len() as u64));
    let vertex = (2 + 3 * OBJ_NUMBER_BYTES) + (3 + 3 * OBJ_NUMBER_BYTES);
    let uv = (3 + 2 * OBJ_NUMBER_BYTES) * m.uvs.len() as u64;
    let corner = 1 + 2 * dv + dt + 2;
    64 + n * vertex + uv + 2 * m.faces.len() as u64 + corners * corner
}

/// Bytes for people: `412 GB`, `3.1 MB`, `820 kB`.
pub fn bytes(b: u64) -> String {
    let b = b as f64;
    if b >= 1e12 {
        format!("{:.1} TB", b / 1e12)
    } else if b >= 1e9 {
        format!("{:.1} GB", b / 1e9)
    } else if b >= 1e6 {
        format!("{:.1} MB", b / 1e6)
    } else {
        format!("{:.0} kB", (b / 1e3).ceil())
    }
}

/// A length for people, 3 significant digits: `0.75 mm`, `0.0733 mm`, `3 mm`, `1.2 m`.
pub fn length(m: f64) -> String {
    let (v, unit) = if m.abs() < 1.0 {
        (m * 1e3, "mm")
    } else {
        (m, "m")
    };
    let s = format!(
        "{:.*}",
        (2 - v.abs().log10().floor().max(-9.0) as i32).max(0) as usize,
        v
    );
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    format!("{s} {unit}")
}

/// Seconds for people: `40 s`, `12 min`, `3.5 h`, `2.1 days`.
pub fn duration(s: f64) -> String {
    if s < 90.0 {
        format!("{:.0} s", s.max(1.0))
    } else if s < 5400.0 {
        format!("{:.0} min", s / 60.0)
    } else if s < 2.0 * 86400.0 {
        format!("{:.1} h", s / 3600.0)
    } else {
        format!("{:.1} days", s / 86400.0)
    }
}

impl Estimate {
    /// Whether the run is large enough for its estimate to be printed before it starts: a
    /// gigabyte of memory or disk, or a minute.
    pub fn is_large(&self) -> bool {
        self.memory_bytes >= 1_000_000_000
            || self.disk_bytes >= 1_000_000_000
            || self.seconds >= 60.0
    }

    /// One line: `about 2.1 GB of memory, 14.3 GB of disk (181 frames of 79.0 MB) and 25 min`.
    pub fn summary(&self) -> String {
        format!(
            "about {} of memory, {} of disk ({} frame{} of {}) and {} on this machine",
            bytes(self.memory_bytes),
            bytes(self.disk_bytes),
            self.frames,
            if self.frames == 1 { "" } else { "s" },
            bytes(self.frame_bytes),
            duration(self.seconds)
        )
    }

    /// What makes the memory large, for the refusal message.
    pub fn memory_breakdown(&self, config: &SimConfig) -> String {
        let c = &config.cloth;
        let mut s = format!("{} particles", self.particles);
        if self.candidates > 0 {
            let per = self.candidates as f64 / self.particles as f64;
            let grid = Grid::new(c);
            s += &format!(
                ", {:.3e} self-collision candidate pairs ({per:.0} per particle: particles of \
                 radius {} on a {} grid reach every particle within {})",
                self.candidates as f64,
                length(c.particle_radius()),
                length(grid.dx.min(grid.dz)),
                length(4.0 * c.particle_radius())
            );
        }
        s
    }
}

/// What the machine has to give a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Available {
    /// Memory the run may use, bytes, when known: the system's available memory, or less
    /// under a control-group limit.
    pub memory: Option<u64>,
    /// Free space on the output's file system, bytes, when known.
    pub disk: Option<u64>,
}

impl Available {
    /// Reads what this machine has for output under `dir` (or its nearest existing
    /// ancestor).
    pub fn here(dir: &std::path::Path) -> Self {
        Self {
            memory: available_memory(),
            disk: free_disk(dir),
        }
    }
}

/// `MemAvailable` of `/proc/meminfo`, lowered to what a cgroup v2 memory limit leaves.
fn available_memory() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kb = meminfo
        .lines()
        .find_map(|l| l.strip_prefix("MemAvailable:"))?
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse::<u64>()
        .ok()?;
    let mut avail = kb * 1024;
    let read = |p: &str| std::fs::read_to_string(p).ok();
    if let (Some(max), Some(current)) = (
        read("/sys/fs/cgroup/memory.max"),
        read("/sys/fs/cgroup/memory.current"),
    ) && let (Ok(max), Ok(current)) = (max.trim().parse::<u64>(), current.trim().parse::<u64>())
    {
        avail = avail.min(max.saturating_sub(current));
    }
    Some(avail)
}

/// Free bytes for an unprivileged writer on the file system of `dir`.
#[cfg(unix)]
fn free_disk(dir: &std::path::Path) -> Option<u64> {
    let mut p = dir;
    loop {
        if p.exists() {
            break;
        }
        p = p.parent()?;
        if p.as_os_str().is_empty() {
            p = std::path::Path::new(".");
        }
    }
    let s = rustix::fs::statvfs(p).ok()?;
    Some(s.f_bavail.saturating_mul(s.f_frsize))
}

#[cfg(not(unix))]
fn free_disk(_dir: &std::path::Path) -> Option<u64> {
    None
}

/// Why a run cannot fit, if it cannot: its estimate against what is available.
pub fn refusal(e: &Estimate, available: Available, config: &SimConfig) -> Option<String> {
    if let Some(mem) = available.memory
        && e.memory_bytes > mem
    {
        return Some(format!(
            "this run needs about {} of memory ({}) and this machine has {} available; lower \
             cloth.resolution{}, or pass --force to run it anyway",
            bytes(e.memory_bytes),
            e.memory_breakdown(config),
            bytes(mem),
            if e.candidates > e.particles * 64 {
                ", thickness and collision_margin, or set self_collision = false"
            } else {
                ""
            }
        ));
    }
    if let Some(disk) = available.disk
        && e.disk_bytes > disk
    {
        return Some(format!(
            "this run writes about {} ({} frames of {}) and the output's file system has {} \
             free; lower cloth.resolution, simulation.frame_rate or simulation.duration, write \
             elsewhere with --out, or pass --force to run it anyway",
            bytes(e.disk_bytes),
            e.frames,
            bytes(e.frame_bytes),
            bytes(disk)
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pairs within reach, counted one by one.
    fn brute_pairs(nx: usize, nz: usize, dx: f64, dz: f64, reach: f64) -> u64 {
        let mut count = 0;
        for a in 0..nx * nz {
            for b in 0..nx * nz {
                let (u, v) = (
                    (a % nx) as f64 - (b % nx) as f64,
                    (a / nx) as f64 - (b / nx) as f64,
                );
                if a != b && (u * dx).powi(2) + (v * dz).powi(2) < reach * reach {
                    count += 1;
                }
            }
        }
        count
    }

    #[test]
    fn pairs_within_reach_match_a_direct_count() {
        for (nx, nz, dx, dz, reach) in [
            (5, 7, 1.0, 1.0, 1.5),
            (6, 4, 0.3, 0.7, 2.0),
            (9, 9, 0.1, 0.1, 10.0),
            (3, 12, 1.0, 0.5, 0.4),
            (10, 10, 1.0, 1.0, 0.0),
            (8, 5, 0.25, 0.25, 0.75),
        ] {
            assert_eq!(
                pairs_within(nx, nz, dx, dz, reach),
                brute_pairs(nx, nz, dx, dz, reach),
                "{nx} x {nz}, {dx} x {dz}, reach {reach}"
            );
        }
    }

    /// A small cloth of `res` particles, `size` m across, `thickness` m thick, resting on the
    /// ground with its air.
    fn cloth(res: [usize; 2], size: f64, thickness: f64, self_collision: bool) -> SimConfig {
        let mut c = SimConfig::thesis_demo();
        c.grabs.clear();
        c.cloth.resolution = res;
        c.cloth.size = [size, size];
        c.cloth.thickness = thickness;
        c.cloth.self_collision = self_collision;
        c.air.trapped_air = 0.0;
        c.cloth.position.y = c.cloth.particle_radius() + 1e-4;
        c
    }

    /// The memory estimate bounds what `Simulation::memory_bytes` reports once the
    /// self-collision lists are built, within a factor of two (lists hold up to twice their
    /// length while they grow), from no candidates to hundreds per particle.
    #[test]
    fn the_memory_estimate_bounds_memory_bytes_on_small_cloths() {
        for (res, size, thickness, sc) in [
            ([12, 12], 0.3, 0.001, true),
            ([20, 9], 0.3, 0.001, false),
            ([16, 16], 0.01, 0.002, true),
            ([30, 24], 0.02, 0.001, true),
            ([40, 40], 0.3, 0.05, true),
        ] {
            let c = cloth(res, size, thickness, sc);
            let mut sim = Simulation::new(c.clone()).unwrap();
            sim.advance(3).unwrap();
            let actual = sim.memory_bytes() as u64;
            let e = estimate(&c, 1);
            let what = format!("{res:?}, {size} m, {thickness} m thick: {e:?}, actual {actual}");
            assert!(actual <= e.simulation_bytes, "{what}");
            assert!(e.simulation_bytes <= 2 * actual, "{what}");
            assert!(e.memory_bytes >= e.simulation_bytes, "{what}");
            if sc {
                // The lists dominate with thick particles: the estimate follows them.
                let per = e.candidates / e.particles;
                assert!(thickness < 0.002 || per > 50, "{what}");
            } else {
                assert_eq!(e.candidates, 0);
            }
        }
    }

    /// The disk estimate bounds the bytes actually written for a frame, flat or moving, by
    /// at most 60 % over, and counts every frame and metrics row.
    #[test]
    fn the_disk_estimate_matches_the_bytes_written() {
        for res in [[8, 8], [33, 20], [100, 90]] {
            let mut c = cloth(res, 0.3, 0.001, false);
            c.simulation.time_step = c.simulation.time_step.min(0.5 * c.stable_time_step());
            c.grabs = vec![wetcloth::GrabSpec::lift(
                [res[0] / 2, res[1] / 2],
                0.0,
                0.05,
                0.02,
            )];
            c.simulation.duration = 0.05;
            c.simulation.frame_rate = 100.0;
            let mut sim = Simulation::new(c.clone()).unwrap();
            sim.advance(400).unwrap();
            let surface = wetcloth::ClothSurface::new(&c.cloth);
            let mut obj = Vec::new();
            let normals = surface.vertex_normals(sim.positions());
            wetcloth_export::write_obj(&mut obj, &surface, sim.positions(), &normals).unwrap();
            let e = estimate(&c, 1);
            let ratio = e.frame_bytes as f64 / obj.len() as f64;
            assert!(
                (1.0..1.6).contains(&ratio),
                "{res:?}: {} vs {}",
                e.frame_bytes,
                obj.len()
            );
            // The flat starting frame too.
            let flat = Simulation::new(c.clone()).unwrap();
            let mut obj = Vec::new();
            let normals = surface.vertex_normals(flat.positions());
            wetcloth_export::write_obj(&mut obj, &surface, flat.positions(), &normals).unwrap();
            let ratio = e.frame_bytes as f64 / obj.len() as f64;
            assert!(
                (1.0..1.6).contains(&ratio),
                "{res:?} flat: {} vs {}",
                e.frame_bytes,
                obj.len()
            );
            assert_eq!(e.frames, 6);
            assert!(e.disk_bytes >= 6 * e.frame_bytes + 6 * CSV_ROW_BYTES);
            assert!((e.steps as f64 - 0.05 / c.simulation.time_step).abs() <= 1.0);
        }
    }

    #[test]
    fn a_run_that_does_not_fit_is_refused_naming_the_flag() {
        let c = cloth([200, 200], 0.001, 0.001, true);
        let e = estimate(&c, 2);
        assert!(e.candidates > 200 * 200 * 1000, "{e:?}");
        let why = refusal(
            &e,
            Available {
                memory: Some(8 << 30),
                disk: None,
            },
            &c,
        )
        .unwrap();
        assert!(
            why.contains("of memory") && why.contains("--force"),
            "{why}"
        );
        assert!(why.contains("self_collision = false"), "{why}");
        let small = cloth([20, 20], 0.3, 0.001, true);
        let e = estimate(&small, 2);
        let why = refusal(
            &e,
            Available {
                memory: Some(8 << 30),
                disk: Some(1000),
            },
            &small,
        )
        .unwrap();
        assert!(
            why.contains("file system has 1 kB free") && why.contains("--force"),
            "{why}"
        );
        assert_eq!(refusal(&e, Available::default(), &small), None);
        assert_eq!(
            refusal(
                &e,
                Available {
                    memory: Some(8 << 30),
                    disk: Some(8 << 30)
                },
                &small
            ),
            None
        );
    }

    #[test]
    fn the_documented_maximum_cloth_is_large() {
        let mut c = SimConfig::default();
        c.cloth.resolution = [4096, 4096];
        let e = estimate(&c, 2);
        assert!(e.is_large());
        assert!(e.memory_bytes > 3_600_000_000, "{e:?}");
        assert!(e.disk_bytes > 100 * e.frame_bytes);
    }

    #[test]
    fn people_read_sizes_and_durations() {
        assert_eq!(bytes(412_000_000_000), "412.0 GB");
        assert_eq!(bytes(3_100_000), "3.1 MB");
        assert_eq!(bytes(819_500), "820 kB");
        assert_eq!(duration(40.2), "40 s");
        assert_eq!(duration(720.0), "12 min");
        assert_eq!(duration(3.5 * 3600.0), "3.5 h");
        assert_eq!(duration(3.0 * 86400.0), "3.0 days");
        assert_eq!(length(0.00075), "0.75 mm");
        assert_eq!(length(0.3 / 4095.0), "0.0733 mm");
        assert_eq!(length(0.003), "3 mm");
        assert_eq!(length(1.25), "1.25 m");
        assert_eq!(length(0.0), "0 mm");
    }
}
