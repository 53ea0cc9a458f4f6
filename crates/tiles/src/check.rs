//! Structural checks of a tileset, written from the 3D Tiles 1.1 specification (OGC 22-025r4):
//! what a validator would report, for any producer's `tileset.json` with glTF contents.
//!
//! The rules checked, each finding naming the tile by its path from the root (`root`,
//! `root/children/2`, ...):
//! * `asset.version` is `"1.0"` or `"1.1"` (§6.7.2); `geometricError` is present, finite and
//!   non-negative for the tileset and every tile (§6.5), and the root's is at most the
//!   tileset's;
//! * the root has `refine`, and every `refine` is `"ADD"` or `"REPLACE"` (§6.6);
//! * every bounding volume has exactly one of `box` (12 numbers, finite), `region` (6) and
//!   `sphere` (4, radius non-negative) (§6.3);
//! * a `transform` has 16 finite numbers and an affine last row (§6.4.3);
//! * **geometricError never grows from parent to child** (§6.5: a tile's error bounds its
//!   descendants' contribution);
//! * **child volumes inside the parent's** (§6.3.6; boxes, in the parent's frame through the
//!   child's transform, with a relative tolerance of `1e-9` of the parent's size);
//! * **content URIs resolve**: relative to the tileset's folder, to a file that is a GLB
//!   (`glTF` magic, version 2, its declared length the file's) (§6.8, §7.8).
//!
//! * **implicit tiling** (§6.8, octree scheme): the tile has a box or region and no explicit
//!   children; every subtree file reachable from the root parses (header, JSON, bitstreams long
//!   enough, 8-byte aligned); every available tile's parent is available, content only where a
//!   tile is, available contents resolve to GLBs, available child subtrees exist, and nothing is
//!   available below `availableLevels`. At most [`MAX_IMPLICIT_TILES`] tiles (and 16 times as
//!   many availability bits) are walked, and subtrees of at most 8 levels.
//!
//! The glTF contents themselves are checked by the Khronos glTF-Validator
//! (`tools/tiles-check/validate-tiles.mjs`), not here.

use std::path::{Component, Path};

use octowrap_geom::DVec3;

use crate::partition::Cell;
use crate::tileset::{BoundingVolume, ImplicitTiling, Tile, Tileset};
use crate::{Error, implicit};

/// Implicit tiles a check walks at most (a constant availability bit can declare `8^levels`).
pub const MAX_IMPLICIT_TILES: usize = 4_000_000;

/// What a check found: the tiles visited and the rule breaks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CheckReport {
    /// Tiles visited.
    pub tiles: usize,
    /// Content files that resolved.
    pub contents: Vec<std::path::PathBuf>,
    /// Rule breaks, each naming a tile.
    pub findings: Vec<String>,
}

/// Reads and checks `path` (a `tileset.json`). Fails only when the file cannot be read or is not a
/// tileset at all (JSON without the required objects); rule breaks are findings.
pub fn check_tileset(path: &Path) -> Result<CheckReport, Error> {
    let name = path.display().to_string();
    let text = std::fs::read(path).map_err(|e| Error::io(&name, e))?;
    let tileset: Tileset =
        serde_json::from_slice(&text).map_err(|e| Error::invalid(format!("{name}: not a 3D Tiles tileset: {e}")))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut r = CheckReport::default();
    if !matches!(tileset.asset.version.as_str(), "1.0" | "1.1") {
        r.findings.push(format!("asset.version is '{}', not 1.0 or 1.1", tileset.asset.version));
    }
    if !(tileset.geometric_error.is_finite() && tileset.geometric_error >= 0.0) {
        r.findings.push(format!("tileset geometricError {} is not a non-negative number", tileset.geometric_error));
    }
    if tileset.root.geometric_error > tileset.geometric_error {
        r.findings.push(format!(
            "root geometricError {} exceeds the tileset's {}",
            tileset.root.geometric_error, tileset.geometric_error
        ));
    }
    if tileset.root.refine.is_none() {
        r.findings.push("root: refine is required at the root".to_owned());
    }
    visit(&tileset.root, "root", dir, None, &mut r);
    Ok(r)
}

/// An oriented box: centre and half-axes.
#[derive(Clone, Copy)]
struct Obb {
    c: DVec3,
    h: [DVec3; 3],
}

