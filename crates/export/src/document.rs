//! The glTF document: buffer views, accessors, meshes and the node chain of the exported levels.
//!
//! Follows the glTF 2.0 specification §3.6 (buffers, views, accessors; vertex attributes aligned
//! to 4 bytes, so 3-component `i16`/`i8`/`u16` attributes use a padded `byteStride`), §3.7
//! (meshes), `KHR_mesh_quantization` (attribute types) and `EXT_meshopt_compression` (compressed
//! views over an empty fallback buffer).

use gltf_json as json;
use json::accessor::{ComponentType, GenericComponentType, Type};
use json::buffer::{Stride, Target};
use json::validation::Checked::Valid;
use json::validation::USize64;
use octowrap_geom::{DVec3, Vec3};
use octowrap_mesh::{Hierarchy, Rgb};
use serde_json::{Map, Value, json};

use crate::geometry::{self, Streams};
use crate::{Error, ExportOptions, LevelSummary, Levels, Summary, lod};

/// A document ready to be packed: its JSON model and the bytes of buffer 0.
pub(crate) struct Built {
    pub root: json::Root,
    pub bin: Vec<u8>,
    pub summary: Summary,
}

const MESHOPT: &str = "EXT_meshopt_compression";
const QUANTIZATION: &str = "KHR_mesh_quantization";
const LOD: &str = "MSFT_lod";

/// Largest `i16` grid coordinate (normalized-range symmetric, so `-32767..=32767`).
const Q16: f64 = 32767.0;

/// The exported levels, in `MSFT_lod` order (finest first).
fn chain(h: &Hierarchy, levels: Levels) -> Result<Vec<usize>, Error> {
    let n = h.levels.len();
    if n == 0 {
        return Err(Error::invalid("the input holds no levels"));
    }
    Ok(match levels {
        Levels::Finest => vec![n - 1],
        Levels::All => (0..n).rev().collect(),
        Levels::One(k) if k < n => vec![k],
        Levels::One(k) => {
            return Err(Error::invalid(format!(
                "level {k} does not exist: the input has {n} level{} (0 to {})",
                if n == 1 { "" } else { "s" },
                n - 1
            )));
        }
    })
}

fn check_options(opts: &ExportOptions) -> Result<Option<f64>, Error> {
    if !(opts.max_screen_error.is_finite() && opts.max_screen_error > 0.0) {
        return Err(Error::invalid(format!(
            "the tolerated screen error must be a positive number, not {}",
            opts.max_screen_error
        )));
    }
    match opts.crease_angle_deg {
        None => Ok(None),
        Some(a) if a.is_finite() && (0.0..=180.0).contains(&a) => Ok((a < 180.0).then(|| a.to_radians().cos())),
        Some(a) => Err(Error::invalid(format!("the crease angle must be between 0 and 180 degrees, not {a}"))),
    }
}

