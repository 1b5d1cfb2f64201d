//! What the parser calls: one method per statement, with its arguments and parameter list
//! read and checked for syntax, and where it is. What a statement means (the graphics
//! state, the scene) is up to the target; the builder is the one that makes a [`Scene`].
//!
//! [`Scene`]: crate::scene::Scene

use super::params::Params;
use super::Loc;
use std::path::Path;

/// `ActiveTransform`'s argument: which of the start and end transforms the transform
/// statements that follow change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ActiveTransform {
    All,
    StartTime,
    EndTime,
}

/// The statements of a pbrt-v4 file, in the order the parser reads them (included files in
/// place). An error stops the reading and is the reading's error.
pub(super) trait Target {
    // The current transform.
    fn identity(&mut self, loc: &Loc) -> crate::error::Result<()>;
    fn translate(&mut self, v: [f64; 3], loc: &Loc) -> crate::error::Result<()>;
    fn scale(&mut self, v: [f64; 3], loc: &Loc) -> crate::error::Result<()>;
    /// `angle` in degrees about `axis` (as written: it may be zero).
    fn rotate(&mut self, angle: f64, axis: [f64; 3], loc: &Loc) -> crate::error::Result<()>;
    fn look_at(
        &mut self,
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
        loc: &Loc,
    ) -> crate::error::Result<()>;
    /// A matrix as pbrt lists it, column by column (as written: it may be singular).
    fn transform(&mut self, m: [f64; 16], loc: &Loc) -> crate::error::Result<()>;
    fn concat_transform(&mut self, m: [f64; 16], loc: &Loc) -> crate::error::Result<()>;
    fn coordinate_system(&mut self, name: String, loc: &Loc) -> crate::error::Result<()>;
    fn coord_sys_transform(&mut self, name: String, loc: &Loc) -> crate::error::Result<()>;
    fn active_transform(&mut self, which: ActiveTransform, loc: &Loc) -> crate::error::Result<()>;
    fn transform_times(&mut self, start: f64, end: f64, loc: &Loc) -> crate::error::Result<()>;
    fn reverse_orientation(&mut self, loc: &Loc) -> crate::error::Result<()>;

    // Blocks.
    fn attribute_begin(&mut self, loc: &Loc) -> crate::error::Result<()>;
    fn attribute_end(&mut self, loc: &Loc) -> crate::error::Result<()>;
    fn transform_begin(&mut self, loc: &Loc) -> crate::error::Result<()>;
    fn transform_end(&mut self, loc: &Loc) -> crate::error::Result<()>;
    fn object_begin(&mut self, name: String, loc: &Loc) -> crate::error::Result<()>;
    fn object_end(&mut self, loc: &Loc) -> crate::error::Result<()>;
    fn object_instance(&mut self, name: String, loc: &Loc) -> crate::error::Result<()>;

    // Rendering options.
    fn camera(&mut self, ty: String, params: Params, loc: &Loc) -> crate::error::Result<()>;
    fn film(&mut self, ty: String, params: Params, loc: &Loc) -> crate::error::Result<()>;
    fn sampler(&mut self, ty: String, params: Params, loc: &Loc) -> crate::error::Result<()>;
    fn pixel_filter(&mut self, ty: String, params: Params, loc: &Loc) -> crate::error::Result<()>;
    fn integrator(&mut self, ty: String, params: Params, loc: &Loc) -> crate::error::Result<()>;
    fn accelerator(&mut self, ty: String, params: Params, loc: &Loc) -> crate::error::Result<()>;
    fn color_space(&mut self, name: String, params: Params, loc: &Loc) -> crate::error::Result<()>;
    /// `Option "name" value`: the value token as written (`None` when it is missing or is
    /// not a bare word or number).
    fn option(
        &mut self,
        name: String,
        value: Option<String>,
        params: Params,
        loc: &Loc,
    ) -> crate::error::Result<()>;
    fn world_begin(&mut self, loc: &Loc) -> crate::error::Result<()>;
    fn world_end(&mut self, loc: &Loc) -> crate::error::Result<()>;

    // The world.
    fn attribute(&mut self, target: String, params: Params, loc: &Loc) -> crate::error::Result<()>;
    fn make_named_medium(
        &mut self,
        name: String,
        params: Params,
        loc: &Loc,
    ) -> crate::error::Result<()>;
    /// `outside` is `None` when the statement names one medium.
    fn medium_interface(
        &mut self,
        inside: String,
        outside: Option<String>,
        loc: &Loc,
    ) -> crate::error::Result<()>;
    fn material(&mut self, ty: String, params: Params, loc: &Loc) -> crate::error::Result<()>;
    fn make_named_material(
        &mut self,
        name: String,
        params: Params,
        loc: &Loc,
    ) -> crate::error::Result<()>;
    fn named_material(&mut self, name: String, loc: &Loc) -> crate::error::Result<()>;
    fn texture(
        &mut self,
        name: String,
        ty: String,
        class: String,
        params: Params,
        loc: &Loc,
    ) -> crate::error::Result<()>;
    fn shape(&mut self, ty: String, params: Params, loc: &Loc) -> crate::error::Result<()>;
    fn light_source(&mut self, ty: String, params: Params, loc: &Loc) -> crate::error::Result<()>;
    fn area_light_source(
        &mut self,
        ty: String,
        params: Params,
        loc: &Loc,
    ) -> crate::error::Result<()>;

    // Files.
    /// An `Include` or `Import` of `path` (relative paths already resolved), called before
    /// the parser reads the file in place.
    fn include(&mut self, path: &Path, loc: &Loc);
    /// The end of the scene file and of everything it includes.
    fn end_of_files(&mut self) -> crate::error::Result<()>;
}
