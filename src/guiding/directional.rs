//! The directional half of the guide: a quadtree over the square of cylindrical coordinates
//! (cos θ, φ / 2π), an area-preserving map of the sphere, so that a density over the square
//! is the density over directions times 4π. Each node keeps the energy of its four
//! quadrants; sampling descends by energy and draws uniformly inside the leaf quadrant
//! (Müller, Gross & Novák 2017, "Practical Path Guiding").

use crate::math::{Vec2, Vec3};
use std::f32::consts::PI;

/// Deepest quadtree level (cells of 4π/4¹² sr). Müller et al.'s 20 gave the same images
/// on the rooms measured, in more time: the deeper levels only split cells evenly.
pub const MAX_DEPTH: u32 = 12;

/// One node: its children's node indices (0: the quadrant is a leaf) and the energy of
/// each quadrant, ordered (x low, y low), (x high, y low), (x low, y high), (x high, y high).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Node {
    child: [u32; 4],
    sum: [f32; 4],
}

impl Node {
    fn total(&self) -> f32 {
        self.sum.iter().sum()
    }
}

/// A quadtree of directional energy. Node 0 is the root; children come after their
/// parents.
#[derive(Clone, Debug, PartialEq)]
pub struct DirTree {
    nodes: Vec<Node>,
}

impl Default for DirTree {
    fn default() -> Self {
        DirTree::new()
    }
}

/// The point of the unit square a direction maps to.
pub fn to_square(d: Vec3) -> Vec2 {
    let u = ((d.z + 1.0) * 0.5).clamp(0.0, 1.0);
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let v = (phi / (2.0 * PI)).clamp(0.0, 1.0);
    Vec2::new(u, v)
}