/// Builds the document for `h`; `bin_uri` is buffer 0's URI (`None` for GLB's binary chunk).
pub(crate) fn build(h: &Hierarchy, opts: &ExportOptions, bin_uri: Option<&str>) -> Result<Built, Error> {
    let crease_cos = check_options(opts)?;
    let chain = chain(h, opts.levels)?;
    let (mut streams, errors) = level_streams(h, &chain, crease_cos, opts.colors)?;
    if opts.meshopt {
        streams.iter_mut().for_each(reorder_for_meshopt);
    }
    let (lo, hi) = bounding_box(streams.iter().flat_map(|s| &s.positions));
    let grid = opts.quantize.then(|| Grid::new(lo, hi));
    let any_colors = streams.iter().any(|s| s.colors.is_some());

    let mut doc = Doc::new(opts.meshopt);
    let mut summary = Summary {
        levels: Vec::new(),
        screen_coverage: Vec::new(),
        extensions_used: Vec::new(),
        extensions_required: Vec::new(),
        bytes: 0,
    };
    for (i, (&k, s)) in chain.iter().zip(&streams).enumerate() {
        let primitive = doc.primitive(s, grid.as_ref())?;
        doc.root.meshes.push(level_mesh(h, k, errors[i], primitive));
        summary.levels.push(LevelSummary {
            level: k,
            source_faces: h.levels[k].mesh.faces.len(),
            vertices: s.positions.len(),
            triangles: s.indices.len() / 3,
            u32_indices: s.positions.len() > usize::from(u16::MAX),
            geometric_error: errors[i],
        });
    }
    // The switching hints use the finest level's bounding sphere.
    let (lo, hi) = bounding_box(&streams[0].positions);
    if chain.len() > 1 {
        summary.screen_coverage = lod::screen_coverage(&errors, 0.5 * (hi - lo).length(), opts.max_screen_error);
    }
    doc.root.nodes = nodes(&chain, grid.as_ref(), &summary.screen_coverage);
    doc.root.scenes.push(json::Scene {
        extensions: None,
        extras: None,
        name: Some("octowrap export".to_owned()),
        nodes: vec![json::Index::new(0)],
    });
    doc.root.scene = Some(json::Index::new(0));
    doc.root.materials.push(material(any_colors));
    (summary.extensions_used, summary.extensions_required) = extensions(opts, chain.len());
    doc.root.extensions_used.clone_from(&summary.extensions_used);
    doc.root.extensions_required.clone_from(&summary.extensions_required);
    doc.root.asset = asset(&opts.metadata);
    let bin = doc.finish(bin_uri);
    Ok(Built { root: doc.root, bin, summary })
}

/// Reorders triangles for the post-transform vertex cache and vertices by first use (meshoptimizer
/// `optimizeVertexCache`, `optimizeVertexFetchRemap`), which the `EXT_meshopt_compression` codecs
/// compress far better (its specification's non-normative advice). The same triangles, each with
/// its winding, on the same vertices: only the order changes, deterministically.
fn reorder_for_meshopt(s: &mut Streams) {
    let n = s.positions.len();
    let indices = match cache_order(&s.indices, n) {
        CacheOrder::Forsyth => meshopt::optimize_vertex_cache(&s.indices, n),
        CacheOrder::Tipsify => meshopt::optimize_vertex_cache_fifo(&s.indices, n, TIPSIFY_CACHE),
    };
    let remap = meshopt::optimize_vertex_fetch_remap(&indices, n);
    // Every vertex is used (the streams hold used vertices only), so `remap` is a permutation.
    if remap.len() != n || remap.iter().any(|&r| r as usize >= n) {
        return;
    }
    s.positions = permute(&s.positions, &remap);
    s.normals = permute(&s.normals, &remap);
    if let Some(c) = &s.colors {
        s.colors = Some(permute(c, &remap));
    }
    s.indices = indices.iter().map(|&i| remap[i as usize]).collect();
}

/// The two vertex cache optimizers of meshoptimizer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CacheOrder {
    /// `optimizeVertexCache` (Forsyth, "Linear-speed vertex cache optimisation", 2006, with
    /// meshoptimizer's tuned scores): the better order, but each emitted triangle rescores the
    /// triangles of every vertex in the cache, so a vertex of valence `k` costs `k²`.
    Forsyth,
    /// `optimizeVertexCacheFifo` (Sander, Nehab, Barczak, "Fast triangle reordering for vertex
    /// locality and reduced overdraw", SIGGRAPH 2007, "Tipsify"): linear time whatever the
    /// valences, a somewhat worse order.
    Tipsify,
}

/// Tipsify's cache size (a typical post-transform FIFO).
const TIPSIFY_CACHE: u32 = 16;

/// Forsyth's work, estimated as the sum of the squared vertex valences, may be this many times
/// the triangle count (a closed mesh of valence-6 vertices has 18); past it, Tipsify runs.
const FORSYTH_WORK_PER_TRIANGLE: u64 = 1024;

