//! The light passes of a path-traced image, as Blender Cycles' compositor reads them: per
//! camera sample, the light that reached the camera split by the kind of lobe the first
//! surface scattered it with (diffuse, glossy, transmission), into direct light (from the
//! lights by next-event estimation at the first surface, or reached by the direction it
//! scattered to) and indirect light (everything after), with each kind's colour at the first
//! surface; the emission and background the camera sees directly; and optionally the light
//! of each emitter alone (light groups). A technique fills one [`PassSample`] per camera
//! sample; the render loop averages them as it averages the image.

use crate::math::Rgb;

/// The lobe passes, in the order of a sample's values and of the EXR layers: per
/// kind of lobe its direct light, indirect light and colour, then the directly seen emission
/// and background. Their names are Cycles' pass names.
pub const LOBE_PASSES: [&str; 11] = [
    "DiffDir", "DiffInd", "DiffCol", "GlossDir", "GlossInd", "GlossCol", "TransDir", "TransInd",
    "TransCol", "Emit", "Env",
];

/// Where the direct light of lobe kind `kind` (`crate::bsdf::passes::DIFFUSE`, ...) is in a
/// [`PassSample`]; its indirect light follows, then its colour.
pub const fn direct_slot(kind: usize) -> usize {
    3 * kind
}

/// The slot of the emission the camera sees directly.
pub const EMIT: usize = 9;
/// The slot of the background the camera sees directly.
pub const ENV: usize = 10;

/// The values of one camera sample: the lobe passes ([`LOBE_PASSES`]: light with its
/// colour, and colours), then one per light group. Light values are what the sample's
/// image value is made of: they sum to it.
#[derive(Clone, Debug, PartialEq)]
pub struct PassSample {
    pub values: Vec<Rgb>,
    /// Light groups: one a light of the scene (in the light set's order), and a last one for
    /// emitting surfaces that are not lights of their own (instances); none if not asked for.
    pub groups: usize,
}

impl PassSample {
    /// Zeroed values for the lobe passes and `groups` light groups.
    pub fn new(groups: usize) -> PassSample {
        PassSample {
            values: vec![Rgb::ZERO; LOBE_PASSES.len() + groups],
            groups,
        }
    }

    /// Zeroes every value for the next sample.
    pub fn clear(&mut self) {
        self.values.fill(Rgb::ZERO);
    }

    /// Adds `c` to group `group` (the last one when `None`), if groups are kept.
    #[inline]
    pub fn add_to_group(&mut self, group: Option<usize>, c: Rgb) {
        if self.groups > 0 {
            let g = group.map_or(self.groups - 1, |g| g.min(self.groups - 1));
            self.values[LOBE_PASSES.len() + g] += c;
        }
    }

    /// Whether slot `i` holds light (not a colour): it scales with the sample.
    pub fn is_light(i: usize) -> bool {
        i >= LOBE_PASSES.len() || !matches!(i, 2 | 5 | 8)
    }
}
