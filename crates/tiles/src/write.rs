//! The writer: frame, partition, errors, contents, then `tileset.json`.

use std::path::{Path, PathBuf};

use octowrap_geom::{Aabb, DVec3};
use octowrap_mesh::Hierarchy;
use rayon::prelude::*;

use crate::content::LevelGeometry;
use crate::georef::{Frame, Georeference};
use crate::implicit;
use crate::partition::{Cell, Partition, TileTree};
use crate::tileset::{Asset, BoundingVolume, Content, ImplicitTiling, Subtrees, Tile, Tileset};
use crate::{Error, Summary, TilesOptions};

/// Moves every position into the tileset's local frame; returns the root transform (column-major)
/// and a description of the frame.
fn place(h: &mut Hierarchy, frame: &Frame) -> Result<([f64; 16], String), Error> {
    let mut b = Aabb::EMPTY;
    for l in &h.levels {
        for p in &l.mesh.vertices.positions {
            b.grow(*p);
        }
    }
    let origin = if b.is_empty() { DVec3::ZERO } else { b.center() };
    match frame {
        Frame::Local => {
            for l in &mut h.levels {
                l.mesh.vertices.positions.par_iter_mut().for_each(|p| *p -= origin);
            }
            h.cube = h.cube.map(|c| Aabb { min: c.min - origin, max: c.max - origin });
            let mut m = [0.0; 16];
            m[0] = 1.0;
            m[5] = 1.0;
            m[10] = 1.0;
            m[15] = 1.0;
            m[12..15].copy_from_slice(&origin.to_array());
            Ok((m, "local (no CRS): the input's own coordinates and units".to_owned()))
        }
        Frame::Crs(wkt) => {
            let g = Georeference::from_crs(wkt, origin)?;
            for l in &mut h.levels {
                let moved: Result<Vec<DVec3>, Error> =
                    l.mesh.vertices.positions.par_iter().map(|&p| g.to_local(p)).collect();
                l.mesh.vertices.positions = moved?;
            }
            // The octree cube of the CRS's coordinates is not a cube of the local frame.
            h.cube = None;
            Ok((g.world_from_local(), format!("EPSG:4978 from {}", g.proj_string)))
        }
    }
}

/// What one tile became.
#[derive(Clone, Copy)]
struct Made {
    error: f64,
    bounds: Aabb,
    bytes: u64,
}

pub(crate) fn write_tileset(
    path: &Path,
    mut h: Hierarchy,
    frame: &Frame,
    opts: &TilesOptions,
) -> Result<Summary, Error> {
    let name = path.display().to_string();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let file_opts = octowrap_fsutil::WriteOptions::no_clobber(opts.no_clobber);
    octowrap_fsutil::check_output(path, &file_opts).map_err(|e| Error::io(&name, e))?;
    let (world_from_local, frame_text) = place(&mut h, frame)?;
    let tree = opts.partition.tiles(&h)?;
    let implicit = opts.implicit.then(|| Implicit::of(&tree));
    let mut export = octowrap_export::ExportOptions::default();
    export.quantize = opts.quantize;
    export.meshopt = opts.meshopt;
    export.colors = opts.colors;
    let mut made: Vec<Option<Made>> = vec![None; tree.nodes.len()];
    for k in 0..h.levels.len() {
        for (i, m) in write_level(
            &h,
            k,
            &tree,
            &Out { dir: &dir, export: &export, flange: opts.flange, implicit: implicit.as_ref() },
        )? {
            made[i] = Some(m);
        }
    }
    let mut made: Vec<Made> = made.into_iter().map(|m| m.expect("every level was written")).collect();
    let subtree_bytes = settle(&tree, &mut made, implicit.as_ref(), &dir)?;
    let mut root = tile_json(&tree, &made, 0, implicit.as_ref());
    root.refine = Some("REPLACE".to_owned());
    root.transform = Some(world_from_local.to_vec());
    let diagonal = made[0].bounds.diagonal();
    let mut extras = serde_json::Map::new();
    extras.insert("frame".to_owned(), frame_text.clone().into());
    for (k, v) in &opts.metadata {
        extras.insert(k.clone(), v.clone().into());
    }
    let tileset = Tileset {
        asset: Asset {
            version: "1.1".to_owned(),
            generator: Some(format!("octowrap {}", env!("CARGO_PKG_VERSION"))),
            other: std::collections::BTreeMap::default(),
        },
        geometric_error: made[0].error.max(diagonal),
        root,
        extensions_used: Vec::new(),
        extensions_required: Vec::new(),
        extras: Some(serde_json::Value::Object(extras)),
        other: std::collections::BTreeMap::default(),
    };
    let json = serde_json::to_vec_pretty(&tileset).expect("the tileset holds only strings, numbers and maps");
    octowrap_fsutil::write_file(path, &file_opts, |w| w.write_all(&json))
        .map_err(|(octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e))| Error::io(&name, e))?;
    Ok(Summary {
        tiles: tree.nodes.len(),
        content_tiles: tree.nodes.iter().filter(|n| !n.faces.is_empty()).count(),
        levels: h.levels.len(),
        bytes: made.iter().map(|m| m.bytes).sum::<u64>() + json.len() as u64 + subtree_bytes,
        root_error: made[0].error,
        frame: frame_text,
    })
}

