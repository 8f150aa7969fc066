//! The USD text encoding (`.usda`), written as frames arrive.
//!
//! In text, an attribute's time samples sit in one `{ time: value, ... }` block. The first
//! per-frame attribute (`points`) goes straight to the output; the others (`normals`, `extent`)
//! go to spill files, one each, which are copied into place when the last frame has arrived.
//! So memory holds one frame, and the spills hold a copy of the other attributes' text.

use super::{Attr, Data, Prim, Stage, Stream, Value, build_stage};
use crate::cache::{CacheSpec, CacheWriter, Frame, check_complete, check_frame, invalid};
use std::fmt::Write as _;
use std::io::{self, Read, Seek, SeekFrom, Write};

/// Indentation step.
const TAB: &str = "    ";

/// Writes a run as a `.usda` stage to `W`, frame by frame. `S` holds the text of the per-frame
/// attributes after the first until the end (a temporary file, or memory in tests).
pub struct UsdaWriter<W: Write, S: Read + Write + Seek> {
    w: W,
    /// The streamed attributes, in order, and the depth of their prim's body.
    streams: Vec<Attr>,
    depth: usize,
    /// One spill per streamed attribute after the first.
    spills: Vec<S>,
    /// The text after the streamed attributes (the end of their prim, later prims).
    tail: Vec<u8>,
    vertices: usize,
    frames: u64,
    fed: u64,
    line: String,
}

impl<W: Write, S: Read + Write + Seek> UsdaWriter<W, S> {
    /// Writes the stage up to the first frame's `points`. `spill` is called once for each
    /// per-frame attribute after the first (`normals`, `extent`) and must give an empty store.
    ///
    /// # Errors
    ///
    /// I/O errors from `w` or `spill`.
    pub fn new(
        mut w: W,
        spec: &CacheSpec<'_>,
        mut spill: impl FnMut(&str) -> io::Result<S>,
    ) -> io::Result<Self> {
        let stage = build_stage(spec);
        let mut r = Render {
            head: &mut w,
            tail: Vec::new(),
            in_tail: false,
            streams: Vec::new(),
            depth: 0,
        };
        r.stage(&stage)?;
        let (tail, streams, depth) = (r.tail, r.streams, r.depth);
        let Some(first) = streams.first() else {
            return Err(invalid("a stage without per-frame attributes".into()));
        };
        write_samples_open(&mut w, first, depth)?;
        let spills = streams[1..]
            .iter()
            .map(|a| spill(&a.name))
            .collect::<io::Result<_>>()?;
        Ok(Self {
            w,
            streams,
            depth,
            spills,
            tail,
            vertices: spec.vertices(),
            frames: spec.frames,
            fed: 0,
            line: String::new(),
        })
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.w
    }

    /// Writes `frame`'s value of stream `s` as one `k: [...],` line into `self.line`.
    fn format(&mut self, s: Stream, frame: &Frame<'_>) {
        self.line.clear();
        let pad = TAB.repeat(self.depth + 1);
        let _ = write!(self.line, "{pad}{}: ", frame.index);
        match s {
            Stream::Points => float3s(&mut self.line, frame.positions),
            Stream::Normals => float3s(&mut self.line, frame.normals),
            Stream::Extent => float3s(&mut self.line, &frame.extent()),
        }
        self.line.push_str(",\n");
    }

    fn write_frame_impl(&mut self, frame: &Frame<'_>) -> io::Result<()> {
        check_frame(frame, self.fed, self.vertices)?;
        for i in 0..self.streams.len() {
            let Data::Streamed(s) = self.streams[i].data else {
                continue;
            };
            self.format(s, frame);
            if i == 0 {
                self.w.write_all(self.line.as_bytes())?;
            } else {
                self.spills[i - 1].write_all(self.line.as_bytes())?;
            }
        }
        self.fed += 1;
        Ok(())
    }

    fn finish_impl(&mut self) -> io::Result<()> {
        check_complete(self.fed, self.frames)?;
        let pad = TAB.repeat(self.depth);
        writeln!(self.w, "{pad}}}")?;
        for (attr, spill) in self.streams[1..].iter().zip(&mut self.spills) {
            write_samples_open(&mut self.w, attr, self.depth)?;
            spill.flush()?;
            spill.seek(SeekFrom::Start(0))?;
            io::copy(spill, &mut self.w)?;
            writeln!(self.w, "{pad}}}")?;
        }
        self.w.write_all(&self.tail)?;
        self.w.flush()
    }
}

impl<W: Write, S: Read + Write + Seek> CacheWriter for UsdaWriter<W, S> {
    fn write_frame(&mut self, frame: &Frame<'_>) -> io::Result<()> {
        self.write_frame_impl(frame)
    }

    fn finish(mut self: Box<Self>) -> io::Result<()> {
        self.finish_impl()
    }
}