impl Obb {
    fn from_volume(v: &BoundingVolume) -> Option<Self> {
        let b = v.bbox.as_ref().filter(|b| b.len() == 12)?;
        let at = |i: usize| DVec3::new(b[i], b[i + 1], b[i + 2]);
        Some(Self { c: at(0), h: [at(3), at(6), at(9)] })
    }

    fn corners(&self) -> impl Iterator<Item = DVec3> + '_ {
        (0..8).map(|i| {
            let s = |k: usize| if (i >> k) & 1 == 1 { 1.0 } else { -1.0 };
            self.c + self.h[0] * s(0) + self.h[1] * s(1) + self.h[2] * s(2)
        })
    }

    /// Whether `p` is inside, with a tolerance relative to the box's size. A flat box (a zero
    /// half-axis) is given the tolerance as its thickness along the normal of the other two.
    fn holds(&self, p: DVec3) -> bool {
        let d = p - self.c;
        let size: f64 = self.h.iter().map(|h| h.length()).sum::<f64>().max(f64::MIN_POSITIVE);
        let tol = 1e-9 * size;
        (0..3).all(|k| {
            let h = self.h[k];
            let h = if h.length_squared() > 0.0 {
                h
            } else {
                self.h[(k + 1) % 3].cross(self.h[(k + 2) % 3]).normalize_or_zero() * tol
            };
            let l2 = h.length_squared();
            l2 == 0.0 || (d.dot(h) / l2).abs() <= 1.0 + tol / l2.sqrt()
        })
    }
}

fn check_volume(v: &BoundingVolume, at: &str, r: &mut CheckReport) {
    let given = [v.bbox.is_some(), v.region.is_some(), v.sphere.is_some()].iter().filter(|&&g| g).count();
    if given != 1 {
        r.findings.push(format!("{at}: boundingVolume must have exactly one of box, region, sphere ({given} given)"));
        return;
    }
    let (what, values, want) = if let Some(b) = &v.bbox {
        ("box", b, 12)
    } else if let Some(g) = &v.region {
        ("region", g, 6)
    } else {
        ("sphere", v.sphere.as_ref().expect("one is given"), 4)
    };
    if values.len() != want || values.iter().any(|x| !x.is_finite()) {
        r.findings.push(format!("{at}: boundingVolume.{what} must be {want} finite numbers"));
    } else if what == "sphere" && values[3] < 0.0 {
        r.findings.push(format!("{at}: boundingVolume.sphere has a negative radius"));
    }
}

fn apply(m: &[f64], p: DVec3) -> DVec3 {
    DVec3::new(
        m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12],
        m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13],
        m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14],
    )
}

fn visit(tile: &Tile, at: &str, dir: &Path, parent: Option<(&Tile, Option<Obb>)>, r: &mut CheckReport) {
    r.tiles += 1;
    let e = tile.geometric_error;
    if !(e.is_finite() && e >= 0.0) {
        r.findings.push(format!("{at}: geometricError {e} is not a non-negative number"));
    }
    if let Some(refine) = &tile.refine {
        if refine != "ADD" && refine != "REPLACE" {
            r.findings.push(format!("{at}: refine '{refine}' is neither ADD nor REPLACE"));
        }
    }
    let transform_ok = match &tile.transform {
        Some(m) if m.len() != 16 || m.iter().any(|x| !x.is_finite()) => {
            r.findings.push(format!("{at}: transform must be 16 finite numbers"));
            false
        }
        #[allow(clippy::float_cmp)] // the affine row is exact by definition
        Some(m) if m[3] != 0.0 || m[7] != 0.0 || m[11] != 0.0 || m[15] != 1.0 => {
            r.findings.push(format!("{at}: transform's last row must be 0 0 0 1"));
            false
        }
        _ => true,
    };
    check_volume(&tile.bounding_volume, at, r);
    let own = Obb::from_volume(&tile.bounding_volume);
    if let Some((p, pbox)) = parent {
        if e > p.geometric_error {
            r.findings.push(format!("{at}: geometricError {e} exceeds its parent's {}", p.geometric_error));
        }
        if let (Some(pbox), Some(cbox), true) = (pbox, own, transform_ok) {
            let outside =
                cbox.corners().map(|c| tile.transform.as_ref().map_or(c, |m| apply(m, c))).find(|&c| !pbox.holds(c));
            if let Some(c) = outside {
                r.findings.push(format!("{at}: bounding box corner {c:?} lies outside the parent's box"));
            }
        }
    }
    // Under implicit tiling the content URI is a template, resolved per tile below.
    if let Some(content) = tile.content.as_ref().filter(|_| tile.implicit_tiling.is_none()) {
        match resolve(dir, &content.uri) {
            Err(why) => r.findings.push(format!("{at}: content uri '{}' {why}", content.uri)),
            Ok(file) => match glb_problem(&file) {
                Some(why) => r.findings.push(format!("{at}: content '{}' {why}", content.uri)),
                None => r.contents.push(file),
            },
        }
    }
    if let Some(imp) = &tile.implicit_tiling {
        check_implicit(tile, imp, at, dir, r);
    }
    for (i, child) in tile.children.iter().enumerate() {
        visit(child, &format!("{at}/children/{i}"), dir, Some((tile, own)), r);
    }
}

