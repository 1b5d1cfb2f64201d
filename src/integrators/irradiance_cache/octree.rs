//! Storage of irradiance values for range search (section 3.3 of the paper). A global cube
//! encloses the scene; each value is stored in the node that contains its position and whose
//! side is greater than twice and at most four times its valid domain a·Ri (the root when the
//! root itself is at most four times the domain, or when the position lies outside the cube).
//! The search visits a node's values, then every child whose cube P is within half the
//! child's side of — and, tighter, within the largest valid domain of any value under that
//! child: a value is only accepted within its domain (|P − Pi| < a·Ri follows from
//! w_i > 1/a), so the children that fail this test hold nothing S could contain. Without
//! it the paper's rule visits about 1.5³ children per level, which made lookups most of the
//! render time on dense caches.

use super::record::{Record, WeightedSum};
use crate::math::{Rgb, Vec3, Vec4};

const NO_CHILDREN: u32 = u32::MAX;
/// Deepest level (a cube 2^-48 of the root): only reached by degenerate domains.
const MAX_DEPTH: u32 = 48;

/// A cube of the tree. The search reads eight of these per node it opens, so they are kept
/// small and apart from the values.
#[derive(Clone, Copy, Debug)]
struct Node {
    center: Vec3,
    /// Half the side.
    half: f32,
    /// The largest valid domain a·Ri of the values in this node and below it (0: none).
    reach: f32,
    /// Index of the first of eight consecutive children, or NO_CHILDREN.
    children: u32,
}

/// The values stored at one node.
#[derive(Clone, Debug, Default)]
struct Contents {
    /// Indices into `Octree::records`, in insertion order.
    values: Vec<u32>,
    /// Per value: its position and the square of its valid domain a·Ri. The search tests
    /// these first, from memory it reads in order, and looks at the record itself only
    /// when P lies inside the domain.
    spheres: Vec<Vec4>,
}

/// The values of one bounce level, with that level's accuracy `a`.
#[derive(Clone, Debug)]
pub struct Octree {
    a: f32,
    nodes: Vec<Node>,
    /// Per node, what it stores.
    contents: Vec<Contents>,
    records: Vec<Record>,
}

/// The depth at which a value whose valid domain is `domain` (= a·Ri) is stored in a tree
/// whose root cube has side `root_side`: the smallest depth d with root_side / 2^d ≤ 4·domain,
/// so that 2·domain < side ≤ 4·domain whenever d > 0.
pub fn storage_depth(root_side: f32, domain: f32) -> u32 {
    let mut d = 0;
    let mut side = root_side;
    while side > 4.0 * domain && d < MAX_DEPTH {
        side *= 0.5;
        d += 1;
    }
    d
}

fn distance_to_cube(p: Vec3, center: Vec3, half: f32) -> f32 {
    let d = ((p - center).abs() - Vec3::splat(half)).max(Vec3::ZERO);
    d.length()
}

impl Octree {
    /// An empty tree over the cube of side `side` centred at `center`, for accuracy `a`.
    pub fn new(center: Vec3, side: f32, a: f32) -> Octree {
        Octree {
            a,
            nodes: vec![Node {
                center,
                half: 0.5 * side,
                reach: 0.0,
                children: NO_CHILDREN,
            }],
            contents: vec![Contents::default()],
            records: Vec::new(),
        }
    }

    pub fn accuracy(&self) -> f32 {
        self.a
    }

    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// The values in insertion order.
    pub fn records(&self) -> &[Record] {
        &self.records
    }

    pub fn root(&self) -> (Vec3, f32) {
        (self.nodes[0].center, 2.0 * self.nodes[0].half)
    }

