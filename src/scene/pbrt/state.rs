//! pbrt's graphics state (CTM, material, area light, orientation) and the attribute stack that
//! saves and restores it.

use super::builder::Builder;
use super::Loc;
use crate::math::Rgb;
use crate::spectrum::{BlackbodyEmission, ColorSpace};
use glam::{DMat4, DVec3};

/// An area light attached to the shapes that follow (`AreaLightSource`).
#[derive(Clone, Copy, Debug)]
pub(super) struct AreaEmission {
    pub(super) radiance: Rgb,
    pub(super) two_sided: bool,
    /// A `blackbody` emitter's spectrum (spectral renders).
    pub(super) spectrum: Option<BlackbodyEmission>,
}

#[derive(Clone, Debug)]
pub(super) struct GraphicsState {
    pub(super) ctm: DMat4,
    pub(super) reverse_orientation: bool,
    /// Index into `Builder::materials`; `None` is pbrt's default (diffuse, reflectance 0.5).
    pub(super) material: Option<usize>,
    pub(super) area: Option<AreaEmission>,
    /// `ActiveTransform EndTime`: transform statements only change the end transform.
    pub(super) end_time_only: bool,
    /// The transform at `TransformTimes`' end time (`ctm` holds at its start time).
    pub(super) end_ctm: DMat4,
    /// `ActiveTransform StartTime`: transform statements only change the start transform.
    pub(super) start_time_only: bool,
    /// `MediumInterface`: the inside and outside media's names ("" is vacuum).
    pub(super) media: (String, String),
    /// `ColorSpace`: the space of the RGB values that follow.
    pub(super) color_space: &'static ColorSpace,
}

impl Default for GraphicsState {
    fn default() -> Self {
        GraphicsState {
            ctm: DMat4::IDENTITY,
            reverse_orientation: false,
            material: None,
            area: None,
            end_time_only: false,
            end_ctm: DMat4::IDENTITY,
            start_time_only: false,
            media: (String::new(), String::new()),
            color_space: ColorSpace::srgb(),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Block {
    Attribute,
    Transform,
    Object,
}

impl Block {
    pub(super) fn begin(self) -> &'static str {
        match self {
            Block::Attribute => "AttributeBegin",
            Block::Transform => "TransformBegin",
            Block::Object => "ObjectBegin",
        }
    }
}

impl Builder {
    /// Applies statement `kw`'s change to the current transform; one that overflows (no
    /// longer finite numbers, e.g. `Scale 1e200 ...` twice) is refused at its line.
    pub(super) fn set_ctm(
        &mut self,
        loc: &Loc,
        kw: &str,
        f: impl Fn(DMat4) -> DMat4,
    ) -> crate::error::Result<()> {
        let ctm = match self.state.end_time_only {
            true => self.state.ctm,
            false => f(self.state.ctm),
        };
        let end_ctm = match self.state.start_time_only {
            true => self.state.end_ctm,
            false => f(self.state.end_ctm),
        };
        if !ctm.is_finite() || !end_ctm.is_finite() {
            return Err(loc.error(format!(
                "{kw}: the transform overflows (its matrix is no longer finite)"
            )));
        }
        self.state.ctm = ctm;
        self.state.end_ctm = end_ctm;
        Ok(())
    }

    pub(super) fn push(&mut self, block: Block, loc: &Loc) {
        self.stack.push((block, self.state.clone(), loc.clone()));
    }

    pub(super) fn pop(&mut self, block: Block, loc: &Loc) -> crate::error::Result<()> {
        let end = match block {
            Block::Attribute => "AttributeEnd",
            Block::Transform => "TransformEnd",
            Block::Object => "ObjectEnd",
        };
        match self.stack.pop() {
            None => Err(loc.error(format!("{end} without a matching {}", block.begin()))),
            Some((open, _, open_loc)) if open != block => Err(loc.error(format!(
                "{end} does not match the {} at line {}",
                open.begin(),
                open_loc.line
            ))),
            Some((_, saved_state, _)) => {
                if block == Block::Transform {
                    self.state.ctm = saved_state.ctm;
                    self.state.end_ctm = saved_state.end_ctm;
                } else {
                    self.state = saved_state;
                }
                Ok(())
            }
        }
    }
}

/// pbrt's `LookAt`: the world-to-camera transform of an eye at `eye` looking at `target`.
pub(crate) fn look_at(eye: DVec3, target: DVec3, up: DVec3) -> Result<DMat4, String> {
    let forward = target - eye;
    let distance = forward.length();
    if !distance.is_finite() {
        return Err(
            "the eye and the target are too far apart: the distance between them overflows".into(),
        );
    }
    if distance == 0.0 {
        return Err("the eye and the target are the same point".into());
    }
    let dir = forward / distance;
    let up_length = up.length();
    if !up_length.is_finite() {
        return Err("the up vector's length overflows".into());
    }
    let right = up.normalize_or_zero().cross(dir);
    if right.length() < 1e-9 {
        return Err("the up vector is parallel to the viewing direction".into());
    }
    let right = right.normalize();
    let new_up = dir.cross(right);
    let camera_to_world = DMat4::from_cols(
        right.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        eye.extend(1.0),
    );
    Ok(camera_to_world.inverse())
}
