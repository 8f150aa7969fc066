//! MurmurHash3 x64 128 (Austin Appleby's public-domain hash), seed 0, fed in pieces.
//!
//! Alembic keys every sample by this hash of its bytes (little-endian, as written): the 16-byte
//! key in front of each sample is `h1` then `h2`, each as little-endian bytes. Fed in pieces so
//! that a frame of positions is hashed as it is converted, without a copy of its bytes.

const C1: u64 = 0x87c3_7b91_1142_53d5;
const C2: u64 = 0x4cf5_ad43_2745_937f;

/// A 128-bit MurmurHash3 (x64 variant) being computed.
#[derive(Clone, Debug, Default)]
pub(crate) struct Murmur3 {
    h1: u64,
    h2: u64,
    /// Bytes fed but not yet mixed in (fewer than 16).
    tail: [u8; 16],
    tail_len: usize,
    len: u64,
}

fn fmix(mut k: u64) -> u64 {
    k ^= k >> 33;
    k = k.wrapping_mul(0xff51_afd7_ed55_8ccd);
    k ^= k >> 33;
    k = k.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    k ^ (k >> 33)
}

fn mix_k1(k1: u64) -> u64 {
    k1.wrapping_mul(C1).rotate_left(31).wrapping_mul(C2)
}

fn mix_k2(k2: u64) -> u64 {
    k2.wrapping_mul(C2).rotate_left(33).wrapping_mul(C1)
}

impl Murmur3 {
    /// A hash of nothing yet (seed 0).
    pub fn new() -> Self {
        Self::default()
    }

    fn block(&mut self, b: &[u8; 16]) {
        let (lo, hi) = b.split_at(8);
        let k1 = u64::from_le_bytes(lo.try_into().expect("8 bytes"));
        let k2 = u64::from_le_bytes(hi.try_into().expect("8 bytes"));
        self.h1 ^= mix_k1(k1);
        self.h1 = self
            .h1
            .rotate_left(27)
            .wrapping_add(self.h2)
            .wrapping_mul(5)
            .wrapping_add(0x52dc_e729);
        self.h2 ^= mix_k2(k2);
        self.h2 = self
            .h2
            .rotate_left(31)
            .wrapping_add(self.h1)
            .wrapping_mul(5)
            .wrapping_add(0x3849_5ab5);
    }

    /// Feeds `bytes`.
    pub fn update(&mut self, mut bytes: &[u8]) {
        self.len += bytes.len() as u64;
        if self.tail_len > 0 {
            let take = (16 - self.tail_len).min(bytes.len());
            self.tail[self.tail_len..self.tail_len + take].copy_from_slice(&bytes[..take]);
            self.tail_len += take;
            bytes = &bytes[take..];
            if self.tail_len < 16 {
                return;
            }
            let b = self.tail;
            self.block(&b);
            self.tail_len = 0;
        }
        let mut blocks = bytes.chunks_exact(16);
        for b in &mut blocks {
            self.block(b.try_into().expect("16 bytes"));
        }
        let rest = blocks.remainder();
        self.tail[..rest.len()].copy_from_slice(rest);
        self.tail_len = rest.len();
    }

    /// The hash of everything fed: `h1` and `h2` as 16 little-endian bytes, as Alembic writes
    /// a sample's key.
    pub fn finish(&self) -> [u8; 16] {
        let (mut h1, mut h2) = (self.h1, self.h2);
        let t = &self.tail[..self.tail_len];
        let word = |bytes: &[u8]| {
            bytes
                .iter()
                .enumerate()
                .fold(0u64, |k, (i, &b)| k ^ (u64::from(b) << (8 * i)))
        };
        if t.len() > 8 {
            h2 ^= mix_k2(word(&t[8..]));
        }
        if !t.is_empty() {
            h1 ^= mix_k1(word(&t[..t.len().min(8)]));
        }
        h1 ^= self.len;
        h2 ^= self.len;
        h1 = h1.wrapping_add(h2);
        h2 = h2.wrapping_add(h1);
        h1 = fmix(h1);
        h2 = fmix(h2);
        h1 = h1.wrapping_add(h2);
        h2 = h2.wrapping_add(h1);
        let mut out = [0u8; 16];
        out[..8].copy_from_slice(&h1.to_le_bytes());
        out[8..].copy_from_slice(&h2.to_le_bytes());
        out
    }
}

/// The key of `bytes` (see [`Murmur3::finish`]).
pub(crate) fn key(bytes: &[u8]) -> [u8; 16] {
    let mut h = Murmur3::new();
    h.update(bytes);
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hex(k: &[u8; 16]) -> String {
        k.iter().map(|b| format!("{b:02x}")).collect()
    }

    /// The key the reference library writes in front of the sample P = float32 (i, 0, j),
    /// j in 0..3 outer and i in 0..3 inner (27 floats, 108 bytes little-endian).
    #[test]
    fn the_reference_librarys_key_of_a_3_by_3_grid_of_points() {
        let mut bytes = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                for c in [i as f32, 0.0, j as f32] {
                    bytes.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        assert_eq!(bytes.len(), 108);
        assert_eq!(hex(&key(&bytes)), "b70069db92a0e481e40f196b538b3467");
    }

    /// Keys the reference library wrote (read back from a file it wrote): the string sample
    /// `pinch` (hashed with its terminating zero byte) and the float64 sample 0.02.
    #[test]
    fn keys_the_reference_library_wrote() {
        assert_eq!(hex(&key(b"pinch\0")), "bf90bc63123596a0d62da03b6d1b53e7");
        assert_eq!(
            hex(&key(&0.02f64.to_le_bytes())),
            "af47c91c5105d7c82e2a81ae421390c2"
        );
        assert_eq!(hex(&key(b"")), "00000000000000000000000000000000");
    }

    /// Feeding in pieces of any size gives the hash of the whole.
    #[test]
    fn pieces_hash_as_the_whole() {
        let data: Vec<u8> = (0..200u32).map(|i| (i * 37 % 251) as u8).collect();
        let whole = key(&data);
        for piece in [1, 3, 7, 15, 16, 17, 33] {
            let mut h = Murmur3::new();
            for c in data.chunks(piece) {
                h.update(c);
            }
            assert_eq!(h.finish(), whole, "pieces of {piece}");
        }
    }
}
