//! `checkpoint.bin`: where a run can continue from (`wetcloth run --resume DIR`).
//!
//! The file holds the simulation's [`wetcloth::Checkpoint`] (everything a step carries to the
//! next) and how far the run's files had got when it was taken: the frames written, the time
//! of the last, and the byte length of each file the run appends to (`metrics.csv`), so that a
//! resumed run cuts off whatever a killed run wrote after the checkpoint and writes it again.
//!
//! Layout (all integers little-endian):
//!
//! | bytes | contents |
//! |---|---|
//! | 8 | magic `WCLOTHCK` |
//! | 4 | file format version ([`FORMAT`]) |
//! | 4 | the core's checkpoint version ([`wetcloth::CHECKPOINT_VERSION`]) |
//! | 8 | payload length in bytes |
//! | 4 | CRC-32 (IEEE) of the payload |
//! | rest | payload: [`Saved`] in postcard (floats as their exact 8 bytes) |
//!
//! The file is written to `checkpoint.bin.part` and renamed, so it is always whole: the last
//! checkpoint survives a kill at any moment. Anything that does not fit (magic, versions,
//! length, checksum, payload) is reported as a damaged checkpoint naming the file.

use crate::error::CliError;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use wetcloth::{CHECKPOINT_VERSION, Checkpoint, Real};

/// The file's name in the run folder.
pub const FILE_NAME: &str = "checkpoint.bin";

/// Version of the file layout.
pub const FORMAT: u32 = 2;

const MAGIC: &[u8; 8] = b"WCLOTHCK";
const HEADER: usize = 8 + 4 + 4 + 8 + 4;

/// What a checkpoint file holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Saved {
    /// FNV-1a digest of the run's `scene.toml`: a resumed run refuses a changed scene.
    pub scene_digest: u64,
    /// Frames between periodic checkpoints (`--checkpoint-every`), kept by a resumed run so
    /// that its `run.json` and checkpoints are those of the run it continues.
    pub every: u64,
    /// Frames written when it was taken: the next frame to write.
    pub frames: u64,
    /// Simulated time of the last frame written, s.
    pub frame_time: Real,
    /// Byte length of each file the run appends to (name in the run folder, length).
    pub appended: Vec<(String, u64)>,
    /// The files the run read besides its scene, each with the digest of what it read: every
    /// mesh collider's file with [`wetcloth::collide::Mesh::digest`] (its vertices and
    /// triangles as read). A resumed run refuses inputs that changed.
    pub inputs: Vec<(String, u64)>,
    /// The simulation.
    pub sim: Checkpoint,
}

/// FNV-1a (64 bit) of `bytes`.
pub fn digest(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The files `config` was read from besides its scene, with the digests of their contents
/// (see [`Saved::inputs`]), in scene order.
pub fn inputs(config: &wetcloth::SimConfig) -> Vec<(String, u64)> {
    config
        .colliders
        .iter()
        .filter_map(|c| match &c.shape {
            wetcloth::Shape::Mesh(m) => Some((m.file.clone(), m.digest())),
            _ => None,
        })
        .collect()
}

/// The file's path in `dir`.
pub fn path(dir: &Path) -> PathBuf {
    dir.join(FILE_NAME)
}

/// The bytes of a checkpoint file holding `saved`.
pub fn encode(saved: &Saved) -> Vec<u8> {
    let payload = postcard::to_allocvec(saved).expect("in-memory serialisation cannot fail");
    let mut out = Vec::with_capacity(HEADER + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT.to_le_bytes());
    out.extend_from_slice(&CHECKPOINT_VERSION.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&payload).to_le_bytes());
    out.extend_from_slice(&payload);
    out
}

/// Reads the bytes of a checkpoint file; the error says what does not fit.
pub fn decode(bytes: &[u8]) -> Result<Saved, String> {
    if bytes.len() < HEADER {
        return Err(format!(
            "{} bytes, shorter than the {HEADER}-byte header",
            bytes.len()
        ));
    }
    if &bytes[..8] != MAGIC {
        return Err("not a wetcloth checkpoint (wrong magic bytes)".into());
    }
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let (format, version) = (u32_at(8), u32_at(12));
    if format != FORMAT {
        return Err(format!(
            "file format version {format}, this build reads version {FORMAT}"
        ));
    }
    if version != CHECKPOINT_VERSION {
        return Err(format!(
            "simulation checkpoint version {version}, this build reads version \
             {CHECKPOINT_VERSION}"
        ));
    }
    let length = u64::from_le_bytes(bytes[16..24].try_into().expect("8 bytes"));
    let payload = &bytes[HEADER..];
    if length != payload.len() as u64 {
        return Err(format!(
            "the header promises {length} bytes of data, the file holds {} (truncated?)",
            payload.len()
        ));
    }
    let crc = u32_at(24);
    if crc32fast::hash(payload) != crc {
        return Err("checksum mismatch (the file was changed or damaged)".into());
    }
    postcard::from_bytes(payload).map_err(|e| format!("unreadable contents ({e})"))
}

/// Writes `saved` to `dir/checkpoint.bin`, atomically.
pub fn write(dir: &Path, saved: &Saved) -> Result<(), CliError> {
    let path = path(dir);
    let bytes = encode(saved);
    wetcloth_export::write_atomically(&path, |w| w.write_all(&bytes))
        .map_err(CliError::output(&path))
}