/// The direction a point of the unit square maps to.
pub fn from_square(p: Vec2) -> Vec3 {
    let z = 2.0 * p.x - 1.0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * p.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// The quadrant of `p` and `p` scaled into it.
fn quadrant(p: Vec2) -> (usize, Vec2) {
    let qx = (p.x >= 0.5) as usize;
    let qy = (p.y >= 0.5) as usize;
    let inner = Vec2::new(p.x * 2.0 - qx as f32, p.y * 2.0 - qy as f32);
    (qx + 2 * qy, inner.clamp(Vec2::ZERO, Vec2::splat(1.0)))
}

impl DirTree {
    /// One node, no energy.
    pub fn new() -> DirTree {
        DirTree {
            nodes: vec![Node::default()],
        }
    }

    /// Leaf quadrants ("slots"): node count × 4, each addressed by `node * 4 + quadrant`.
    pub fn slots(&self) -> usize {
        self.nodes.len() * 4
    }

    pub fn total(&self) -> f32 {
        self.nodes[0].total()
    }

    /// The slot of the leaf quadrant holding direction `d`.
    pub fn slot(&self, d: Vec3) -> u32 {
        let mut p = to_square(d);
        let mut node = 0usize;
        loop {
            let (q, inner) = quadrant(p);
            let c = self.nodes[node].child[q];
            if c == 0 {
                return (node * 4 + q) as u32;
            }
            node = c as usize;
            p = inner;
        }
    }

    /// The same tree with each leaf quadrant's energy taken from `sums` (by slot), the
    /// inner quadrants summing their children.
    pub fn with_energy(&self, sums: &[f64]) -> DirTree {
        let mut t = self.clone();
        for (i, n) in t.nodes.iter_mut().enumerate() {
            for q in 0..4 {
                n.sum[q] = if n.child[q] == 0 {
                    (sums[i * 4 + q] as f32).max(0.0)
                } else {
                    0.0
                };
            }
        }
        // Children come after their parents: sum from the back.
        for i in (0..t.nodes.len()).rev() {
            for q in 0..4 {
                let c = t.nodes[i].child[q] as usize;
                if c != 0 {
                    t.nodes[i].sum[q] = t.nodes[c].total();
                }
            }
        }
        t
    }

    /// A new structure (no energy) refined where this tree's energy is: a quadrant holding
    /// more than `fraction` of the total is subdivided (recursively, an unrefined quadrant's
    /// energy split evenly among its would-be children), up to [`MAX_DEPTH`].
    pub fn refined(&self, fraction: f32) -> DirTree {
        let total = self.total();
        let mut out = DirTree::new();
        if total <= 0.0 {
            return out;
        }
        // (node of self or None with the quadrant energies, node of out, depth).
        let mut stack: Vec<(Option<usize>, [f32; 4], usize, u32)> =
            vec![(Some(0), self.nodes[0].sum, 0, 1)];
        while let Some((from, sums, to, depth)) = stack.pop() {
            for (q, &energy) in sums.iter().enumerate() {
                if depth >= MAX_DEPTH || energy <= total * fraction {
                    continue;
                }
                let index = out.nodes.len();
                out.nodes.push(Node::default());
                out.nodes[to].child[q] = index as u32;
                let child = from
                    .map(|f| self.nodes[f].child[q] as usize)
                    .filter(|&c| c != 0);
                let child_sums = match child {
                    Some(c) => self.nodes[c].sum,
                    None => [energy / 4.0; 4],
                };
                stack.push((child, child_sums, index, depth + 1));
            }
        }
        out
    }

    /// The density (per steradian) of [`sample`](Self::sample) at direction `d`; uniform
    /// when the tree holds no energy.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let mut density = 1.0;
        let mut p = to_square(d);
        let mut node = 0usize;
        loop {
            let n = &self.nodes[node];
            let total = n.total();
            if total <= 0.0 {
                break;
            }
            let (q, inner) = quadrant(p);
            density *= 4.0 * n.sum[q] / total;
            let c = n.child[q];
            if c == 0 || density == 0.0 {
                break;
            }
            node = c as usize;
            p = inner;
        }
        density / (4.0 * PI)
    }

    /// A direction drawn by energy from `u` in [0, 1)².
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let (mut u, mut origin, mut scale) = (u, Vec2::ZERO, 1.0f32);
        let mut node = 0usize;
        loop {
            let n = &self.nodes[node];
            let total = n.total();
            if total <= 0.0 {
                break;
            }
            // First the column by its energy, then the row within it.
            let high_x = n.sum[1] + n.sum[3];
            let p_high_x = high_x / total;
            let qx = if u.x < 1.0 - p_high_x {
                u.x /= 1.0 - p_high_x;
                0
            } else {
                u.x = (u.x - (1.0 - p_high_x)) / p_high_x;
                1
            };
            let (low, high) = (n.sum[qx], n.sum[qx + 2]);
            let p_high_y = high / (low + high);
            let qy = if u.y < 1.0 - p_high_y {
                u.y /= 1.0 - p_high_y;
                0
            } else {
                u.y = (u.y - (1.0 - p_high_y)) / p_high_y;
                1
            };
            u = u.clamp(
                Vec2::ZERO,
                Vec2::splat(crate::math::sobol::ONE_MINUS_EPSILON),
            );
            scale *= 0.5;
            origin += Vec2::new(qx as f32, qy as f32) * scale;
            let c = n.child[qx + 2 * qy];
            if c == 0 {
                break;
            }
            node = c as usize;
        }
        from_square(origin + u * scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    /// A tree refined around a bright spot, as a guide would learn it.
    fn peaked_tree() -> DirTree {
        let mut rng = Rng::for_key(7, &[1]);
        let mut t = DirTree::new();
        for _ in 0..3 {
            let mut sums = vec![0.0f64; t.slots()];
            for _ in 0..20_000 {
                let p = Vec2::new(rng.uniform(), rng.uniform());
                let d = from_square(p);
                // A bright lobe around +z and a dim one around -x.
                let w = 50.0 * (d.z.max(0.0)).powi(20) + (-d.x).max(0.0) + 0.01;
                sums[t.slot(d) as usize] += w as f64;
            }
            t = t.with_energy(&sums).refined(0.01);
            t = t.with_energy(&{
                let mut s = vec![0.0f64; t.slots()];
                for _ in 0..20_000 {
                    let d = from_square(Vec2::new(rng.uniform(), rng.uniform()));
                    let w = 50.0 * (d.z.max(0.0)).powi(20) + (-d.x).max(0.0) + 0.01;
                    s[t.slot(d) as usize] += w as f64;
                }
                s
            });
        }
        assert!(
            t.nodes.len() > 20,
            "the tree refined: {} nodes",
            t.nodes.len()
        );
        t
    }

    #[test]
    fn the_square_map_round_trips() {
        let mut rng = Rng::for_key(3, &[2]);
        for _ in 0..1000 {
            let p = Vec2::new(rng.uniform(), rng.uniform());
            let q = to_square(from_square(p));
            assert!((p - q).abs().max_element() < 1e-4, "{p} -> {q}");
        }
    }

    /// ∫ pdf dω = 1: the mean of pdf(ω)·4π over uniform directions is 1 within 1%.
    #[test]
    fn the_density_integrates_to_one() {
        let t = peaked_tree();
        let mut rng = Rng::for_key(5, &[3]);
        let n = 400_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let d = from_square(Vec2::new(rng.uniform(), rng.uniform()));
            sum += (t.pdf(d) * 4.0 * PI) as f64;
        }
        let mean = sum / n as f64;
        assert!((mean - 1.0).abs() < 0.01, "∫pdf = {mean}");
        assert!((DirTree::new().pdf(Vec3::Z) * 4.0 * PI - 1.0).abs() < 1e-6);
    }

    /// Samples fall into a 32×32 grid of the square as the pdf says: chi-square of the
    /// histogram against the integrated pdf, below the 0.999 quantile for its degrees of
    /// freedom.
    #[test]
    fn samples_follow_the_density() {
        let t = peaked_tree();
        let cells = 32usize;
        let mut rng = Rng::for_key(11, &[4]);
        // Expected probability of each cell: the pdf integrated over it (the pdf is constant
        // over quadtree leaves, so a fine midpoint rule is exact for leaves above depth 7).
        let fine = 8usize;
        let mut expected = vec![0.0f64; cells * cells];
        for i in 0..cells * fine {
            for j in 0..cells * fine {
                let p = Vec2::new(
                    (i as f32 + 0.5) / (cells * fine) as f32,
                    (j as f32 + 0.5) / (cells * fine) as f32,
                );
                let area = 1.0 / ((cells * fine) * (cells * fine)) as f64;
                expected[(i / fine) * cells + j / fine] +=
                    (t.pdf(from_square(p)) * 4.0 * PI) as f64 * area;
            }
        }
        let n = 200_000;
        let mut seen = vec![0u32; cells * cells];
        for _ in 0..n {
            let p = to_square(t.sample(Vec2::new(rng.uniform(), rng.uniform())));
            let i = ((p.x * cells as f32) as usize).min(cells - 1);
            let j = ((p.y * cells as f32) as usize).min(cells - 1);
            seen[i * cells + j] += 1;
        }
        let (mut chi2, mut dof) = (0.0, 0usize);
        for (o, e) in seen.iter().zip(&expected) {
            let e = e * n as f64;
            if e < 5.0 {
                assert!(
                    (*o as f64) < 5.0 + 5.0 * e.sqrt() + 20.0,
                    "{o} in a cell expecting {e}"
                );
                continue;
            }
            chi2 += (*o as f64 - e).powi(2) / e;
            dof += 1;
        }
        // The 0.999 quantile of chi-square ≈ dof + 3.1·sqrt(2 dof) for large dof.
        let bound = dof as f64 + 3.1 * (2.0 * dof as f64).sqrt() + 10.0;
        assert!(
            chi2 < bound,
            "chi2 = {chi2} over {dof} cells (bound {bound})"
        );
    }

    /// Refinement follows the energy: the bright lobe's leaves are smaller, so the density
    /// there is far above uniform.
    #[test]
    fn the_tree_refines_towards_energy() {
        let t = peaked_tree();
        assert!(
            t.pdf(Vec3::Z) * 4.0 * PI > 20.0,
            "{}",
            t.pdf(Vec3::Z) * 4.0 * PI
        );
        assert!(t.pdf(-Vec3::Z) * 4.0 * PI < 0.5);
    }
}
