//! The USD binary encoding (`.usdc`, the "crate" file, version 0.8.0), written as frames arrive.
//!
//! A crate file is a header, then values, then six tables that say which prim and attribute
//! ("spec") has which fields, then a table of contents:
//!
//! | part | contents |
//! |---|---|
//! | header, 88 bytes | `PXR-USDC`, version bytes 0 8 0 0 0 0 0 0, u64 offset of the table of contents, 64 zero bytes |
//! | values | whatever does not fit in 48 bits of a [`Rep`]: arrays as u64 count + elements, doubles, time samples |
//! | `TOKENS` | u64 count, u64 byte size, compressed block: every token, each ending in a zero byte |
//! | `STRINGS` | u64 count, u32 token index per string |
//! | `FIELDS` | u64 count, compressed ints: token index of each field's name; compressed block: its [`Rep`] |
//! | `FIELDSETS` | u64 count, compressed ints: field indices, each spec's list ended by `u32::MAX` |
//! | `PATHS` | u64 count twice, compressed ints: path index, element token (negative for a property), jump, for every path in depth-first order |
//! | `SPECS` | u64 count, compressed ints: path index, fieldset index, spec type |
//! | table of contents | u64 count, per section: 16-byte name, u64 start, u64 size |
//!
//! All little-endian. "Compressed" is an LZ4 block behind a zero byte (one chunk); this writer
//! stores every block as literals, which any LZ4 decoder reads. "Compressed ints" are deltas
//! with 2-bit width codes, then such a block. Neither needs to be small: the file is dominated
//! by the per-frame arrays, stored raw.
//!
//! Each frame's `points`, `normals` and `extent` arrays are written as the frame arrives; only
//! their offsets are kept, and the time samples that point to them are written at the end.

use super::{Attr, Data, Prim, Stage, Stream, Value, build_stage};
use crate::cache::{CacheSpec, CacheWriter, Frame, check_complete, check_frame};
use std::collections::HashMap;
use std::io::{self, Seek, SeekFrom, Write};

/// The crate version written: 0.8.0 (64-bit array sizes, compressed tables), read by every USD
/// release since 2019.
const VERSION: [u8; 3] = [0, 8, 0];
/// Size of the header.
const HEADER_BYTES: u64 = 88;

/// Value types of the crate format (the subset used here).
mod ty {
    pub const BOOL: u64 = 1;
    pub const INT: u64 = 3;
    pub const DOUBLE: u64 = 9;
    pub const STRING: u64 = 10;
    pub const TOKEN: u64 = 11;
    pub const VEC2D: u64 = 19;
    pub const VEC2F: u64 = 20;
    pub const VEC2I: u64 = 22;
    pub const VEC3D: u64 = 23;
    pub const VEC3F: u64 = 24;
    pub const VEC3I: u64 = 26;
    pub const VEC4D: u64 = 27;
    pub const VEC4I: u64 = 30;
    pub const TOKEN_VECTOR: u64 = 41;
    pub const SPECIFIER: u64 = 42;
    pub const VARIABILITY: u64 = 44;
    pub const TIME_SAMPLES: u64 = 46;
    pub const DOUBLE_VECTOR: u64 = 48;
}

/// Spec types.
const SPEC_ATTRIBUTE: i32 = 1;
const SPEC_PRIM: i32 = 6;
const SPEC_PSEUDO_ROOT: i32 = 7;

/// A value representation: bit 63 array, bit 62 inlined, bits 48..56 type, bits 0..48 the
/// value itself (inlined) or its offset in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Rep(u64);

impl Rep {
    fn inline(ty: u64, payload: u64) -> Self {
        Rep(1 << 62 | ty << 48 | (payload & 0xffff_ffff_ffff))
    }

    fn at(ty: u64, offset: u64) -> Self {
        Rep(ty << 48 | offset)
    }

    fn array_at(ty: u64, offset: u64) -> Self {
        Rep(1 << 63 | ty << 48 | offset)
    }
}