/// The optimizer for `indices`: Forsyth unless some vertices' valences make it quadratic (a fan
/// of a hundred thousand triangles around one vertex).
fn cache_order(indices: &[u32], vertices: usize) -> CacheOrder {
    let mut valence = vec![0u64; vertices];
    for &i in indices {
        if let Some(v) = valence.get_mut(i as usize) {
            *v += 1;
        }
    }
    let work: u64 = valence.iter().map(|k| k * k).sum();
    let triangles = (indices.len() / 3) as u64;
    if work <= FORSYTH_WORK_PER_TRIANGLE.saturating_mul(triangles.max(1)) {
        CacheOrder::Forsyth
    } else {
        CacheOrder::Tipsify
    }
}

/// `v` with element `i` moved to `remap[i]` (`remap` a permutation).
fn permute<T: Copy>(v: &[T], remap: &[u32]) -> Vec<T> {
    let mut out = v.to_vec();
    for (old, &new) in remap.iter().enumerate() {
        out[new as usize] = v[old];
    }
    out
}

/// Component-wise bounds of `points` (infinite and inverted when there are none).
fn bounding_box<'a>(points: impl IntoIterator<Item = &'a DVec3>) -> (DVec3, DVec3) {
    points
        .into_iter()
        .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), &p| (lo.min(p), hi.max(p)))
}

/// Checks every exported level and builds its streams; also returns the levels' geometric errors.
fn level_streams(
    h: &Hierarchy,
    chain: &[usize],
    crease_cos: Option<f64>,
    colors: bool,
) -> Result<(Vec<Streams>, Vec<f64>), Error> {
    let mut streams = Vec::with_capacity(chain.len());
    let mut errors = Vec::with_capacity(chain.len());
    for &k in chain {
        let mesh = &h.levels[k].mesh;
        mesh.check_indices().map_err(|e| Error::invalid(format!("level {k}: {e}")))?;
        if mesh.faces.is_empty() {
            return Err(Error::invalid(format!(
                "level {k} has no faces: glTF export writes surfaces (reconstruct a point cloud first)"
            )));
        }
        let s = geometry::build(mesh, crease_cos, colors);
        if s.indices.is_empty() {
            return Err(Error::invalid(format!(
                "level {k}: every triangle of its {} faces names a vertex twice, so none has an area to draw",
                mesh.faces.len()
            )));
        }
        if let Some(p) = s.positions.iter().find(|p| !p.is_finite()) {
            return Err(Error::invalid(format!("level {k}: a face uses a vertex at a non-finite position {p}")));
        }
        if let Some(p) = s.positions.iter().find(|p| !p.as_vec3().is_finite()) {
            return Err(Error::limit(format!("level {k}: position {p} is beyond the range of f32")));
        }
        errors.push(lod::mean_edge_length(mesh));
        streams.push(s);
    }
    Ok((streams, errors))
}

/// Level `k`'s mesh, its numbers in `extras.octowrap`.
fn level_mesh(h: &Hierarchy, k: usize, error: f64, primitive: json::mesh::Primitive) -> json::Mesh {
    let mesh = &h.levels[k].mesh;
    let extras = json!({ "octowrap": {
        "level": k,
        "source_faces": mesh.faces.len(),
        "source_quads": mesh.faces.iter().filter(|f| f.len() == 4).count(),
        "source_vertices": mesh.vertex_count(),
        "geometric_error": error,
        "geometric_error_kind": "mean edge length",
    }});
    json::Mesh {
        extensions: None,
        extras: raw(&extras),
        name: Some(format!("level {k}")),
        primitives: vec![primitive],
        weights: None,
    }
}

