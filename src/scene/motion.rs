//! Motion blur at the scene level: whether a scene moves during the exposure, and the still
//! scene at shutter open for techniques that cannot follow time.

use super::Scene;
use std::borrow::Cow;

impl Scene {
    /// Whether some shape moves during the exposure.
    pub fn moves(&self) -> bool {
        self.shapes.iter().any(|s| s.moves())
    }

    /// The scene as it is at shutter open: every shape still. Borrowed when nothing moves.
    pub fn at_shutter_open(&self) -> Cow<'_, Scene> {
        if !self.shapes.iter().any(|s| s.motion.is_some()) {
            return Cow::Borrowed(self);
        }
        Cow::Owned(self.clone().into_shutter_open())
    }

    /// [`at_shutter_open`](Self::at_shutter_open), taking the scene.
    pub(crate) fn into_shutter_open(mut self) -> Scene {
        for shape in &mut self.shapes {
            shape.motion = None;
        }
        self
    }
}

/// The warning for a technique that renders a moving scene at shutter open.
pub(crate) fn still_warning(technique: &str) -> String {
    format!(
        "the {technique} does not follow shutter time: moving shapes are rendered \
         as they are at shutter open (no motion blur)"
    )
}
