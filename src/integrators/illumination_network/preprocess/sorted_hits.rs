//! A slot's hits sorted by line as three arrays, and the sort of each line's few hits by
//! depth that the linking runs first.

use super::scan::LANES;
use super::LineHit;
use wide::{f32x4, i32x4, u32x4};

/// A slot's hits sorted by line, as three arrays (hit i is `line[i]`, `depth[i]`, `key[i]`):
/// the linking compares a hit with the one before it four hits at a time.
#[derive(Default)]
pub struct SortedHits {
    pub(super) line: Vec<u32>,
    pub(super) depth: Vec<f32>,
    pub(super) key: Vec<u32>,
}

impl SortedHits {
    pub(super) fn len(&self) -> usize {
        self.line.len()
    }

    pub(super) fn get(&self, i: usize) -> LineHit {
        LineHit {
            line: self.line[i],
            depth: self.depth[i],
            key: self.key[i],
        }
    }

    /// `n` hits, their values left to be overwritten (the arrays only grow).
    pub(super) fn set_len(&mut self, n: usize) {
        if self.line.len() < n {
            self.line.resize(n, 0);
            self.depth.resize(n, 0.0);
            self.key.resize(n, 0);
        }
        self.line.truncate(n);
        self.depth.truncate(n);
        self.key.truncate(n);
    }

    /// Each line's few hits in order of (depth, key): an insertion sort that never moves a hit
    /// past its line's first. The scan order mostly gives the order already, so each hit is
    /// compared with the one before it four at a time, and the sort's step runs only for a
    /// group with a pair out of order (for each of its hits in turn: a step changes what
    /// the next compares).
    pub(super) fn sort_lines(&mut self) {
        let n = self.len();
        let mut i = 1;
        while i + LANES <= n {
            // The hits before [i, i + 4) and those hits (slices of one length: no bounds
            // checks in the loop).
            let (line, depth, key) = (&self.line[..n], &self.depth[..n], &self.key[..n]);
            let u32s = |v: &[u32], at: usize| {
                let v: [u32; LANES] = v[at..at + LANES].try_into().expect("four hits");
                v
            };
            let f32s = |at: usize| {
                let v: [f32; LANES] = depth[at..at + LANES].try_into().expect("four hits");
                f32x4::from(v)
            };
            let bits = |m: i32x4| wide::bytemuck::cast::<_, f32x4>(m).to_bitmask();
            let same = u32x4::from(u32s(line, i - 1)).simd_eq(u32x4::from(u32s(line, i)));
            // Keys are below 2^31: a signed comparison orders them.
            let (k0, k1): (i32x4, i32x4) = (
                wide::bytemuck::cast(u32s(key, i - 1)),
                wide::bytemuck::cast(u32s(key, i)),
            );
            let (d0, d1) = (f32s(i - 1), f32s(i));
            let before =
                d1.simd_lt(d0).to_bitmask() | (d1.simd_eq(d0).to_bitmask() & bits(k1.simd_lt(k0)));
            if bits(wide::bytemuck::cast(same)) & before != 0 {
                (i..i + LANES).for_each(|h| self.insert(h));
            }
            i += LANES;
        }
        (i..n).for_each(|h| self.insert(h));
    }

    /// The insertion sort's step for hit `h`.
    fn insert(&mut self, mut h: usize) {
        while h > 0 && self.line[h - 1] == self.line[h] && {
            let (x, y) = (self.get(h - 1), self.get(h));
            (y.depth, y.key) < (x.depth, x.key)
        } {
            for v in [&mut self.line, &mut self.key] {
                v.swap(h, h - 1);
            }
            self.depth.swap(h, h - 1);
            h -= 1;
        }
    }
}
