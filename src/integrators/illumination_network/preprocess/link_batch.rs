//! A batch of slots' links as packed link ends grouped by key block, the form the assembly
//! reads them in.

use super::counting_sort::group_slots;
use super::link_buffers::LinkBuffers;
use super::packing::EndPacking;

/// The links of a batch of consecutive slots as packed link ends ([`EndPacking`]: a side key
/// and the side key at the other end), grouped by key block and, within a block, by slot:
/// group g = b·slots + j (block b, the batch's j-th slot) is `ends[start[g]..start[g + 1]]`, in
/// the order the links were found along the sorted lines (each link's two ends); and the
/// escapes, kept apart, grouped alike. The assembly reads block b of every batch in turn, so
/// a block's share of a batch lies in one piece.
#[derive(Clone, Debug, Default)]
pub struct LinkBatch {
    pub slots: u32,
    pub ends: Vec<u32>,
    pub start: Vec<u32>,
    /// Bit sets over side keys: the sides whose line leaves the scene, per group: group g's
    /// bits are `escapes[g·w..(g + 1)·w]` for w = `words` (block / 64), bit i of word k the
    /// block's key 64·k + i. Escapes can be as many as link ends, and most are on sides that
    /// never become nodes: as bits they take a thirty-second of the memory, and the assembly
    /// skips the sides that are not nodes a word at a time. (Those of sides facing out of
    /// the scene, a room's walls seen from outside, are not recorded at all.)
    pub escapes: Vec<u64>,
    /// Escape words per group: a block's keys / 64.
    pub words: usize,
    /// A side's second and later escapes in a slot (a patch meeting two lines that both
    /// leave), per group: `more_escapes[more_start[g]..more_start[g + 1]]`.
    pub more_escapes: Vec<u32>,
    pub more_start: Vec<u32>,
    /// Links between two sides (each has two ends).
    pub pairs: u64,
    pub intersections: u64,
    /// Consecutive hits on the same side (dropped).
    pub degenerate: u64,
}

impl LinkBatch {
    /// Group of key block `b` and the batch's `j`-th slot.
    #[inline]
    fn group(&self, b: usize, j: usize) -> usize {
        b * self.slots as usize + j
    }

    /// The packed link ends of key block `b` in the batch's `j`-th slot.
    #[inline]
    pub fn ends(&self, b: usize, j: usize) -> &[u32] {
        let g = self.group(b, j);
        &self.ends[self.start[g] as usize..self.start[g + 1] as usize]
    }

    /// The ends of key block `b` in every slot of the batch.
    #[inline]
    pub fn block_ends(&self, b: usize) -> usize {
        let (g0, g1) = (self.group(b, 0), self.group(b + 1, 0));
        (self.start[g1] - self.start[g0]) as usize
    }

    /// The escape bits of key block `b` in the batch's `j`-th slot.
    #[inline]
    pub fn escapes(&self, b: usize, j: usize) -> &[u64] {
        let g = self.group(b, j);
        &self.escapes[g * self.words..(g + 1) * self.words]
    }

    /// The second and later escapes of key block `b` in the batch's `j`-th slot.
    #[inline]
    pub fn more_escapes(&self, b: usize, j: usize) -> &[u32] {
        let g = self.group(b, j);
        &self.more_escapes[self.more_start[g] as usize..self.more_start[g + 1] as usize]
    }
}

impl LinkBatch {
    /// An empty batch of `slots` slots, for `keys` side keys.
    pub(super) fn new(slots: usize, keys: usize, packing: EndPacking) -> LinkBatch {
        let groups = keys.div_ceil(packing.block()) * slots;
        let words = packing.block() / 64;
        LinkBatch {
            slots: slots as u32,
            start: vec![0; groups + 1],
            escapes: vec![0; groups * words],
            words,
            more_start: vec![0; groups + 1],
            ..LinkBatch::default()
        }
    }

    /// Joins the batch's buckets of link ends block after block (each is grouped by slot
    /// already) and groups its later escapes (`buf`, slot after slot) by key block and slot,
    /// keeping their order within a group.
    pub(super) fn group_ends(&mut self, buf: &LinkBuffers, packing: EndPacking) {
        let slots = self.slots as usize;
        let total: usize = buf.buckets.iter().map(Vec::len).sum();
        self.pairs = total as u64 / 2;
        let mut ends = Vec::with_capacity(total);
        for (b, bucket) in buf.buckets.iter().enumerate() {
            let base = ends.len() as u32;
            let at = &buf.bucket_at[b * slots..(b + 1) * slots];
            for (to, &at) in self.start[b * slots..(b + 1) * slots].iter_mut().zip(at) {
                *to = base + at;
            }
            ends.extend_from_slice(bucket);
        }
        *self.start.last_mut().expect("a batch has a group") = total as u32;
        self.ends = ends;
        self.more_escapes = group_slots(&mut self.more_start, &buf.more, &buf.more_at, |k| {
            (packing.block_of(k) * slots, k)
        });
    }
}
