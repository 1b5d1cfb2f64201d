//! A piecewise-constant density over the unit square, sampled within any axis-aligned
//! window of it (pbrt-v4's `WindowedPiecewiseConstant2D`): a summed-area table gives the
//! mass of any window, and of its rows, in a few lookups, so that each sample costs two
//! binary searches whatever the window.

use crate::math::Vec2;

/// Non-negative values on an `nx`×`ny` grid of equal cells over \[0,1\]², row-major, row 0
/// at v = 0.
#[derive(Debug)]
pub struct WindowedTable {
    nx: usize,
    ny: usize,
    values: Vec<f64>,
    /// (ny+1)×(nx+1): the sum of the cells left of column `i` and below row `j`.
    sums: Vec<f64>,
    /// ny×(nx+1): the sum of the cells of row `j` left of column `i`.
    rows: Vec<f64>,
}

impl WindowedTable {
    /// The table of `values` (`nx`×`ny` of them, each finite and not negative).
    pub fn new(nx: usize, ny: usize, values: &[f32]) -> WindowedTable {
        assert!(nx > 0 && ny > 0 && values.len() == nx * ny);
        let values: Vec<f64> = values.iter().map(|&v| v.max(0.0) as f64).collect();
        let mut sums = vec![0.0; (nx + 1) * (ny + 1)];
        let mut rows = vec![0.0; (nx + 1) * ny];
        for j in 0..ny {
            let mut row = 0.0;
            for i in 0..nx {
                row += values[j * nx + i];
                rows[j * (nx + 1) + i + 1] = row;
                sums[(j + 1) * (nx + 1) + i + 1] = sums[j * (nx + 1) + i + 1] + row;
            }
        }
        WindowedTable {
            nx,
            ny,
            values,
            sums,
            rows,
        }
    }

    /// The window \[`lo`, `hi`\] in cells, clamped to the grid.
    fn window(&self, lo: Vec2, hi: Vec2) -> Window<'_> {
        let (nx, ny) = (self.nx as f64, self.ny as f64);
        let (x0, x1) = (
            (lo.x as f64 * nx).clamp(0.0, nx),
            (hi.x as f64 * nx).clamp(0.0, nx),
        );
        // x is not negative: truncation is the floor.
        let (i0, i1) = (
            (x0 as usize).min(self.nx - 1),
            (x1 as usize).min(self.nx - 1),
        );
        Window {
            table: self,
            x0,
            x1,
            y0: (lo.y as f64 * ny).clamp(0.0, ny),
            y1: (hi.y as f64 * ny).clamp(0.0, ny),
            i0,
            i1,
            f0: x0 - i0 as f64,
            f1: x1 - i1 as f64,
        }
    }

    /// A point of the window \[`lo`, `hi`\] chosen in proportion to the values, and its density
    /// over the unit square; `None` when the window holds no mass.
    pub fn sample(&self, u: Vec2, lo: Vec2, hi: Vec2) -> Option<(Vec2, f32)> {
        let w = self.window(lo, hi);
        let (x0, x1, y0, y1) = (w.x0, w.x1, w.y0, w.y1);
        let (base, total) = w.mass()?;
        // The row: the last boundary whose mass below stays under the target.
        let target = u.y as f64 * total;
        let (j0, j1) = (y0 as usize, (y1.ceil() as usize).max(1) - 1);
        let j0 = j0.min(j1);
        let mut lo_row = j0;
        let mut hi_row = j1;
        while lo_row < hi_row {
            let mid = (lo_row + hi_row).div_ceil(2);
            if w.at_boundary(mid) - base <= target {
                lo_row = mid;
            } else {
                hi_row = mid - 1;
            }
        }
        let j = lo_row;
        let row_start = (j as f64).max(y0);
        let per_y = w.at_boundary(j + 1) - w.at_boundary(j);
        let y = if per_y > 0.0 {
            row_start + (target - (w.below(row_start) - base)) / per_y
        } else {
            row_start
        }
        .clamp(row_start, ((j + 1) as f64).min(y1));
        // The column within row j, the same way along x (the row's own sums).
        let row = &self.rows[j * (self.nx + 1)..(j + 1) * (self.nx + 1)];
        let values = &self.values[j * self.nx..(j + 1) * self.nx];
        let along = |x: f64| {
            let i = (x as usize).min(self.nx - 1);
            row[i] + (x - i as f64) * values[i]
        };
        let start = along(x0);
        let target = start + u.x as f64 * (along(x1) - start);
        let (i0, i1) = (x0 as usize, (x1.ceil() as usize).max(1) - 1);
        let (mut lo_col, mut hi_col) = (i0.min(i1), i1);
        while lo_col < hi_col {
            let mid = (lo_col + hi_col).div_ceil(2);
            if row[mid].max(start) <= target {
                lo_col = mid;
            } else {
                hi_col = mid - 1;
            }
        }
        let i = lo_col;
        let col_start = (i as f64).max(x0);
        let value = values[i];
        if value <= 0.0 {
            return None;
        }
        let x = (col_start + (target - along(col_start)) / value)
            .clamp(col_start, ((i + 1) as f64).min(x1));
        let p = Vec2::new((x / self.nx as f64) as f32, (y / self.ny as f64) as f32);
        let density = value / total * (self.nx * self.ny) as f64;
        Some((p, density as f32))
    }

    /// The density over the unit square with which [`sample`](Self::sample) picks `p`
    /// within the window \[`lo`, `hi`\] (0 outside it).
    pub fn pdf(&self, p: Vec2, lo: Vec2, hi: Vec2) -> f32 {
        if p.x < lo.x || p.x > hi.x || p.y < lo.y || p.y > hi.y {
            return 0.0;
        }
        let Some((_, total)) = self.window(lo, hi).mass() else {
            return 0.0;
        };
        let i = ((p.x as f64 * self.nx as f64) as usize).min(self.nx - 1);
        let j = ((p.y as f64 * self.ny as f64) as usize).min(self.ny - 1);
        (self.values[j * self.nx + i] / total * (self.nx * self.ny) as f64) as f32
    }
}

