//! The linking: a slot's sorted hits, consecutive ones on a line linked and the first and
//! last escaping, in parallel over batches of slots.

use super::cast::{cast_slot, radix_by_line};
use super::link_batch::LinkBatch;
use super::link_buffers::LinkBuffers;
use super::packing::EndPacking;
use super::row_buckets::scan_slot_into;
use super::sorted_hits::SortedHits;
use super::Builder;
use crate::control::CancelToken;
use crate::integrators::illumination_network::patches::Patches;
use crate::integrators::illumination_network::ray_space::RaySpace;
use crate::transport::{Context, RayStats};
use rayon::prelude::*;

/// Slots linked by one task, one after the other: a few, so that the assembly reads each key
/// block's ends and escapes in runs of several slots rather than a short piece per slot.
pub const SLOT_BATCH: usize = 8;

/// Hits closer than this along a line (unit-cube units of p_a) are on touching surfaces.
pub const COINCIDENT: f32 = 1e-5;

/// Sorts one slot's hits (sorted by line) by depth within each line's few hits and links
/// consecutive ones, as the `j`-th slot of `out`: the packed link ends go to their key
/// block's bucket and a side's second and later escapes to `more` (both joined later,
/// [`LinkBatch::group_ends`]), the escapes straight into `out`. (Which sides are nodes, the
/// assembly reads off the link ends.) Not inlined: in the batch's loop, its loop reloaded
/// the buckets' and the hits' addresses from the stack for every pair. The buffers come as
/// separate parameters, so that each `&mut` is a `noalias` argument: taken as one
/// `&mut LinkBuffers`, the linking ran 1.5% more instructions (callgrind, office, h = 1/128).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn link_slot<const USUAL: bool>(
    hits: &mut SortedHits,
    j: usize,
    packing: EndPacking,
    outer: &[u64],
    buckets: &mut [Vec<u32>],
    more: &mut Vec<u32>,
    more_at: &mut Vec<usize>,
    escapes: &mut [u64],
    out: &mut LinkBatch,
) {
    let packing = packing.known::<USUAL>();
    let len = hits.len();
    out.intersections += len as u64;
    // The slot's escapes gather in `escapes` (a bit set over all side keys: dense, so it
    // stays in cache, where the batch's block-major copy would not) and go to `out` after.
    // A side's later escapes go to `more` without a branch (whether a side has escaped
    // already is data, not a pattern): each escape is written at the next place, which
    // advances only for a later one. A line has at most two.
    let mut n = *more_at.last().expect("a batch's escapes start at 0");
    if more.len() < n + 2 * len {
        more.resize(n + 2 * len, 0);
    }
    // A slice: the compiler keeps its address and length in registers, where it reloaded
    // the Vec's from memory for every escape.
    let more = &mut more[..];
    let mut escape = |k: u32| {
        let (w, bit) = (k as usize / 64, k % 64);
        // A side facing out of the scene is never a node: its escape is dropped here, not
        // carried to the assembly (in a room, nearly every escape is a wall's outer side).
        if outer[w] >> bit & 1 == 1 {
            return;
        }
        let seen = escapes[w] >> bit & 1;
        more[n] = k;
        n += seen as usize;
        escapes[w] |= 1 << bit;
    };
    hits.sort_lines();
    // Entering the scene: the first side facing −d looks out of it; leaving it, the last
    // side facing +d. Consecutive hits on a line link; between lines, one leaves and the
    // next enters (the same order as line by line).
    let (line, depth, key) = (&hits.line[..len], &hits.depth[..len], &hits.key[..len]);
    if let (Some(&first), Some(&last)) = (key.first(), key.last()) {
        escape(first ^ 1);
        for i in 1..len {
            if line[i - 1] != line[i] {
                escape(key[i - 1]);
                escape(key[i] ^ 1);
                continue;
            }
            let (x, y) = (key[i - 1], key[i] ^ 1);
            // A line meeting the same side twice in a row (a hit on an edge counted by both
            // of its cells' polygon) carries nothing; coincident surfaces (a box standing on
            // the floor) touch, and no light passes between them.
            if x != y && depth[i] - depth[i - 1] > COINCIDENT {
                for (k, t) in [(x, y), (y, x)] {
                    buckets[packing.block_of(k)].push(packing.pack(k, t));
                }
            } else {
                out.degenerate += 1;
            }
        }
        escape(last);
    }
    more_at.push(n);
    let (words, slots) = (out.words, out.slots as usize);
    for (b, bits) in escapes.chunks_mut(words).enumerate() {
        let g = b * slots + j;
        out.escapes[g * words..g * words + bits.len()].copy_from_slice(bits);
        bits.fill(0);
    }
}

