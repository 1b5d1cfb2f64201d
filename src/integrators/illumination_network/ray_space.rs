//! The uniform 4-D ray space of the paper ("Links"): the scene is scaled into the unit cube;
//! lines are grouped in three *families*, one per intercept plane. A line of family `a`
//! (the axis it advances along) is
//!
//! ```text
//! p_u = s_u·p_a + i_u,   p_v = s_v·p_a + i_v,   u = (a+1) mod 3, v = (a+2) mod 3,
//! ```
//!
//! with slopes s in [−1, 1] and intercepts i in [−1, 2] (every line through the unit cube
//! whose direction is closest to axis `a` is of this form). The grid takes cell centres:
//! S slopes per axis, s_k = −1 + (k + ½)·Δs with Δs = 2/S, and N intercepts per axis,
//! i_j = −1 + (j + ½)·h. A *slot* is one (family, s_u, s_v): the direction of a link comes from
//! its slot, the index of the link in its patch's array.
//!
//! **Étendue of a line cell (the per-slope weight of figure 3).** The measure of lines,
//! dG = cosθ dA dω, written in slope-intercept coordinates of family `a`: the intercept plane
//! p_a = 0 has normal e_a, and the unit direction is d = (e_a + s_u e_u + s_v e_v)/r with
//! r = √(1 + s_u² + s_v²), so cosθ = 1/r. The gnomonic map s ↦ d has dω = ds_u ds_v / r³
//! (a plane at unit distance seen from the origin: dω = cosθ dA / r² with cosθ = 1/r). Hence
//!
//! ```text
//! dG = ds_u ds_v di_u di_v / (1 + s_u² + s_v²)²,   w(s) = Δs² h² / (1 + s_u² + s_v²)².
//! ```
//!
//! Lines with small slopes are sparser in direction (and the lines through one point are
//! sparser), so they carry *more* étendue: the weight falls off as 1/r⁴ toward the corners.
//! Summed over the lines through a patch of area A (one family covers a sixth of the sphere
//! of directions, each unoriented direction once over the three families), the weights give
//! ∫ A|cosθ| dω over a hemisphere's worth of lines: πA (tested).

use crate::math::Vec3;
use wide::{f32x4, i32x4, u32x4};

/// The grid over lines, and the map from world space into the unit cube.
#[derive(Clone, Debug, PartialEq)]
pub struct RaySpace {
    /// Slopes per axis (S).
    pub slopes: u32,
    /// Intercept step h, in unit-cube units.
    pub step: f32,
    /// Intercepts per axis: N = ⌈3/h⌉, covering [−1, −1 + N·h] ⊇ [−1, 2].
    pub intercepts: u32,
    /// World position of the unit cube's corner (0, 0, 0).
    pub origin: Vec3,
    /// World length of the unit cube's side.
    pub scale: f32,
}

/// `d` or −d, whichever lies in the hemisphere of `n`.
#[inline]
fn towards(d: Vec3, n: Vec3) -> Vec3 {
    if d.dot(n) < 0.0 {
        -d
    } else {
        d
    }
}

/// Each slot's unit direction and étendue, worked out once for the renderer's gathers
/// (the same values as [`RaySpace::direction_towards`] and [`RaySpace::etendue`]).
pub struct SlotGeometry {
    unit: Vec<Vec3>,
    etendue: Vec<f32>,
}

impl SlotGeometry {
    pub fn new(space: &RaySpace) -> SlotGeometry {
        let slots = 0..space.slots() as u32;
        SlotGeometry {
            unit: slots
                .clone()
                .map(|l| space.direction(l).normalize())
                .collect(),
            etendue: slots.map(|l| space.etendue(l)).collect(),
        }
    }

    /// [`RaySpace::direction_towards`]: the slot's unit direction into the hemisphere of `n`.
    #[inline]
    pub fn direction_towards(&self, slot: u32, n: Vec3) -> Vec3 {
        towards(self.unit[slot as usize], n)
    }

