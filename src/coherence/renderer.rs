//! The incremental frame renderer (Jevans 1992, sections 3.2 and 3.3): frame 0 is traced in
//! full while every block's ray segments are recorded in the voxel tables; each later frame
//! marks the voxels of what changed, ORs their tables into the frame's block set, clears
//! those blocks' records everywhere, retraces exactly those blocks (recording again) and
//! copies every other pixel from the previous frame. A pixel's value depends only on the
//! scene of its frame and its own random stream, so every frame equals a full render.

use super::adaptive::AdaptiveGrid;
use super::changes::{Changes, FrameSummary};
use super::grid::{ActiveVoxels, Grid};
use super::record::{Recorded, RecordingAccel, Records, Replaying, Reuse};
use super::segments::{Changed, Quantiser, SegmentRecords};
use super::tables::{BlockLayout, BlockSet, Table, VoxelTables};
use super::LIGHT_SELECTION;
use crate::accel::Accel;
use crate::control::{Control, MemoryBudget};
use crate::error::Result;
use crate::image::Image;
use crate::math::{Rgb, Vec3};
use crate::render::pixels::PixelView;
use crate::render::small_objects::SmallObjects;
use crate::render::{Tile, MERGE_WINDOW};
use crate::scene::Scene;
use crate::transport::driver::drive;
use crate::transport::ProgressiveOptions;
use crate::transport::{Context, Integrator, MonteCarlo, RayStats};
use std::time::Instant;

/// How pixels are computed: one of the two tile kernels, with its view.
pub(crate) enum Engine<'a> {
    /// The one-pass kernel (Whitted's adaptive or uniform supersampling).
    Whitted {
        integrator: &'a dyn Integrator,
        view: PixelView,
    },
    /// The Monte Carlo kernel, for integrators that splat nothing (the path tracer).
    MonteCarlo {
        integrator: &'a dyn MonteCarlo,
        options: ProgressiveOptions,
    },
}

impl Engine<'_> {
    pub fn size(&self) -> (u32, u32) {
        match self {
            Engine::Whitted { view, .. } => (view.view.width, view.view.height),
            Engine::MonteCarlo { options, .. } => (options.view.width, options.view.height),
        }
    }

    fn threads(&self) -> Option<usize> {
        match self {
            Engine::Whitted { view, .. } => view.view.threads,
            Engine::MonteCarlo { options, .. } => options.view.threads,
        }
    }

    /// The objects smaller than a pixel that the one-pass kernel looks for between corners.
    fn small_objects(&self, ctx: &Context) -> SmallObjects {
        match self {
            Engine::Whitted { view, .. } => view.small_objects(ctx),
            Engine::MonteCarlo { .. } => SmallObjects::none(),
        }
    }

    /// Renders one block through its recorder; returns its pixels and the rays traced.
    fn region(
        &self,
        ctx: &Context,
        recorder: &RecordingAccel,
        small: &SmallObjects,
        tile: &Tile,
    ) -> (Vec<Rgb>, RayStats) {
        let ctx = &ctx.with_accel(recorder);
        match self {
            Engine::Whitted { integrator, view } => {
                let replaying = Replaying {
                    inner: *integrator,
                    recorder,
                };
                let integrator: &dyn Integrator = if recorder.keeps_samples() {
                    &replaying
                } else {
                    *integrator
                };
                let out = crate::render::pixels::render_tile(ctx, integrator, view, small, tile);
                (out.pixels, out.rays)
            }
            Engine::MonteCarlo {
                integrator,
                options,
            } => {
                let (p, r, _) =
                    crate::render::progressive::render_tile(ctx, *integrator, options, tile);
                (p, r)
            }
        }
    }

    /// Renders the whole frame without coherence (the reference, and the "traditional"
    /// column of the statistics). `None` if cancelled.
    pub fn render_full(&self, ctx: &Context, control: &Control) -> Result<(Image, RayStats)> {
        let (image, stats) = match self {
            Engine::Whitted { integrator, view } => {
                let whole = Tile::whole(view.view.width, view.view.height);
                crate::render::pixels::render_pixels(ctx, *integrator, view, &whole, control)?
            }
            Engine::MonteCarlo {
                integrator,
                options,
            } => {
                let (film, stats) = crate::render::progressive::render_passes(
                    ctx,
                    *integrator,
                    options,
                    None,
                    crate::render::Watch::nobody(),
                    control,
                )?;
                (film.image()?, stats)
            }
        };
        if stats.cancelled {
            control.cancel.check("a frame")?;
        }
        Ok((image, stats.rays))
    }
}

