//! A light hierarchy for choosing, at a shaded point, one of many lights in proportion to
//! the light it may receive from each (pbrt-v4's `BVHLightSampler`, after Conty Estevez &
//! Kulla 2018): a binary tree over the lights' bounds, split by pbrt-v4's cost (power
//! times the measure of the emission cone times the box's area), walked from the root by
//! the importance of each child at the point. Lights at infinity are outside the tree and
//! share the choice with it evenly, as in pbrt-v4.

use super::bounds::LightBounds;
use crate::math::Vec3;

/// How many buckets each axis is split into when looking for the cheapest split.
const BUCKETS: usize = 12;

#[derive(Clone, Debug)]
struct Node {
    bounds: LightBounds,
    /// A leaf's light, or an interior node's second child (its first follows it).
    index: usize,
    leaf: bool,
}

#[derive(Clone, Debug)]
pub struct LightTree {
    nodes: Vec<Node>,
    /// For each light in the tree, the path from the root to its leaf (bit i: the second
    /// child at depth i).
    trails: Vec<Option<u64>>,
    /// The lights at infinity, chosen uniformly outside the tree.
    infinite: Vec<usize>,
}

impl LightTree {
    /// The tree over `bounded` (light index, bounds, both with positive power) of a set of
    /// `count` lights, with the lights at infinity `infinite`.
    pub fn new(
        mut bounded: Vec<(usize, LightBounds)>,
        infinite: Vec<usize>,
        count: usize,
    ) -> LightTree {
        let mut tree = LightTree {
            nodes: Vec::with_capacity(2 * bounded.len()),
            trails: vec![None; count],
            infinite,
        };
        if !bounded.is_empty() {
            tree.build(&mut bounded, 0, 0);
        }
        tree
    }

    /// Builds the subtree of `lights` at `depth` reached by `trail`; returns its node.
    fn build(&mut self, lights: &mut [(usize, LightBounds)], trail: u64, depth: u32) -> usize {
        let at = self.nodes.len();
        if lights.len() == 1 {
            let (light, bounds) = lights[0];
            self.nodes.push(Node {
                bounds,
                index: light,
                leaf: true,
            });
            self.trails[light] = Some(trail);
            return at;
        }
        let total = lights[1..]
            .iter()
            .fold(lights[0].1, |acc, (_, b)| acc.union(b));
        self.nodes.push(Node {
            bounds: total,
            index: 0,
            leaf: false,
        });
        let mid = if depth < 60 {
            split(lights, &total)
        } else {
            None
        }
        .unwrap_or_else(|| {
            // No useful split: halves in order of the centroids along the longest axis.
            let d = total.hi - total.lo;
            let axis = if d.x >= d.y && d.x >= d.z {
                0
            } else if d.y >= d.z {
                1
            } else {
                2
            };
            lights.sort_by(|a, b| a.1.centroid()[axis].total_cmp(&b.1.centroid()[axis]));
            lights.len() / 2
        });
        let (first, second) = lights.split_at_mut(mid);
        self.build(first, trail, depth + 1);
        let second = self.build(second, trail | (1 << depth), depth + 1);
        self.nodes[at].index = second;
        at
    }

    /// Whether the tree holds any light with a position.
    fn has_bounded(&self) -> bool {
        !self.nodes.is_empty()
    }

    /// The probability of choosing among the lights at infinity rather than in the tree.
    fn p_infinite(&self) -> f32 {
        let n = self.infinite.len() as f32;
        n / (n + if self.has_bounded() { 1.0 } else { 0.0 })
    }