/// A window of a [`WindowedTable`] in cells, with the interpolation of its two edge columns
/// worked out once.
struct Window<'a> {
    table: &'a WindowedTable,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    i0: usize,
    i1: usize,
    f0: f64,
    f1: f64,
}

impl Window<'_> {
    /// The integral over \[x0, x1\]×\[0, k\] for a row boundary `k`: exact, as the
    /// density is constant within a cell.
    fn at_boundary(&self, k: usize) -> f64 {
        let stride = self.table.nx + 1;
        let s = &self.table.sums[k * stride..(k + 1) * stride];
        let (i0, i1) = (self.i0, self.i1);
        (s[i1] + self.f1 * (s[i1 + 1] - s[i1])) - (s[i0] + self.f0 * (s[i0 + 1] - s[i0]))
    }

    /// The integral over \[x0, x1\]×\[0, y\] (linear within a row).
    fn below(&self, y: f64) -> f64 {
        let j = (y as usize).min(self.table.ny - 1);
        let (f, a) = (y - j as f64, self.at_boundary(j));
        if f == 0.0 {
            a
        } else {
            a + f * (self.at_boundary(j + 1) - a)
        }
    }

    /// The mass below the window's bottom and the window's own; `None` when it has none.
    fn mass(&self) -> Option<(f64, f64)> {
        let base = self.below(self.y0);
        let total = self.below(self.y1) - base;
        (total.is_finite() && total > 0.0).then_some((base, total))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    fn table(rng: &mut Rng, nx: usize, ny: usize) -> (WindowedTable, Vec<f32>) {
        let values: Vec<f32> = (0..nx * ny)
            .map(|k| if k % 7 == 3 { 0.0 } else { rng.uniform() * 4.0 })
            .collect();
        (WindowedTable::new(nx, ny, &values), values)
    }

    #[test]
    fn the_density_integrates_to_one_over_any_window() {
        let mut rng = Rng::for_key(11, &[]);
        let (t, _) = table(&mut rng, 9, 6);
        for _ in 0..20 {
            let a = Vec2::new(rng.uniform(), rng.uniform());
            let b = Vec2::new(rng.uniform(), rng.uniform());
            let (lo, hi) = (a.min(b), a.max(b));
            // Midpoint rule on a grid fine enough that cells straddling the window's edge
            // contribute little.
            let n = 600;
            let mut sum = 0.0f64;
            for y in 0..n {
                for x in 0..n {
                    let p = Vec2::new((x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32);
                    sum += t.pdf(p, lo, hi) as f64;
                }
            }
            let integral = sum / (n * n) as f64;
            let edge = 2.0 * ((hi.x - lo.x) + (hi.y - lo.y)) as f64 / n as f64;
            let area = ((hi.x - lo.x) * (hi.y - lo.y)) as f64;
            assert!(
                (integral - 1.0).abs() < 0.02 + 20.0 * edge / area.max(1e-3),
                "window {lo}..{hi}: {integral}"
            );
        }
    }

    #[test]
    fn samples_fall_in_the_window_with_the_density_they_report() {
        let mut rng = Rng::for_key(12, &[]);
        let (t, values) = table(&mut rng, 8, 5);
        let (lo, hi) = (Vec2::new(0.13, 0.27), Vec2::new(0.81, 0.93));
        // The mass of each cell within the window, from the values directly.
        let (nx, ny) = (8, 5);
        let overlap = |i: usize, n: usize, a: f32, b: f32| {
            let (c0, c1) = (i as f32 / n as f32, (i + 1) as f32 / n as f32);
            (c1.min(b) - c0.max(a)).max(0.0)
        };
        let mut expected = vec![0.0f64; nx * ny];
        for j in 0..ny {
            for i in 0..nx {
                expected[j * nx + i] = values[j * nx + i] as f64
                    * overlap(i, nx, lo.x, hi.x) as f64
                    * overlap(j, ny, lo.y, hi.y) as f64;
            }
        }
        let total: f64 = expected.iter().sum();
        let n = 200_000;
        let mut counts = vec![0usize; nx * ny];
        for _ in 0..n {
            let u = Vec2::new(rng.uniform(), rng.uniform());
            let (p, pdf) = t.sample(u, lo, hi).unwrap();
            assert!(
                p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y,
                "{p}"
            );
            let reported = t.pdf(p, lo, hi);
            assert!(
                (pdf - reported).abs() <= 1e-3 * pdf.max(reported),
                "{pdf} vs {reported}"
            );
            let i = ((p.x * nx as f32) as usize).min(nx - 1);
            let j = ((p.y * ny as f32) as usize).min(ny - 1);
            counts[j * nx + i] += 1;
        }
        for k in 0..nx * ny {
            let p = expected[k] / total;
            let se = (n as f64 * p * (1.0 - p)).sqrt().max(1.0);
            let z = (counts[k] as f64 - n as f64 * p) / se;
            assert!(
                z.abs() < 5.0,
                "cell {k}: {} vs {} (z {z})",
                counts[k],
                n as f64 * p
            );
        }
    }

    #[test]
    fn an_empty_window_gives_no_sample() {
        let t = WindowedTable::new(2, 1, &[0.0, 3.0]);
        let (lo, hi) = (Vec2::new(0.1, 0.0), Vec2::new(0.4, 1.0));
        assert!(t.sample(Vec2::splat(0.5), lo, hi).is_none());
        assert_eq!(t.pdf(Vec2::new(0.2, 0.5), lo, hi), 0.0);
        // The whole square: everything on the right half, density 2 there.
        let (p, pdf) = t.sample(Vec2::splat(0.5), Vec2::ZERO, Vec2::ONE).unwrap();
        assert!(p.x >= 0.5 && (pdf - 2.0).abs() < 1e-6, "{p} {pdf}");
    }
}
