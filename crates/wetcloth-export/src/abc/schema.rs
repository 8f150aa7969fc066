//! An Alembic archive in an Ogawa file (the layout of the reference library's `AbcCoreOgawa`):
//! objects holding compound, scalar and array properties, whose samples are keyed by their
//! MurmurHash3 and written as they come.
//!
//! ```text
//! root group    [i32 file version 0] [i32 library version] [top object] [archive metadata]
//!               [time samplings] [indexed metadata]
//! object        [its properties' compound] [child object]... [child headers + 32-byte hashes]
//! compound      [property]... [property headers]        (no properties: the empty group)
//! scalar        [sample]...                             sample = 16-byte key + bytes
//! array         [sample, dimensions]...                 dimensions empty for 1-D arrays
//! ```
//!
//! A sample equal to the previous one of its property is not written again (the property
//! header's first and last changed indices say which samples are stored); a sample equal to
//! one written anywhere before refers to that block. Property headers share metadata strings
//! through the indexed metadata (up to 254 strings under 256 bytes; longer ones are inline).
//!
//! The 32-byte hashes after each object's child headers (of the properties, then of the
//! children) identify equal content; the reference library folds them with SpookyHash, this
//! writer with MurmurHash3 over the same items, which readers do not check but compare.

use super::murmur::{Murmur3, key};
use super::ogawa::{Child, OgawaWriter};
use std::collections::HashMap;
use std::io::{self, Seek, Write};

/// The library version written in the archive: that of the reference library (1.8.12) whose
/// layout this writer follows.
const LIBRARY_VERSION: i32 = 10812;

/// Plain old data types, numbered as Alembic numbers them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Pod {
    Bool = 0,
    U8 = 1,
    U32 = 5,
    I32 = 6,
    F32 = 10,
    F64 = 11,
    String = 12,
}

/// A property, by index in the archive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct PropId(usize);

/// An object, by index in the archive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct ObjId(usize);

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Compound,
    Scalar,
    Array,
}

#[derive(Debug)]
struct Prop {
    name: String,
    meta: String,
    kind: Kind,
    pod: Pod,
    extent: u8,
    time_sampling: u32,
    /// Children of a compound.
    props: Vec<PropId>,
    /// Stored samples (array: sample and dimensions, two children each).
    stored: Vec<Child>,
    samples: u32,
    first_changed: u32,
    last_changed: u32,
    /// Key and byte count of the last sample set.
    last: Option<([u8; 16], u64)>,
    /// Element count of every sample, while they agree.
    points: Option<u64>,
    homogeneous: bool,
    scalar_like: bool,
    hash: [u8; 16],
}

#[derive(Debug)]
struct Object {
    name: String,
    meta: String,
    props: Vec<PropId>,
    children: Vec<ObjId>,
}

/// The indexed metadata: strings that headers refer to by a one-byte index.
#[derive(Debug, Default)]
struct MetaMap {
    strings: Vec<String>,
    index: HashMap<String, u32>,
}

impl MetaMap {
    /// 0 for no metadata, 1 to 254 for an indexed string, 255 for one written inline.
    fn index(&mut self, s: &str) -> u32 {
        if s.is_empty() {
            return 0;
        }
        if s.len() < 256 {
            if let Some(&i) = self.index.get(s) {
                return i + 1;
            }
            if self.strings.len() < 254 {
                let i = self.strings.len() as u32;
                self.strings.push(s.to_string());
                self.index.insert(s.to_string(), i);
                return i + 1;
            }
        }
        255
    }

    fn bytes(&self) -> Vec<u8> {
        let mut b = Vec::new();
        for s in &self.strings {
            b.push(s.len() as u8);
            b.extend_from_slice(s.as_bytes());
        }
        b
    }
}

/// `v` in 1, 2 or 4 little-endian bytes as `hint` (0, 1, 2) says.
fn push_hinted(b: &mut Vec<u8>, v: u32, hint: u32) {
    let n = [1, 2, 4][hint as usize];
    b.extend_from_slice(&v.to_le_bytes()[..n]);
}

/// MurmurHash3 of the concatenated `parts`.
fn hash_of(parts: &[&[u8]]) -> [u8; 16] {
    let mut h = Murmur3::new();
    for p in parts {
        h.update(p);
    }
    h.finish()
}

/// An Alembic archive being written to `W`.
#[derive(Debug)]
pub(crate) struct Archive<W: Write + Seek> {
    o: OgawaWriter<W>,
    props: Vec<Prop>,
    objects: Vec<Object>,
    /// Uniform time samplings after the identity one (index 0): seconds per sample, start.
    samplings: Vec<(f64, f64)>,
    /// Data blocks already written, by key, byte count and whether they hold strings.
    written: HashMap<([u8; 16], u64, bool), Child>,
    metadata: String,
}