/// What one frame did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameStats {
    pub rays: RayStats,
    pub blocks_retraced: usize,
    /// Blocks of the frame's tables.
    pub blocks_total: usize,
    pub pixels_retraced: u64,
    /// Voxels marked changed (0 on a full frame).
    pub changed_voxels: usize,
    /// Seconds spent finding and clearing the blocks to retrace (the coherence overhead that
    /// is not ray tracing).
    pub bookkeeping_seconds: f64,
    pub seconds: f64,
    /// Why the whole frame was retraced, if it was.
    pub full_reason: Option<String>,
    /// The blocks retraced.
    pub blocks: Vec<usize>,
    /// Camera rays traced, and those answered from their hit in the block's last trace
    /// (section 3.3.3).
    pub camera_rays: u64,
    pub camera_reused: u64,
    /// Reflection, refraction and shadow rays answered from the block's last trace.
    pub others_reused: u64,
    /// Samples not shaded again: every ray of their tree was answered from the block's
    /// last trace, and no light changed.
    pub samples_reused: u64,
}

/// The incremental renderer's state between frames.
pub struct CoherentRenderer {
    pub grid: Grid,
    voxels: ActiveVoxels,
    pub layout: BlockLayout,
    store: Store,
    previous: Option<(FrameSummary, Image)>,
    /// The previous frame's objects smaller than a pixel: the adaptive sampler looks for
    /// them without tracing a ray to them, so no record shows where they moved.
    small: SmallObjects,
    /// With [`restrict_to_sequence`](Self::restrict_to_sequence): per voxel, the last
    /// position in the sequence at which it changes (0: never).
    last_change: Option<Vec<u32>>,
    /// The position in the sequence of the next frame (0 after [`reset`](Self::reset)).
    position: u32,
    /// Records that grow past this many bytes are cut down: segment records become voxel
    /// tables, and stored answers are no longer kept.
    segment_budget: usize,
    /// Per block, its queries and their answers, and its samples, in its last trace
    /// (section 3.3.3), while `camera_on`.
    camera: Vec<Recorded>,
    /// Per block, the point lights its shadow rays went to in its last trace
    /// ([`Recorded::lights`]).
    lights: Vec<u64>,
    camera_on: bool,
}

/// The records, in either form.
enum Store {
    Tables(VoxelTables),
    Segments(SegmentRecords),
}

impl Store {
    fn new(records: Records, grid: &Grid, layout: &BlockLayout) -> Store {
        match records {
            Records::Tables => Store::Tables(VoxelTables::new(grid.len(), layout)),
            Records::Segments => Store::Segments(SegmentRecords::new(layout, grid)),
        }
    }

    fn records(&self) -> Records {
        match self {
            Store::Tables(_) => Records::Tables,
            Store::Segments(_) => Records::Segments,
        }
    }
}

/// Relative margin around changed boxes: covers rounding in the DDA and in hit distances, so
/// a segment that meets a changed object always has a bit in a changed voxel.
const MARGIN: f32 = 1e-4;

/// How a voxel a changed surface passes through is cut for the segment walks
/// ([`CoherentRenderer::cut_changes`]): in `CUT_SPLIT`³ cells, `CUT_DEPTH` times.
const CUT_SPLIT: u32 = 2;
const CUT_DEPTH: u32 = 2;
/// At most this many surface pieces for the cut voxels: fewer levels of cuts otherwise.
const MAX_PIECES: usize = 1 << 16;

impl CoherentRenderer {
    /// A renderer keeping segment records (the faster form; `with_records` chooses).
    #[cfg(test)]
    pub fn new(grid: Grid, layout: BlockLayout) -> CoherentRenderer {
        CoherentRenderer::with_records(grid, layout, Records::Segments)
    }

