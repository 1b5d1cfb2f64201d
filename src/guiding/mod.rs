//! Path guiding: the incident light field learned during a render and sampled from
//! (Müller, Gross & Novák 2017, "Practical Path Guiding"). The guide is an SD-tree: a binary
//! tree over space ([`spatial`]) whose leaves hold quadtrees over directions
//! ([`directional`]). A render learns in iterations of doubling sample counts (1, 1, 2, 4,
//! … samples per pixel, up to half the samples): during an iteration the paths sample from
//! the guide the previous one built and deposit what they find in a new one; between
//! iterations (a pass boundary every thread waits at) the deposits are summed in tile order
//! and the next guide is built. The guide a pass reads never changes during it, and the
//! deposits are summed in a fixed order, so the image is the same for any thread count.

pub mod directional;
pub mod spatial;

use crate::math::Vec3;
use directional::DirTree;
use spatial::SpatialTree;
use std::sync::Arc;

/// Spatial leaves split when an iteration of one sample per pixel left more than this many
/// deposits in them (the threshold grows with the square root of the iteration's samples).
pub const SPATIAL_THRESHOLD: f64 = 12_000.0;
/// A directional quadrant holding more than this share of its leaf's energy is refined.
pub const DIRECTIONAL_FRACTION: f32 = 0.01;
/// The probability of sampling the guide rather than the BSDF where both are used.
pub const GUIDE_FRACTION: f32 = 0.5;

/// Directional distributions per spatial leaf: one for each way a surface may face (the
/// axis its normal is nearest, and the sign), so that a floor and a ceiling in the same
/// leaf do not share one: light from behind a surface never reaches it, and a distribution
/// shared with surfaces facing the other way would send half its samples there.
pub const FACINGS: usize = 6;

/// Which of the [`FACINGS`] the normal `n` is.
fn facing(n: Vec3) -> usize {
    let a = n.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    axis * 2 + (n[axis] < 0.0) as usize
}

/// A deposit: a slot of the guide being learned (a leaf quadrant of one spatial leaf's
/// quadtree) and the energy found there (incident radiance over the density it was
/// sampled with).
pub type Deposit = (u32, f32);

/// What a guided sample reads and writes: the pass's guide, and the tile's deposits when
/// the pass learns.
pub struct Guidance<'a> {
    pub guide: &'a Guide,
    /// `Some` when the pass learns: the deposits of the tile's samples, in their order.
    pub deposits: Option<Vec<Deposit>>,
}

/// One directional leaf (a spatial leaf and a facing): the distribution sampled from, and
/// the structure being learned.
#[derive(Clone, Debug)]
struct Leaf {
    /// `None` until something was learned there (BSDF sampling alone then).
    sampling: Option<DirTree>,
    learning: DirTree,
    /// Its first slot among all leaves'.
    offset: u32,
}

/// The guide a pass samples from and deposits into: immutable while a pass runs.
#[derive(Clone, Debug)]
pub struct Guide {
    space: SpatialTree,
    leaves: Vec<Leaf>,
    /// For every slot, its leaf.
    slot_leaf: Vec<u32>,
}

impl Guide {
    /// Nothing learned yet, over the scene's bounds.
    pub fn new(bounds: (Vec3, Vec3)) -> Guide {
        let mut g = Guide {
            space: SpatialTree::new(bounds),
            leaves: vec![
                Leaf {
                    sampling: None,
                    learning: DirTree::new(),
                    offset: 0,
                };
                FACINGS
            ],
            slot_leaf: Vec::new(),
        };
        g.index_slots();
        g
    }

    fn index_slots(&mut self) {
        self.slot_leaf.clear();
        for (i, l) in self.leaves.iter_mut().enumerate() {
            l.offset = self.slot_leaf.len() as u32;
            self.slot_leaf
                .extend(std::iter::repeat_n(i as u32, l.learning.slots()));
        }
    }

    /// The directional leaf of a surface at `p` facing `n`.
    pub fn leaf(&self, p: Vec3, n: Vec3) -> u32 {
        self.space.leaf(p) * FACINGS as u32 + facing(n) as u32
    }

    /// The distribution to sample at leaf `leaf`, if one was learned there.
    pub fn distribution(&self, leaf: u32) -> Option<&DirTree> {
        self.leaves[leaf as usize].sampling.as_ref()
    }

    /// The slot a deposit of light arriving from direction `d` at leaf `leaf` goes to.
    pub fn slot(&self, leaf: u32, d: Vec3) -> u32 {
        let l = &self.leaves[leaf as usize];
        l.offset + l.learning.slot(d)
    }

    pub fn slots(&self) -> usize {
        self.slot_leaf.len()
    }

    #[cfg(test)]
    pub fn spatial_leaves(&self) -> usize {
        self.leaves.len() / FACINGS
    }
}

/// The samples per pixel after which guides are built in a render of `spp`: 1, 2, 4, …, up
/// to half of `spp`.
pub fn rebuilds(spp: u32) -> impl Iterator<Item = u32> {
    (0..31)
        .map(|k| 1u32 << k)
        .take_while(move |&b| b as u64 * 2 <= spp as u64)
}

/// A guide being learned: the current one and the deposits into the next.
pub struct Learning {
    guide: Arc<Guide>,
    sums: Vec<f64>,
    counts: Vec<u64>,
    /// Samples per pixel when the last guide was built.
    built_at: u32,
    /// The last of [`rebuilds`].
    last: u32,
}

