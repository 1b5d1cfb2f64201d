//! Illumination networks (Buckalew & Fussell, "Illumination Networks: Fast Realistic Rendering
//! with Arbitrary Reflectance Functions", 1989): the patch-link model.
//!
//! - [`ray_space`]: the uniform 4-D grid of lines and the étendue weight of a line cell.
//! - [`patches`]: polygons (and spheres) cut into patches; each patch side is a potential
//!   network node.
//! - [`preprocess`]: lines → links, by incremental scan conversion or by Embree casting.
//! - [`Network`] (here): the compact network: per node its links in slot order, 32 bits each
//!   (the slot and the node at the other end).
//! - [`distribute`]: light carried over the links until convergence, with reflectance maps
//!   for diffuse (the paper's bypass), mirror, glossy, transmission and frosted surfaces.
//! - [`render`]: eye rays find the patch; interpolation over patches and slopes (figure 6).
//! - [`file`](mod@file): saving and loading networks, so views and lighting change without a preprocess.
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
pub(crate) mod technique;

use crate::integrators::Context;
use crate::job::Control;
use crate::scene::Scene;
use patches::Patches;
pub use preprocess::Builder;
use preprocess::{EndPacking, LinkBatch};
use ray_space::RaySpace;
use std::time::Instant;

/// No link in this slot (no line of this slope meets the side), in a row of
/// [`Network::row_into`].
pub const NONE: u32 = u32::MAX;
/// The slot's line leaves the scene.
pub const ESCAPE: u32 = u32::MAX - 1;

/// Side keys per block of the link table's assembly, at most 2^9: a block's links (at most
/// 512 nodes, about a megabyte at 1,200 slots) stay in cache while they are grouped, and each
/// slot's ends for a block are long enough to stream. Networks of more than 2^23 side keys
/// take smaller blocks (the packed link ends, [`preprocess::EndPacking`], need the bits).
pub const MAX_KEY_BLOCK_BITS: u32 = 9;

/// The places of a key block's links by key ([`BlockLinks::places`]): one more than the
/// largest block's keys.
const KEY_BLOCK_PLACES: usize = (1 << MAX_KEY_BLOCK_BITS) + 1;

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
    /// Links beyond the first of their slot at a node (a patch meeting two lines of a slot).
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

/// How a node's link is stored in 32 bits: its slot in the high bits, the node at the other
/// end in the low ones (all ones: the line leaves the scene). Half of a node's slots have no
/// link on average, so a list of its links takes about half the memory of the paper's row of
/// one entry per slot, and the slot bits cost nothing a row index did not.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkCode {
    target_bits: u32,
}

impl LinkCode {
    /// The code for `slots` slots and `keys` side keys (nodes are at most as many).
    pub fn new(slots: usize, keys: usize) -> Result<LinkCode, String> {
        let slot_bits = (usize::BITS - slots.saturating_sub(1).leading_zeros()).max(1);
        let target_bits = 32u32.saturating_sub(slot_bits);
        if keys as u64 >= 1u64 << target_bits {
            return Err(format!(
                "the network would have {} patch sides, more than its 32-bit links can address \
                 at {slots} slots per patch ({}); use a larger --patch-size or fewer --slopes",
                keys,
                (1u64 << target_bits) - 1
            ));
        }
        Ok(LinkCode { target_bits })
    }

    /// The target bits of an escape (and a mask of the target bits).
    #[inline]
    fn escape(self) -> u32 {
        (1 << self.target_bits) - 1
    }

    /// A link of `slot` to node `target` (or [`ESCAPE`]).
    #[inline]
    pub fn pack(self, slot: u32, target: u32) -> u32 {
        let t = if target == ESCAPE {
            self.escape()
        } else {
            target
        };
        slot << self.target_bits | t
    }

    /// A link of `slot` to a node (not an escape).
    #[inline]
    fn pack_node(self, slot: u32, node: u32) -> u32 {
        slot << self.target_bits | node
    }