    #[inline]
    pub fn etendue(&self, slot: u32) -> f32 {
        self.etendue[slot as usize]
    }

    /// Bytes held.
    pub fn memory(&self) -> usize {
        self.unit.len() * std::mem::size_of::<Vec3>() + self.etendue.len() * 4
    }
}

#[cfg(test)]
/// One line of the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Line {
    pub family: u32,
    pub su: u32,
    pub sv: u32,
    pub iu: u32,
    pub iv: u32,
}

/// The two other axes of a family, in the paper's order.
#[inline]
pub fn axes(family: u32) -> (usize, usize, usize) {
    let a = family as usize;
    (a, (a + 1) % 3, (a + 2) % 3)
}

impl RaySpace {
    /// The ray space for a scene's bounding box: the box is centred in the unit cube with a
    /// margin of 1% so no surface lies on the cube's faces.
    pub fn new(slopes: u32, step: f32, bounds: (Vec3, Vec3)) -> RaySpace {
        let (lo, hi) = bounds;
        let extent = (hi - lo).max_element().max(1e-6);
        let scale = extent * 1.02;
        let centre = 0.5 * (lo + hi);
        RaySpace {
            slopes,
            step,
            intercepts: (3.0 / step).ceil() as u32,
            origin: centre - Vec3::splat(0.5 * scale),
            scale,
        }
    }

    pub fn slots(&self) -> usize {
        3 * (self.slopes * self.slopes) as usize
    }

    /// Lines per slot (N²).
    pub fn lines_per_slot(&self) -> usize {
        (self.intercepts as usize).pow(2)
    }

    pub fn slope_step(&self) -> f32 {
        2.0 / self.slopes as f32
    }

    /// The slope at grid index k (a cell centre).
    #[inline]
    pub fn slope(&self, k: u32) -> f32 {
        -1.0 + (k as f32 + 0.5) * self.slope_step()
    }

    /// The intercept at grid index j (a cell centre).
    #[inline]
    pub fn intercept(&self, j: u32) -> f32 {
        -1.0 + (j as f32 + 0.5) * self.step
    }

    pub fn to_unit(&self, p: Vec3) -> Vec3 {
        (p - self.origin) / self.scale
    }

    pub fn to_world(&self, p: Vec3) -> Vec3 {
        self.origin + p * self.scale
    }

    /// Slot index of (family, su, sv).
    #[inline]
    pub fn slot(&self, family: u32, su: u32, sv: u32) -> u32 {
        (family * self.slopes + su) * self.slopes + sv
    }

    /// (family, su, sv) of a slot.
    #[inline]
    pub fn slot_parts(&self, slot: u32) -> (u32, u32, u32) {
        let s = self.slopes;
        (slot / (s * s), (slot / s) % s, slot % s)
    }

    /// The slopes (s_u, s_v) of a slot.
    #[inline]
    pub fn slot_slopes(&self, slot: u32) -> (u32, f32, f32) {
        let (f, su, sv) = self.slot_parts(slot);
        (f, self.slope(su), self.slope(sv))
    }

    /// The line index: a bijection between lines and 0..3·S²·N².
    #[cfg(test)]
    pub fn line_index(&self, l: Line) -> u64 {
        let n = self.intercepts as u64;
        let slot = self.slot(l.family, l.su, l.sv) as u64;
        (slot * n + l.iu as u64) * n + l.iv as u64
    }

    #[cfg(test)]
    pub fn line(&self, index: u64) -> Line {
        let n = self.intercepts as u64;
        let iv = (index % n) as u32;
        let iu = ((index / n) % n) as u32;
        let (family, su, sv) = self.slot_parts((index / (n * n)) as u32);
        Line {
            family,
            su,
            sv,
            iu,
            iv,
        }
    }

