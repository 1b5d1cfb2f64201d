//! Illumination networks (Buckalew & Fussell, "Illumination Networks: Fast Realistic Rendering
//! with Arbitrary Reflectance Functions", 1989): the patch-link model.
//!
//! - [`ray_space`]: the uniform 4-D grid of lines and the étendue weight of a line cell.
//! - [`patches`]: polygons (and spheres) cut into patches; each patch side is a potential
//!   network node.
//! - [`preprocess`]: lines → links, by incremental scan conversion or by Embree casting.
//! - [`Network`] (here): the compact network: per node one 32-bit link per slot, plus extra
//!   links for slots that meet the patch more than once.
//! - [`distribute`]: light carried over the links until convergence, with reflectance maps
//!   for diffuse (the paper's bypass), mirror, glossy, transmission and frosted surfaces.
//! - [`render`]: eye rays find the patch; interpolation over patches and slopes (figure 6).
//! - [`file`]: saving and loading networks, so views and lighting change without a preprocess.
//!
//! Units: a link carries *flux*; a slot's étendue w converts between radiance and flux. A
//! node's étendue W is the sum of w over its slots (linked or escaping), about π·area: a
//! diffuse node with flux Φ leaving it has radiance Φ/W on every link, which keeps energy
//! exactly conserved whatever the sampling (the form factors are Σw/W).

pub mod distribute;
pub mod file;
pub mod patches;
pub mod preprocess;
pub mod ray_space;
pub mod relight;
pub mod render;

use crate::integrators::Context;
use crate::scene::Scene;
use patches::Patches;
pub use preprocess::Builder;
use preprocess::{EndPacking, LinkBatch};
use ray_space::RaySpace;
use std::time::Instant;

/// No link in this slot (no line of this slope meets the side).
pub const NONE: u32 = u32::MAX;
/// The slot's line leaves the scene.
pub const ESCAPE: u32 = u32::MAX - 1;

/// Side keys per block of the link table's assembly, at most 2^9: a block's rows (at most 512
/// nodes, 2.4 MB at 1,200 slots) stay in the last-level cache while it is filled, and each
/// slot's ends for a block are long enough to stream. Networks of more than 2^23 side keys
/// take smaller blocks (the packed link ends, [`preprocess::EndPacking`], need the bits).
pub const MAX_KEY_BLOCK_BITS: u32 = 9;

pub const DEFAULT_SLOPES: u32 = 12;
pub const DEFAULT_STEP: f32 = 1.0 / 64.0;
pub const DEFAULT_TOLERANCE: f32 = 1e-3;

/// What the network's geometry depends on (the file header stores these).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NetworkParams {
    /// Slopes per axis (S): 3·S² slots per node.
    pub slopes: u32,
    /// Intercept step h, unit-cube units.
    pub step: f32,
    /// Patch edge, unit-cube units.
    pub patch_size: f32,
    /// Intercept jitter, a fraction of h (0: the regular grid; 1: anywhere in the cell).
    pub jitter: f32,
    pub seed: u64,
}

impl Default for NetworkParams {
    fn default() -> Self {
        NetworkParams {
            slopes: DEFAULT_SLOPES,
            step: DEFAULT_STEP,
            patch_size: DEFAULT_STEP,
            jitter: 1.0,
            seed: 0,
        }
    }
}

impl NetworkParams {
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=128).contains(&self.slopes) {
            return Err(format!(
                "--slopes must be between 1 and 128, got {}",
                self.slopes
            ));
        }
        if !(self.step.is_finite() && self.step >= 1.0 / 4096.0 && self.step <= 1.0) {
            return Err(format!(
                "--intercept-step must be between 1/4096 and 1, got {}",
                self.step
            ));
        }
        if !(self.patch_size.is_finite()
            && self.patch_size >= 1.0 / 4096.0
            && self.patch_size <= 1.0)
        {
            return Err(format!(
                "--patch-size must be between 1/4096 and 1, got {}",
                self.patch_size
            ));
        }
        if !(0.0..=1.0).contains(&self.jitter) {
            return Err(format!("--jitter must be in [0, 1], got {}", self.jitter));
        }
        Ok(())
    }
}

/// What a preprocess did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildStats {
    /// Line-patch intersections found.
    pub intersections: u64,
    /// Link ends stored (each link counts at both of its nodes).
    pub link_ends: u64,
    /// Slots whose line leaves the scene.
    pub escapes: u64,
    /// Link ends beyond the first of their slot at a node (in `extra`).
    pub extra: u64,
    /// Consecutive hits of a line on the same side or on touching surfaces (no link).
    pub degenerate: u64,
    /// Closest-hit queries (Embree builder).
    pub rays: u64,
    /// Whole preprocess, and its parts: finding and linking the lines (parallel over slots)
    /// and assembling the node table.
    pub seconds: f64,
    pub link_seconds: f64,
    pub assemble_seconds: f64,
}