/// Where and how [`write_level`] writes its tiles.
struct Out<'a> {
    dir: &'a Path,
    export: &'a octowrap_export::ExportOptions,
    flange: bool,
    implicit: Option<&'a Implicit>,
}

/// Writes the tiles of level `k`: each tile's content (its faces and, with the flange, the ring
/// around them) and its measured error; returns each tile's node and what was made.
fn write_level(h: &Hierarchy, k: usize, tree: &TileTree, out: &Out<'_>) -> Result<Vec<(usize, Made)>, Error> {
    let level = &h.levels[k];
    let ids: Vec<usize> = (0..tree.nodes.len()).filter(|&i| tree.nodes[i].level == k).collect();
    let mut tile_of = vec![u32::MAX; level.mesh.faces.len()];
    for &i in &ids {
        for &f in &tree.nodes[i].faces {
            tile_of[f as usize] = i as u32;
        }
    }
    let geometry = LevelGeometry::new(&level.mesh);
    let finest_mesh = &h.levels[h.levels.len() - 1].mesh;
    let errors: Vec<f64> = ids
        .par_iter()
        .map(|&i| {
            let node = &tree.nodes[i];
            if k == h.levels.len() - 1 || node.faces.is_empty() {
                return 0.0;
            }
            let d = octowrap_decimate::metrics::certified_hausdorff(
                &level.mesh.subset(&node.faces),
                &finest_mesh.subset(&tree.regions[i]),
            );
            if d.upper.is_finite() { d.upper } else { 0.0 }
        })
        .collect();
    let push_back = errors.iter().copied().fold(0.0, f64::max);
    let written: Result<Vec<Made>, Error> = ids
        .par_iter()
        .zip(&errors)
        .map(|(&i, &error)| {
            let node = &tree.nodes[i];
            if node.faces.is_empty() {
                return Ok(Made { error, bounds: Aabb::EMPTY, bytes: 0 });
            }
            let flange = if out.flange { geometry.flange(&node.faces, &tile_of, i as u32) } else { Vec::new() };
            let mesh = geometry.content(&node.faces, &flange, push_back);
            let bounds = Aabb::from_points(
                mesh.vertices.positions.iter().map(|p| DVec3::new(p.x, -p.z, p.y)).collect::<Vec<_>>().iter(),
            );
            let (glb, _) = octowrap_export::to_glb(&Hierarchy::single(mesh), out.export)?;
            let file = out.dir.join(content_uri(tree, i, out.implicit));
            let shown = file.display().to_string();
            if let Some(parent) = file.parent() {
                std::fs::create_dir_all(parent).map_err(|e| Error::io(&shown, e))?;
            }
            octowrap_fsutil::write_file(&file, &octowrap_fsutil::WriteOptions::default(), |w| w.write_all(&glb))
                .map_err(|(octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e))| {
                    Error::io(&shown, e)
                })?;
            Ok(Made { error, bounds, bytes: glb.len() as u64 })
        })
        .collect();
    Ok(ids.into_iter().zip(written?).collect())
}

/// Raises every tile's error to its children's largest and its box to hold theirs (children
/// after parents); with implicit tiling, gives the implicit root the error that halves per level
/// without falling under any implicit tile's measured one, and writes the subtree files (returns
/// their bytes).
fn settle(tree: &TileTree, made: &mut [Made], implicit: Option<&Implicit>, dir: &Path) -> Result<u64, Error> {
    // Children after parents: walking backwards settles every child before its parent.
    for i in (0..tree.nodes.len()).rev() {
        for &c in &tree.nodes[i].children {
            let child = made[c];
            made[i].error = made[i].error.max(child.error);
            made[i].bounds = made[i].bounds.union(&child.bounds);
        }
    }
    if let Some(imp) = implicit {
        // The implicit root: the cube, and the error that halves per level without falling
        // under any implicit tile's measured one; the explicit tiles above it hold both.
        let root_error = (0..tree.nodes.len())
            .filter(|&i| tree.nodes[i].level >= imp.base)
            .map(|i| made[i].error * f64::from(1u32 << tree.nodes[i].cell.depth))
            .fold(0.0, f64::max);
        let mut i = imp.root;
        made[i].error = root_error;
        made[i].bounds = made[i].bounds.union(&tree.cube);
        while let Some(p) = (0..i).rev().find(|&p| tree.nodes[p].children.contains(&i)) {
            made[p].error = made[p].error.max(made[i].error);
            made[p].bounds = made[p].bounds.union(&made[i].bounds);
            i = p;
        }
        return write_subtrees(dir, tree, imp);
    }
    Ok(0)
}