    #[cfg(test)]
    pub fn line_count(&self) -> u64 {
        self.slots() as u64 * self.lines_per_slot() as u64
    }

    /// The étendue of one line cell of a slot (module comment), in unit-cube units.
    #[inline]
    pub fn etendue(&self, slot: u32) -> f32 {
        let (_, su, sv) = self.slot_slopes(slot);
        let ds = self.slope_step();
        let r2 = 1.0 + su * su + sv * sv;
        ds * ds * self.step * self.step / (r2 * r2)
    }

    /// The étendue of every slot, in slot order.
    pub fn etendues(&self) -> Vec<f32> {
        (0..self.slots() as u32).map(|s| self.etendue(s)).collect()
    }

    /// The (unnormalised, d_a = 1) direction of a slot's lines.
    pub fn direction(&self, slot: u32) -> Vec3 {
        let (f, su, sv) = self.slot_slopes(slot);
        let (a, u, v) = axes(f);
        let mut d = [0.0; 3];
        d[a] = 1.0;
        d[u] = su;
        d[v] = sv;
        Vec3::from_array(d)
    }

    /// The unit direction of a slot oriented into the hemisphere of `n`.
    pub fn direction_towards(&self, slot: u32, n: Vec3) -> Vec3 {
        towards(self.direction(slot).normalize(), n)
    }

    /// The family of a direction and its continuous slope coordinates (s_u, s_v) in [−1, 1].
    pub fn slopes_of(&self, d: Vec3) -> (u32, f32, f32) {
        let ad = d.abs();
        let a = if ad.x >= ad.y && ad.x >= ad.z {
            0
        } else if ad.y >= ad.z {
            1
        } else {
            2
        };
        let (a, u, v) = axes(a);
        let da = d[a];
        (a as u32, d[u] / da, d[v] / da)
    }

    /// The continuous grid coordinate of a slope (cell centres at integers).
    #[inline]
    pub fn slope_coord(&self, s: f32) -> f32 {
        (s + 1.0) / self.slope_step() - 0.5
    }

    /// The slot whose direction is nearest (in slope space) to `d` (either orientation): the
    /// slot whose cell of directions holds `d`.
    pub fn nearest_slot(&self, d: Vec3) -> u32 {
        let (f, su, sv) = self.slopes_of(d);
        let k = |s: f32| (self.slope_coord(s).round().max(0.0) as u32).min(self.slopes - 1);
        self.slot(f, k(su), k(sv))
    }

    /// The four slots bounding direction `d` (either orientation) in slope space, with
    /// bilinear weights (figure 6 a); clamped at the edges of `d`'s family.
    pub fn bounding_slots(&self, d: Vec3) -> [(u32, f32); 4] {
        let (f, su, sv) = self.slopes_of(d);
        let (x, y) = (self.slope_coord(su), self.slope_coord(sv));
        let last = self.slopes as i32 - 1;
        let (x0, y0) = (x.floor() as i32, y.floor() as i32);
        let (fx, fy) = (
            (x - x0 as f32).clamp(0.0, 1.0),
            (y - y0 as f32).clamp(0.0, 1.0),
        );
        let at = |dx: i32, dy: i32| {
            self.slot(
                f,
                (x0 + dx).clamp(0, last) as u32,
                (y0 + dy).clamp(0, last) as u32,
            )
        };
        [
            (at(0, 0), (1.0 - fx) * (1.0 - fy)),
            (at(1, 0), fx * (1.0 - fy)),
            (at(0, 1), (1.0 - fx) * fy),
            (at(1, 1), fx * fy),
        ]
    }

    /// The jitter of a line's intercept, in [−½, ½)² times `amount`·h: a hash of the seed and
    /// the line, so both builders (and any thread) see the same lines.
    #[inline]
    pub fn jitter(&self, seed: u64, amount: f32, slot: u32, iu: u32, iv: u32) -> (f32, f32) {
        self.jitter_mixed(jitter_seed(seed), amount, slot, iu, iv)
    }

