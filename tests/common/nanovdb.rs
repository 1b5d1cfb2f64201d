//! A NanoVDB writer for tests only: float grids written byte by byte from the format's
//! layout (version 32: a segment header, a 176-byte record and the name of each grid, then
//! each grid as it lies in memory: grid, tree, root and its tiles, upper nodes, lower
//! nodes, leaves), independent of the reader in `src/`, to make valid files and damage them.

#![allow(dead_code)]

use std::collections::BTreeMap;

pub const MAGIC: u64 = 0x3042_4456_6f6e_614e; // "NanoVDB0"
pub const VERSION: u32 = (32 << 21) | (3 << 10) | 3;
pub const FLOAT: u32 = 1;
pub const FOG: u32 = 2;

const GRID: usize = 672;
const TREE: usize = 64;
const ROOT: usize = 64;
const TILE: usize = 32;
const UPPER: usize = 270_400;
const LOWER: usize = 33_856;
const LEAF: usize = 2144;

/// A float grid to write.
#[derive(Clone)]
pub struct Grid {
    pub name: String,
    pub class: u32,
    pub value_type: u32,
    pub version: u32,
    /// Index to world: a row-major 3×3 matrix and a translation.
    pub matrix: [f64; 9],
    pub translation: [f64; 3],
    pub background: f32,
    /// Active voxels, by index coordinates.
    pub voxels: BTreeMap<[i32; 3], f32>,
}

impl Grid {
    /// A fog volume named `name` with an identity map.
    pub fn new(name: &str) -> Grid {
        Grid {
            name: name.into(),
            class: FOG,
            value_type: FLOAT,
            version: VERSION,
            matrix: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            translation: [0.0; 3],
            background: 0.0,
            voxels: BTreeMap::new(),
        }
    }

    pub fn voxel(mut self, ijk: [i32; 3], v: f32) -> Grid {
        self.voxels.insert(ijk, v);
        self
    }

    /// The index box of the active voxels.
    fn bbox(&self) -> ([i32; 3], [i32; 3]) {
        let mut lo = [i32::MAX; 3];
        let mut hi = [i32::MIN; 3];
        for k in self.voxels.keys() {
            for a in 0..3 {
                lo[a] = lo[a].min(k[a]);
                hi[a] = hi[a].max(k[a]);
            }
        }
        (lo, hi)
    }