    #[inline]
    pub fn slot(self, link: u32) -> usize {
        (link >> self.target_bits) as usize
    }

    /// The node at the other end, or [`ESCAPE`].
    #[inline]
    pub fn target(self, link: u32) -> u32 {
        let t = link & self.escape();
        if t == self.escape() {
            ESCAPE
        } else {
            t
        }
    }

    /// The other end's bits as they are: an escape is larger than any node (the loader's
    /// checks compare them without a branch).
    #[inline]
    pub fn raw_target(self, link: u32) -> usize {
        (link & self.escape()) as usize
    }
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
    /// Each node's links in slot order, packed by `code`: node n's are
    /// `links[link_start[n]..link_start[n + 1]]`. A patch bigger than an intercept cell in
    /// projection can meet two lines of one slot: such a slot has two (or more) links.
    pub link_start: Vec<u32>,
    pub links: Vec<u32>,
    pub code: LinkCode,
    /// For each node, W = Σ w over its links (escapes included).
    pub etendue: Vec<f32>,
    /// For each node, the part of W over its escaping links (the energy balance's escapes),
    /// added up beside W by the build and the loader.
    pub escape_etendue: Vec<f32>,
    pub stats: BuildStats,
}

/// The slots' étendues w, padded with zeros to a power of two: a slot index masked into the
/// table needs no bounds check in the loops over links (every link's slot is below the
/// number of slots, so the mask changes nothing).
pub(crate) struct SlotWeights {
    w: Vec<f32>,
    mask: usize,
}

impl SlotWeights {
    pub(crate) fn new(space: &RaySpace) -> SlotWeights {
        let mut w = space.etendues();
        let mask = w.len().next_power_of_two() - 1;
        w.resize(mask + 1, 0.0);
        SlotWeights { w, mask }
    }

    /// The table (its length `mask() + 1`) and the mask.
    #[inline]
    pub(crate) fn table(&self) -> (&[f32], usize) {
        (&self.w[..=self.mask], self.mask)
    }
}

/// Σ term(l) over `list`, in four interleaved partial sums added as (s₀ + s₁) + (s₂ + s₃): one
/// running sum over ~800 links would be a chain of dependent additions. The order is fixed,
/// so the bits depend on the list alone.
#[inline(always)]
pub(crate) fn interleaved_sum<T>(list: &[u32], mut term: impl FnMut(u32) -> T) -> T
where
    T: Copy + Default + std::ops::Add<Output = T> + std::ops::AddAssign,
{
    let mut sum = [T::default(); 4];
    let mut quads = list.chunks_exact(4);
    for q in &mut quads {
        for (s, &l) in sum.iter_mut().zip(q) {
            *s += term(l);
        }
    }
    for (s, &l) in sum.iter_mut().zip(quads.remainder()) {
        *s += term(l);
    }
    (sum[0] + sum[1]) + (sum[2] + sum[3])
}

/// W of one node: Σ w over its links (`list`, in slot order) ([`interleaved_sum`]). The
/// build and the loader both add up W here, so a loaded network has the same bits.
#[inline(always)]
fn list_etendue(code: LinkCode, w: &SlotWeights, list: &[u32]) -> f32 {
    let (w, mask) = w.table();
    interleaved_sum(list, |l| w[code.slot(l) & mask])
}

/// Whether a node's links include an escape.
#[inline]
fn has_escape(code: LinkCode, list: &[u32]) -> bool {
    let escape = code.escape();
    list.iter()
        .fold(false, |any, &l| any | (l & escape == escape))
}

/// The part of a node's W over its escaping links (the energy balance's escapes), in the
/// order of [`list_etendue`]. The build and the loader add it up once, for the nodes with
/// an escape (few in a closed scene), so a distribution does not walk every link for it.
fn list_escape_etendue(code: LinkCode, w: &SlotWeights, list: &[u32]) -> f32 {
    let (w, mask) = w.table();
    let escape = code.escape();
    interleaved_sum(list, |l| {
        if l & escape == escape {
            w[code.slot(l) & mask]
        } else {
            0.0
        }
    })
}