/// Writes a run as a `.usdc` stage to `W`, frame by frame. `W` must start empty at offset 0;
/// the header is written last, over the placeholder written first.
pub struct UsdcWriter<W: Write + Seek> {
    w: W,
    /// Bytes written so far (the current offset).
    pos: u64,
    stage: Stage,
    streams: Vec<Stream>,
    /// Offsets of each frame's array, per stream.
    offsets: Vec<Vec<u64>>,
    vertices: usize,
    frames: u64,
    fed: u64,
    buf: Vec<u8>,
}

impl<W: Write + Seek> UsdcWriter<W> {
    /// Writes the placeholder header.
    ///
    /// # Errors
    ///
    /// I/O errors.
    pub fn new(mut w: W, spec: &CacheSpec<'_>) -> io::Result<Self> {
        w.write_all(&[0; HEADER_BYTES as usize])?;
        let stage = build_stage(spec);
        let mut streams = Vec::new();
        collect_streams(&stage.root, &mut streams);
        Ok(Self {
            w,
            pos: HEADER_BYTES,
            offsets: vec![Vec::with_capacity(spec.frames as usize); streams.len()],
            streams,
            stage,
            vertices: spec.vertices(),
            frames: spec.frames,
            fed: 0,
            buf: Vec::new(),
        })
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.w
    }

    fn put(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.w.write_all(bytes)?;
        self.pos += bytes.len() as u64;
        Ok(())
    }

    fn put_u64(&mut self, v: u64) -> io::Result<()> {
        self.put(&v.to_le_bytes())
    }

    /// Writes `v` (u64 count + elements) and returns its offset.
    fn put_float3s(&mut self, v: &[[f32; 3]]) -> io::Result<u64> {
        let at = self.pos;
        self.buf.clear();
        self.buf.extend_from_slice(&(v.len() as u64).to_le_bytes());
        for p in v {
            for c in p {
                self.buf.extend_from_slice(&c.to_le_bytes());
            }
        }
        let buf = std::mem::take(&mut self.buf);
        let r = self.put(&buf);
        self.buf = buf;
        r.map(|()| at)
    }

    fn write_frame_impl(&mut self, frame: &Frame<'_>) -> io::Result<()> {
        check_frame(frame, self.fed, self.vertices)?;
        for i in 0..self.streams.len() {
            let at = match self.streams[i] {
                Stream::Points => self.put_float3s(frame.positions)?,
                Stream::Normals => self.put_float3s(frame.normals)?,
                Stream::Extent => self.put_float3s(&frame.extent())?,
            };
            self.offsets[i].push(at);
        }
        self.fed += 1;
        Ok(())
    }

    fn finish_impl(&mut self) -> io::Result<()> {
        check_complete(self.fed, self.frames)?;
        let mut t = Tables::default();
        // Token 0 is never a property name: a property's element token is stored negated, and
        // -0 would read as a prim.
        t.token("");
        // The stage is not needed after this: take it rather than copy its arrays.
        let stage = std::mem::replace(
            &mut self.stage,
            Stage {
                doc: String::new(),
                frame_rate: 0.0,
                start: 0.0,
                end: 0.0,
                root: Prim::new("", ""),
            },
        );
        self.pseudo_root(&mut t, &stage)?;
        self.sections(&t)
    }

    /// The pseudo-root spec (layer metadata) and everything under it.
    fn pseudo_root(&mut self, t: &mut Tables, stage: &Stage) -> io::Result<()> {
        t.nodes.push((0, -1));
        let mut fields = Vec::new();
        for (key, _, value) in stage.metadata() {
            let rep = self.value(t, &value)?;
            fields.push((key, rep));
        }
        let children = self.token_vector(t, &[stage.root.name.as_str()])?;
        fields.push(("primChildren", children));
        t.spec(0, &fields, SPEC_PSEUDO_ROOT);
        self.prim(t, &stage.root, false)
    }