    /// [`jitter`](Self::jitter) with the seed already mixed by [`jitter_seed`].
    #[inline]
    pub fn jitter_mixed(&self, mixed: u64, amount: f32, slot: u32, iu: u32, iv: u32) -> (f32, f32) {
        let (du, dv) = self.jitter_lanes(
            slot_jitter_seed(mixed, slot),
            amount,
            u32x4::splat(iu * self.intercepts + iv),
        );
        (du.to_array()[0], dv.to_array()[0])
    }

    /// The jitters of four lines of one slot (`lines`: iu·intercepts + iv), the slot's seed
    /// from [`slot_jitter_seed`]. One 32-bit hash per line (a bijection with full avalanche
    /// of the line and the slot's seed), in SIMD lanes: the scan converter asks for millions
    /// of lines. Its high 16 bits give the u jitter and its low 16 bits the v jitter: steps
    /// of h/65536, finer than any use of the lines can tell.
    #[inline]
    pub fn jitter_lanes(&self, seed: u32, amount: f32, lines: u32x4) -> (f32x4, f32x4) {
        // No early return for no jitter: a zero scale gives zeros, and the scan converter
        // would test `amount` for every group of lanes.
        let scale = f32x4::splat(amount * self.step);
        let hash = hash32(lines ^ u32x4::splat(seed));
        let fraction = |bits: u32x4| {
            let bits: i32x4 = wide::bytemuck::cast(bits);
            (bits.round_float() * f32x4::splat(1.0 / 65536.0) - f32x4::splat(0.5)) * scale
        };
        (
            fraction(hash >> 16u32),
            fraction(hash & u32x4::splat(0xffff)),
        )
    }
}

/// A slot's jitter seed, from the mixed seed.
#[inline]
pub fn slot_jitter_seed(mixed: u64, slot: u32) -> u32 {
    splitmix(mixed ^ slot as u64) as u32
}

/// Chris Wellons's "lowbias32" integer hash, lane by lane.
#[inline]
fn hash32(mut x: u32x4) -> u32x4 {
    x ^= x >> 16u32;
    x *= u32x4::splat(0x7feb_352d);
    x ^= x >> 15u32;
    x *= u32x4::splat(0x846c_a68b);
    x ^ (x >> 16u32)
}

/// The seed as [`RaySpace::jitter_mixed`] takes it.
#[inline]
pub fn jitter_seed(seed: u64) -> u64 {
    splitmix(seed ^ 0x6a09_e667_f3bc_c909)
}