    /// The node a value goes to, and its depth, subdividing as needed.
    pub fn insert(&mut self, rec: Record) -> u32 {
        let root = &self.nodes[0];
        let inside = (rec.p - root.center).abs().max_element() <= root.half;
        let depth = if inside {
            storage_depth(2.0 * root.half, self.a * rec.r)
        } else {
            0
        };
        let domain = self.a * rec.r;
        let mut node = 0usize;
        for _ in 0..depth {
            self.nodes[node].reach = self.nodes[node].reach.max(domain);
            if self.nodes[node].children == NO_CHILDREN {
                let first = self.nodes.len() as u32;
                let (c, h) = (self.nodes[node].center, self.nodes[node].half * 0.5);
                for k in 0..8 {
                    let o = Vec3::new(
                        if k & 1 != 0 { h } else { -h },
                        if k & 2 != 0 { h } else { -h },
                        if k & 4 != 0 { h } else { -h },
                    );
                    self.nodes.push(Node {
                        center: c + o,
                        half: h,
                        reach: 0.0,
                        children: NO_CHILDREN,
                    });
                    self.contents.push(Contents::default());
                }
                self.nodes[node].children = first;
            }
            let n = &self.nodes[node];
            let k = (rec.p.x >= n.center.x) as u32
                | ((rec.p.y >= n.center.y) as u32) << 1
                | ((rec.p.z >= n.center.z) as u32) << 2;
            node = (n.children + k) as usize;
        }
        self.nodes[node].reach = self.nodes[node].reach.max(domain);
        let contents = &mut self.contents[node];
        contents.values.push(self.records.len() as u32);
        contents.spheres.push(rec.p.extend(domain * domain));
        self.records.push(rec);
        depth
    }

    #[cfg(test)]
    /// Indices of the values in S at P (w_i > 1/a and d_i ≥ 0), with their weights, by the
    /// recursive search of section 3.3.
    pub fn search(&self, p: Vec3, n: Vec3, out: &mut Vec<(u32, f32)>) {
        self.visit(0, p, n, &mut |i, w| out.push((i, w)));
    }

    /// Adds the values in S at P to `sum` (the secondary method, eq. 5), in the order the
    /// search meets them. That order depends only on the order the values were inserted in
    /// (which fixes the tree), and a cache file keeps it.
    pub fn accumulate(&self, p: Vec3, n: Vec3, sum: &mut WeightedSum) {
        self.visit(0, p, n, &mut |i, w| {
            sum.add(w, self.records[i as usize].extrapolated(p, n))
        });
    }

    /// The secondary method: the weighted average over S (eq. 5), or None when S is empty.
    pub fn interpolate(&self, p: Vec3, n: Vec3) -> Option<Rgb> {
        let mut sum = WeightedSum::default();
        self.accumulate(p, n, &mut sum);
        sum.average()
    }

