//! The diffuse radiance at the corners of the patches, computed once per solution.
//!
//! Rendering interpolates each hit bilinearly between the four corners of its patch, and a
//! corner is the average of the (up to four) patches sharing it (figure 6 b, c). Where all of
//! them are diffuse, that value does not depend on the view: it is worked out here once, in
//! the order the per-pixel code adds it up, so a pixel reads four values instead of
//! averaging nine patches, and the image is the same bit for bit. A polygon side with a
//! directional node is left to the per-pixel gather (its corners depend on the eye).

use super::distribute::Solution;
use super::{Network, NONE};
use crate::math::Rgb;

/// Corner values of every all-diffuse polygon side.
pub struct Corners {
    /// For each polygon side (polygon·2 + side), the index of its corner (0, 0) in
    /// `values`, or [`NONE`] for a side left to the per-pixel code. Corner (i, j) of a
    /// polygon with ns × nt patches is at first + i·(nt + 1) + j.
    first: Vec<u32>,
    /// A corner's average, or `None` where no patch around it has a node on that side.
    values: Vec<Option<Rgb>>,
}

impl Corners {
    /// The corner values of `solution` on `net` (`hybrid`: without the direct light, which
    /// the renderer adds per pixel).
    pub fn new(net: &Network, solution: &Solution, hybrid: bool) -> Corners {
        let polygons = &net.patches.polygons;
        let mut first = vec![NONE; polygons.len() * 2];
        let mut values = Vec::new();
        for (p, pg) in polygons.iter().enumerate() {
            for side in 0..2u32 {
                let cells = pg.first_cell..pg.first_cell + pg.ns * pg.nt;
                let node = |cell: u32| net.node_of_key[(cell * 2 + side) as usize];
                let mut nodes = cells.map(node).filter(|&n| n != NONE).peekable();
                let any = nodes.peek().is_some();
                if !any || nodes.any(|n| solution.dir_index[n as usize] != NONE) {
                    continue;
                }
                let Ok(start) = u32::try_from(values.len()) else {
                    return Corners { first, values };
                };
                first[p * 2 + side as usize] = start;
                for i in 0..=pg.ns as i64 {
                    for j in 0..=pg.nt as i64 {
                        let mut sum = Rgb::ZERO;
                        let mut n = 0;
                        for ci in i - 1..=i {
                            for cj in j - 1..=j {
                                if ci < 0 || cj < 0 || ci >= pg.ns as i64 || cj >= pg.nt as i64 {
                                    continue;
                                }
                                let cell = pg.first_cell + ci as u32 * pg.nt + cj as u32;
                                let nd = node(cell);
                                if nd != NONE {
                                    sum += solution.diffuse_radiance(nd, hybrid);
                                    n += 1;
                                }
                            }
                        }
                        values.push((n > 0).then(|| sum / n as f32));
                    }
                }
            }
        }
        Corners { first, values }
    }

    /// The four corners (i, j), (i, j + 1), (i + 1, j), (i + 1, j + 1) of patch (i, j) of
    /// polygon `poly`, side `side`; `None` if that side is left to the per-pixel code.
    #[inline]
    pub fn of_patch(
        &self,
        net: &Network,
        poly: u32,
        side: u32,
        i: u32,
        j: u32,
    ) -> Option<[Option<Rgb>; 4]> {
        let first = self.first[(poly * 2 + side) as usize];
        if first == NONE {
            return None;
        }
        let row = net.patches.polygons[poly as usize].nt as usize + 1;
        let at = first as usize + i as usize * row + j as usize;
        let below = at + row;
        Some([
            self.values[at],
            self.values[at + 1],
            self.values[below],
            self.values[below + 1],
        ])
    }

    /// Bytes held.
    pub fn memory(&self) -> usize {
        self.first.len() * 4 + self.values.len() * std::mem::size_of::<Option<Rgb>>()
    }
}