    fn prim(&mut self, t: &mut Tables, p: &Prim, has_sibling: bool) -> io::Result<()> {
        let node = t.nodes.len();
        let name = t.token(&p.name) as i32;
        t.nodes.push((name, 0));
        let mut fields = vec![
            ("specifier", Rep::inline(ty::SPECIFIER, 0)),
            (
                "typeName",
                Rep::inline(ty::TOKEN, t.token(p.type_name) as u64),
            ),
        ];
        if !p.attrs.is_empty() {
            let names: Vec<&str> = p.attrs.iter().map(|a| a.name.as_str()).collect();
            fields.push(("properties", self.token_vector(t, &names)?));
        }
        if !p.children.is_empty() {
            let names: Vec<&str> = p.children.iter().map(|c| c.name.as_str()).collect();
            fields.push(("primChildren", self.token_vector(t, &names)?));
        }
        t.spec(node, &fields, SPEC_PRIM);
        let n = p.attrs.len() + p.children.len();
        for (i, a) in p.attrs.iter().enumerate() {
            self.attr(t, a, i + 1 < n)?;
        }
        for (i, c) in p.children.iter().enumerate() {
            self.prim(t, c, p.attrs.len() + i + 1 < n)?;
        }
        t.nodes[node].1 = jump(n > 0, has_sibling, t.nodes.len() - node);
        Ok(())
    }

    fn attr(&mut self, t: &mut Tables, a: &Attr, has_sibling: bool) -> io::Result<()> {
        let node = t.nodes.len();
        let name = t.token(&a.name) as i32;
        t.nodes.push((-name, jump(false, has_sibling, 0)));
        let mut fields = vec![(
            "typeName",
            Rep::inline(ty::TOKEN, t.token(a.type_name) as u64),
        )];
        if a.custom {
            fields.push(("custom", Rep::inline(ty::BOOL, 1)));
        }
        if a.uniform {
            fields.push(("variability", Rep::inline(ty::VARIABILITY, 1)));
        }
        if let Some(interp) = a.interpolation {
            fields.push((
                "interpolation",
                Rep::inline(ty::TOKEN, t.token(interp) as u64),
            ));
        }
        match &a.data {
            Data::Default(v) => fields.push(("default", self.value(t, v)?)),
            Data::Samples(samples) => {
                let mut times = Vec::with_capacity(samples.len());
                let mut reps = Vec::with_capacity(samples.len());
                for (time, v) in samples {
                    times.push(*time);
                    reps.push(self.value(t, v)?);
                }
                fields.push(("timeSamples", self.time_samples(&times, &reps)?));
            }
            Data::Streamed(s) => {
                let i = self
                    .streams
                    .iter()
                    .position(|x| x == s)
                    .expect("streams are collected from the stage");
                let times: Vec<f64> = (0..self.frames).map(|k| k as f64).collect();
                let reps: Vec<Rep> = self.offsets[i]
                    .iter()
                    .map(|&at| Rep::array_at(ty::VEC3F, at))
                    .collect();
                fields.push(("timeSamples", self.time_samples(&times, &reps)?));
            }
        }
        t.spec(node, &fields, SPEC_ATTRIBUTE);
        Ok(())
    }

    /// Time samples: a jump to the times' rep, the times (u64 count + f64s), their rep, a jump
    /// to the values, u64 count, one rep per value.
    fn time_samples(&mut self, times: &[f64], reps: &[Rep]) -> io::Result<Rep> {
        let at = self.pos;
        let times_bytes = 8 + 8 * times.len() as u64;
        self.put(&(8 + times_bytes as i64).to_le_bytes())?;
        let times_at = self.pos;
        self.put_u64(times.len() as u64)?;
        let mut b = Vec::with_capacity(8 * times.len());
        for t in times {
            b.extend_from_slice(&t.to_le_bytes());
        }
        self.put(&b)?;
        self.put_u64(Rep::at(ty::DOUBLE_VECTOR, times_at).0)?;
        self.put(&8i64.to_le_bytes())?;
        self.put_u64(reps.len() as u64)?;
        let mut b = Vec::with_capacity(8 * reps.len());
        for r in reps {
            b.extend_from_slice(&r.0.to_le_bytes());
        }
        self.put(&b)?;
        Ok(Rep::at(ty::TIME_SAMPLES, at))
    }

