//! The spatial half of the guide: a binary tree over a cube around the scene, split at the
//! middle along x, y, z in turn, whose leaves each hold a directional distribution.

use crate::math::Vec3;

/// Deepest spatial level (16 splits per axis).
pub const MAX_DEPTH: u32 = 48;

/// A node: its first child (the second follows it; 0: a leaf) or its leaf's index.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Node {
    children: u32,
    leaf: u32,
}

#[derive(Clone, Debug, PartialEq)]
pub struct SpatialTree {
    lo: Vec3,
    size: f32,
    nodes: Vec<Node>,
}

impl SpatialTree {
    /// One leaf (number 0) over the cube holding `(lo, hi)`, with a margin.
    pub fn new((lo, hi): (Vec3, Vec3)) -> SpatialTree {
        let extent = (hi - lo).max_element().max(1e-3);
        let margin = extent * 0.01;
        SpatialTree {
            lo: lo - Vec3::splat(margin),
            size: extent + 2.0 * margin,
            nodes: vec![Node {
                children: 0,
                leaf: 0,
            }],
        }
    }

    /// The index of the leaf holding `p` (points outside the cube go to the nearest leaf).
    pub fn leaf(&self, p: Vec3) -> u32 {
        let mut q = ((p - self.lo) / self.size).clamp(Vec3::ZERO, Vec3::ONE);
        let mut node = 0usize;
        let mut axis = 0usize;
        loop {
            let n = self.nodes[node];
            if n.children == 0 {
                return n.leaf;
            }
            let high = q[axis] >= 0.5;
            q[axis] = q[axis] * 2.0 - high as u32 as f32;
            node = n.children as usize + high as usize;
            axis = (axis + 1) % 3;
        }
    }

    /// Splits leaves: `splits(leaf)` says how many more levels to split each one. The first
    /// half of a split leaf keeps its index, the second takes the next new one; returns,
    /// for every leaf after the split, the old leaf it came from.
    pub fn split(&mut self, splits: impl Fn(u32) -> u32) -> Vec<u32> {
        let mut origin: Vec<u32> = (0..self.leaves() as u32).collect();
        // (node, depth, levels to split still).
        let mut stack: Vec<(usize, u32, u32)> = Vec::new();
        let mut depths = vec![(0usize, 0u32)];
        while let Some((node, depth)) = depths.pop() {
            let n = self.nodes[node];
            if n.children != 0 {
                depths.push((n.children as usize, depth + 1));
                depths.push((n.children as usize + 1, depth + 1));
            } else {
                stack.push((node, depth, splits(n.leaf)));
            }
        }
        while let Some((node, depth, levels)) = stack.pop() {
            if levels == 0 || depth >= MAX_DEPTH {
                continue;
            }
            let leaf = self.nodes[node].leaf;
            let new_leaf = origin.len() as u32;
            origin.push(origin[leaf as usize]);
            let first = self.nodes.len();
            self.nodes.push(Node { children: 0, leaf });
            self.nodes.push(Node {
                children: 0,
                leaf: new_leaf,
            });
            self.nodes[node].children = first as u32;
            stack.push((first, depth + 1, levels - 1));
            stack.push((first + 1, depth + 1, levels - 1));
        }
        origin
    }

    pub fn leaves(&self) -> usize {
        self.nodes.iter().filter(|n| n.children == 0).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_put_points_in_their_halves() {
        let mut t = SpatialTree::new((Vec3::ZERO, Vec3::ONE));
        assert_eq!(t.leaf(Vec3::splat(0.3)), 0);
        let origin = t.split(|_| 2);
        assert_eq!(origin, vec![0, 0, 0, 0]);
        assert_eq!(t.leaves(), 4);
        // Two levels: x then y.
        let corners = [
            Vec3::new(0.1, 0.1, 0.5),
            Vec3::new(0.9, 0.1, 0.5),
            Vec3::new(0.1, 0.9, 0.5),
            Vec3::new(0.9, 0.9, 0.5),
        ];
        let mut leaves: Vec<u32> = corners.iter().map(|&p| t.leaf(p)).collect();
        leaves.sort();
        assert_eq!(leaves, vec![0, 1, 2, 3]);
        // z does not matter yet.
        assert_eq!(t.leaf(Vec3::new(0.1, 0.1, 0.0)), t.leaf(corners[0]));
        // Split only the leaf at the first corner once more, along z.
        let l = t.leaf(corners[0]);
        let origin = t.split(|leaf| (leaf == l) as u32);
        assert_eq!(origin.len(), 5);
        assert_eq!(origin[4], l);
        assert_ne!(
            t.leaf(Vec3::new(0.1, 0.1, 0.1)),
            t.leaf(Vec3::new(0.1, 0.1, 0.9))
        );
    }
}