    /// Chooses a light for a point `p` from `u` in [0, 1): the light and the probability
    /// of choosing it there. `None` when no light can reach `p`.
    pub fn choose(&self, p: Vec3, u: f32) -> Option<(usize, f32)> {
        let p_inf = self.p_infinite();
        if u < p_inf {
            let n = self.infinite.len();
            let i = ((u / p_inf * n as f32) as usize).min(n - 1);
            return Some((self.infinite[i], p_inf / n as f32));
        }
        if !self.has_bounded() {
            return None;
        }
        let mut u = ((u - p_inf) / (1.0 - p_inf)).min(1.0 - f32::EPSILON / 2.0);
        let mut pmf = 1.0 - p_inf;
        let mut at = 0;
        loop {
            let node = &self.nodes[at];
            if node.leaf {
                // A light alone in the tree is taken wherever p is (its own sampling finds
                // out whether it reaches p), which keeps one-light scenes as fast as before.
                return Some((node.index, pmf));
            }
            let (c0, c1) = (at + 1, node.index);
            let i0 = self.nodes[c0].bounds.importance(p);
            let i1 = self.nodes[c1].bounds.importance(p);
            if i0 + i1 <= 0.0 || (i0 + i1).is_nan() {
                return None;
            }
            let p0 = i0 / (i0 + i1);
            if u < p0 {
                u = (u / p0).min(1.0 - f32::EPSILON / 2.0);
                pmf *= p0;
                at = c0;
            } else {
                u = ((u - p0) / (1.0 - p0)).min(1.0 - f32::EPSILON / 2.0);
                pmf *= 1.0 - p0;
                at = c1;
            }
        }
    }

    /// The probability with which [`LightTree::choose`] picks `light` at `p`.
    pub fn pmf(&self, p: Vec3, light: usize) -> f32 {
        let Some(mut trail) = self.trails.get(light).copied().flatten() else {
            return if self.infinite.contains(&light) {
                self.p_infinite() / self.infinite.len() as f32
            } else {
                0.0
            };
        };
        let mut pmf = 1.0 - self.p_infinite();
        let mut at = 0;
        loop {
            let node = &self.nodes[at];
            if node.leaf {
                return pmf;
            }
            let (c0, c1) = (at + 1, node.index);
            let i0 = self.nodes[c0].bounds.importance(p);
            let i1 = self.nodes[c1].bounds.importance(p);
            if i0 + i1 <= 0.0 || (i0 + i1).is_nan() {
                return 0.0;
            }
            if trail & 1 == 0 {
                pmf *= i0 / (i0 + i1);
                at = c0;
            } else {
                pmf *= i1 / (i0 + i1);
                at = c1;
            }
            trail >>= 1;
        }
    }
}

/// pbrt-v4's cost of a group of lights in a box whose extent along `axis` is split.
fn cost(b: &LightBounds, extent: Vec3, axis: usize) -> f32 {
    use std::f32::consts::PI;
    let cos_o = b.normals.cos_theta.clamp(-1.0, 1.0);
    let theta_o = cos_o.acos();
    let theta_e = b.cos_theta_e.clamp(-1.0, 1.0).acos();
    let theta_w = (theta_o + theta_e).min(PI);
    let sin_o = (1.0 - cos_o * cos_o).max(0.0).sqrt();
    let m_omega = 2.0 * PI * (1.0 - cos_o)
        + PI / 2.0
            * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o
                + cos_o);
    let kr = extent.max_element() / extent[axis].max(f32::MIN_POSITIVE);
    let d = b.hi - b.lo;
    let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
    b.phi * m_omega * kr * area
}

/// The cheapest split of `lights` (reordered so that the first part comes first) into two
/// non-empty parts by buckets of their centroids along an axis: the first part's length.
fn split(lights: &mut [(usize, LightBounds)], total: &LightBounds) -> Option<usize> {
    let (lo, hi) = lights.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), (_, b)| (lo.min(b.centroid()), hi.max(b.centroid())),
    );
    let extent = total.hi - total.lo;
    let bucket = |c: Vec3, axis: usize| -> usize {
        let t = (c[axis] - lo[axis]) / (hi[axis] - lo[axis]);
        ((t * BUCKETS as f32) as usize).min(BUCKETS - 1)
    };
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if hi[axis] <= lo[axis] || (hi[axis] - lo[axis]).is_nan() {
            continue;
        }
        let mut buckets: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
        for (_, b) in lights.iter() {
            let slot = &mut buckets[bucket(b.centroid(), axis)];
            *slot = Some(slot.map_or(*b, |s| s.union(b)));
        }
        for cut in 1..BUCKETS {
            let join = |part: &[Option<LightBounds>]| {
                part.iter()
                    .flatten()
                    .fold(None, |acc: Option<LightBounds>, b| {
                        Some(acc.map_or(*b, |a| a.union(b)))
                    })
            };
            let (Some(below), Some(above)) = (join(&buckets[..cut]), join(&buckets[cut..])) else {
                continue;
            };
            let c = cost(&below, extent, axis) + cost(&above, extent, axis);
            if best.is_none_or(|(bc, _, _)| c < bc) {
                best = Some((c, axis, cut));
            }
        }
    }
    let (_, axis, cut) = best?;
    let mut first = 0;
    for i in 0..lights.len() {
        if bucket(lights[i].1.centroid(), axis) < cut {
            lights.swap(i, first);
            first += 1;
        }
    }
    (first > 0 && first < lights.len()).then_some(first)
}