impl Learning {
    pub fn new(bounds: (Vec3, Vec3), spp: u32) -> Learning {
        let guide = Guide::new(bounds);
        Learning {
            sums: vec![0.0; guide.slots()],
            counts: vec![0; guide.leaves.len()],
            guide: Arc::new(guide),
            built_at: 0,
            last: rebuilds(spp).last().unwrap_or(0),
        }
    }

    /// The guide to sample from now.
    pub fn guide(&self) -> Arc<Guide> {
        self.guide.clone()
    }

    /// Whether samples from `done` per pixel on still deposit (a guide comes after them).
    pub fn learns_at(&self, done: u32) -> bool {
        done < self.last
    }

    /// Whether a guide is built once `done` samples per pixel are taken.
    pub fn builds_at(&self, done: u32) -> bool {
        done <= self.last && done.is_power_of_two() && done > self.built_at
    }

    /// Adds a tile's deposits (tiles must come in a fixed order).
    pub fn absorb(&mut self, deposits: &[Deposit]) {
        for &(slot, value) in deposits {
            self.sums[slot as usize] += value as f64;
            self.counts[self.guide.slot_leaf[slot as usize] as usize] += 1;
        }
    }

    /// Builds the next guide from the deposits of the samples since the last one, which
    /// now number `done` per pixel.
    pub fn build(&mut self, done: u32) {
        let per_pixel = (done - self.built_at).max(1) as f64;
        let threshold = SPATIAL_THRESHOLD * per_pixel.sqrt();
        let old = &self.guide;
        // What each leaf learned (a leaf with no deposits keeps its distribution).
        let learned: Vec<(Option<DirTree>, DirTree)> = old
            .leaves
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let start = l.offset as usize;
                let energy = l
                    .learning
                    .with_energy(&self.sums[start..start + l.learning.slots()]);
                let sampling = if self.counts[i] == 0 {
                    l.sampling.clone()
                } else {
                    (energy.total() > 0.0).then(|| energy.clone())
                };
                let next = match &sampling {
                    Some(s) => s.refined(DIRECTIONAL_FRACTION),
                    None => DirTree::new(),
                };
                (sampling, next)
            })
            .collect();
        let mut space = old.space.clone();
        let counts = &self.counts;
        let origin = space.split(|leaf| {
            let first = leaf as usize * FACINGS;
            let mut n = counts[first..first + FACINGS].iter().sum::<u64>() as f64;
            let mut levels = 0;
            while n > threshold {
                n *= 0.5;
                levels += 1;
            }
            levels
        });
        let mut guide = Guide {
            space,
            leaves: origin
                .iter()
                .flat_map(|&o| (0..FACINGS).map(move |f| o as usize * FACINGS + f))
                .map(|o| {
                    let (sampling, learning) = &learned[o];
                    Leaf {
                        sampling: sampling.clone(),
                        learning: learning.clone(),
                        offset: 0,
                    }
                })
                .collect(),
            slot_leaf: Vec::new(),
        };
        guide.index_slots();
        self.sums = vec![0.0; guide.slots()];
        self.counts = vec![0; guide.leaves.len()];
        self.guide = Arc::new(guide);
        self.built_at = done;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guides_are_built_at_powers_of_two_up_to_half_the_samples() {
        assert_eq!(rebuilds(16).collect::<Vec<_>>(), vec![1, 2, 4, 8]);
        assert_eq!(rebuilds(17).collect::<Vec<_>>(), vec![1, 2, 4, 8]);
        assert_eq!(rebuilds(1).count(), 0);
        let l = Learning::new((Vec3::ZERO, Vec3::ONE), 16);
        assert!(l.learns_at(7) && !l.learns_at(8));
        assert!(l.builds_at(1) && l.builds_at(8) && !l.builds_at(16) && !l.builds_at(6));
    }

    /// Light deposited from one direction in one corner of the scene: the built guide
    /// samples towards it there, and splits space where the deposits were many.
    #[test]
    fn a_guide_learns_where_light_comes_from() {
        let mut l = Learning::new((Vec3::ZERO, Vec3::ONE), 64);
        let corner = Vec3::splat(0.1);
        let g = l.guide();
        let leaf = g.leaf(corner, Vec3::Y);
        assert!(g.distribution(leaf).is_none());
        let mut rng = crate::math::Rng::for_key(1, &[1]);
        for done in [1, 2, 4] {
            let g = l.guide();
            let mut deposits = Vec::new();
            for _ in 0..30_000 {
                let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                let u = crate::math::Vec2::new(rng.uniform(), rng.uniform());
                let d = directional::from_square(u);
                let lit = p.x < 0.5 && d.z > 0.9;
                deposits.push((g.slot(g.leaf(p, Vec3::Y), d), if lit { 1.0 } else { 0.0 }));
            }
            l.absorb(&deposits);
            l.build(done);
        }
        let g = l.guide();
        assert!(g.spatial_leaves() >= 2, "{} leaves", g.spatial_leaves());
        let d = g.distribution(g.leaf(corner, Vec3::Y)).expect("learned");
        let density = d.pdf(Vec3::Z) * 4.0 * std::f32::consts::PI;
        assert!(density > 10.0, "density towards the light {density}");
        // Where no light was found nothing is learned.
        assert!(g.distribution(g.leaf(Vec3::splat(0.9), Vec3::Y)).is_none());
    }
}