/// Node `i` shows mesh `i` (level `chain[i]`); node 0, the finest, carries the `MSFT_lod` chain and
/// its `MSFT_screencoverage` hints, and is the scene's only root.
fn nodes(chain: &[usize], grid: Option<&Grid>, coverage: &[f64]) -> Vec<json::Node> {
    let chained = chain.len() > 1;
    chain
        .iter()
        .enumerate()
        .map(|(i, &k)| {
            let mut node = json::Node {
                mesh: Some(json::Index::new(i as u32)),
                name: Some(if i == 0 && chained {
                    format!("level {k} (finest of the LOD chain)")
                } else {
                    format!("level {k}")
                }),
                ..json::Node::default()
            };
            if let Some(g) = grid {
                node.translation = Some(g.origin.to_array());
                node.scale = Some([g.step; 3]);
            }
            if i == 0 && chained {
                let ids: Vec<u32> = (1..chain.len() as u32).collect();
                let mut ext = json::extensions::scene::Node::default();
                ext.others.insert(LOD.to_owned(), json!({ "ids": ids }));
                node.extensions = Some(ext);
                node.extras = raw(&json!({ "MSFT_screencoverage": coverage }));
            }
            node
        })
        .collect()
}

/// `extensionsUsed` and `extensionsRequired`, sorted.
fn extensions(opts: &ExportOptions, levels: usize) -> (Vec<String>, Vec<String>) {
    let mut used = Vec::new();
    let mut required = Vec::new();
    if opts.meshopt {
        used.push(MESHOPT.to_owned());
        required.push(MESHOPT.to_owned());
    }
    if opts.quantize {
        used.push(QUANTIZATION.to_owned());
        required.push(QUANTIZATION.to_owned());
    }
    if levels > 1 {
        used.push(LOD.to_owned());
    }
    used.sort();
    required.sort();
    (used, required)
}

/// The asset: version, generator, and the input's metadata in `extras.octowrap`.
fn asset(metadata: &[(String, String)]) -> json::Asset {
    let metadata: Map<String, Value> = metadata.iter().map(|(k, v)| (k.clone(), Value::from(v.as_str()))).collect();
    json::Asset {
        copyright: None,
        extensions: None,
        extras: if metadata.is_empty() { None } else { raw(&json!({ "octowrap": metadata })) },
        generator: Some(format!("octowrap-export {}", env!("CARGO_PKG_VERSION"))),
        min_version: None,
        version: "2.0".to_owned(),
    }
}

/// The `i16` position grid shared by every exported level: world = origin + step * q.
struct Grid {
    origin: Vec3,
    step: f32,
}

impl Grid {
    fn new(lo: DVec3, hi: DVec3) -> Self {
        let half = ((hi - lo) * 0.5).max_element();
        let step = if half > 0.0 && (half / Q16) as f32 > 0.0 { (half / Q16) as f32 } else { 1.0 };
        Self { origin: ((lo + hi) * 0.5).as_vec3(), step }
    }

    fn quantize(&self, p: DVec3) -> [i16; 3] {
        let q = (p - self.origin.as_dvec3()) / f64::from(self.step);
        q.to_array().map(|c| c.round().clamp(-Q16, Q16) as i16)
    }
}

fn material(any_colors: bool) -> json::Material {
    let base = if any_colors { [1.0; 4] } else { [0.8, 0.8, 0.8, 1.0] };
    json::Material {
        name: Some("octowrap surface".to_owned()),
        double_sided: true,
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor(base),
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(0.7),
            ..Default::default()
        },
        ..Default::default()
    }
}

/// `v` as an `extras` value.
fn raw(v: &Value) -> json::Extras {
    serde_json::value::RawValue::from_string(v.to_string()).ok()
}

/// 8-bit sRGB to 16-bit linear (glTF vertex colours are linear).
fn srgb_to_linear16(c: u8) -> u16 {
    let s = f64::from(c) / 255.0;
    let l = if s <= 0.04045 { s / 12.92 } else { ((s + 0.055) / 1.055).powf(2.4) };
    (l * 65535.0).round() as u16
}

/// A buffer view under construction, with its compressed form when meshopt is on.
struct PendingView {
    offset: usize,
    len: usize,
    stride: usize,
    count: usize,
    vertex: bool,
    compressed: Option<Vec<u8>>,
}

struct Doc {
    root: json::Root,
    data: Vec<u8>,
    views: Vec<PendingView>,
    meshopt: bool,
}

