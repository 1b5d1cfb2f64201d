//! Environment-map directions for a receiver that only reflects: texels chosen in proportion
//! to luminance times a bound on their cosine with the receiver's normal, so that next-event
//! estimation does not spend half its samples below the horizon. The map is cut into blocks
//! (at most 32 a side); for each of 26 normal directions (the cube's faces, edges and
//! corners) a table over blocks holds each block's luminance times the largest cosine any
//! normal nearer that direction than the other 25 makes with any direction in the block.
//! A texel inside the block is then chosen by luminance alone. Every block keeps a small
//! share (`FLOOR`) whatever the bound says, so no direction has density 0.

use crate::math::{luminance, Rgb, Vec2, Vec3};
use crate::scene::environment::equal_area_square_to_sphere;
use crate::scene::Environment;
use std::f32::consts::{FRAC_PI_2, PI};

/// Blocks on a side of the map (fewer for a smaller map).
const BLOCKS_PER_SIDE: u32 = 32;
/// The least cosine factor a block keeps.
const FLOOR: f32 = 1e-3;
/// Normal directions whose tables are kept.
const BINS: usize = 26;

/// A texel's weight for sampling: luminance with a floor, as the map's own sampler has.
pub(super) fn texel_weight(v: Rgb, scale: Rgb) -> f32 {
    luminance(v.max(Rgb::ZERO) * scale) + 1e-4
}

#[derive(Debug)]
pub(super) struct FacingTables {
    /// Texels on a side of the map, and on a side of a block.
    texels: u32,
    block: u32,
    /// Blocks on a side.
    side: u32,
    /// Texel indices block by block, and their cumulative weights within their block.
    order: Vec<u32>,
    local_cdf: Vec<f32>,
    /// Where each block starts in `order` (one more entry than blocks).
    block_start: Vec<u32>,
    /// Each normal bin's cumulative weights over blocks, bin after bin.
    bin_cdf: Vec<f32>,
    bins: [Vec3; BINS],
}

impl FacingTables {
    pub fn new(env: &Environment) -> FacingTables {
        let n = env.image.width.max(1);
        let block = n.div_ceil(BLOCKS_PER_SIDE);
        let side = n.div_ceil(block);
        let blocks = (side * side) as usize;
        let mut order = Vec::with_capacity((n * n) as usize);
        let mut local_cdf = Vec::with_capacity((n * n) as usize);
        let mut block_start = Vec::with_capacity(blocks + 1);
        let mut sums = Vec::with_capacity(blocks);
        let mut cones = Vec::with_capacity(blocks);
        for by in 0..side {
            for bx in 0..side {
                block_start.push(order.len() as u32);
                let mut acc = 0.0f32;
                for y in by * block..((by + 1) * block).min(n) {
                    for x in bx * block..((bx + 1) * block).min(n) {
                        let i = y * n + x;
                        acc += texel_weight(env.image.pixels[i as usize], env.scale);
                        order.push(i);
                        local_cdf.push(acc);
                    }
                }
                sums.push(acc);
                cones.push(block_cone(env, n, (bx * block, by * block), block));
            }
        }
        block_start.push(order.len() as u32);
        let bins = bin_directions();
        let reach = bin_reach(&bins);
        let mut bin_cdf = Vec::with_capacity(BINS * blocks);
        for (b, dir) in bins.iter().enumerate() {
            let mut acc = 0.0f32;
            for (sum, (centre, radius)) in sums.iter().zip(&cones) {
                let angle = dir.dot(*centre).clamp(-1.0, 1.0).acos();
                let gap = (angle - reach[b] - radius).max(0.0);
                let cos = if gap < FRAC_PI_2 { gap.cos() } else { 0.0 };
                acc += sum * cos.max(FLOOR);
                bin_cdf.push(acc);
            }
        }
        FacingTables {
            texels: n,
            block,
            side,
            order,
            local_cdf,
            block_start,
            bin_cdf,
            bins,
        }
    }

    fn bin(&self, n: Vec3) -> usize {
        let mut best = (0, f32::NEG_INFINITY);
        for (b, d) in self.bins.iter().enumerate() {
            let c = d.dot(n);
            if c > best.1 {
                best = (b, c);
            }
        }
        best.0
    }

    fn bin_table(&self, b: usize) -> &[f32] {
        let blocks = (self.side * self.side) as usize;
        &self.bin_cdf[b * blocks..(b + 1) * blocks]
    }

    /// A texel for a receiver facing `n` and what is left of `u.x` for the position inside
    /// it (`u.y` is left for the other axis).
    pub fn sample(&self, n: Vec3, u: f32) -> (usize, f32) {
        let table = self.bin_table(self.bin(n));
        let (j, rest) = pick(table, u);
        let (start, end) = (
            self.block_start[j] as usize,
            self.block_start[j + 1] as usize,
        );
        let (k, rest) = pick(&self.local_cdf[start..end], rest);
        (self.order[start + k] as usize, rest)
    }

