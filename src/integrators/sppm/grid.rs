//! A uniform hash grid over points with radii (balls): built once over the points, then
//! asked which balls contain a point. Stochastic progressive photon mapping builds one over
//! its visible points each iteration and asks it at every photon hit; the structure knows
//! nothing of photons or pixels.
//!
//! The cells are cubes as wide as the largest ball, so a ball's bounding box touches at
//! most 2 × 2 × 2 cells. Each cell a ball touches lists the ball's index; the lists live in
//! one array sorted by hash bucket (a counting sort), each entry with its cell's code, so a
//! query sees only the balls of its own cell, each once, in increasing index order. The
//! build is sequential and the order of every list is the points' order: queries give the
//! same indices in the same order whatever the thread count.

use crate::math::Vec3;

/// The most cells along one axis: coordinates are packed 21 bits each into a cell code.
const MAX_RES: i64 = 1 << 21;

/// Balls (centre, radius), indexed as given, for point queries.
#[derive(Clone, Debug)]
pub struct HashGrid {
    lo: Vec3,
    /// Cells per unit length.
    inv_cell: f32,
    res: [i64; 3],
    /// Per hash bucket, where its entries start in `entries` (one more than the buckets).
    starts: Vec<u32>,
    /// (cell code, ball index), grouped by bucket, in ball order within a bucket.
    entries: Vec<(u64, u32)>,
    centres: Vec<Vec3>,
    radii2: Vec<f32>,
}

impl HashGrid {
    /// The grid over balls `(centre, radius)`; balls with a radius that is not positive and
    /// finite, or a centre that is not finite, are left out (no query finds them).
    pub fn build(balls: &[(Vec3, f32)]) -> HashGrid {
        let usable = |&(c, r): &(Vec3, f32)| r > 0.0 && r.is_finite() && c.is_finite();
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        let mut max_r = 0.0f32;
        for b in balls.iter().filter(|b| usable(b)) {
            lo = lo.min(b.0 - Vec3::splat(b.1));
            hi = hi.max(b.0 + Vec3::splat(b.1));
            max_r = max_r.max(b.1);
        }
        let centres = balls.iter().map(|b| b.0).collect();
        let radii2 = balls
            .iter()
            .map(|b| if usable(b) { b.1 * b.1 } else { -1.0 })
            .collect();
        if max_r == 0.0 {
            return HashGrid {
                lo: Vec3::ZERO,
                inv_cell: 0.0,
                res: [0; 3],
                starts: vec![0, 0],
                entries: Vec::new(),
                centres,
                radii2,
            };
        }
        // Cells as wide as a ball, fewer where the extent would need more than MAX_RES.
        let extent = hi - lo;
        let cell = (2.0 * max_r).max(extent.max_element() / (MAX_RES - 1) as f32);
        let inv_cell = 1.0 / cell;
        let res = [extent.x, extent.y, extent.z]
            .map(|e| ((e * inv_cell).floor() as i64 + 1).clamp(1, MAX_RES));
        let mut grid = HashGrid {
            lo,
            inv_cell,
            res,
            starts: Vec::new(),
            entries: Vec::new(),
            centres,
            radii2,
        };
        let buckets = balls.len().next_power_of_two().max(1);
        let mut counts = vec![0u32; buckets + 1];
        let mut cells = Vec::new();
        for (i, b) in balls.iter().enumerate() {
            if usable(b) {
                grid.cells_of(b.0, b.1, |code| cells.push((code, i as u32)));
            }
        }
        for &(code, _) in &cells {
            counts[bucket(code, buckets) + 1] += 1;
        }
        for k in 1..counts.len() {
            counts[k] += counts[k - 1];
        }
        let mut fill = counts.clone();
        let mut entries = vec![(0u64, 0u32); cells.len()];
        for &(code, i) in &cells {
            let b = bucket(code, buckets);
            entries[fill[b] as usize] = (code, i);
            fill[b] += 1;
        }
        grid.starts = counts;
        grid.entries = entries;
        grid
    }