impl Doc {
    fn new(meshopt: bool) -> Self {
        Self { root: json::Root::default(), data: Vec::new(), views: Vec::new(), meshopt }
    }

    /// Appends a view of `count` elements of `stride` bytes at a 4-byte boundary.
    fn view(&mut self, bytes: &[u8], stride: usize, vertex: bool, index_vertices: usize) -> Result<u32, Error> {
        while self.data.len() % 4 != 0 {
            self.data.push(0);
        }
        let count = bytes.len() / stride;
        let compressed = if self.meshopt {
            Some(if vertex {
                encode_attributes(bytes, stride)?
            } else {
                encode_triangles(bytes, stride, index_vertices)?
            })
        } else {
            None
        };
        self.views.push(PendingView { offset: self.data.len(), len: bytes.len(), stride, count, vertex, compressed });
        self.data.extend_from_slice(bytes);
        Ok(self.views.len() as u32 - 1)
    }

    fn accessor(
        &mut self,
        view: u32,
        count: usize,
        ct: ComponentType,
        ty: Type,
        normalized: bool,
        bounds: Option<(Value, Value)>,
    ) -> json::Index<json::Accessor> {
        let (min, max) = bounds.map_or((None, None), |(a, b)| (Some(a), Some(b)));
        self.root.accessors.push(json::Accessor {
            buffer_view: Some(json::Index::new(view)),
            byte_offset: None,
            count: USize64(count as u64),
            component_type: Valid(GenericComponentType(ct)),
            extensions: None,
            extras: None,
            type_: Valid(ty),
            min,
            max,
            name: None,
            normalized,
            sparse: None,
        });
        json::Index::new(self.root.accessors.len() as u32 - 1)
    }