    /// The probability with which [`sample`](Self::sample) picks texel `i` (of weight
    /// `weight`) for a receiver facing `n`.
    pub fn texel_probability(&self, n: Vec3, i: usize, weight: f32) -> f32 {
        let table = self.bin_table(self.bin(n));
        let i = i as u32;
        let (x, y) = (i % self.texels, i / self.texels);
        let j = ((y / self.block) * self.side + x / self.block) as usize;
        let block_weight = table[j] - if j == 0 { 0.0 } else { table[j - 1] };
        let end = self.block_start[j + 1] as usize - 1;
        let block_sum = self.local_cdf[end];
        let total = *table.last().unwrap_or(&0.0);
        if total <= 0.0 || block_sum <= 0.0 {
            return 0.0;
        }
        block_weight / total * (weight / block_sum)
    }
}

/// An entry of the cumulative table `cdf` chosen by `u`, and `u`'s leftover in [0, 1).
fn pick(cdf: &[f32], u: f32) -> (usize, f32) {
    let total = *cdf.last().unwrap_or(&0.0);
    let target = u * total;
    let i = cdf.partition_point(|&c| c <= target).min(cdf.len() - 1);
    let lo = if i == 0 { 0.0 } else { cdf[i - 1] };
    let rest = ((target - lo) / (cdf[i] - lo).max(f32::MIN_POSITIVE)).clamp(0.0, 0.999_999);
    (i, rest)
}

/// A cone holding every direction of the block of `size` texels at `corner` of the map:
/// its axis and angular radius (the widest of a grid of directions over the block, plus the
/// grid's spacing, so that directions between the grid's points are inside).
fn block_cone(env: &Environment, n: u32, corner: (u32, u32), size: u32) -> (Vec3, f32) {
    const STEPS: u32 = 8;
    let size = size.min(n - corner.0).min(n - corner.1) as f32;
    let mut dirs = Vec::with_capacity(((STEPS + 1) * (STEPS + 1)) as usize);
    for sy in 0..=STEPS {
        for sx in 0..=STEPS {
            let p = Vec2::new(
                corner.0 as f32 + size * sx as f32 / STEPS as f32,
                corner.1 as f32 + size * sy as f32 / STEPS as f32,
            ) / n as f32;
            dirs.push((env.transform * equal_area_square_to_sphere(p)).normalize());
        }
    }
    let axis = dirs.iter().copied().sum::<Vec3>().normalize_or_zero();
    if axis == Vec3::ZERO {
        return (Vec3::Z, PI);
    }
    let angle = |a: Vec3, b: Vec3| a.dot(b).clamp(-1.0, 1.0).acos();
    let widest = dirs.iter().map(|d| angle(axis, *d)).fold(0.0, f32::max);
    let row = (STEPS + 1) as usize;
    let mut spacing = 0.0f32;
    for (k, d) in dirs.iter().enumerate() {
        if k % row + 1 < row {
            spacing = spacing.max(angle(*d, dirs[k + 1]));
        }
        if k + row < dirs.len() {
            spacing = spacing.max(angle(*d, dirs[k + row]));
        }
    }
    ((axis), (widest + spacing).min(PI))
}

/// The 26 normal directions: the cube's face, edge and corner directions.
fn bin_directions() -> [Vec3; BINS] {
    let mut bins = [Vec3::ZERO; BINS];
    let mut k = 0;
    for x in -1i32..=1 {
        for y in -1i32..=1 {
            for z in -1i32..=1 {
                if (x, y, z) != (0, 0, 0) {
                    bins[k] = Vec3::new(x as f32, y as f32, z as f32).normalize();
                    k += 1;
                }
            }
        }
    }
    bins
}

/// For each bin, the widest angle between its direction and a normal that falls into it,
/// measured over a dense spiral of normals, with a margin for the normals between them.
fn bin_reach(bins: &[Vec3; BINS]) -> [f32; BINS] {
    const POINTS: usize = 20_000;
    let mut reach = [0.0f32; BINS];
    let golden = PI * (3.0 - 5.0f32.sqrt());
    for k in 0..POINTS {
        let z = 1.0 - 2.0 * (k as f32 + 0.5) / POINTS as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = golden * k as f32;
        let n = Vec3::new(r * phi.cos(), r * phi.sin(), z);
        let (b, c) = bins
            .iter()
            .enumerate()
            .map(|(b, d)| (b, d.dot(n)))
            .fold((0, f32::NEG_INFINITY), |a, x| if x.1 > a.1 { x } else { a });
        reach[b] = reach[b].max(c.clamp(-1.0, 1.0).acos());
    }
    // The spiral's points are about 0.025 rad apart.
    reach.map(|r| r + 0.05)
}
