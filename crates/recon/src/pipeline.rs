//! The reconstruction pipeline in the order of the paper's §3 (Keller, Hering-Bertram & Hagen):
//! partition the points into an octree (§3.2) and find the deepest level the sampling density
//! supports (§4.2); start from the root cube's six faces (§3.3); then for every level refine the
//! faces of the level above regularly (§3.4) and irregularly (§3.5), or subdivide them past the
//! density limit (§4.2); map the new vertices onto the points (§3.6), relax them (§3.6.1) and fit
//! them to the points by least squares (beyond the paper).
//!
//! [`reconstruct_with_progress`] is the sequence; each step is one function below, named for what
//! it does, and the stage modules do the work.

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use octowrap_geom::{DVec3, morton};
use octowrap_mesh::{FaceList, FaceOrigin, Hierarchy, Level, LevelLattice, Mesh, PointCloud};
use rayon::prelude::*;

use octowrap_format::LineOrigin;

use crate::irregular::Decisions;
use crate::lattice::{MAX_LEVEL, unslot};
use crate::lines::{LineRun, LocalLine};
use crate::mapping::TangentPlane;
use crate::octree::{Octree, voxel_size};
use crate::rankmap::RankMap;
use crate::{
    AUTO_CAP, DecoderGrid, Error, LevelKind, LevelReport, MaxLevel, Progress, ReconOptions, Reconstruction, SparseMode,
    Stage, StageTimings,
};
use crate::{autolevel, extract, irregular, least_squares, mapping, regions, regular, relax, sheet, sparse, untangle};

/// Near decoder lines ([`ReconOptions::line_reach`] finite): the fit's free passes at most,
/// before the vertices within reach of their lines go onto them.
const FREE_PASSES: u32 = 2;

/// Near decoder lines: the fit's passes after the snap, which move the line vertices along
/// their lines only (measured on the bunny, one leaves its level 6 at +6 % points-to-mesh RMS
/// against the free level, two at +2.5 %).
const CONSTRAINED_PASSES: u32 = 2;

