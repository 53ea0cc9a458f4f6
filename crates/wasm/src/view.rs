//! View-dependent streaming of a chunked MRQ file (format version 5, spec §11): for each camera,
//! the chunks the view needs ([`octowrap_format::select::select_for_view`]: fine where the
//! viewer looks, coarse farther away, none out of view), fetched by byte range, and their
//! crack-free mesh ([`octowrap_format::ChunkedMrq::cut_where`], spec §11.5).
//!
//! The caller fetches what [`View::next_ranges`] names and hands each piece to [`View::push`]:
//! the preamble first, then, after [`View::select`], the chunks of the selection and their
//! ancestors. [`View::cut`] makes the mesh; when the crack rule needs chunks that have not
//! arrived it returns `None`, and `next_ranges` names them. Pieces no cut has used for longest
//! are dropped when the bytes held exceed the budget.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::rc::Rc;

use octowrap_format::select::{ViewCamera, in_view, select_for_view};
use octowrap_format::{ChunkInfo, ChunkedMrq, CutError, DecodeError, Limits, RangeSource};

use crate::stream::{LevelMesh, StreamError};

/// Byte ranges received, by start offset, with what reads found missing.
#[derive(Debug, Default)]
struct Held {
    /// Start offset → (bytes, the cut that last read them).
    pieces: BTreeMap<u64, (Vec<u8>, u64)>,
    /// Ranges a read needed and did not find, since the last [`Held::take_missing`].
    missing: Vec<(u64, u64)>,
    /// Cuts so far (the clock of `pieces`' last use).
    clock: u64,
}

impl Held {
    fn bytes(&self) -> u64 {
        self.pieces.values().map(|(b, _)| b.len() as u64).sum()
    }

    /// The contiguous bytes held from offset 0.
    fn prefix(&self) -> Vec<u8> {
        let mut out = Vec::new();
        for (&start, (b, _)) in &self.pieces {
            let end = start + b.len() as u64;
            let have = out.len() as u64;
            if start > have {
                break;
            }
            if end > have {
                out.extend_from_slice(&b[(have - start) as usize..]);
            }
        }
        out
    }

    /// Copies `offset..offset + buf.len()` out of the pieces (a read may span several), or
    /// records the first gap as missing.
    fn read(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        let end = offset + buf.len() as u64;
        let mut at = offset;
        while at < end {
            let found = self.pieces.range_mut(..=at).next_back().filter(|(s, (b, _))| **s + b.len() as u64 > at);
            let Some((&start, (bytes, used))) = found else {
                let next = self.pieces.range(at..).next().map_or(end, |(&s, _)| s.min(end));
                self.missing.push((at, next.max(at + 1)));
                return Err(std::io::ErrorKind::UnexpectedEof.into());
            };
            *used = self.clock;
            let upto = end.min(start + bytes.len() as u64);
            buf[(at - offset) as usize..(upto - offset) as usize]
                .copy_from_slice(&bytes[(at - start) as usize..(upto - start) as usize]);
            at = upto;
        }
        Ok(())
    }

    /// Whether every byte of `start..end` is held.
    fn has(&self, start: u64, end: u64) -> bool {
        let mut at = start;
        while at < end {
            match self.pieces.range(..=at).next_back() {
                Some((&s, (b, _))) if s + b.len() as u64 > at => at = s + b.len() as u64,
                _ => return false,
            }
        }
        true
    }

    /// Drops the pieces no cut has read for longest (never the one at offset 0, the preamble's)
    /// until at most `budget` bytes are held or only pieces of the last cut are left.
    fn evict(&mut self, budget: u64) {
        let mut total = self.bytes();
        while total > budget {
            let oldest = self
                .pieces
                .iter()
                .filter(|(s, (_, used))| **s > 0 && *used < self.clock)
                .min_by_key(|(_, (_, used))| *used);
            let Some((&start, _)) = oldest else { break };
            let (b, _) = self.pieces.remove(&start).expect("listed");
            total -= b.len() as u64;
        }
    }
}

/// The pieces as a [`RangeSource`] for the reader.
#[derive(Clone, Debug, Default)]
struct Source(Rc<RefCell<Held>>);

impl RangeSource for Source {
    fn read_range(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        self.0.borrow_mut().read(offset, buf)
    }
}

/// What the last cut drew.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CutStats {
    /// Chunks drawn (after the crack rule's refinements).
    pub drawn: u32,
    /// Of them, chunks of the file's finest level.
    pub finest_drawn: u32,
    /// The finest level drawn.
    pub finest_level: u32,
    /// Chunks the crack rule refined.
    pub refined: u32,
    /// Seams the crack rule could not close.
    pub unresolved: u32,
}

/// One chunked MRQ file being viewed.
pub struct View {
    held: Source,
    reader: Option<ChunkedMrq<Source>>,
    chunks: Vec<ChunkInfo>,
    preamble_len: Option<u64>,
    file_len: Option<u64>,
    budget_bytes: u64,
    drawn: Vec<u32>,
    fetched: Vec<u32>,
    seen: Vec<bool>,
    last: CutStats,
}

impl View {
    /// A view holding at most about `budget_bytes` of the file's bytes.
    pub fn new(budget_bytes: u64) -> Self {
        Self {
            held: Source::default(),
            reader: None,
            chunks: Vec::new(),
            preamble_len: None,
            file_len: None,
            budget_bytes,
            drawn: Vec::new(),
            fetched: Vec::new(),
            seen: Vec::new(),
            last: CutStats::default(),
        }
    }