/// What the assembly reads the links of a key block from: the batches' link ends and escapes,
/// and the node numbering.
struct BlockLinks<'a> {
    batches: &'a [LinkBatch],
    packing: EndPacking,
    code: LinkCode,
    node_of_key: &'a [u32],
    marks: &'a [u64],
}

impl BlockLinks<'_> {
    /// The places of key block `b`'s links by key: `at[j]` the first place of its j-th key's
    /// links and `at[block]` their number (its link ends and its escapes at nodes), and the
    /// block's node marks (bit j of word j / 64: the j-th key is a node). The ends are
    /// counted from their key bits alone, and a key is a node when it has an end: the
    /// linking marks no nodes, and the count needs no node numbering.
    fn places<const USUAL: bool>(
        batches: &[LinkBatch],
        packing: EndPacking,
        b: usize,
    ) -> (Vec<u32>, Vec<u64>) {
        let packing = packing.known::<USUAL>();
        // The largest block's size whatever the block (those past it count nothing), so
        // that the fill's places are a fixed-size array: its index, a key's offset in the
        // block, then needs no bounds check with the usual packing.
        let mut at = vec![0u32; KEY_BLOCK_PLACES];
        for s in batches {
            for j in 0..s.slots as usize {
                for &e in s.ends(b, j) {
                    at[(e >> packing.target_bits) as usize + 1] += 1;
                }
            }
        }
        let marks: Vec<u64> = at[1..=packing.block()]
            .chunks_exact(64)
            .map(|c| (0..64).fold(0, |m, i| m | u64::from(c[i] > 0) << i))
            .collect();
        for s in batches {
            for j in 0..s.slots as usize {
                Self::escapes_at_nodes(s, b, j, &marks, |k| at[k as usize + 1] += 1);
            }
        }
        preprocess::starts_from_counts(&mut at);
        (at, marks)
    }

    /// Calls `keep(j)` for each escape at a node of key block `b` in slot `j` of batch `s`
    /// (the node's key the j-th of the block; `marks` the block's node marks): a word of
    /// node marks at a time, then the side's later escapes.
    #[inline(always)]
    fn escapes_at_nodes(
        s: &LinkBatch,
        b: usize,
        j: usize,
        marks: &[u64],
        mut keep: impl FnMut(u32),
    ) {
        for (wi, (&e, &mk)) in (0u32..).zip(s.escapes(b, j).iter().zip(marks)) {
            let mut m = e & mk;
            while m != 0 {
                keep(wi * 64 + m.trailing_zeros());
                m &= m - 1;
            }
        }
        let k0 = (b * s.words * 64) as u32;
        for &k in s.more_escapes(b, j) {
            let k = k - k0;
            if marks[k as usize / 64] >> (k % 64) & 1 == 1 {
                keep(k);
            }
        }
    }

    /// Puts every link of key block `b` in place, in slot order (a slot's link ends, then
    /// its escapes at nodes): a link goes to its key's next place (`at`, by the key's offset
    /// in the block) in `out`, the block's part of the table.
    #[inline(always)]
    fn fill<const USUAL: bool>(&self, b: usize, at: &mut [u32; KEY_BLOCK_PLACES], out: &mut [u32]) {
        let packing = self.packing.known::<USUAL>();
        let code = self.code;
        let slots = self
            .batches
            .iter()
            .flat_map(|s| (0..s.slots as usize).map(move |j| (s, j)));
        let words = packing.block() / 64;
        let block_marks = &self.marks[b * words..((b + 1) * words).min(self.marks.len())];
        for (slot, (s, j)) in slots.enumerate() {
            let slot = slot as u32;
            let ends = s.ends(b, j);
            place_ends::<USUAL>(
                ends,
                packing,
                code.pack_node(slot, 0),
                self.node_of_key,
                at,
                out,
            );
            // Then the slot's escapes at nodes (a side's escapes are all alike, so their order
            // among themselves does not matter).
            let escape = code.pack(slot, ESCAPE);
            Self::escapes_at_nodes(s, b, j, block_marks, |k| {
                let to = &mut at[k as usize];
                out[*to as usize] = escape;
                *to += 1;
            });
        }
    }
}