/// The illumination network: geometry only (no materials, no light), so it is reused for
/// new views and new lighting.
#[derive(Clone, Debug)]
pub struct Network {
    pub params: NetworkParams,
    pub space: RaySpace,
    pub patches: Patches,
    /// For each side key (cell·2 + side), its node or [`NONE`].
    pub node_of_key: Vec<u32>,
    /// For each node, its side key.
    pub key_of_node: Vec<u32>,
    /// nodes × slots: the node at the other end of each slot's link, [`ESCAPE`] or [`NONE`].
    pub links: Vec<u32>,
    /// Further links of a slot whose entry in `links` is taken (a patch that meets more than
    /// one line of a slope): the (slot, target) pairs of node n are
    /// extra[extra_start[n]..extra_start[n + 1]].
    pub extra_start: Vec<u32>,
    pub extra: Vec<[u32; 2]>,
    /// For each node, W = Σ w over its linked and escaping slots.
    pub etendue: Vec<f32>,
    pub stats: BuildStats,
}

/// W of one node: Σ w over its linked and escaping slots, in slot order, a slot's entry in
/// the row before its extra links (`extra`: the node's extra (slot, target) pairs, in slot
/// order). This is the order in which the build adds them up while it fills the table, so
/// a loaded network has the same bits.
#[inline]
pub(crate) fn row_etendue(row: &[u32], extra: &[[u32; 2]], w: &[f32]) -> f32 {
    let mut sum = 0.0f32;
    let mut more = extra.iter().peekable();
    for (slot, (&t, &ws)) in row.iter().zip(w).enumerate() {
        if t != NONE {
            sum += ws;
        }
        while more.next_if(|e| e[0] as usize == slot).is_some() {
            sum += ws;
        }
    }
    sum
}

/// W of every node.
pub(crate) fn node_etendue(
    space: &RaySpace,
    links: &[u32],
    extra_start: &[u32],
    extra: &[[u32; 2]],
) -> Vec<f32> {
    use rayon::prelude::*;
    let w = space.etendues();
    links
        .par_chunks(space.slots())
        .enumerate()
        .map(|(n, row)| {
            row_etendue(
                row,
                &extra[extra_start[n] as usize..extra_start[n + 1] as usize],
                &w,
            )
        })
        .collect()
}

/// Slots per cache line of a link row (cleared together by the assembly).
const FILL_SLOTS: usize = 16;

impl Network {
    /// Preprocess: patches and links for a scene. The Embree builder casts through `ctx`.
    pub fn build(
        scene: &Scene,
        ctx: &Context,
        params: NetworkParams,
        builder: Builder,
    ) -> Result<Network, String> {
        params.validate()?;
        let start = Instant::now();
        let bounds = scene.bounds().ok_or("the scene has no shapes")?;
        let space = RaySpace::new(params.slopes, params.step, bounds);
        let patches = Patches::new(scene, &space, params.patch_size)?;
        // The dense link table (a u32 per slot for each side of each cell) dominates; the
        // preprocess's sorted line hits take about as much again.
        let table = patches.cells as u64 * 2 * space.slots() as u64 * 4;
        crate::memory::check("the illumination network", 2 * table).map_err(|e| e.to_string())?;
        if builder == Builder::Scan {
            if let Some(p) = patches.polygons.iter().find(|p| p.sphere.is_some()) {
                return Err(format!(
                    "shape {} is a sphere: the scan converter projects polygons only; use \
                     --network-builder embree",
                    p.shape
                ));
            }
        }
        let packing = EndPacking::for_keys(2 * patches.cells as usize)?;
        let t = Instant::now();
        let (batches, rays) = preprocess::build_links(
            (builder == Builder::Embree).then_some(ctx),
            &space,
            &patches,
            params.seed,
            params.jitter,
            builder,
            packing,
        );
        let link_seconds = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let mut net = Network::assemble(params, space, patches, &batches, packing);
        net.stats.assemble_seconds = t.elapsed().as_secs_f64();
        net.stats.link_seconds = link_seconds;
        net.stats.rays = rays.total();
        net.stats.seconds = start.elapsed().as_secs_f64();
        Ok(net)
    }