/// Like [`crate::reconstruct`], reporting progress through `progress` (called on the calling
/// thread at the start of every stage of every level) and returning per-level figures and timings.
pub fn reconstruct_with_progress(
    points: &[DVec3],
    opts: &ReconOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Reconstruction, Error> {
    check_input(points, opts)?;
    let mut run = Run::partition(points, opts, progress)?;
    let (mut prev, root_report) = run.root_cube(points.len());
    let mut lines = run.line_run()?;
    let mut levels = vec![prev.take_level(&run.tree, false)];
    if let Some(lr) = &mut lines {
        lr.push(&levels[0])?;
    }
    let mut reports = vec![root_report];
    let mut j = 0;
    while j < run.finest {
        j += 1;
        let finest = run.finest;
        let mut stage = |s| progress(Progress { level: j, levels: finest, stage: s });
        let mut rep = run.prepare_level(j);
        let mut next = if j <= run.trusted {
            run.wrap_level(j, &prev, &mut rep, &mut stage)
        } else {
            run.subdivide_level(j, &prev, &mut rep, &mut stage)?
        };
        // The level above is not needed any more (its output level is already built).
        drop(std::mem::take(&mut prev));
        let mut on = match &lines {
            Some(lr) => next.decoder_lines(&run.tree, lr, rep.kind)?,
            None => Vec::new(),
        };
        run.place_vertices(j, &mut next, &mut rep, &mut stage, &mut on);
        if run.auto_level(j, &next) == autolevel::Verdict::Drop {
            break;
        }
        if let Some(lr) = &lines {
            lr.snap(&mut next.positions, &on);
            rep.on_lines = on.iter().filter(|l| l.is_some()).count();
        }
        rep.faces = next.quads.len();
        rep.vertices = next.corners.len();
        let mut level = next.take_level(&run.tree, j == run.finest);
        untangle_level(&mut level, opts, &mut rep);
        if let Some(lr) = &mut lines {
            lr.exact(&mut level.mesh.vertices.positions);
            if j < run.finest {
                lr.push(&level)?;
            }
        }
        levels.push(level);
        reports.push(rep);
        prev = next;
    }
    let hierarchy = Hierarchy { levels, cube: Some(run.tree.frame.cube()) };
    let auto = run.auto.take().and_then(|a| a.finish(run.tree.frame.edge));
    let line_grid = lines.map(|lr| lr.grid());
    Ok(Reconstruction { hierarchy, levels: reports, trusted_level: run.trusted, auto, line_grid })
}

/// Rejects input that cannot be reconstructed: no points, non-finite coordinates, more points
/// than 32-bit indices hold, a requested level outside `1..=MAX_LEVEL`.
fn check_input(points: &[DVec3], opts: &ReconOptions) -> Result<(), Error> {
    if points.is_empty() {
        return Err(Error::Empty);
    }
    let bad = points.par_iter().filter(|p| !p.is_finite()).count();
    if bad > 0 {
        return Err(Error::NonFinite { count: bad, total: points.len() });
    }
    let max_points = u32::MAX as usize - 1;
    if points.len() > max_points {
        return Err(Error::TooManyPoints { count: points.len(), max: max_points });
    }
    if let MaxLevel::Level(n) = opts.max_level {
        if n == 0 || n > MAX_LEVEL {
            return Err(Error::BadLevel { requested: n, max: MAX_LEVEL });
        }
    }
    Ok(())
}

/// Whether trusted levels are decided per region (module `regions`).
fn regions_on(opts: &ReconOptions) -> bool {
    let tau = opts.region_density;
    opts.sparse == SparseMode::Subdivide && opts.region_levels > 0 && tau.is_finite() && tau > 0.0
}

/// The state the levels share: the octree, the level bounds, and what a wrapped level hands to
/// the next one's filled voxels.
struct Run<'a> {
    opts: &'a ReconOptions,
    tree: Octree,
    /// Partitioning time per octree level.
    part_times: Vec<Duration>,
    /// The finest level built.
    finest: u32,
    /// The deepest level wrapped (deeper levels are subdivided).
    trusted: u32,
    /// The deepest level the global density criterion trusts: sparse regions start below it.
    global: u32,
    /// Whether sparse regions are marked ([`regions_on`]).
    regions: bool,
    /// The mask of the wrapped level above, for the next level's filled voxels.
    prev_mask: Option<sheet::Mask>,
    /// The flipped diagonal decisions of every wrapped level so far (level 0's empty).
    flips_by_level: Vec<BTreeSet<(u64, u64)>>,
    /// The choice of the finest level past the trusted one ([`MaxLevel::Auto`]).
    auto: Option<autolevel::AutoLevel>,
}

impl<'a> Run<'a> {
    /// §3.2 with §4.2: partitions the points into an octree as deep as the levels need, and
    /// decides the finest level built and the deepest level wrapped.
    fn partition(points: &[DVec3], opts: &'a ReconOptions, progress: &mut dyn FnMut(Progress)) -> Result<Self, Error> {
        let padding = if opts.padding.is_finite() { opts.padding.clamp(0.0, 1.0) } else { 0.01 };
        let t = Instant::now();
        progress(Progress { level: 0, levels: 0, stage: Stage::Partitioning });
        let tree = Octree::new(points, padding);
        tree.check(3)?;
        let mut run = Run {
            opts,
            tree,
            part_times: vec![t.elapsed()],
            finest: 0,
            trusted: 0,
            global: 0,
            regions: regions_on(opts),
            prev_mask: None,
            flips_by_level: vec![BTreeSet::new()],
            auto: None,
        };
        run.density_limit(progress);
        if opts.sparse == SparseMode::Wrap {
            run.trusted = run.finest;
        }
        run.global = run.trusted;
        if run.regions {
            run.extend_into_dense_regions();
        }
        if opts.max_level == MaxLevel::Auto && opts.sparse == SparseMode::Subdivide {
            let a = autolevel::AutoLevel::new(run.trusted, MAX_LEVEL, points.len(), opts);
            run.finest = a.cap;
            run.auto = Some(a);
        }
        run.keep_needed_levels();
        Ok(run)
    }