impl<W: Write + Seek> Archive<W> {
    /// Starts an archive with `metadata` (serialized `key=value;...`, keys sorted).
    pub fn new(w: W, metadata: String) -> io::Result<Self> {
        let mut o = OgawaWriter::new(w)?;
        // The two version blocks come first, as the reference library writes them.
        o.data(&[&0i32.to_le_bytes()])?;
        o.data(&[&LIBRARY_VERSION.to_le_bytes()])?;
        Ok(Self {
            o,
            props: Vec::new(),
            objects: vec![Object {
                name: "ABC".into(),
                meta: String::new(),
                props: Vec::new(),
                children: Vec::new(),
            }],
            samplings: Vec::new(),
            written: HashMap::new(),
            metadata,
        })
    }

    /// The top object (`/`).
    pub fn top(&self) -> ObjId {
        ObjId(0)
    }

    /// Adds a uniform time sampling of `seconds_per_sample` starting at `start` (s); returns
    /// its index (0 is the identity sampling, one sample at time 0).
    pub fn add_uniform_sampling(&mut self, seconds_per_sample: f64, start: f64) -> u32 {
        self.samplings.push((seconds_per_sample, start));
        self.samplings.len() as u32
    }

    /// Adds an object named `name` (no `/`) with metadata `meta` under `parent`.
    pub fn add_object(&mut self, parent: ObjId, name: &str, meta: &str) -> ObjId {
        debug_assert!(!name.is_empty() && !name.contains('/'));
        let id = ObjId(self.objects.len());
        self.objects.push(Object {
            name: name.into(),
            meta: meta.into(),
            props: Vec::new(),
            children: Vec::new(),
        });
        self.objects[parent.0].children.push(id);
        id
    }

    fn add_prop(&mut self, parent: Parent, p: Prop) -> PropId {
        let id = PropId(self.props.len());
        self.props.push(p);
        match parent {
            Parent::Object(o) => self.objects[o.0].props.push(id),
            Parent::Compound(c) => {
                debug_assert_eq!(self.props[c.0].kind, Kind::Compound);
                self.props[c.0].props.push(id)
            }
        }
        id
    }

    fn prop(name: &str, meta: &str, kind: Kind, pod: Pod, extent: u8, ts: u32) -> Prop {
        Prop {
            name: name.into(),
            meta: meta.into(),
            kind,
            pod,
            extent,
            time_sampling: ts,
            props: Vec::new(),
            stored: Vec::new(),
            samples: 0,
            first_changed: 0,
            last_changed: 0,
            last: None,
            points: None,
            homogeneous: true,
            scalar_like: true,
            hash: [0; 16],
        }
    }

    /// Adds a compound property (a schema such as `.geom`, or `.userProperties`).
    pub fn add_compound(&mut self, parent: Parent, name: &str, meta: &str) -> PropId {
        let p = Self::prop(name, meta, Kind::Compound, Pod::U8, 0, 0);
        self.add_prop(parent, p)
    }

    /// Adds a scalar property: one value of `extent` `pod`s per sample.
    pub fn add_scalar(
        &mut self,
        parent: Parent,
        name: &str,
        meta: &str,
        pod: Pod,
        extent: u8,
        ts: u32,
    ) -> PropId {
        let p = Self::prop(name, meta, Kind::Scalar, pod, extent, ts);
        self.add_prop(parent, p)
    }

    /// Adds an array property: a 1-D array of elements of `extent` `pod`s per sample.
    pub fn add_array(
        &mut self,
        parent: Parent,
        name: &str,
        meta: &str,
        pod: Pod,
        extent: u8,
        ts: u32,
    ) -> PropId {
        let p = Self::prop(name, meta, Kind::Array, pod, extent, ts);
        self.add_prop(parent, p)
    }

    /// Sets the next sample of `id` to `bytes`, holding `points` elements.
    pub fn set(&mut self, id: PropId, bytes: &[u8], points: u64) -> io::Result<()> {
        let k = key(bytes);
        self.set_with(id, k, bytes.len() as u64, points, |o| o.write_raw(bytes))
    }

    /// Sets the next sample of `id` to `values` as little-endian bytes (`f32`, `i32`...),
    /// `extent` values per element.
    pub fn set_values<T: Copy, const N: usize>(
        &mut self,
        id: PropId,
        values: &[T],
        extent: usize,
        to_le: impl Fn(T) -> [u8; N],
    ) -> io::Result<()> {
        let mut buf = Vec::with_capacity(N * values.len());
        for &v in values {
            buf.extend_from_slice(&to_le(v));
        }
        self.set(id, &buf, (values.len() / extent.max(1)) as u64)
    }