/// Puts one slot's link ends of a key block in place ([`BlockLinks::fill`]); `slot` is the
/// slot packed as a link ([`LinkCode`]), to which the node at the other end is added. Not
/// inlined: the loop then has the registers to itself (inlined in the block's fill, it
/// reloaded three addresses from the stack for every end).
#[inline(never)]
fn place_ends<const USUAL: bool>(
    ends: &[u32],
    packing: EndPacking,
    slot: u32,
    node_of_key: &[u32],
    at: &mut [u32; KEY_BLOCK_PLACES],
    out: &mut [u32],
) {
    let packing = packing.known::<USUAL>();
    let target_mask = (1 << packing.target_bits) - 1;
    for &e in ends {
        let to = &mut at[(e >> packing.target_bits) as usize];
        out[*to as usize] = slot | node_of_key[(e & target_mask) as usize];
        *to += 1;
    }
}

impl Network {
    /// Preprocess: patches and links for a scene. The Embree builder casts through `ctx`.
    pub fn build(
        scene: &Scene,
        ctx: &Context,
        params: NetworkParams,
        builder: Builder,
    ) -> Result<Network, String> {
        Self::build_packed(
            scene,
            ctx,
            params,
            builder,
            EndPacking::for_keys,
            true,
            &Control::default(),
        )
    }

    /// [`Network::build`] under a job's controls: its memory budget bounds the network, and
    /// a cancel stops the preprocess. A problem of the scene's is an error naming its file.
    pub(crate) fn build_with(
        scene: &Scene,
        ctx: &Context,
        params: NetworkParams,
        builder: Builder,
        control: &Control,
    ) -> crate::Result<Network> {
        let n = Self::build_packed(
            scene,
            ctx,
            params,
            builder,
            EndPacking::for_keys,
            true,
            control,
        )
        .map_err(|e| crate::Error::input(&scene.source, e))?;
        control.cancel.check("the network preprocess")?;
        Ok(n)
    }

    /// [`Network::build`] with the preprocess's link ends packed as `packing(side keys)` says,
    /// and the escapes of sides facing out of the scene dropped as the linking finds them or
    /// (`drop_outer` false) by the assembly, as those of any side that is not a node.
    fn build_packed(
        scene: &Scene,
        ctx: &Context,
        params: NetworkParams,
        builder: Builder,
        packing: impl FnOnce(usize) -> Result<EndPacking, String>,
        drop_outer: bool,
        control: &Control,
    ) -> Result<Network, String> {
        params.validate()?;
        let start = Instant::now();
        let bounds = scene.bounds().ok_or("the scene has no shapes")?;
        let space = RaySpace::new(params.slopes, params.step, bounds);
        let patches = Patches::new(scene, &space, params.patch_size)?;
        // A bound: a link per slot for each side of each cell (half of them are linked in a
        // closed room); the preprocess's link ends take about as much again.
        let table = patches.cells as u64 * 2 * space.slots() as u64 * 4;
        control
            .budget
            .check("the illumination network", 2 * table)
            .map_err(|e| e.to_string())?;
        if builder == Builder::Scan {
            if let Some(p) = patches.polygons.iter().find(|p| p.sphere.is_some()) {
                return Err(format!(
                    "shape {} is a sphere: the scan converter projects polygons only; use \
                     --network-builder embree",
                    p.shape
                ));
            }
        }
        let keys = 2 * patches.cells as usize;
        let packing = packing(keys)?;
        let code = LinkCode::new(space.slots(), keys)?;
        let outer = match drop_outer {
            true => patches.outer_sides(),
            false => vec![0; keys.div_ceil(64)],
        };
        let t = Instant::now();
        let (batches, rays) = preprocess::build_links(
            (builder == Builder::Embree).then_some(ctx),
            &space,
            &patches,
            params.seed,
            params.jitter,
            builder,
            packing,
            &outer,
        );
        let link_seconds = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let mut net = Network::assemble(params, space, patches, &batches, packing, code)?;
        net.stats.assemble_seconds = t.elapsed().as_secs_f64();
        net.stats.link_seconds = link_seconds;
        net.stats.rays = rays.total();
        net.stats.seconds = start.elapsed().as_secs_f64();
        Ok(net)
    }

