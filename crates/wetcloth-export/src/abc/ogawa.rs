//! The Ogawa container that Alembic archives are stored in: a tree of groups whose leaves are
//! data blocks, everything little-endian.
//!
//! ```text
//! bytes 0..5    "Ogawa"
//! byte  5       0xff once the file is complete (0 while it is being written)
//! bytes 6..8    format version, 0 then 1
//! bytes 8..16   u64 offset of the root group
//! data block    u64 size, then the bytes (an empty block is never written: see below)
//! group         u64 child count, then one u64 per child: a data block's offset with the high
//!               bit set, or a group's offset (offset 0: an empty block or an empty group)
//! ```
//!
//! Children are referred to by offset, so a group is written after its children: data blocks
//! go to the file as they come (a frame's samples when the frame arrives) and the groups that
//! list them at the end, which keeps memory to the offsets, not the data.

use std::io::{self, Seek, SeekFrom, Write};

/// The high bit that marks a group's child as a data block.
const DATA_BIT: u64 = 1 << 63;

/// A child of a group: a data block or a group, by offset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Child {
    /// A data block at this offset (0: the empty block).
    Data(u64),
    /// A group at this offset (0: the empty group).
    Group(u64),
}

impl Child {
    /// The empty data block.
    pub const EMPTY_DATA: Child = Child::Data(0);

    fn encode(self) -> u64 {
        match self {
            Child::Data(p) => p | DATA_BIT,
            Child::Group(p) => p,
        }
    }
}

/// An Ogawa file being written to `W`, appended to until [`OgawaWriter::finish`].
#[derive(Debug)]
pub(crate) struct OgawaWriter<W: Write + Seek> {
    w: W,
    /// Offset of the next byte written, from the start of the file.
    pos: u64,
}

impl<W: Write + Seek> OgawaWriter<W> {
    /// Writes the header of an unfinished file.
    pub fn new(mut w: W) -> io::Result<Self> {
        w.write_all(b"Ogawa\0\0\x01")?;
        w.write_all(&0u64.to_le_bytes())?;
        Ok(Self { w, pos: 16 })
    }

    /// Writes a data block of the concatenated `parts`. An empty block is not written: it is
    /// [`Child::EMPTY_DATA`].
    pub fn data(&mut self, parts: &[&[u8]]) -> io::Result<Child> {
        let size: u64 = parts.iter().map(|p| p.len() as u64).sum();
        if size == 0 {
            return Ok(Child::EMPTY_DATA);
        }
        let at = self.begin_data(size)?;
        for p in parts {
            self.write_raw(p)?;
        }
        Ok(at)
    }

    /// Starts a data block of `size` bytes (not 0), which the caller then writes with
    /// [`OgawaWriter::write_raw`], exactly `size` bytes.
    pub fn begin_data(&mut self, size: u64) -> io::Result<Child> {
        debug_assert!(size > 0);
        let at = self.pos;
        self.write_raw(&size.to_le_bytes())?;
        Ok(Child::Data(at))
    }

    /// Appends bytes to the data block being written.
    pub fn write_raw(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.w.write_all(bytes)?;
        self.pos += bytes.len() as u64;
        Ok(())
    }

    /// Writes a group of `children`; a group without children is not written: it is the
    /// empty group.
    pub fn group(&mut self, children: &[Child]) -> io::Result<Child> {
        if children.is_empty() {
            return Ok(Child::Group(0));
        }
        let at = self.pos;
        let mut buf = Vec::with_capacity(8 * (children.len() + 1));
        buf.extend_from_slice(&(children.len() as u64).to_le_bytes());
        for c in children {
            buf.extend_from_slice(&c.encode().to_le_bytes());
        }
        self.write_raw(&buf)?;
        Ok(Child::Group(at))
    }

    /// Writes the root group of `children`, points the header at it, marks the file complete
    /// and flushes; returns the output.
    pub fn finish(mut self, children: &[Child]) -> io::Result<W> {
        let Child::Group(root) = self.group(children)? else {
            unreachable!("group() returns a group")
        };
        self.w.seek(SeekFrom::Start(8))?;
        self.w.write_all(&root.to_le_bytes())?;
        self.w.seek(SeekFrom::Start(5))?;
        self.w.write_all(&[0xff])?;
        self.w.seek(SeekFrom::Start(self.pos))?;
        self.w.flush()?;
        Ok(self.w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    #[test]
    fn header_blocks_and_groups_are_laid_out_as_ogawa_reads_them() {
        let mut o = OgawaWriter::new(Cursor::new(Vec::new())).unwrap();
        let d = o.data(&[b"ab", b"c"]).unwrap();
        assert_eq!(d, Child::Data(16));
        assert_eq!(o.data(&[]).unwrap(), Child::EMPTY_DATA);
        let g = o.group(&[d, Child::EMPTY_DATA]).unwrap();
        assert_eq!(g, Child::Group(16 + 8 + 3));
        assert_eq!(o.group(&[]).unwrap(), Child::Group(0));
        let bytes = o.finish(&[g, d]).unwrap().into_inner();
        assert_eq!(&bytes[..8], b"Ogawa\xff\x00\x01");
        let u64_at = |p: usize| u64::from_le_bytes(bytes[p..p + 8].try_into().unwrap());
        let root = u64_at(8) as usize;
        assert_eq!(root, 27 + 24);
        assert_eq!(u64_at(root), 2);
        assert_eq!(u64_at(root + 8), 27);
        assert_eq!(u64_at(root + 16), 16 | DATA_BIT);
        assert_eq!(u64_at(16), 3);
        assert_eq!(&bytes[24..27], b"abc");
        assert_eq!(u64_at(27), 2);
        assert_eq!(u64_at(35), 16 | DATA_BIT);
        assert_eq!(u64_at(43), DATA_BIT);
        assert_eq!(bytes.len(), root + 24);
    }
}