    /// The grid's bytes as NanoVDB holds them in memory.
    pub fn bytes(&self) -> Vec<u8> {
        let origin = |k: &[i32; 3], span: i32| k.map(|c| c.div_euclid(span) * span);
        let mut uppers: BTreeMap<[i32; 3], ()> = BTreeMap::new();
        let mut lowers: BTreeMap<[i32; 3], ()> = BTreeMap::new();
        let mut leaves: BTreeMap<[i32; 3], ()> = BTreeMap::new();
        for k in self.voxels.keys() {
            uppers.insert(origin(k, 4096), ());
            lowers.insert(origin(k, 128), ());
            leaves.insert(origin(k, 8), ());
        }
        let root = GRID + TREE;
        let first_upper = root + ROOT + TILE * uppers.len();
        let first_lower = first_upper + UPPER * uppers.len();
        let first_leaf = first_lower + LOWER * lowers.len();
        let size = first_leaf + LEAF * leaves.len();
        let index =
            |m: &BTreeMap<[i32; 3], ()>, k: &[i32; 3]| m.keys().position(|x| x == k).unwrap();
        let upper_at = |k: &[i32; 3]| first_upper + UPPER * index(&uppers, k);
        let lower_at = |k: &[i32; 3]| first_lower + LOWER * index(&lowers, k);
        let leaf_at = |k: &[i32; 3]| first_leaf + LEAF * index(&leaves, k);
        let mut b = vec![0u8; size];
        let put = |b: &mut Vec<u8>, at: usize, bytes: &[u8]| {
            b[at..at + bytes.len()].copy_from_slice(bytes)
        };
        // Grid.
        put(&mut b, 0, &MAGIC.to_le_bytes());
        put(&mut b, 16, &self.version.to_le_bytes());
        put(&mut b, 28, &1u32.to_le_bytes());
        put(&mut b, 32, &(size as u64).to_le_bytes());
        put(&mut b, 40, self.name.as_bytes());
        for i in 0..9 {
            put(&mut b, 296 + 4 * i, &(self.matrix[i] as f32).to_le_bytes());
            put(&mut b, 384 + 8 * i, &self.matrix[i].to_le_bytes());
        }
        for i in 0..3 {
            put(
                &mut b,
                368 + 4 * i,
                &(self.translation[i] as f32).to_le_bytes(),
            );
            put(&mut b, 528 + 8 * i, &self.translation[i].to_le_bytes());
        }
        put(&mut b, 380, &1f32.to_le_bytes());
        put(&mut b, 552, &1f64.to_le_bytes());
        put(&mut b, 632, &self.class.to_le_bytes());
        put(&mut b, 636, &self.value_type.to_le_bytes());
        // Tree: offsets from the tree to the first node of each level, and the counts.
        let tree = GRID;
        let offsets = [first_leaf, first_lower, first_upper, root].map(|a| (a - tree) as u64);
        for (i, o) in offsets.iter().enumerate() {
            let o = if i < 3 && [leaves.len(), lowers.len(), uppers.len()][i] == 0 {
                0
            } else {
                *o
            };
            put(&mut b, tree + 8 * i, &o.to_le_bytes());
        }
        for (i, n) in [leaves.len(), lowers.len(), uppers.len()]
            .iter()
            .enumerate()
        {
            put(&mut b, tree + 32 + 4 * i, &(*n as u32).to_le_bytes());
        }
        put(&mut b, tree + 56, &(self.voxels.len() as u64).to_le_bytes());
        // Root.
        let (lo, hi) = self.bbox();
        for a in 0..3 {
            put(&mut b, root + 4 * a, &lo[a].to_le_bytes());
            put(&mut b, root + 12 + 4 * a, &hi[a].to_le_bytes());
        }
        put(&mut b, root + 24, &(uppers.len() as u32).to_le_bytes());
        put(&mut b, root + 28, &self.background.to_le_bytes());
        for (t, k) in uppers.keys().enumerate() {
            let tile = root + ROOT + TILE * t;
            let key = k.map(|c| ((c as u32) >> 12) as u64);
            let key = (key[0] << 42) | (key[1] << 21) | key[2];
            put(&mut b, tile, &key.to_le_bytes());
            put(
                &mut b,
                tile + 8,
                &((upper_at(k) - root) as i64).to_le_bytes(),
            );
            put(&mut b, tile + 20, &self.background.to_le_bytes());
        }
        // Internal nodes: every entry a tile of the background but those with children.
        for (k, _) in uppers.iter() {
            let at = upper_at(k);
            put(&mut b, at, &bytes_of(k));
            for n in 0..32768 {
                put(&mut b, at + 8256 + 8 * n, &self.background.to_le_bytes());
            }
        }
        for (k, _) in lowers.iter() {
            let at = lower_at(k);
            put(&mut b, at, &bytes_of(k));
            for n in 0..4096 {
                put(&mut b, at + 1088 + 8 * n, &self.background.to_le_bytes());
            }
            let up = origin(k, 4096);
            let parent = upper_at(&up);
            let local = [0, 1, 2].map(|a| ((k[a] - up[a]) >> 7) as usize);
            let n = (local[0] << 10) | (local[1] << 5) | local[2];
            set_bit(&mut b, parent + 4128, n);
            put(
                &mut b,
                parent + 8256 + 8 * n,
                &((at - parent) as i64).to_le_bytes(),
            );
        }
        for (k, _) in leaves.iter() {
            let at = leaf_at(k);
            put(&mut b, at, &bytes_of(k));
            for n in 0..512 {
                put(&mut b, at + 96 + 4 * n, &self.background.to_le_bytes());
            }
            let low = origin(k, 128);
            let parent = lower_at(&low);
            let local = [0, 1, 2].map(|a| ((k[a] - low[a]) >> 3) as usize);
            let n = (local[0] << 8) | (local[1] << 4) | local[2];
            set_bit(&mut b, parent + 544, n);
            put(
                &mut b,
                parent + 1088 + 8 * n,
                &((at - parent) as i64).to_le_bytes(),
            );
        }
        for (ijk, v) in &self.voxels {
            let leaf = leaf_at(&origin(ijk, 8));
            let l = ijk.map(|c| c.rem_euclid(8) as usize);
            let n = (l[0] << 6) | (l[1] << 3) | l[2];
            put(&mut b, leaf + 96 + 4 * n, &v.to_le_bytes());
            set_bit(&mut b, leaf + 16, n);
        }
        b
    }
}