    /// Numbers the nodes (sides with at least one real link, in key order) and fills the
    /// link lists. Each batch of slots has its link ends grouped by blocks of side keys
    /// ([`LinkBatch`], `packing`), so one task fills a block's place in the table (a
    /// megabyte or so) by walking every slot's ends for that block in slot order twice: to
    /// count each key's links, then to put them in place (a stable counting sort: each
    /// node's links stay in slot order; keys are counted, not nodes, since the nodes are
    /// numbered in key order and other keys have no links). Blocks are independent
    /// (parallel), and nothing depends on the schedule.
    pub fn assemble(
        params: NetworkParams,
        space: RaySpace,
        patches: Patches,
        batches: &[LinkBatch],
        packing: EndPacking,
        code: LinkCode,
    ) -> Result<Network, String> {
        use rayon::prelude::*;
        let keys = 2 * patches.cells as usize;
        let block = packing.block();
        let blocks = keys.div_ceil(block);
        // Each block's links by key, exactly, so that each block fills its own place; and
        // its nodes: keys with a real link (not only escapes).
        let (places, marks): (Vec<Vec<u32>>, Vec<Vec<u64>>) = (0..blocks)
            .into_par_iter()
            .map(|b| match packing == EndPacking::USUAL {
                true => BlockLinks::places::<true>(batches, packing, b),
                false => BlockLinks::places::<false>(batches, packing, b),
            })
            .unzip();
        let mut marks = marks.concat();
        marks.truncate(keys.div_ceil(64));
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
        let block_links = BlockLinks {
            batches,
            packing,
            code,
            node_of_key: &node_of_key,
            marks: &marks,
        };
        let total: usize = places.iter().map(|at| at[block] as usize).sum();
        if total > u32::MAX as usize {
            return Err(format!(
                "the network would have {total} links, more than 32-bit offsets address; use \
                 a larger --intercept-step or fewer --slopes"
            ));
        }
        let w = SlotWeights::new(&space);
        // Zeroed pages come lazily from the system; each block fills its own part.
        let mut links = vec![0u32; total];
        let mut link_start = vec![0u32; nodes + 1];
        let mut etendue = vec![0f32; nodes];
        let mut escape_etendue = vec![0f32; nodes];
        let mut parts = Vec::with_capacity(blocks);
        {
            let mut rest = (
                &mut links[..],
                &mut link_start[1..],
                &mut etendue[..],
                &mut escape_etendue[..],
            );
            let mut base = 0;
            for (b, at) in places.into_iter().enumerate() {
                let (count, n) = (at[block] as usize, first_node[b + 1] - first_node[b]);
                let (l, lr) = std::mem::take(&mut rest.0).split_at_mut(count);
                let (s, sr) = std::mem::take(&mut rest.1).split_at_mut(n);
                let (e, er) = std::mem::take(&mut rest.2).split_at_mut(n);
                let (x, xr) = std::mem::take(&mut rest.3).split_at_mut(n);
                rest = (lr, sr, er, xr);
                parts.push((b, at, base as u32, l, s, (e, x)));
                base += count;
            }
        }
        // Per block: the escapes seen, and the links beyond the first of their slot.
        let filled: Vec<(u64, u64)> = parts
            .into_par_iter()
            .map(|(b, mut at, base, out, ends_at, (wb, xb))| {
                // The block's links walked in slot order and put in place by key. Nodes are
                // numbered in key order and keys that are not nodes have no links, so the
                // keys' places are the nodes'.
                let ends: usize = batches.iter().map(|s| s.block_ends(b)).sum();
                let escapes = (out.len() - ends) as u64;
                let k0 = b * block;
                let block_keys = &node_of_key[k0..(k0 + block).min(keys)];
                let nodes_at = block_keys.iter().zip(&at[1..]).filter(|(&n, _)| n != NONE);
                for (to, (_, &end)) in ends_at.iter_mut().zip(nodes_at) {
                    *to = base + end;
                }
                let at: &mut [u32; KEY_BLOCK_PLACES] =
                    (&mut at[..]).try_into().expect("a block's places");
                match packing == EndPacking::USUAL {
                    true => block_links.fill::<true>(b, at, out),
                    false => block_links.fill::<false>(b, at, out),
                }
                // W (and its escapes' part, in blocks with escapes), and the links beyond the
                // first of their slot.
                let mut extra = 0u64;
                let mut from = 0;
                for (i, (wn, xn)) in wb.iter_mut().zip(xb.iter_mut()).enumerate() {
                    let to = (ends_at[i] - base) as usize;
                    let list = &out[from..to];
                    *wn = list_etendue(code, &w, list);
                    if escapes > 0 && has_escape(code, list) {
                        *xn = list_escape_etendue(code, &w, list);
                    }
                    for p in list.windows(2) {
                        extra += u64::from(code.slot(p[0]) == code.slot(p[1]));
                    }
                    from = to;
                }
                (escapes, extra)
            })
            .collect();
        let mut stats = BuildStats::default();
        for s in batches {
            stats.intersections += s.intersections;
            stats.degenerate += s.degenerate;
            stats.link_ends += 2 * s.pairs;
        }
        for (escapes, extra) in filled {
            stats.escapes += escapes;
            stats.extra += extra;
        }
        Ok(Network {
            params,
            space,
            patches,
            node_of_key,
            key_of_node,
            link_start,
            links,
            code,
            etendue,
            escape_etendue,
            stats,
        })
    }

