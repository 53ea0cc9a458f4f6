//! The `tileset.json` model: the subset of 3D Tiles 1.1 (OGC 22-025r4) the writer produces and
//! the checker reads.
//!
//! Field names are the specification's (`geometricError`, `boundingVolume`, ...); properties the
//! writer never sets are left out rather than written empty. Unknown properties are kept in
//! `other` when read, so the checker sees files from other producers as they are.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use serde_json::Value;

/// A whole `tileset.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Tileset {
    /// `asset`: the 3D Tiles version and generator.
    pub asset: Asset,
    /// The error, in metres, of not drawing the tileset at all.
    pub geometric_error: f64,
    /// The root tile.
    pub root: Tile,
    /// Extensions used by this tileset.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extensions_used: Vec<String>,
    /// Extensions required to load this tileset.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extensions_required: Vec<String>,
    /// Application data (the source's metadata).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extras: Option<Value>,
    /// Anything else found when reading.
    #[serde(flatten)]
    pub other: BTreeMap<String, Value>,
}

/// `asset`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Asset {
    /// `"1.1"` (or `"1.0"` in files of other producers).
    pub version: String,
    /// The program that wrote the tileset.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub generator: Option<String>,
    /// Anything else found when reading.
    #[serde(flatten)]
    pub other: BTreeMap<String, Value>,
}

/// A bounding volume: exactly one of `box`, `region`, `sphere` must be present.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BoundingVolume {
    /// Centre then three half-axis vectors (12 numbers).
    #[serde(rename = "box", default, skip_serializing_if = "Option::is_none")]
    pub bbox: Option<Vec<f64>>,
    /// West, south, east, north (radians), minimum and maximum height (metres).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<Vec<f64>>,
    /// Centre and radius (4 numbers).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sphere: Option<Vec<f64>>,
    /// Anything else found when reading.
    #[serde(flatten)]
    pub other: BTreeMap<String, Value>,
}

/// `content`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Content {
    /// The content's URI, relative to the tileset file (or a template under implicit tiling).
    pub uri: String,
    /// Anything else found when reading.
    #[serde(flatten)]
    pub other: BTreeMap<String, Value>,
}

/// `implicitTiling`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct ImplicitTiling {
    /// `"OCTREE"` or `"QUADTREE"`.
    pub subdivision_scheme: String,
    /// Levels in each subtree.
    pub subtree_levels: u32,
    /// Levels with tiles.
    pub available_levels: u32,
    /// The subtree files.
    pub subtrees: Subtrees,
}

/// `implicitTiling.subtrees`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Subtrees {
    /// The subtree URI template (`{level}`, `{x}`, `{y}`, `{z}`).
    pub uri: String,
}

/// A tile.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Tile {
    /// The volume holding this tile's content and all its descendants.
    pub bounding_volume: BoundingVolume,
    /// The error, in metres, of drawing this tile instead of its children.
    pub geometric_error: f64,
    /// `"REPLACE"` or `"ADD"` (required at the root, inherited below).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refine: Option<String>,
    /// Column-major 4x4 matrix from this tile's frame to its parent's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transform: Option<Vec<f64>>,
    /// The content.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub content: Option<Content>,
    /// Implicit tiling below this tile.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub implicit_tiling: Option<ImplicitTiling>,
    /// Children.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub children: Vec<Tile>,
    /// Anything else found when reading.
    #[serde(flatten)]
    pub other: BTreeMap<String, Value>,
}

impl BoundingVolume {
    /// A box from its minimum and maximum corners (axis-aligned in the tile's frame).
    pub fn aligned_box(min: [f64; 3], max: [f64; 3]) -> Self {
        let c = [0, 1, 2].map(|k| (min[k] + max[k]) * 0.5);
        let h = [0, 1, 2].map(|k| (max[k] - min[k]) * 0.5);
        Self { bbox: Some(vec![c[0], c[1], c[2], h[0], 0.0, 0.0, 0.0, h[1], 0.0, 0.0, 0.0, h[2]]), ..Self::default() }
    }
}