    /// Calls `found(i)` for every ball `i` that contains `p` (its distance at most the
    /// radius), each once, in increasing order of `i`.
    pub fn query(&self, p: Vec3, mut found: impl FnMut(usize)) {
        let Some(code) = self.cell(p) else {
            return;
        };
        let buckets = self.starts.len() - 1;
        let b = bucket(code, buckets);
        let range = self.starts[b] as usize..self.starts[b + 1] as usize;
        for &(c, i) in &self.entries[range] {
            let i = i as usize;
            if c == code && (self.centres[i] - p).length_squared() <= self.radii2[i] {
                found(i);
            }
        }
    }

    /// The code of the cell holding `p`, if it is inside the grid.
    fn cell(&self, p: Vec3) -> Option<u64> {
        let g = (p - self.lo) * self.inv_cell;
        let c = [g.x, g.y, g.z].map(|v| v.floor() as i64);
        if (0..3).any(|k| !(0..self.res[k]).contains(&c[k])) {
            return None;
        }
        Some(code(c))
    }

    /// Calls `each` with the code of every cell the box of the ball (`c`, `r`) touches.
    fn cells_of(&self, c: Vec3, r: f32, mut each: impl FnMut(u64)) {
        let clamp = |v: f32, k: usize| (v.floor() as i64).clamp(0, self.res[k] - 1);
        let a = (c - Vec3::splat(r) - self.lo) * self.inv_cell;
        let b = (c + Vec3::splat(r) - self.lo) * self.inv_cell;
        for z in clamp(a.z, 2)..=clamp(b.z, 2) {
            for y in clamp(a.y, 1)..=clamp(b.y, 1) {
                for x in clamp(a.x, 0)..=clamp(b.x, 0) {
                    each(code([x, y, z]));
                }
            }
        }
    }
}

fn code(c: [i64; 3]) -> u64 {
    (c[0] as u64) | ((c[1] as u64) << 21) | ((c[2] as u64) << 42)
}

/// The bucket of a cell code among `buckets` (a power of two): the code mixed (SplitMix64's
/// finaliser) so that neighbouring cells spread over the table.
fn bucket(code: u64, buckets: usize) -> usize {
    let mut z = code.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z as usize) & (buckets - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    /// Every query agrees with testing every ball, for balls of many sizes, some left out.
    #[test]
    fn queries_find_exactly_the_balls_that_contain_the_point() {
        let mut rng = Rng::for_key(7, &[1]);
        let mut balls = Vec::new();
        for i in 0..500 {
            let c = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform() * 0.1) * 10.0;
            let r = match i % 7 {
                0 => 0.0,
                1 => 1.5,
                _ => 0.05 + rng.uniform() * 0.4,
            };
            balls.push((c, r));
        }
        let grid = HashGrid::build(&balls);
        let mut found_any = 0;
        for _ in 0..5000 {
            let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform() * 0.1) * 10.5
                - Vec3::splat(0.25);
            let mut got = Vec::new();
            grid.query(p, |i| got.push(i));
            let want: Vec<usize> = (0..balls.len())
                .filter(|&i| balls[i].1 > 0.0 && (balls[i].0 - p).length() <= balls[i].1)
                .collect();
            assert_eq!(got, want, "at {p:?}");
            found_any += got.len();
        }
        assert!(found_any > 1000, "{found_any}");
    }

    #[test]
    fn an_empty_grid_finds_nothing() {
        let grid = HashGrid::build(&[]);
        grid.query(Vec3::ZERO, |_| panic!("found a ball"));
        let grid = HashGrid::build(&[(Vec3::ONE, 0.0), (Vec3::ZERO, f32::NAN)]);
        grid.query(Vec3::ONE, |_| panic!("found a ball"));
    }
}
