//! The MRQ decoder for web browsers: `octowrap-format`'s reader compiled to WebAssembly
//! (`wasm32-unknown-unknown`, bindings by wasm-bindgen), streaming one file from HTTP range
//! requests into typed arrays for `THREE.BufferGeometry`, level by level ([`MrqStream`]) or,
//! for chunked files (format version 5), view-dependently ([`MrqView`]).
//!
//! The logic stays in Rust ([`stream::Stream`], [`view::View`]); JavaScript only fetches the byte
//! ranges they name and uploads the arrays. `tools/viewer/mrq-worker.js` runs them in a Web
//! Worker. Level by level:
//!
//! ```js
//! const s = new MrqStream(512 * 2 ** 20);          // memory budget in bytes
//! for (let r; (r = s.nextRange()); ) {            // [start, end): the preamble, then each level
//!   const { bytes, total } = await fetchRange(url, r[0], r[1]);
//!   s.setFileLength(total);                       // from Content-Range
//!   s.push(r[0], bytes);
//!   const k = s.readyLevel();                     // the finest level whose bytes are all in
//!   if (k !== undefined) {
//!     const m = s.decode(k);                      // Float32Array positions, Uint32Array triangles
//!     draw(m.takePositions(), m.takeTriangles());
//!   }
//! }
//! ```
//!
//! `nextRange` asks for the preamble (at least [`stream::FIRST_REQUEST_BYTES`], which holds a
//! reconstruction's coarse levels too, so that the first frame needs one request) and then for
//! one level after the other. Decoding level `k` decodes the levels above it again (the format
//! codes each level against its decoded parent), about a third more work than decoding the finest
//! level alone. View-dependently ([`MrqView`]), each camera selects the chunks its view needs
//! (`octowrap_format::select`), `nextRanges` names the byte ranges of those not held (and of the
//! chunks the crack rule adds), and `cut` returns their crack-free mesh (spec §11.5).
//!
//! Errors reach JavaScript as `Error`s whose message names the byte offset: a truncated file, a
//! checksum that does not match, a file that goes on after its last level.
//!
//! # zstd in WebAssembly
//! The format's own decoder runs unchanged: the `zstd` crate's C library (zstd-sys), compiled for
//! `wasm32-unknown-unknown` by clang through zstd-sys's wasm shim (`CC_wasm32_unknown_unknown=clang`,
//! `AR_wasm32_unknown_unknown=llvm-ar`; `tools/viewer/build-wasm.sh`), rather than the pure-Rust
//! `ruzstd` decoder.
#![doc = include_str!("../ZSTD.md")]

pub mod stream;
pub mod view;

use wasm_bindgen::prelude::{JsError, wasm_bindgen};

use crate::stream::{LevelMesh, Stream};
use crate::view::View;

/// One MRQ file being streamed (JavaScript: `new MrqStream(budgetBytes)`).
#[wasm_bindgen]
pub struct MrqStream(Stream);

#[wasm_bindgen]
impl MrqStream {
    /// A stream fetching levels while their estimated decoding memory stays within
    /// `budget_bytes`.
    #[wasm_bindgen(constructor)]
    pub fn new(budget_bytes: f64) -> MrqStream {
        MrqStream(Stream::new(to_u64(budget_bytes)))
    }

    /// Adds the bytes fetched from `offset`.
    pub fn push(&mut self, offset: f64, bytes: &[u8]) -> Result<(), JsError> {
        Ok(self.0.push(to_u64(offset), bytes)?)
    }

    /// Records the file's total length (from `Content-Range`); fails when it differs from the
    /// length recorded before. `nextRange` fails when the level table does not fit the length.
    #[wasm_bindgen(js_name = setFileLength)]
    pub fn set_file_length(&mut self, len: f64) -> Result<(), JsError> {
        Ok(self.0.set_file_len(to_u64(len))?)
    }

    /// The next range to fetch as `[start, end)` (`Float64Array`), or `undefined` when done;
    /// throws for a truncated file or bytes after the last level.
    #[wasm_bindgen(js_name = nextRange)]
    pub fn next_range(&self) -> Result<Option<Vec<f64>>, JsError> {
        Ok(self.0.next_range()?.map(|r| vec![r.start as f64, r.end as f64]))
    }

