//! Pixel-block bit tables (Jevans 1992, section 3.2): the screen is cut into a fixed number of
//! blocks (16x16 by default, up to one per pixel) and every voxel keeps one bit per block,
//! set when a ray of a pixel in that block crosses the voxel. Memory does not depend on the
//! image resolution. Each voxel has two tables: one for rays that find surfaces (camera,
//! reflection, refraction, path bounces) and one for shadow rays (section 6.2), so that a
//! light whose intensity changes retraces only the pixels that looked at it.

use crate::render::Tile;
use std::sync::atomic::{AtomicU64, Ordering};

/// How pixels map to blocks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockLayout {
    pub width: u32,
    pub height: u32,
    /// Blocks across and down.
    pub cols: u32,
    pub rows: u32,
}

impl BlockLayout {
    /// `cols`×`rows` blocks over a `width`×`height` image (never more blocks than pixels).
    pub fn new(width: u32, height: u32, cols: u32, rows: u32) -> BlockLayout {
        BlockLayout {
            width,
            height,
            cols: cols.clamp(1, width.max(1)),
            rows: rows.clamp(1, height.max(1)),
        }
    }

    pub fn len(&self) -> usize {
        self.cols as usize * self.rows as usize
    }

    /// The block holding pixel (x, y).
    pub fn block_of(&self, x: u32, y: u32) -> usize {
        let c = (x as u64 * self.cols as u64 / self.width as u64) as usize;
        let r = (y as u64 * self.rows as u64 / self.height as u64) as usize;
        r * self.cols as usize + c
    }

    /// The pixels of block `b`.
    pub fn rect(&self, b: usize) -> Tile {
        let (c, r) = (
            (b % self.cols as usize) as u64,
            (b / self.cols as usize) as u64,
        );
        let edge = |i: u64, n: u64, size: u32| (i * size as u64).div_ceil(n) as u32;
        Tile {
            x0: edge(c, self.cols as u64, self.width),
            x1: edge(c + 1, self.cols as u64, self.width),
            y0: edge(r, self.rows as u64, self.height),
            y1: edge(r + 1, self.rows as u64, self.height),
        }
    }

    /// Adds the blocks holding the pixels of `pixels` (clipped to the image) to `into`.
    pub fn insert_pixels(&self, pixels: &Tile, into: &mut BlockSet) {
        for y in pixels.y0..pixels.y1.min(self.height) {
            for x in pixels.x0..pixels.x1.min(self.width) {
                into.insert(self.block_of(x, y));
            }
        }
    }

    /// Words of 64 bits a table of this layout takes.
    pub fn words(&self) -> usize {
        self.len().div_ceil(64)
    }
}

/// A set of blocks (the frame-buffer table of section 3.3.1).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BlockSet {
    pub words: Vec<u64>,
}

impl BlockSet {
    pub fn new(layout: &BlockLayout) -> BlockSet {
        BlockSet {
            words: vec![0; layout.words()],
        }
    }

    pub fn all(layout: &BlockLayout) -> BlockSet {
        let mut s = BlockSet::new(layout);
        for b in 0..layout.len() {
            s.insert(b);
        }
        s
    }

    pub fn insert(&mut self, b: usize) {
        self.words[b / 64] |= 1 << (b % 64);
    }

    pub fn contains(&self, b: usize) -> bool {
        self.words[b / 64] >> (b % 64) & 1 != 0
    }

    #[cfg(test)]
    pub fn count(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    pub fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        self.words.iter().enumerate().flat_map(|(i, &w)| {
            (0..64)
                .filter(move |b| w >> b & 1 != 0)
                .map(move |b| i * 64 + b)
        })
    }
}

/// Which table of a voxel a ray segment goes to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Table {
    /// Rays that look for the closest surface.
    Surface,
    /// Shadow rays.
    Shadow,
}

/// The two bit tables of every voxel, written concurrently by the render threads (bits are
/// only ever OR-ed in while a frame renders, so the result does not depend on thread order).
pub struct VoxelTables {
    words: usize,
    surface: Vec<AtomicU64>,
    shadow: Vec<AtomicU64>,
    /// Blocks whose rays found any surface at all: what a moved light can reach.
    hits: Vec<AtomicU64>,
}

impl VoxelTables {
    pub fn new(voxels: usize, layout: &BlockLayout) -> VoxelTables {
        let words = layout.words();
        let zeros = |n: usize| (0..n).map(|_| AtomicU64::new(0)).collect::<Vec<_>>();
        VoxelTables {
            words,
            surface: zeros(voxels * words),
            shadow: zeros(voxels * words),
            hits: zeros(words),
        }
    }

    fn table(&self, t: Table) -> &[AtomicU64] {
        match t {
            Table::Surface => &self.surface,
            Table::Shadow => &self.shadow,
        }
    }

    /// Records that a ray of block `block` crossed `voxel`.
    pub fn set(&self, t: Table, voxel: usize, block: usize) {
        let word = &self.table(t)[voxel * self.words + block / 64];
        let bit = 1 << (block % 64);
        // Most crossings find the bit already set: a load keeps the cache line shared.
        if word.load(Ordering::Relaxed) & bit == 0 {
            word.fetch_or(bit, Ordering::Relaxed);
        }
    }

    /// Records that a ray of block `block` found a surface.
    pub fn set_hit(&self, block: usize) {
        let bit = 1 << (block % 64);
        if self.hits[block / 64].load(Ordering::Relaxed) & bit == 0 {
            self.hits[block / 64].fetch_or(bit, Ordering::Relaxed);
        }
    }

    /// OR-s a voxel's table into `into`.
    pub fn collect(&self, t: Table, voxel: usize, into: &mut BlockSet) {
        let table = &self.table(t)[voxel * self.words..(voxel + 1) * self.words];
        for (w, a) in into.words.iter_mut().zip(table) {
            *w |= a.load(Ordering::Relaxed);
        }
    }

    pub fn collect_hits(&self, into: &mut BlockSet) {
        for (w, a) in into.words.iter_mut().zip(&self.hits) {
            *w |= a.load(Ordering::Relaxed);
        }
    }

    /// Forgets every record of the blocks in `blocks` (they are about to be retraced and may
    /// not cross the same voxels again).
    pub fn clear(&mut self, blocks: &BlockSet) {
        let words = self.words;
        for table in [&mut self.surface, &mut self.shadow] {
            for chunk in table.chunks_mut(words) {
                for (a, m) in chunk.iter_mut().zip(&blocks.words) {
                    *a.get_mut() &= !m;
                }
            }
        }
        for (a, m) in self.hits.iter_mut().zip(&blocks.words) {
            *a.get_mut() &= !m;
        }
    }

    /// Bytes the tables take.
    pub fn memory_bytes(&self) -> usize {
        (self.surface.len() + self.shadow.len() + self.hits.len()) * 8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_partition_the_image() {
        for (w, h, c, r) in [
            (20, 15, 16, 16),
            (7, 5, 3, 2),
            (64, 64, 64, 64),
            (3, 3, 16, 16),
        ] {
            let l = BlockLayout::new(w, h, c, r);
            let mut seen = vec![usize::MAX; (w * h) as usize];
            for b in 0..l.len() {
                let t = l.rect(b);
                for y in t.y0..t.y1 {
                    for x in t.x0..t.x1 {
                        assert_eq!(seen[(y * w + x) as usize], usize::MAX);
                        seen[(y * w + x) as usize] = b;
                        assert_eq!(l.block_of(x, y), b);
                    }
                }
            }
            assert!(seen.iter().all(|&b| b != usize::MAX));
        }
    }
}
