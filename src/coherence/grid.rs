//! The uniform voxel grid the coherence records live in, and the 3-D DDA (Amanatides & Woo
//! 1987) that walks a ray segment through it. The grid is independent of the intersection
//! backend: it only has to cover every place geometry or lights occupy during the sequence.

use crate::math::Vec3;

#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    pub lo: Vec3,
    pub hi: Vec3,
    pub res: [u32; 3],
    cell: Vec3,
    inv_cell: Vec3,
}

impl Grid {
    /// A grid over `[lo, hi]` with `res` voxels along each axis (each at least 1).
    pub fn new(lo: Vec3, hi: Vec3, res: [u32; 3]) -> Grid {
        let res = res.map(|r| r.max(1));
        let size = (hi - lo).max(Vec3::splat(1e-6));
        let hi = lo + size;
        let cell = size / Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
        Grid {
            lo,
            hi,
            res,
            cell,
            inv_cell: cell.recip(),
        }
    }

    /// A grid over `[lo, hi]` with about `voxels` roughly cubic voxels.
    pub fn with_voxels(lo: Vec3, hi: Vec3, voxels: u32) -> Grid {
        let size = (hi - lo).max(Vec3::splat(1e-6));
        let side = (size.x * size.y * size.z / voxels.max(1) as f32).cbrt();
        let res = (size / side)
            .ceil()
            .to_array()
            .map(|r| (r as u32).clamp(1, 1024));
        Grid::new(lo, hi, res)
    }

    pub fn len(&self) -> usize {
        self.res.iter().map(|&r| r as usize).product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn index(&self, c: [u32; 3]) -> usize {
        (c[2] as usize * self.res[1] as usize + c[1] as usize) * self.res[0] as usize
            + c[0] as usize
    }

    pub fn coords(&self, index: usize) -> [u32; 3] {
        let (rx, ry) = (self.res[0] as usize, self.res[1] as usize);
        [
            (index % rx) as u32,
            (index / rx % ry) as u32,
            (index / (rx * ry)) as u32,
        ]
    }

    /// The box of voxel `index`.
    pub fn voxel_box(&self, index: usize) -> (Vec3, Vec3) {
        let c = self.coords(index);
        let lo = self.lo + Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * self.cell;
        (lo, lo + self.cell)
    }

    /// The voxel coordinates holding `p`, clamped into the grid.
    fn cell_of(&self, p: Vec3) -> [u32; 3] {
        let f = ((p - self.lo) * self.inv_cell).floor();
        [0, 1, 2].map(|a| (f[a].max(0.0) as u32).min(self.res[a] - 1))
    }

    /// Every voxel overlapping the box `[lo, hi]` (none if it misses the grid).
    pub fn voxels_in_box(&self, lo: Vec3, hi: Vec3, mut f: impl FnMut(usize)) {
        if lo.cmpgt(self.hi).any() || hi.cmplt(self.lo).any() {
            return;
        }
        let (a, b) = (self.cell_of(lo), self.cell_of(hi));
        for z in a[2]..=b[2] {
            for y in a[1]..=b[1] {
                for x in a[0]..=b[0] {
                    f(self.index([x, y, z]));
                }
            }
        }
    }

    /// Walks the segment `origin + t·dir`, `t ∈ [t0, t1]`, through the grid, calling `f` on
    /// every voxel it crosses, in order. Parts outside the grid are skipped.
    pub fn walk(&self, origin: Vec3, dir: Vec3, t0: f32, t1: f32, mut f: impl FnMut(usize)) {
        // Clip to the grid's box (slabs).
        let (mut tin, mut tout) = (t0.max(0.0), t1);
        for a in 0..3 {
            if dir[a] == 0.0 {
                if origin[a] < self.lo[a] || origin[a] > self.hi[a] {
                    return;
                }
                continue;
            }
            let inv = 1.0 / dir[a];
            let (mut ta, mut tb) = (
                (self.lo[a] - origin[a]) * inv,
                (self.hi[a] - origin[a]) * inv,
            );
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            tin = tin.max(ta);
            tout = tout.min(tb);
        }
        if tin.is_nan() || tout.is_nan() || tin > tout {
            return;
        }
        let mut cell = self.cell_of(origin + dir * tin);
        let mut step = [0i32; 3];
        let mut next = [f32::INFINITY; 3];
        let mut delta = [f32::INFINITY; 3];
        for a in 0..3 {
            if dir[a] > 0.0 {
                step[a] = 1;
                let boundary = self.lo[a] + (cell[a] + 1) as f32 * self.cell[a];
                next[a] = (boundary - origin[a]) / dir[a];
                delta[a] = self.cell[a] / dir[a];
            } else if dir[a] < 0.0 {
                step[a] = -1;
                let boundary = self.lo[a] + cell[a] as f32 * self.cell[a];
                next[a] = (boundary - origin[a]) / dir[a];
                delta[a] = -self.cell[a] / dir[a];
            }
        }
        loop {
            f(self.index(cell));
            let a = if next[0] < next[1] {
                if next[0] < next[2] {
                    0
                } else {
                    2
                }
            } else if next[1] < next[2] {
                1
            } else {
                2
            };
            if next[a] > tout {
                return;
            }
            let c = cell[a] as i64 + step[a] as i64;
            if c < 0 || c >= self.res[a] as i64 {
                return;
            }
            cell[a] = c as u32;
            next[a] += delta[a];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_and_coords_round_trip() {
        let g = Grid::new(Vec3::ZERO, Vec3::ONE, [3, 4, 5]);
        for i in 0..g.len() {
            assert_eq!(g.index(g.coords(i)), i);
        }
    }
}