#[cfg(test)]
mod tests {
    use super::super::bounds::DirectionCone;
    use super::*;
    use crate::math::Rng;

    /// Many small one- and two-sided lights scattered through a room, facing every way.
    fn lamps(n: usize, seed: u64) -> Vec<(usize, LightBounds)> {
        let mut rng = Rng::for_key(seed, &[]);
        (0..n)
            .map(|i| {
                let c = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 10.0;
                let w = Vec3::new(
                    rng.uniform() - 0.5,
                    rng.uniform() - 0.5,
                    rng.uniform() - 0.5,
                )
                .normalize();
                let b = LightBounds {
                    lo: c - 0.05,
                    hi: c + 0.05,
                    phi: 0.5 + rng.uniform(),
                    normals: DirectionCone::of(w),
                    cos_theta_e: 0.0,
                    two_sided: i % 3 == 0,
                };
                (i, b)
            })
            .collect()
    }

    /// At random points, the probabilities of all lights sum to at most 1 (less where a
    /// whole subtree faces away, and choosing there finds nothing), and choosing by
    /// `choose` gives each light its `pmf` (frequencies over 200k choices within 4
    /// standard errors).
    #[test]
    fn choices_follow_the_probabilities_the_tree_reports() {
        let n = 300;
        let tree = LightTree::new(lamps(n, 7), vec![n, n + 1], n + 2);
        let mut rng = Rng::for_key(3, &[]);
        for _ in 0..5 {
            let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 12.0 - 1.0;
            let sum: f64 = (0..n + 2).map(|i| tree.pmf(p, i) as f64).sum();
            assert!(sum < 1.0 + 1e-4 && sum > 0.5, "sum {sum} at {p}");
            let draws = 200_000;
            let mut counts = vec![0u32; n + 2];
            let mut none = 0;
            for k in 0..draws {
                let u = (k as f32 + rng.uniform()) / draws as f32;
                let Some((i, pmf)) = tree.choose(p, u) else {
                    none += 1;
                    continue;
                };
                assert!(
                    (pmf - tree.pmf(p, i)).abs() <= 1e-5 * pmf.max(1e-3),
                    "light {i}"
                );
                counts[i] += 1;
            }
            let expected_none = (1.0 - sum) * draws as f64;
            assert!(
                (none as f64 - expected_none).abs() < 4.0 * expected_none.max(1.0).sqrt() + 2.0
            );
            for (i, &c) in counts.iter().enumerate() {
                let expected = tree.pmf(p, i) as f64 * draws as f64;
                let se = expected.max(1.0).sqrt();
                assert!(
                    (c as f64 - expected).abs() < 4.0 * se + 1.0,
                    "light {i}: {c} chosen, {expected:.1} expected"
                );
            }
        }
    }

    /// The near lights are chosen more often than the far ones of the same power.
    #[test]
    fn nearer_lights_are_chosen_more_often() {
        let lights = lamps(64, 11);
        let tree = LightTree::new(lights.clone(), Vec::new(), 64);
        let p = Vec3::new(5.0, 5.0, 5.0);
        // Two-sided lamps (importance alike in every direction), nearest and farthest by
        // distance over the square root of power.
        let mut by_distance: Vec<(f32, usize)> = lights
            .iter()
            .filter(|(_, b)| b.two_sided)
            .map(|(i, b)| (b.centroid().distance(p) / b.phi.sqrt(), *i))
            .collect();
        by_distance.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (near, far) = (by_distance[0].1, by_distance[by_distance.len() - 1].1);
        assert!(tree.pmf(p, near) > 4.0 * tree.pmf(p, far));
    }
}