    fn visit(&self, node: usize, p: Vec3, n: Vec3, found: &mut impl FnMut(u32, f32)) {
        let nd = &self.nodes[node];
        let contents = &self.contents[node];
        for (&i, sphere) in contents.values.iter().zip(&contents.spheres) {
            if (p - sphere.truncate()).length_squared() >= sphere.w {
                continue;
            }
            if let Some(w) = self.records[i as usize].accept(p, n, self.a) {
                found(i, w);
            }
        }
        if nd.children == NO_CHILDREN {
            return;
        }
        for k in 0..8 {
            let c = (nd.children + k) as usize;
            let child = &self.nodes[c];
            // Within half the child's side (its `half`) of the child's cube, and within
            // reach of a value below it (`<=`: the exact bound is strict).
            if child.reach > 0.0
                && distance_to_cube(p, child.center, child.half) <= child.half.min(child.reach)
            {
                self.visit(c, p, n, found);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    #[test]
    fn storage_level_rule() {
        // Root side 8. Domain 2: 8 ≤ 4·2 → root.
        assert_eq!(storage_depth(8.0, 2.0), 0);
        // Domain 3 (larger than the root's quarter): root.
        assert_eq!(storage_depth(8.0, 3.0), 0);
        // Domain 1: side 4 ∈ (2, 4] → depth 1.
        assert_eq!(storage_depth(8.0, 1.0), 1);
        // Domain 0.9: side 4 > 3.6, side 2 ∈ (1.8, 3.6] → depth 2.
        assert_eq!(storage_depth(8.0, 0.9), 2);
        // Domain 0.5: side 2 ∈ (1, 2] → depth 2; 0.49: side 1 ∈ (0.98, 1.96] → depth 3.
        assert_eq!(storage_depth(8.0, 0.5), 2);
        assert_eq!(storage_depth(8.0, 0.49), 3);
        // The invariant for many domains.
        let mut rng = Rng::for_key(1, &[]);
        for _ in 0..1000 {
            let domain = 8.0 * rng.uniform().powi(4) + 1e-4;
            let d = storage_depth(8.0, domain);
            let side = 8.0 / (1u64 << d) as f32;
            assert!(side <= 4.0 * domain, "{domain} {d}");
            if d > 0 {
                assert!(side > 2.0 * domain, "{domain} {d}");
            }
        }
    }

    #[test]
    fn insert_places_value_at_its_level() {
        let mut t = Octree::new(Vec3::ZERO, 8.0, 0.5);
        let rec = |p: Vec3, r: f32| Record {
            p,
            n: Vec3::Z,
            e: Rgb::ONE,
            r,
            grad: Default::default(),
        };
        // a·R = 0.5 → depth 2 (side 2).
        assert_eq!(t.insert(rec(Vec3::new(1.0, 1.0, 1.0), 1.0)), 2);
        // Outside the cube: the root.
        assert_eq!(t.insert(rec(Vec3::new(10.0, 0.0, 0.0), 0.01)), 0);
        assert_eq!(t.len(), 2);
    }

    /// The search returns exactly the values a scan over all values accepts.
    #[test]
    fn search_matches_brute_force() {
        let mut rng = Rng::for_key(7, &[]);
        let u3 = |rng: &mut Rng| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
        for &a in &[0.1f32, 0.3, 0.8] {
            let mut t = Octree::new(Vec3::splat(0.5), 1.0, a);
            for _ in 0..2000 {
                let p = u3(&mut rng);
                // Half the records face +z, so that queries facing +z accept many.
                let n = if rng.uniform() < 0.5 {
                    Vec3::Z
                } else {
                    (u3(&mut rng) * 2.0 - Vec3::ONE).normalize_or(Vec3::Z)
                };
                let r = 0.002 + 0.3 * rng.uniform().powi(3);
                t.insert(Record {
                    p,
                    n,
                    e: u3(&mut rng),
                    r,
                    grad: Default::default(),
                });
            }
            let mut total = 0;
            for _ in 0..2000 {
                // Half the queries near a record, the others anywhere, also a little outside
                // the cube.
                let p = if rng.uniform() < 0.5 {
                    let i = (rng.uniform() * t.len() as f32) as usize % t.len();
                    let rec = t.records()[i];
                    rec.p + (u3(&mut rng) * 2.0 - Vec3::ONE) * (1.2 * a * rec.r)
                } else {
                    u3(&mut rng) * 1.2 - Vec3::splat(0.1)
                };
                let n = if rng.uniform() < 0.7 {
                    Vec3::Z
                } else {
                    (u3(&mut rng) * 2.0 - Vec3::ONE).normalize_or(Vec3::Z)
                };
                let mut found = Vec::new();
                t.search(p, n, &mut found);
                let mut got: Vec<u32> = found.iter().map(|f| f.0).collect();
                got.sort_unstable();
                let want: Vec<u32> = (0..t.len() as u32)
                    .filter(|&i| t.records()[i as usize].accept(p, n, a).is_some())
                    .collect();
                assert_eq!(got, want, "a = {a}, P = {p}");
                total += want.len();
            }
            assert!(
                total > 30,
                "a = {a}: only {total} accepted values in all queries"
            );
        }
    }
}