    /// The finest level whose bytes have all arrived.
    #[wasm_bindgen(js_name = readyLevel)]
    pub fn ready_level(&self) -> Option<u32> {
        self.0.ready_level()
    }

    /// Decodes level `k` into triangle arrays.
    pub fn decode(&self, k: u32) -> Result<DecodedLevel, JsError> {
        Ok(DecodedLevel(self.0.decode(k)?))
    }

    /// Bytes received.
    pub fn held(&self) -> f64 {
        self.0.held() as f64
    }

    /// Levels in the file (0 before the preamble has arrived).
    #[wasm_bindgen(js_name = levelCount)]
    pub fn level_count(&self) -> u32 {
        self.0.info().map_or(0, |i| i.levels.len() as u32)
    }

    /// `[offset, stored bytes, vertices, faces]` of level `k` (`Float64Array`).
    #[wasm_bindgen(js_name = levelInfo)]
    pub fn level_info(&self, k: u32) -> Option<Vec<f64>> {
        let l = self.0.info()?.levels.get(k as usize)?;
        Some(vec![l.offset as f64, l.stored_size as f64, f64::from(l.vertex_count), f64::from(l.face_count)])
    }

    /// The octree cube as `[min x, y, z, max x, y, z]`, when the file records one.
    pub fn cube(&self) -> Option<Vec<f64>> {
        let (min, max) = self.0.info()?.cube?;
        Some([min, max].concat())
    }

    /// Estimated memory, in bytes, of decoding up to level `k`.
    #[wasm_bindgen(js_name = memoryEstimate)]
    pub fn memory_estimate(&self, k: u32) -> f64 {
        self.0.memory_estimate(k) as f64
    }
}

/// A decoded level (JavaScript: the result of `MrqStream.decode`).
#[wasm_bindgen]
pub struct DecodedLevel(LevelMesh);

#[wasm_bindgen]
impl DecodedLevel {
    /// The level's index.
    pub fn level(&self) -> u32 {
        self.0.level
    }

    /// Vertices.
    pub fn vertices(&self) -> u32 {
        (self.0.positions.len() / 3) as u32
    }

    /// Polygon faces.
    pub fn faces(&self) -> u32 {
        self.0.faces
    }

    /// Triangles.
    #[wasm_bindgen(js_name = triangleCount)]
    pub fn triangle_count(&self) -> u32 {
        (self.0.triangles.len() / 3) as u32
    }

    /// The positions (`Float32Array`, `x, y, z` per vertex); moves them out (a second call gives
    /// an empty array).
    #[wasm_bindgen(js_name = takePositions)]
    pub fn take_positions(&mut self) -> Vec<f32> {
        std::mem::take(&mut self.0.positions)
    }

    /// The triangles (`Uint32Array`, three vertex indices each); moves them out.
    #[wasm_bindgen(js_name = takeTriangles)]
    pub fn take_triangles(&mut self) -> Vec<u32> {
        std::mem::take(&mut self.0.triangles)
    }
}

/// A JavaScript number as a byte count or offset (negative and NaN as 0, beyond `u64` saturated).
fn to_u64(x: f64) -> u64 {
    if x.is_nan() || x <= 0.0 { 0 } else { x as u64 }
}

/// One chunked MRQ file viewed view-dependently (JavaScript: `new MrqView(budgetBytes)`; see
/// [`view`]).
///
/// ```js
/// const v = new MrqView(256 * 2 ** 20);
/// for (let r; (r = v.nextRanges()).length; )      // the preamble: [start, end, start, end, ...]
///   for (let i = 0; i < r.length; i += 2) v.push(r[i], (await fetchRange(url, r[i], r[i + 1])).bytes);
/// v.select([...eye, ...target, ...up, fovY, viewportHeight, pixelError], aspect);
/// let m;
/// while (!(m = v.cut()))                          // undefined: chunks it needs are still missing
///   for (const [s, e] of pairs(v.nextRanges())) v.push(s, (await fetchRange(url, s, e)).bytes);
/// draw(m.takePositions(), m.takeTriangles());
/// ```
#[wasm_bindgen]
pub struct MrqView(View);

