//! Implicit tiling (3D Tiles 1.1, OGC 22-025r4 §6.8 "Implicit Tiling", octree subdivision): the
//! tiles below one root described by availability bitstreams in subtree files instead of explicit
//! JSON, for trees too large to list.
//!
//! The writer's mapping: the octree partition's cut levels ([`crate::partition`]) are the implicit
//! levels. The tile of hierarchy level `base` over the whole cube is the implicit root (implicit
//! level 0); the tile of level `base + d` in cell `(d, x, y, z)` is the implicit tile at level `d`,
//! coordinates `(x, y, z)`. Implicit tiles' volumes are the subdivided cube, not tight boxes (a
//! tile's faces can reach past its cell by part of a face, since a face goes to the cell of its
//! centroid: a client culling by the cell may drop such a sliver at the very edge of the view), and
//! their geometric error halves per level from the root's, so the root's is chosen as the
//! smallest that keeps every implicit tile's error at or above its measured one:
//! `max over levels d of (largest measured error at d) * 2^d`.
//!
//! # Subtree files (binary `.subtree`)
//! | bytes | field |
//! |---|---|
//! | 4 | magic `subt` |
//! | 4 | version, u32 LE: 1 |
//! | 8 | JSON byte length, u64 LE (a multiple of 8: padded with spaces) |
//! | 8 | binary byte length, u64 LE (a multiple of 8: padded with zeros) |
//! | .. | JSON: `buffers`, `bufferViews`, `tileAvailability`, `contentAvailability`, `childSubtreeAvailability` |
//! | .. | binary: the bitstreams, each at an 8-byte aligned offset |
//!
//! A subtree holds `subtreeLevels` levels. Its availability bitstreams hold one bit per tile, level
//! after level from the subtree's root, in Morton order within a level (bit `3k` of the index is
//! bit `k` of x, `3k + 1` of y, `3k + 2` of z); bit `i` is bit `i % 8` of byte `i / 8`. Child
//! subtree availability has one bit per tile of the level just below the subtree. A bitstream
//! whose bits are all equal is written as a `constant` instead.

use crate::partition::Cell;

/// The subtree file's magic, `subt`.
pub const SUBTREE_MAGIC: &[u8; 4] = b"subt";

/// Bits of an availability bitstream: one per tile, or a constant.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Availability {
    /// Every bit has this value.
    Constant(bool),
    /// The bits, least significant first within each byte.
    Bits(Vec<u8>),
}

impl Availability {
    fn from_bits(bits: &[bool]) -> Self {
        if bits.iter().all(|&b| b) {
            return Self::Constant(true);
        }
        if bits.iter().all(|&b| !b) {
            return Self::Constant(false);
        }
        let mut bytes = vec![0u8; bits.len().div_ceil(8)];
        for (i, _) in bits.iter().enumerate().filter(|(_, b)| **b) {
            bytes[i / 8] |= 1 << (i % 8);
        }
        Self::Bits(bytes)
    }

    /// Bit `i`.
    pub fn get(&self, i: usize) -> bool {
        match self {
            Self::Constant(c) => *c,
            Self::Bits(b) => b.get(i / 8).is_some_and(|byte| (byte >> (i % 8)) & 1 == 1),
        }
    }
}

/// The Morton index of `(x, y, z)` at a level (x in the lowest bit of each triple).
pub fn morton(xyz: [u32; 3], level: u8) -> u64 {
    let mut m = 0u64;
    for k in 0..level {
        for (axis, c) in xyz.iter().enumerate() {
            m |= u64::from((c >> k) & 1) << (3 * u64::from(k) + axis as u64);
        }
    }
    m
}

/// The coordinates of Morton index `m` at a level (the inverse of [`morton`]).
pub fn demorton(m: u64, level: u8) -> [u32; 3] {
    let mut xyz = [0u32; 3];
    for k in 0..level {
        for (axis, c) in xyz.iter_mut().enumerate() {
            *c |= u32::try_from((m >> (3 * u64::from(k) + axis as u64)) & 1).expect("one bit") << k;
        }
    }
    xyz
}

/// Tiles of an octree with `levels` levels: `(8^levels - 1) / 7`.
pub fn tiles_in(levels: u8) -> usize {
    ((1usize << (3 * usize::from(levels))) - 1) / 7
}

/// The bit of `cell` (relative to the subtree root `root`) in a subtree's tile bitstream.
pub fn bit_index(root: Cell, cell: Cell) -> usize {
    let rel = cell.depth - root.depth;
    let xyz = [0, 1, 2].map(|k| cell.xyz[k] - (root.xyz[k] << rel));
    tiles_in(rel) + morton(xyz, rel) as usize
}