    /// Numbers the nodes (sides with at least one real link, in key order) and fills the
    /// dense link table. Each batch of slots has its link ends grouped by blocks of side keys
    /// ([`LinkBatch`], `packing`), so a block's rows (a few hundred kilobytes) are filled
    /// in cache by one task walking every slot's ends for that block in slot order: the
    /// first end of a slot at a node goes into its row, further ones into its extra links.
    /// Blocks are independent (parallel), and nothing depends on the schedule.
    pub fn assemble(
        params: NetworkParams,
        space: RaySpace,
        patches: Patches,
        batches: &[LinkBatch],
        packing: EndPacking,
    ) -> Network {
        use rayon::prelude::*;
        let keys = 2 * patches.cells as usize;
        let block = packing.block();
        let blocks = keys.div_ceil(block);
        let n_slots = space.slots();
        // Nodes: keys with a real link (not only escapes), marked by each batch of slots.
        let words = keys.div_ceil(64);
        let mut marks = vec![0u64; words];
        for s in batches {
            for (m, &sm) in marks.iter_mut().zip(&s.marks) {
                *m |= sm;
            }
        }
        let mut first_node = Vec::with_capacity(blocks + 1);
        let mut node_of_key = vec![NONE; keys];
        let mut key_of_node = Vec::new();
        for (wi, &m) in marks.iter().enumerate() {
            if wi % (block / 64) == 0 {
                first_node.push(key_of_node.len());
            }
            for i in 0..64 {
                if m >> i & 1 == 1 {
                    let k = wi * 64 + i;
                    node_of_key[k] = key_of_node.len() as u32;
                    key_of_node.push(k as u32);
                }
            }
        }
        let nodes = key_of_node.len();
        first_node.push(nodes);
        let w = space.etendues();
        // Zeroed pages come lazily from the system; each block fills its own rows.
        let mut links = vec![0u32; nodes * n_slots];
        let mut etendue = vec![0f32; nodes];
        let mut parts = Vec::with_capacity(blocks);
        {
            let (mut rest, mut wrest) = (&mut links[..], &mut etendue[..]);
            for b in 0..blocks {
                let n = first_node[b + 1] - first_node[b];
                let (rows, r) = std::mem::take(&mut rest).split_at_mut(n * n_slots);
                let (wb, wr) = std::mem::take(&mut wrest).split_at_mut(n);
                rest = r;
                wrest = wr;
                parts.push((b, rows, wb));
            }
        }
        // Per block: where each of its nodes' extra links start, their (slot, target) pairs
        // grouped by node, and the escapes seen.
        type Part = (Vec<u32>, Vec<[u32; 2]>, u64);
        let filled: Vec<Part> = parts
            .into_par_iter()
            .map_init(Vec::new, |extra, (b, rows, wb)| {
                let first = first_node[b] as u32;
                let nodes_in_block = rows.len() / n_slots;
                // Room for every end and escape of the block: one that finds its slot taken
                // is written there and kept by advancing `len`, without a branch (whether a
                // slot is taken is close to a coin toss, which a branch would mispredict).
                // (Escapes count too: a large patch in an open scene meets many escaping
                // lines of a slot.)
                let room: usize = batches
                    .iter()
                    .map(|s| s.block_ends(b) + s.block_escapes(b))
                    .sum();
                // (A buffer per thread, reused: a block's room is a megabyte or so. Only
                // grown, never cleared: every entry kept is written first.)
                if extra.len() < room {
                    extra.resize(room, (0u32, [0u32; 2]));
                }
                let mut len = 0;
                let mut escapes = 0u64;
                let (w0, w1) = (b * block / 64, ((b + 1) * block / 64).min(words));
                let slots = batches
                    .iter()
                    .flat_map(|s| (0..s.slots as usize).map(move |j| (s, j)));
                // Rows end in a partial line when the slots are not a multiple of
                // FILL_SLOTS: that part is cleared first, so that the loop clears whole lines.
                let whole = n_slots - n_slots % FILL_SLOTS;
                for row in rows.chunks_exact_mut(n_slots) {
                    row[whole..].fill(NONE);
                }
                for (slot, (s, j)) in slots.enumerate() {
                    // Each row's next cache line of slots is cleared just before the slots
                    // are filled, while the block's lines are in cache (clearing the whole
                    // block first would send them back to memory before they are filled).
                    if slot % FILL_SLOTS == 0 && slot < whole {
                        for r in 0..nodes_in_block {
                            // (A fixed-size array: a call to memset per 64 bytes costs more.)
                            if let Some(line) =
                                rows[r * n_slots + slot..].first_chunk_mut::<FILL_SLOTS>()
                            {
                                *line = [NONE; FILL_SLOTS];
                            }
                        }
                    }
                    let ws = w[slot];
                    // One end (node, target): the first of its slot at the node fills the
                    // row, later ones go to the extra links.
                    // (A macro, shared by the three loops below.)
                    macro_rules! put {
                        ($node:expr, $target:expr) => {{
                            let (node, target): (u32, u32) = ($node, $target);
                            let local = (node - first) as usize;
                            let e = &mut rows[local * n_slots + slot];
                            let taken = *e != NONE;
                            *e = if taken { *e } else { target };
                            extra[len] = (node - first, [slot as u32, target]);
                            len += usize::from(taken);
                            // W in slot order, as `row_etendue` adds it up.
                            wb[local] += ws;
                        }};
                    }
                    for &e in s.ends(b, j) {
                        let (k, t) = packing.unpack(b, e);
                        let node = node_of_key[k as usize];
                        if node != NONE {
                            put!(node, node_of_key[t as usize]);
                        }
                    }
                    // Then the slot's escapes at nodes (a side's escapes are all alike, so
                    // their order among themselves does not matter).
                    for (wi, &e) in (w0..w1).zip(s.escapes(b, j)) {
                        let mut m = e & marks[wi];
                        while m != 0 {
                            put!(node_of_key[wi * 64 + m.trailing_zeros() as usize], ESCAPE);
                            escapes += 1;
                            m &= m - 1;
                        }
                    }
                    for &k in s.more_escapes(b, j) {
                        let node = node_of_key[k as usize];
                        if node != NONE {
                            put!(node, ESCAPE);
                            escapes += 1;
                        }
                    }
                }
                let extra = &extra[..len];
                // Grouped by node, in slot order within a node.
                let mut start = vec![0u32; rows.len() / n_slots + 1];
                for e in extra {
                    start[e.0 as usize + 1] += 1;
                }
                let grouped =
                    preprocess::group_stably(&mut start, extra, |e| e.0 as usize, |e| e.1);
                (start, grouped, escapes)
            })
            .collect();
        let mut stats = BuildStats::default();
        for s in batches {
            stats.intersections += s.intersections;
            stats.degenerate += s.degenerate;
            stats.link_ends += 2 * s.pairs;
        }
        let mut extra_start = Vec::with_capacity(nodes + 1);
        extra_start.push(0u32);
        for (start, _, escapes) in &filled {
            stats.escapes += escapes;
            let base = extra_start[extra_start.len() - 1];
            extra_start.extend(start[1..].iter().map(|&i| base + i));
        }
        // The blocks' lists copied into place in parallel (the copy first touches the memory).
        let mut extra = vec![[0u32; 2]; extra_start[nodes] as usize];
        {
            let mut rest = &mut extra[..];
            let mut pieces = Vec::with_capacity(filled.len());
            for (_, list, _) in &filled {
                let (to, r) = std::mem::take(&mut rest).split_at_mut(list.len());
                rest = r;
                pieces.push((to, list));
            }
            pieces
                .into_par_iter()
                .for_each(|(to, list)| to.copy_from_slice(list));
        }
        stats.extra = extra.len() as u64;
        Network {
            params,
            space,
            patches,
            node_of_key,
            key_of_node,
            links,
            extra_start,
            extra,
            etendue,
            stats,
        }
    }

