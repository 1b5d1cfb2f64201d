//! What the network's geometry depends on, and the defaults of the command line.

pub const DEFAULT_SLOPES: u32 = 12;
pub const DEFAULT_STEP: f32 = 1.0 / 64.0;
pub const DEFAULT_TOLERANCE: f32 = 1e-3;

/// What the network's geometry depends on (the file header stores these).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NetworkParams {
    /// Slopes per axis (S): 3·S² slots per node.
    pub slopes: u32,
    /// Intercept step h, unit-cube units.
    pub step: f32,
    /// Patch edge, unit-cube units.
    pub patch_size: f32,
    /// Intercept jitter, a fraction of h (0: the regular grid; 1: anywhere in the cell).
    pub jitter: f32,
    pub seed: u64,
}

impl Default for NetworkParams {
    fn default() -> Self {
        NetworkParams {
            slopes: DEFAULT_SLOPES,
            step: DEFAULT_STEP,
            patch_size: DEFAULT_STEP,
            jitter: 1.0,
            seed: 0,
        }
    }
}

impl NetworkParams {
    pub fn validate(&self) -> crate::error::Result<()> {
        let bad = |name: &str, detail: String| Err(crate::error::Error::setting(name, detail));
        if !(1..=128).contains(&self.slopes) {
            return bad(
                "slopes",
                format!("must be between 1 and 128, got {}", self.slopes),
            );
        }
        if !(self.step.is_finite() && self.step >= 1.0 / 4096.0 && self.step <= 1.0) {
            return bad(
                "intercept_step",
                format!("must be between 1/4096 and 1, got {}", self.step),
            );
        }
        if !(self.patch_size.is_finite()
            && self.patch_size >= 1.0 / 4096.0
            && self.patch_size <= 1.0)
        {
            return bad(
                "patch_size",
                format!("must be between 1/4096 and 1, got {}", self.patch_size),
            );
        }
        if !(0.0..=1.0).contains(&self.jitter) {
            return bad(
                "network_jitter",
                format!("must be in [0, 1], got {}", self.jitter),
            );
        }
        Ok(())
    }
}