    pub fn with_records(grid: Grid, layout: BlockLayout, records: Records) -> CoherentRenderer {
        CoherentRenderer {
            store: Store::new(records, &grid, &layout),
            voxels: ActiveVoxels::all(grid.clone()),
            grid,
            layout,
            previous: None,
            small: SmallObjects::none(),
            last_change: None,
            position: 0,
            segment_budget: (MemoryBudget::default().limit() / 4).min(usize::MAX as u64) as usize,
            camera: vec![Recorded::default(); layout.len()],
            lights: vec![0; layout.len()],
            camera_on: true,
        }
    }

    /// Records that grow past `bytes` are cut down: segment records are turned into voxel
    /// tables (which take a fixed, small amount of memory), stored answers are dropped, and the
    /// sequence goes on without them. By default a quarter of the memory limit
    /// (`--max-memory`).
    pub fn set_segment_budget(&mut self, bytes: usize) {
        self.segment_budget = bytes;
    }

    /// A grid of about `voxels` voxels over every box in `bounds`. It must hold every box a
    /// change will mark (a change outside it retraces the whole frame): the extents of every
    /// frame do, and so do the boxes of the changes themselves (what `raylink animate` uses).
    pub fn grid_around(bounds: &[(Vec3, Vec3)], voxels: u32) -> Grid {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for (a, b) in bounds {
            lo = lo.min(*a);
            hi = hi.max(*b);
        }
        if lo.x > hi.x {
            (lo, hi) = (Vec3::splat(-1.0), Vec3::ONE);
        }
        // A little padding so geometry on the boundary is inside.
        let pad = (hi - lo).max_element().max(1e-3) * 1e-3;
        Grid::with_voxels(lo - pad, hi + pad, voxels)
    }

    /// The boxes whose voxels `changes` marks changed: the surfaces of the changed objects
    /// (in pieces of at most half a voxel) and the shadow boxes of changed lights. What
    /// [`restrict_to_sequence`](Self::restrict_to_sequence) wants for each frame.
    pub fn surface_boxes(&self, changes: &Changes) -> Vec<(Vec3, Vec3)> {
        changes.surface_boxes(0.5 * self.grid.cell_size().min_element())
    }

    /// Records only where a *later* frame changes something: `changes[k]` holds the boxes
    /// that the change from the sequence's frame `k` to frame `k + 1` marks. A record is
    /// only ever read when its voxel changes, so a voxel keeps records until the last
    /// frame that changes it and none after: a sequence whose motion ends costs nothing to
    /// record from then on. A change the list did not foresee retraces the whole frame.
    #[cfg(test)]
    pub fn restrict_to_sequence(&mut self, changes: &[Vec<(Vec3, Vec3)>]) {
        let last = Self::last_changes(&self.grid, changes);
        self.restrict_to_last_changes(last);
    }

    /// Per voxel of `grid`, the last position in the sequence at which `changes` (as
    /// [`restrict_to_sequence`](Self::restrict_to_sequence) takes them) change it (0: never).
    pub fn last_changes(grid: &Grid, changes: &[Vec<(Vec3, Vec3)>]) -> Vec<u32> {
        let margin = 2.0 * MARGIN * (grid.hi - grid.lo).length();
        let mut last = vec![0u32; grid.len()];
        for (k, boxes) in changes.iter().enumerate() {
            for (lo, hi) in boxes {
                grid.voxels_in_box(*lo - margin, *hi + margin, |v| last[v] = k as u32 + 1);
            }
        }
        last
    }

    /// [`restrict_to_sequence`](Self::restrict_to_sequence) with its voxels worked out
    /// ([`last_changes`](Self::last_changes) over this renderer's grid).
    pub fn restrict_to_last_changes(&mut self, last: Vec<u32>) {
        assert_eq!(last.len(), self.grid.len(), "one entry per voxel");
        self.last_change = Some(last);
        self.update_active();
    }

    /// The active voxels at the current position: those a later frame changes.
    fn update_active(&mut self) {
        if let Some(last) = &self.last_change {
            let mask: Vec<bool> = last.iter().map(|&k| k > self.position).collect();
            self.voxels = ActiveVoxels::from_mask(self.grid.clone(), &mask);
        }
    }