    /// Sets the next sample of a string scalar `id` to `s` (stored with a terminating zero
    /// byte; a zero byte inside `s` is replaced by U+FFFD).
    pub fn set_string(&mut self, id: PropId, s: &str) -> io::Result<()> {
        let mut b = s.replace('\0', "\u{fffd}").into_bytes();
        b.push(0);
        self.set(id, &b, 1)
    }

    /// Sets the next sample of `id`: `nbytes` bytes (`points` elements) with key `k`, which
    /// `write` puts in the file (exactly `nbytes` bytes through `write_raw`) if the sample
    /// must be stored.
    pub fn set_with(
        &mut self,
        id: PropId,
        k: [u8; 16],
        nbytes: u64,
        points: u64,
        write: impl FnOnce(&mut OgawaWriter<W>) -> io::Result<()>,
    ) -> io::Result<()> {
        let p = &self.props[id.0];
        debug_assert_ne!(p.kind, Kind::Compound);
        let is_string = p.pod == Pod::String;
        if p.samples > 0 && p.last == Some((k, nbytes)) {
            return self.repeat(id);
        }
        let data = match self.written.get(&(k, nbytes, is_string)) {
            Some(&c) => c,
            None if nbytes == 0 => Child::EMPTY_DATA,
            None => {
                let c = self.o.begin_data(16 + nbytes)?;
                self.o.write_raw(&k)?;
                write(&mut self.o)?;
                self.written.insert((k, nbytes, is_string), c);
                c
            }
        };
        let p = &mut self.props[id.0];
        let array = p.kind == Kind::Array;
        if p.first_changed != 0 {
            // Samples since the last change repeat the last stored one: store them now.
            let per_sample = if array { 2 } else { 1 };
            let prev: Vec<Child> = p.stored[p.stored.len() - per_sample..].to_vec();
            for _ in p.last_changed + 1..p.samples {
                p.stored.extend_from_slice(&prev);
            }
        }
        p.stored.push(data);
        if array {
            p.stored.push(Child::EMPTY_DATA);
        }
        if p.first_changed == 0 {
            p.first_changed = p.samples;
        }
        p.last_changed = p.samples;
        p.scalar_like &= points == 1;
        if p.points.is_some_and(|n| n != points) {
            p.homogeneous = false;
        }
        p.points = Some(points);
        p.last = Some((k, nbytes));
        p.hash = hash_of(&[&p.hash, &k]);
        p.samples += 1;
        Ok(())
    }

    /// Sets the next sample of `id` equal to its last one.
    pub fn repeat(&mut self, id: PropId) -> io::Result<()> {
        let p = &mut self.props[id.0];
        let Some((k, _)) = p.last else {
            return Err(io::Error::other(format!(
                "property {} repeats a sample before its first",
                p.name
            )));
        };
        p.hash = hash_of(&[&p.hash, &k]);
        p.samples += 1;
        Ok(())
    }

    /// Writes every group and the archive's closing blocks; returns the output.
    pub fn finish(mut self) -> io::Result<W> {
        let mut meta = MetaMap::default();
        let mut max_samples = vec![0u32; self.samplings.len() + 1];
        for p in &self.props {
            if p.kind != Kind::Compound {
                let n = if p.last_changed == 0 && p.samples > 0 {
                    1
                } else {
                    p.samples
                };
                let m = &mut max_samples[p.time_sampling as usize];
                *m = (*m).max(n);
            }
        }
        let (top, _) = self.write_object(ObjId(0), &mut meta)?;
        let archive_meta = self.o.data(&[self.metadata.as_bytes()])?;
        let mut ts = Vec::new();
        let all = std::iter::once((1.0, 0.0)).chain(self.samplings.iter().copied());
        for ((per_sample, start), max) in all.zip(&max_samples) {
            push_hinted(&mut ts, *max, 2);
            ts.extend_from_slice(&per_sample.to_le_bytes());
            push_hinted(&mut ts, 1, 2);
            ts.extend_from_slice(&start.to_le_bytes());
        }
        let ts = self.o.data(&[&ts])?;
        let md = self.o.data(&[&meta.bytes()])?;
        let children = [Child::Data(16), Child::Data(28), top, archive_meta, ts, md];
        self.o.finish(&children)
    }