/// Implicit tiling's place in the tree: the implicit root and its level.
struct Implicit {
    /// The hierarchy level of implicit level 0.
    base: usize,
    /// The implicit root's node.
    root: usize,
    /// Implicit levels (the deepest cell depth + 1).
    levels: u8,
    /// Levels per subtree file.
    subtree_levels: u8,
    /// `(cell, node)` of every implicit tile, sorted by cell.
    cells: Vec<(Cell, usize)>,
}

/// Levels per subtree file (fewer when the tree has fewer).
const SUBTREE_LEVELS: u8 = 3;
const CONTENT_TEMPLATE: &str = "implicit/{level}/{x}-{y}-{z}.glb";
const SUBTREE_TEMPLATE: &str = "subtrees/{level}/{x}-{y}-{z}.subtree";

impl Implicit {
    fn of(tree: &TileTree) -> Self {
        // The cut starts below the deepest tile over the whole cube.
        let root = (0..tree.nodes.len())
            .filter(|&i| tree.nodes[i].cell == Cell::ROOT)
            .max_by_key(|&i| tree.nodes[i].level)
            .expect("the root tile covers the cube");
        let base = tree.nodes[root].level;
        let mut cells: Vec<(Cell, usize)> =
            (0..tree.nodes.len()).filter(|&i| tree.nodes[i].level >= base).map(|i| (tree.nodes[i].cell, i)).collect();
        cells.sort_unstable();
        let levels = cells.iter().map(|(c, _)| c.depth).max().unwrap_or(0) + 1;
        Self { base, root, levels, subtree_levels: SUBTREE_LEVELS.min(levels), cells }
    }

    fn node(&self, cell: Cell) -> Option<usize> {
        self.cells.binary_search_by(|(c, _)| c.cmp(&cell)).ok().map(|k| self.cells[k].1)
    }
}

/// Writes every subtree file; returns their bytes.
fn write_subtrees(dir: &Path, tree: &TileTree, imp: &Implicit) -> Result<u64, Error> {
    let available = |c: Cell| imp.node(c).map(|i| !tree.nodes[i].faces.is_empty());
    let mut bytes = 0;
    let mut roots = vec![Cell::ROOT];
    while let Some(r) = roots.pop() {
        let (subtree, children) = implicit::build(r, imp.subtree_levels, &available);
        let data = subtree.to_bytes();
        let file = dir.join(implicit::fill(SUBTREE_TEMPLATE, r));
        let shown = file.display().to_string();
        if let Some(parent) = file.parent() {
            std::fs::create_dir_all(parent).map_err(|e| Error::io(&shown, e))?;
        }
        octowrap_fsutil::write_file(&file, &octowrap_fsutil::WriteOptions::default(), |w| w.write_all(&data)).map_err(
            |(octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e))| Error::io(&shown, e),
        )?;
        bytes += data.len() as u64;
        roots.extend(children.into_iter().rev());
    }
    Ok(bytes)
}

/// `tiles/LEVEL/DEPTH-X-Y-Z.glb`, or under implicit tiling `implicit/DEPTH/X-Y-Z.glb` below
/// the implicit root.
fn content_uri(tree: &TileTree, i: usize, implicit: Option<&Implicit>) -> String {
    let n = &tree.nodes[i];
    if implicit.is_some_and(|imp| n.level >= imp.base) {
        return implicit::fill(CONTENT_TEMPLATE, n.cell);
    }
    let [x, y, z] = n.cell.xyz;
    format!("tiles/{}/{}-{x}-{y}-{z}.glb", n.level, n.cell.depth)
}

fn tile_json(tree: &TileTree, made: &[Made], i: usize, implicit: Option<&Implicit>) -> Tile {
    let m = made[i];
    let b = if m.bounds.is_empty() { Aabb { min: DVec3::ZERO, max: DVec3::ZERO } } else { m.bounds };
    let mut tile = Tile {
        bounding_volume: BoundingVolume::aligned_box(b.min.to_array(), b.max.to_array()),
        geometric_error: m.error,
        refine: None,
        transform: None,
        content: (!tree.nodes[i].faces.is_empty())
            .then(|| Content { uri: content_uri(tree, i, implicit), other: std::collections::BTreeMap::default() }),
        implicit_tiling: None,
        children: Vec::new(),
        other: std::collections::BTreeMap::default(),
    };
    match implicit {
        Some(imp) if imp.root == i => {
            // Implicit tiles subdivide this tile's volume: the octree cube itself.
            let c = tree.cube;
            tile.bounding_volume = BoundingVolume::aligned_box(c.min.to_array(), c.max.to_array());
            tile.content =
                Some(Content { uri: CONTENT_TEMPLATE.to_owned(), other: std::collections::BTreeMap::default() });
            tile.implicit_tiling = Some(ImplicitTiling {
                subdivision_scheme: "OCTREE".to_owned(),
                subtree_levels: u32::from(imp.subtree_levels),
                available_levels: u32::from(imp.levels),
                subtrees: Subtrees { uri: SUBTREE_TEMPLATE.to_owned() },
            });
        }
        _ => tile.children = tree.nodes[i].children.iter().map(|&c| tile_json(tree, made, c, implicit)).collect(),
    }
    tile
}
