//! The preprocess: which patches each grid line meets, in order along the line, and the links
//! between consecutive ones.
//!
//! **Scan conversion** (the paper's builder). For one slot (slope pair) and one polygon, the
//! polygon is projected onto the intercept plane along the slot's direction; the lines whose
//! (jittered) intercepts fall inside the projection meet the polygon. Rows of the intercept
//! grid are scanned; along a row the intersection coordinate p_a follows the paper's
//! recurrence: with the plane n·p + D = 0 and δ = n_a + n_u s_u + n_v s_v computed once per
//! slope and polygon, B' = n_u/δ, C' = n_v/δ, D' = D/δ,
//!
//! ```text
//! p_a = −D' − B'·i_u − C'·i_v at the row's first cell, then p_a ← p_a − B'·h per cell,
//! ```
//!
//! and the line's jitter (a fraction of h on each intercept, hashed from the seed and the
//! line) adds −B'·δ_u − C'·δ_v. The inside test uses the jittered intercept itself, so both
//! builders meet exactly the same lines. A row's cells go four at a time through SIMD lanes
//! (the jitter hash, the intercepts, the inside test, the patch keys); the depths still
//! follow the recurrence cell after cell.
//!
//! **Embree casting**. The same jittered lines are cast through the intersection backend with
//! repeated closest-hit queries (for geometry the scan converter cannot project, and as a
//! cross-check).
//!
//! **Links.** The hits of one slot are sorted by (line, p_a): the scan converter buckets them
//! by intercept row as it finds them and one counting pass by column finishes the sort by
//! line ([`RowBuckets`]); Embree's hits take a radix sort. Consecutive hits k, k+1 on a line
//! link the side of k facing +d with the side of k+1 facing −d; the first and last hits have
//! an *escape* slot (light leaving that way leaves the scene). Work is parallel over batches
//! of slots (the paper's slope queue; [`LinkBatch`]) and merged in slot order: the network
//! does not depend on the thread count.
//!
//! Files: `scan.rs` (one polygon's scan conversion in SIMD lanes), `row_buckets.rs` (a slot's
//! polygons scanned into buckets by intercept row, then sorted by line), `cast.rs` (Embree
//! casting and its radix sort), `sorted_hits.rs` (a slot's hits by line, in depth order on a
//! line), `link.rs` (consecutive hits linked, in parallel over batches of slots),
//! `link_batch.rs` (a batch's links grouped by key block for the assembly), `packing.rs` (a
//! link end in 32 bits) and `counting_sort.rs` (the stable counting sorts they share).

mod cast;
mod counting_sort;
mod link;
mod link_batch;
mod link_buffers;
mod packing;
mod row_buckets;
mod scan;
mod sorted_hits;

pub(super) use counting_sort::starts_from_counts;
pub use link::{build_links, LinkInputs};
pub use link_batch::LinkBatch;
pub use packing::EndPacking;
#[cfg(test)]
pub use row_buckets::{scan_order, scan_slot};
#[cfg(test)]
pub use scan::{line_point, scan_polygon};

/// A line meeting a patch: the line within its slot, p_a along it, and the key of the side
/// facing +d (cell·2 + 0 for the front, + 1 for the back).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineHit {
    pub line: u32,
    pub depth: f32,
    pub key: u32,
}

/// Which builder finds the line-patch intersections.
pub use crate::settings::NetworkBuilder as Builder;