    /// Writes an object's group (after its properties and children); returns it and the
    /// object's hash.
    fn write_object(&mut self, id: ObjId, meta: &mut MetaMap) -> io::Result<(Child, [u8; 16])> {
        let props = self.objects[id.0].props.clone();
        let (props_group, props_hash) = self.write_compound(&props, meta)?;
        let mut children = vec![props_group];
        let mut headers = Vec::new();
        let mut child_hashes = Vec::new();
        for c in self.objects[id.0].children.clone() {
            let (g, h) = self.write_object(c, meta)?;
            children.push(g);
            child_hashes.extend_from_slice(&h);
            let obj = &self.objects[c.0];
            push_hinted(&mut headers, obj.name.len() as u32, 2);
            headers.extend_from_slice(obj.name.as_bytes());
            let i = meta.index(&obj.meta);
            push_hinted(&mut headers, i, 0);
            if i == 255 {
                push_hinted(&mut headers, obj.meta.len() as u32, 2);
                headers.extend_from_slice(obj.meta.as_bytes());
            }
        }
        let children_hash = if child_hashes.is_empty() {
            [0; 16]
        } else {
            hash_of(&[&child_hashes])
        };
        headers.extend_from_slice(&props_hash);
        headers.extend_from_slice(&children_hash);
        children.push(self.o.data(&[&headers])?);
        let obj = &self.objects[id.0];
        let hash = hash_of(&[
            &props_hash,
            &children_hash,
            obj.meta.as_bytes(),
            obj.name.as_bytes(),
        ]);
        Ok((self.o.group(&children)?, hash))
    }

    /// Writes a compound's group of properties `props`; returns it and the hash of its
    /// properties.
    fn write_compound(
        &mut self,
        props: &[PropId],
        meta: &mut MetaMap,
    ) -> io::Result<(Child, [u8; 16])> {
        let mut children = Vec::new();
        let mut headers = Vec::new();
        let mut hashes = Vec::new();
        for &id in props {
            let (g, h) = if self.props[id.0].kind == Kind::Compound {
                let sub = self.props[id.0].props.clone();
                let (g, h) = self.write_compound(&sub, meta)?;
                (g, hash_of(&[&h, self.props[id.0].name.as_bytes()]))
            } else {
                let p = &self.props[id.0];
                let h = hash_of(&[&p.hash, p.name.as_bytes(), p.meta.as_bytes()]);
                (self.o.group(&p.stored)?, h)
            };
            children.push(g);
            hashes.extend_from_slice(&h);
            property_header(&mut headers, &self.props[id.0], meta);
        }
        if !headers.is_empty() {
            children.push(self.o.data(&[&headers])?);
        }
        let hash = if hashes.is_empty() {
            [0; 16]
        } else {
            hash_of(&[&hashes])
        };
        Ok((self.o.group(&children)?, hash))
    }
}

/// Where a property goes: an object's own compound or a compound property.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Parent {
    Object(ObjId),
    Compound(PropId),
}

/// Appends the header of `p` as the reference library's `WritePropertyInfo` lays it out.
fn property_header(b: &mut Vec<u8>, p: &Prop, meta: &mut MetaMap) {
    let max = (p.meta.len() as u32)
        .max(p.name.len() as u32)
        .max(p.samples)
        .max(p.time_sampling);
    let hint = if max < 256 {
        0
    } else if max < 65536 {
        1
    } else {
        2
    };
    let md = meta.index(&p.meta);
    let mut info: u32 = ((hint << 2) & 0xc) | ((md << 20) & 0x0ff0_0000);
    if p.kind == Kind::Compound {
        push_hinted(b, info, 2);
    } else {
        info |= match p.kind {
            Kind::Scalar => 1,
            _ => 2,
        };
        info |= u32::from(p.scalar_like);
        info |= ((p.pod as u32) << 4) & 0xf0;
        if p.time_sampling != 0 {
            info |= 0x100;
        }
        let mut first_last = false;
        if p.first_changed == 0 && p.last_changed == 0 {
            info |= 0x800;
        } else if p.first_changed != 1 || p.last_changed != p.samples - 1 {
            info |= 0x200;
            first_last = true;
        }
        info |= (u32::from(p.extent) << 12) & 0xff000;
        // The reference library keeps the flag only for arrays of one value per element.
        if p.homogeneous && (p.kind == Kind::Scalar || p.extent == 1) {
            info |= 0x400;
        }
        push_hinted(b, info, 2);
        push_hinted(b, p.samples, hint);
        if first_last {
            push_hinted(b, p.first_changed, hint);
            push_hinted(b, p.last_changed, hint);
        }
        if p.time_sampling != 0 {
            push_hinted(b, p.time_sampling, hint);
        }
    }
    push_hinted(b, p.name.len() as u32, hint);
    b.extend_from_slice(p.name.as_bytes());
    if md == 255 {
        push_hinted(b, p.meta.len() as u32, hint);
        b.extend_from_slice(p.meta.as_bytes());
    }
}