#[inline]
fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e3779b97f4a7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn space() -> RaySpace {
        RaySpace::new(5, 0.25, (Vec3::ZERO, Vec3::ONE))
    }

    /// The jitters are uniform over [−½, ½)·amount·h on each axis, the two axes and
    /// neighbouring lines uncorrelated, and the SIMD lanes give each line the jitter the
    /// one-line form gives it.
    #[test]
    fn line_jitters_are_uniform_and_lane_independent() {
        let space = RaySpace::new(6, 1.0 / 64.0, (Vec3::ZERO, Vec3::ONE));
        let (amount, half) = (0.75f32, 0.5 * 0.75 / 64.0);
        let mixed = jitter_seed(3);
        let n = space.intercepts;
        let (mut m, mut uu, mut vv, mut uv, mut next) = ([0.0f64; 2], 0.0, 0.0, 0.0, 0.0);
        let mut count = 0.0;
        for slot in [0, 7, space.slots() as u32 - 1] {
            let seed = slot_jitter_seed(mixed, slot);
            for iu in 0..n {
                for iv in (0..n).step_by(4) {
                    let lines = u32x4::from(std::array::from_fn(|l| iu * n + iv + l as u32));
                    let (du, dv) = space.jitter_lanes(seed, amount, lines);
                    let (du, dv) = (du.to_array(), dv.to_array());
                    for l in 0..4 {
                        let one = space.jitter_mixed(mixed, amount, slot, iu, iv + l as u32);
                        assert_eq!(
                            one,
                            (du[l], dv[l]),
                            "slot {slot} line ({iu}, {})",
                            iv + l as u32
                        );
                        assert!((-half..half).contains(&du[l]) && (-half..half).contains(&dv[l]));
                    }
                    let half = half as f64;
                    let (x, y) = (du[0] as f64 / half, dv[0] as f64 / half);
                    m[0] += x;
                    m[1] += y;
                    uu += x * x;
                    vv += y * y;
                    uv += x * y;
                    next += x * du[1] as f64 / half;
                    count += 1.0;
                }
            }
        }
        // Uniform on [−1, 1): mean 0, second moment 1/3. Over 27,648 lines the standard
        // deviation of each estimate is at most 0.0035: 0.02 is about six of them.
        for (what, value, expected) in [
            ("mean u", m[0] / count, 0.0),
            ("mean v", m[1] / count, 0.0),
            ("E[u²]", uu / count, 1.0 / 3.0),
            ("E[v²]", vv / count, 1.0 / 3.0),
            ("E[uv]", uv / count, 0.0),
            ("E[u u_next]", next / count, 0.0),
        ] {
            assert!(
                (value - expected).abs() < 0.02,
                "{what} = {value}, expected {expected}"
            );
        }
        assert_eq!(space.jitter_mixed(mixed, 0.0, 1, 2, 3), (0.0, 0.0));
    }

    #[test]
    fn line_indexing_is_a_bijection() {
        let rs = space();
        let mut seen = vec![false; rs.line_count() as usize];
        for f in 0..3 {
            for su in 0..rs.slopes {
                for sv in 0..rs.slopes {
                    for iu in 0..rs.intercepts {
                        for iv in 0..rs.intercepts {
                            let l = Line {
                                family: f,
                                su,
                                sv,
                                iu,
                                iv,
                            };
                            let i = rs.line_index(l);
                            assert!(i < rs.line_count());
                            assert!(!seen[i as usize], "{l:?} collides");
                            seen[i as usize] = true;
                            assert_eq!(rs.line(i), l);
                        }
                    }
                }
            }
        }
        assert!(seen.iter().all(|&s| s));
    }

    #[test]
    fn nearest_slot_inverts_direction() {
        let rs = RaySpace::new(7, 0.1, (Vec3::ZERO, Vec3::ONE));
        for slot in 0..rs.slots() as u32 {
            assert_eq!(rs.nearest_slot(rs.direction(slot)), slot);
            assert_eq!(rs.nearest_slot(-rs.direction(slot)), slot);
        }
    }

    /// The projected area of a patch along a slot's lines, in intercept cells, times the
    /// slot's weight, summed over every slot: ∫ A|n·d| dω over each unoriented direction once,
    /// which is πA for any orientation n (the hemisphere's projected solid angle).
    #[test]
    fn slot_weights_integrate_to_pi_times_area() {
        let rs = RaySpace::new(48, 0.5, (Vec3::ZERO, Vec3::ONE));
        for n in [
            Vec3::X,
            Vec3::Z,
            Vec3::new(1.0, 2.0, 3.0).normalize(),
            Vec3::new(-0.3, 0.9, 0.1).normalize(),
        ] {
            let sum: f64 = (0..rs.slots() as u32)
                .map(|s| {
                    let d = rs.direction(s);
                    // Area of the unit patch projected along d onto p_a = 0: |n·d̂|·r.
                    let proj = n.dot(d).abs() as f64;
                    rs.etendue(s) as f64 * proj / (rs.step as f64).powi(2)
                })
                .sum();
            let exact = std::f64::consts::PI;
            assert!((sum - exact).abs() / exact < 1e-3, "{n}: {sum} vs {exact}");
        }
    }
}