/// Opens the time-sample block of a streamed attribute (declaring its metadata first, if any).
fn write_samples_open(w: &mut impl Write, a: &Attr, depth: usize) -> io::Result<()> {
    let pad = TAB.repeat(depth);
    let decl = declaration(a);
    if let Some(interp) = a.interpolation {
        writeln!(w, "{pad}{decl} (")?;
        writeln!(w, "{pad}{TAB}interpolation = \"{interp}\"")?;
        writeln!(w, "{pad})")?;
    }
    writeln!(w, "{pad}{decl}.timeSamples = {{")
}

/// `custom uniform type name`, as much of it as applies.
fn declaration(a: &Attr) -> String {
    let mut s = String::new();
    if a.custom {
        s.push_str("custom ");
    }
    if a.uniform {
        s.push_str("uniform ");
    }
    s.push_str(a.type_name);
    s.push(' ');
    s.push_str(&a.name);
    s
}

/// Renders the stage; text goes to `head` until the streamed attributes, then to `tail`.
struct Render<'a> {
    head: &'a mut dyn Write,
    tail: Vec<u8>,
    in_tail: bool,
    streams: Vec<Attr>,
    depth: usize,
}

impl Render<'_> {
    fn out(&mut self) -> &mut dyn Write {
        if self.in_tail {
            &mut self.tail
        } else {
            self.head
        }
    }

    fn stage(&mut self, stage: &Stage) -> io::Result<()> {
        let out = self.out();
        writeln!(out, "#usda 1.0\n(")?;
        for (_, key, value) in stage.metadata() {
            let mut s = String::new();
            value_text(&mut s, &value);
            writeln!(out, "{TAB}{key} = {s}")?;
        }
        writeln!(out, ")\n")?;
        self.prim(&stage.root, 0)
    }

    fn prim(&mut self, p: &Prim, depth: usize) -> io::Result<()> {
        let pad = TAB.repeat(depth);
        writeln!(
            self.out(),
            "{pad}def {} \"{}\"\n{pad}{{",
            p.type_name,
            p.name
        )?;
        let mut streamed = Vec::new();
        for a in &p.attrs {
            match &a.data {
                Data::Streamed(_) => streamed.push(a.clone()),
                data => self.attr(a, data, depth + 1)?,
            }
        }
        if !streamed.is_empty() {
            if self.in_tail {
                return Err(invalid("per-frame attributes on more than one prim".into()));
            }
            self.streams = streamed;
            self.depth = depth + 1;
            self.in_tail = true;
        }
        for (i, c) in p.children.iter().enumerate() {
            if i > 0 || !p.attrs.is_empty() {
                writeln!(self.out())?;
            }
            self.prim(c, depth + 1)?;
        }
        writeln!(self.out(), "{pad}}}")
    }

    fn attr(&mut self, a: &Attr, data: &Data, depth: usize) -> io::Result<()> {
        let pad = TAB.repeat(depth);
        let mut s = String::new();
        let _ = write!(s, "{pad}{}", declaration(a));
        match data {
            Data::Default(v) => {
                s.push_str(" = ");
                value_text(&mut s, v);
            }
            Data::Samples(samples) => {
                s.push_str(".timeSamples = {\n");
                for (t, v) in samples {
                    let _ = write!(s, "{pad}{TAB}{t:?}: ");
                    value_text(&mut s, v);
                    s.push_str(",\n");
                }
                let _ = write!(s, "{pad}}}");
            }
            Data::Streamed(_) => unreachable!("streamed attributes are written per frame"),
        }
        if let Some(interp) = a.interpolation {
            let _ = write!(s, " (\n{pad}{TAB}interpolation = \"{interp}\"\n{pad})");
        }
        s.push('\n');
        self.out().write_all(s.as_bytes())
    }
}

/// Appends `v` in usda syntax.
fn value_text(s: &mut String, v: &Value) {
    let list =
        |s: &mut String, open: char, close: char, items: &mut dyn Iterator<Item = String>| {
            s.push(open);
            for (i, item) in items.enumerate() {
                if i > 0 {
                    s.push_str(", ");
                }
                s.push_str(&item);
            }
            s.push(close);
        };
    match v {
        Value::Bool(b) => s.push_str(if *b { "1" } else { "0" }),
        Value::Int(i) => {
            let _ = write!(s, "{i}");
        }
        Value::Double(d) => {
            let _ = write!(s, "{d:?}");
        }
        Value::String(t) | Value::Token(t) => quoted(s, t),
        Value::IntTuple(v) => list(s, '(', ')', &mut v.iter().map(|i| i.to_string())),
        Value::DoubleTuple(v) => list(s, '(', ')', &mut v.iter().map(|d| format!("{d:?}"))),
        Value::Ints(v) => list(s, '[', ']', &mut v.iter().map(|i| i.to_string())),
        Value::Doubles(v) => list(s, '[', ']', &mut v.iter().map(|d| format!("{d:?}"))),
        Value::Tokens(v) => list(
            s,
            '[',
            ']',
            &mut v.iter().map(|t| {
                let mut q = String::new();
                quoted(&mut q, t);
                q
            }),
        ),
        Value::Float2s(v) => list(
            s,
            '[',
            ']',
            &mut v.iter().map(|[a, b]| format!("({a:?}, {b:?})")),
        ),
        Value::Float3s(v) => float3s(s, v),
    }
}