    fn token_vector(&mut self, t: &mut Tables, names: &[&str]) -> io::Result<Rep> {
        let at = self.pos;
        let mut b = (names.len() as u64).to_le_bytes().to_vec();
        for n in names {
            b.extend_from_slice(&t.token(n).to_le_bytes());
        }
        self.put(&b)?;
        Ok(Rep::at(ty::TOKEN_VECTOR, at))
    }

    /// Encodes `v`: inline when it fits, else written here.
    fn value(&mut self, t: &mut Tables, v: &Value) -> io::Result<Rep> {
        let at = self.pos;
        let mut b = Vec::new();
        let array = |b: &mut Vec<u8>, n: usize| b.extend_from_slice(&(n as u64).to_le_bytes());
        let rep = match v {
            Value::Bool(x) => return Ok(Rep::inline(ty::BOOL, *x as u64)),
            Value::Int(i) => return Ok(Rep::inline(ty::INT, *i as u32 as u64)),
            Value::String(s) => return Ok(Rep::inline(ty::STRING, t.string(s) as u64)),
            Value::Token(s) => return Ok(Rep::inline(ty::TOKEN, t.token(s) as u64)),
            Value::Double(d) => {
                b.extend_from_slice(&d.to_le_bytes());
                Rep::at(ty::DOUBLE, at)
            }
            Value::IntTuple(v) => {
                v.iter().for_each(|i| b.extend_from_slice(&i.to_le_bytes()));
                let ty = [ty::VEC2I, ty::VEC3I, ty::VEC4I][v.len().clamp(2, 4) - 2];
                Rep::at(ty, at)
            }
            Value::DoubleTuple(v) => {
                v.iter().for_each(|d| b.extend_from_slice(&d.to_le_bytes()));
                let ty = [ty::VEC2D, ty::VEC3D, ty::VEC4D][v.len().clamp(2, 4) - 2];
                Rep::at(ty, at)
            }
            Value::Ints(v) => {
                array(&mut b, v.len());
                v.iter().for_each(|i| b.extend_from_slice(&i.to_le_bytes()));
                Rep::array_at(ty::INT, at)
            }
            Value::Doubles(v) => {
                array(&mut b, v.len());
                v.iter().for_each(|d| b.extend_from_slice(&d.to_le_bytes()));
                Rep::array_at(ty::DOUBLE, at)
            }
            Value::Tokens(v) => {
                array(&mut b, v.len());
                for s in v {
                    b.extend_from_slice(&t.token(s).to_le_bytes());
                }
                Rep::array_at(ty::TOKEN, at)
            }
            Value::Float2s(v) => {
                array(&mut b, v.len());
                v.iter()
                    .flatten()
                    .for_each(|f| b.extend_from_slice(&f.to_le_bytes()));
                Rep::array_at(ty::VEC2F, at)
            }
            Value::Float3s(v) => {
                array(&mut b, v.len());
                v.iter()
                    .flatten()
                    .for_each(|f| b.extend_from_slice(&f.to_le_bytes()));
                Rep::array_at(ty::VEC3F, at)
            }
        };
        self.put(&b)?;
        Ok(rep)
    }