/// One subtree's contents.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Subtree {
    /// Tiles that exist.
    pub tiles: Availability,
    /// Tiles with content.
    pub content: Availability,
    /// Child subtrees that exist.
    pub children: Availability,
}

/// Builds the subtree rooted at `root` (`levels` levels) from `available(cell) -> Option<has
/// content>`; also gives the roots of its available child subtrees, in Morton order.
pub fn build(root: Cell, levels: u8, available: &dyn Fn(Cell) -> Option<bool>) -> (Subtree, Vec<Cell>) {
    let n = tiles_in(levels);
    let mut tiles = vec![false; n];
    let mut content = vec![false; n];
    let mut stack = vec![root];
    let mut children = vec![false; 1usize << (3 * usize::from(levels))];
    let mut child_roots = Vec::new();
    while let Some(c) = stack.pop() {
        let Some(has) = available(c) else { continue };
        if c.depth - root.depth == levels {
            let rel = [0, 1, 2].map(|k| c.xyz[k] - (root.xyz[k] << levels));
            children[morton(rel, levels) as usize] = true;
            child_roots.push((morton(rel, levels), c));
            continue;
        }
        let i = bit_index(root, c);
        tiles[i] = true;
        content[i] = has;
        stack.extend((0..8).map(|o| c.child(o)));
    }
    child_roots.sort_unstable();
    let subtree = Subtree {
        tiles: Availability::from_bits(&tiles),
        content: Availability::from_bits(&content),
        children: Availability::from_bits(&children),
    };
    (subtree, child_roots.into_iter().map(|(_, c)| c).collect())
}

fn availability_json(a: &Availability, views: &mut Vec<(usize, usize)>, bin: &mut Vec<u8>) -> serde_json::Value {
    match a {
        Availability::Constant(c) => serde_json::json!({ "constant": u8::from(*c) }),
        Availability::Bits(b) => {
            while bin.len() % 8 != 0 {
                bin.push(0);
            }
            views.push((bin.len(), b.len()));
            bin.extend_from_slice(b);
            serde_json::json!({ "bitstream": views.len() - 1 })
        }
    }
}