    pub fn nodes(&self) -> usize {
        self.key_of_node.len()
    }

    pub fn slots(&self) -> usize {
        self.space.slots()
    }

    /// A node's links, in slot order (packed by [`Network::code`]).
    #[inline]
    pub fn links_of(&self, node: u32) -> &[u32] {
        let n = node as usize;
        &self.links[self.link_start[n] as usize..self.link_start[n + 1] as usize]
    }

    /// A node's links as (slot, node at the other end or [`ESCAPE`]), in slot order.
    #[inline]
    pub fn slot_links(&self, node: u32) -> impl DoubleEndedIterator<Item = (usize, u32)> + '_ {
        let code = self.code;
        self.links_of(node)
            .iter()
            .map(move |&l| (code.slot(l), code.target(l)))
    }

    /// A node's links as a row of one entry per slot (the paper's layout): the other end of
    /// the slot's first link, [`ESCAPE`], or [`NONE`]. For the directional nodes' maps and
    /// rendering, which look slots up by direction.
    pub fn row_into(&self, node: u32, row: &mut Vec<u32>) {
        row.clear();
        row.resize(self.slots(), NONE);
        for (slot, t) in self.slot_links(node).rev() {
            row[slot] = t;
        }
    }

    /// The rows ([`Network::row_into`]) of `nodes`, one after another.
    pub fn rows_of(&self, nodes: impl IntoIterator<Item = u32>) -> Vec<u32> {
        let (mut rows, mut row) = (Vec::new(), Vec::new());
        for node in nodes {
            self.row_into(node, &mut row);
            rows.extend_from_slice(&row);
        }
        rows
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

    /// The scene material of a node (its polygon's shape's), and its side (0 front, 1 back).
    pub fn node_material(&self, node: u32, scene: &Scene) -> (usize, u32) {
        let (poly, _, side) = self.node_place(node);
        let shape = self.patches.polygons[poly as usize].shape as usize;
        (scene.shapes[shape].material, side)
    }

    /// The node on the other side of a node's patch (where transmitted light goes on), or
    /// [`NONE`] when no link reaches that side.
    #[inline]
    pub fn twin(&self, node: u32) -> u32 {
        self.node_of_key[(self.key_of_node[node as usize] ^ 1) as usize]
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
            + self.link_start.len()
            + self.node_of_key.len()
            + self.key_of_node.len()
            + self.etendue.len())
            + self.patches.polygons.len() * std::mem::size_of::<patches::Polygon>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{self, Backend};

    /// The loops over link ends are compiled apart for the usual packing
    /// ([`EndPacking::known`]): the other copies, those of networks of more than 2^23 side
    /// keys, must build the same network.
    #[test]
    fn every_packing_of_link_ends_builds_the_same_network() {
        let (scene, params) = cornell_network();
        let acc = accel::build(&scene, Backend::Embree, &Control::default()).unwrap();
        let ctx = Context::new(&scene, acc.as_ref());
        let usual = Network::build(&scene, &ctx, params, Builder::Scan).unwrap();
        // Blocks of 64 keys: the smallest the packing allows.
        let small = |_| {
            Ok(EndPacking {
                block_bits: 6,
                target_bits: 26,
            })
        };
        let other = Network::build_packed(
            &scene,
            &ctx,
            params,
            Builder::Scan,
            small,
            true,
            &Control::default(),
        )
        .unwrap();
        assert_eq!(
            EndPacking::for_keys(2 * usual.patches.cells as usize),
            Ok(EndPacking::USUAL)
        );
        assert!(usual.links.len() > 10_000 && usual.stats.escapes > 0 && usual.stats.extra > 0);
        assert_same_network(&usual, &other);
    }

    /// The linking drops the escapes of sides facing out of the scene, which the assembly
    /// would drop as those of sides that are not nodes: the network is the same either way.
    /// The Cornell box is open at the front, so some of its nodes have escapes.
    #[test]
    fn dropping_the_outer_sides_escapes_builds_the_same_network() {
        let (scene, params) = cornell_network();
        let acc = accel::build(&scene, Backend::Embree, &Control::default()).unwrap();
        let ctx = Context::new(&scene, acc.as_ref());
        for builder in [Builder::Scan, Builder::Embree] {
            let build = |drop| {
                Network::build_packed(
                    &scene,
                    &ctx,
                    params,
                    builder,
                    EndPacking::for_keys,
                    drop,
                    &Control::default(),
                )
                .unwrap()
            };
            let (dropped, kept) = (build(true), build(false));
            let outer = dropped.patches.outer_sides();
            // The ceiling and three walls (the floor is tilted by a hair).
            let ones: u32 = outer.iter().map(|w| w.count_ones()).sum();
            assert!(ones > 1000, "{ones} outer sides");
            assert!(dropped.stats.escapes > 0);
            assert_same_network(&dropped, &kept);
        }
    }

    /// The Cornell box and a small network's parameters.
    fn cornell_network() -> (Scene, NetworkParams) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
        let params = NetworkParams {
            slopes: 4,
            step: 1.0 / 32.0,
            patch_size: 1.0 / 16.0,
            jitter: 1.0,
            seed: 3,
        };
        (Scene::load(&path).unwrap(), params)
    }

    /// The two networks are the same, bit for bit.
    fn assert_same_network(a: &Network, b: &Network) {
        assert_eq!(a.key_of_node, b.key_of_node);
        assert_eq!(a.node_of_key, b.node_of_key);
        assert_eq!(a.link_start, b.link_start);
        assert_eq!(a.links, b.links);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.etendue), bits(&b.etendue));
        assert_eq!(bits(&a.escape_etendue), bits(&b.escape_etendue));
        assert_eq!(a.stats.extra, b.stats.extra);
        assert_eq!(a.stats.escapes, b.stats.escapes);
    }
}