fn check_implicit(tile: &Tile, imp: &ImplicitTiling, at: &str, dir: &Path, r: &mut CheckReport) {
    if !tile.children.is_empty() {
        r.findings.push(format!("{at}: a tile with implicitTiling must not list children"));
    }
    if tile.bounding_volume.sphere.is_some() {
        r.findings.push(format!("{at}: implicit tiling needs a box or region, not a sphere"));
    }
    match imp.subdivision_scheme.as_str() {
        "OCTREE" => {}
        // Quadtrees are valid; this checker walks octrees only.
        "QUADTREE" => return,
        other => {
            r.findings.push(format!("{at}: subdivisionScheme '{other}' is neither QUADTREE nor OCTREE"));
            return;
        }
    }
    let (n, levels) = (imp.subtree_levels, imp.available_levels);
    if !(1..=8).contains(&n) || levels == 0 || levels > 31 {
        r.findings.push(format!(
            "{at}: subtreeLevels {n} and availableLevels {levels} must be positive (at most 8 and 31 here)"
        ));
        return;
    }
    let n = u8::try_from(n).expect("at most 8");
    let mut steps = 0usize;
    let content = tile.content.as_ref().map(|c| c.uri.as_str());
    let mut walked = 0usize;
    let mut roots = vec![(Cell::ROOT, true)];
    while let Some((root, root_parent)) = roots.pop() {
        let uri = implicit::fill(&imp.subtrees.uri, root);
        let sub_at = format!("{at}: subtree {uri}");
        let Some(sub) = read_subtree(dir, &uri, n, &sub_at, r) else { continue };
        if !sub.tiles.get(0) && root_parent {
            r.findings.push(format!("{sub_at}: its root tile is not available but the subtree is"));
        }
        for l in 0..=n {
            let count = 1u64 << (3 * u32::from(l));
            for m in 0..count {
                steps += 1;
                if steps > 16 * MAX_IMPLICIT_TILES {
                    r.findings.push(format!("{at}: the subtrees hold too many bits to walk; not walked further"));
                    return;
                }
                let rel = implicit::demorton(m, l);
                let cell = Cell { depth: root.depth + l, xyz: [0, 1, 2].map(|k| (root.xyz[k] << l) + rel[k]) };
                let parent_bit = (l > 0).then(|| implicit::bit_index(root, cell.parent()));
                if l == n {
                    if sub.children.get(m as usize) {
                        if u32::from(cell.depth) >= levels {
                            r.findings.push(format!("{sub_at}: child subtree {cell:?} lies below availableLevels"));
                        } else if parent_bit.is_some_and(|b| !sub.tiles.get(b)) {
                            r.findings.push(format!("{sub_at}: child subtree {cell:?} under an unavailable tile"));
                        } else {
                            roots.push((cell, true));
                        }
                    }
                    continue;
                }
                let bit = implicit::bit_index(root, cell);
                let (has_tile, has_content) = (sub.tiles.get(bit), sub.content.get(bit));
                if has_content && !has_tile {
                    r.findings.push(format!("{sub_at}: content of {cell:?} where no tile is available"));
                }
                if !has_tile {
                    continue;
                }
                walked += 1;
                if walked > MAX_IMPLICIT_TILES {
                    r.findings.push(format!("{at}: more than {MAX_IMPLICIT_TILES} implicit tiles; not walked further"));
                    return;
                }
                // The implicit root is the tile itself, counted already.
                r.tiles += usize::from(cell != Cell::ROOT);
                if u32::from(cell.depth) >= levels {
                    r.findings.push(format!("{sub_at}: tile {cell:?} lies below availableLevels {levels}"));
                }
                if parent_bit.is_some_and(|b| !sub.tiles.get(b)) {
                    r.findings.push(format!("{sub_at}: tile {cell:?} is available but its parent is not"));
                }
                if let (true, Some(template)) = (has_content, content) {
                    check_content(dir, &implicit::fill(template, cell), &sub_at, r);
                }
            }
        }
    }
}