    /// Writes the six tables, the table of contents and the header.
    fn sections(&mut self, t: &Tables) -> io::Result<()> {
        let mut toc: Vec<(&str, u64, u64)> = Vec::new();

        let start = self.pos;
        let mut chars = Vec::new();
        for tok in &t.tokens {
            chars.extend_from_slice(tok.as_bytes());
            chars.push(0);
        }
        self.put_u64(t.tokens.len() as u64)?;
        self.put_u64(chars.len() as u64)?;
        self.put_block(&chars)?;
        toc.push(("TOKENS", start, self.pos - start));

        let start = self.pos;
        self.put_u64(t.strings.len() as u64)?;
        let b: Vec<u8> = t.strings.iter().flat_map(|s| s.to_le_bytes()).collect();
        self.put(&b)?;
        toc.push(("STRINGS", start, self.pos - start));

        let start = self.pos;
        self.put_u64(t.fields.len() as u64)?;
        let names: Vec<i32> = t.fields.iter().map(|f| f.0 as i32).collect();
        self.put_ints(&names)?;
        let reps: Vec<u8> = t.fields.iter().flat_map(|f| f.1.0.to_le_bytes()).collect();
        self.put_block(&reps)?;
        toc.push(("FIELDS", start, self.pos - start));

        let start = self.pos;
        self.put_u64(t.fieldsets.len() as u64)?;
        let sets: Vec<i32> = t.fieldsets.iter().map(|&f| f as i32).collect();
        self.put_ints(&sets)?;
        toc.push(("FIELDSETS", start, self.pos - start));

        let start = self.pos;
        let n = t.nodes.len();
        self.put_u64(n as u64)?;
        self.put_u64(n as u64)?;
        self.put_ints(&(0..n as i32).collect::<Vec<_>>())?;
        self.put_ints(&t.nodes.iter().map(|x| x.0).collect::<Vec<_>>())?;
        self.put_ints(&t.nodes.iter().map(|x| x.1).collect::<Vec<_>>())?;
        toc.push(("PATHS", start, self.pos - start));

        let start = self.pos;
        self.put_u64(t.specs.len() as u64)?;
        for k in 0..3 {
            self.put_ints(&t.specs.iter().map(|s| s[k]).collect::<Vec<_>>())?;
        }
        toc.push(("SPECS", start, self.pos - start));

        let toc_at = self.pos;
        self.put_u64(toc.len() as u64)?;
        for (name, start, size) in toc {
            let mut n = [0u8; 16];
            n[..name.len()].copy_from_slice(name.as_bytes());
            self.put(&n)?;
            self.put_u64(start)?;
            self.put_u64(size)?;
        }

        let mut header = Vec::with_capacity(HEADER_BYTES as usize);
        header.extend_from_slice(b"PXR-USDC");
        header.extend_from_slice(&VERSION);
        header.extend_from_slice(&[0; 5]);
        header.extend_from_slice(&toc_at.to_le_bytes());
        header.resize(HEADER_BYTES as usize, 0);
        self.w.seek(SeekFrom::Start(0))?;
        self.w.write_all(&header)?;
        self.w.seek(SeekFrom::Start(self.pos))?;
        self.w.flush()
    }

    /// A compressed block: u64 size, then [`lz4_literals`] of `data`.
    fn put_block(&mut self, data: &[u8]) -> io::Result<()> {
        let block = lz4_literals(data);
        self.put_u64(block.len() as u64)?;
        self.put(&block)
    }

    /// Compressed ints: [`encode_ints`], then a block.
    fn put_ints(&mut self, v: &[i32]) -> io::Result<()> {
        self.put_block(&encode_ints(v))
    }
}

impl<W: Write + Seek> CacheWriter for UsdcWriter<W> {
    fn write_frame(&mut self, frame: &Frame<'_>) -> io::Result<()> {
        self.write_frame_impl(frame)
    }

    fn finish(mut self: Box<Self>) -> io::Result<()> {
        self.finish_impl()
    }
}

/// The streamed attributes of the stage, in depth-first order.
fn collect_streams(p: &Prim, out: &mut Vec<Stream>) {
    for a in &p.attrs {
        if let Data::Streamed(s) = a.data {
            out.push(s);
        }
    }
    for c in &p.children {
        collect_streams(c, out);
    }
}

/// The jump of a path node in depth-first order: -2 a leaf with no next sibling, -1 a node whose
/// only follower is its first child, 0 a leaf followed by its sibling, and otherwise the
/// distance to the next sibling (`subtree` nodes on), its first child following it.
fn jump(has_child: bool, has_sibling: bool, subtree: usize) -> i32 {
    match (has_child, has_sibling) {
        (false, false) => -2,
        (true, false) => -1,
        (false, true) => 0,
        (true, true) => subtree as i32,
    }
}