/// `[(x, y, z), ...]` with every f32 in its shortest exact text.
fn float3s(s: &mut String, v: &[[f32; 3]]) {
    s.push('[');
    for (i, [x, y, z]) in v.iter().enumerate() {
        if i > 0 {
            s.push_str(", ");
        }
        let _ = write!(s, "({x:?}, {y:?}, {z:?})");
    }
    s.push(']');
}

/// `t` as a double-quoted usda string.
fn quoted(s: &mut String, t: &str) {
    s.push('"');
    for c in t.chars() {
        match c {
            '"' => s.push_str("\\\""),
            '\\' => s.push_str("\\\\"),
            '\n' => s.push_str("\\n"),
            '\r' => s.push_str("\\r"),
            '\t' => s.push_str("\\t"),
            c if (c as u32) < 0x20 => {
                let _ = write!(s, "\\x{:02x}", c as u32);
            }
            c => s.push(c),
        }
    }
    s.push('"');
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RunInfo;
    use crate::params::{ParamValue, SceneParam};
    use std::io::Cursor;
    use wetcloth::SimConfig;

    #[test]
    fn strings_are_escaped_and_numbers_exact() {
        let mut s = String::new();
        quoted(&mut s, "a \"b\"\\\n");
        assert_eq!(s, r#""a \"b\"\\\n""#);
        s.clear();
        value_text(&mut s, &Value::Doubles(vec![0.1, 1e-20, 101325.0]));
        assert_eq!(s, "[0.1, 1e-20, 101325.0]");
        s.clear();
        float3s(&mut s, &[[0.1, -2.0, 1.0 / 3.0]]);
        assert_eq!(s, "[(0.1, -2.0, 0.33333334)]");
    }

    /// The whole text of a 2 x 2 cloth over two frames, with a plane, as USD reads it.
    #[test]
    fn a_small_stage_reads_as_expected() {
        let mut cfg = SimConfig::default();
        cfg.cloth.resolution = [2, 2];
        cfg.cloth.size = [0.2, 0.1];
        cfg.simulation.frame_rate = 10.0;
        cfg.colliders = SimConfig::thesis_demo().colliders;
        let run = RunInfo::new("tiny-run", &cfg, 2, true);
        let params = [SceneParam {
            name: "wetcloth:cloth:mass".into(),
            value: ParamValue::Float(0.02),
        }];
        let spec = CacheSpec {
            run: &run,
            frames: 2,
            surface: &wetcloth::ClothSurface::new(&cfg.cloth),
            params: &params,
        };
        let mut w = UsdaWriter::new(Vec::new(), &spec, |_| Ok(Cursor::new(Vec::new()))).unwrap();
        for k in 0..2 {
            let p: Vec<[f32; 3]> = (0..4).map(|v| [v as f32, k as f32, 0.5]).collect();
            let n = vec![[0.0, 1.0, 0.0]; 4];
            w.write_frame_impl(&Frame {
                index: k,
                positions: &p,
                normals: &n,
            })
            .unwrap();
        }
        w.finish_impl().unwrap();
        let text = String::from_utf8(w.into_inner()).unwrap();
        for want in [
            "#usda 1.0\n(\n    defaultPrim = \"tiny_run\"\n",
            "    metersPerUnit = 1.0\n",
            "    timeCodesPerSecond = 10.0\n    upAxis = \"Y\"\n)\n\ndef Xform \"tiny_run\"\n{\n",
            "    custom double wetcloth:cloth:mass = 0.02\n",
            "        int[] faceVertexIndices = [0, 3, 1, 0, 2, 3]\n",
            "        texCoord2f[] primvars:st = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] (\n            interpolation = \"vertex\"\n        )\n",
            "        point3f[] points.timeSamples = {\n            0: [(0.0, 0.0, 0.5), (1.0, 0.0, 0.5), (2.0, 0.0, 0.5), (3.0, 0.0, 0.5)],\n            1: [(0.0, 1.0, 0.5),",
            "        normal3f[] normals (\n            interpolation = \"vertex\"\n        )\n        normal3f[] normals.timeSamples = {\n            0: [(0.0, 1.0, 0.0),",
            "        float3[] extent.timeSamples = {\n            0: [(0.0, 0.0, 0.5), (3.0, 0.0, 0.5)],\n            1: [(0.0, 1.0, 0.5), (3.0, 1.0, 0.5)],\n        }\n    }\n\n    def Scope \"colliders\"\n    {\n        def Mesh \"plane_0\"\n",
            "            custom token wetcloth:shape = \"plane\"\n",
        ] {
            assert!(text.contains(want), "missing\n{want}\nin\n{text}");
        }
        assert!(text.ends_with("        }\n    }\n}\n"), "{text}");
    }
}