    /// Partitions one more octree level, timing it.
    fn push_level(&mut self) {
        let t = Instant::now();
        self.tree.push_level();
        self.part_times.push(t.elapsed());
    }

    /// §4.2: the trusted level is the last before the first level whose median points per
    /// occupied voxel falls below [`ReconOptions::min_median_points`]; the finest level is the
    /// one asked for, or the trusted level with [`MaxLevel::Auto`].
    fn density_limit(&mut self, progress: &mut dyn FnMut(Progress)) {
        let opts = self.opts;
        let mut failed: Option<u32> = None;
        (self.finest, self.trusted) = loop {
            let j = self.tree.depth();
            if failed.is_none() && j >= 1 && self.tree.levels[j as usize].median_count() < opts.min_median_points {
                failed = Some(j);
            }
            let trusted_so_far = failed.map_or(j, |f| (f - 1).max(1));
            match opts.max_level {
                MaxLevel::Auto if failed.is_some() || j >= AUTO_CAP => break (trusted_so_far, trusted_so_far),
                // Stop once the trusted level is known and the levels the mapping needs exist.
                MaxLevel::Level(n) if j >= n || (failed.is_some() && j + 1 >= n && j > trusted_so_far) => {
                    break (n, trusted_so_far.min(n));
                }
                _ => {}
            }
            progress(Progress { level: j + 1, levels: j + 1, stage: Stage::Partitioning });
            self.push_level();
        };
    }

    /// §4.2 per region: past the global limit, up to [`ReconOptions::region_levels`] more levels
    /// are wrapped while some region is dense ([`ReconOptions::region_density`]); with
    /// [`MaxLevel::Auto`] the finest level goes as deep.
    fn extend_into_dense_regions(&mut self) {
        let opts = self.opts;
        let auto = opts.max_level == MaxLevel::Auto;
        let bound = if auto { AUTO_CAP } else { self.finest };
        let last = bound.min(self.trusted.saturating_add(opts.region_levels)).min(MAX_LEVEL);
        while self.trusted < last {
            while self.tree.depth() < self.trusted + 1 {
                self.push_level();
            }
            let j = self.trusted as usize;
            if !regions::any_dense(&self.tree.levels[j], &self.tree.levels[j + 1], opts.region_density) {
                break;
            }
            self.trusted += 1;
        }
        if auto {
            self.finest = self.trusted;
        }
    }

    /// Keeps the octree levels the mapping needs and no deeper: a wrapped level `j` queries level
    /// `j + 1`, a subdivided level `k` level `k - 1` (its points, summed per child). The voxels'
    /// moments are summed down to the trusted level (sheets, diagonal tests, mapping fallback).
    fn keep_needed_levels(&mut self) {
        let keep = (self.trusted + 1).max(self.finest.saturating_sub(1)).min(MAX_LEVEL);
        while self.tree.depth() > keep {
            self.tree.levels.pop();
            self.part_times.pop();
        }
        while self.tree.depth() < keep {
            self.push_level();
        }
        let t = Instant::now();
        self.tree.finish(self.trusted);
        self.part_times[self.trusted as usize] += t.elapsed();
    }

    /// The decoder's view of the levels ([`ReconOptions::decoder_lines`], module `lines`), on
    /// the grid asked for; `None` without it.
    fn line_run(&self) -> Result<Option<LineRun>, Error> {
        let Some(grid) = self.opts.decoder_lines else { return Ok(None) };
        let bits = match grid {
            DecoderGrid::Finest => octowrap_format::reconstruction_grid_bits(self.finest as usize),
            DecoderGrid::Bits(b) => b,
        };
        LineRun::new(self.tree.frame, bits).map(Some)
    }