/// What the linking of every slot reads ([`build_links`]).
#[derive(Clone, Copy)]
pub struct LinkInputs<'a> {
    /// The Embree builder casts through it (the scan converter needs none).
    pub ctx: Option<&'a Context<'a>>,
    pub space: &'a RaySpace,
    pub patches: &'a Patches,
    /// The intercepts' jitter: its seed, and its amount as a fraction of the step.
    pub seed: u64,
    pub jitter: f32,
    pub builder: Builder,
    pub packing: EndPacking,
    /// A bit set over side keys: sides that can never be nodes ([`Patches::outer_sides`]).
    pub outer: &'a [u64],
    /// Once set, batches stop linking (the caller then drops what was built).
    pub cancel: &'a CancelToken,
}

/// Runs a builder over every slot, in parallel over batches of [`SLOT_BATCH`] slots,
/// returning the batches in slot order. Escapes at the side keys of `outer` are dropped.
pub fn build_links(inputs: &LinkInputs) -> (Vec<LinkBatch>, RayStats) {
    let LinkInputs {
        ctx,
        space,
        patches,
        seed,
        jitter,
        builder,
        packing,
        outer,
        cancel,
    } = *inputs;
    let slots = space.slots();
    let keys = 2 * patches.cells as usize;
    let results: Vec<(LinkBatch, RayStats)> = (0..slots.div_ceil(SLOT_BATCH))
        .into_par_iter()
        .map_init(LinkBuffers::default, |buf, batch| {
            let first = batch * SLOT_BATCH;
            let mut out = LinkBatch::new(SLOT_BATCH.min(slots - first), keys, packing);
            let mut stats = RayStats::default();
            let (slots, blocks) = (out.slots as usize, keys.div_ceil(packing.block()));
            buf.more_at.clear();
            buf.more_at.push(0);
            buf.buckets.resize_with(blocks, Vec::new);
            buf.buckets.iter_mut().for_each(Vec::clear);
            buf.bucket_at.clear();
            buf.bucket_at.resize(blocks * slots, 0);
            buf.escapes.resize(keys.div_ceil(64), 0);
            for j in 0..slots {
                if cancel.is_cancelled() {
                    break;
                }
                let slot = (first + j) as u32;
                match (builder, ctx) {
                    (Builder::Embree, Some(ctx)) => {
                        let hits = cast_slot(ctx, space, patches, slot, seed, jitter, &mut stats);
                        radix_by_line(&hits, space.lines_per_slot(), buf);
                    }
                    _ => {
                        scan_slot_into(space, patches, slot, seed, jitter, &mut buf.rows);
                        buf.rows.sorted_into(&mut buf.sorted);
                    }
                }
                for (b, bucket) in buf.buckets.iter().enumerate() {
                    buf.bucket_at[b * slots + j] = bucket.len() as u32;
                }
                let sorted = &mut buf.sorted;
                let (buckets, escapes) = (&mut buf.buckets, &mut buf.escapes);
                let (more, more_at) = (&mut buf.more, &mut buf.more_at);
                let (p, out) = (packing, &mut out);
                if p == EndPacking::USUAL {
                    link_slot::<true>(sorted, j, p, outer, buckets, more, more_at, escapes, out);
                } else {
                    link_slot::<false>(sorted, j, p, outer, buckets, more, more_at, escapes, out);
                }
            }
            out.group_ends(buf, packing);
            (out, stats)
        })
        .collect();
    let mut stats = RayStats::default();
    let links = results
        .into_iter()
        .map(|(l, s)| {
            stats.add(&s);
            l
        })
        .collect();
    (links, stats)
}