/// Reads `dir/checkpoint.bin`: `Ok(None)` when there is none, an input error naming the file
/// when it cannot be read or is damaged.
pub fn read(dir: &Path) -> Result<Option<Saved>, CliError> {
    let path = path(dir);
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(CliError::Input(format!(
                "cannot read {}: {e}",
                path.display()
            )));
        }
    };
    decode(&bytes).map(Some).map_err(|why| {
        CliError::Input(format!(
            "{} is damaged: {why}; nothing was changed in {} (run the scene again without \
             --resume to start over)",
            path.display(),
            dir.display()
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use wetcloth::{SimConfig, Simulation};

    fn config(pockets: bool) -> SimConfig {
        let mut cfg = SimConfig::thesis_demo();
        cfg.cloth.resolution = [6, 5];
        cfg.grabs = vec![wetcloth::GrabSpec::lift([2, 2], 0.0, 0.01, 0.01)];
        if pockets {
            cfg.air.model = wetcloth::params::AirModelKind::Pockets;
        }
        cfg
    }

    fn saved() -> Saved {
        saved_of(config(false))
    }

    fn saved_of(cfg: SimConfig) -> Saved {
        let mut sim = Simulation::new(cfg).unwrap();
        sim.advance(3).unwrap();
        Saved {
            scene_digest: 7,
            every: 10,
            frames: 2,
            frame_time: 0.5,
            appended: vec![("metrics.csv".into(), 123)],
            inputs: vec![("/scenes/plate.obj".into(), 42)],
            sim: sim.checkpoint(),
        }
    }

    #[test]
    fn a_checkpoint_file_reads_back_as_written() {
        let bytes = encode(&saved());
        let back = decode(&bytes).unwrap();
        assert_eq!(encode(&back), bytes);
        assert_eq!(back.frames, 2);
        assert_eq!(back.sim.steps(), 3);
    }

    #[test]
    fn every_damaged_byte_and_every_truncation_is_refused() {
        let bytes = encode(&saved());
        for i in 0..bytes.len() {
            let mut b = bytes.clone();
            b[i] ^= 0x5a;
            assert!(decode(&b).is_err(), "byte {i} changed, still read");
            assert!(decode(&bytes[..i]).is_err(), "cut at {i}, still read");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode(&longer).unwrap_err().contains("truncated"));
    }

    /// The header of `payload` with a correct length and checksum: damage that gets past
    /// the checksum, so that the decoder and the restore see it.
    fn resealed(payload: &[u8]) -> Vec<u8> {
        let mut out = encode(&saved())[..HEADER].to_vec();
        out[16..24].copy_from_slice(&(payload.len() as u64).to_le_bytes());
        out[24..28].copy_from_slice(&crc32fast::hash(payload).to_le_bytes());
        out.extend_from_slice(payload);
        out
    }

    /// Damaged checkpoints, the damage resealed with a right checksum (what a faulty disk
    /// or a hand edit could leave): reading, restoring and stepping never panic; the result is
    /// a refusal, a blow-up or a run.
    fn damaged_checkpoints_never_panic(cases: u32) {
        for pockets in [false, true] {
            damaged_checkpoints_of(config(pockets), cases / 2);
        }
    }

    fn damaged_checkpoints_of(cfg: SimConfig, cases: u32) {
        use proptest::prelude::*;
        use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
        let base = encode(&saved_of(cfg.clone()));
        let payload = base[HEADER..].to_vec();
        let seed: u64 = std::env::var("WETCLOTH_FUZZ_SEED")
            .ok()
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or(0xc4ec);
        let mut bytes = [0u8; 32];
        bytes[..8].copy_from_slice(&seed.to_le_bytes());
        let mut runner = TestRunner::new_with_rng(
            Config {
                cases,
                failure_persistence: None,
                ..Config::default()
            },
            TestRng::from_seed(RngAlgorithm::ChaCha, &bytes),
        );
        let n = payload.len();
        let damage = (
            prop::collection::vec((0..n, any::<u8>()), 1..6),
            prop_oneof![4 => Just(None), 1 => (0..n).prop_map(Some)],
            any::<bool>(),
        );
        let stats = std::cell::Cell::new((0u32, 0u32, 0u32));
        runner
            .run(&damage, |(edits, cut, reseal)| {
                let mut p = payload.clone();
                for (i, b) in edits {
                    p[i] = b;
                }
                if let Some(c) = cut {
                    p.truncate(c);
                }
                let file = if reseal {
                    resealed(&p)
                } else {
                    let mut f = base[..HEADER].to_vec();
                    f.extend_from_slice(&p);
                    f
                };
                let (refused, failed, ran) = stats.get();
                match decode(&file) {
                    Err(why) => {
                        prop_assert!(!why.is_empty());
                        stats.set((refused + 1, failed, ran));
                    }
                    Ok(s) => match Simulation::restore(cfg.clone(), s.sim) {
                        Err(_) => stats.set((refused + 1, failed, ran)),
                        Ok(mut sim) => match sim.advance(40) {
                            Err(_) => stats.set((refused, failed + 1, ran)),
                            Ok(()) => stats.set((refused, failed, ran + 1)),
                        },
                    },
                }
                Ok(())
            })
            .unwrap();
        let (refused, failed, ran) = stats.get();
        eprintln!(
            "damaged checkpoints ({:?} air): {cases} cases, {refused} refused, {failed} blew \
             up, {ran} ran",
            cfg.air.model
        );
    }

    #[test]
    fn damaged_checkpoints_are_refused_or_run_and_never_panic() {
        damaged_checkpoints_never_panic(
            std::env::var("WETCLOTH_FUZZ_CASES")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(300),
        );
    }

    /// The long campaign: `cargo test --release -p wetcloth-cli --bin wetcloth -- --ignored
    /// damaged_checkpoints_long` (docs/reliability.md).
    #[test]
    #[ignore]
    fn damaged_checkpoints_long_campaign() {
        damaged_checkpoints_never_panic(
            std::env::var("WETCLOTH_FUZZ_CASES")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(100_000),
        );
    }
}