    /// §3.3: level 0, the six faces of the root cube, and its report.
    fn root_cube(&self, points: usize) -> (LevelState, LevelReport) {
        let root_slots: Vec<u64> = (0..6u8).map(|d| crate::lattice::slot(0, d)).collect();
        let (ex, _) = extract::extract(&root_slots, &Decisions::new(&self.tree.levels[0]));
        let positions = ex.corners.iter().map(|c| lattice_point(*c)).collect();
        let state = LevelState {
            slots: root_slots,
            quads: ex.quads,
            corners: ex.corners,
            positions,
            origins: vec![FaceOrigin::Created; 6],
        };
        let report = LevelReport {
            level: 0,
            kind: LevelKind::Root,
            voxels: 1,
            median_points: points as f64,
            faces: 6,
            vertices: 8,
            created: 6,
            oriented_voxels: 0,
            flips: 0,
            dropped: 0,
            filled: 0,
            sparse_voxels: 0,
            intersecting: None,
            on_lines: 0,
            timings: StageTimings { partitioning: self.part_times[0], ..StageTimings::default() },
        };
        (state, report)
    }

    /// The voxels of level `j` before it is wrapped: the sparse regions' children present
    /// (§4.2 per region) and the one-voxel gaps of sparsely sampled sheets filled. Returns the
    /// level's report with its voxel figures and partitioning time.
    fn prepare_level(&mut self, j: u32) -> LevelReport {
        let marks = self.sparse_regions(j);
        let t = Instant::now();
        let filled = if self.opts.fill_gaps && (2..=self.trusted).contains(&j) {
            self.tree.levels[j as usize].fill_gaps()
        } else {
            0
        };
        let gap_time = t.elapsed();
        let here = self.tree.levels.get(j as usize);
        let voxels = here.map_or(0, crate::octree::Cells::len);
        let median_points = here.map_or(0.0, crate::octree::Cells::median_count);
        let sparse_voxels = match marks {
            Some(marks) => {
                let (above, here) = self.tree.levels.split_at_mut(j as usize);
                regions::fill(&mut here[0], &above[j as usize - 1], &marks)
            }
            None => 0,
        };
        LevelReport {
            level: j,
            kind: LevelKind::Wrapped,
            voxels,
            median_points,
            faces: 0,
            vertices: 0,
            created: 0,
            oriented_voxels: 0,
            flips: 0,
            dropped: 0,
            filled,
            sparse_voxels,
            intersecting: None,
            on_lines: 0,
            timings: StageTimings {
                partitioning: self.part_times.get(j as usize).copied().unwrap_or_default() + gap_time,
                ..StageTimings::default()
            },
        }
    }

    /// The sparse voxels of level `j - 1` past the global limit (before gaps are filled: those
    /// hold no points). When every voxel is sparse, level `j` and the deeper ones are plain
    /// subdivision, and there are none.
    fn sparse_regions(&mut self, j: u32) -> Option<Vec<bool>> {
        if !(self.regions && j > self.global && j <= self.trusted) {
            return None;
        }
        let marks =
            regions::mark(&self.tree.levels[j as usize - 1], &self.tree.levels[j as usize], self.opts.region_density);
        if marks.iter().all(|&s| s) {
            self.trusted = j - 1;
            return None;
        }
        Some(marks)
    }