    pub fn nodes(&self) -> usize {
        self.key_of_node.len()
    }

    pub fn slots(&self) -> usize {
        self.space.slots()
    }

    /// The link row of a node.
    #[inline]
    pub fn row(&self, node: u32) -> &[u32] {
        let s = self.slots();
        &self.links[node as usize * s..(node as usize + 1) * s]
    }

    /// The extra (slot, target) links of a node.
    #[inline]
    pub fn extra_links(&self, node: u32) -> &[[u32; 2]] {
        let (a, b) = (
            self.extra_start[node as usize] as usize,
            self.extra_start[node as usize + 1] as usize,
        );
        &self.extra[a..b]
    }

    /// The polygon, cell and side (0 front, 1 back) of a node.
    pub fn node_place(&self, node: u32) -> (u32, u32, u32) {
        let key = self.key_of_node[node as usize];
        let cell = key / 2;
        let poly = self
            .patches
            .polygons
            .partition_point(|p| p.first_cell <= cell)
            - 1;
        (poly as u32, cell, key & 1)
    }

    /// The outward unit normal of a node's side.
    pub fn node_normal(&self, node: u32) -> crate::math::Vec3 {
        let (poly, cell, side) = self.node_place(node);
        let pg = &self.patches.polygons[poly as usize];
        let (s, t) = pg.cell_centre(cell);
        let n = pg.normal_at(pg.point(s, t));
        if side == 0 {
            n
        } else {
            -n
        }
    }

    /// Bytes held by the network's tables.
    pub fn memory(&self) -> usize {
        4 * (self.links.len()
            + self.node_of_key.len()
            + self.key_of_node.len()
            + self.etendue.len()
            + self.extra_start.len()
            + 2 * self.extra.len())
            + self.patches.polygons.len() * std::mem::size_of::<patches::Polygon>()
    }
}