    /// Records the file's length (from `Content-Range`).
    pub fn set_file_len(&mut self, len: u64) -> Result<(), StreamError> {
        crate::stream::record_len(&mut self.file_len, len)
    }

    /// Adds the bytes fetched from `offset`; opens the file once its preamble is in.
    pub fn push(&mut self, offset: u64, data: &[u8]) -> Result<(), StreamError> {
        if data.is_empty() {
            return Ok(());
        }
        {
            let mut held = self.held.0.borrow_mut();
            let now = held.clock;
            held.pieces.insert(offset, (data.to_vec(), now));
        }
        if self.reader.is_none() {
            let prefix = self.held.0.borrow().prefix();
            match octowrap_format::read_info(&prefix[..], &Limits::default()) {
                Ok(info) => {
                    self.preamble_len = Some(info.preamble_size);
                    let reader = ChunkedMrq::open(self.held.clone(), &Limits::default())?;
                    self.chunks = reader.chunks();
                    self.reader = Some(reader);
                }
                Err(DecodeError::Truncated { offset, needed, got, .. }) if got < needed => {
                    self.preamble_len = Some(offset + needed);
                }
                Err(e) => return Err(e.into()),
            }
        }
        Ok(())
    }

    /// The file's chunks, once the preamble is in (empty before).
    pub fn chunks(&self) -> &[ChunkInfo] {
        &self.chunks
    }

    /// The file's description, once the preamble is in.
    pub fn info(&self) -> Option<octowrap_format::FileInfo> {
        self.reader.as_ref().map(ChunkedMrq::info)
    }

    /// Chooses the chunks for `camera` (viewport `aspect`, width over height).
    pub fn select(&mut self, camera: &ViewCamera, aspect: f64) {
        let s = select_for_view(&self.chunks, camera, aspect);
        self.seen = in_view(&self.chunks, camera, aspect);
        self.drawn = s.drawn;
        self.fetched = s.fetched;
    }

    /// The byte ranges to fetch next (start inclusive, end exclusive, adjacent ones merged): the
    /// preamble until it is in, then the selected chunks and their ancestors not held, and what
    /// the last cut found missing.
    pub fn next_ranges(&self) -> Result<Vec<(u64, u64)>, StreamError> {
        let held = self.held.0.borrow();
        if self.reader.is_none() {
            let have = held.prefix().len() as u64;
            let end = crate::stream::preamble_end(self.file_len, self.preamble_len)?;
            return Ok(if end > have { vec![(have, end)] } else { Vec::new() });
        }
        let mut want: Vec<(u64, u64)> = self
            .fetched
            .iter()
            .map(|&c| &self.chunks[c as usize])
            .map(|c| (c.offset, c.offset + u64::from(c.stored_size)))
            .filter(|&(s, e)| !held.has(s, e))
            .collect();
        want.extend(held.missing.iter().copied().filter(|&(s, e)| !held.has(s, e)));
        if let Some(len) = self.file_len {
            if let Some(&(s, e)) = want.iter().find(|&&(_, e)| e > len) {
                return Err(StreamError::Truncated { len, what: "a chunk".into(), start: s, end: e });
            }
        }
        want.sort_unstable();
        let mut out: Vec<(u64, u64)> = Vec::new();
        for (s, e) in want {
            match out.last_mut() {
                Some(last) if s <= last.1 => last.1 = last.1.max(e),
                _ => out.push((s, e)),
            }
        }
        Ok(out)
    }

    /// The crack-free mesh of the selection, or `None` when chunks it needs have not arrived
    /// ([`View::next_ranges`] names them).
    pub fn cut(&mut self) -> Result<Option<LevelMesh>, StreamError> {
        let Some(reader) = &mut self.reader else { return Ok(None) };
        {
            let mut held = self.held.0.borrow_mut();
            held.missing.clear();
            held.clock += 1;
        }
        let seen = &self.seen;
        let cut = match reader.cut_where(&self.drawn, |c| seen.get(c as usize).copied().unwrap_or(false)) {
            Ok(cut) => cut,
            Err(CutError::Decode(DecodeError::Truncated { .. })) if !self.held.0.borrow().missing.is_empty() => {
                return Ok(None);
            }
            Err(CutError::Decode(e)) => return Err(e.into()),
            Err(CutError::Selection(reason)) => return Err(StreamError::Selection(reason)),
            Err(e) => return Err(StreamError::Selection(e.to_string())),
        };
        let finest = self.chunks.iter().map(|c| c.level).max().unwrap_or(0);
        let levels: Vec<u32> = cut.drawn.iter().map(|&c| self.chunks[c as usize].level).collect();
        self.last = CutStats {
            drawn: cut.drawn.len() as u32,
            finest_drawn: levels.iter().filter(|&&l| l == finest).count() as u32,
            finest_level: levels.iter().copied().max().unwrap_or(0),
            refined: cut.refined,
            unresolved: cut.unresolved,
        };
        self.held.0.borrow_mut().evict(self.budget_bytes);
        let mesh = &cut.mesh;
        let positions = mesh.vertices.positions.iter().flat_map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect();
        let triangles = mesh.triangles().into_iter().flatten().collect();
        Ok(Some(LevelMesh { level: self.last.finest_level, positions, triangles, faces: mesh.faces.len() as u32 }))
    }

    /// What the last cut drew.
    pub fn last_cut(&self) -> CutStats {
        self.last
    }

    /// Bytes held.
    pub fn held(&self) -> u64 {
        self.held.0.borrow().bytes()
    }
}