    /// §3.4 and §3.5: wraps level `j` around its occupied voxels, refining the faces of `prev`.
    fn wrap_level(
        &mut self,
        j: u32,
        prev: &LevelState,
        rep: &mut LevelReport,
        stage: &mut dyn FnMut(Stage),
    ) -> LevelState {
        let tree = &self.tree;
        let cells = &tree.levels[j as usize];
        // §3.4: the oriented-sheet mask and the regular refinement.
        stage(Stage::Regular);
        let t = Instant::now();
        let prev_index = RankMap::from_sorted(&prev.slots);
        let mask = sheet::build(tree, cells, &tree.levels[j as usize - 1], &prev_index, self.prev_mask.as_ref());
        rep.oriented_voxels = mask.signed_count();
        let initial = regular::refine(&prev.slots, &prev_index, cells, &mask);
        rep.timings.regular = t.elapsed();
        // §3.5: the closure, then vertex extraction with vertex and edge splits.
        stage(Stage::Irregular);
        let t = Instant::now();
        let mut dec = Decisions::with_parents(cells, &tree.levels[..j as usize], &self.flips_by_level);
        let (mut slots, mut origins, created) = irregular::close(initial, cells, &mask, &dec);
        rep.created = created;
        let ex = extract_with_splits(&mut slots, &mut origins, &mut dec, rep);
        rep.timings.irregular = t.elapsed();
        let flips = std::mem::take(&mut dec.flips);
        drop(dec);
        let h = voxel_size(j);
        let mut positions: Vec<DVec3> = ex.corners.iter().map(|c| lattice_point(*c) * h).collect();
        if rep.sparse_voxels > 0 {
            regions::start_on_parents(
                &regions::Faces { slots: &slots, origins: &origins, quads: &ex.quads, corners: &ex.corners },
                cells,
                &regions::Parents { quads: &prev.quads, corners: &prev.corners, positions: &prev.positions },
                &mut positions,
            );
        }
        // Kept for the next level's filled voxels, if it is wrapped.
        if self.regions && j < self.trusted {
            self.flips_by_level.push(flips);
            self.prev_mask = Some(mask);
        } else {
            self.prev_mask = None;
        }
        LevelState { slots, quads: ex.quads, corners: ex.corners, positions, origins }
    }

    /// §4.2: level `j` past the trusted level splits every face of `prev` into four. Fails when
    /// the finest level would exceed [`ReconOptions::max_faces`], before any subdivided level is
    /// built.
    fn subdivide_level(
        &self,
        j: u32,
        prev: &LevelState,
        rep: &mut LevelReport,
        stage: &mut dyn FnMut(Stage),
    ) -> Result<LevelState, Error> {
        // The auto choice never builds a level past the limit: only this level is checked.
        let finest = if self.auto.is_some() { j } else { self.finest };
        let faces = (prev.quads.len() as u64).saturating_mul(4u64.saturating_pow(finest - j + 1));
        if faces > self.opts.max_faces.min(u64::from(u32::MAX / 4)) {
            return Err(Error::TooManyFaces { level: finest, faces, max: self.opts.max_faces });
        }
        rep.kind = LevelKind::Subdivided;
        stage(Stage::Irregular);
        let t = Instant::now();
        let s = sparse::subdivide(&prev.quads, &prev.corners, &prev.slots, &prev.positions);
        rep.timings.irregular = t.elapsed();
        Ok(LevelState {
            slots: s.slots,
            quads: s.quads,
            corners: s.corners,
            positions: s.positions,
            origins: s.origins,
        })
    }