    /// Voxels that keep records (at the start of the sequence).
    pub fn active_voxels(&self) -> usize {
        match &self.last_change {
            Some(last) => last.iter().filter(|&&k| k > 0).count(),
            None => self.voxels.count(),
        }
    }

    /// Bytes the records take: the voxel tables or the segments held (the stored answers
    /// apart: [`camera_bytes`](Self::camera_bytes)).
    pub fn record_bytes(&self) -> usize {
        match &self.store {
            Store::Tables(t) => t.memory_bytes(),
            Store::Segments(s) => s.memory_bytes(),
        }
    }

    /// Bytes the stored answers take.
    pub fn camera_bytes(&self) -> usize {
        (self.camera.iter())
            .map(|c| {
                std::mem::size_of_val(c.camera.as_slice())
                    + std::mem::size_of_val(c.shaded.as_slice())
            })
            .sum()
    }

    /// Whether stored answers are kept for reuse (until the records pass their budget).
    pub fn keeps_camera_hits(&self) -> bool {
        self.camera_on
    }

    /// Segments held (segment records; 0 with tables).
    pub fn segments(&self) -> usize {
        match &self.store {
            Store::Tables(_) => 0,
            Store::Segments(s) => s.segments(),
        }
    }

    pub fn records(&self) -> Records {
        self.store.records()
    }

    /// Forgets the previous frame: the next frame is traced in full.
    pub fn reset(&mut self) {
        self.previous = None;
        self.camera = vec![Recorded::default(); self.layout.len()];
        self.lights = vec![0; self.layout.len()];
        self.store = Store::new(self.store.records(), &self.grid, &self.layout);
        self.position = 0;
        self.update_active();
    }

    /// The blocks to retrace for `changes`, how many voxels were marked changed, and why
    /// every block is retraced, if so; else the voxels where a surface changed (what a
    /// stored answer must not be behind).
    pub fn blocks_for(&self, changes: &Changes) -> (BlockSet, usize, Result<ActiveVoxels, String>) {
        let mut blocks = BlockSet::new(&self.layout);
        if let Some(reason) = &changes.everything {
            return (BlockSet::all(&self.layout), 0, Err(reason.clone()));
        }
        let margin = MARGIN * (self.grid.hi - self.grid.lo).length();
        // Records exist only inside the grid: a change elsewhere cannot be traced back.
        let inside = |(lo, hi): &(Vec3, Vec3)| {
            lo.cmpge(self.grid.lo - margin).all() && hi.cmple(self.grid.hi + margin).all()
        };
        if !changes.objects.iter().chain(&changes.shadows).all(inside) {
            let reason = "something changed outside the voxel grid".to_string();
            return (BlockSet::all(&self.layout), 0, Err(reason));
        }
        // A kept segment lies within a lattice step of the traced one (segments.rs; so do
        // the tables made from segments past the budget): the boxes grow by that step more,
        // which stays within the margin of `restrict_to_sequence`.
        let margin = margin + Quantiser::new(&self.grid).error();
        let mut changed = vec![false; self.grid.len()];
        // The changes of geometry alone (what a surface record answers to).
        let geometry = Changes {
            shadows: Vec::new(),
            ..changes.clone()
        };
        let surfaces = self.surface_boxes(&geometry);
        let pieces = surfaces.len();
        for (lo, hi) in surfaces {
            self.grid
                .voxels_in_box(lo - margin, hi + margin, |v| changed[v] = true);
        }
        let mut shadow_only = vec![false; self.grid.len()];
        for (lo, hi) in &changes.shadows {
            self.grid
                .voxels_in_box(*lo - margin, *hi + margin, |v| shadow_only[v] = true);
        }
        if (0..self.grid.len()).any(|v| (changed[v] || shadow_only[v]) && !self.voxels.is_active(v))
        {
            let reason = "something changed where no records were kept".to_string();
            return (BlockSet::all(&self.layout), 0, Err(reason));
        }
        let count = (0..self.grid.len())
            .filter(|&v| changed[v] || shadow_only[v])
            .count();
        let mut changed_voxels = None;
        match &self.store {
            Store::Tables(tables) => {
                for v in 0..self.grid.len() {
                    if changed[v] {
                        tables.collect(Table::Surface, v, &mut blocks);
                        tables.collect(Table::Shadow, v, &mut blocks);
                    } else if shadow_only[v] {
                        tables.collect(Table::Shadow, v, &mut blocks);
                    }
                }
                if changes.light_moved {
                    tables.collect_hits(&mut blocks);
                }
            }
            Store::Segments(segments) => {
                if changes.light_moved {
                    segments.collect_hits(&mut blocks);
                }
                // Shadow segments answer to every changed voxel, surface ones only to those
                // where a surface changed (as the two tables are read above), over the
                // voxels cut finer around the changed surfaces where the cuts are affordable.
                let cut = self.cut_changes(&geometry, &changes.shadows, margin, pieces);
                let (surface, any) = cut.unwrap_or_else(|| {
                    let any: Vec<bool> = (changed.iter().zip(&shadow_only))
                        .map(|(a, b)| a | b)
                        .collect();
                    let uniform = |mask: &[bool]| ActiveVoxels::from_mask(self.grid.clone(), mask);
                    (uniform(&changed), uniform(&any))
                });
                let q = segments.quantiser();
                let (surface, any) = (Changed::new(surface, q), Changed::new(any, q));
                segments.collect(&surface, &any, &mut blocks);
                // Stored answers hold against the same, finer, changed voxels.
                changed_voxels = Some(surface.voxels);
            }
        }
        // A light whose intensity alone changed: every block that sent it a shadow ray.
        let dimmed = changes
            .dimmed
            .iter()
            .fold(0u64, |m, &i| m | 1u64 << i.min(63));
        if dimmed != 0 {
            for (b, &lights) in self.lights.iter().enumerate() {
                if lights & dimmed != 0 {
                    blocks.insert(b);
                }
            }
        }
        let changed =
            changed_voxels.unwrap_or_else(|| ActiveVoxels::from_mask(self.grid.clone(), &changed));
        (blocks, count, Ok(changed))
    }