impl Subtree {
    /// The subtree file's bytes (see the module docs).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut views = Vec::new();
        let mut bin = Vec::new();
        let tiles = availability_json(&self.tiles, &mut views, &mut bin);
        let content = availability_json(&self.content, &mut views, &mut bin);
        let children = availability_json(&self.children, &mut views, &mut bin);
        while bin.len() % 8 != 0 {
            bin.push(0);
        }
        let mut json = serde_json::Map::new();
        if !bin.is_empty() {
            json.insert("buffers".into(), serde_json::json!([{ "byteLength": bin.len() }]));
            let v: Vec<_> = views
                .iter()
                .map(|&(o, l)| serde_json::json!({ "buffer": 0, "byteOffset": o, "byteLength": l }))
                .collect();
            json.insert("bufferViews".into(), v.into());
        }
        json.insert("tileAvailability".into(), tiles);
        json.insert("contentAvailability".into(), serde_json::Value::Array(vec![content]));
        json.insert("childSubtreeAvailability".into(), children);
        let mut text = serde_json::to_vec(&json).expect("plain JSON");
        while text.len() % 8 != 0 {
            text.push(b' ');
        }
        let mut out = Vec::with_capacity(24 + text.len() + bin.len());
        out.extend_from_slice(SUBTREE_MAGIC);
        out.extend_from_slice(&1u32.to_le_bytes());
        out.extend_from_slice(&(text.len() as u64).to_le_bytes());
        out.extend_from_slice(&(bin.len() as u64).to_le_bytes());
        out.extend_from_slice(&text);
        out.extend_from_slice(&bin);
        out
    }

    /// Reads a subtree file of `levels` levels: the header, the JSON and every bitstream, each
    /// checked against the file's length and the bits the levels need. Errors name the byte offset.
    pub fn parse(bytes: &[u8], levels: u8) -> Result<Self, String> {
        if bytes.len() < 24 {
            return Err(format!("{} bytes: shorter than the 24-byte header", bytes.len()));
        }
        if &bytes[..4] != SUBTREE_MAGIC {
            return Err("offset 0: not a subtree (magic is not 'subt')".into());
        }
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
        let version = u32::from_le_bytes(bytes[4..8].try_into().expect("4 bytes"));
        if version != 1 {
            return Err(format!("offset 4: version {version}, not 1"));
        }
        let (json_len, bin_len) = (u64_at(8), u64_at(16));
        let total = 24u64.checked_add(json_len).and_then(|n| n.checked_add(bin_len));
        if total != Some(bytes.len() as u64) {
            return Err(format!(
                "offset 8: JSON {json_len} + binary {bin_len} bytes do not fill the {}-byte file",
                bytes.len()
            ));
        }
        if json_len % 8 != 0 || bin_len % 8 != 0 {
            return Err("offset 8: the JSON and binary lengths must be multiples of 8".into());
        }
        let json_end = 24 + json_len as usize;
        let json: serde_json::Value = serde_json::from_slice(&bytes[24..json_end])
            .map_err(|e| format!("offset 24: the JSON does not parse: {e}"))?;
        let bin = &bytes[json_end..];
        if let Some(b) = json["buffers"].as_array() {
            if b.iter().any(|b| b.get("uri").is_some()) {
                return Err("external subtree buffers are not read".into());
            }
        }
        let views = json["bufferViews"].as_array().cloned().unwrap_or_default();
        let read = |what: &str, v: &serde_json::Value, bits: usize| -> Result<Availability, String> {
            if let Some(c) = v.get("constant") {
                return match c.as_u64() {
                    Some(0) => Ok(Availability::Constant(false)),
                    Some(1) => Ok(Availability::Constant(true)),
                    _ => Err(format!("{what}: constant must be 0 or 1")),
                };
            }
            let i = v["bitstream"].as_u64().ok_or_else(|| format!("{what}: neither constant nor bitstream"))?;
            let view = views.get(i as usize).ok_or_else(|| format!("{what}: bitstream {i} is not a bufferView"))?;
            let (o, l) = (view["byteOffset"].as_u64().unwrap_or(0), view["byteLength"].as_u64().unwrap_or(0));
            if o % 8 != 0 {
                return Err(format!("{what}: bufferView {i} at offset {o} is not 8-byte aligned"));
            }
            if o.checked_add(l).is_none_or(|end| end > bin.len() as u64) {
                return Err(format!(
                    "{what}: bufferView {i} ({o} + {l}) runs past the {}-byte binary chunk",
                    bin.len()
                ));
            }
            if (l as usize) < bits.div_ceil(8) {
                return Err(format!("{what}: {l} bytes hold fewer than the {bits} bits needed"));
            }
            Ok(Availability::Bits(bin[o as usize..(o + l) as usize].to_vec()))
        };
        let n = tiles_in(levels);
        let content = match json["contentAvailability"].as_array().map(Vec::as_slice) {
            None | Some([]) => Availability::Constant(false),
            Some([one]) => read("contentAvailability[0]", one, n)?,
            Some(_) => return Err("more than one content per tile is not written by octowrap".into()),
        };
        Ok(Self {
            tiles: read("tileAvailability", &json["tileAvailability"], n)?,
            content,
            children: read(
                "childSubtreeAvailability",
                &json["childSubtreeAvailability"],
                1 << (3 * usize::from(levels)),
            )?,
        })
    }
}

/// Fills a URI template's `{level}`, `{x}`, `{y}`, `{z}`.
pub fn fill(template: &str, cell: Cell) -> String {
    template
        .replace("{level}", &cell.depth.to_string())
        .replace("{x}", &cell.xyz[0].to_string())
        .replace("{y}", &cell.xyz[1].to_string())
        .replace("{z}", &cell.xyz[2].to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_order_interleaves_x_first() {
        assert_eq!(morton([1, 0, 0], 1), 1);
        assert_eq!(morton([0, 1, 0], 1), 2);
        assert_eq!(morton([0, 0, 1], 1), 4);
        assert_eq!(morton([3, 0, 0], 2), 0b1001);
        for m in 0..512 {
            assert_eq!(morton(demorton(m, 3), 3), m);
        }
        assert_eq!(bit_index(Cell::ROOT, Cell::ROOT), 0);
        assert_eq!(bit_index(Cell::ROOT, Cell::ROOT.child(7)), 8);
        assert_eq!(bit_index(Cell::ROOT, Cell::ROOT.child(0).child(1)), 9 + 1);
    }

    #[test]
    fn subtrees_round_trip_and_truncations_fail() {
        let keep = |c: Cell| (c.depth <= 2 && c.xyz.iter().all(|&v| v == 0)).then_some(c.depth != 1);
        let (s, roots) = build(Cell::ROOT, 2, &keep);
        assert_eq!(roots, vec![Cell { depth: 2, xyz: [0; 3] }]);
        assert!(s.tiles.get(0) && s.tiles.get(1) && !s.tiles.get(2));
        assert!(s.content.get(0) && !s.content.get(1));
        assert!(s.children.get(0) && !s.children.get(1));
        let bytes = s.to_bytes();
        assert_eq!(Subtree::parse(&bytes, 2).unwrap(), s);
        for n in 0..bytes.len() {
            assert!(Subtree::parse(&bytes[..n], 2).is_err(), "a {n}-byte prefix must fail");
        }
    }
}