    /// §3.6, §3.6.1 and the least-squares fit: maps the vertices of level `j` onto the points,
    /// relaxes them, and fits them to the points. With decoder lines (`lines`, empty or one per
    /// vertex) and a finite [`ReconOptions::line_reach`], the level is placed free (mapping,
    /// relaxation, the fit's first passes), then each vertex within the reach of its line goes to
    /// the line's nearest point (the others lose their line), and the fit's last passes move the
    /// line vertices along their lines and the others freely. With an infinite reach, a vertex with a line goes where its line meets its
    /// plane and moves along its line only: the relaxation holds it (its tangential place is the
    /// line's), the fit moves its scalar. Either way a vertex whose line would fold a face keeps
    /// its free position and loses its line.
    /// Releases the points after the finest level's last use of them.
    fn place_vertices(
        &mut self,
        j: u32,
        next: &mut LevelState,
        rep: &mut LevelReport,
        stage: &mut dyn FnMut(Stage),
        lines: &mut [Option<LocalLine>],
    ) {
        stage(Stage::Mapping);
        let t = Instant::now();
        let mut planes = self.map_vertices(j, rep.kind, next);
        let reach = self.opts.line_reach;
        let construct = !lines.is_empty() && reach.is_infinite();
        if construct {
            let before = next.positions.clone();
            mapping::onto_lines(&mut next.positions, &planes, lines, voxel_size(j));
            mapping::free_folding_lines(&mut next.positions, &before, &next.quads, lines);
            for (plane, line) in planes.iter_mut().zip(lines.iter()) {
                if line.is_some() {
                    *plane = None;
                }
            }
        }
        rep.timings.mapping = t.elapsed();
        let opts = self.opts;
        // The auto choice's levels past the trusted one are fitted whatever their size: they
        // are kept only when they come closer to the points.
        let auto_extra = self.auto.as_ref().is_some_and(|a| a.measures(j) && j > self.trusted);
        let fit_here = opts.fit_passes > 0 && (next.quads.len() <= opts.fit_max_faces || auto_extra);
        if j == self.finest && !fit_here && self.auto.is_none() {
            // Freed before the relaxation's buffers and the output's conversions (this keeps the
            // finest level's peak down).
            self.tree.release();
        }
        stage(Stage::Relaxation);
        let t = Instant::now();
        let passes = if j >= opts.relax_from_level { opts.relax_passes } else { 0 };
        relax::relax(&mut next.positions, &planes, &next.quads, passes);
        drop(planes);
        let near = !lines.is_empty() && !construct;
        let mut before_snap = None;
        if fit_here {
            let (fixed, near_lines): (&[Option<LocalLine>], _) = match (construct, near) {
                (true, _) => (&*lines, None),
                (false, true) => (&[], Some((&mut *lines, reach * voxel_size(j)))),
                (false, false) => (&[], None),
            };
            before_snap = self.fit_to_points(j, rep.kind, next, fixed, near_lines);
        }
        if near {
            if let Some(free) = before_snap {
                // The constrained passes moved the free vertices too: the vertices of a face
                // they fold go back to where they were before the snap (free).
                mapping::unfold_refit(&mut next.positions, &free, &next.quads, lines);
            } else {
                let free = next.positions.clone();
                mapping::near_lines(&mut next.positions, lines, reach * voxel_size(j));
                mapping::free_folding_lines(&mut next.positions, &free, &next.quads, lines);
            }
        }
        if fit_here && j == self.finest && self.auto.is_none() {
            self.tree.release();
        }
        rep.timings.relaxation = t.elapsed();
    }

    /// [`MaxLevel::Auto`] past the trusted level (module `autolevel`): measures level `j` and
    /// decides whether it is the finest, or dropped, or a deeper level follows (`run.finest`
    /// follows the decision).
    fn auto_level(&mut self, j: u32, next: &LevelState) -> autolevel::Verdict {
        let Some(auto) = self.auto.as_mut().filter(|a| a.measures(j)) else {
            return autolevel::Verdict::Continue;
        };
        let rms = autolevel::rms_to_mesh(&self.tree.points, &next.quads, &next.positions, voxel_size(j));
        let verdict = auto.verdict(j, next.quads.len(), rms);
        match verdict {
            autolevel::Verdict::Continue => {}
            autolevel::Verdict::Stop => self.finest = j,
            autolevel::Verdict::Drop => self.finest = j - 1,
        }
        verdict
    }

    /// §3.6: maps the vertices of level `j` onto tangent planes of the points; returns each
    /// vertex's plane for the relaxation.
    fn map_vertices(&self, j: u32, kind: LevelKind, next: &mut LevelState) -> Vec<Option<TangentPlane>> {
        let tree = &self.tree;
        if kind != LevelKind::Wrapped {
            return mapping::map_free(tree, j, &mut next.positions);
        }
        let cells = &tree.levels[j as usize];
        let face_cells: Vec<u32> = next
            .slots
            .par_iter()
            .map(|&s| cells.find(unslot(s).0).expect("faces lie on occupied voxels") as u32)
            .collect();
        let coarse = &tree.levels[j as usize - 1];
        mapping::map_wrapped(
            tree,
            cells,
            coarse,
            &next.quads,
            &face_cells,
            &mut next.positions,
            self.opts.quadric_mapping,
        )
    }