    /// The voxels where a surface of `geometry` changed, and those where anything changed
    /// (also the `shadows` boxes), over this renderer's grid with every voxel a changed
    /// surface passes through cut [`CUT_DEPTH`] times in [`CUT_SPLIT`]³ (the adaptive
    /// subdivision of Jevans's grid): the changed voxels then hug the surfaces, and fewer
    /// recorded segments merely pass near them. `pieces`: how many surface pieces the
    /// uniform voxels took; a cut makes [`CUT_SPLIT`]² as many, so the cuts stop short of
    /// [`MAX_PIECES`]; `None` if no level of cuts fits (a large changed surface keeps the
    /// uniform voxels). (`margin` as for the uniform voxels: the leaves are finer, the
    /// rounding the same.)
    fn cut_changes(
        &self,
        geometry: &Changes,
        shadows: &[(Vec3, Vec3)],
        margin: f32,
        pieces: usize,
    ) -> Option<(ActiveVoxels, ActiveVoxels)> {
        let mut depth = CUT_DEPTH;
        while depth > 0 && pieces * (CUT_SPLIT as usize).pow(2 * depth) > MAX_PIECES {
            depth -= 1;
        }
        if depth == 0 {
            return None;
        }
        let leaf = self.grid.cell_size().min_element() / CUT_SPLIT.pow(depth) as f32;
        let grown: Vec<(Vec3, Vec3)> = (geometry.surface_boxes(0.5 * leaf).iter())
            .map(|(lo, hi)| (*lo - margin, *hi + margin))
            .collect();
        let max_leaves = 8 * self.grid.len();
        let grid = AdaptiveGrid::refined(self.grid.clone(), &grown, CUT_SPLIT, depth, max_leaves);
        let mut surface = vec![false; grid.len()];
        for (lo, hi) in &grown {
            grid.voxels_in_box(*lo, *hi, |v| surface[v] = true);
        }
        let mut any = surface.clone();
        for (lo, hi) in shadows {
            grid.voxels_in_box(*lo - margin, *hi + margin, |v| any[v] = true);
        }
        Some((
            ActiveVoxels::from_mask(grid.clone(), &surface),
            ActiveVoxels::from_mask(grid, &any),
        ))
    }

