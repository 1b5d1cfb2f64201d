//! The buffers a batch of slots is linked with, reused from batch to batch: the sorts'
//! scratch, the sorted hits, and the link ends and escapes found.

use super::row_buckets::RowBuckets;
use super::sorted_hits::SortedHits;
use super::LineHit;

/// Reusable buffers of a batch's linking and the sorts before it.
#[derive(Default)]
pub struct LinkBuffers {
    pub(super) counts: Vec<u32>,
    pub(super) tmp: Vec<LineHit>,
    pub(super) radix: Vec<LineHit>,
    pub(super) sorted: SortedHits,
    pub(super) rows: RowBuckets,
    /// The batch's packed link ends, one bucket per key block, each in the order the links
    /// were found, slot after slot (so grouped by slot already); `bucket_at[b·slots + j]` is
    /// block b's length before the batch's j-th slot.
    pub(super) buckets: Vec<Vec<u32>>,
    pub(super) bucket_at: Vec<u32>,
    /// The batch's later escapes, slot after slot: slot j's are
    /// `more[more_at[j]..more_at[j + 1]]` (past the last, room for the next slot's).
    pub(super) more: Vec<u32>,
    pub(super) more_at: Vec<usize>,
    /// A slot's escapes, over all side keys (cleared after each slot).
    pub(super) escapes: Vec<u64>,
}