    /// Beyond the paper: fits the vertices of level `j` to the points by least squares (module
    /// `least_squares`). A subdivided level starts from its fitted parent's surface, so it takes
    /// at most two passes: they do what three do on a wrapped level (the bunny's level 6: RMS
    /// .00024 with three, .00025 with two) at two thirds of the cost.
    fn fit_to_points(
        &self,
        j: u32,
        kind: LevelKind,
        next: &mut LevelState,
        lines: &[Option<LocalLine>],
        near: Option<(&mut [Option<LocalLine>], f64)>,
    ) -> Option<Vec<DVec3>> {
        // The deepest level kept holds the faces' voxels (a wrapped level's own, a subdivided
        // level's parents).
        let g = j.min(self.tree.depth());
        let grid = &self.tree.levels[g as usize];
        let face_voxel: Vec<u32> = if kind == LevelKind::Wrapped {
            // A wrapped face's own voxel.
            next.slots.par_iter().map(|&s| grid.find(unslot(s).0).map_or(u32::MAX, |i| i as u32)).collect()
        } else {
            // A subdivided face's voxel may be empty: the voxel of its centre, if occupied.
            let cells = f64::from(1u32 << g);
            next.quads
                .par_iter()
                .map(|q| {
                    let c = q.iter().fold(DVec3::ZERO, |s, &v| s + next.positions[v as usize]) * 0.25;
                    let k = c.map(|x| (x * cells).clamp(0.0, cells - 1.0)).as_uvec3();
                    grid.find(morton::encode(k.x, k.y, k.z)).map_or(u32::MAX, |i| i as u32)
                })
                .collect()
        };
        let input = least_squares::Input { points: &self.tree.points, grid, face_voxel: &face_voxel };
        let passes = if kind == LevelKind::Wrapped { self.opts.fit_passes } else { self.opts.fit_passes.min(2) };
        let dir = |l: &Option<LocalLine>| l.map_or(DVec3::ZERO, |l| l.dir);
        let dirs: Vec<DVec3> = lines.iter().map(dir).collect();
        let Some((near, reach)) = near else {
            least_squares::fit(&input, &next.quads, &mut next.positions, (passes, self.opts.fit_samples), &dirs);
            return None;
        };
        // Near lines: the first passes place the level free, then every vertex within the reach
        // of its line goes onto it, and the last passes move it along its line only while the
        // free vertices around it make up for its lost tangential freedom.
        let at = passes.min(FREE_PASSES);
        let passes = at + CONSTRAINED_PASSES;
        let quads = &next.quads;
        let mut before = None;
        let mut snap = |x: &mut [DVec3]| {
            let free = x.to_vec();
            mapping::near_lines(x, near, reach);
            mapping::free_folding_lines(x, &free, quads, near);
            before = Some(free);
            near.iter().map(dir).collect()
        };
        least_squares::fit_switching(
            &input,
            quads,
            &mut next.positions,
            (passes, self.opts.fit_samples),
            dirs,
            Some((at, &mut snap)),
        );
        before
    }
}

/// §3.5, Fig. 5: extracts the vertices of the faces `slots`; a pinched diagonal edge has its
/// decision flipped (the edge split), once per edge, and the faces of an edge that flipping cannot
/// split are dropped, until every vertex has a single fan.
fn extract_with_splits(
    slots: &mut Vec<u64>,
    origins: &mut Vec<FaceOrigin>,
    dec: &mut Decisions<'_>,
    rep: &mut LevelReport,
) -> extract::Extracted {
    let mut tried = BTreeSet::new();
    loop {
        let (ex, bad) = extract::extract(slots, dec);
        if bad.is_empty() {
            return ex;
        }
        let mut drop = vec![false; slots.len()];
        for b in bad {
            match b.diagonal {
                Some(p) if tried.insert(p) => {
                    dec.flips.insert(p);
                    rep.flips += 1;
                }
                _ => {
                    for f in b.faces {
                        drop[f as usize] = true;
                    }
                }
            }
        }
        let before = slots.len();
        let mut keep = drop.iter().map(|d| !d);
        slots.retain(|_| keep.next().unwrap_or(true));
        let mut keep = drop.iter().map(|d| !d);
        origins.retain(|_| keep.next().unwrap_or(true));
        rep.dropped += before - slots.len();
    }
}