    /// Renders the next frame of the sequence (the first call traces every pixel).
    pub fn render_frame(
        &mut self,
        scene: &Scene,
        accel: &dyn Accel,
        engine: &Engine,
        control: &Control,
    ) -> Result<(Image, FrameStats)> {
        let start = Instant::now();
        let (width, height) = engine.size();
        if (width, height) != (self.layout.width, self.layout.height) {
            return Err(crate::error::Error::Invalid(format!(
                "the frame is {width}x{height} but the block tables were made for {}x{}",
                self.layout.width, self.layout.height
            )));
        }
        let ctx = Context::with_light_selection(scene, accel, LIGHT_SELECTION);
        let light_choice = matches!(engine, Engine::MonteCarlo { .. }).then_some(&ctx.lights);
        let summary = FrameSummary::new(scene, light_choice);
        let small = engine.small_objects(&ctx);
        let mut stats = FrameStats::default();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(engine.threads().unwrap_or(0))
            .build()
            .map_err(|e| crate::error::Error::Invalid(format!("cannot start threads: {e}")))?;
        // Samples are reused only while every light stays as it was (shading reads them).
        let mut lights_same = false;
        let (blocks, mut image, changed) = match self.previous.take() {
            None => {
                stats.full_reason = Some("first frame".into());
                (BlockSet::all(&self.layout), Image::new(width, height), None)
            }
            Some((previous, image)) => {
                let changes = previous.diff(&summary);
                lights_same =
                    !changes.light_moved && changes.shadows.is_empty() && changes.dimmed.is_empty();
                let (mut blocks, voxels, changed) = pool.install(|| self.blocks_for(&changes));
                for disc in small.differences(&self.small) {
                    self.layout.insert_pixels(&disc.pixels(), &mut blocks);
                }
                stats.changed_voxels = voxels;
                stats.full_reason = changed.as_ref().err().cloned();
                (blocks, image, changed.ok())
            }
        };
        match &mut self.store {
            Store::Tables(tables) => tables.clear(&blocks),
            Store::Segments(segments) => segments.clear(&blocks),
        }
        // The retraced blocks' queries, to reuse where nothing changed along them (only
        // when the frame's changed voxels are known: not after a change that reaches every
        // pixel, whose geometry changes are not worked out).
        let mut previous_camera: Vec<Recorded> = vec![Recorded::default(); self.layout.len()];
        for b in blocks.iter() {
            previous_camera[b] = std::mem::take(&mut self.camera[b]);
        }
        let changed = changed.filter(|_| self.camera_on);
        // From here on, record only where a later frame changes something (the check
        // above used the previous frame's set, under which its records were made).
        if self.position > 0 && self.last_change.is_some() {
            self.update_active();
        }
        stats.bookkeeping_seconds = start.elapsed().as_secs_f64();

        let list: Vec<usize> = blocks.iter().collect();
        // A frame that retraces a few blocks cuts them into tiles no larger than the full
        // renderer's, to keep every thread busy; with many blocks, each block is traced
        // whole (one recorder records each voxel once per block and traces fewer shared
        // tile corners; a pixel's value does not depend on the tiling), and small blocks
        // are traced several to a task, which spares the driver a hand-over per block.
        let workers = crate::transport::driver::worker_count(engine.threads(), usize::MAX);
        let split = list.len() < 8 * workers;
        let per_task = if split {
            1
        } else {
            let area = (self.layout.width as usize * self.layout.height as usize)
                .div_ceil(self.layout.len())
                .max(1);
            let tile = crate::render::TILE_SIZE as usize;
            (4 * tile * tile / area).clamp(1, (list.len() / (8 * workers)).max(1))
        };
        let pieces: Vec<(usize, Tile)> = list
            .iter()
            .flat_map(|&b| {
                let r = self.layout.rect(b);
                let whole = Tile {
                    x0: 0,
                    x1: r.x1 - r.x0,
                    y0: 0,
                    y1: r.y1 - r.y0,
                };
                let tiles = if split {
                    crate::render::tiles(r.x1 - r.x0, r.y1 - r.y0)
                } else {
                    vec![whole]
                };
                tiles.into_iter().map(move |t| {
                    (
                        b,
                        Tile {
                            x0: r.x0 + t.x0,
                            x1: r.x0 + t.x1,
                            y0: r.y0 + t.y0,
                            y1: r.y0 + t.y1,
                        },
                    )
                })
            })
            .collect();
        let tasks: Vec<&[(usize, Tile)]> = pieces.chunks(per_task).collect();
        let (voxels, store) = (&self.voxels, &self.store);
        let records = store.records();
        let nearest_blocker = matches!(engine, Engine::Whitted { .. });
        // Camera hits are kept from a block's first retrace on, not by a frame traced in
        // full: most blocks of such a frame are never retraced, and keeping theirs cost frame
        // 0 more time (the memory's first touch) than reusing them saved later.
        let camera_on = self.camera_on && stats.full_reason.is_none();
        let mut results: Vec<(Vec<Rgb>, RayStats, Recorded)> = Vec::with_capacity(pieces.len());
        let trace = |(b, tile): &(usize, Tile)| {
            let mut recorder = RecordingAccel::new(accel, scene, voxels, nearest_blocker, records);
            if camera_on {
                let reuse = changed.as_ref().map(|changed| Reuse {
                    previous: &previous_camera[*b].camera,
                    shaded: &previous_camera[*b].shaded,
                    shading: lights_same,
                    changed,
                });
                recorder = recorder.with_camera(&summary.keys, reuse);
            }
            let (pixels, rays) = engine.region(&ctx, &recorder, &small, tile);
            if let Store::Tables(tables) = store {
                recorder.flush(tables, *b);
            }
            (pixels, rays, recorder.finish())
        };
        let driven = drive(
            &tasks,
            engine.threads(),
            MERGE_WINDOW,
            &control.cancel,
            |task| task.iter().map(trace).collect::<Vec<_>>(),
            |_, r| results.extend(r),
        );
        drop(previous_camera);
        if driven.cancelled {
            // A frame is written whole or not at all; the records are no longer whole
            // either, so the next frame starts afresh.
            self.reset();
            control.cancel.check("a frame")?;
        }
        for b in blocks.iter() {
            self.lights[b] = 0;
        }
        for ((b, t), (pixels, rays, recorded)) in pieces.iter().zip(results) {
            self.lights[*b] |= recorded.lights;
            if let Store::Segments(store) = &mut self.store {
                store.add(*b, recorded.segments, recorded.hit);
            }
            // (A block traced in several tiles: the parts in order.)
            stats.samples_reused += recorded.samples_reused;
            let kept = Recorded {
                camera: recorded.camera,
                shaded: recorded.shaded,
                ..Recorded::default()
            };
            if self.camera[*b].camera.is_empty() {
                self.camera[*b] = kept;
            } else {
                self.camera[*b].append(kept);
            }
            stats.camera_rays += recorded.camera_rays;
            stats.camera_reused += recorded.camera_reused;
            stats.others_reused += recorded.others_reused;
            crate::render::place(&mut image, (0, 0), t, pixels);
            stats.rays.add(&rays);
            stats.pixels_retraced += t.pixels();
        }
        stats.blocks_retraced = list.len();
        stats.blocks_total = self.layout.len();
        stats.blocks = list;
        if self.record_bytes() + self.camera_bytes() > self.segment_budget {
            // Over the budget: segment records become tables, and stored answers are no longer
            // kept (the frames stay the same; retraced camera rays are queried again).
            self.camera_on = false;
            self.camera = vec![Recorded::default(); self.layout.len()];
            if let Store::Segments(segments) = &self.store {
                let tables = pool.install(|| segments.to_tables(&self.voxels, &self.layout));
                self.store = Store::Tables(tables);
            }
        }
        stats.seconds = start.elapsed().as_secs_f64();
        self.previous = Some((summary, image.clone()));
        self.small = small;
        self.position += 1;
        Ok((image, stats))
    }
}