/// The interned tables of a crate file.
#[derive(Default)]
struct Tables {
    tokens: Vec<String>,
    token_index: HashMap<String, u32>,
    /// Token index of each string.
    strings: Vec<u32>,
    string_index: HashMap<u32, u32>,
    /// (token index of the name, value).
    fields: Vec<(u32, Rep)>,
    /// Field indices, each spec's run ended by `u32::MAX`.
    fieldsets: Vec<u32>,
    /// Path nodes in depth-first order: (element token, negated for a property; jump).
    nodes: Vec<(i32, i32)>,
    /// (path index, fieldset index, spec type).
    specs: Vec<[i32; 3]>,
}

impl Tables {
    fn token(&mut self, s: &str) -> u32 {
        if let Some(&i) = self.token_index.get(s) {
            return i;
        }
        let i = self.tokens.len() as u32;
        self.tokens.push(s.to_string());
        self.token_index.insert(s.to_string(), i);
        i
    }

    fn string(&mut self, s: &str) -> u32 {
        let tok = self.token(s);
        let next = self.strings.len() as u32;
        let i = *self.string_index.entry(tok).or_insert(next);
        if i == next {
            self.strings.push(tok);
        }
        i
    }

    fn spec(&mut self, node: usize, fields: &[(&str, Rep)], spec_type: i32) {
        let set = self.fieldsets.len() as i32;
        for (name, rep) in fields {
            let name = self.token(name);
            self.fieldsets.push(self.fields.len() as u32);
            self.fields.push((name, *rep));
        }
        self.fieldsets.push(u32::MAX);
        self.specs.push([node as i32, set, spec_type]);
    }
}

/// USD's integer coding for 32-bit ints: an i32 "common" delta, then 2 bits per value (0: the
/// common delta, 3: a full i32 delta follows; 1 and 2, for i8 and i16 deltas, are not used
/// here), then the deltas from the previous value (from 0 for the first).
fn encode_ints(v: &[i32]) -> Vec<u8> {
    let common = 1i32;
    let mut codes = vec![0u8; (2 * v.len()).div_ceil(8)];
    let mut deltas = Vec::with_capacity(4 * v.len());
    let mut prev = 0i32;
    for (i, &x) in v.iter().enumerate() {
        let d = x.wrapping_sub(prev);
        prev = x;
        if d != common {
            codes[i / 4] |= 3 << (2 * (i % 4));
            deltas.extend_from_slice(&d.to_le_bytes());
        }
    }
    let mut out = common.to_le_bytes().to_vec();
    out.extend_from_slice(&codes);
    out.extend_from_slice(&deltas);
    out
}