/// Beyond the paper: repairs the intersecting faces of a level (module `untangle`), in world
/// coordinates (where the validator tests them), when it has at most
/// [`ReconOptions::untangle_max_faces`] faces.
fn untangle_level(level: &mut Level, opts: &ReconOptions, rep: &mut LevelReport) {
    if level.mesh.faces.len() > opts.untangle_max_faces {
        return;
    }
    let t = Instant::now();
    let quads: Vec<[u32; 4]> = level.mesh.faces.iter().map(|f| [f[0], f[1], f[2], f[3]]).collect();
    let u = untangle::untangle(&quads, &mut level.mesh.vertices.positions);
    rep.intersecting = Some((u.before, u.after));
    rep.timings.relaxation += t.elapsed();
}

/// A lattice corner as a point (in voxels of its level).
fn lattice_point(c: [u32; 3]) -> DVec3 {
    DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]))
}

/// One level while it is being built (local coordinates).
#[derive(Default)]
struct LevelState {
    slots: Vec<u64>,
    quads: Vec<[u32; 4]>,
    corners: Vec<[u32; 3]>,
    positions: Vec<DVec3>,
    origins: Vec<FaceOrigin>,
}

impl LevelState {
    /// The decoder line of every vertex with one (module `lines`): through its lattice point on
    /// a wrapped level, through the parent's bilinear point on a subdivided one.
    fn decoder_lines(&self, tree: &Octree, lines: &LineRun, kind: LevelKind) -> Result<Vec<Option<LocalLine>>, Error> {
        let child = Level {
            mesh: Mesh {
                vertices: PointCloud::from_positions(self.positions.iter().map(|&p| tree.frame.to_world(p)).collect()),
                faces: FaceList::from_quads(&self.quads),
            },
            origins: self.origins.clone(),
            lattice: Some(LevelLattice { face_slots: face_slots(&self.slots), vertex_corners: self.corners.clone() }),
        };
        let origin = if kind == LevelKind::Subdivided { LineOrigin::Bilinear } else { LineOrigin::LatticePoint };
        lines.lines(&child, origin)
    }

    /// The output level; moves the origins out (the next level does not need them), and with
    /// `last` also the positions, corners and quads (converted in place, no copies at the
    /// finest level).
    fn take_level(&mut self, tree: &Octree, last: bool) -> Level {
        let world: Vec<DVec3> = if last {
            let mut p = std::mem::take(&mut self.positions);
            p.par_iter_mut().for_each(|p| *p = tree.frame.to_world(*p));
            p
        } else {
            self.positions.par_iter().map(|&p| tree.frame.to_world(p)).collect()
        };
        let vertex_corners = if last { std::mem::take(&mut self.corners) } else { self.corners.clone() };
        let faces = if last {
            FaceList::from_quad_vec(std::mem::take(&mut self.quads))
        } else {
            FaceList::from_quads(&self.quads)
        };
        let mesh = Mesh { vertices: PointCloud::from_positions(world), faces };
        Level {
            mesh,
            origins: std::mem::take(&mut self.origins),
            lattice: Some(LevelLattice { face_slots: face_slots(&self.slots), vertex_corners }),
        }
    }
}

/// Every slot's voxel and side.
fn face_slots(slots: &[u64]) -> Vec<([u32; 3], u8)> {
    slots
        .par_iter()
        .map(|&s| {
            let (code, side) = unslot(s);
            (morton::decode(code), side)
        })
        .collect()
}
