//! The assembly: the linking's batches of packed link ends turned into the node table, one
//! key block at a time.

use super::etendue::{has_escape, list_escape_etendue, list_etendue, SlotWeights};
use super::patches::Patches;
use super::preprocess::{self, EndPacking, LinkBatch};
use super::ray_space::RaySpace;
use super::{BuildStats, LinkCode, Network, NetworkParams, ESCAPE, NONE};

/// Side keys per block of the link table's assembly, at most 2^9: a block's links (at most
/// 512 nodes, about a megabyte at 1,200 slots) stay in cache while they are grouped, and each
/// slot's ends for a block are long enough to stream. Networks of more than 2^23 side keys
/// take smaller blocks (the packed link ends, [`preprocess::EndPacking`], need the bits).
pub const MAX_KEY_BLOCK_BITS: u32 = 9;

/// The places of a key block's links by key ([`BlockLinks::places`]): one more than the
/// largest block's keys.
const KEY_BLOCK_PLACES: usize = (1 << MAX_KEY_BLOCK_BITS) + 1;

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
    ) -> Result<Network, super::build::BuildError> {
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
                 a larger intercept_step or fewer slopes"
            )
            .into());
        }
        let w = SlotWeights::new(&space);
        // Each block fills its own part. The link table is reserved fallibly: memory the
        // system refuses is an error, not an abort.
        let mut links = crate::platform::try_vec(total, 0u32, || {
            format!("the link table of the illumination network ({total} links)")
        })?;
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
}