    fn primitive(&mut self, s: &Streams, grid: Option<&Grid>) -> Result<json::mesh::Primitive, Error> {
        let n = s.positions.len();
        let mut attributes = std::collections::BTreeMap::new();
        // POSITION
        let position = if let Some(g) = grid {
            let q: Vec<[i16; 4]> = s
                .positions
                .iter()
                .map(|&p| {
                    let [x, y, z] = g.quantize(p);
                    [x, y, z, 0]
                })
                .collect();
            let (lo, hi) = bounds(q.iter().map(|v| [v[0], v[1], v[2]].map(f64::from)));
            let view = self.view(bytemuck::cast_slice(&q), 8, true, 0)?;
            self.accessor(view, n, ComponentType::I16, Type::Vec3, false, Some((json!(lo), json!(hi))))
        } else {
            let f: Vec<[f32; 3]> = s.positions.iter().map(|p| p.as_vec3().to_array()).collect();
            let (lo, hi) = bounds(f.iter().map(|v| v.map(f64::from)));
            let view = self.view(bytemuck::cast_slice(&f), 12, true, 0)?;
            self.accessor(view, n, ComponentType::F32, Type::Vec3, false, Some((json!(lo), json!(hi))))
        };
        attributes.insert(Valid(json::mesh::Semantic::Positions), position);
        // NORMAL
        let normal = if grid.is_some() {
            let q: Vec<[i8; 4]> = s
                .normals
                .iter()
                .map(|n| {
                    let [x, y, z] = n.to_array().map(|c| (c * 127.0).round().clamp(-127.0, 127.0) as i8);
                    [x, y, z, 0]
                })
                .collect();
            let view = self.view(bytemuck::cast_slice(&q), 4, true, 0)?;
            self.accessor(view, n, ComponentType::I8, Type::Vec3, true, None)
        } else {
            let f: Vec<[f32; 3]> = s.normals.iter().map(Vec3::to_array).collect();
            let view = self.view(bytemuck::cast_slice(&f), 12, true, 0)?;
            self.accessor(view, n, ComponentType::F32, Type::Vec3, false, None)
        };
        attributes.insert(Valid(json::mesh::Semantic::Normals), normal);
        // COLOR_0
        if let Some(colors) = &s.colors {
            let c: Vec<[u16; 4]> = colors
                .iter()
                .map(|&[r, g, b]: &Rgb| [srgb_to_linear16(r), srgb_to_linear16(g), srgb_to_linear16(b), 0])
                .collect();
            let view = self.view(bytemuck::cast_slice(&c), 8, true, 0)?;
            let color = self.accessor(view, n, ComponentType::U16, Type::Vec3, true, None);
            attributes.insert(Valid(json::mesh::Semantic::Colors(0)), color);
        }
        // Indices: u16 while every index stays below the primitive-restart value 65535.
        let indices = if u16::try_from(n).is_ok() {
            let i: Vec<u16> = s.indices.iter().map(|&i| i as u16).collect();
            let view = self.view(bytemuck::cast_slice(&i), 2, false, n)?;
            self.accessor(view, i.len(), ComponentType::U16, Type::Scalar, false, None)
        } else {
            let view = self.view(bytemuck::cast_slice(&s.indices), 4, false, n)?;
            self.accessor(view, s.indices.len(), ComponentType::U32, Type::Scalar, false, None)
        };
        Ok(json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: None,
            indices: Some(indices),
            material: Some(json::Index::new(0)),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        })
    }

    /// Writes the views and buffers into the JSON model; returns buffer 0's bytes.
    fn finish(&mut self, bin_uri: Option<&str>) -> Vec<u8> {
        while self.data.len() % 4 != 0 {
            self.data.push(0);
        }
        let mut compressed = Vec::new();
        for v in &self.views {
            let mut view = json::buffer::View {
                buffer: json::Index::new(0),
                byte_length: USize64(v.len as u64),
                byte_offset: Some(USize64(v.offset as u64)),
                byte_stride: v.vertex.then_some(Stride(v.stride)),
                name: None,
                target: Some(Valid(if v.vertex { Target::ArrayBuffer } else { Target::ElementArrayBuffer })),
                extensions: None,
                extras: None,
            };
            if let Some(c) = &v.compressed {
                while compressed.len() % 4 != 0 {
                    compressed.push(0);
                }
                let ext = json!({
                    "buffer": 0,
                    "byteOffset": compressed.len(),
                    "byteLength": c.len(),
                    "byteStride": v.stride,
                    "count": v.count,
                    "mode": if v.vertex { "ATTRIBUTES" } else { "TRIANGLES" },
                });
                compressed.extend_from_slice(c);
                view.buffer = json::Index::new(1);
                view.extensions =
                    Some(json::extensions::buffer::View { others: Map::from_iter([(MESHOPT.to_owned(), ext)]) });
            }
            self.root.buffer_views.push(view);
        }
        let buffer = |len: usize, uri: Option<&str>| json::Buffer {
            byte_length: USize64(len as u64),
            name: None,
            uri: uri.map(str::to_owned),
            extensions: None,
            extras: None,
        };
        if self.meshopt {
            while compressed.len() % 4 != 0 {
                compressed.push(0);
            }
            self.root.buffers.push(buffer(compressed.len(), bin_uri));
            let mut fallback = buffer(self.data.len(), None);
            fallback.extensions = Some(json::extensions::buffer::Buffer {
                others: Map::from_iter([(MESHOPT.to_owned(), json!({ "fallback": true }))]),
            });
            self.root.buffers.push(fallback);
            compressed
        } else {
            self.root.buffers.push(buffer(self.data.len(), bin_uri));
            std::mem::take(&mut self.data)
        }
    }
}

/// Component-wise minimum and maximum.
fn bounds(values: impl Iterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    values.fold(([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]), |(lo, hi), v| {
        (std::array::from_fn(|i| lo[i].min(v[i])), std::array::from_fn(|i| hi[i].max(v[i])))
    })
}