fn bytes_of(k: &[i32; 3]) -> Vec<u8> {
    k.iter().flat_map(|c| c.to_le_bytes()).collect()
}

fn set_bit(b: &mut [u8], mask: usize, n: usize) {
    b[mask + n / 8] |= 1 << (n % 8);
}

/// NanoVDB's hash of a grid's name (its file records carry it).
fn name_key(name: &str) -> u64 {
    let mut hash = 0u64;
    for &c in name.as_bytes() {
        let overflow = hash >> 56;
        hash = hash.wrapping_mul(67).wrapping_add(c as u64 + overflow);
    }
    hash
}

/// A grid's bytes as a file stores them with `codec`: as they are but for ZIP (1), which
/// stores the compressed size (u64) and a zlib stream (zlib's `compress`).
pub fn stored(raw: &[u8], codec: u16) -> Vec<u8> {
    if codec != 1 {
        return raw.to_vec();
    }
    let packed = miniz_oxide::deflate::compress_to_vec_zlib(raw, 6);
    let mut out = (packed.len() as u64).to_le_bytes().to_vec();
    out.extend_from_slice(&packed);
    out
}

/// A file of one segment holding `grids`, uncompressed unless `codec` says otherwise (ZIP is
/// written as NanoVDB writes it; other codecs only name themselves in the header).
pub fn file(grids: &[Grid], codec: u16) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&MAGIC.to_le_bytes());
    out.extend_from_slice(&grids.first().map_or(VERSION, |g| g.version).to_le_bytes());
    out.extend_from_slice(&(grids.len() as u16).to_le_bytes());
    out.extend_from_slice(&codec.to_le_bytes());
    let raw: Vec<Vec<u8>> = grids.iter().map(Grid::bytes).collect();
    let bodies: Vec<Vec<u8>> = raw.iter().map(|r| stored(r, codec)).collect();
    for ((g, body), raw) in grids.iter().zip(&bodies).zip(&raw) {
        let mut record = vec![0u8; 176];
        let mut put = |at: usize, bytes: &[u8]| record[at..at + bytes.len()].copy_from_slice(bytes);
        put(0, &(raw.len() as u64).to_le_bytes());
        put(8, &(body.len() as u64).to_le_bytes());
        put(16, &name_key(&g.name).to_le_bytes());
        put(24, &(g.voxels.len() as u64).to_le_bytes());
        put(32, &g.value_type.to_le_bytes());
        put(36, &g.class.to_le_bytes());
        let (lo, hi) = g.bbox();
        for a in 0..3 {
            put(88 + 4 * a, &lo[a].to_le_bytes());
            put(100 + 4 * a, &hi[a].to_le_bytes());
        }
        put(136, &(g.name.len() as u32 + 1).to_le_bytes());
        put(168, &codec.to_le_bytes());
        put(172, &g.version.to_le_bytes());
        out.extend_from_slice(&record);
        out.extend_from_slice(g.name.as_bytes());
        out.push(0);
    }
    for body in bodies {
        out.extend_from_slice(&body);
    }
    out
}