/// `data` as one LZ4 block of literals behind the chunk-count byte 0: a token byte whose high
/// nibble is the literal length (15 meaning more length bytes follow: 255s, then the rest),
/// then the bytes themselves. A valid LZ4 block (one final sequence with no match).
fn lz4_literals(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len() + data.len() / 255 + 3);
    out.push(0);
    let n = data.len();
    if n < 15 {
        out.push((n as u8) << 4);
    } else {
        out.push(0xf0);
        let mut rest = n - 15;
        while rest >= 255 {
            out.push(255);
            rest -= 255;
        }
        out.push(rest as u8);
    }
    out.extend_from_slice(data);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ints_code_deltas_with_full_width_codes_except_the_common_one() {
        // 5, 6, 7, 1: deltas 5, 1, 1, -6; codes 3, 0, 0, 3 -> 0b11_00_00_11.
        let b = encode_ints(&[5, 6, 7, 1]);
        let mut want = 1i32.to_le_bytes().to_vec();
        want.push(0b1100_0011);
        want.extend_from_slice(&5i32.to_le_bytes());
        want.extend_from_slice(&(-6i32).to_le_bytes());
        assert_eq!(b, want);
    }

    #[test]
    fn lz4_literal_blocks_encode_their_length() {
        assert_eq!(lz4_literals(b"abc"), [0, 0x30, b'a', b'b', b'c']);
        let long = vec![7u8; 15 + 255 + 4];
        let b = lz4_literals(&long);
        assert_eq!(b[..4], [0, 0xf0, 255, 4]);
        assert_eq!(b.len(), 4 + long.len());
        let b = lz4_literals(&[1; 15]);
        assert_eq!(b[..3], [0, 0xf0, 0]);
    }

    /// The file's frame: header, table of contents, tokens, and each frame's points where the
    /// time samples say. (USD itself reads these files in the `wetcloth-cli` export tests.)
    #[test]
    fn header_toc_and_frame_arrays_are_where_they_are_said_to_be() {
        use crate::RunInfo;
        use std::io::Cursor;
        let mut cfg = wetcloth::SimConfig::default();
        cfg.cloth.resolution = [2, 2];
        let run = RunInfo::new("t", &cfg, 2, true);
        let spec = CacheSpec {
            run: &run,
            frames: 2,
            surface: &wetcloth::ClothSurface::new(&cfg.cloth),
            params: &[],
        };
        let mut w = UsdcWriter::new(Cursor::new(Vec::new()), &spec).unwrap();
        let frames: Vec<Vec<[f32; 3]>> = (0..2)
            .map(|k| (0..4).map(|v| [v as f32, k as f32, -1.5]).collect())
            .collect();
        for (k, p) in frames.iter().enumerate() {
            w.write_frame_impl(&Frame {
                index: k as u64,
                positions: p,
                normals: p,
            })
            .unwrap();
        }
        let offsets = w.offsets.clone();
        w.finish_impl().unwrap();
        let b = w.into_inner().into_inner();
        let u64_at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap());
        assert_eq!(&b[..8], b"PXR-USDC");
        assert_eq!(b[8..16], [0, 8, 0, 0, 0, 0, 0, 0]);
        let toc = u64_at(16) as usize;
        assert!(b[24..88].iter().all(|&x| x == 0));
        assert_eq!(u64_at(toc), 6);
        let mut end = 0;
        for (i, name) in ["TOKENS", "STRINGS", "FIELDS", "FIELDSETS", "PATHS", "SPECS"]
            .iter()
            .enumerate()
        {
            let at = toc + 8 + 32 * i;
            assert_eq!(&b[at..at + name.len()], name.as_bytes());
            assert!(b[at + name.len()..at + 16].iter().all(|&x| x == 0));
            let (start, size) = (u64_at(at + 16) as usize, u64_at(at + 24) as usize);
            assert!(
                i == 0 || start == end,
                "{name} follows the previous section"
            );
            end = start + size;
        }
        assert_eq!(end, toc, "the table of contents follows the last section");
        // Tokens: count, byte size, then a literal LZ4 block of zero-terminated names.
        let tokens_at = u64_at(toc + 8 + 16) as usize;
        let chars = u64_at(tokens_at + 8) as usize;
        let block = &b[tokens_at + 24..];
        assert_eq!(
            (block[0], block[1]),
            (0, 0xf0),
            "one chunk, over 15 literals"
        );
        let mut at = 2;
        let mut len = 15;
        while block[at] == 255 {
            len += 255;
            at += 1;
        }
        len += block[at] as usize;
        assert_eq!(len, chars);
        let text = &block[at + 1..at + 1 + chars];
        assert_eq!(text[0], 0, "token 0 is empty");
        for name in ["cloth", "points", "normals", "faceVertexIndices", "upAxis"] {
            let t = format!("\0{name}\0");
            assert!(
                text.windows(t.len()).any(|w| w == t.as_bytes()),
                "token {name}"
            );
        }
        // Each frame's points: u64 count 4, then the f32 triples.
        for (k, p) in frames.iter().enumerate() {
            let at = offsets[0][k] as usize;
            assert_eq!(u64_at(at), 4);
            let got: Vec<f32> = (0..12)
                .map(|i| f32::from_le_bytes(b[at + 8 + 4 * i..at + 12 + 4 * i].try_into().unwrap()))
                .collect();
            assert_eq!(got, p.concat());
        }
    }

    #[test]
    fn jumps_follow_the_depth_first_layout() {
        // / -> a -> (x, b -> (y)); a has children and no sibling.
        assert_eq!(jump(true, false, 4), -1);
        assert_eq!(jump(false, true, 1), 0);
        assert_eq!(jump(true, true, 3), 3);
        assert_eq!(jump(false, false, 1), -2);
    }
}