#[wasm_bindgen]
impl MrqView {
    /// A view holding at most about `budget_bytes` of the file.
    #[wasm_bindgen(constructor)]
    pub fn new(budget_bytes: f64) -> MrqView {
        MrqView(View::new(to_u64(budget_bytes)))
    }

    /// Adds the bytes fetched from `offset`.
    pub fn push(&mut self, offset: f64, bytes: &[u8]) -> Result<(), JsError> {
        Ok(self.0.push(to_u64(offset), bytes)?)
    }

    /// Records the file's length (from `Content-Range`).
    #[wasm_bindgen(js_name = setFileLength)]
    pub fn set_file_length(&mut self, len: f64) -> Result<(), JsError> {
        Ok(self.0.set_file_len(to_u64(len))?)
    }

    /// Whether the preamble is in.
    #[wasm_bindgen(js_name = isOpen)]
    pub fn is_open(&self) -> bool {
        self.0.info().is_some()
    }

    /// The file's format version (0 before the preamble is in).
    pub fn version(&self) -> u32 {
        self.0.info().map_or(0, |i| u32::from(i.version))
    }

    /// Levels in the file.
    #[wasm_bindgen(js_name = levelCount)]
    pub fn level_count(&self) -> u32 {
        self.0.info().map_or(0, |i| i.levels.len() as u32)
    }

    /// Chunks in the file (one per level before version 5).
    #[wasm_bindgen(js_name = chunkCount)]
    pub fn chunk_count(&self) -> u32 {
        self.0.chunks().len() as u32
    }

    /// The box holding every chunk: `[xmin, ymin, zmin, xmax, ymax, zmax]`.
    pub fn bounds(&self) -> Vec<f64> {
        let mut b = [f64::MAX, f64::MAX, f64::MAX, f64::MIN, f64::MIN, f64::MIN];
        for c in self.0.chunks() {
            for a in 0..3 {
                b[a] = b[a].min(f64::from(c.bbox_min[a]));
                b[a + 3] = b[a + 3].max(f64::from(c.bbox_max[a]));
            }
        }
        b.to_vec()
    }

    /// Chooses the chunks for a camera: `[eye x, y, z, target x, y, z, up x, y, z, fov_y
    /// degrees, viewport height px, pixel error]` and the viewport's width over height.
    pub fn select(&mut self, camera: &[f64], aspect: f64) -> Result<(), JsError> {
        let [px, py, pz, tx, ty, tz, ux, uy, uz, fov_y_degrees, viewport_height_px, pixel_error] = camera[..] else {
            return Err(JsError::new("a camera is 12 numbers: eye, target, up, fov_y, viewport height, pixel error"));
        };
        let camera = octowrap_format::select::ViewCamera {
            position: [px, py, pz],
            target: [tx, ty, tz],
            up: [ux, uy, uz],
            fov_y_degrees,
            viewport_height_px,
            pixel_error,
        };
        self.0.select(&camera, aspect);
        Ok(())
    }

    /// The byte ranges to fetch next, as `[start, end, start, end, ...]` (end exclusive).
    #[wasm_bindgen(js_name = nextRanges)]
    pub fn next_ranges(&self) -> Result<Vec<f64>, JsError> {
        Ok(self.0.next_ranges()?.into_iter().flat_map(|(s, e)| [s as f64, e as f64]).collect())
    }

    /// The crack-free mesh of the selection, or `undefined` when chunks it needs are missing.
    pub fn cut(&mut self) -> Result<Option<DecodedLevel>, JsError> {
        Ok(self.0.cut()?.map(DecodedLevel))
    }

    /// What the last cut drew: `[chunks drawn, of the finest level, finest level drawn, chunks
    /// refined by the crack rule, unresolved seams]`.
    #[wasm_bindgen(js_name = lastCut)]
    pub fn last_cut(&self) -> Vec<f64> {
        let c = self.0.last_cut();
        [c.drawn, c.finest_drawn, c.finest_level, c.refined, c.unresolved].map(f64::from).to_vec()
    }

    /// Bytes held.
    pub fn held(&self) -> f64 {
        self.0.held() as f64
    }
}