/// The subtree file `uri` names, parsed; `None` with a finding when it cannot be read or parsed.
fn read_subtree(dir: &Path, uri: &str, n: u8, sub_at: &str, r: &mut CheckReport) -> Option<implicit::Subtree> {
    let bytes = match resolve(dir, uri) {
        Ok(file) => match std::fs::read(&file) {
            Ok(b) => b,
            Err(e) => {
                r.findings.push(format!("{sub_at} cannot be read: {e}"));
                return None;
            }
        },
        Err(why) => {
            r.findings.push(format!("{sub_at} {why}"));
            return None;
        }
    };
    implicit::Subtree::parse(&bytes, n).map_err(|why| r.findings.push(format!("{sub_at}: {why}"))).ok()
}

/// An implicit tile's content `uri`: it must resolve to a glb file, which joins the contents.
fn check_content(dir: &Path, uri: &str, sub_at: &str, r: &mut CheckReport) {
    match resolve(dir, uri) {
        Err(why) => r.findings.push(format!("{sub_at}: content uri '{uri}' {why}")),
        Ok(file) => match glb_problem(&file) {
            Some(why) => r.findings.push(format!("{sub_at}: content '{uri}' {why}")),
            None => r.contents.push(file),
        },
    }
}

/// The file a relative URI names under `dir`; absolute URIs, schemes, `..` and queries are refused
/// (a tileset on disk names files beside it).
fn resolve(dir: &Path, uri: &str) -> Result<std::path::PathBuf, String> {
    if uri.contains(':') || uri.starts_with('/') || uri.contains('?') || uri.contains('#') {
        return Err("is not a relative path".to_owned());
    }
    let decoded = percent_decode(uri).ok_or_else(|| "has a malformed percent escape".to_owned())?;
    let rel = Path::new(&decoded);
    if rel.components().any(|c| !matches!(c, Component::Normal(_) | Component::CurDir)) {
        return Err("leaves the tileset's folder".to_owned());
    }
    let file = dir.join(rel);
    if file.is_file() { Ok(file) } else { Err("does not resolve to a file".to_owned()) }
}

fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

fn glb_problem(file: &Path) -> Option<String> {
    let mut head = [0u8; 12];
    let read = std::fs::File::open(file).and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head));
    if let Err(e) = read {
        return Some(format!("cannot be read as GLB: {e}"));
    }
    if &head[..4] != b"glTF" {
        return Some("is not a GLB (no glTF magic)".to_owned());
    }
    let version = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    if version != 2 {
        return Some(format!("is GLB version {version}, not 2"));
    }
    let declared = u64::from(u32::from_le_bytes([head[8], head[9], head[10], head[11]]));
    let actual = std::fs::metadata(file).map_or(0, |m| m.len());
    (declared != actual).then(|| format!("declares {declared} bytes but has {actual}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_hold_their_corners() {
        let b = Obb { c: DVec3::ZERO, h: [DVec3::X, DVec3::Y * 2.0, DVec3::Z] };
        assert!(b.corners().all(|c| b.holds(c)));
        assert!(!b.holds(DVec3::new(0.0, 2.1, 0.0)));
        let flat = Obb { c: DVec3::ZERO, h: [DVec3::X, DVec3::Y, DVec3::ZERO] };
        assert!(flat.holds(DVec3::new(0.5, -0.5, 0.0)));
        assert!(!flat.holds(DVec3::new(0.5, -0.5, 0.1)));
    }

    #[test]
    fn uris_stay_in_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("a b.glb"), b"x").unwrap();
        assert!(resolve(dir.path(), "a%20b.glb").is_ok());
        assert!(resolve(dir.path(), "../a.glb").is_err());
        assert!(resolve(dir.path(), "/etc/passwd").is_err());
        assert!(resolve(dir.path(), "http://x/a.glb").is_err());
        assert!(resolve(dir.path(), "missing.glb").is_err());
        assert!(resolve(dir.path(), "a%2.glb").is_err());
    }
}