/// meshopt attribute codec, version 0 (the only one `EXT_meshopt_compression` allows).
fn encode_attributes(bytes: &[u8], stride: usize) -> Result<Vec<u8>, Error> {
    let r = match stride {
        4 => meshopt::encode_vertex_buffer_level(bytemuck::cast_slice::<u8, [u8; 4]>(bytes), 2, Some(0)),
        8 => meshopt::encode_vertex_buffer_level(bytemuck::cast_slice::<u8, [u8; 8]>(bytes), 2, Some(0)),
        12 => meshopt::encode_vertex_buffer_level(bytemuck::cast_slice::<u8, [u8; 12]>(bytes), 2, Some(0)),
        _ => unreachable!("the exporter writes vertex strides of 4, 8 and 12 bytes only"),
    };
    r.map_err(|e| Error::invalid(format!("meshopt could not encode a vertex stream: {e}")))
}

/// meshopt triangle index codec.
fn encode_triangles(bytes: &[u8], stride: usize, vertices: usize) -> Result<Vec<u8>, Error> {
    let indices: Vec<u32> = if stride == 2 {
        bytemuck::cast_slice::<u8, u16>(bytes).iter().map(|&i| u32::from(i)).collect()
    } else {
        bytemuck::cast_slice::<u8, u32>(bytes).to_vec()
    };
    meshopt::encode_index_buffer(&indices, vertices)
        .map_err(|e| Error::invalid(format!("meshopt could not encode an index stream: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_huge_fan_is_ordered_in_linear_time() {
        // A grid: Forsyth.
        let k = 100u32;
        let mut grid = Vec::new();
        for y in 0..k - 1 {
            for x in 0..k - 1 {
                let v = y * k + x;
                grid.extend([v, v + 1, v + k + 1, v, v + k + 1, v + k]);
            }
        }
        assert_eq!(cache_order(&grid, (k * k) as usize), CacheOrder::Forsyth);
        // A cone of 200,000 triangles around one apex: Forsyth would take minutes.
        let n = 200_000u32;
        let fan: Vec<u32> = (0..n).flat_map(|i| [0, 1 + i, 1 + (i + 1) % n]).collect();
        assert_eq!(cache_order(&fan, n as usize + 1), CacheOrder::Tipsify);
        // Reordered, the same triangles with the same windings (vertex x = its input number).
        let mut s = Streams {
            positions: (0..=n).map(|i| DVec3::new(f64::from(i), 0.0, 0.0)).collect(),
            normals: vec![geometry::FALLBACK_NORMAL; n as usize + 1],
            colors: None,
            indices: fan.clone(),
        };
        reorder_for_meshopt(&mut s);
        let canonical = |idx: &[u32], id: &dyn Fn(u32) -> u32| {
            let mut t: Vec<[u32; 3]> = idx
                .chunks(3)
                .map(|c| {
                    let t = [id(c[0]), id(c[1]), id(c[2])];
                    let r = (0..3).min_by_key(|&r| t[r]).unwrap_or(0);
                    [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]
                })
                .collect();
            t.sort_unstable();
            t
        };
        let moved = canonical(&s.indices, &|i| s.positions[i as usize].x as u32);
        assert_eq!(moved, canonical(&fan, &|i| i));
    }

    #[test]
    fn srgb_endpoints_and_midpoint() {
        assert_eq!(srgb_to_linear16(0), 0);
        assert_eq!(srgb_to_linear16(255), 65535);
        // sRGB 0.5 is about 21.4 % linear.
        assert!((f64::from(srgb_to_linear16(128)) / 65535.0 - 0.2158).abs() < 1e-3);
    }

    #[test]
    fn grid_spans_the_box_symmetrically() {
        let g = Grid::new(DVec3::new(-1.0, 0.0, 2.0), DVec3::new(3.0, 1.0, 2.5));
        assert_eq!(g.quantize(DVec3::new(-1.0, 0.5, 2.25)), [-32767, 0, 0]);
        assert_eq!(g.quantize(DVec3::new(3.0, 0.5, 2.25)), [32767, 0, 0]);
        // A flat or single-point box still gives a usable (non-zero) step.
        assert!(Grid::new(DVec3::ONE, DVec3::ONE).step > 0.0);
    }
}
